//! Passive tracers for seeing the air: massless points carried by the fluid's velocity,
//! x' = u(x), integrated with the explicit midpoint rule (RK2) through the velocity
//! interpolated multilinearly (bilinear in 2D, trilinear in 3D) between the nodes. The CPU twin
//! of `shaders/tracers.wgsl` (`crate::gpu::tracers`).
//!
//! A tracer that leaves the interior, or whose nearest node is not fluid (it ran into a body),
//! is born again at a point of the seed box (the inlet, say) drawn from a counter-based hash of
//! (tracer, generation): no random stream, so the CPU and the GPU re-seed alike and a run is
//! reproducible. Solid nodes count as velocity zero in the interpolation (walls at rest).
//!
//! Units: positions in interior lattice coordinates (cells; z = 0 in 2D), velocities in lattice
//! units, time in the fluid's lattice time (a fluid step is `StepParams::dt`).

use super::boundary::FaceCondition;
use super::grid::Grid;
use super::layout::{Layout, NodeKind};
use super::solver::FluidSolver;
use crate::hash::mix32;
use glam::DVec3;

/// The velocity the tracers see: u per padded node (f32, as the GPU holds it) and whether the
/// node is fluid.
#[derive(Clone, Debug, PartialEq)]
pub struct VelocityField {
    pub grid: Grid,
    pub u: Vec<[f32; 3]>,
    pub fluid: Vec<bool>,
}

impl VelocityField {
    /// The fluid's velocity now (solid and halo nodes: zero, not fluid).
    pub fn of(s: &FluidSolver) -> Self {
        let g = &s.layout.grid;
        let fluid: Vec<bool> = s.layout.kind.iter().map(|k| *k == NodeKind::Fluid).collect();
        let u = (0..g.len()).map(|n| if fluid[n] { s.macro_at(n).u.map(|v| v as f32) } else { [0.0; 3] }).collect();
        Self { grid: g.clone(), u, fluid }
    }

    /// A field given by `f` at every interior node (all fluid), for tests and analytic flows.
    pub fn analytic(grid: Grid, f: impl Fn(DVec3) -> DVec3) -> Self {
        let fluid: Vec<bool> = (0..grid.len()).map(|n| grid.is_interior(grid.coords(n))).collect();
        let u = (0..grid.len())
            .map(|n| {
                let c = grid.coords(n);
                if fluid[n] { f(DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)).to_array().map(|v| v as f32) } else { [0.0; 3] }
            })
            .collect();
        Self { grid, u, fluid }
    }

    /// u at `x`, or `None` where a tracer cannot be: outside the interior box, or nearest to a
    /// node that is not fluid.
    pub fn sample(&self, x: DVec3) -> Option<DVec3> {
        let g = &self.grid;
        let d = g.dim;
        for a in 0..d {
            if !(x[a] >= 0.0 && x[a] <= (g.n[a] - 1) as f64) {
                return None;
            }
        }
        let nearest = [x.x.round() as i64, x.y.round() as i64, if d == 3 { x.z.round() as i64 } else { 0 }];
        if !self.fluid[g.index(nearest)] {
            return None;
        }
        let lo = [x.x.floor() as i64, x.y.floor() as i64, if d == 3 { x.z.floor() as i64 } else { 0 }];
        let t = [x.x - lo[0] as f64, x.y - lo[1] as f64, if d == 3 { x.z - lo[2] as f64 } else { 0.0 }];
        let mut u = DVec3::ZERO;
        for c in 0..1usize << d {
            let o = [c & 1, (c >> 1) & 1, (c >> 2) & 1];
            let w: f64 = (0..d).map(|a| if o[a] == 1 { t[a] } else { 1.0 - t[a] }).product();
            if w == 0.0 {
                continue;
            }
            let n = [lo[0] + o[0] as i64, lo[1] + o[1] as i64, lo[2] + o[2] as i64];
            let v = self.u[g.index(n)];
            u += w * DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
        }
        Some(u)
    }
}

