//! A coarse-space correction for the implicit step's preconditioner (two-level additive
//! Schwarz): the smoother (the patches of [`super::patch_jacobi`], or block Jacobi, one 3×3
//! block per particle, [`super::implicit::BlockJacobi`]) damps what varies from particle to
//! particle, but the smooth, body-wide modes of
//! A = M − Δt D − Δt² K are what a large time step makes stiff, and block Jacobi needs many
//! iterations to move them. The particles are grouped into aggregates (cubes of a few
//! spacings); on each, the affine motions — translations, rotations and uniform strains (2D: 6
//! modes; 3D: 12) — are the coarse unknowns (the columns of P, clamped particles left out): the
//! rigid-body modes of smoothed aggregation for elasticity, with the strains that bending and
//! stretching of a body need. The coarse matrix A_c = Pᵀ A P is computed once, matrix-free,
//! by probing: aggregates whose indices agree modulo c (c − 1 aggregates between two of them,
//! more than A's reach of 3 r_e: the rotations slaved to the positions, (2.74), carry a
//! particle's influence one bond further than the gradient model's two) are pushed together,
//! one axis at a time, and each aggregate's response is read as the entry of the one pushed
//! aggregate within its reach. A_c is dense and factorised by Cholesky; the preconditioner is
//! z = S r + P A_c⁻¹ Pᵀ r (S the smoother), symmetric positive definite as conjugate gradients need.
//!
//! A small body's aggregates are 4 spacings wide, grown until A_c has ≤ [`MAX_UNKNOWNS`]
//! unknowns, and A_c is dense. A body too large for that with aggregates as wide as A's reach
//! (beyond ~3·10⁴ particles in 3D) keeps aggregates of that width and holds A_c block-sparse,
//! solved by an inner conjugate-gradient loop with a third level ([`super::coarse_sparse`]):
//! grown aggregates stop carrying the intermediate modes (the 10⁶-particle block, aggregates of
//! 18 spacings: see the README).

use super::coarse_sparse::{BlockSparse, Groups, SparseCoarse};
use super::dense::{cholesky_inverse, cholesky_solve, symmetrised_cholesky};
use glam::DVec3;
use probing::{Aggregates, Probes, Storage, particle_vectors};
use rayon::prelude::*;

#[path = "coarse_probing.rs"]
mod probing;

/// Largest number of coarse unknowns (aggregates × modes): the dense factor then holds
/// ≤ 2000² f64 (32 MB) and takes ≈ 3·10⁹ flops once.
pub const MAX_UNKNOWNS: usize = 2000;

/// The coarse space and the factor of its matrix.
#[derive(Clone, Debug)]
pub struct CoarseSpace {
    /// Aggregate (dense index) of each particle; `u32::MAX` for clamped particles.
    aggregate: Vec<u32>,
    /// First coarse unknown of each aggregate (and the total at the end).
    offset: Vec<usize>,
    /// How A_c is held and solved.
    solve: CoarseSolve,
    /// Side of an aggregate (length).
    pub side: f64,
    /// The basis vectors at each particle (those of its aggregate's basis, in order), from
    /// `start[i]`: P's entries, evaluated once.
    vectors: Vec<DVec3>,
    start: Vec<usize>,
    /// Centre of each aggregate (length) and its basis: coefficients of the affine modes of
    /// [`mode`] about the centre (one row of 12 per basis vector), for [`Self::basis_of`].
    centre: Vec<DVec3>,
    basis: Vec<Vec<[f64; 12]>>,
    dim: usize,
}

/// A_c and its solve.
#[derive(Clone, Debug)]
enum CoarseSolve {
    /// Lower Cholesky factor of the dense A_c, row-major, unknowns².
    Dense(Vec<f64>),
    /// Block-sparse A_c solved by inner conjugate gradients with a third level.
    Sparse(Box<SparseCoarse>),
}

