//! The padded Cartesian grid of the FDLB solver: interior nodes plus a halo of two nodes on
//! every face of a 2D or 3D domain (the reach of the 3rd-order upwind stencil, [`super::upwind`]).
//! Node values are stored cell-major (all populations of one node contiguous) on the CPU.

/// Halo width: the upwind stencil reads x−2 … x+1 along each axis.
pub const HALO: usize = 2;

#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// 2 or 3.
    pub dim: usize,
    /// Interior nodes per axis (`n[2] == 1` in 2D).
    pub n: [usize; 3],
    /// Halo per axis (0 along z in 2D).
    pub halo: [usize; 3],
    /// Padded sizes.
    pub padded: [usize; 3],
    /// Node strides of the padded grid.
    pub stride: [usize; 3],
}

impl Grid {
    pub fn new(dim: usize, n: [usize; 3]) -> Self {
        let n = if dim == 2 { [n[0], n[1], 1] } else { n };
        let halo = if dim == 2 { [HALO, HALO, 0] } else { [HALO; 3] };
        let padded = [n[0] + 2 * halo[0], n[1] + 2 * halo[1], n[2] + 2 * halo[2]];
        let stride = [1, padded[0], padded[0] * padded[1]];
        Grid { dim, n, halo, padded, stride }
    }

    /// Number of padded nodes.
    pub fn len(&self) -> usize {
        self.padded[0] * self.padded[1] * self.padded[2]
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of interior nodes.
    pub fn interior_len(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    /// Padded index of a node given in padded coordinates.
    #[inline]
    pub fn index_padded(&self, p: [usize; 3]) -> usize {
        p[0] + self.stride[1] * p[1] + self.stride[2] * p[2]
    }

    /// Padded index of interior node `x` (0-based interior coordinates; may be negative or
    /// ≥ n inside the halo).
    #[inline]
    pub fn index(&self, x: [i64; 3]) -> usize {
        let p = [(x[0] + self.halo[0] as i64) as usize, (x[1] + self.halo[1] as i64) as usize, (x[2] + self.halo[2] as i64) as usize];
        self.index_padded(p)
    }

    /// Interior coordinates (may be in the halo) of a padded index.
    #[inline]
    pub fn coords(&self, idx: usize) -> [i64; 3] {
        let z = idx / self.stride[2];
        let r = idx % self.stride[2];
        let y = r / self.stride[1];
        let x = r % self.stride[1];
        [x as i64 - self.halo[0] as i64, y as i64 - self.halo[1] as i64, z as i64 - self.halo[2] as i64]
    }

    /// Whether interior coordinates lie inside the padded grid.
    #[inline]
    pub fn contains(&self, x: [i64; 3]) -> bool {
        (0..3).all(|a| x[a] >= -(self.halo[a] as i64) && x[a] < (self.n[a] + self.halo[a]) as i64)
    }

    /// Whether interior coordinates lie in the interior (not the halo).
    #[inline]
    pub fn is_interior(&self, x: [i64; 3]) -> bool {
        (0..3).all(|a| x[a] >= 0 && x[a] < self.n[a] as i64)
    }

    /// Number of padded rows (nodes sharing y and z).
    pub fn rows(&self) -> usize {
        self.padded[1] * self.padded[2]
    }
}
