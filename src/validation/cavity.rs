//! Lid-driven cavity at Re = 100 against Ghia, Ghia & Shin (1982), Tables I–II
//! (../shared/reference): u on the vertical centreline and v on the horizontal centreline.

pub use crate::analysis::cavity::{GHIA_U, GHIA_V, ghia_deviation};
use crate::fluid::{Boundaries, Equilibrium, FaceCondition, FluidSolver, GasModel, Grid, Macro, VelocitySet, VelocitySetKind, timestep};

#[derive(Clone, Debug, serde::Serialize)]
pub struct CavityResult {
    pub n: usize,
    /// Largest |u − u_Ghia| / U over both tables.
    pub max_deviation: f64,
    pub steps: u64,
    pub lid_transits: f64,
}

pub fn cavity(n: usize, mach: f64, transits: f64) -> CavityResult {
    let vs = VelocitySet::new(VelocitySetKind::D2q21);
    let l1 = vs.max_l1_speed();
    let eq = Equilibrium::new(vs, GasModel::Monatomic);
    let theta0 = 0.6;
    let lid = mach * eq.sound_speed(theta0);
    let nu = lid * n as f64 / 100.0;
    let params = timestep::choose(nu, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
    let wall = FaceCondition::Wall { velocity: [0.0; 3], temperature: Some(theta0) };
    let mut b = Boundaries::periodic();
    b.faces[0] = wall.clone();
    b.faces[1] = wall.clone();
    b.faces[2] = wall;
    b.faces[3] = FaceCondition::Wall { velocity: [lid, 0.0, 0.0], temperature: Some(theta0) };
    let mut s = FluidSolver::new(eq, Grid::new(2, [n, n, 1]), b, &[], params, |_| Macro { rho: 1.0, u: [0.0; 3], theta: theta0 });
    let t_end = transits * n as f64 / lid;
    while s.time < t_end {
        s.step().expect("cavity stays stable");
    }
    let dev = ghia_deviation(&s, lid);
    CavityResult { n, max_deviation: dev, steps: s.step_count, lid_transits: transits }
}
