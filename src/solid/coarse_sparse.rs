//! The coarse problem of a large body: A_c block-sparse and solved by an inner preconditioned
//! conjugate-gradient loop with a third level.
//!
//! The aggregates of [`super::coarse`] must stay a few particle spacings wide for the
//! two-level preconditioner to keep its iteration count (measured on the benchmark blocks at 10×
//! the explicit step: aggregates of 4–6 spacings, 27–34 iterations; 18 spacings at 10⁶
//! particles, 76–81). A dense A_c of ≤ [`super::coarse::MAX_UNKNOWNS`] unknowns cannot hold
//! that many aggregates once the body passes ~3·10⁴ particles, so beyond it A_c is kept
//! block-sparse: aggregates no narrower than A's reach couple only to their 3^dim neighbours,
//! one block of ≤ 12 × 12 per pair (≈ 130 MB at 10⁶ particles). A_c u = g is then solved to
//! [`INNER_TOLERANCE`] by conjugate gradients preconditioned with the inverses of A_c's diagonal
//! blocks plus a third level: groups of aggregates whose affine motions span Q, with
//! A₂ = Qᵀ A_c Q dense and Cholesky-factorised — the same two-level construction one level
//! down. The outer solve treats the result as a (slightly) varying preconditioner: flexible
//! conjugate gradients ([`super::implicit::conjugate_gradient`]).

use super::dense::{cholesky, cholesky_solve};
use rayon::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Relative residual the inner solve reaches on A_c u = g. Measured on the 46³ benchmark block
/// at 10× the explicit step (aggregates 6.3 spacings wide, 5568 coarse unknowns, one implicit
/// system to 10⁻⁸, 2026-12-04): 31 outer iterations at an inner tolerance of 10⁻⁶, 10⁻³ and
/// 10⁻² alike, with 34, 13 and 8 inner iterations per application (6.4, 5.4 and 4.8 s).
pub const INNER_TOLERANCE: f64 = 1e-2;

/// Largest number of inner iterations (the inner problem converges in tens).
const INNER_MAX_ITERATIONS: usize = 500;

/// A block-sparse symmetric matrix on aggregates: aggregate j holds the unknowns
/// `offset[j]..offset[j + 1]`; its row lists its neighbours `col[row[j]..row[j + 1]]` (sorted)
/// and their blocks, row-major (unknowns of j) × (unknowns of the neighbour), from `at[k]`.
#[derive(Clone, Debug)]
pub struct BlockSparse {
    offset: Vec<usize>,
    row: Vec<usize>,
    col: Vec<u32>,
    at: Vec<usize>,
    values: Vec<f64>,
}

impl BlockSparse {
    /// Zero blocks on the pattern `neighbours` (each aggregate's list, its own index included).
    pub fn new(offset: Vec<usize>, neighbours: Vec<Vec<u32>>) -> Self {
        let size = |j: usize| offset[j + 1] - offset[j];
        let (mut row, mut col, mut at) = (vec![0], Vec::new(), Vec::new());
        let mut len = 0;
        for (j, mut list) in neighbours.into_iter().enumerate() {
            list.sort_unstable();
            for i in list {
                at.push(len);
                len += size(j) * size(i as usize);
                col.push(i);
            }
            row.push(col.len());
        }
        Self { offset, row, col, at, values: vec![0.0; len] }
    }

    /// Number of aggregates (block rows).
    pub fn aggregates(&self) -> usize {
        self.row.len() - 1
    }

    /// Number of scalar unknowns.
    pub fn unknowns(&self) -> usize {
        *self.offset.last().expect("one offset per aggregate and the total")
    }

    /// Unknowns of aggregate j.
    pub fn size(&self, j: usize) -> usize {
        self.offset[j + 1] - self.offset[j]
    }

    /// Index of block (j, i) in the pattern, if i neighbours j.
    fn find(&self, j: usize, i: usize) -> Option<usize> {
        let cols = &self.col[self.row[j]..self.row[j + 1]];
        cols.binary_search(&(i as u32)).ok().map(|k| self.row[j] + k)
    }

    /// Entry (unknown e of aggregate j, unknown d of aggregate i); `None` off the pattern.
    pub fn entry_mut(&mut self, j: usize, e: usize, i: usize, d: usize) -> Option<&mut f64> {
        let k = self.find(j, i)?;
        let w = self.size(i);
        Some(&mut self.values[self.at[k] + e * w + d])
    }

