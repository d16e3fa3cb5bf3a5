//! Dense symmetric positive definite factorisation for the preconditioner's small blocks
//! (the coarse matrices and their diagonal blocks).

use rayon::prelude::*;

/// Columns factorised together by [`cholesky`].
const CHOLESKY_BLOCK: usize = 16;

/// In-place dense Cholesky A = L Lᵀ (row-major m × m; the lower triangle becomes L); false when a
/// pivot is not positive (A not positive definite to round-off).
///
/// Left-looking, every entry L_ij = (A_ij − Σ_{k<j} L_ik L_jk) / L_jj summed in the order k = 0, 1,
/// …, by blocks of [`CHOLESKY_BLOCK`] columns: the block's own rows first, then each row below
/// (rows on the pool's threads) runs the block's sums over the columns before it side by side —
/// one read of the row for the block, independent sums in flight — and finishes each over the
/// block's columns in order. The same additions in the same order as column by column, so the
/// same factor bit for bit (test `the_blocked_factor_is_the_column_by_column_one_bit_for_bit`). On
/// 2 cores the 46³ benchmark block's A_c (m = 5568) assembled, factorised and inverted
/// ([`super::coarse::CoarseSpace::dense_inverse`]) took 26.1 s column by column, 17.6 s so.
pub fn cholesky(a: &mut [f64], m: usize) -> bool {
    let mut j0 = 0;
    while j0 < m {
        let j1 = (j0 + CHOLESKY_BLOCK).min(m);
        for j in j0..j1 {
            let d = a[j * m + j] - (0..j).map(|k| a[j * m + k] * a[j * m + k]).sum::<f64>();
            if d.is_nan() || d <= 1e-14 * a[j * m + j].abs() {
                return false;
            }
            let d = d.sqrt();
            a[j * m + j] = d;
            for i in j + 1..j1 {
                let s: f64 = (0..j).map(|k| a[i * m + k] * a[j * m + k]).sum();
                a[i * m + j] = (a[i * m + j] - s) / d;
            }
        }
        let (head, tail) = a.split_at_mut(j1 * m);
        let block = &head[j0 * m..j1 * m];
        let w = j1 - j0;
        let update = |row: &mut [f64]| {
            // `Sum` for f64 starts from −0.0: so do these
            let mut acc = [-0.0f64; CHOLESKY_BLOCK];
            for k in 0..j0 {
                let x = row[k];
                for c in 0..w {
                    acc[c] += x * block[c * m + k];
                }
            }
            for c in 0..w {
                let j = j0 + c;
                let mut s = acc[c];
                for k in j0..j {
                    s += row[k] * block[c * m + k];
                }
                row[j] = (row[j] - s) / block[c * m + j];
            }
        };
        // the rows below the block in parallel where there are enough of them to pay for it
        if m >= 256 {
            tail.par_chunks_mut(m).for_each(update);
        } else {
            tail.chunks_mut(m).for_each(update);
        }
        j0 = j1;
    }
    true
}

/// [`cholesky`] of a matrix symmetric in exact arithmetic, each pair of mirror entries first
/// replaced by their mean (against round-off).
pub fn symmetrised_cholesky(a: &mut [f64], m: usize) -> bool {
    for p in 0..m {
        for q in 0..p {
            let s = 0.5 * (a[p * m + q] + a[q * m + p]);
            a[p * m + q] = s;
            a[q * m + p] = s;
        }
    }
    cholesky(a, m)
}

/// Solves L Lᵀ u = b in place (`l` from [`cholesky`], m × m): forward, then backward substitution.
pub fn cholesky_solve(l: &[f64], m: usize, u: &mut [f64]) {
    for p in 0..m {
        let s: f64 = (0..p).map(|q| l[p * m + q] * u[q]).sum();
        u[p] = (u[p] - s) / l[p * m + p];
    }
    for p in (0..m).rev() {
        let s: f64 = (p + 1..m).map(|q| l[q * m + p] * u[q]).sum();
        u[p] = (u[p] - s) / l[p * m + p];
    }
}

