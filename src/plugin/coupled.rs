//! The coupled fluid–solid solver in the Bevy schedule: every entity with a
//! [`CoupledSimulation`] advances by the frame's steps of [`crate::stages::COUPLED_WEAK_STEP`]
//! on the CPU, in [`super::PhonationSystems::CoupledStep`]. An instability marks the entity
//! [`CoupledStatus::Unstable`] (with the diagnosis) and stops it; its state is kept.

use super::{PhonationSystems, StepsThisFrame};
use crate::coupling::WeakCoupling;
use bevy::prelude::*;

/// A coupled air + bodies simulation owned by an entity.
#[derive(Component)]
pub struct CoupledSimulation {
    pub solver: WeakCoupling,
}

#[derive(Component, Debug, Clone, Default, PartialEq)]
pub enum CoupledStatus {
    #[default]
    Running,
    /// What went wrong, where and when.
    Unstable(String),
}

/// Per-entity figures updated every frame (scene units).
#[derive(Component, Debug, Clone, Default)]
pub struct CoupledDiagnostics {
    pub steps: u64,
    /// Physical time (s).
    pub time: f64,
    /// The air's force on each body (per unit depth in 2D).
    pub body_forces: Vec<Vec3>,
    pub fluid_momentum: Vec3,
    pub solid_momentum: Vec3,
    pub uncovered_nodes: usize,
    pub covered_nodes: usize,
}

pub(super) fn build(app: &mut App) {
    app.add_systems(Update, (step_coupled, coupled_diagnostics).chain().in_set(PhonationSystems::CoupledStep));
}

fn step_coupled(steps: Res<StepsThisFrame>, mut sims: Query<(Entity, &mut CoupledSimulation, Option<&CoupledStatus>)>, mut commands: Commands) {
    if steps.0 == 0 {
        return;
    }
    for (entity, mut sim, status) in &mut sims {
        if matches!(status, Some(CoupledStatus::Unstable(_))) {
            continue;
        }
        if let Err(e) = sim.solver.run(steps.0 as u64) {
            let why = e.to_string();
            warn!("phonation: coupled simulation on {entity} stopped: {why}");
            commands.entity(entity).insert(CoupledStatus::Unstable(why));
        }
    }
}

fn coupled_diagnostics(sims: Query<(Entity, &CoupledSimulation)>, mut commands: Commands) {
    for (entity, sim) in &sims {
        let s = &sim.solver;
        let (fluid, solid) = s.momentum();
        let d = CoupledDiagnostics {
            steps: s.step_count,
            time: s.time,
            body_forces: s.forces.total.iter().map(|f| f.as_vec3()).collect(),
            fluid_momentum: fluid.as_vec3(),
            solid_momentum: solid.as_vec3(),
            uncovered_nodes: s.geometry.uncovered,
            covered_nodes: s.geometry.covered,
        };
        commands.entity(entity).insert(d);
    }
}
