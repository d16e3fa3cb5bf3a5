//! Tests of the implicit step's preconditioner layouts on the benchmark blocks.
use super::*;
use crate::solid::bench::benchmark_block;

/// The block-sparse coarse space with its third level (what a body beyond ~3·10⁴ particles
/// gets) against the dense one on the same aggregates, on the 20³ benchmark block at 10×
/// the explicit step (aggregates one reach, 6.3 spacings, wide: 52 of them — 4³ less those
/// that hold only the clamped face — 624 unknowns): the probed A_c is the same matrix to
/// round-off, and the implicit steps take the same number of CG iterations (measured
/// 2026-12-04: 31, 30, 32 both ways) to the same motion (10⁻¹¹ of it). The dense A_c⁻¹ that
/// the GPU applies (`CoarseSpace::dense_inverse`) inverts either: ‖A_c A_c⁻¹ − I‖_max 1.8·10⁻¹⁴
/// both ways (2026-12-06), asserted < 10⁻⁹ (cond(A_c) times f64's round-off, with room).
#[test]
fn the_sparse_coarse_space_with_a_third_level_steps_like_the_dense_one() {
    let base = benchmark_block(20, Integrator::Implicit);
    let side = 3.0 * base.disc.bonds.radius * (1.0 + 1e-6);
    let dense = base.probe_coarse_space(Some((side, false))).expect("dense A_c positive definite");
    let sparse = base.probe_coarse_space(Some((side, true))).expect("sparse A_c positive definite");
    assert!(sparse.is_inexact() && !dense.is_inexact());
    let (a, b) = (dense.matrix(), sparse.matrix());
    let m = dense.unknowns();
    assert_eq!(m, sparse.unknowns());
    println!("{m} coarse unknowns, aggregates {:.3} wide", dense.side);
    let scale = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let diff = a.iter().zip(&b).fold(0.0f64, |s, (x, y)| s.max((x - y).abs()));
    println!("A_c dense against block-sparse: {:.1e} of the largest entry", diff / scale);
    assert!(diff <= 1e-12 * scale, "{diff:e} of {scale:e}");
    // the dense A_c⁻¹ the GPU applies: from the dense factor, or the block-sparse A_c assembled
    // and factorised; A_c A_c⁻¹ = I to round-off times A_c's condition
    for (c, a) in [(&dense, &a), (&sparse, &b)] {
        let inverse = c.dense_inverse().expect("A_c factorises");
        let worst = (0..m)
            .into_par_iter()
            .map(|p| {
                (0..m).map(|q| ((0..m).map(|s| a[p * m + s] * inverse[s * m + q]).sum::<f64>() - if p == q { 1.0 } else { 0.0 }).abs()).fold(0.0, f64::max)
            })
            .reduce(|| 0.0, f64::max);
        println!("A_c A_c⁻¹ − I ({}): {worst:.1e}", if c.is_inexact() { "sparse" } else { "dense" });
        assert!(worst < 1e-9, "{worst:e}");
    }
    let run = |coarse: CoarseSpace| {
        let mut s = base.clone();
        s.coarse = Some(Some(coarse));
        s.prepare_preconditioner();
        let its: Vec<usize> = (0..3)
            .map(|_| {
                s.step().unwrap();
                assert!(s.last.cg.converged, "{:?}", s.last.cg);
                s.last.cg.iterations
            })
            .collect();
        (its, s.particles.position.clone())
    };
    let (id, xd) = run(dense);
    let (is, xs) = run(sparse);
    let moved = xd.iter().zip(&base.particles.reference).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    let gap = xd.iter().zip(&xs).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    println!("CG iterations: dense {id:?}, sparse with a third level {is:?}; positions differ by {:.1e} of the motion", gap / moved);
    for (d, s) in id.iter().zip(&is) {
        assert!(s.abs_diff(*d) <= 1, "dense {id:?} against sparse {is:?}");
    }
    assert!(gap <= 1e-6 * moved, "{gap:e} of {moved:e}");
}

/// The patches split each axis of the body into whole patches of 2–4 layers: a block whose
/// side is not a multiple of 3 no longer ends in a one-layer patch at its faces, which took
/// the patch smoother up to twice the iterations (before, patches alone on 16³: 80 against
/// 40 on 24³). Patches alone (no coarse space), one implicit system each on 13³, 14³, 15³
/// (the three remainders): measured 2026-12-04, 39, 39 and 40 iterations (patches of 27–48,
/// 12–36 and 18–27 particles).
#[test]
fn patches_have_no_thin_remainder_whatever_the_side_of_the_block() {
    let mut counts = Vec::new();
    for side in [13, 14, 15] {
        let mut s = benchmark_block(side, Integrator::Implicit);
        s.coarse = Some(None);
        let pj = PatchJacobi::new(&s.disc, &s.particles, s.dt);
        let sizes: Vec<usize> = (0..pj.patches()).map(|q| pj.members(q).len()).collect();
        let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
        s.step().unwrap();
        assert!(s.last.cg.converged, "{:?}", s.last.cg);
        println!("{side}³: {} patches of {lo}–{hi} particles, {} CG iterations", pj.patches(), s.last.cg.iterations);
        assert!(*lo >= 8 && *hi <= 64, "{side}³: patches of {lo}–{hi} particles");
        counts.push(s.last.cg.iterations);
    }
    let (lo, hi) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
    assert!(*hi as f64 <= 1.25 * *lo as f64, "patches alone: {counts:?} CG iterations on 13³, 14³, 15³");
}
