//! Speed of sound: a standing isentropic acoustic mode in a periodic tube; its oscillation
//! period against c_s = √(γθ) (2.104) with γ = (D+2)/D (monatomic) or 1.4 (diatomic).

use crate::fluid::{Boundaries, Equilibrium, FluidSolver, GasModel, Grid, Macro, VelocitySet, VelocitySetKind, timestep};
use crate::gpu::GpuError;
use crate::run::{Backend, FluidEngine};
use crate::step::Solver;
use std::f64::consts::PI;

#[derive(Clone, Debug, serde::Serialize)]
pub struct SoundResult {
    pub gamma: f64,
    pub predicted: f64,
    pub measured: f64,
    pub relative_error: f64,
}

/// Runs the mode on an `n`-node periodic line (1 node across) for about three periods.
pub fn sound_speed(set: VelocitySetKind, gas: GasModel, n: usize) -> SoundResult {
    sound_speed_on(set, gas, n, Backend::Cpu).expect("the CPU backend always exists")
}

/// The same measurement on a chosen backend.
pub fn sound_speed_on(set: VelocitySetKind, gas: GasModel, n: usize, backend: Backend) -> Result<SoundResult, GpuError> {
    let vs = VelocitySet::new(set);
    let dim = vs.dim;
    let l1 = vs.max_l1_speed();
    let eq = Equilibrium::new(vs, gas);
    let gamma = eq.gamma();
    let theta0 = 0.6;
    let nu = 0.01;
    let params = timestep::choose(nu, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
    let k = 2.0 * PI / n as f64;
    // Small enough to stay linear over three periods, large enough for f32 on the GPU (the mode
    // amplitude must stand well above f32 round-off of ρ ≈ 1).
    let eps = 1e-3;
    let init = move |x: [f64; 3]| {
        let c = (k * x[0]).cos();
        Macro { rho: 1.0 + eps * c, u: [0.0; 3], theta: theta0 * (1.0 + (gamma - 1.0) * eps * c) }
    };
    let grid = Grid::new(dim, [n, 1, 1]);
    let s = FluidSolver::new(eq, grid, Boundaries::periodic(), &[], params, init);
    let predicted = (gamma * theta0).sqrt();
    let omega = predicted * k;
    let t_end = 3.2 * 2.0 * PI / omega;
    let mode = |s: &FluidSolver| -> f64 { (0..n).map(|x| (s.macro_at_coords([x as i64, 0, 0]).rho - 1.0) * (k * x as f64).cos()).sum::<f64>() };
    let mut engine = FluidEngine::new(backend, s)?;
    let s = engine.state().expect("the initial state is on the CPU");
    let mut prev = (s.time, mode(s));
    let mut crossings = Vec::new();
    while prev.0 < t_end {
        engine.advance(1).expect("acoustic mode stays stable");
        let s = engine.state().expect("the state comes back");
        let cur = (s.time, mode(s));
        if prev.1.signum() != cur.1.signum() {
            crossings.push(prev.0 + (cur.0 - prev.0) * prev.1 / (prev.1 - cur.1));
        }
        prev = cur;
    }
    // Successive zero crossings are half a period apart.
    let half = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    let measured = PI / half / k;
    Ok(SoundResult { gamma, predicted, measured, relative_error: (measured - predicted) / predicted })
}
