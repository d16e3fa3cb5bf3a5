//! The FCHC lattice gas in the Bevy schedule: every entity with a [`LatticeGasSimulation`]
//! advances by the frame's steps of [`crate::stages::LATTICE_GAS_STEP`] on the CPU, in
//! [`super::PhonationSystems::LatticeGasStep`], honouring pause and single steps. The gas is
//! integer and exact, so it cannot go unstable; [`LatticeGasDiagnostics`] reports what it
//! conserves (and, in periodic boxes, must keep) and the isotropy of its velocity populations.

use super::{PhonationSystems, StepsThisFrame};
use crate::lattice_gas::collision::CollisionTable;
use crate::lattice_gas::isotropy::{family_shares, smallest_share};
use crate::lattice_gas::lattice::{Invariants, LatticeGas};
use crate::scene::lattice_gas::{LatticeGasScene, region_velocity};
use bevy::prelude::*;

/// A lattice gas owned by an entity.
#[derive(Component)]
pub struct LatticeGasSimulation {
    pub gas: LatticeGas,
    /// Cells per edge of the blocks the drawing coarse-grains over (the scene's
    /// `output.coarse_block`).
    pub coarse_block: usize,
    /// The scene's probe (X, Y in ℓ), read over a square of half-width `coarse_block` cells.
    pub probe: Option<[f64; 2]>,
}

impl LatticeGasSimulation {
    /// Allocates and fills the gas of a validated scene.
    pub fn from_scene(scene: &LatticeGasScene) -> Self {
        Self { gas: scene.build(), coarse_block: scene.file.lattice_gas.output.coarse_block, probe: scene.probe }
    }

    /// The mean velocity (X, Y; ℓ/step) at the probe, as `probe.csv` of a run records it.
    pub fn probe_velocity(&self) -> Option<[f64; 2]> {
        self.probe.map(|p| region_velocity(&self.gas, p, 2.0 * self.coarse_block as f64))
    }
}

/// Per-entity figures updated every frame.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct LatticeGasDiagnostics {
    pub steps: u32,
    /// Particle count and total 4-momentum (integers; constant in a periodic box).
    pub invariants: Invariants,
    /// The smallest share of a velocity family (1 while the populations stay isotropic; see
    /// [`crate::lattice_gas::isotropy`]).
    pub smallest_family_share: f64,
    /// The velocity at the scene's probe (ℓ/step), if it has one.
    pub probe_velocity: Option<[f64; 2]>,
}

pub(super) fn build(app: &mut App) {
    app.add_systems(Update, (step_gases, gas_diagnostics).chain().in_set(PhonationSystems::LatticeGasStep));
}

fn step_gases(steps: Res<StepsThisFrame>, mut sims: Query<&mut LatticeGasSimulation>) {
    if steps.0 == 0 {
        return;
    }
    let table = CollisionTable::shared();
    for mut sim in &mut sims {
        for _ in 0..steps.0 {
            sim.gas.advance(table);
        }
    }
}

fn gas_diagnostics(sims: Query<(Entity, &LatticeGasSimulation)>, mut commands: Commands) {
    for (entity, sim) in &sims {
        let d = LatticeGasDiagnostics {
            steps: sim.gas.step,
            invariants: sim.gas.invariants(),
            smallest_family_share: smallest_share(&family_shares(&sim.gas)),
            probe_velocity: sim.probe_velocity(),
        };
        commands.entity(entity).insert(d);
    }
}
