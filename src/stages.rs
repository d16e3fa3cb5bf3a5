//! The ordered list of stages of one solver step: the single source of truth that the CPU
//! backend executes, that the GPU backend records, that the Bevy plugin schedules, and that the
//! per-stage timings are keyed by.
//!
//! One FDLB step is Heun's two-stage Runge–Kutta method (seed §2.3) on (2.77); each Runge–Kutta
//! stage computes the moments (2.79–2.81) and equilibria (2.78) of its input together with the
//! local (collision and force) part of the update, fills the boundary nodes, then adds the
//! advection (3rd-order upwind of h = (1 − A/τ) f + (A/τ) f⁰).

use std::time::Duration;

/// Kind of work a stage does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StageKind {
    /// Macroscopic moments, equilibria, the advected field h and the local part of the
    /// Runge–Kutta update (BGK collision, body force) of every fluid node; instability check.
    MomentsCollide,
    /// Ghost, inlet/outlet and periodic halo nodes.
    Boundaries,
    /// Advection: subtracts Δt c·∇h (3rd-order upwind) from the stage's output.
    Advect,
}

/// Which Runge–Kutta stage a stage belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RkStage {
    /// f¹ = fⁿ + Δt L(fⁿ)
    First,
    /// fⁿ⁺¹ = ½ fⁿ + ½ (f¹ + Δt L(f¹))
    Second,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Stage {
    pub kind: StageKind,
    pub rk: RkStage,
    pub name: &'static str,
}

/// One FDLB step, in order.
pub const FDLB_STEP: [Stage; 6] = [
    Stage { kind: StageKind::MomentsCollide, rk: RkStage::First, name: "moments_collide/1" },
    Stage { kind: StageKind::Boundaries, rk: RkStage::First, name: "boundaries/1" },
    Stage { kind: StageKind::Advect, rk: RkStage::First, name: "advect/1" },
    Stage { kind: StageKind::MomentsCollide, rk: RkStage::Second, name: "moments_collide/2" },
    Stage { kind: StageKind::Boundaries, rk: RkStage::Second, name: "boundaries/2" },
    Stage { kind: StageKind::Advect, rk: RkStage::Second, name: "advect/2" },
];

/// Accumulated wall time per stage of [`FDLB_STEP`].
#[derive(Clone, Debug, Default)]
pub struct StageTimings {
    pub total: [Duration; FDLB_STEP.len()],
    pub steps: u64,
}

