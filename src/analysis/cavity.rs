//! The lid-driven square cavity at Re = 100 against Ghia, Ghia & Shin (1982), Tables I–II
//! (../shared/reference): u on the vertical centreline and v on the horizontal centreline, in
//! units of the lid's speed, at positions in units of the cavity's side (lid at y = 1 moving
//! along +x).

use crate::fluid::FluidSolver;

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

/// Largest |u − u_Ghia| / U over both of Ghia's tables for the state of `s`, a 2D square
/// cavity filling the lattice (nodes at (i + ½)/n of the side) whose lid at y = 1 moves along +x
/// at `lid` (lattice units, as the state's velocities): bilinear interpolation between nodes.
pub fn ghia_deviation(s: &FluidSolver, lid: f64) -> f64 {
    let [nx, ny, _] = s.layout.grid.n;
    let (fx_n, fy_n) = (nx as f64, ny as f64);
    let sample = |x: f64, y: f64, comp: usize| -> f64 {
        let (fx, fy) = (x * fx_n - 0.5, y * fy_n - 0.5);
        let (i0, j0) = (fx.floor().clamp(0.0, fx_n - 2.0) as i64, fy.floor().clamp(0.0, fy_n - 2.0) as i64);
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
    dev
}