/// Where tracers are born on `layout`'s lattice (lower and upper corner, interior lattice
/// coordinates; z = 0 in 2D): a slab two cells thick inside the first inflow face — a velocity
/// or pressure inlet, looked for in the order x_min, x_max, y_min, y_max, z_min, z_max — kept a
/// cell off the faces across it; or, where the air has no inlet (periodic boxes, cavities), the
/// whole interior, so that tracers stay spread over a flow that nothing feeds.
pub fn birth_box(layout: &Layout) -> (DVec3, DVec3) {
    let g = &layout.grid;
    let top = |a: usize| (g.n[a] as f64 - 1.0).max(0.0);
    let (mut lo, mut hi) = (DVec3::ZERO, DVec3::ZERO);
    let inflow = (0..2 * g.dim).find(|&f| matches!(layout.boundaries.faces[f], FaceCondition::PressureInlet { .. } | FaceCondition::VelocityInlet { .. }));
    for a in 0..g.dim {
        (lo[a], hi[a]) = match inflow {
            Some(f) if f / 2 == a && f % 2 == 0 => (0.5, 2.5),
            Some(f) if f / 2 == a => (top(a) - 2.5, top(a) - 0.5),
            Some(_) => (1.0, top(a) - 1.0),
            None => (0.5, top(a) - 0.5),
        };
    }
    (lo, hi)
}

/// A number in [0, 1) from (tracer, generation, axis) by the lowbias32 hash, exact in f32.
pub fn unit(tracer: u32, generation: u32, axis: u32) -> f64 {
    (mix32(mix32(mix32(tracer) ^ generation) ^ axis) >> 8) as f64 / (1u32 << 24) as f64
}

/// Tracers and where they are born.
#[derive(Clone, Debug, PartialEq)]
pub struct Tracers {
    /// Positions (interior lattice coordinates).
    pub positions: Vec<DVec3>,
    /// How many times each tracer was born (0 for the first).
    pub generation: Vec<u32>,
    /// The seed box (lower and upper corner, lattice coordinates; z = 0 in 2D).
    pub seed: (DVec3, DVec3),
    /// Tracers born again over the run.
    pub reseeded: u64,
}

impl Tracers {
    /// `count` tracers spread over the seed box.
    pub fn new(count: usize, seed: (DVec3, DVec3)) -> Self {
        let mut t = Tracers { positions: Vec::with_capacity(count), generation: vec![0; count], seed, reseeded: 0 };
        for k in 0..count {
            let p = t.seed_point(k as u32, 0);
            t.positions.push(p);
        }
        t
    }

    /// Where tracer `k` is born in its `generation`.
    pub fn seed_point(&self, k: u32, generation: u32) -> DVec3 {
        let (lo, hi) = self.seed;
        DVec3::new(unit(k, generation, 0), unit(k, generation, 1), unit(k, generation, 2)) * (hi - lo) + lo
    }

