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

impl StageTimings {
    pub fn report(&self) -> Vec<(&'static str, f64)> {
        let all: f64 = self.total.iter().map(|d| d.as_secs_f64()).sum();
        FDLB_STEP.iter().zip(&self.total).map(|(s, d)| (s.name, if all > 0.0 { d.as_secs_f64() / all } else { 0.0 })).collect()
    }
}
