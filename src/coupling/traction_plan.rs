//! Method 1's traction (seed 000 §2.4.1, 2.110–2.113) laid out for a backend that holds the
//! populations elsewhere (the GPU): everything [`super::traction::surface_forces`] computes
//! from the solid — the surface pieces, their normals, tangents, lengths and wall velocities,
//! the interpolation stencils of their two samples along the normal and how each piece's force
//! is shared between its edge's two particles — so that the device evaluates the air's side
//! (the moments at the stencil nodes, the samples, the traction, the spread) without bringing
//! any population back. [`TractionPlan::piece_forces`] is the CPU's evaluation (what
//! `surface_forces` runs), the GPU kernels (`gpu::codegen::traction`) its twin in f32.

use super::surface::BodySurface;
use super::traction::{SAMPLE_DISTANCES, SurfaceForces, TractionModel, edge_pieces, lattice_points};
use crate::fluid::{FluidSolver, Macro};
use crate::solid::Particles;
use crate::units::Units;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::ops::Range;

/// Stencil nodes or pieces per task of the pool in [`TractionPlan::piece_forces`]: each costs
/// 0.1–0.3 µs (a node's moments from its populations; a piece's two samples and traction).
const PAR_PIECES: usize = 64;

/// One surface piece of the plan (lattice units; velocities in c units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanPiece {
    /// Outward unit normal N and unit tangent T of the piece's edge.
    pub normal: DVec3,
    pub tangent: DVec3,
    /// The wall's velocity at the piece's centre, v_w (linear along the edge).
    pub wall_velocity: DVec3,
    /// The wall's own derivative along the surface, ∂v_w/∂s.
    pub dvds: DVec3,
    /// The piece's length (its area per unit depth).
    pub area: f64,
    /// `stencil[0]..stencil[1]` and `stencil[1]..stencil[2]` of [`TractionPlan::stencil`]:
    /// the samples at one and two cells along N (both empty: no fluid within reach, no force).
    pub stencil: [u32; 3],
}

/// Method 1's traction for the solid's current configuration.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TractionPlan {
    pub pieces: Vec<PlanPiece>,
    /// (fluid node, weight) of every sample's stencil ([`FluidSolver::sample_stencil`]).
    pub stencil: Vec<(u32, f64)>,
    /// The particles the pieces load (ascending), each with its range of [`Self::shares`]; the
    /// others receive no force from the air.
    pub targets: Vec<(u32, Range<u32>)>,
    /// (piece, weight): (1 − t) for its edge's first particle, t for the second, in the pieces'
    /// order.
    pub shares: Vec<(u32, f64)>,
    /// Particles of the solid.
    pub particles: usize,
    /// The pieces of each surface, in the surfaces' order (their forces sum to its total).
    pub surfaces: Vec<Range<usize>>,
    /// Pieces with no fluid within reach (their force is zero).
    pub pieces_without_fluid: usize,
    pub model: TractionModel,
    /// Reference pressure p₀ = ρ₀θ₀ (lattice units): tractions are gauge.
    pub p0: f64,
    /// τ − A: the dynamic viscosity is ρθ(τ − A) (lattice units).
    pub relaxation: f64,
    /// Lattice dimension D (the viscous stress subtracts (2/D) ∇·u).
    pub dim: usize,
    /// Lattice force per unit depth → physical (pressure unit × Δx).
    pub force_unit: f64,
}

