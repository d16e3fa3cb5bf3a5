//! Flow past a circular cylinder at Re = 100: Strouhal number of the vortex shedding
//! (reference 0.164–0.167 unconfined; ../shared/reference). Velocity inlet, zero-gradient
//! outlet, periodic lateral faces far from the cylinder; the lift-like transverse velocity at a
//! wake probe is sampled and its period found from upward zero crossings after the transient.

use crate::fluid::{Boundaries, Equilibrium, FaceCondition, FluidSolver, GasModel, Grid, Macro, Obstacle, Shape, VelocitySet, VelocitySetKind, timestep};

#[derive(Clone, Debug, serde::Serialize)]
pub struct CylinderResult {
    pub diameter: f64,
    pub strouhal: f64,
    pub periods_measured: usize,
    pub steps: u64,
}

/// `diameter` in nodes; the domain is `length_d` × `width_d` diameters with the cylinder 6 D from
/// the inlet; `periods` expected shedding periods are simulated (the last 40% measured).
pub fn cylinder(diameter: usize, mach: f64, periods: f64, length_d: usize, width_d: usize) -> CylinderResult {
    let vs = VelocitySet::new(VelocitySetKind::D2q21);
    let l1 = vs.max_l1_speed();
    let eq = Equilibrium::new(vs, GasModel::Monatomic);
    let theta0 = 0.6;
    let u0 = mach * eq.sound_speed(theta0);
    let d = diameter as f64;
    let nu = u0 * d / 100.0;
    let params = timestep::choose(nu, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
    let (nx, ny) = (length_d * diameter, width_d * diameter);
    let mut b = Boundaries::periodic();
    b.faces[0] = FaceCondition::VelocityInlet { velocity: [u0, 0.0, 0.0], theta: theta0, profile: Default::default() };
    b.faces[1] = FaceCondition::Outlet;
    let centre = [6.0 * d, 0.5 * ny as f64 - 0.5, 0.0];
    let obstacle = Obstacle { shape: Shape::Cylinder { center: centre, radius: 0.5 * d }, velocity: [0.0; 3], temperature: None };
    let init = move |x: [f64; 3]| {
        // Asymmetric start: a small transverse velocity bump behind the cylinder.
        let bump = 0.1 * u0 * (-((x[0] - centre[0] - d).powi(2) + (x[1] - centre[1]).powi(2)) / (d * d)).exp();
        Macro { rho: 1.0, u: [u0, bump, 0.0], theta: theta0 }
    };
    let mut s = FluidSolver::new(eq, Grid::new(2, [nx, ny, 1]), b, &[obstacle], params, init);
    let probe = s.layout.grid.index([(centre[0] + 2.0 * d) as i64, centre[1].round() as i64, 0]);
    let expected_period = d / (0.165 * u0);
    let t_end = periods * expected_period;
    let t_transient = 0.6 * t_end;
    let mut prev = 0.0;
    let mut ups = Vec::new();
    while s.time < t_end {
        s.step().expect("cylinder wake stays stable");
        let v = s.macro_at(probe).u[1];
        if s.time > t_transient && prev < 0.0 && v >= 0.0 {
            ups.push(s.time - params.dt * v / (v - prev));
        }
        prev = v;
    }
    let period = if ups.len() >= 2 { (ups[ups.len() - 1] - ups[0]) / (ups.len() - 1) as f64 } else { f64::NAN };
    CylinderResult { diameter: d, strouhal: d / (period * u0), periods_measured: ups.len().saturating_sub(1), steps: s.step_count }
}
