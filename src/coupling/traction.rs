//! Fluid → solid in the weak coupling (seed 000 §2.4.1, 2.110–2.113): the force of the air on
//! each surface particle.
//!
//! Every edge of a body's surface polygon is cut into pieces no longer than `piece_length`
//! lattice cells (the seed's recursive subdivision of surface triangles larger than a cell; in
//! 2D an edge splits into equal pieces). At each piece's centre the fluid is sampled along the
//! outward normal N at one and two cells from the wall (multilinear interpolation over fluid
//! nodes; the seed uses Lagrange interpolation (2.111) at the wall itself, which reads ghost
//! values inside the body); the wall values follow by extrapolation:
//!
//! * pressure p_w = 2 p(1) − p(2) (linear);
//! * wall-normal velocity derivative ∂u/∂n = (4 (u(1) − v_w) − (u(2) − v_w)) / 2 (the quadratic
//!   through the no-slip wall value v_w and the two samples).
//!
//! The traction on the piece is then, by [`TractionModel`],
//! * `SeedPressure`: t = −P N with P = p_w + ½ ρ ((u(1) − v_w)·N)² (2.110: static plus dynamic
//!   pressure, shear neglected as in the seed);
//! * `PressureAndShear` (default): t = −p_w N + σ'·N, the Newtonian traction, with the
//!   velocity gradient at the wall G = ∂u/∂n ⊗ N + ∂v_w/∂s ⊗ T (the derivative along the
//!   surface is the wall's own, T the edge's tangent; of ∂u/∂n the tangential part is sampled
//!   and the normal part follows from continuity, −∂v_w/∂s·T) and σ' = μ (G + Gᵀ − (2/D) tr G I)
//!   (the BGK gas has no bulk viscosity). The ∂v_w/∂s term carries the −μΩ of a rotating wall:
//!   without it a free disc in shear turns 1.5× too fast. Without any shear term the drag of a
//!   cylinder at Re = 20 is ~35 % too small, so the default keeps it.
//!
//! Pressures are gauge pressures against the reference state (p₀ = ρ₀θ₀): the body's inside is
//! at p₀. The piece's force A·t (A its length, per unit depth) is spread to the edge's two
//! particles linearly in the piece centre's position along the edge (2.113), so that the sum
//! over particles is exactly the sum over pieces.

use super::surface::BodySurface;
use super::traction_plan::TractionPlan;
use crate::fluid::FluidSolver;
use crate::solid::Particles;
use crate::units::Units;
use glam::DVec3;

/// Which traction the air exerts on a body's surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TractionModel {
    /// Static + dynamic pressure only (seed 2.110).
    SeedPressure,
    /// Pressure and viscous shear.
    #[default]
    PressureAndShear,
}

/// Forces of the air on the particles of the coupled bodies (physical units: force per unit
/// depth in 2D).
#[derive(Clone, Debug, Default)]
pub struct SurfaceForces {
    /// Force per particle (zero off the surface).
    pub force: Vec<DVec3>,
    /// Sum over each body, in the order of the surfaces.
    pub total: Vec<DVec3>,
    /// Pieces evaluated and pieces with no fluid within reach (inside a rigid obstacle or
    /// another body), whose force is zero.
    pub pieces: usize,
    pub pieces_without_fluid: usize,
}

/// The tractions of `fluid` on the `surfaces` of the bodies made of `p`; `units` converts the
/// particle positions (physical, from the domain's origin) to lattice coordinates. The pieces
/// and their samples are laid out by [`TractionPlan::new`] (from the solid) and evaluated by
/// [`TractionPlan::piece_forces`] (on the air) — the arithmetic the GPU's traction kernels mirror.
pub fn surface_forces<'a>(
    fluid: &FluidSolver,
    units: &Units,
    surfaces: impl IntoIterator<Item = &'a BodySurface>,
    p: &Particles,
    model: TractionModel,
    piece_length: f64,
) -> SurfaceForces {
    let plan = TractionPlan::new(fluid, units, surfaces, p, model, piece_length);
    plan.forces(&plan.piece_forces(fluid))
}

/// The surface points of `s` in lattice coordinates.
pub(super) fn lattice_points(s: &BodySurface, p: &Particles, units: &Units) -> Vec<DVec3> {
    s.points(p).into_iter().map(|x| DVec3::new(units.position_to_lattice(x.x), units.position_to_lattice(x.y), 0.0)).collect()
}

/// Where along a piece's outward normal the air is sampled (lattice cells from the wall).
pub(super) const SAMPLE_DISTANCES: [f64; 2] = [1.0, 2.0];

/// A piece of a surface edge (lattice units): the edge runs from surface point `ka` to `kb`
/// (`edge` = x_kb − x_ka, of `length`), the piece's centre sits at `t` along it.
pub(super) struct Piece {
    pub(super) ka: usize,
    pub(super) kb: usize,
    pub(super) t: f64,
    pub(super) centre: DVec3,
    pub(super) normal: DVec3,
    /// The piece's length (its area per unit depth).
    pub(super) area: f64,
    pub(super) edge: DVec3,
    pub(super) length: f64,
}