/// Mode k of an aggregate of side `side` at `rel` from its centre — the affine motions:
/// translations along the axes, rotations (about z in 2D; about x, y, z in 3D), then the uniform
/// strains (normal, then shear), the last two kinds scaled by 1/side so that every mode moves the
/// aggregate's particles by O(1).
fn mode(k: usize, dim: usize, rel: DVec3, side: f64) -> DVec3 {
    let r = rel / side;
    match (dim, k) {
        (_, k) if k < dim => DVec3::AXES[k],
        (2, 2) => DVec3::Z.cross(r),
        (2, 3) => DVec3::new(r.x, 0.0, 0.0),
        (2, 4) => DVec3::new(0.0, r.y, 0.0),
        (2, 5) => DVec3::new(r.y, r.x, 0.0),
        (3, k) if k < 6 => DVec3::AXES[k - 3].cross(r),
        (3, k) if k < 9 => DVec3::AXES[k - 6] * r[k - 6],
        (3, 9) => DVec3::new(r.y, r.x, 0.0),
        (3, 10) => DVec3::new(0.0, r.z, r.y),
        (3, 11) => DVec3::new(r.z, 0.0, r.x),
        _ => unreachable!("mode {k} of {dim}D"),
    }
}

/// Number of affine modes in `dim` dimensions.
fn mode_count(dim: usize) -> usize {
    if dim == 2 { 6 } else { 12 }
}

/// An orthonormal basis (in the inner product over the particles `members`) of the affine
/// modes about `centre`, as coefficients of [`mode`]: Gram–Schmidt, dropping a mode that the
/// others already span there (a one-particle-thick aggregate's strain across its thickness).
fn affine_basis(members: &[usize], reference: &[DVec3], centre: DVec3, side: f64, dim: usize) -> Vec<[f64; 12]> {
    let modes = mode_count(dim);
    let mut gram = [[0.0; 12]; 12];
    for &i in members {
        let v: Vec<DVec3> = (0..modes).map(|k| mode(k, dim, reference[i] - centre, side)).collect();
        for k in 0..modes {
            for l in 0..modes {
                gram[k][l] += v[k].dot(v[l]);
            }
        }
    }
    let dot = |a: &[f64; 12], b: &[f64; 12]| -> f64 { (0..modes).map(|k| (0..modes).map(|l| a[k] * gram[k][l] * b[l]).sum::<f64>()).sum() };
    let mut accepted: Vec<[f64; 12]> = Vec::new();
    for k in 0..modes {
        let mut v = [0.0; 12];
        v[k] = 1.0;
        let norm0 = dot(&v, &v);
        for b in &accepted {
            let p = dot(&v, b);
            for (x, y) in v.iter_mut().zip(b) {
                *x -= p * y;
            }
        }
        let norm = dot(&v, &v);
        if norm > 1e-8 * norm0 {
            let s = 1.0 / norm.sqrt();
            accepted.push(v.map(|x| x * s));
        }
    }
    accepted
}

/// Basis vector `b` (coefficients of the modes about `centre`, aggregate side `side`) at `x`.
fn basis_value(b: &[f64; 12], dim: usize, x: DVec3, centre: DVec3, side: f64) -> DVec3 {
    (0..mode_count(dim)).map(|k| b[k] * mode(k, dim, x - centre, side)).sum()
}

/// Where the aggregates lie: a grid of cubes of side `side` from `lo`.
struct AggregateGrid {
    lo: DVec3,
    side: f64,
    cells: [usize; 3],
    dim: usize,
}

impl AggregateGrid {
    fn new(reference: &[DVec3], dim: usize, side: f64) -> Self {
        let lo = reference.iter().fold(DVec3::splat(f64::INFINITY), |a, x| a.min(*x));
        let hi = reference.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, x| a.max(*x));
        let cells = std::array::from_fn(|a| if a < dim { ((hi[a] - lo[a]) / side).floor() as usize + 1 } else { 1 });
        Self { lo, side, cells, dim }
    }

    /// Upper bound of the coarse unknowns: every cell an aggregate with all its modes.
    fn unknowns(&self) -> usize {
        self.cells.iter().product::<usize>() * mode_count(self.dim)
    }

    fn coords(&self, x: DVec3) -> [usize; 3] {
        std::array::from_fn(|a| if a < self.dim { (((x[a] - self.lo[a]) / self.side).floor() as usize).min(self.cells[a] - 1) } else { 0 })
    }

    fn flat(&self, c: [usize; 3]) -> usize {
        (c[2] * self.cells[1] + c[1]) * self.cells[0] + c[0]
    }

    fn centre(&self, c: [usize; 3]) -> DVec3 {
        self.lo + DVec3::from_array(std::array::from_fn(|a| if a < self.dim { (c[a] as f64 + 0.5) * self.side } else { 0.0 }))
    }
}

