//! How [`super::CoarseSpace::build_with`] makes A_c = Pᵀ A P matrix-free: the aggregates that
//! hold a free particle, P's entries at each particle, and the probes — the aggregates whose
//! grid indices agree modulo the colour period pushed together, one mode at a time, each
//! aggregate's response read as the entry of the one pushed aggregate within its reach.

use super::{AggregateGrid, BlockSparse, basis_value};
use glam::DVec3;
use rayon::prelude::*;

/// A_c while it is probed.
pub(super) enum Storage {
    Dense(Vec<f64>),
    Sparse(BlockSparse),
}

/// The aggregates that hold a free particle, numbered in the order of their first particle.
pub(super) struct Aggregates {
    /// Dense index of each grid cell's aggregate (`u32::MAX`: none).
    id: Vec<u32>,
    /// Grid cell of each aggregate.
    pub cell: Vec<[usize; 3]>,
    /// Aggregate of each particle (`u32::MAX` at clamped particles).
    pub of_particle: Vec<u32>,
    /// Particles of each aggregate, in particle order.
    pub members: Vec<Vec<usize>>,
}

impl Aggregates {
    /// The free particles at `reference` grouped by the cells of `grid`.
    pub fn new(reference: &[DVec3], fixed: &[bool], grid: &AggregateGrid) -> Self {
        let mut a =
            Self { id: vec![u32::MAX; grid.cells.iter().product()], cell: Vec::new(), of_particle: vec![u32::MAX; reference.len()], members: Vec::new() };
        for (i, x) in reference.iter().enumerate() {
            if fixed[i] {
                continue;
            }
            let c = grid.coords(*x);
            let f = grid.flat(c);
            if a.id[f] == u32::MAX {
                a.id[f] = a.cell.len() as u32;
                a.cell.push(c);
                a.members.push(Vec::new());
            }
            a.of_particle[i] = a.id[f];
            a.members[a.id[f] as usize].push(i);
        }
        a
    }

    /// How many aggregates hold a free particle.
    pub fn len(&self) -> usize {
        self.cell.len()
    }

    /// The aggregates within `r` cells of cell `c` along every axis, in the order of the block of
    /// (2r + 1)^dim cells around it.
    pub fn neighbours(&self, grid: &AggregateGrid, c: &[usize; 3], r: usize) -> Vec<u32> {
        let period = 2 * r + 1;
        let mut list = Vec::new();
        for k in 0..period.pow(grid.dim as u32) {
            let mut o = [0usize; 3];
            let mut inside = true;
            for ax in 0..grid.dim {
                let v = c[ax] as isize + (k / period.pow(ax as u32) % period) as isize - r as isize;
                inside &= v >= 0 && (v as usize) < grid.cells[ax];
                o[ax] = v.max(0) as usize;
            }
            if inside && self.id[grid.flat(o)] != u32::MAX {
                list.push(self.id[grid.flat(o)]);
            }
        }
        list
    }

    /// The aggregate within `r` cells of cell `cj` whose indices are ≡ `colour` modulo 2r + 1
    /// (at most one), if a cell there holds one.
    fn pushed_near(&self, grid: &AggregateGrid, cj: &[usize; 3], colour: &[usize; 3], r: usize) -> Option<usize> {
        let period = 2 * r + 1;
        let mut ci = [0usize; 3];
        let mut inside = true;
        for ax in 0..grid.dim {
            let off = (colour[ax] + period - cj[ax] % period) % period;
            let off = if off > r { off as isize - period as isize } else { off as isize };
            let v = cj[ax] as isize + off;
            inside &= v >= 0 && (v as usize) < grid.cells[ax];
            ci[ax] = v.max(0) as usize;
        }
        (inside && self.id[grid.flat(ci)] != u32::MAX).then(|| self.id[grid.flat(ci)] as usize)
    }
}

