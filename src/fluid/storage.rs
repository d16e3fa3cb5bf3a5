//! CPU memory layout of node values: **row-blocked structure of arrays**. For every padded row
//! (fixed y, z) the values of one population (or macro field) are contiguous along x, and the
//! populations of a row follow each other: index = (row · n_values + v) · p_x + x.
//! Inner loops run along x over contiguous memory (vectorisable), and a row is one contiguous
//! chunk, so rows are updated in parallel without sharing.

use super::layout::PeriodicRun;

/// The number type the populations (fⁿ, f¹, fⁿ⁺¹ and the advected h) are stored in between the
/// passes of a step: `f64`, the reference, or `f32`, half the bytes per node for scenes that
/// tolerate its rounding (`[numerics] storage = "f32"`). Every pass loads its inputs into f64,
/// computes in f64 and rounds once on the store; the macroscopic fields, the boundaries' scratch
/// and the side ghosts stay f64. The errors it costs are measured on Taylor–Green and Sod
/// (`phonation bench --only storage`, the tests of [`super::solver`]).
pub trait Storage: Copy + Default + PartialEq + Send + Sync + std::fmt::Debug + 'static {
    /// "f64" or "f32" (what the bench and the summaries print).
    const NAME: &'static str;
    /// The value as f64 (exact).
    fn load(self) -> f64;
    /// `x` rounded to the storage type (to nearest; exact for f64).
    fn store(x: f64) -> Self;
}

impl Storage for f64 {
    const NAME: &'static str = "f64";
    #[inline(always)]
    fn load(self) -> f64 {
        self
    }
    #[inline(always)]
    fn store(x: f64) -> Self {
        x
    }
}

impl Storage for f32 {
    const NAME: &'static str = "f32";
    #[inline(always)]
    fn load(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn store(x: f64) -> Self {
        x as f32
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowBlocked {
    /// Padded row length p_x.
    pub px: usize,
    /// Values per node.
    pub nv: usize,
}

impl RowBlocked {
    #[inline]
    pub fn index(&self, node: usize, v: usize) -> usize {
        let r = node / self.px;
        let x = node % self.px;
        (r * self.nv + v) * self.px + x
    }

    /// Length of one row chunk.
    #[inline]
    pub fn row_len(&self) -> usize {
        self.nv * self.px
    }

    /// Copies the values of `node` into `out` (length nv).
    #[inline]
    pub fn gather<S: Storage>(&self, a: &[S], node: usize, out: &mut [f64]) {
        let base = self.index(node, 0);
        for (v, o) in out.iter_mut().enumerate() {
            *o = a[base + v * self.px].load();
        }
    }

    /// Writes `vals` (length nv) into `node`.
    #[inline]
    pub fn scatter<S: Storage>(&self, a: &mut [S], node: usize, vals: &[f64]) {
        let base = self.index(node, 0);
        for (v, x) in vals.iter().enumerate() {
            a[base + v * self.px] = S::store(*x);
        }
    }

    /// Copies every value of node `src` onto node `dst`.
    #[inline]
    pub fn copy_node<T: Copy>(&self, a: &mut [T], src: usize, dst: usize) {
        let (bs, bd) = (self.index(src, 0), self.index(dst, 0));
        for v in 0..self.nv {
            a[bd + v * self.px] = a[bs + v * self.px];
        }
    }

    /// Offset in values of the same population at a neighbour displaced by `d` nodes, for a
    /// padded grid of `py` rows per z-plane.
    #[inline]
    pub fn neighbour_offset(&self, d: [i64; 3], py: usize) -> isize {
        (d[0] + (d[1] + d[2] * py as i64) * (self.nv * self.px) as i64) as isize
    }
}

/// Copies, for every periodic run, the values `values(run)` (indices below `layout.nv`) of its
/// source nodes onto its destination nodes, runs in parallel. The destinations of the runs must
/// be disjoint from each other and from every source (true of periodic halo copies, whose
/// sources are interior nodes and whose destinations are halo nodes).
pub fn copy_runs_parallel<'v, T: Copy + Send>(layout: RowBlocked, a: &mut [T], runs: &[PeriodicRun], values: impl Fn(&PeriodicRun) -> &'v [usize] + Sync) {
    use rayon::prelude::*;
    struct Ptr<T>(*mut T);
    // SAFETY: every task writes only its own run's destination values and reads only sources,
    // which no task writes (the caller's contract above).
    unsafe impl<T: Send> Sync for Ptr<T> {}
    unsafe impl<T: Send> Send for Ptr<T> {}
    let len = a.len();
    let p = Ptr(a.as_mut_ptr());
    runs.par_iter().with_min_len(64).for_each(|run| {
        let p = &p;
        let n = run.len;
        let (bs, bd) = (layout.index(run.src, 0), layout.index(run.dst, 0));
        for &v in values(run) {
            assert!(v < layout.nv);
            let (s0, d0) = (bs + v * layout.px, bd + v * layout.px);
            assert!(s0 + n <= len && d0 + n <= len);
            // SAFETY: in bounds (checked above); source and destination ranges do not overlap.
            // Short runs (the x halo: a few nodes per row) are copied inline, not by a call.
            unsafe {
                if n <= 8 {
                    for k in 0..n {
                        *p.0.add(d0 + k) = *p.0.add(s0 + k);
                    }
                } else {
                    std::ptr::copy_nonoverlapping(p.0.add(s0), p.0.add(d0), n)
                }
            };
        }
    });
}