    /// Block (j, i) as a row-major slice.
    fn block(&self, k: usize, j: usize) -> &[f64] {
        let len = self.size(j) * self.size(self.col[k] as usize);
        &self.values[self.at[k]..self.at[k] + len]
    }

    /// Replaces each pair of blocks (j, i), (i, j) by the mean of the one and the other's
    /// transpose (symmetric in exact arithmetic; round-off removed).
    pub fn symmetrise(&mut self) {
        for j in 0..self.aggregates() {
            for k in self.row[j]..self.row[j + 1] {
                let i = self.col[k] as usize;
                if i <= j {
                    continue;
                }
                let t = self.find(i, j).expect("the pattern is symmetric");
                let (nj, ni) = (self.size(j), self.size(i));
                for e in 0..nj {
                    for d in 0..ni {
                        let (p, q) = (self.at[k] + e * ni + d, self.at[t] + d * nj + e);
                        let s = 0.5 * (self.values[p] + self.values[q]);
                        self.values[p] = s;
                        self.values[q] = s;
                    }
                }
            }
        }
    }

    /// y = A x (each block row by one thread: the same sums whatever the thread count).
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        let rows: Vec<[f64; 12]> = (0..self.aggregates())
            .into_par_iter()
            .map(|j| {
                let nj = self.size(j);
                let mut acc = [0.0; 12];
                for k in self.row[j]..self.row[j + 1] {
                    let i = self.col[k] as usize;
                    let (b, xi) = (self.block(k, j), &x[self.offset[i]..self.offset[i + 1]]);
                    for (e, a) in acc.iter_mut().enumerate().take(nj) {
                        *a += b[e * xi.len()..(e + 1) * xi.len()].iter().zip(xi).map(|(p, q)| p * q).sum::<f64>();
                    }
                }
                acc
            })
            .collect();
        for (j, r) in rows.iter().enumerate() {
            y[self.offset[j]..self.offset[j + 1]].copy_from_slice(&r[..self.size(j)]);
        }
    }
}

/// The third level: aggregate j's unknowns mapped onto its group's affine modes.
#[derive(Clone, Debug)]
pub struct Groups {
    /// Group of each aggregate.
    pub group: Vec<u32>,
    /// First unknown of each group (and the total at the end).
    pub offset: Vec<usize>,
    /// Per aggregate, Q's block: (unknowns of the aggregate) × (unknowns of its group), row-major.
    pub q: Vec<Vec<f64>>,
}

/// A_c held block-sparse with its inner preconditioner.
#[derive(Clone, Debug)]
pub struct SparseCoarse {
    a: BlockSparse,
    /// Cholesky factors of A_c's diagonal blocks.
    diagonal: Vec<Vec<f64>>,
    groups: Groups,
    /// Cholesky factor of A₂ = Qᵀ A_c Q, row-major.
    factor: Vec<f64>,
    /// Solves so far and their inner iterations, for the diagnostics (shared by clones).
    solves: Arc<[AtomicUsize; 2]>,
}

impl SparseCoarse {
    /// Factorises the diagonal blocks and A₂; `None` when one is not positive definite.
    pub fn new(a: BlockSparse, groups: Groups) -> Option<Self> {
        let n = a.aggregates();
        let mut diagonal = Vec::with_capacity(n);
        for j in 0..n {
            let k = a.find(j, j)?;
            let mut b = a.block(k, j).to_vec();
            if !cholesky(&mut b, a.size(j)) {
                return None;
            }
            diagonal.push(b);
        }
        // A₂ = Σ over blocks (j, i) of Q_jᵀ B_ji Q_i, added at (group of j, group of i)
        let m2 = *groups.offset.last()?;
        let mut a2 = vec![0.0; m2 * m2];
        for j in 0..n {
            let gj = groups.group[j] as usize;
            let (nj, wj, oj) = (a.size(j), groups.offset[gj + 1] - groups.offset[gj], groups.offset[gj]);
            for k in a.row[j]..a.row[j + 1] {
                let i = a.col[k] as usize;
                let gi = groups.group[i] as usize;
                let (ni, wi, oi) = (a.size(i), groups.offset[gi + 1] - groups.offset[gi], groups.offset[gi]);
                let b = a.block(k, j);
                // B Q_i: nj × wi
                let mut bq = vec![0.0; nj * wi];
                for e in 0..nj {
                    for d in 0..ni {
                        let v = b[e * ni + d];
                        for l in 0..wi {
                            bq[e * wi + l] += v * groups.q[i][d * wi + l];
                        }
                    }
                }
                for kk in 0..wj {
                    for l in 0..wi {
                        a2[(oj + kk) * m2 + oi + l] += (0..nj).map(|e| groups.q[j][e * wj + kk] * bq[e * wi + l]).sum::<f64>();
                    }
                }
            }
        }
        for p in 0..m2 {
            for q in 0..p {
                let s = 0.5 * (a2[p * m2 + q] + a2[q * m2 + p]);
                a2[p * m2 + q] = s;
                a2[q * m2 + p] = s;
            }
        }
        cholesky(&mut a2, m2).then_some(Self { a, diagonal, groups, factor: a2, solves: Arc::new([AtomicUsize::new(0), AtomicUsize::new(0)]) })
    }

