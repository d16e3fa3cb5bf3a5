//! Lid-driven cavity at Re = 100 against Ghia, Ghia & Shin (1982), Tables I–II
//! (../shared/reference): u on the vertical centreline and v on the horizontal centreline.

use crate::fluid::{Boundaries, Equilibrium, FaceCondition, FluidSolver, GasModel, Grid, Macro, VelocitySet, VelocitySetKind, timestep};

/// Ghia et al. Table I: (y, u/U) on x = 0.5.
pub const GHIA_U: [(f64, f64); 15] = [
    (0.9766, 0.84123),
    (0.9688, 0.78871),
    (0.9609, 0.73722),
    (0.9531, 0.68717),
    (0.8516, 0.23151),
    (0.7344, 0.00332),
    (0.6172, -0.13641),
    (0.5000, -0.20581),
    (0.4531, -0.21090),
    (0.2813, -0.15662),
    (0.1719, -0.10150),
    (0.1016, -0.06434),
    (0.0703, -0.04775),
    (0.0625, -0.04192),
    (0.0547, -0.03717),
];
/// Ghia et al. Table II: (x, v/U) on y = 0.5.
pub const GHIA_V: [(f64, f64); 15] = [
    (0.9688, -0.05906),
    (0.9609, -0.07391),
    (0.9531, -0.08864),
    (0.9453, -0.10313),
    (0.9063, -0.16914),
    (0.8594, -0.22445),
    (0.8047, -0.24533),
    (0.5000, 0.05454),
    (0.2344, 0.17527),
    (0.2266, 0.17507),
    (0.1563, 0.16077),
    (0.0938, 0.12317),
    (0.0781, 0.10890),
    (0.0703, 0.10091),
    (0.0625, 0.09233),
];

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
    let nf = n as f64;
    // Bilinear sample at physical (x, y) ∈ [0,1]², nodes at (i + 0.5)/n.
    let sample = |x: f64, y: f64, comp: usize| -> f64 {
        let (fx, fy) = (x * nf - 0.5, y * nf - 0.5);
        let (i0, j0) = (fx.floor().clamp(0.0, nf - 2.0) as i64, fy.floor().clamp(0.0, nf - 2.0) as i64);
        let (tx, ty) = ((fx - i0 as f64).clamp(0.0, 1.0), (fy - j0 as f64).clamp(0.0, 1.0));
        let v = |i: i64, j: i64| s.macro_at_coords([i, j, 0]).u[comp];
        (1.0 - tx) * (1.0 - ty) * v(i0, j0) + tx * (1.0 - ty) * v(i0 + 1, j0) + (1.0 - tx) * ty * v(i0, j0 + 1) + tx * ty * v(i0 + 1, j0 + 1)
    };
    let mut dev: f64 = 0.0;
    for (y, u) in GHIA_U {
        dev = dev.max((sample(0.5, y, 0) / lid - u).abs());
    }
    for (x, v) in GHIA_V {
        dev = dev.max((sample(x, 0.5, 1) / lid - v).abs());
    }
    CavityResult { n, max_deviation: dev, steps: s.step_count, lid_transits: transits }
}
