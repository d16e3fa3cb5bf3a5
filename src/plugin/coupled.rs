//! The coupled fluid–solid solver in the Bevy schedule: every entity with a
//! [`CoupledSimulation`] advances by the frame's steps of [`crate::coupling::CoupledSolver::stages`] (method 1 or 2)
//! on the CPU, in [`super::PhonationSystems::CoupledStep`]. An instability marks the entity
//! [`CoupledStatus::Unstable`] (with the diagnosis) and stops it; its state is kept. With
//! [`super::GpuStepping`] (and [`super::PhonationGpuPlugin`], a render device) the render world
//! steps it on the GPU instead ([`super::gpu_coupled`]).
//!
//! A glottis scene's entity may also carry a [`CoupledGlottis`]: the glottis is then sampled
//! after every coupled step and the entity gets [`VoiceDiagnostics`] (current flow and area, and
//! f0, OQ, … of the kept window) as the two-mass model does.

use super::{PhonationSystems, StepsThisFrame, VoiceDiagnostics};
use crate::analysis::voice::{VoiceOptions, voice_measures};
use crate::coupling::CoupledSolver;
use crate::coupling::glottis::Glottis;
use bevy::prelude::*;
use std::collections::VecDeque;

/// A coupled air + bodies simulation owned by an entity.
#[derive(Component)]
pub struct CoupledSimulation {
    pub solver: CoupledSolver,
}

/// The glottis of a [`CoupledSimulation`] (two folds) and its recent glottal flow.
#[derive(Component, Debug, Clone)]
pub struct CoupledGlottis {
    pub glottis: Glottis,
    /// Seconds of flow kept for the live measures.
    pub history_s: f64,
    /// Glottal flow (cm³/s), one sample per coupled step, over the last `history_s`.
    pub flow: VecDeque<f64>,
    /// Glottal area (cm²) after the last step.
    pub area: f64,
}

impl CoupledGlottis {
    /// The glottis of `scene` as built into `solver`, keeping `history_s` seconds of flow;
    /// `None` when the scene has no pair of folds.
    pub fn of(scene: &crate::scene::coupled::CoupledScene, solver: &CoupledSolver, history_s: f64) -> Option<Self> {
        let glottis = scene.glottis(solver)?;
        let area = glottis.sample(solver).area;
        Some(Self { glottis, history_s, flow: VecDeque::new(), area })
    }
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

/// What [`step_coupled`] reads and writes of a coupled simulation's entity.
type CoupledStepData<'a> = (Entity, &'a mut CoupledSimulation, Option<&'a mut CoupledGlottis>, Option<&'a CoupledStatus>);

pub(super) fn step_coupled(steps: Res<StepsThisFrame>, mut sims: Query<CoupledStepData, super::gpu_coupled::CpuStepped>, mut commands: Commands) {
    if steps.0 == 0 {
        return;
    }
    for (entity, mut sim, mut glottis, status) in &mut sims {
        if matches!(status, Some(CoupledStatus::Unstable(_))) {
            continue;
        }
        let solver = &mut sim.solver;
        let mut result = Ok(());
        for _ in 0..steps.0 {
            result = solver.step();
            if result.is_err() {
                break;
            }
            if let Some(g) = glottis.as_deref_mut() {
                let s = g.glottis.sample(solver);
                g.area = s.area;
                g.flow.push_back(s.flow);
                let keep = (g.history_s / solver.dt()).ceil() as usize;
                while g.flow.len() > keep {
                    g.flow.pop_front();
                }
            }
        }
        if let Err(e) = result {
            let why = e.to_string();
            warn!("phonation: coupled simulation on {entity} stopped: {why}");
            commands.entity(entity).insert(CoupledStatus::Unstable(why));
        }
    }
}

/// The voice measures of the kept flow and the figures of [`CoupledDiagnostics`]; the air's
/// momentum of a GPU-stepped entity from the totals summed on the device.
pub(super) fn coupled_diagnostics(
    mut sims: Query<(Entity, &CoupledSimulation, Option<&mut CoupledGlottis>, Option<&super::GpuCoupledReadback>)>,
    mut commands: Commands,
) {
    for (entity, sim, glottis, gpu) in &mut sims {
        if let Some(mut g) = glottis {
            let dt = sim.solver.dt();
            let opts = VoiceOptions { window_fraction: 1.0, ..VoiceOptions::default() };
            let flow = g.flow.back().copied().unwrap_or(0.0);
            let (measures, no_voice) = match voice_measures(g.flow.make_contiguous(), dt, &opts) {
                Ok(m) => (Some(m), None),
                Err(e) => (None, Some(e.to_string())),
            };
            commands.entity(entity).insert(VoiceDiagnostics { steps: sim.solver.step_count, time: sim.solver.time, flow, area: g.area, measures, no_voice });
        }
        let s = &sim.solver;
        let (fluid, solid) = match gpu {
            Some(r) => (r.totals.map(|t| s.fluid_momentum(&t)).unwrap_or_default(), s.solid.particles.linear_momentum()),
            None => s.momentum(),
        };
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