impl CoarseSpace {
    /// Builds the coarse space of particles at `reference` (spacing l₀, dimension `dim`) for the
    /// operator `apply` (x ↦ A x, zero on `fixed` particles), whose reach is `reach` (length).
    /// Aggregates of 4 spacings, grown until a dense A_c has ≤ [`MAX_UNKNOWNS`] unknowns; when
    /// even aggregates as wide as A's reach need more, aggregates of that width (they couple to
    /// their 3^dim neighbours only: probing takes 3^dim × modes operator products) and A_c
    /// block-sparse ([`super::coarse_sparse`]). `None` when A_c is not positive definite to
    /// round-off (the caller keeps the smoother alone).
    pub fn build(reference: &[DVec3], fixed: &[bool], dim: usize, spacing: f64, reach: f64, apply: impl FnMut(&[DVec3], &mut [DVec3])) -> Option<Self> {
        let sparse_side = (4.0 * spacing).max(reach * (1.0 + 1e-9));
        if AggregateGrid::new(reference, dim, sparse_side).unknowns() > MAX_UNKNOWNS {
            return Self::build_with(reference, fixed, dim, sparse_side, reach, true, apply);
        }
        let mut side = 4.0 * spacing;
        while AggregateGrid::new(reference, dim, side).unknowns() > MAX_UNKNOWNS {
            side *= 1.25;
        }
        Self::build_with(reference, fixed, dim, side, reach, false, apply)
    }

    /// [`CoarseSpace::build`] with the aggregates' side and A_c's storage given: the aggregates,
    /// each one's orthonormal affine basis, P's entries at the particles, A_c probed
    /// (src/solid/coarse_probing.rs) and factorised (dense: Cholesky; sparse: symmetrised,
    /// with a third level).
    pub fn build_with(
        reference: &[DVec3],
        fixed: &[bool],
        dim: usize,
        side: f64,
        reach: f64,
        sparse: bool,
        apply: impl FnMut(&[DVec3], &mut [DVec3]),
    ) -> Option<Self> {
        let grid = AggregateGrid::new(reference, dim, side);
        let aggregates = Aggregates::new(reference, fixed, &grid);
        if aggregates.len() == 0 {
            return None;
        }
        let centre: Vec<DVec3> = aggregates.cell.iter().map(|c| grid.centre(*c)).collect();
        let basis: Vec<Vec<[f64; 12]>> = aggregates.members.iter().zip(&centre).map(|(m, c)| affine_basis(m, reference, *c, side, dim)).collect();
        let mut offset = vec![0];
        for b in &basis {
            offset.push(offset.last().unwrap() + b.len());
        }
        let m = *offset.last().unwrap();
        // aggregates within reach differ by at most r in each index; colour period 2r + 1
        let r = (reach / side).floor() as usize + 1;
        // each particle's basis vectors, made once: the probes and the responses read them
        let (start, vectors) = particle_vectors(reference, &aggregates, &centre, &basis, &grid);
        let mut storage = if sparse {
            Storage::Sparse(BlockSparse::new(offset.clone(), aggregates.cell.iter().map(|c| aggregates.neighbours(&grid, c, r)).collect()))
        } else {
            Storage::Dense(vec![0.0; m * m])
        };
        Probes { grid: &grid, aggregates: &aggregates, basis: &basis, offset: &offset, start: &start, vectors: &vectors, r }.fill(&mut storage, apply);
        let solve = match storage {
            Storage::Dense(mut a) => {
                // symmetric in exact arithmetic; symmetrised against round-off
                if !symmetrised_cholesky(&mut a, m) {
                    return None;
                }
                CoarseSolve::Dense(a)
            }
            Storage::Sparse(mut a) => {
                a.symmetrise();
                let groups = third_level(reference, &grid, &aggregates.cell, &aggregates.members, &centre, &basis);
                CoarseSolve::Sparse(Box::new(SparseCoarse::new(a, groups)?))
            }
        };
        Some(Self { aggregate: aggregates.of_particle, offset, solve, side, vectors, start, centre, basis, dim })
    }

    /// Aggregate of each particle (`u32::MAX` at clamped particles).
    pub fn aggregate_of(&self) -> &[u32] {
        &self.aggregate
    }