    /// Number of unknowns of A_c and of A₂.
    pub fn unknowns(&self) -> (usize, usize) {
        (self.a.unknowns(), *self.groups.offset.last().expect("one offset per group and the total"))
    }

    /// z = D⁻¹ r + Q A₂⁻¹ Qᵀ r (D the diagonal blocks of A_c).
    fn precondition(&self, r: &[f64], z: &mut [f64]) {
        let a = &self.a;
        let g = &self.groups;
        for j in 0..a.aggregates() {
            let (o, n) = (a.offset[j], a.size(j));
            z[o..o + n].copy_from_slice(&r[o..o + n]);
            cholesky_solve(&self.diagonal[j], n, &mut z[o..o + n]);
        }
        let m2 = *g.offset.last().expect("one offset per group and the total");
        let mut u = vec![0.0; m2];
        for j in 0..a.aggregates() {
            let gj = g.group[j] as usize;
            let (o2, w) = (g.offset[gj], g.offset[gj + 1] - g.offset[gj]);
            for e in 0..a.size(j) {
                let re = r[a.offset[j] + e];
                for l in 0..w {
                    u[o2 + l] += g.q[j][e * w + l] * re;
                }
            }
        }
        cholesky_solve(&self.factor, m2, &mut u);
        for j in 0..a.aggregates() {
            let gj = g.group[j] as usize;
            let (o2, w) = (g.offset[gj], g.offset[gj + 1] - g.offset[gj]);
            for e in 0..a.size(j) {
                z[a.offset[j] + e] += (0..w).map(|l| g.q[j][e * w + l] * u[o2 + l]).sum::<f64>();
            }
        }
    }

    /// Solves A_c u = g to [`INNER_TOLERANCE`] from u = 0; returns the iterations taken.
    pub fn solve(&self, g: &[f64], u: &mut [f64]) -> usize {
        let m = g.len();
        let dot = |a: &[f64], b: &[f64]| -> f64 { a.iter().zip(b).map(|(x, y)| x * y).sum() };
        u.iter_mut().for_each(|x| *x = 0.0);
        let gnorm = dot(g, g).sqrt();
        if gnorm == 0.0 {
            return 0;
        }
        let mut r = g.to_vec();
        let mut z = vec![0.0; m];
        self.precondition(&r, &mut z);
        let mut p = z.clone();
        let mut ap = vec![0.0; m];
        let mut rz = dot(&r, &z);
        let mut it = 0;
        while dot(&r, &r).sqrt() > INNER_TOLERANCE * gnorm && it < INNER_MAX_ITERATIONS {
            self.a.apply(&p, &mut ap);
            let pap = dot(&p, &ap);
            if pap <= 0.0 {
                break;
            }
            let alpha = rz / pap;
            for k in 0..m {
                u[k] += alpha * p[k];
                r[k] -= alpha * ap[k];
            }
            self.precondition(&r, &mut z);
            let rz_new = dot(&r, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            for k in 0..m {
                p[k] = z[k] + beta * p[k];
            }
            it += 1;
        }
        self.solves[0].fetch_add(1, Ordering::Relaxed);
        self.solves[1].fetch_add(it, Ordering::Relaxed);
        it
    }

    /// Solves so far and their mean inner iterations.
    pub fn inner_iterations(&self) -> (usize, f64) {
        let (n, it) = (self.solves[0].load(Ordering::Relaxed), self.solves[1].load(Ordering::Relaxed));
        (n, it as f64 / n.max(1) as f64)
    }

    /// y = A_c x (for tests against the dense matrix).
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.a.apply(x, y)
    }
}
