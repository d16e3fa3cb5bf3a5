//! Tests of the solver's step: the advection's sweep order and the memory hints.

use super::{MemoryHints, advect_order};
use crate::fluid::VelocitySetKind;
use crate::fluid::fixtures::busy_lattice as busy_scene;
use crate::fluid::storage::Storage;

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