    /// First coarse unknown of each aggregate, and the total at the end.
    pub fn offsets(&self) -> &[usize] {
        &self.offset
    }

    /// Aggregate j's centre (length) and basis, each basis vector as the coefficients of the
    /// affine modes about the centre with positions scaled by 1/[`Self::side`] — in 3D the
    /// translations x, y, z, the rotations about x, y, z (e_k × r), the normal strains
    /// (r_k e_k), the shears (r_y, r_x, 0), (0, r_z, r_y), (r_z, 0, r_x); in 2D x, y, e_z × r,
    /// (r_x, 0), (0, r_y), (r_y, r_x); the device's kernels (`coarse_restrict`,
    /// `coarse_prolong` in shaders/solid_implicit.wgsl) evaluate the same list.
    pub fn basis_of(&self, j: usize) -> (DVec3, &[[f64; 12]]) {
        (self.centre[j], &self.basis[j])
    }

    /// Number of affine modes per aggregate (6 in 2D, 12 in 3D).
    pub fn modes(&self) -> usize {
        mode_count(self.dim)
    }

    /// A_c⁻¹, dense and row-major (symmetric): from the Cholesky factor (`dense::cholesky_inverse`,
    /// ≈ m³/3 multiply-adds), for a block-sparse A_c assembled and factorised first (the device
    /// applies A_c⁻¹ as one dense product, where the CPU solves). `None` when a
    /// block-sparse A_c does not factorise to round-off.
    pub fn dense_inverse(&self) -> Option<Vec<f64>> {
        let m = self.unknowns();
        let factor = match &self.solve {
            CoarseSolve::Dense(l) => std::borrow::Cow::Borrowed(l),
            CoarseSolve::Sparse(s) => {
                let mut a = vec![0.0; m * m];
                a.par_chunks_mut(m).enumerate().for_each(|(q, row)| {
                    let mut e = vec![0.0; m];
                    e[q] = 1.0;
                    s.apply(&e, row);
                });
                if !symmetrised_cholesky(&mut a, m) {
                    return None;
                }
                std::borrow::Cow::Owned(a)
            }
        };
        Some(cholesky_inverse(&factor, m))
    }

    /// Number of coarse unknowns.
    pub fn unknowns(&self) -> usize {
        *self.offset.last().expect("one offset per aggregate and the total")
    }

    /// Whether A_c is solved iteratively (to [`super::coarse_sparse::INNER_TOLERANCE`]): the
    /// preconditioner then varies slightly from one application to the next, and the outer
    /// conjugate gradients must be the flexible kind.
    pub fn is_inexact(&self) -> bool {
        matches!(self.solve, CoarseSolve::Sparse(_))
    }

    /// A_c as a dense row-major matrix (the dense factor multiplied out, or the sparse matrix
    /// applied to the unit vectors): for tests.
    #[cfg(test)]
    pub(super) fn matrix(&self) -> Vec<f64> {
        let m = self.unknowns();
        let mut a = vec![0.0; m * m];
        match &self.solve {
            CoarseSolve::Dense(l) => {
                for p in 0..m {
                    for q in 0..m {
                        a[p * m + q] = (0..=p.min(q)).map(|s| l[p * m + s] * l[q * m + s]).sum();
                    }
                }
            }
            CoarseSolve::Sparse(s) => {
                let (mut e, mut y) = (vec![0.0; m], vec![0.0; m]);
                for q in 0..m {
                    e[q] = 1.0;
                    s.apply(&e, &mut y);
                    e[q] = 0.0;
                    for p in 0..m {
                        a[p * m + q] = y[p];
                    }
                }
            }
        }
        a
    }

    /// For a block-sparse A_c: its unknowns, A₂'s, the inner solves so far and their mean
    /// iterations.
    pub fn inner_solve(&self) -> Option<(usize, usize, usize, f64)> {
        match &self.solve {
            CoarseSolve::Dense(_) => None,
            CoarseSolve::Sparse(s) => {
                let ((m, m2), (n, it)) = (s.unknowns(), s.inner_iterations());
                Some((m, m2, n, it))
            }
        }
    }