/// Σ aₖ bₖ over the shorter of the two, in eight running sums (independent: they pipeline, and the
/// compiler can vectorise them). Rounded differently from one running sum, so for new code only:
/// [`cholesky`] and [`cholesky_solve`] keep their single sums, which the CPU's trajectories depend
/// on bit for bit.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f64 = ca.remainder().iter().zip(cb.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// Columns handled together by [`cholesky_inverse`]: each row of L (or of L⁻¹) read from memory
/// serves this many of them while it is in cache.
const INVERSE_BLOCK: usize = 16;

/// A⁻¹ (row-major m × m, symmetric) from the Cholesky factor L of A ([`cholesky`]): L⁻¹ column by
/// column (forward substitution of the unit vectors, each from its own row down), then
/// A⁻¹ = L⁻ᵀ L⁻¹ — the order of LAPACK's `dpotri` (`dtrtri`, then `dlauum`): ≈ m³/3
/// multiply-adds, where solving the m unit columns through L Lᵀ takes ≈ m³ and reads Lᵀ across
/// its rows. Every inner product runs over contiguous memory, [`INVERSE_BLOCK`] columns share
/// each row read, blocks on the pool's threads. (m = 5568, the largest dense coarse space: 2 cores
/// took 428 s by the unit columns, 8 s so.)
pub fn cholesky_inverse(l: &[f64], m: usize) -> Vec<f64> {
    // x[q·m + p] = (L⁻¹)[p][q] for p ≥ q (zero above): L x_q = e_q, from row q down
    let mut x = vec![0.0; m * m];
    x.par_chunks_mut(m * INVERSE_BLOCK).enumerate().for_each(|(b, cols)| {
        let q0 = b * INVERSE_BLOCK;
        let width = cols.len() / m;
        for p in q0..m {
            let row = &l[p * m..p * m + p];
            for c in 0..width.min(p - q0 + 1) {
                let q = q0 + c;
                let col = &mut cols[c * m..(c + 1) * m];
                col[p] = if p == q { 1.0 / l[p * m + p] } else { -dot(&row[q..p], &col[q..p]) / l[p * m + p] };
            }
        }
    });
    // (A⁻¹)[i][j] = Σ_{p ≥ max(i, j)} (L⁻¹)[p][i] (L⁻¹)[p][j]: the lower triangle by blocks of
    // rows, then mirrored
    let mut inv = vec![0.0; m * m];
    inv.par_chunks_mut(m * INVERSE_BLOCK).enumerate().for_each(|(b, rows)| {
        let i0 = b * INVERSE_BLOCK;
        let height = rows.len() / m;
        for j in 0..i0 + height {
            let xj = &x[j * m..(j + 1) * m];
            for r in j.saturating_sub(i0)..height {
                let i = i0 + r;
                let k = i.max(j);
                rows[r * m + j] = dot(&x[i * m + k..(i + 1) * m], &xj[k..]);
            }
        }
    });
    for i in 0..m {
        for j in 0..i {
            inv[j * m + i] = inv[i * m + j];
        }
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A symmetric positive definite m × m matrix: BᵀB/m + I with B pseudo-random in [−1, 1).
    fn spd(m: usize, seed: u64) -> Vec<f64> {
        let b = crate::analysis::synthetic::uniform_noise(seed, m * m);
        let mut a = vec![0.0; m * m];
        a.par_chunks_mut(m).enumerate().for_each(|(i, row)| {
            for j in 0..m {
                row[j] = (0..m).map(|k| b[k * m + i] * b[k * m + j]).sum::<f64>() / m as f64 + if i == j { 1.0 } else { 0.0 };
            }
        });
        a
    }

    /// The inverse from L⁻ᵀ L⁻¹ against the unit columns solved through L Lᵀ (the way it was
    /// formed before) and against A itself: A A⁻¹ = I to round-off, exactly symmetric; sizes on
    /// and off the block and the vector width, one smaller than a block.
    #[test]
    fn the_inverse_from_the_factor_is_the_inverse() {
        for (m, seed) in [(1, 1), (7, 2), (16, 3), (37, 4), (203, 5)] {
            let a = spd(m, seed);
            let mut l = a.clone();
            assert!(cholesky(&mut l, m));
            let inv = cholesky_inverse(&l, m);
            let mut worst_solved: f64 = 0.0;
            for q in 0..m {
                let mut col = vec![0.0; m];
                col[q] = 1.0;
                cholesky_solve(&l, m, &mut col);
                for p in 0..m {
                    worst_solved = worst_solved.max((inv[p * m + q] - col[p]).abs());
                    assert_eq!(inv[p * m + q].to_bits(), inv[q * m + p].to_bits());
                }
            }
            let mut worst_identity: f64 = 0.0;
            for i in 0..m {
                for j in 0..m {
                    let e = dot(&a[i * m..(i + 1) * m], &(0..m).map(|k| inv[k * m + j]).collect::<Vec<_>>());
                    worst_identity = worst_identity.max((e - if i == j { 1.0 } else { 0.0 }).abs());
                }
            }
            // A = BᵀB/m + I has eigenvalues in [1, ~5]: round-off of order m ε
            assert!(worst_solved < 1e-13 && worst_identity < 1e-13, "m = {m}: against the solved columns {worst_solved:.2e}, A A⁻¹ − I {worst_identity:.2e}");
        }
    }

    /// The factor as it was computed before the blocking, column by column (for the test below).
    fn cholesky_by_columns(a: &mut [f64], m: usize) -> bool {
        for j in 0..m {
            let d = a[j * m + j] - (0..j).map(|k| a[j * m + k] * a[j * m + k]).sum::<f64>();
            if d.is_nan() || d <= 1e-14 * a[j * m + j].abs() {
                return false;
            }
            let d = d.sqrt();
            a[j * m + j] = d;
            let (head, tail) = a.split_at_mut((j + 1) * m);
            let row_j = &head[j * m..j * m + j];
            for row_i in tail.chunks_mut(m) {
                let s: f64 = row_i[..j].iter().zip(row_j).map(|(x, y)| x * y).sum();
                row_i[j] = (row_i[j] - s) / d;
            }
        }
        true
    }

    /// The blocked factor against the column-by-column one, every entry of the lower triangle
    /// bit for bit: sizes below, at and across a block and the parallel threshold, dense matrices
    /// and ones with exact zero blocks (as a coarse matrix has: aggregates out of each other's
    /// reach), so exact zeros in the factor; and the same refusal of a matrix that is not
    /// positive definite.
    #[test]
    fn the_blocked_factor_is_the_column_by_column_one_bit_for_bit() {
        for (m, seed) in [(1, 1), (15, 2), (16, 3), (17, 4), (40, 5), (300, 6)] {
            for zero_blocks in [false, true] {
                let mut a = spd(m, seed);
                if zero_blocks {
                    // keep the 6 × 6 diagonal blocks' band and the identity: still positive definite
                    for i in 0..m {
                        for j in 0..m {
                            if i / 6 != j / 6 && (i / 6).abs_diff(j / 6) != 1 {
                                a[i * m + j] = if i == j { 1.0 } else { 0.0 };
                            }
                        }
                    }
                    for i in 0..m {
                        a[i * m + i] += 2.0;
                    }
                }
                let (mut blocked, mut columns) = (a.clone(), a.clone());
                assert_eq!(cholesky(&mut blocked, m), cholesky_by_columns(&mut columns, m), "m = {m}");
                for i in 0..m {
                    for j in 0..=i {
                        assert_eq!(blocked[i * m + j].to_bits(), columns[i * m + j].to_bits(), "m = {m}, zero blocks {zero_blocks}, ({i}, {j})");
                    }
                }
            }
        }
        // not positive definite: refused by both
        let m = 40;
        let mut a = spd(m, 7);
        a[33 * m + 33] = -1.0;
        assert!(!cholesky(&mut a.clone(), m) && !cholesky_by_columns(&mut a, m));
    }

    /// The eight running sums against one, on lengths around the vector width.
    #[test]
    fn the_vectorised_dot_product_sums_every_term() {
        for n in [0usize, 1, 7, 8, 9, 15, 16, 17, 100] {
            let a: Vec<f64> = (0..n).map(|k| 1.0 + k as f64).collect();
            let b: Vec<f64> = (0..n).map(|k| 2.0 - 0.5 * k as f64).collect();
            let exact: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
            assert_eq!(dot(&a, &b), exact, "n = {n}"); // small integers and halves: exact in any order
            assert_eq!(dot(&a, &b[..n.saturating_sub(1)]), a.iter().zip(&b[..n.saturating_sub(1)]).map(|(x, y)| x * y).sum::<f64>());
        }
    }
}