impl TractionPlan {
    /// The plan of `surface_forces(fluid, units, surfaces, p, model, piece_length)`.
    pub fn new<'a>(
        fluid: &FluidSolver,
        units: &Units,
        surfaces: impl IntoIterator<Item = &'a BodySurface>,
        p: &Particles,
        model: TractionModel,
        piece_length: f64,
    ) -> Self {
        let mut plan = TractionPlan {
            model,
            p0: units.theta0,
            relaxation: fluid.params.tau - fluid.params.a,
            dim: fluid.layout.grid.dim,
            force_unit: units.pressure_unit() * units.dx,
            ..Default::default()
        };
        // (particle, piece, weight) in the pieces' order: grouped by particle below
        let mut loads: Vec<(u32, u32, f64)> = Vec::new();
        // one piece's two samples' stencils (reused: no allocation per sample)
        let mut sample: Vec<(usize, f64)> = Vec::new();
        for s in surfaces {
            let first = plan.pieces.len();
            let x = lattice_points(s, p, units);
            let v: Vec<DVec3> = s.velocities(p).into_iter().map(|v| v / units.velocity).collect();
            for piece in edge_pieces(&x, piece_length) {
                let k = plan.pieces.len() as u32;
                let start = plan.stencil.len() as u32;
                let mut bounds = [start; 3];
                // both samples' stencils, or neither
                let [near, far] = SAMPLE_DISTANCES.map(|d| (piece.centre + d * piece.normal).to_array());
                sample.clear();
                let found_near = fluid.sample_stencil_into(near, &mut sample);
                let split = sample.len() as u32;
                if found_near && fluid.sample_stencil_into(far, &mut sample) {
                    bounds = [start, start + split, start + sample.len() as u32];
                    plan.stencil.extend(sample.iter().map(|&(n, w)| (n as u32, w)));
                } else {
                    plan.pieces_without_fluid += 1;
                }
                let (ka, kb, t) = (piece.ka, piece.kb, piece.t);
                plan.pieces.push(PlanPiece {
                    normal: piece.normal,
                    tangent: piece.edge / piece.length,
                    wall_velocity: v[ka].lerp(v[kb], t),
                    dvds: (v[kb] - v[ka]) / piece.length,
                    area: piece.area,
                    stencil: bounds,
                });
                loads.push((s.particles[ka] as u32, k, 1.0 - t));
                loads.push((s.particles[kb] as u32, k, t));
            }
            plan.surfaces.push(first..plan.pieces.len());
        }
        plan.particles = p.len();
        // by particle, ascending; a stable sort keeps each particle's shares in the pieces'
        // order (as pushed)
        loads.sort_by_key(|l| l.0);
        for run in loads.chunk_by(|a, b| a.0 == b.0) {
            let from = plan.shares.len() as u32;
            plan.shares.extend(run.iter().map(|&(_, k, w)| (k, w)));
            plan.targets.push((run[0].0, from..plan.shares.len() as u32));
        }
        plan
    }

    /// The fluid nodes the stencils read, ascending, each once (what
    /// [`super::traction::sampled_nodes`] lists, without finding the stencils again).
    pub fn read_nodes(&self) -> Vec<u32> {
        let mut nodes: Vec<u32> = self.stencil.iter().map(|&(n, _)| n).collect();
        nodes.sort_unstable();
        nodes.dedup();
        nodes
    }

    /// Each piece's force (physical units per unit depth) from the air of `fluid` (the solver
    /// the plan was made for): the samples at one and two cells along N (the stencils' weighted
    /// moments), the wall values extrapolated from them and the traction of [`Self::model`]
    /// times the piece's area (see [`super::traction`] for the formulas); zero for a piece with
    /// no fluid within reach. The moments and the pieces are each independent: found on the
    /// pool's threads, in order (the same numbers as one by one).
    pub fn piece_forces(&self, fluid: &FluidSolver) -> Vec<DVec3> {
        // Each sampled node's moments once: neighbouring pieces' stencils share most of their
        // nodes (on the 2D glottis scenes 2,242 stencil entries read 430 nodes, 4,762 read 868),
        // and a node's moments are the same values however often they are asked for.
        let nodes = self.read_nodes();
        let moments: Vec<Macro> = nodes.par_iter().with_min_len(PAR_PIECES).map(|&n| fluid.macro_at(n as usize)).collect();
        let sample = |r: Range<u32>| {
            let mut m = Macro::default();
            for &(node, w) in &self.stencil[r.start as usize..r.end as usize] {
                let mk = &moments[nodes.binary_search(&node).expect("a node of the stencils")];
                m.rho += w * mk.rho;
                m.theta += w * mk.theta;
                for a in 0..3 {
                    m.u[a] += w * mk.u[a];
                }
            }
            m
        };
        self.pieces
            .par_iter()
            .with_min_len(PAR_PIECES)
            .map(|pc| {
                if pc.stencil[0] == pc.stencil[2] {
                    return DVec3::ZERO;
                }
                let (m1, m2) = (sample(pc.stencil[0]..pc.stencil[1]), sample(pc.stencil[1]..pc.stencil[2]));
                let (normal, vw) = (pc.normal, pc.wall_velocity);
                let pw = 2.0 * m1.pressure() - m2.pressure() - self.p0;
                let (u1, u2) = (DVec3::from_array(m1.u), DVec3::from_array(m2.u));
                let traction = match self.model {
                    TractionModel::SeedPressure => {
                        let vn = (u1 - vw).dot(normal);
                        -(pw + 0.5 * m1.rho * vn * vn) * normal
                    }
                    TractionModel::PressureAndShear => {
                        // ∇u at the wall: along the surface, the wall's own derivative ∂v_w/∂s;
                        // along the normal, the sampled ∂u/∂n for the tangential part and, for
                        // the normal part, continuity at the wall (∂u_n/∂n = −∂v_w/∂s·T): the
                        // one-sided estimate of ∂u_n/∂n is noise where the flow decelerates
                        // within a cell or two (a stagnation point).
                        let sampled = (4.0 * (u1 - vw) - (u2 - vw)) * 0.5;
                        let (dvds, tangent) = (pc.dvds, pc.tangent);
                        let dudn = sampled - sampled.dot(normal) * normal - dvds.dot(tangent) * normal;
                        let g = DMat3::from_cols(dudn * normal.x + dvds * tangent.x, dudn * normal.y + dvds * tangent.y, DVec3::ZERO);
                        let div = g.x_axis.x + g.y_axis.y;
                        let rho_w = 2.0 * m1.rho - m2.rho;
                        let theta_w = 2.0 * m1.theta - m2.theta;
                        let mu = rho_w * theta_w * self.relaxation;
                        // σ' = μ (∇u + ∇uᵀ − (2/D) ∇·u I): the BGK gas has no bulk viscosity.
                        let viscous = mu * ((g + g.transpose()) * normal - (2.0 / self.dim as f64) * div * normal);
                        -pw * normal + viscous
                    }
                };
                pc.area * traction * self.force_unit
            })
            .collect()
    }

    /// The forces on the particles and the surfaces' totals from the pieces' forces (physical
    /// units; `piece_force[k]` of piece k, e.g. as a device computed them), spread as
    /// `surface_forces` spreads them.
    pub fn forces(&self, piece_force: &[DVec3]) -> SurfaceForces {
        let mut force = vec![DVec3::ZERO; self.particles];
        for (i, r) in &self.targets {
            let own = &self.shares[r.start as usize..r.end as usize];
            force[*i as usize] = own.iter().fold(DVec3::ZERO, |f, &(k, w)| f + w * piece_force[k as usize]);
        }
        let total = self.surfaces.iter().map(|r| piece_force[r.clone()].iter().fold(DVec3::ZERO, |a, &f| a + f)).collect();
        SurfaceForces { force, total, pieces: self.pieces.len(), pieces_without_fluid: self.pieces_without_fluid }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coupling::surface::ReferenceShape;
    use crate::coupling::traction::sampled_nodes;
    use crate::fluid::*;
    use crate::solid::particles::sample_ball;

    /// A moving, spinning disc in a sheared, compressed box: the plan reads exactly the nodes
    /// `sampled_nodes` lists, every surface particle takes the shares of its two edges, and the
    /// spread is exact — the particles receive the pieces' forces to round-off, per surface.
    #[test]
    fn the_plan_reads_the_sampled_nodes_and_spreads_every_piece() {
        let units = Units::new(0.01, 1.0e-3, 3.0e4, 0.6, 2.0);
        let (c, r, l0) = (DVec3::new(0.20, 0.20, 0.0), 0.08, 0.004);
        let mut p = Particles::new(2, l0);
        for x in sample_ball(2, c, r, l0) {
            p.push(x, 1.0, 0, 0, false);
        }
        for i in 0..p.len() {
            let d = p.position[i] - c;
            p.velocity[i] = DVec3::new(30.0 - 400.0 * d.y, 10.0 + 400.0 * d.x, 0.0);
            p.spin[i] = DVec3::new(0.0, 0.0, 400.0);
        }
        let surface = BodySurface::build(&p, 0, &ReferenceShape::Disc { centre: c, radius: r }).unwrap();
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let params = timestep::choose(0.05, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        let x: Vec<[f64; 2]> = surface.points(&p).iter().map(|x| [units.position_to_lattice(x.x), units.position_to_lattice(x.y)]).collect();
        let n = x.len();
        let poly = Obstacle { shape: Shape::Polygon(Polygon::new(x, vec![[0.0; 3]; n])), velocity: [0.0; 3], temperature: None };
        let fluid = FluidSolver::new(eq, Grid::new(2, [40, 40, 1]), Boundaries::periodic(), &[poly], params, |x| Macro {
            rho: 1.0 + 1e-3 * (x[1] - 20.0) + 5e-4 * (0.3 * x[0]).sin(),
            u: [0.02 * (0.2 * x[1]).sin(), 0.01 * (0.25 * x[0]).cos(), 0.0],
            theta: 0.6 + 0.002 * (0.2 * x[0] + 0.1 * x[1]).cos(),
        });
        for model in [TractionModel::PressureAndShear, TractionModel::SeedPressure] {
            let plan = TractionPlan::new(&fluid, &units, std::slice::from_ref(&surface), &p, model, 1.0);
            assert!(plan.pieces.len() > 100 && plan.pieces_without_fluid == 0, "{} pieces", plan.pieces.len());
            let read: Vec<usize> = plan.read_nodes().into_iter().map(|n| n as usize).collect();
            assert_eq!(read, sampled_nodes(&fluid, &units, std::slice::from_ref(&surface), &p, 1.0));
            assert_eq!(plan.targets.len(), surface.particles.len());
            assert!(plan.targets.iter().all(|(_, r)| r.end - r.start >= 2), "each surface particle shares two edges' pieces");
            let pf = plan.piece_forces(&fluid);
            let f = plan.forces(&pf);
            let spread: DVec3 = f.force.iter().copied().sum();
            let scale = pf.iter().map(|f| f.length()).sum::<f64>();
            assert!(scale > 0.0);
            assert!((spread - f.total[0]).length() < 1e-13 * scale, "{model:?}: {spread} vs {}", f.total[0]);
        }
    }
}
