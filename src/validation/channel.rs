//! Channel flows with analytic profiles (../shared/reference):
//! * Poiseuille: periodic channel driven by a body force g between isothermal no-slip walls,
//!   u(y) = (g / 2ν) y (H − y), walls half a node outside the first and last nodes.
//! * Thermal Couette: a wall moving at U over a wall at rest, both at θ₀; with viscous heating
//!   the peak temperature rise at mid-gap is Pr U² / (8 c_p) with Pr = 1 (2.101, 2.103) and
//!   c_p = (D + 2)/2 in units of θ for the monatomic gas.

use crate::fluid::{Boundaries, Equilibrium, FaceCondition, FluidSolver, GasModel, Grid, Macro, VelocitySet, VelocitySetKind, timestep};

#[derive(Clone, Debug, serde::Serialize)]
pub struct ProfileResult {
    /// Relative L2 error of the velocity profile.
    pub l2_error: f64,
    /// Couette only: measured and predicted peak temperature rise Δθ.
    pub peak_rise: Option<(f64, f64)>,
    pub steps: u64,
}

fn channel(h: usize, nu: f64, top: [f64; 3], theta0: f64) -> FluidSolver {
    let vs = VelocitySet::new(VelocitySetKind::D2q21);
    let l1 = vs.max_l1_speed();
    let eq = Equilibrium::new(vs, GasModel::Monatomic);
    let params = timestep::choose(nu, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
    let mut b = Boundaries::periodic();
    b.faces[2] = FaceCondition::Wall { velocity: [0.0; 3], temperature: Some(theta0) };
    b.faces[3] = FaceCondition::Wall { velocity: top, temperature: Some(theta0) };
    FluidSolver::new(eq, Grid::new(2, [4, h, 1]), b, &[], params, |_| Macro { rho: 1.0, u: [0.0; 3], theta: theta0 })
}

fn run_to_steady(s: &mut FluidSolver, h: usize, nu: f64, efolds: f64) {
    // Slowest viscous mode decays as exp(−ν π² t / H²).
    let t_end = efolds * (h * h) as f64 / (nu * std::f64::consts::PI.powi(2));
    while s.time < t_end {
        s.step().expect("channel flow stays stable");
    }
}

pub fn poiseuille(h: usize) -> ProfileResult {
    let nu = 0.1;
    let u_max = 0.05;
    let hf = h as f64;
    let g = 8.0 * nu * u_max / (hf * hf);
    let mut s = channel(h, nu, [0.0; 3], 0.6);
    s.body_force = [g, 0.0, 0.0];
    run_to_steady(&mut s, h, nu, 12.0);
    let (mut num, mut den) = (0.0, 0.0);
    for y in 0..h {
        let yy = y as f64 + 0.5;
        let exact = g / (2.0 * nu) * yy * (hf - yy);
        let m = s.macro_at_coords([1, y as i64, 0]);
        num += (m.u[0] - exact).powi(2);
        den += exact * exact;
    }
    ProfileResult { l2_error: (num / den).sqrt(), peak_rise: None, steps: s.step_count }
}

pub fn thermal_couette(h: usize) -> ProfileResult {
    let nu = 0.2;
    let theta0 = 0.6;
    let u_wall = 0.3;
    let mut s = channel(h, nu, [u_wall, 0.0, 0.0], theta0);
    run_to_steady(&mut s, h, nu, 12.0);
    let hf = h as f64;
    let (mut num, mut den) = (0.0, 0.0);
    let mut peak: f64 = 0.0;
    for y in 0..h {
        let yy = y as f64 + 0.5;
        let exact = u_wall * yy / hf;
        let m = s.macro_at_coords([1, y as i64, 0]);
        num += (m.u[0] - exact).powi(2);
        den += exact * exact;
        peak = peak.max(m.theta - theta0);
    }
    let cp = (2.0 + 2.0) / 2.0;
    let predicted = u_wall * u_wall / (8.0 * cp);
    // The discrete nodes straddle mid-gap (h even): correct the sampled maximum of the parabola.
    let offset = if h.is_multiple_of(2) { 0.5 / hf } else { 0.0 };
    let predicted_at_node = predicted * (1.0 - 4.0 * offset * offset);
    ProfileResult { l2_error: (num / den).sqrt(), peak_rise: Some((peak, predicted_at_node)), steps: s.step_count }
}
