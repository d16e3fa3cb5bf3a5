//! Sod shock tube against the exact Riemann solution for the model's γ ([`super::riemann`]).
//! Left (ρ, p) = (1, 1)·s, right (0.125, 0.1)·s in lattice units, with s scaling the
//! temperature into the positivity window of the velocity set; zero-gradient ends.

use super::FluidRun;
use super::riemann::{Solution, State};
use crate::fluid::storage::Storage;
use crate::fluid::{Boundaries, Equilibrium, FaceCondition, FluidSolver, GasModel, Grid, Macro, StepParams, VelocitySet, VelocitySetKind, timestep};
use crate::gpu::GpuError;
use crate::run::{Backend, FluidEngine};

#[derive(Clone, Debug, serde::Serialize)]
pub struct SodResult {
    pub gamma: f64,
    /// (quantity, measured, exact, relative error) on the plateaus.
    pub plateaus: Vec<(String, f64, f64, f64)>,
    pub shock_position: (f64, f64),
    pub contact_position: (f64, f64),
    pub steps: u64,
}

pub struct SodCase {
    pub set: VelocitySetKind,
    pub gas: GasModel,
    pub n: usize,
    /// Temperature scale s: θ_L = s.
    pub scale: f64,
    pub nu: f64,
    /// Time at which to compare, in units of n / (left sound speed).
    pub time_fraction: f64,
}

impl SodCase {
    pub fn new(set: VelocitySetKind, gas: GasModel) -> Self {
        SodCase { set, gas, n: 800, scale: 0.9, nu: 0.05, time_fraction: 0.2 }
    }

    pub fn run(&self) -> SodResult {
        self.run_on(Backend::Cpu).expect("the CPU backend always exists")
    }

    /// Runs on the given backend.
    pub fn run_on(&self, backend: Backend) -> Result<SodResult, GpuError> {
        let (solver, exact) = self.solver::<f64>();
        Ok(self.measure(FluidEngine::new(backend, solver)?, exact))
    }

    /// Runs on the CPU with the populations stored as `S` ([`Storage`]: f32 for the storage
    /// option's error).
    pub fn run_stored<S: Storage>(&self) -> SodResult {
        let (solver, exact) = self.solver::<S>();
        self.measure(solver, exact)
    }

    /// The smoothed jump and the exact solution it is compared with.
    fn solver<S: Storage>(&self) -> (FluidSolver<S>, Solution) {
        let vs = VelocitySet::new(self.set);
        let dim = vs.dim;
        let l1 = vs.max_l1_speed();
        let eq = Equilibrium::new(vs, self.gas);
        let gamma = eq.gamma();
        let s = self.scale;
        let left = State { rho: 1.0, u: 0.0, p: s };
        let right = State { rho: 0.125, u: 0.0, p: 0.1 * s };
        let exact = Solution::new(left, right, gamma);
        let params: StepParams = timestep::choose(self.nu, s, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        let n = self.n;
        let x0 = n as f64 / 2.0 - 0.5;
        let init = move |x: [f64; 3]| {
            // Smoothed jump (tanh over ~2 cells) so that the start is resolved by the grid.
            let w = 0.5 * (1.0 - ((x[0] - x0) / 1.0).tanh());
            let rho = w * left.rho + (1.0 - w) * right.rho;
            let p = w * left.p + (1.0 - w) * right.p;
            Macro { rho, u: [0.0; 3], theta: p / rho }
        };
        let mut b = Boundaries::periodic();
        b.faces[0] = FaceCondition::Outlet;
        b.faces[1] = FaceCondition::Outlet;
        (FluidSolver::with_storage(eq, Grid::new(dim, [n, 1, 1]), b, &[], params, init), exact)
    }

    /// Steps `run` to the comparison time and reads the plateaus and fronts.
    fn measure<S: Storage>(&self, mut run: impl FluidRun<S>, exact: Solution) -> SodResult {
        let (left, right) = (exact.left, exact.right);
        let gamma = exact.gamma;
        let (n, s) = (self.n, self.scale);
        let x0 = n as f64 / 2.0 - 0.5;
        let dt = run.state().params.dt;
        let t_end = self.time_fraction * n as f64 / (gamma * s).sqrt();
        let steps = ((t_end / dt) - 0.5).ceil().max(0.0) as u64;
        run.advance(steps).expect("Sod shock tube stays stable");
        let solver = run.state();
        let t = solver.time;
        let field: Vec<Macro> = (0..n).map(|x| solver.macro_at_coords([x as i64, 0, 0])).collect();
        let xi = |x: f64| (x - x0) / t;
        let pos = |xi: f64| x0 + xi * t;
        // Plateau 3 (between rarefaction tail and contact) and 4 (between contact and shock):
        // average over the middle half of each region.
        let al = (gamma * left.p / left.rho).sqrt();
        let a_star = al * (exact.p_star / left.p).powf((gamma - 1.0) / (2.0 * gamma));
        let tail = pos(exact.u_star - a_star);
        let contact = pos(exact.u_star);
        let shock = pos(exact.right_shock_speed());
        let avg = |a: f64, b: f64, q: &dyn Fn(&Macro) -> f64| {
            let (lo, hi) = ((a + 0.25 * (b - a)).ceil() as usize, (b - 0.25 * (b - a)).floor() as usize);
            (lo..=hi).map(|x| q(&field[x])).sum::<f64>() / (hi - lo + 1) as f64
        };
        let mut plateaus = Vec::new();
        let mut push = |name: &str, m: f64, e: f64| plateaus.push((name.to_string(), m, e, (m - e) / e));
        push("pressure (3-4)", avg(tail, shock, &|m| m.pressure()), exact.p_star);
        push("velocity (3-4)", avg(tail, shock, &|m| m.u[0]), exact.u_star);
        push("density (3)", avg(tail, contact, &|m| m.rho), exact.rho_star_left);
        push("density (4)", avg(contact, shock, &|m| m.rho), exact.rho_star_right);
        // Front positions: where the density crosses the mid value between its two sides.
        let crossing = |a: f64, b: f64, level: f64| -> f64 {
            let (lo, hi) = (a as usize, (b as usize).min(n - 2));
            for x in lo..hi {
                let (r0, r1) = (field[x].rho, field[x + 1].rho);
                if (r0 - level) * (r1 - level) <= 0.0 && r0 != r1 {
                    return x as f64 + (level - r0) / (r1 - r0);
                }
            }
            f64::NAN
        };
        let shock_measured =
            crossing(contact + 0.5 * (shock - contact), (shock + 0.5 * (n as f64 - shock)).min(n as f64 - 1.0), 0.5 * (exact.rho_star_right + right.rho));
        let contact_measured = crossing(tail + 0.5 * (contact - tail), contact + 0.5 * (shock - contact), 0.5 * (exact.rho_star_left + exact.rho_star_right));
        let _ = xi;
        SodResult { gamma, plateaus, shock_position: (shock_measured, shock), contact_position: (contact_measured, contact), steps: solver.step_count }
    }
}