/// The pieces of the closed polygon `x` (lattice coordinates, counter-clockwise): each edge
/// cut into equal pieces no longer than `piece_length`; edges of zero length have none.
pub(super) fn edge_pieces(x: &[DVec3], piece_length: f64) -> impl Iterator<Item = Piece> + '_ {
    let n = x.len();
    (0..n).flat_map(move |ka| {
        let kb = (ka + 1) % n;
        let edge = x[kb] - x[ka];
        let length = edge.length();
        let pieces = if length > 0.0 { (length / piece_length).ceil().max(1.0) as usize } else { 0 };
        let normal = if length > 0.0 { DVec3::new(edge.y, -edge.x, 0.0) / length } else { DVec3::ZERO };
        (0..pieces).map(move |j| {
            let t = (j as f64 + 0.5) / pieces as f64;
            Piece { ka, kb, t, centre: x[ka] + t * edge, normal, area: length / pieces as f64, edge, length }
        })
    })
}

/// The fluid nodes whose populations [`surface_forces`] reads with the same arguments: the
/// interpolation stencils of its samples along every piece's normal (ascending, each once).
/// A backend that holds the populations elsewhere (the GPU) brings back only these.
pub fn sampled_nodes<'a>(
    fluid: &FluidSolver,
    units: &Units,
    surfaces: impl IntoIterator<Item = &'a BodySurface>,
    p: &Particles,
    piece_length: f64,
) -> Vec<usize> {
    let mut nodes = Vec::new();
    for s in surfaces {
        for piece in edge_pieces(&lattice_points(s, p, units), piece_length) {
            for d in SAMPLE_DISTANCES {
                let stencil = fluid.sample_stencil((piece.centre + d * piece.normal).to_array());
                nodes.extend(stencil.into_iter().flatten().map(|(node, _)| node));
            }
        }
    }
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coupling::surface::{BodySurface, ReferenceShape};
    use crate::fluid::*;
    use crate::solid::particles::sample_ball;

    /// A disc of particles (physical radius `r` at `c`) and a D2Q21 box at rest whose density
    /// rises linearly with y: p = ρθ, ∇p = (0, βθ) in lattice units.
    fn hydrostatic(beta: f64) -> (FluidSolver, Units, BodySurface, Particles) {
        let units = Units::new(0.01, 1.0e-3, 3.0e4, 0.6, 2.0);
        let (c, r, l0) = (DVec3::new(0.20, 0.20, 0.0), 0.08, 0.004);
        let mut p = Particles::new(2, l0);
        for x in sample_ball(2, c, r, l0) {
            p.push(x, 1.0, 0, 0, false);
        }
        let surface = BodySurface::build(&p, 0, &ReferenceShape::Disc { centre: c, radius: r }).unwrap();
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let params = timestep::choose(0.05, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        let x: Vec<[f64; 2]> = surface.points(&p).iter().map(|x| [units.position_to_lattice(x.x), units.position_to_lattice(x.y)]).collect();
        let n = x.len();
        let poly = Obstacle { shape: Shape::Polygon(Polygon::new(x, vec![[0.0; 3]; n])), velocity: [0.0; 3], temperature: None };
        let fluid = FluidSolver::new(eq, Grid::new(2, [40, 40, 1]), Boundaries::periodic(), &[poly], params, move |x| Macro {
            rho: 1.0 + beta * (x[1] - 20.0),
            u: [0.0; 3],
            theta: 0.6,
        });
        (fluid, units, surface, p)
    }

    /// A disc turning at Ω in the potential vortex u_θ = ΩR²/r (the Stokes flow around a
    /// rotating cylinder): the wall shear stress is −2μΩ and the torque per unit depth
    /// −4πμR²Ω. The samples see the vortex on the lattice; the one-sided quadratic gradient has
    /// an error O(Δx²/R²).
    #[test]
    fn a_disc_turning_in_its_potential_vortex_feels_the_stokes_torque() {
        let (fluid0, units, surface, mut p) = hydrostatic(0.0);
        let omega = 0.02 * units.velocity / units.dx; // 1/s: wall speed Ω R = 0.02·8 lattice
        let c = DVec3::new(0.20, 0.20, 0.0);
        let r = 0.08;
        for i in 0..p.len() {
            let d = p.position[i] - c;
            p.velocity[i] = DVec3::new(-omega * d.y, omega * d.x, 0.0);
            p.spin[i] = DVec3::new(0.0, 0.0, omega);
        }
        let (cx, cy) = (units.position_to_lattice(c.x), units.position_to_lattice(c.y));
        let om_lat = omega * units.dx / units.velocity;
        let r_lat = r / units.dx;
        let poly = fluid0.layout.obstacles.clone();
        let eq = fluid0.eq.clone();
        let params = fluid0.params;
        let fluid = FluidSolver::new(eq, fluid0.layout.grid.clone(), Boundaries::periodic(), &poly, params, move |x| {
            let (dx, dy) = (x[0] - cx, x[1] - cy);
            let r2 = (dx * dx + dy * dy).max(1e-9);
            let k = om_lat * r_lat * r_lat / r2;
            Macro { rho: 1.0, u: [-k * dy, k * dx, 0.0], theta: 0.6 }
        });
        let f = surface_forces(&fluid, &units, std::slice::from_ref(&surface), &p, TractionModel::PressureAndShear, 1.0);
        let torque: f64 = (0..p.len()).map(|i| (p.position[i] - c).cross(f.force[i]).z).sum();
        let mu = 0.6 * (params.tau - params.a) * units.pressure_unit() * units.time();
        let expected = -4.0 * std::f64::consts::PI * mu * r * r * omega;
        eprintln!("rotating disc: torque {torque:.5e} vs Stokes {expected:.5e} ({:+.2} %)", 100.0 * (torque / expected - 1.0));
        assert!((torque - expected).abs() < 0.03 * expected.abs(), "torque {torque:.4e} vs Stokes {expected:.4e}");
        // No net force from a symmetric vortex.
        assert!(f.total[0].length() < 0.02 * expected.abs() / r, "{:?}", f.total[0]);
    }

    /// [`sampled_nodes`] lists every node the traction reads: with every other node's
    /// populations set to NaN, both models give the same forces bit for bit (a node missing from
    /// the list would turn them NaN).
    #[test]
    fn the_traction_reads_only_the_sampled_nodes() {
        let (mut fluid, units, surface, p) = hydrostatic(1e-3);
        let nodes = sampled_nodes(&fluid, &units, std::slice::from_ref(&surface), &p, 1.0);
        let full: Vec<SurfaceForces> = [TractionModel::PressureAndShear, TractionModel::SeedPressure]
            .map(|m| surface_forces(&fluid, &units, std::slice::from_ref(&surface), &p, m, 1.0))
            .into();
        let nan = vec![f64::NAN; fluid.pop.nv];
        let n = fluid.layout.grid.len();
        for node in (0..n).filter(|k| nodes.binary_search(k).is_err()) {
            fluid.set_node_populations(node, &nan);
        }
        eprintln!("the traction reads {} of {n} nodes ({} pieces)", nodes.len(), full[0].pieces);
        assert!(!nodes.is_empty() && nodes.len() < n / 4, "{} nodes", nodes.len());
        for (m, f) in [TractionModel::PressureAndShear, TractionModel::SeedPressure].into_iter().zip(&full) {
            let g = surface_forces(&fluid, &units, std::slice::from_ref(&surface), &p, m, 1.0);
            assert_eq!((g.pieces, g.pieces_without_fluid), (f.pieces, f.pieces_without_fluid));
            let bits = |v: &[DVec3]| v.iter().flat_map(|x| x.to_array().map(f64::to_bits)).collect::<Vec<_>>();
            assert_eq!(bits(&g.force), bits(&f.force), "{m:?}");
            assert_eq!(bits(&g.total), bits(&f.total), "{m:?}");
        }
    }

    #[test]
    fn a_linear_pressure_field_pushes_a_disc_with_the_archimedes_force() {
        let beta = 1e-3;
        let (fluid, units, surface, p) = hydrostatic(beta);
        for model in [TractionModel::PressureAndShear, TractionModel::SeedPressure] {
            let f = surface_forces(&fluid, &units, std::slice::from_ref(&surface), &p, model, 1.0);
            assert_eq!(f.pieces_without_fluid, 0);
            // −∮ p N dA = −∇p · area: (0, −βθ) per lattice area, in physical force per depth.
            let pts = surface.points(&p);
            let area = 0.5 * (0..pts.len()).map(|k| pts[k].x * pts[(k + 1) % pts.len()].y - pts[(k + 1) % pts.len()].x * pts[k].y).sum::<f64>();
            let grad_p = beta * 0.6 * units.pressure_unit() / units.dx;
            let expected = -grad_p * area;
            let total = f.total[0];
            // Exact up to round-off: the samples reproduce a linear field, the extrapolation to
            // the wall is linear and the midpoint rule integrates a linear traction exactly.
            assert!((total.y - expected).abs() < 1e-10 * expected.abs(), "{model:?}: {} vs {expected}", total.y);
            // The inscribed polygon's area is within 0.2 % of the disc's (r = 20 spacings).
            let circle = std::f64::consts::PI * 0.08f64.powi(2);
            assert!((area - circle).abs() < 2e-3 * circle, "{area} vs {circle}");
            assert!(total.x.abs() < 1e-3 * expected.abs(), "{model:?}: no sideways force, {}", total.x);
            // The particles receive exactly the pieces' sum.
            let spread: DVec3 = f.force.iter().copied().sum();
            assert!((spread - total).length() < 1e-12 * expected.abs());
        }
    }
}