/// Each stage's share of the summed wall time (zeros before any time was measured).
pub fn time_shares<'a>(stages: impl IntoIterator<Item = (&'static str, &'a Duration)>) -> Vec<(&'static str, f64)> {
    let stages: Vec<(&'static str, f64)> = stages.into_iter().map(|(n, d)| (n, d.as_secs_f64())).collect();
    let all: f64 = stages.iter().map(|(_, t)| t).sum();
    stages.into_iter().map(|(n, t)| (n, if all > 0.0 { t / all } else { 0.0 })).collect()
}

impl StageTimings {
    pub fn report(&self) -> Vec<(&'static str, f64)> {
        time_shares(FDLB_STEP.iter().map(|s| s.name).zip(&self.total))
    }
}

/// Kind of work a stage of the MPS solid does (seed 000 §2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SolidStageKind {
    /// Explicit: rotation matrices from the quaternions. Implicit: rotations by Newton–Raphson
    /// (2.74) and angular velocities (2.73) from the current positions and velocities.
    Rotations,
    /// Deformation gradient, co-rotated strain, stress and the gradient-part torque per particle.
    StrainStress,
    /// Gradient-model, pair (Laplacian) and viscous forces and torques gathered per particle.
    BondForces,
    /// Search grid and distinct-element contact forces (2.22–2.37), loads and gravity.
    Contact,
    /// Implicit only: A ΔV = B (2.63–2.66) by preconditioned conjugate gradients.
    ConjugateGradient,
    /// Velocities, positions and (explicit) rotations: (2.44)–(2.45), (2.52)–(2.56) or (2.57).
    Integrate,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SolidStage {
    pub kind: SolidStageKind,
    pub name: &'static str,
}

/// One explicit step of the solid (seed §2.2.4), in order.
pub const SOLID_EXPLICIT_STEP: [SolidStage; 5] = [
    SolidStage { kind: SolidStageKind::Rotations, name: "rotations" },
    SolidStage { kind: SolidStageKind::StrainStress, name: "strain_stress" },
    SolidStage { kind: SolidStageKind::BondForces, name: "bond_forces" },
    SolidStage { kind: SolidStageKind::Contact, name: "contact" },
    SolidStage { kind: SolidStageKind::Integrate, name: "integrate" },
];

/// One implicit step of the solid (seed §2.2.5 and §3.1.3), in order.
pub const SOLID_IMPLICIT_STEP: [SolidStage; 6] = [
    SolidStage { kind: SolidStageKind::Rotations, name: "rotations" },
    SolidStage { kind: SolidStageKind::StrainStress, name: "strain_stress" },
    SolidStage { kind: SolidStageKind::BondForces, name: "bond_forces" },
    SolidStage { kind: SolidStageKind::Contact, name: "contact" },
    SolidStage { kind: SolidStageKind::ConjugateGradient, name: "conjugate_gradient" },
    SolidStage { kind: SolidStageKind::Integrate, name: "integrate" },
];

/// Kind of work a stage of the integer lattice gas does (seed 002 §3.3–3.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LatticeGasStageKind {
    /// Every fluid site's 24 bits replaced by a member of their (mass, 4-momentum) class; every
    /// obstacle site's particles reversed (bounce-back).
    Collide,
    /// The interference operation on the departing particles, with probability p per (cell, velocity).
    Interfere,
    /// Every particle moved by its velocity (bit shifts; periodic wrap).
    Propagate,
    /// Channel scenes: the outlet (zero-gradient copy or free stream) and +X injection at the inlet.
    Boundaries,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LatticeGasStage {
    pub kind: LatticeGasStageKind,
    pub name: &'static str,
}

/// One lattice-gas step, in order (the CPU backend runs it, the GPU backend records one kernel
/// per stage).
pub const LATTICE_GAS_STEP: [LatticeGasStage; 4] = [
    LatticeGasStage { kind: LatticeGasStageKind::Collide, name: "collide" },
    LatticeGasStage { kind: LatticeGasStageKind::Interfere, name: "interfere" },
    LatticeGasStage { kind: LatticeGasStageKind::Propagate, name: "propagate" },
    LatticeGasStage { kind: LatticeGasStageKind::Boundaries, name: "boundaries" },
];

/// Kind of work a stage of a coupled fluid–solid step does (seed 000 §2.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CoupledStageKind {
    /// Solid → fluid: the bodies' surfaces (positions, wall velocities) become the fluid's
    /// moving walls; the fluid geometry is rebuilt, uncovered nodes initialised.
    FluidGeometry,
    /// One fluid step ([`FDLB_STEP`]).
    Fluid,
    /// Fluid → solid: tractions on the surface pieces spread to the surface particles (2.110–2.113).
    SurfaceTraction,
    /// Fluid → solid (method 2): the momentum the air handed to the wall nodes, link by link,
    /// shared among the particles near each node with normalised kernel weights (2.127–2.128).
    MomentumExchange,
    /// Solid sub-steps over the fluid step ([`SOLID_EXPLICIT_STEP`]); prescribed bodies follow
    /// their motion.
    Solid,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CoupledStage {
    pub kind: CoupledStageKind,
    pub name: &'static str,
}

/// One step of the weak coupling (method 1, seed §2.4.1), in order.
pub const COUPLED_WEAK_STEP: [CoupledStage; 4] = [
    CoupledStage { kind: CoupledStageKind::FluidGeometry, name: "fluid_geometry" },
    CoupledStage { kind: CoupledStageKind::Fluid, name: "fluid" },
    CoupledStage { kind: CoupledStageKind::SurfaceTraction, name: "surface_traction" },
    CoupledStage { kind: CoupledStageKind::Solid, name: "solid" },
];

/// One step of the momentum-conserving coupling (method 2, seed §2.4.2), in order.
pub const COUPLED_CONSERVING_STEP: [CoupledStage; 4] = [
    CoupledStage { kind: CoupledStageKind::FluidGeometry, name: "fluid_geometry" },
    CoupledStage { kind: CoupledStageKind::Fluid, name: "fluid" },
    CoupledStage { kind: CoupledStageKind::MomentumExchange, name: "momentum_exchange" },
    CoupledStage { kind: CoupledStageKind::Solid, name: "solid" },
];
