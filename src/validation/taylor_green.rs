//! Taylor–Green vortex in a periodic box (analytic, ../shared/reference): the decay rate of the
//! velocity mode against the viscosity the model predicts, ν = θ₀(τ − A) (2.101).
//!
//! 2D: u = −U cos kx sin ky, v = U sin kx cos ky, amplitude ∝ exp(−2νk²t) (exact NS solution).
//! 3D: u = U sin kx cos ky cos kz, v = −U cos kx sin ky cos kz, w = 0, amplitude ∝
//! exp(−3νk²t) in the linear (low Reynolds number) regime.
//! Density uniform, temperature θ₀ uniform, plus the pressure field of the 2D vortex.

use super::FluidRun;
use crate::fluid::storage::Storage;
use crate::fluid::timestep;
use crate::fluid::{Boundaries, Equilibrium, FluidSolver, GasModel, Grid, Macro, StepParams, VelocitySet, VelocitySetKind};
use crate::gpu::GpuError;
use crate::run::{Backend, FluidEngine};
use std::f64::consts::PI;
use std::time::Instant;

#[derive(Clone, Debug)]
pub struct TaylorGreenCase {
    pub set: VelocitySetKind,
    pub n: usize,
    /// Velocity amplitude (c units).
    pub u0: f64,
    pub theta0: f64,
    /// Kinematic viscosity ν (cells²/time unit).
    pub nu: f64,
    /// Fixed Δt, or automatic.
    pub dt: Option<f64>,
    /// Fixed τ (A = τ − ν/θ₀), or automatic.
    pub tau: Option<f64>,
    /// Simulated time in units of the predicted decay time 1/(rate).
    pub decay_times: f64,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct TaylorGreenResult {
    pub n: usize,
    pub params: StepParams,
    pub steps: u64,
    pub predicted_rate: f64,
    pub measured_rate: f64,
    pub relative_error: f64,
    /// Wall time per simulated lattice time unit (s).
    pub wall_per_time_unit: f64,
    pub mass_drift: f64,
}

impl TaylorGreenCase {
    pub fn new(set: VelocitySetKind, n: usize) -> Self {
        TaylorGreenCase { set, n, u0: 0.02, theta0: 0.6, nu: 0.002 * n as f64, dt: None, tau: None, decay_times: 0.5 }
    }

    pub fn run(&self) -> TaylorGreenResult {
        self.run_on(Backend::Cpu).expect("the CPU backend always exists")
    }

    /// Runs on the given backend (the GPU results are read back into the CPU mirror).
    pub fn run_on(&self, backend: Backend) -> Result<TaylorGreenResult, GpuError> {
        let (s, params) = self.solver::<f64>();
        Ok(self.measure(FluidEngine::new(backend, s)?, params))
    }

    /// Runs on the CPU with the populations stored as `S` ([`Storage`]: f32 for the storage
    /// option's error).
    pub fn run_stored<S: Storage>(&self) -> TaylorGreenResult {
        let (s, params) = self.solver::<S>();
        self.measure(s, params)
    }

    /// The initial state: the vortex with its pressure field, and the step parameters.
    fn solver<S: Storage>(&self) -> (FluidSolver<S>, StepParams) {
        let vs = VelocitySet::new(self.set);
        let dim = vs.dim;
        let l1 = vs.max_l1_speed();
        let eq = Equilibrium::new(vs, GasModel::Monatomic);
        let mut params = timestep::choose(self.nu, self.theta0, l1, self.dt, timestep::DEFAULT_COURANT_SAFETY).expect("valid TG parameters");
        if let Some(tau) = self.tau {
            params.tau = tau;
            params.a = tau - self.nu / self.theta0;
        }
        let n = self.n;
        let grid = Grid::new(dim, [n, n, n]);
        let k = 2.0 * PI / n as f64;
        let (u0, th0) = (self.u0, self.theta0);
        let init = move |x: [f64; 3]| {
            let (kx, ky, kz) = (k * x[0], k * x[1], k * x[2]);
            if dim == 2 {
                let p = th0 - 0.25 * u0 * u0 * ((2.0 * kx).cos() + (2.0 * ky).cos());
                Macro { rho: p / th0, u: [-u0 * kx.cos() * ky.sin(), u0 * kx.sin() * ky.cos(), 0.0], theta: th0 }
            } else {
                Macro { rho: 1.0, u: [u0 * kx.sin() * ky.cos() * kz.cos(), -u0 * kx.cos() * ky.sin() * kz.cos(), 0.0], theta: th0 }
            }
        };
        (FluidSolver::with_storage(eq, grid, Boundaries::periodic(), &[], params, init), params)
    }

    /// Steps `run` and fits the decay rate of the vortex's amplitude.
    fn measure<S: Storage>(&self, mut run: impl FluidRun<S>, params: StepParams) -> TaylorGreenResult {
        let (n, dim) = (self.n, run.state().layout.grid.dim);
        let k = 2.0 * PI / n as f64;
        let predicted = if dim == 2 { 2.0 } else { 3.0 } * self.nu * k * k;
        let m0 = run.state().totals().mass;
        let amplitude = |s: &FluidSolver<S>| -> f64 {
            let mut num = 0.0;
            let mut den = 0.0;
            for (idx, m) in s.interior_macros().iter().enumerate() {
                let m = m.expect("no solids");
                let x = (idx % n) as f64;
                let y = ((idx / n) % n) as f64;
                let z = (idx / (n * n)) as f64;
                let shape = if dim == 2 { -(k * x).cos() * (k * y).sin() } else { (k * x).sin() * (k * y).cos() * (k * z).cos() };
                num += m.u[0] * shape;
                den += shape * shape;
            }
            num / den
        };
        let t_end = self.decay_times / predicted;
        let steps = (t_end / params.dt).ceil() as u64;
        // Fit ln A(t) by least squares over the second half of the run (after acoustic transients).
        let samples = 20u64;
        let every = (steps / samples).max(1);
        let mut ts = Vec::new();
        let mut ls = Vec::new();
        let t0 = Instant::now();
        let mut step = 0;
        while step < steps {
            let n = every.min(steps - step);
            run.advance(n).expect("Taylor–Green run stays stable");
            step += n;
            if step >= steps / 2 {
                let s = run.state();
                ts.push(s.time);
                ls.push(amplitude(s).ln());
            }
        }
        let wall = t0.elapsed().as_secs_f64();
        let s = run.state();
        let measured = -slope(&ts, &ls);
        let m1 = s.totals().mass;
        TaylorGreenResult {
            n,
            params,
            steps,
            predicted_rate: predicted,
            measured_rate: measured,
            relative_error: (measured - predicted) / predicted,
            wall_per_time_unit: wall / s.time,
            mass_drift: (m1 - m0) / m0,
        }
    }
}

pub use crate::analysis::fit::slope;
