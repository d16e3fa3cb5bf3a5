//! The bodies' surfaces as triangle meshes ([`crate::mesh`]) in physical coordinates, written
//! beside each particle snapshot as `surface_NNN.vtk` (open both in ParaView): the level set
//! the air sees for a coupled scene, the particles' own for a solid.

use crate::coupling::CoupledSolver;
use crate::fluid::KernelLevelSet;
use crate::mesh::TriangleMesh;
use crate::mesh::particle_field::body_surfaces;
use crate::solid::SolidSolver;
use glam::DVec3;

/// Sampling of the level set: half a cell (or half a particle spacing) in 2D, a cell in 3D
/// (the 3D glottis has 10⁵ surface cells at that spacing already).
fn spacing(dim: usize) -> f64 {
    if dim == 3 { 1.0 } else { 0.5 }
}

/// What the bodies' surfaces are made from: one level set per body (in the sets' own length
/// unit: lattice cells for a coupled scene, particle spacings for a solid), the grid spacing
/// they are sampled at and the dimension, and the map to scene units, x ↦ (x + `offset`) ·
/// `scale`. [`Self::mesh`] makes the surface on the CPU; the plugin's GPU fold mesh makes it
/// from the same source on the device.
#[derive(Clone, Debug)]
pub struct SurfaceSource {
    pub sets: Vec<KernelLevelSet>,
    pub spacing: f64,
    pub dim: usize,
    pub offset: DVec3,
    pub scale: f64,
}

impl SurfaceSource {
    /// The coupled bodies' level sets as the air sees them ([`CoupledSolver::drawn_level_sets`]);
    /// the inverse of `CoupledSolver::to_lattice` (cell centres at +½; z = 0 is the nodes' plane
    /// in 2D).
    pub fn coupled(c: &CoupledSolver) -> Self {
        let dim = c.fluid.layout.grid.dim;
        let offset = if dim == 3 { DVec3::splat(0.5) } else { DVec3::new(0.5, 0.5, 0.0) };
        SurfaceSource { sets: c.drawn_level_sets(), spacing: spacing(dim), dim, offset, scale: c.units.dx }
    }

    /// A solid's bodies' level sets ([`crate::coupling::level_set::body_level_sets`]).
    pub fn solid(s: &SolidSolver) -> Self {
        let p = &s.particles;
        SurfaceSource { sets: crate::coupling::level_set::body_level_sets(p), spacing: spacing(p.dim), dim: p.dim, offset: DVec3::ZERO, scale: p.spacing }
    }

    /// The surfaces {L = 0} as one mesh in scene units, each vertex tagged with its body
    /// ([`body_surfaces`]); a 2D scene's as a slab one sampling spacing thick around z = 0.
    pub fn mesh(&self) -> TriangleMesh {
        body_surfaces(&self.sets, self.spacing, self.dim, |p| (p + self.offset) * self.scale)
    }
}

/// The coupled bodies' surfaces {L = 0}, scene units.
pub fn coupled_surface(c: &CoupledSolver) -> TriangleMesh {
    SurfaceSource::coupled(c).mesh()
}

/// A solid's bodies' surfaces, scene units.
pub fn solid_surface(s: &SolidSolver) -> TriangleMesh {
    SurfaceSource::solid(s).mesh()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin;
    use crate::scene::coupled::CoupledScene;

    #[test]
    fn the_glottis_surface_is_two_closed_folds_around_their_particles() {
        let c = CoupledScene::parse(builtin("glottis_2d_c").unwrap()).unwrap().build().unwrap();
        let m = coupled_surface(&c);
        assert_eq!(m.unmatched_edges(), 0, "closed");
        // two folds, each a closed prism: every vertex tagged 0 or 1, both present
        assert!(m.scalars.contains(&0.0) && m.scalars.contains(&1.0));
        // the prism's section area ≈ the particles' area (N l₀², cm²) within 5 %
        let p = &c.solid.particles;
        let particles_area = p.len() as f64 * p.spacing * p.spacing;
        let thickness = 0.5 * c.units.dx;
        let area = m.volume() / thickness;
        assert!((area / particles_area - 1.0).abs() < 0.05, "section {area} cm² vs particles {particles_area} cm²");
        // every particle inside the mesh's box, and the mesh within r_e of the particles
        let (lo, hi) = m.positions.iter().fold((DVec3::MAX, DVec3::MIN), |(lo, hi), x| (lo.min(*x), hi.max(*x)));
        let (plo, phi) = p.position.iter().fold((DVec3::MAX, DVec3::MIN), |(lo, hi), x| (lo.min(*x), hi.max(*x)));
        for a in 0..2 {
            assert!(lo[a] < plo[a] && hi[a] > phi[a], "axis {a}: mesh {lo}–{hi}, particles {plo}–{phi}");
            assert!(plo[a] - lo[a] < 2.0 * c.units.dx && hi[a] - phi[a] < 2.0 * c.units.dx);
        }
    }

    #[test]
    fn a_solid_beam_surface_is_a_closed_box_around_its_particles() {
        let mut p = crate::solid::Particles::new(3, 0.1);
        for x in crate::solid::particles::sample_box(3, DVec3::ZERO, DVec3::new(1.0, 0.4, 0.3), 0.1) {
            p.push(x, 1.0, 0, 0, false);
        }
        let s = SolidSolver::new(p, vec![crate::solid::material::Orthotropic::isotropic(1e5, 0.3, 1.0, 0.0)], Default::default()).unwrap();
        let m = solid_surface(&s);
        assert_eq!(m.unmatched_edges(), 0);
        // the box 1 × 0.4 × 0.3 its particles sample (at its cells' centres): the faces of the
        // mesh within a tenth of a spacing of the box's (φ is calibrated on the face points),
        // its edges rounded by the kernel (radius ≤ r_e = 2 l₀): the volume between the box's
        // and the box's with every edge rounded to radius r_e
        let (lo, hi) = m.positions.iter().fold((DVec3::MAX, DVec3::MIN), |(lo, hi), x| (lo.min(*x), hi.max(*x)));
        let size = DVec3::new(1.0, 0.4, 0.3);
        assert!(lo.abs().max_element() < 0.01 && (hi - size).abs().max_element() < 0.01, "mesh box {lo}–{hi}");
        let re = 0.2;
        let rounded = 0.12 - (1.0 - std::f64::consts::FRAC_PI_4) * re * re * 4.0 * (size.x + size.y + size.z);
        let v = m.volume();
        assert!(v < 0.12 && v > rounded, "volume {v}, not in ({rounded}, 0.12)");
    }
}
