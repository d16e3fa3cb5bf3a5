//! CPU memory layout of node values: **row-blocked structure of arrays**. For every padded row
//! (fixed y, z) the values of one population (or macro field) are contiguous along x, and the
//! populations of a row follow each other: index = (row · n_values + v) · p_x + x.
//! Inner loops run along x over contiguous memory (vectorisable), and a row is one contiguous
//! chunk, so rows are updated in parallel without sharing.

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
    pub fn gather(&self, a: &[f64], node: usize, out: &mut [f64]) {
        let base = self.index(node, 0);
        for (v, o) in out.iter_mut().enumerate() {
            *o = a[base + v * self.px];
        }
    }

    /// Writes `vals` (length nv) into `node`.
    #[inline]
    pub fn scatter(&self, a: &mut [f64], node: usize, vals: &[f64]) {
        let base = self.index(node, 0);
        for (v, x) in vals.iter().enumerate() {
            a[base + v * self.px] = *x;
        }
    }

    /// Copies every value of node `src` onto node `dst`.
    #[inline]
    pub fn copy_node(&self, a: &mut [f64], src: usize, dst: usize) {
        let (bs, bd) = (self.index(src, 0), self.index(dst, 0));
        for v in 0..self.nv {
            a[bd + v * self.px] = a[bs + v * self.px];
        }
    }

    /// Copies `len` consecutive nodes (same row) starting at `src` onto those starting at `dst`.
    #[inline]
    pub fn copy_run(&self, a: &mut [f64], src: usize, dst: usize, len: usize) {
        let (bs, bd) = (self.index(src, 0), self.index(dst, 0));
        for v in 0..self.nv {
            a.copy_within(bs + v * self.px..bs + v * self.px + len, bd + v * self.px);
        }
    }

    /// Offset in values of the same population at a neighbour displaced by `d` nodes, for a
    /// padded grid of `py` rows per z-plane.
    #[inline]
    pub fn neighbour_offset(&self, d: [i64; 3], py: usize) -> isize {
        (d[0] + (d[1] + d[2] * py as i64) * (self.nv * self.px) as i64) as isize
    }
}
