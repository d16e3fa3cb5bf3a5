//! Tests of the solver's step: the advection's sweep order and the memory hints.

use super::{MemoryHints, advect_order};
use crate::fluid::boundary::{Boundaries, FaceCondition};
use crate::fluid::storage::Storage;
use crate::fluid::{Equilibrium, FluidSolver, GasModel, Grid, Macro, Obstacle, Shape, VelocitySet, VelocitySetKind, timestep};

/// A small lattice with walls (y), a moving lid, an obstacle centred at x = `obstacle_x`, a
/// body force and a diatomic gas, periodic along x (and z), its populations stored as `S`.
pub(crate) fn busy_scene<S: Storage>(kind: VelocitySetKind, n: [usize; 3], obstacle_x: f64) -> FluidSolver<S> {
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

/// The streaming stores of the moments–collision pass and the rows fetched ahead change
/// when bytes move, not what they are: 12 steps with and without them leave fⁿ,
/// the stage arrays and the macroscopic fields the same to the bit (2D and 3D, f64 and f32
/// storage; rows of 18–40 values, so the streaming path's head, 16-byte and tail stores all
/// run).
#[test]
fn the_memory_hints_change_no_bit() {
    fn same<S: Storage>(kind: VelocitySetKind, n: [usize; 3]) {
        let (mut plain, mut streamed) = (busy_scene::<S>(kind, n, 4.2), busy_scene::<S>(kind, n, 4.2));
        let none = MemoryHints { streaming_stores: false, prefetch_rows: false };
        assert_eq!(plain.memory_hints(), none, "a lattice this small fits the cache");
        streamed.set_memory_hints(MemoryHints { streaming_stores: true, prefetch_rows: true });
        plain.run(12).unwrap();
        streamed.run(12).unwrap();
        let bits = |a: &[S], b: &[S]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.load().to_bits() == y.load().to_bits());
        assert!(bits(&plain.f, &streamed.f), "{kind:?}: fⁿ");
        for (k, (a, b)) in plain.stage_arrays_stored().into_iter().zip(streamed.stage_arrays_stored()).enumerate() {
            assert!(bits(a, b), "{kind:?}: stage array {k} (f¹, fⁿ⁺¹, h)");
        }
        assert!(plain.mac.iter().zip(&streamed.mac).all(|(a, b)| a.to_bits() == b.to_bits()), "{kind:?}: macroscopic fields");
        assert!(plain.f.iter().any(|x| x.load() != 0.0));
    }
    same::<f64>(VelocitySetKind::D2q21, [15, 10, 1]);
    same::<f64>(VelocitySetKind::D3q39, [9, 8, 6]);
    same::<f32>(VelocitySetKind::D2q21, [15, 10, 1]);
    same::<f32>(VelocitySetKind::D3q39, [9, 8, 6]);
}

#[test]
fn the_advection_sweeps_every_row_once_in_slabs() {
    for (row_bytes, py, pz) in [(32_000, 102, 102), (1 << 20, 7, 5), (8, 134, 1), (100, 3, 2)] {
        let order = advect_order(row_bytes, py, pz);
        let mut seen = vec![false; py * pz];
        for &r in &order {
            assert!(!std::mem::replace(&mut seen[r as usize], true), "row {r} twice");
        }
        assert!(seen.iter().all(|&s| s), "{py}×{pz}: a row left out");
    }
    // 32 000-byte rows: slabs of 6 rows (5 planes × 6 rows × 32 kB ≈ 1 MiB); z runs inside a slab
    let order = advect_order(32_000, 102, 102);
    assert_eq!(&order[..7], &[0, 1, 2, 3, 4, 5, 102]);
}