    /// One step of length `dt` (lattice time) through `field`: the midpoint rule
    /// x* = x + (dt/2) u(x), x ← x + dt u(x*); a tracer that cannot be where it is or where it
    /// goes is born again.
    pub fn advect(&mut self, field: &VelocityField, dt: f64) {
        for k in 0..self.positions.len() {
            let x = self.positions[k];
            let moved = field.sample(x).and_then(|u| field.sample(x + 0.5 * dt * u)).map(|u| x + dt * u).filter(|y| field.sample(*y).is_some());
            match moved {
                Some(y) => self.positions[k] = y,
                None => {
                    self.generation[k] += 1;
                    self.positions[k] = self.seed_point(k as u32, self.generation[k]);
                    self.reseeded += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_a_uniform_flow_a_tracer_moves_u_t() {
        let g = Grid::new(3, [40, 20, 12]);
        let u = DVec3::new(0.05, -0.02, 0.01);
        let f = VelocityField::analytic(g, |_| u);
        let mut t = Tracers::new(50, (DVec3::new(2.0, 8.0, 3.0), DVec3::new(4.0, 12.0, 6.0)));
        let start = t.positions.clone();
        let dt = 0.7;
        for _ in 0..200 {
            t.advect(&f, dt);
        }
        assert_eq!(t.reseeded, 0);
        for (a, b) in start.iter().zip(&t.positions) {
            // u in f32: 0.05 is off by ~1e-9
            assert!((*b - *a - u * 140.0).length() < 1e-5, "moved {} instead of {}", *b - *a, u * 140.0);
        }
    }

    #[test]
    fn in_a_solid_body_rotation_tracers_keep_their_radius_over_a_revolution() {
        // ω = 2π/(200 dt): a revolution in 200 steps; the midpoint rule's radius grows by
        // (ω dt)⁴/8 per step, 2π (ω dt)³/8 ≈ 2.4e-5 of itself per revolution
        let g = Grid::new(2, [64, 64, 1]);
        let c = DVec3::new(31.5, 31.5, 0.0);
        let (dt, steps) = (1.0, 200);
        let w = 2.0 * std::f64::consts::PI / (steps as f64 * dt);
        let f = VelocityField::analytic(g, |x| DVec3::new(-(x.y - c.y), x.x - c.x, 0.0) * w);
        let mut t = Tracers::new(100, (c + DVec3::new(-20.0, -20.0, 0.0), c + DVec3::new(20.0, 20.0, 0.0)));
        t.positions.retain(|p| (*p - c).length() > 2.0 && (*p - c).length() < 28.0);
        t.generation.truncate(t.positions.len());
        let r0: Vec<f64> = t.positions.iter().map(|p| (*p - c).length()).collect();
        let p0 = t.positions.clone();
        for _ in 0..steps {
            t.advect(&f, dt);
        }
        assert_eq!(t.reseeded, 0);
        for ((p, a), r) in t.positions.iter().zip(&p0).zip(&r0) {
            let r1 = (*p - c).length();
            assert!((r1 / r - 1.0).abs() < 1e-3, "radius {r} → {r1}");
            // and back where it started after one revolution (phase error ∝ (ω dt)²)
            assert!((*p - *a).length() < 1e-2 * r, "{a} → {p}");
        }
    }

    #[test]
    fn tracers_are_born_along_the_first_inflow_face_or_everywhere_without_one() {
        use crate::fluid::boundary::{Boundaries, FaceCondition, InletProfile};
        let inlet = FaceCondition::VelocityInlet { velocity: [0.05, 0.0, 0.0], theta: 0.6, profile: InletProfile::Uniform };
        let pressure = FaceCondition::PressureInlet { rho: 1.01, theta: 0.6 };
        let layout = |dim: usize, faces: &[(usize, FaceCondition)]| {
            let mut b = Boundaries::periodic();
            for (f, c) in faces {
                b.faces[*f] = c.clone();
            }
            Layout::new(Grid::new(dim, [30, 20, 12]), b, &[])
        };
        let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        // the glottis: lungs at y_min (n = 30 × 20: interior coordinates 0 … 29, 0 … 19)
        assert_eq!(birth_box(&layout(2, &[(2, pressure.clone())])), (v(1.0, 0.5, 0.0), v(28.0, 2.5, 0.0)));
        // a channel: x_min before y_min
        assert_eq!(birth_box(&layout(2, &[(0, inlet.clone()), (2, pressure.clone())])), (v(0.5, 1.0, 0.0), v(2.5, 18.0, 0.0)));
        // air fed from x_max, and from z_max in 3D
        assert_eq!(birth_box(&layout(2, &[(1, inlet.clone())])), (v(26.5, 1.0, 0.0), v(28.5, 18.0, 0.0)));
        assert_eq!(birth_box(&layout(3, &[(5, pressure)])), (v(1.0, 1.0, 8.5), v(28.0, 18.0, 10.5)));
        // no inlet: the whole interior
        assert_eq!(birth_box(&layout(3, &[])), (v(0.5, 0.5, 0.5), v(28.5, 18.5, 10.5)));
        assert_eq!(birth_box(&layout(2, &[])), (v(0.5, 0.5, 0.0), v(28.5, 18.5, 0.0)));
    }

    #[test]
    fn a_tracer_that_leaves_or_hits_a_body_is_born_again_in_the_seed_box() {
        let g = Grid::new(2, [30, 10, 1]);
        let mut f = VelocityField::analytic(g.clone(), |_| DVec3::new(0.5, 0.0, 0.0));
        // a solid column at x = 15, rows 0–4
        for y in 0..5 {
            f.fluid[g.index([15, y, 0])] = false;
        }
        let seed = (DVec3::new(1.0, 1.0, 0.0), DVec3::new(2.0, 8.0, 0.0));
        let mut t = Tracers::new(200, seed);
        for _ in 0..100 {
            t.advect(&f, 1.0);
            for p in &t.positions {
                assert!(f.sample(*p).is_some(), "{p} is no tracer's place");
            }
        }
        // every tracer crossed the 30 cells at 0.5 per step (slower beside the column) or hit it
        assert!(t.generation.iter().all(|g| *g >= 1), "{:?}", t.generation);
        assert_eq!(t.reseeded, t.generation.iter().map(|g| *g as u64).sum::<u64>());
        // the hash spreads the births over the box
        let ys: Vec<f64> = (0..200).map(|k| t.seed_point(k, 1).y).collect();
        let mean = ys.iter().sum::<f64>() / 200.0;
        assert!((mean - 4.5).abs() < 0.5 && ys.iter().all(|y| (1.0..8.0).contains(y)), "mean {mean}");
    }
}
