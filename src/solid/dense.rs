//! Dense symmetric positive definite factorisation for the preconditioner's small blocks
//! (the coarse matrices and their diagonal blocks).

use rayon::prelude::*;

/// In-place dense Cholesky A = L Lᵀ (row-major m × m; the lower triangle becomes L); false when a
/// pivot is not positive (A not positive definite to round-off).
pub fn cholesky(a: &mut [f64], m: usize) -> bool {
    for j in 0..m {
        let d = a[j * m + j] - (0..j).map(|k| a[j * m + k] * a[j * m + k]).sum::<f64>();
        if d.is_nan() || d <= 1e-14 * a[j * m + j].abs() {
            return false;
        }
        let d = d.sqrt();
        a[j * m + j] = d;
        let (head, tail) = a.split_at_mut((j + 1) * m);
        let row_j = &head[j * m..j * m + j];
        let update = |row_i: &mut [f64]| {
            let s: f64 = row_i[..j].iter().zip(row_j).map(|(x, y)| x * y).sum();
            row_i[j] = (row_i[j] - s) / d;
        };
        // the rows below j in parallel where there are enough of them to pay for it
        if m >= 256 {
            tail.par_chunks_mut(m).for_each(update);
        } else {
            tail.chunks_mut(m).for_each(update);
        }
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
