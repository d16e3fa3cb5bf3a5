//! The bodies' surfaces as triangle meshes ([`crate::mesh`]) in physical coordinates, written
//! beside each particle snapshot as `surface_NNN.vtk` (open both in ParaView): the level set
//! the air sees for a coupled scene, the particles' own for a solid.

use crate::coupling::CoupledSolver;
use crate::mesh::TriangleMesh;
use crate::mesh::particle_field::body_surfaces;
use crate::solid::SolidSolver;
use glam::DVec3;

/// Sampling of the level set: half a cell (or half a particle spacing) in 2D, a cell in 3D
/// (the 3D glottis has 10⁵ surface cells at that spacing already).
fn spacing(dim: usize) -> f64 {
    if dim == 3 { 1.0 } else { 0.5 }
}

/// The coupled bodies' surfaces {L = 0} ([`CoupledSolver::drawn_level_sets`]), scene units; a
/// 2D scene's as a slab one sampling spacing thick around z = 0.
pub fn coupled_surface(c: &CoupledSolver) -> TriangleMesh {
    let dim = c.fluid.layout.grid.dim;
    let dx = c.units.dx;
    // the inverse of CoupledSolver::to_lattice (z = 0 is the nodes' plane in 2D)
    let to_world = move |p: DVec3| if dim == 3 { (p + DVec3::splat(0.5)) * dx } else { DVec3::new((p.x + 0.5) * dx, (p.y + 0.5) * dx, p.z * dx) };
    body_surfaces(&c.drawn_level_sets(), spacing(dim), dim, to_world)
}

/// A solid's bodies' surfaces ([`crate::coupling::level_set::body_level_sets`]), scene units.
pub fn solid_surface(s: &SolidSolver) -> TriangleMesh {
    let p = &s.particles;
    let l0 = p.spacing;
    body_surfaces(&crate::coupling::level_set::body_level_sets(p), spacing(p.dim), p.dim, move |x| x * l0)
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
