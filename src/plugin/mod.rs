//! Bevy integration (feature `bevy`): the [`PhonationPlugin`] steps every entity that carries a
//! [`FluidSimulation`], a [`SolidSimulation`], a [`LatticeGasSimulation`], a [`CoupledSimulation`] or a [`TwoMassSimulation`] (with live [`VoiceDiagnostics`]) on the CPU backend, `steps_per_frame` steps per frame, honouring
//! pause / single-step from [`SimulationControl`]. The systems live in [`PhonationSystems`] sets
//! named after the solver's stages, so apps can order their own systems around them.
//!
//! A run that goes unstable stops stepping its entity and records the diagnosis in
//! [`FluidStatus`]; the state before the failing step is kept for inspection.
//!
//! Works with `MinimalPlugins` (headless apps and tests). With Bevy's renderer, add
//! [`PhonationGpuPlugin`] and put [`GpuStepping`] on an entity: a fluid ([`gpu`]), a solid
//! ([`gpu_solid`]) or a coupled simulation ([`gpu_coupled`]) is then stepped on the render
//! device in the render world, with the same components on the entity; the drawing (feature
//! `render`) is in `phonation::render`.

use crate::fluid::{FluidSolver, Instability, Totals};
use crate::scene::FluidScene;
use crate::units::Units;
use bevy::prelude::*;

pub mod coupled;
pub mod diagnostics;
pub mod gpu;
pub mod gpu_coupled;
pub mod gpu_solid;
pub mod lattice_gas;
pub mod solid;
pub mod two_mass;
pub use coupled::{CoupledDiagnostics, CoupledGlottis, CoupledSimulation, CoupledStatus};
pub use diagnostics::PhonationDiagnosticsPlugin;
pub use gpu::{GpuAir, GpuFluidHandle, GpuProbes, GpuStepping, PhonationGpuPlugin};
pub use gpu_coupled::{GpuCoupledHandle, GpuCoupledReadback, GpuLevelSets};
pub use gpu_solid::GpuSolidHandle;
pub use lattice_gas::{LatticeGasDiagnostics, LatticeGasSimulation};
pub use solid::{SolidDiagnostics, SolidSimulation, SolidStatus};
pub use two_mass::{TwoMassSimulation, VoiceDiagnostics};

/// System sets, in order, of one frame of the simulation.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub enum PhonationSystems {
    /// Advances every simulation by `steps_per_frame` steps of [`crate::stages::FDLB_STEP`].
    Step,
    /// Advances every [`SolidSimulation`] by the same number of steps of its solid stage list.
    SolidStep,
    /// Advances every [`LatticeGasSimulation`] by the same number of steps of
    /// [`crate::stages::LATTICE_GAS_STEP`].
    LatticeGasStep,
    /// Advances every [`CoupledSimulation`] by the same number of steps of its coupling's stage
    /// list ([`crate::stages::COUPLED_WEAK_STEP`] or [`crate::stages::COUPLED_CONSERVING_STEP`]).
    CoupledStep,
    /// Advances every [`TwoMassSimulation`] by the same number of steps and updates its
    /// [`VoiceDiagnostics`].
    TwoMassStep,
    /// Updates [`FluidDiagnostics`].
    Diagnostics,
}

/// Global pause / stepping controls (an egui panel or the app's input edits this).
#[derive(Resource, Debug, Clone)]
pub struct SimulationControl {
    pub paused: bool,
    /// Steps per frame while running.
    pub steps_per_frame: u32,
    /// While paused: run this many steps on the next frame, then stay paused.
    pub single_steps: u32,
}

impl Default for SimulationControl {
    fn default() -> Self {
        SimulationControl { paused: false, steps_per_frame: 1, single_steps: 0 }
    }
}

/// A fluid simulation owned by an entity (CPU backend).
#[derive(Component)]
pub struct FluidSimulation {
    pub solver: FluidSolver,
    /// Physical ↔ lattice units of the scene, when built from one.
    pub units: Option<Units>,
    /// Probe names and padded node indices (the scene's probes).
    pub probes: Vec<(String, usize)>,
}