    /// z += P A_c⁻¹ Pᵀ r.
    pub fn add_correction(&self, r: &[DVec3], z: &mut [DVec3]) {
        let m = self.unknowns();
        let mut g = vec![0.0; m];
        for (i, ri) in r.iter().enumerate() {
            let a = self.aggregate[i];
            if a != u32::MAX {
                let o = self.offset[a as usize];
                for (e, v) in self.vectors[self.start[i]..self.start[i + 1]].iter().enumerate() {
                    g[o + e] += v.dot(*ri);
                }
            }
        }
        let u = match &self.solve {
            CoarseSolve::Dense(l) => {
                cholesky_solve(l, m, &mut g);
                g
            }
            CoarseSolve::Sparse(s) => {
                let mut u = vec![0.0; m];
                s.solve(&g, &mut u);
                u
            }
        };
        let u = &u;
        z.par_iter_mut().enumerate().for_each(|(i, zi)| {
            let a = self.aggregate[i];
            if a != u32::MAX {
                let o = self.offset[a as usize];
                for (e, v) in self.vectors[self.start[i]..self.start[i + 1]].iter().enumerate() {
                    *zi += u[o + e] * *v;
                }
            }
        });
    }
}

/// The third level of a block-sparse coarse space: the aggregates grouped into cubes of g³
/// (g ≥ 2, the smallest that keeps A₂ within [`MAX_UNKNOWNS`] unknowns), each group's affine
/// modes (an orthonormal basis over its particles) expressed in its aggregates' bases. An
/// affine motion of the group is affine on each aggregate, so it lies in the aggregate's span
/// and the coefficients — the projections onto the aggregate's orthonormal basis — are exact.
fn third_level(
    reference: &[DVec3],
    grid: &AggregateGrid,
    grid_of: &[[usize; 3]],
    members: &[Vec<usize>],
    centre: &[DVec3],
    basis: &[Vec<[f64; 12]>],
) -> Groups {
    let (dim, side) = (grid.dim, grid.side);
    let modes = mode_count(dim);
    let extent: [usize; 3] = std::array::from_fn(|a| grid_of.iter().map(|c| c[a] + 1).max().unwrap_or(1));
    let groups_along = |g: usize| -> [usize; 3] { std::array::from_fn(|a| extent[a].div_ceil(g)) };
    let mut g = 2;
    while groups_along(g).iter().product::<usize>() * modes > MAX_UNKNOWNS {
        g += 1;
    }
    let along = groups_along(g);
    let mut dense = vec![u32::MAX; along.iter().product()];
    let mut group = Vec::with_capacity(grid_of.len());
    let mut cells: Vec<[usize; 3]> = Vec::new();
    let mut particles: Vec<Vec<usize>> = Vec::new();
    for (j, c) in grid_of.iter().enumerate() {
        let gc: [usize; 3] = std::array::from_fn(|a| c[a] / g);
        let f = (gc[2] * along[1] + gc[1]) * along[0] + gc[0];
        if dense[f] == u32::MAX {
            dense[f] = cells.len() as u32;
            cells.push(gc);
            particles.push(Vec::new());
        }
        group.push(dense[f]);
        particles[dense[f] as usize].extend_from_slice(&members[j]);
    }
    // a group's centre: the middle of its g × g (× g) cells
    let side2 = g as f64 * side;
    let centre2: Vec<DVec3> =
        cells.iter().map(|gc| grid.lo + DVec3::from_array(std::array::from_fn(|a| if a < dim { (gc[a] as f64 + 0.5) * side2 } else { 0.0 }))).collect();
    let basis2: Vec<Vec<[f64; 12]>> = particles.iter().zip(&centre2).map(|(p, c)| affine_basis(p, reference, *c, side2, dim)).collect();
    let mut offset = vec![0];
    for b in &basis2 {
        offset.push(offset.last().unwrap() + b.len());
    }
    let q = (0..grid_of.len())
        .into_par_iter()
        .map(|j| {
            let gj = group[j] as usize;
            let w = basis2[gj].len();
            let mut q = vec![0.0; basis[j].len() * w];
            for &i in &members[j] {
                for (e, b) in basis[j].iter().enumerate() {
                    let v = basis_value(b, dim, reference[i], centre[j], side);
                    for (l, b2) in basis2[gj].iter().enumerate() {
                        q[e * w + l] += v.dot(basis_value(b2, dim, reference[i], centre2[gj], side2));
                    }
                }
            }
            q
        })
        .collect();
    Groups { group, offset, q }
}

#[cfg(test)]
#[path = "coarse_tests.rs"]
mod tests;
