//! The two-mass model in the Bevy schedule, with the voice measures live: every entity with a
//! [`TwoMassSimulation`] advances by the frame's steps (each `rk4_per_step` RK4 steps of `dt`)
//! in [`super::PhonationSystems::TwoMassStep`], keeps the last `history_s` seconds of its
//! glottal flow, and gets [`VoiceDiagnostics`] (f0, OQ, peak flow, … of that window, by
//! [`crate::analysis::voice`]) — what a panel plots next to a 2D/3D glottis.

use super::{PhonationSystems, StepsThisFrame};
use crate::analysis::voice::{VoiceMeasures, VoiceOptions, voice_measures};
use crate::two_mass::{TwoMass, TwoMassParams};
use bevy::prelude::*;
use std::collections::VecDeque;

/// A two-mass model owned by an entity.
#[derive(Component, Debug, Clone)]
pub struct TwoMassSimulation {
    pub model: TwoMass,
    /// RK4 step (s).
    pub dt: f64,
    /// RK4 steps per simulation step (one simulation step per `steps_per_frame` unit).
    pub rk4_per_step: u32,
    /// Seconds of flow kept for the live measures.
    pub history_s: f64,
    /// The glottal flow (cm³/s) over the last `history_s`, one sample per RK4 step.
    pub flow: VecDeque<f64>,
}

impl TwoMassSimulation {
    /// The standard model (Ishizaka & Flanagan) at a lung pressure (dyn/cm²), at 176.4 kHz,
    /// keeping 0.1 s of flow.
    pub fn new(params: TwoMassParams, lung_pressure: f64) -> Self {
        TwoMassSimulation { model: TwoMass::new(params, lung_pressure), dt: 1.0 / 176_400.0, rk4_per_step: 1, history_s: 0.1, flow: VecDeque::new() }
    }
}

/// Live figures of a [`TwoMassSimulation`], updated every frame it stepped.
#[derive(Component, Debug, Clone, Default)]
pub struct VoiceDiagnostics {
    pub steps: u64,
    /// Simulated time (s).
    pub time: f64,
    /// Current glottal flow (cm³/s) and area (cm²).
    pub flow: f64,
    pub area: f64,
    /// The measures of the kept window, or why there are none yet.
    pub measures: Option<VoiceMeasures>,
    pub no_voice: Option<String>,
}

pub(super) fn build(app: &mut App) {
    app.add_systems(Update, step_two_mass.in_set(PhonationSystems::TwoMassStep));
}

fn step_two_mass(steps: Res<StepsThisFrame>, mut sims: Query<(Entity, &mut TwoMassSimulation)>, mut commands: Commands) {
    if steps.0 == 0 {
        return;
    }
    for (entity, mut sim) in &mut sims {
        let sim = &mut *sim;
        let keep = (sim.history_s / sim.dt).ceil() as usize;
        for _ in 0..steps.0 * sim.rk4_per_step {
            sim.model.step(sim.dt);
            sim.flow.push_back(sim.model.flow());
            if sim.flow.len() > keep {
                sim.flow.pop_front();
            }
        }
        let opts = VoiceOptions { window_fraction: 1.0, ..VoiceOptions::default() };
        let (measures, no_voice) = match voice_measures(sim.flow.make_contiguous(), sim.dt, &opts) {
            Ok(m) => (Some(m), None),
            Err(e) => (None, Some(e.to_string())),
        };
        commands.entity(entity).insert(VoiceDiagnostics {
            steps: sim.model.steps,
            time: sim.model.time,
            flow: sim.model.flow(),
            area: sim.model.glottal_area(),
            measures,
            no_voice,
        });
    }
}
