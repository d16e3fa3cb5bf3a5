//! Small lattices shared by the fluid's tests and the GPU parity tests (tests/gpu/): one
//! definition, so that a CPU test and its GPU twin step the same scene.

use crate::fluid::boundary::{Boundaries, FaceCondition};
use crate::fluid::storage::Storage;
use crate::fluid::{Equilibrium, FluidSolver, GasModel, Grid, KernelLevelSet, Macro, Obstacle, Polygon, Shape, VelocitySet, VelocitySetKind, timestep};

/// A small lattice with walls (y), a moving lid, an obstacle centred at x = `obstacle_x`, a body
/// force and a diatomic gas, periodic along x (and z), its populations stored as `S`: every kind
/// of node the step fills (ghosts, face halos, periodic copies) in a few hundred nodes.
pub fn busy_lattice<S: Storage>(kind: VelocitySetKind, n: [usize; 3], obstacle_x: f64) -> FluidSolver<S> {
    let vs = VelocitySet::new(kind);
    let dim = vs.dim;
    let params = timestep::choose(0.02, 0.6, vs.max_l1_speed(), None, 0.8).unwrap();
    let mut b = Boundaries::periodic();
    b.faces[2] = FaceCondition::Wall { velocity: [0.0; 3], temperature: Some(0.6) };
    b.faces[3] = FaceCondition::Wall { velocity: [0.04, 0.0, 0.01], temperature: None };
    let centre = [obstacle_x, 4.3, if dim == 3 { 2.6 } else { 0.0 }];
    let shape = if dim == 3 { Shape::Sphere { center: centre, radius: 1.7 } } else { Shape::Cylinder { center: centre, radius: 1.7 } };
    let obstacle = Obstacle { shape, velocity: [0.0; 3], temperature: None };
    let k = 2.0 * std::f64::consts::PI / n[0] as f64;
    let mut s = FluidSolver::<S>::with_storage(Equilibrium::new(vs, GasModel::Diatomic), Grid::new(dim, n), b, &[obstacle], params, move |x| Macro {
        rho: 1.0 + 0.01 * (k * x[0]).sin(),
        u: [0.03 * (0.5 * x[1]).cos(), 0.02 * (k * x[0]).sin(), 0.01 * (k * x[2]).cos()],
        theta: 0.6,
    });
    s.body_force = [2e-5, 0.0, -1e-5];
    s
}

/// A 24 × 32 D2Q21 channel at rest (pressure inlet at y = 0 at 5 % over the rest density, outlet
/// at the top, side walls) closed by a plate of `thickness` cells across its whole width, centred
/// between the node rows 16 and 17 (thickness 2: both rows solid) or on row 16 (thickness 1),
/// with `more` obstacles besides: the thin walls' leak tests and their GPU twin.
pub fn closed_channel(gas: GasModel, thickness: usize, more: &[Obstacle]) -> FluidSolver {
    let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), gas);
    let params = timestep::choose(0.05, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
    let mut b = Boundaries::periodic();
    b.faces[0] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
    b.faces[1] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
    b.faces[2] = FaceCondition::PressureInlet { rho: 1.05, theta: 0.6 };
    b.faces[3] = FaceCondition::Outlet;
    let (y0, y1) = if thickness == 2 { (15.6, 17.4) } else { (15.6, 16.4) };
    let plate = Polygon::new(vec![[-5.0, y0], [30.0, y0], [30.0, y1], [-5.0, y1]], vec![[0.0; 3]; 4]);
    let mut obstacles = vec![Obstacle { shape: Shape::Polygon(plate), velocity: [0.0; 3], temperature: None }];
    obstacles.extend_from_slice(more);
    FluidSolver::new(eq, Grid::new(2, [24, 32, 1]), b, &obstacles, params, |_| Macro { rho: 1.0, u: [0.0; 3], theta: 0.6 })
}

/// The ghost-like nodes of the level set `s` in the box of lattice nodes `lo..=hi`: nodes
/// inside (L > 0) with a node outside (L ≤ 0) within two cells along an axis, each with the
/// nearest such node (±1 before ±2, x before y before z), as the layout picks the fluid node
/// that makes a node a ghost — the queries of `KernelLevelSet::ghost_wall` and of its GPU twin.
pub fn level_set_ghosts(s: &KernelLevelSet, dim: usize, lo: [i64; 3], hi: [i64; 3]) -> Vec<([f64; 3], [f64; 3])> {
    let pos = |x: [i64; 3]| [x[0] as f64, x[1] as f64, x[2] as f64];
    let inside = |x: [i64; 3]| s.level(pos(x)).0 > 0.0;
    let mut out = Vec::new();
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                let p = [x, y, z];
                if !inside(p) {
                    continue;
                }
                let q = [1i64, 2].iter().find_map(|&d| {
                    (0..dim).flat_map(|a| [-d, d].map(move |sh| (a, sh))).find_map(|(a, sh)| {
                        let mut q = p;
                        q[a] += sh;
                        (!inside(q)).then_some(q)
                    })
                });
                if let Some(q) = q {
                    out.push((pos(p), pos(q)));
                }
            }
        }
    }
    out
}
