//! The MPS solid in the Bevy schedule: every entity with a [`SolidSimulation`] advances by the
//! frame's steps of its solid stage list ([`crate::stages::SOLID_EXPLICIT_STEP`] or
//! [`crate::stages::SOLID_IMPLICIT_STEP`]) on the CPU, in [`super::PhonationSystems::SolidStep`].
//! A state that stops being finite marks the entity [`SolidStatus::Unstable`] and stops it.
//! With [`super::GpuStepping`] (and [`super::PhonationGpuPlugin`], a render device) the render
//! world steps it on the GPU instead ([`super::gpu_solid`]).

use super::{PhonationSystems, StepsThisFrame};
use crate::solid::{Energies, SolidSolver};
use bevy::prelude::*;

/// A solid owned by an entity.
#[derive(Component)]
pub struct SolidSimulation {
    pub solver: SolidSolver,
}

#[derive(Component, Debug, Clone, Default, PartialEq)]
pub enum SolidStatus {
    #[default]
    Running,
    /// What went wrong, where and when.
    Unstable(String),
}

/// Per-entity figures updated every frame.
#[derive(Component, Debug, Clone, Default)]
pub struct SolidDiagnostics {
    pub steps: u64,
    pub time: f64,
    pub energies: Energies,
    pub linear_momentum: Vec3,
    pub angular_momentum: Vec3,
    /// CG iterations of the last implicit step.
    pub cg_iterations: usize,
}

pub(super) fn build(app: &mut App) {
    app.add_systems(Update, (step_solids, solid_diagnostics).chain().in_set(PhonationSystems::SolidStep));
}

pub(super) fn step_solids(
    steps: Res<StepsThisFrame>,
    mut sims: Query<(Entity, &mut SolidSimulation, Option<&SolidStatus>), super::gpu_solid::CpuStepped>,
    mut commands: Commands,
) {
    if steps.0 == 0 {
        return;
    }
    for (entity, mut sim, status) in &mut sims {
        if matches!(status, Some(SolidStatus::Unstable(_))) {
            continue;
        }
        for _ in 0..steps.0 {
            if let Err(e) = sim.solver.step() {
                let why = e.to_string();
                warn!("phonation: solid on {entity} stopped: {why}");
                commands.entity(entity).insert(SolidStatus::Unstable(why));
                break;
            }
        }
    }
}

pub(super) fn solid_diagnostics(mut sims: Query<(Entity, &mut SolidSimulation)>, mut commands: Commands) {
    for (entity, mut sim) in &mut sims {
        let s = &mut sim.solver;
        let energies = s.energies();
        let p = &s.particles;
        let d = SolidDiagnostics {
            steps: s.step_count,
            time: s.time,
            energies,
            linear_momentum: p.linear_momentum().as_vec3(),
            angular_momentum: p.angular_momentum().as_vec3(),
            cg_iterations: s.last.cg.iterations,
        };
        commands.entity(entity).insert(d);
    }
}
