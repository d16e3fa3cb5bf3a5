//! The surface of a body of particles: its level set L (seed 000 2.124, positive inside;
//! [`KernelLevelSet`]) sampled on a grid and passed through marching cubes. With the coupling's
//! own level sets (method 2's walls) the mesh is the wall the air sees; for a solid alone the
//! level set is calibrated the same way on the body's sampled surface.

use super::marching_cubes::{ScalarGrid, TriangleMesh, extract};
use crate::fluid::KernelLevelSet;
use glam::DVec3;

/// The grid a body's level set is sampled on for its surface: `dims` nodes per axis from node
/// (0, 0, 0) at `origin`, `spacing` apart (the set's length unit); a 2D body's is a slab
/// ([`ScalarGrid::slab`]: three layers, the body's plane z = 0 in the middle one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceGrid {
    pub dims: [usize; 3],
    pub origin: DVec3,
    pub spacing: f64,
    pub slab: bool,
}

impl SurfaceGrid {
    /// The box of `set`'s particles grown by r_e and one more node, so that the field is outside
    /// (−φ) at the grid's border and the surface closes; nodes `h` apart. In 2D (`dim` 2) the
    /// plane z = 0 as a slab one spacing thick.
    pub fn around(set: &KernelLevelSet, h: f64, dim: usize) -> Self {
        let (lo, hi, _) = set.bin_box();
        let lo = DVec3::from_array(lo) - DVec3::splat(h);
        let hi = DVec3::from_array(hi) + DVec3::splat(h);
        let n = |a: usize| ((hi[a] - lo[a]) / h).ceil() as usize + 1;
        if dim == 2 {
            SurfaceGrid { dims: [n(0), n(1), 3], origin: DVec3::new(lo.x, lo.y, -h), spacing: h, slab: true }
        } else {
            SurfaceGrid { dims: [n(0), n(1), n(2)], origin: lo, spacing: h, slab: false }
        }
    }

    pub fn nodes(&self) -> usize {
        self.dims.iter().product()
    }
}

/// L of `set` (2.124) at the nodes of its [`SurfaceGrid::around`] (spacing `h`, dimension
/// `dim`). Its GPU twin is shaders/level_set_grid.wgsl.
pub fn level_set_grid(set: &KernelLevelSet, h: f64, dim: usize) -> ScalarGrid {
    let g = SurfaceGrid::around(set, h, dim);
    let level = |x: DVec3| set.level(x.to_array()).0;
    if g.slab {
        let plane = ScalarGrid::sample([g.dims[0], g.dims[1], 1], DVec3::new(g.origin.x, g.origin.y, 0.0), h, level);
        ScalarGrid::slab([g.dims[0], g.dims[1]], plane.origin, h, &plane.values, 0.0)
    } else {
        ScalarGrid::sample(g.dims, g.origin, h, level)
    }
}

/// The surfaces {L = 0} of `sets` as one mesh, each vertex moved by `to_world` (from the sets'
/// coordinates) and tagged with its body's index in `scalars`.
pub fn body_surfaces(sets: &[KernelLevelSet], h: f64, dim: usize, to_world: impl Fn(DVec3) -> DVec3) -> TriangleMesh {
    let mut all = TriangleMesh::default();
    for (k, set) in sets.iter().enumerate() {
        if set.points.is_empty() {
            continue;
        }
        let mut m = extract(&level_set_grid(set, h, dim), 0.0);
        m.positions.iter_mut().for_each(|p| *p = to_world(*p));
        m.scalars = vec![k as f32; m.positions.len()];
        all.append(&m);
    }
    all
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coupling::level_set::surface_level;

    #[test]
    fn a_ball_of_particles_gives_a_closed_sphere_through_its_surface_points() {
        // particles on a cubic lattice of spacing 1 inside radius 8; the surface points half a
        // spacing out; φ calibrated on them as the coupling does
        let (r, re) = (8.0, 2.0);
        let mut pts = Vec::new();
        for k in -9..=9 {
            for j in -9..=9 {
                for i in -9..=9 {
                    let x = DVec3::new(i as f64, j as f64, k as f64);
                    if x.length() <= r {
                        pts.push(x);
                    }
                }
            }
        }
        let surface: Vec<DVec3> = (0..400)
            .map(|k| {
                // a Fibonacci sphere of radius r + 1/2
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / 400.0;
                let a = k as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
                let s = (1.0 - z * z).sqrt();
                DVec3::new(s * a.cos(), s * a.sin(), z) * (r + 0.5)
            })
            .collect();
        let phi = surface_level(&pts, &surface, re, 0.5 * re);
        let set = KernelLevelSet::new(pts.iter().map(|p| p.to_array()).collect(), vec![[0.0; 3]; pts.len()], re, 0.5 * re, phi);
        let m = body_surfaces(&[set], 0.5, 3, |p| p + DVec3::X);
        assert_eq!(m.unmatched_edges(), 0);
        let radii: Vec<f64> = m.positions.iter().map(|p| (*p - DVec3::X).length()).collect();
        let mean = radii.iter().sum::<f64>() / radii.len() as f64;
        assert!((mean - (r + 0.5)).abs() < 0.25, "mean radius {mean}");
        assert!(m.scalars.iter().all(|s| *s == 0.0));
    }
}