/// P's entries: each particle's basis vectors (its aggregate's `basis` about `centre`, in
/// order), from `start[i]` in `vectors` (none at a clamped particle).
pub(super) fn particle_vectors(
    reference: &[DVec3],
    aggregates: &Aggregates,
    centre: &[DVec3],
    basis: &[Vec<[f64; 12]>],
    grid: &AggregateGrid,
) -> (Vec<usize>, Vec<DVec3>) {
    let n = reference.len();
    let mut start = Vec::with_capacity(n + 1);
    let mut vectors = Vec::new();
    for i in 0..n {
        start.push(vectors.len());
        if aggregates.of_particle[i] != u32::MAX {
            let j = aggregates.of_particle[i] as usize;
            vectors.extend(basis[j].iter().map(|b| basis_value(b, grid.dim, reference[i], centre[j], grid.side)));
        }
    }
    start.push(vectors.len());
    (start, vectors)
}

/// What the probes read: the aggregates on their grid, each one's basis and first unknown
/// (`offset`, the total at the end), P's entries per particle, and A's reach in cells `r`.
pub(super) struct Probes<'a> {
    pub grid: &'a AggregateGrid,
    pub aggregates: &'a Aggregates,
    pub basis: &'a [Vec<[f64; 12]>],
    pub offset: &'a [usize],
    pub start: &'a [usize],
    pub vectors: &'a [DVec3],
    pub r: usize,
}

impl Probes<'_> {
    /// Fills `storage` with A_c: for each colour (a residue of the aggregates' indices modulo
    /// 2r + 1) and each mode d, the probe x = Σ of the pushed aggregates' d-th basis vectors,
    /// y = A x by `apply`, and each aggregate j's projections of y onto its basis vectors as
    /// the entries (j, e; i, d) of the one pushed aggregate i within its reach.
    pub fn fill(&self, storage: &mut Storage, mut apply: impl FnMut(&[DVec3], &mut [DVec3])) {
        let (grid, agg, basis) = (self.grid, self.aggregates, self.basis);
        let (dim, n, count) = (grid.dim, self.start.len() - 1, agg.len());
        let m = *self.offset.last().expect("the total");
        let period = 2 * self.r + 1;
        let modes = super::mode_count(dim);
        let colours: Vec<[usize; 3]> =
            (0..period.pow(dim as u32)).map(|k| std::array::from_fn(|ax| if ax < dim { (k / period.pow(ax as u32)) % period } else { 0 })).collect();
        let mut x = vec![DVec3::ZERO; n];
        let mut y = vec![DVec3::ZERO; n];
        for colour in &colours {
            let pushed = |c: &[usize; 3]| (0..dim).all(|ax| c[ax] % period == colour[ax]);
            if !agg.cell.iter().any(pushed) {
                continue;
            }
            for d in 0..modes {
                let probed = |j: usize| pushed(&agg.cell[j]) && d < basis[j].len();
                if !(0..count).any(probed) {
                    continue;
                }
                // the probe vector and the responses: each particle and each aggregate on its
                // own (the pool's threads; every sum in the same order as one by one)
                x.par_iter_mut().enumerate().with_min_len(4096).for_each(|(i, v)| {
                    let j = agg.of_particle[i];
                    *v = if j != u32::MAX && probed(j as usize) { self.vectors[self.start[i] + d] } else { DVec3::ZERO };
                });
                apply(&x, &mut y);
                let responses: Vec<Option<(usize, Vec<f64>)>> = agg
                    .cell
                    .par_iter()
                    .enumerate()
                    .map(|(j, cj)| {
                        let i = agg.pushed_near(grid, cj, colour, self.r)?;
                        if d >= basis[i].len() {
                            return None;
                        }
                        Some((i, (0..basis[j].len()).map(|e| agg.members[j].iter().map(|&p| self.vectors[self.start[p] + e].dot(y[p])).sum()).collect()))
                    })
                    .collect();
                for (j, r) in responses.into_iter().enumerate() {
                    let Some((i, response)) = r else { continue };
                    for (e, response) in response.into_iter().enumerate() {
                        match storage {
                            Storage::Dense(a) => a[(self.offset[j] + e) * m + self.offset[i] + d] = response,
                            Storage::Sparse(a) => *a.entry_mut(j, e, i, d).expect("a pushed aggregate within reach is a neighbour") = response,
                        }
                    }
                }
            }
        }
    }
}