impl FluidSimulation {
    pub fn new(solver: FluidSolver) -> Self {
        FluidSimulation { solver, units: None, probes: Vec::new() }
    }

    /// Allocates the solver of a validated scene. The plugin steps the populations in f64: a
    /// scene's `numerics.storage = "f32"` applies to the headless run (`phonation run`), whose
    /// engine keeps an f64 mirror for its outputs, not to this component.
    pub fn from_scene(scene: &FluidScene) -> Self {
        let solver = scene.build_solver();
        let probes = scene.probes.iter().map(|(n, x)| (n.clone(), solver.layout.grid.index(*x))).collect();
        FluidSimulation { solver, units: Some(scene.units), probes }
    }
}

/// Steps every simulation advances this frame, from [`SimulationControl`] (pause, single steps).
#[derive(Resource, Debug, Clone, Copy, Default)]
pub struct StepsThisFrame(pub u32);

/// Whether an entity's simulation is still running.
#[derive(Component, Debug, Clone, Default, PartialEq)]
pub enum FluidStatus {
    #[default]
    Running,
    Unstable(Instability),
}

/// Per-entity figures updated every frame.
#[derive(Component, Debug, Clone, Default)]
pub struct FluidDiagnostics {
    pub steps: u64,
    /// Lattice time units simulated.
    pub time: f64,
    pub initial_totals: Option<Totals>,
    pub totals: Option<Totals>,
    /// Relative mass drift since the first frame.
    pub mass_drift: f64,
}

pub struct PhonationPlugin;

impl Plugin for PhonationPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<SimulationControl>()
            .init_resource::<StepsThisFrame>()
            .configure_sets(
                Update,
                (
                    PhonationSystems::Step,
                    PhonationSystems::SolidStep,
                    PhonationSystems::LatticeGasStep,
                    PhonationSystems::CoupledStep,
                    PhonationSystems::TwoMassStep,
                    PhonationSystems::Diagnostics,
                )
                    .chain(),
            )
            .add_systems(Update, (plan_steps, step_simulations).chain().in_set(PhonationSystems::Step))
            .add_systems(Update, update_diagnostics.in_set(PhonationSystems::Diagnostics));
        solid::build(app);
        lattice_gas::build(app);
        coupled::build(app);
        two_mass::build(app);
    }
}

fn plan_steps(mut control: ResMut<SimulationControl>, mut steps: ResMut<StepsThisFrame>) {
    steps.0 = if control.paused { std::mem::take(&mut control.single_steps) } else { control.steps_per_frame };
}

fn step_simulations(
    steps: Res<StepsThisFrame>,
    mut sims: Query<(Entity, &mut FluidSimulation, Option<&mut FluidStatus>), Without<gpu::GpuFluidHandle>>,
    mut commands: Commands,
) {
    let steps = steps.0;
    if steps == 0 {
        return;
    }
    for (entity, mut sim, status) in &mut sims {
        if matches!(status.as_deref(), Some(FluidStatus::Unstable(_))) {
            continue;
        }
        if let Err(e) = sim.solver.run(steps as u64) {
            warn!("phonation: simulation on {entity} stopped: {e}");
            match status {
                Some(mut s) => *s = FluidStatus::Unstable(e),
                None => {
                    commands.entity(entity).insert(FluidStatus::Unstable(e));
                }
            }
        }
    }
}

fn update_diagnostics(mut sims: Query<(Entity, &FluidSimulation, Option<&mut FluidDiagnostics>), Without<gpu::GpuFluidHandle>>, mut commands: Commands) {
    for (entity, sim, diag) in &mut sims {
        let totals = sim.solver.totals();
        let mut d = diag.as_deref().cloned().unwrap_or_default();
        let initial = *d.initial_totals.get_or_insert(totals);
        d.steps = sim.solver.step_count;
        d.time = sim.solver.time;
        d.totals = Some(totals);
        d.mass_drift = (totals.mass - initial.mass) / initial.mass;
        match diag {
            Some(mut existing) => *existing = d,
            None => {
                commands.entity(entity).insert(d);
            }
        }
    }
}
