//! Moving walls: the fluid's geometry rebuilt between steps (the per-step `fluid_geometry`
//! stage of the coupled solver), nodes that a moving body uncovers or covers, and sampling the
//! fluid at arbitrary points (for the tractions on a body's surface).
//!
//! A body moves less than one cell per step (the coupled solver checks it), and every solid
//! node within two cells of the fluid is a ghost node filled at each Runge–Kutta stage, so a
//! node the body uncovers held a ghost before. Its populations at the end of the step are not
//! those of the last fill, though (the stage buffers rotate), so a *fresh* node takes the mean
//! populations of its fluid neighbours (the 3ᴰ − 1 surrounding nodes that are fluid before and
//! after the move): a zero-gradient extrapolation with well-defined, admissible values (a convex
//! combination of admissible states). A node the body covers leaves the fluid with its mass.

use super::equilibrium::Macro;
use super::geometry::Obstacle;
use super::interpolation::multilinear_corners;
use super::layout::{Layout, NodeKind};
use super::neighbours::fluid_node;
use super::solver::FluidSolver;
use super::storage::Storage;
use rayon::prelude::*;

/// The nodes a change of layout touches (padded indices, ascending): those that leave the
/// fluid, and those that join it with the neighbours they take their populations from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LayoutChange {
    pub nodes: Vec<(usize, NodeChange)>,
}

/// How a node changes side.
#[derive(Clone, Debug, PartialEq)]
pub enum NodeChange {
    /// It leaves the fluid (with its mass).
    Covered,
    /// It joins the fluid, filled with the mean populations of these neighbours (the 3ᴰ − 1
    /// surrounding nodes that are fluid in both layouts; none for an isolated node, which
    /// keeps its populations).
    Uncovered(Vec<usize>),
}

impl LayoutChange {
    /// The change from layout `old` to `new` (of the same lattice).
    pub fn between(old: &Layout, new: &Layout) -> Self {
        assert_eq!(new.grid.padded, old.grid.padded, "a layout of the same lattice");
        let grid = &new.grid;
        let offsets = neighbour_offsets(grid.dim);
        let fluid = |l: &Layout, k: usize| l.kind[k] == NodeKind::Fluid;
        let change = |node: usize| -> Option<(usize, NodeChange)> {
            match (fluid(old, node), fluid(new, node)) {
                (true, false) => Some((node, NodeChange::Covered)),
                (false, true) => {
                    let x = grid.coords(node);
                    let neighbours = offsets
                        .iter()
                        .map(|d| [x[0] + d[0], x[1] + d[1], x[2] + d[2]])
                        .filter(|y| grid.contains(*y))
                        .map(|y| grid.index(y))
                        .filter(|&k| fluid(old, k) && fluid(new, k))
                        .collect();
                    Some((node, NodeChange::Uncovered(neighbours)))
                }
                _ => None,
            }
        };
        // the lattice in chunks on the pool's threads, in node order; a chunk whose kinds did
        // not change (almost all: a body moves a fraction of a cell a step) is passed over by
        // one comparison of the two runs of kinds
        const CHUNK: usize = 4096;
        let nodes = old
            .kind
            .par_chunks(CHUNK)
            .zip(new.kind.par_chunks(CHUNK))
            .enumerate()
            .filter(|(_, (a, b))| a != b)
            .flat_map_iter(|(c, (a, _))| (c * CHUNK..c * CHUNK + a.len()).filter_map(change))
            .collect();
        LayoutChange { nodes }
    }

    /// Every node whose populations the change reads: the nodes that change side (an isolated
    /// node keeps its own; method 2 books the momentum of every node that changes side) and the
    /// neighbours the fresh nodes are filled from — sorted, without repeats.
    pub fn reads(&self) -> Vec<usize> {
        let mut r: Vec<usize> = Vec::new();
        for (node, change) in &self.nodes {
            r.push(*node);
            if let NodeChange::Uncovered(nb) = change {
                r.extend(nb);
            }
        }
        r.sort_unstable();
        r.dedup();
        r
    }

    /// The nodes whose populations the change writes: the uncovered ones that have a fluid
    /// neighbour.
    pub fn fresh(&self) -> Vec<usize> {
        self.nodes.iter().filter(|(_, c)| matches!(c, NodeChange::Uncovered(nb) if !nb.is_empty())).map(|(n, _)| *n).collect()
    }
}

/// What a geometry update did to the fluid (lattice units).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GeometryChange {
    /// Nodes that became fluid.
    pub uncovered: usize,
    /// Nodes that left the fluid.
    pub covered: usize,
    /// Mass of the fresh nodes minus the mass of the covered ones.
    pub mass_change: f64,
    /// Uncovered nodes with no fluid neighbour (left at their previous values).
    pub isolated: usize,
}

impl<S: Storage> FluidSolver<S> {
    /// Rebuilds the geometry with `obstacles` (the scene's user obstacles and the moving
    /// bodies' walls; face walls are added by the layout) and initialises uncovered nodes.
    pub fn set_obstacles(&mut self, obstacles: &[Obstacle]) -> GeometryChange {
        let new = self.layout_with(obstacles);
        self.set_layout(new)
    }

    /// The layout of this solver's lattice and faces with `obstacles` (what
    /// [`Self::set_obstacles`] installs), without installing it: rebuilt from the current one
    /// near the obstacles that changed ([`Layout::rebuilt`]).
    pub fn layout_with(&self, obstacles: &[Obstacle]) -> Layout {
        self.layout.rebuilt(obstacles)
    }

    /// [`Self::layout_with`], the questions of kernel level sets (the nodes' sides, the ghosts'
    /// wall points) answered by `queries` (a device's twin, [`super::LevelSetQueries`]).
    pub fn layout_with_level_sets(&self, obstacles: &[Obstacle], queries: &dyn super::LevelSetQueries) -> Layout {
        self.layout.rebuilt_with(obstacles, queries)
    }

    /// Installs `new` (a layout of the same lattice, [`Self::layout_with`]) and initialises
    /// uncovered nodes from the populations of their fluid neighbours. It reads the populations
    /// of [`LayoutChange::reads`] only and writes those of the fresh nodes
    /// ([`LayoutChange::fresh`]): a backend whose populations live elsewhere (the GPU) brings
    /// back and sends up those nodes alone.
    pub fn set_layout(&mut self, new: Layout) -> GeometryChange {
        let plan = LayoutChange::between(&self.layout, &new);
        self.apply_layout(new, &plan)
    }

    /// [`Self::set_layout`] with its plan already made (`plan` = [`LayoutChange::between`] the
    /// current layout and `new`), so that a caller who needed the plan first does not scan the
    /// lattice twice.
    pub fn apply_layout(&mut self, new: Layout, plan: &LayoutChange) -> GeometryChange {
        self.layout = new;
        let nv = self.pop.nv;
        let q = self.eq.q();
        let mut change = GeometryChange::default();
        let mut fk = vec![0.0; nv];
        let mut fresh: Vec<(usize, Vec<f64>)> = Vec::new();
        for (node, c) in &plan.nodes {
            match c {
                NodeChange::Covered => {
                    change.covered += 1;
                    self.pop.gather_populations(&self.f, *node, &self.shift, &mut fk);
                    change.mass_change -= fk[..q].iter().sum::<f64>();
                }
                NodeChange::Uncovered(neighbours) => {
                    change.uncovered += 1;
                    if neighbours.is_empty() {
                        change.isolated += 1;
                        continue;
                    }
                    let mut sum = vec![0.0; nv];
                    for &k in neighbours {
                        self.pop.gather_populations(&self.f, k, &self.shift, &mut fk);
                        sum.iter_mut().zip(&fk).for_each(|(s, v)| *s += v);
                    }
                    let vals: Vec<f64> = sum.iter().map(|s| s / neighbours.len() as f64).collect();
                    change.mass_change += vals[..q].iter().sum::<f64>();
                    fresh.push((*node, vals));
                }
            }
        }
        for (node, vals) in fresh {
            self.pop.scatter_populations(&mut self.f, node, &self.shift, &vals);
        }
        change
    }

    /// The macroscopic state of fⁿ at `p` (interior node coordinates) from fluid nodes only:
    /// multilinear interpolation when every corner of the cell around `p` is fluid, else the
    /// least-squares linear fit over the fluid nodes of the 4ᴰ block around it (exact for
    /// linear fields, as the multilinear case is); `None` when that block has too few fluid
    /// nodes for a fit.
    pub fn sample(&self, p: [f64; 3]) -> Option<Macro> {
        let stencil = self.sample_stencil(p)?;
        let mut m = Macro::default();
        for (node, w) in stencil {
            let mk = self.macro_at(node);
            m.rho += w * mk.rho;
            m.theta += w * mk.theta;
            for a in 0..3 {
                m.u[a] += w * mk.u[a];
            }
        }
        Some(m)
    }
}

impl<S: Storage> FluidSolver<S> {
    /// The fluid nodes [`Self::sample`] reads at `p`, with their weights (`None` where it finds
    /// too few).
    pub fn sample_stencil(&self, p: [f64; 3]) -> Option<Vec<(usize, f64)>> {
        let mut out = Vec::new();
        linear_stencil(&self.layout, p, &mut out).then_some(out)
    }

    /// [`Self::sample_stencil`] appended to `out` (the same nodes and weights; nothing appended
    /// where it finds too few, and then `false`): a caller that lays out many samples (method
    /// 1's traction plan, two a surface piece each step) allocates nothing per sample.
    pub fn sample_stencil_into(&self, p: [f64; 3], out: &mut Vec<(usize, f64)>) -> bool {
        linear_stencil(&self.layout, p, out)
    }
}

/// Weights (node, w) that reproduce linear fields at `p` from fluid nodes (see
/// [`FluidSolver::sample`]), appended to `out`; `false` (nothing appended) where the block
/// around `p` has too few fluid nodes.
fn linear_stencil(layout: &Layout, p: [f64; 3], out: &mut Vec<(usize, f64)>) -> bool {
    let dim = layout.grid.dim;
    let periodic = layout.boundaries.periodic_axes(dim);
    let fluid_at = |x: [i64; 3]| fluid_node(&layout.grid, &layout.kind, &periodic, x);
    let start = out.len();
    if multilinear_corners(dim, p).all(|(x, w)| fluid_at(x).map(|i| out.push((i, w))).is_some()) {
        return true;
    }
    out.truncate(start);
    let base: [i64; 3] = std::array::from_fn(|a| if a < dim { p[a].floor() as i64 } else { p[a].round() as i64 });
    // Least squares: value ≈ a + g·(x − p) over the fluid nodes of the block; the value at p is
    // a = e₀ᵀ (AᵀA)⁻¹ Aᵀ φ, so node k gets weight e₀ᵀ (AᵀA)⁻¹ A_kᵀ.
    let zr = if dim == 3 { -1..=2 } else { 0..=0 };
    // at most the 4ᴰ block's 64 nodes (16 in 2D)
    let mut rows = [(0usize, [0.0f64; 4]); 64];
    let mut n_rows = 0;
    for dz in zr {
        for dy in -1..=2i64 {
            for dx in -1..=2i64 {
                let x = [base[0] + dx, base[1] + dy, base[2] + dz];
                if let Some(i) = fluid_at(x) {
                    let r = [1.0, x[0] as f64 - p[0], x[1] as f64 - p[1], if dim == 3 { x[2] as f64 - p[2] } else { 0.0 }];
                    rows[n_rows] = (i, r);
                    n_rows += 1;
                }
            }
        }
    }
    let rows = &rows[..n_rows];
    let m = dim + 1;
    if rows.len() < m + 1 {
        return false;
    }
    let mut ata = [[0.0f64; 4]; 4];
    for (_, r) in rows {
        for i in 0..m {
            for j in 0..m {
                ata[i][j] += r[i] * r[j];
            }
        }
    }
    let Some(e0) = solve_small(ata, m) else { return false };
    out.extend(rows.iter().map(|&(i, r)| (i, (0..m).map(|k| e0[k] * r[k]).sum())));
    true
}

/// The first row of the inverse of the symmetric m×m matrix `a` (Gauss–Jordan with partial
/// pivoting); `None` when it is singular (fluid nodes on a line).
fn solve_small(mut a: [[f64; 4]; 4], m: usize) -> Option<[f64; 4]> {
    let mut inv = [[0.0f64; 4]; 4];
    for (i, row) in inv.iter_mut().enumerate().take(m) {
        row[i] = 1.0;
    }
    let scale = (0..m).map(|i| a[i][i].abs()).fold(0.0, f64::max);
    for col in 0..m {
        let piv = (col..m).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() <= 1e-10 * scale {
            return None;
        }
        a.swap(col, piv);
        inv.swap(col, piv);
        let d = a[col][col];
        for k in 0..m {
            a[col][k] /= d;
            inv[col][k] /= d;
        }
        for r in 0..m {
            if r != col {
                let f = a[r][col];
                for k in 0..m {
                    a[r][k] -= f * a[col][k];
                    inv[r][k] -= f * inv[col][k];
                }
            }
        }
    }
    // (AᵀA)⁻¹ is symmetric: its first row is its first column.
    Some(std::array::from_fn(|k| if k < m { inv[k][0] } else { 0.0 }))
}

/// The 3ᴰ − 1 offsets to a node's surrounding nodes.
fn neighbour_offsets(dim: usize) -> Vec<[i64; 3]> {
    let zr = if dim == 3 { -1..=1 } else { 0..=0 };
    let mut out = Vec::new();
    for dz in zr {
        for dy in -1..=1 {
            for dx in -1..=1 {
                if (dx, dy, dz) != (0, 0, 0) {
                    out.push([dx, dy, dz]);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use crate::fluid::*;

    fn box_solver(obstacles: &[Obstacle]) -> FluidSolver {
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let params = timestep::choose(0.05, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        FluidSolver::new(eq, Grid::new(2, [24, 24, 1]), Boundaries::periodic(), obstacles, params, |x| Macro {
            rho: 1.0 + 0.01 * (x[0] / 24.0),
            u: [0.0; 3],
            theta: 0.6,
        })
    }

    fn disc(cx: f64) -> Obstacle {
        Obstacle { shape: Shape::Cylinder { center: [cx, 12.0, 0.0], radius: 4.0 }, velocity: [0.0; 3], temperature: None }
    }

    #[test]
    fn a_moving_disc_uncovers_and_covers_nodes_with_admissible_fresh_states() {
        let mut s = box_solver(&[disc(10.0)]);
        let before = s.layout.fluid_count;
        let m0 = s.totals().mass;
        // A shift by one whole cell covers as many nodes as it uncovers.
        let ch = s.set_obstacles(&[disc(11.0)]);
        assert_eq!(s.layout.fluid_count, before, "{ch:?}");
        assert!(ch.uncovered > 0 && ch.covered == ch.uncovered && ch.isolated == 0, "{ch:?}");
        // Fresh nodes on the trailing side take their neighbours' density (ρ varies by 1 % over the box).
        let m1 = s.totals().mass;
        assert!(((m1 - m0) - ch.mass_change).abs() < 1e-12, "{m0} {m1} {ch:?}");
        assert!(ch.mass_change.abs() < 0.01 * ch.uncovered as f64 * 1.01, "{ch:?}");
        for node in 0..s.layout.grid.len() {
            if s.layout.kind[node] == layout::NodeKind::Fluid {
                let m = s.macro_at(node);
                assert!(m.rho > 0.99 && m.rho < 1.02 && (m.theta - 0.6).abs() < 1e-12, "{m:?}");
            }
        }
        // Sampling between nodes interpolates linearly; next to the disc only fluid nodes count.
        let m = s.sample([3.5, 5.0, 0.0]).unwrap();
        assert!((m.rho - (1.0 + 0.01 * 3.5 / 24.0)).abs() < 1e-12, "{m:?}");
        assert!(s.sample([11.0, 12.0, 0.0]).is_none(), "the disc's centre is more than two cells from the fluid");
        // Next to the disc (cells with solid corners) the fit is still exact for the linear ρ
        // (away from the fresh nodes on the trailing side, which hold their neighbours' mean).
        for p in [[11.2, 16.3, 0.0], [11.2, 7.4, 0.0], [15.3, 12.0, 0.0]] {
            let m = s.sample(p).unwrap();
            assert!((m.rho - (1.0 + 0.01 * p[0] / 24.0)).abs() < 1e-12, "{p:?}: {m:?}");
        }
        s.step().expect("stays stable after the move");
    }

    /// `sample_stencil_into` appends to what the caller holds and leaves it as it was where it
    /// finds too few fluid nodes: over points across a box with a disc (cells all fluid, cells
    /// with solid corners, points deep in the disc), every stencil it appends reproduces linear
    /// fields (Σ w = 1, Σ w x_k = p) from fluid nodes only, and a refused point appends nothing
    /// (each case met: multilinear, least-squares and refused points).
    #[test]
    fn a_sample_stencil_appends_a_linear_stencil_or_nothing() {
        let s = box_solver(&[disc(10.0)]);
        let g = &s.layout.grid;
        let prefix = vec![(usize::MAX, -1.0); 3];
        let (mut corners, mut fitted, mut refused) = (0, 0, 0);
        for a in 0..60 {
            for b in 0..60 {
                let p = [1.0 + 0.37 * a as f64, 1.0 + 0.37 * b as f64, 0.0];
                let mut out = prefix.clone();
                let found = s.sample_stencil_into(p, &mut out);
                assert_eq!(out[..3], prefix[..], "{p:?}: the caller's entries");
                let st = &out[3..];
                if !found {
                    assert!(st.is_empty(), "{p:?}: a refused point appends nothing");
                    refused += 1;
                    continue;
                }
                assert!(st.iter().all(|&(n, _)| s.layout.kind[n] == layout::NodeKind::Fluid), "{p:?}: fluid nodes only");
                let sum: f64 = st.iter().map(|&(_, w)| w).sum();
                let first: [f64; 2] = std::array::from_fn(|k| st.iter().map(|&(n, w)| w * g.coords(n)[k] as f64).sum::<f64>());
                assert!((sum - 1.0).abs() < 1e-12 && (first[0] - p[0]).abs() < 1e-11 && (first[1] - p[1]).abs() < 1e-11, "{p:?}: {sum} {first:?}");
                if st.iter().all(|&(_, w)| w >= 0.0) && st.len() == 4 {
                    corners += 1;
                } else {
                    fitted += 1;
                }
            }
        }
        eprintln!("{corners} multilinear, {fitted} fitted, {refused} refused");
        assert!(corners > 1000 && fitted > 20 && refused > 20, "{corners} multilinear, {fitted} fitted, {refused} refused");
    }

    /// `LayoutChange::between` (the lattice in chunks on the pool's threads, unchanged chunks
    /// passed over) lists what a plain scan of every node lists, in the same order: on lattices
    /// of many chunks, 2D and 3D, with discs that move across chunk boundaries.
    #[test]
    fn a_change_of_layout_lists_every_node_that_changes_side_in_order() {
        use crate::fluid::layout::{Layout, NodeKind};
        let plain = |old: &Layout, new: &Layout| -> Vec<(usize, NodeChange)> {
            let g = &new.grid;
            let fluid = |l: &Layout, k: usize| l.kind[k] == NodeKind::Fluid;
            let mut out = Vec::new();
            for node in 0..g.len() {
                match (fluid(old, node), fluid(new, node)) {
                    (true, false) => out.push((node, NodeChange::Covered)),
                    (false, true) => {
                        let x = g.coords(node);
                        let mut nb = Vec::new();
                        for d in super::neighbour_offsets(g.dim) {
                            let y = [x[0] + d[0], x[1] + d[1], x[2] + d[2]];
                            if g.contains(y) && fluid(old, g.index(y)) && fluid(new, g.index(y)) {
                                nb.push(g.index(y));
                            }
                        }
                        out.push((node, NodeChange::Uncovered(nb)));
                    }
                    _ => {}
                }
            }
            out
        };
        for (dim, n) in [(2, [160, 90, 1]), (3, [40, 36, 30])] {
            let grid = Grid::new(dim, n);
            let zc = if dim == 3 { 15.0 } else { 0.0 };
            let body = |c: [f64; 2]| {
                let (center, radius) = ([c[0], c[1], zc], 6.3);
                let shape = if dim == 2 { Shape::Cylinder { center, radius } } else { Shape::Sphere { center, radius } };
                Obstacle { shape, velocity: [0.0; 3], temperature: None }
            };
            let discs = |t: f64| vec![body([30.0 + t, 40.0 - 0.6 * t]), body([22.0 - 0.4 * t, 14.0 + t])];
            let mut layout = Layout::new(grid.clone(), Boundaries::periodic(), &discs(0.0));
            assert!(grid.len() > 3 * 4096, "{dim}D: {} nodes, several chunks", grid.len());
            let mut changed = 0;
            for step in 1..=6 {
                let next = layout.rebuilt(&discs(0.7 * step as f64));
                let ch = LayoutChange::between(&layout, &next);
                assert_eq!(ch.nodes, plain(&layout, &next), "{dim}D step {step}");
                changed += ch.nodes.len();
                layout = next;
            }
            assert!(changed > 50, "{dim}D: {changed} nodes changed side");
        }
    }

    /// A change of layout reads the populations of `LayoutChange::reads` only and writes those
    /// of `fresh` only (what the GPU backend brings back and sends up instead of the whole
    /// state): with every other node's populations NaN, the disc moved by 0.7 cells gives the
    /// same fresh values and mass change, bit for bit, and changes no other node.
    #[test]
    fn a_change_of_layout_reads_and_writes_only_the_nodes_it_lists() {
        let mut whole = box_solver(&[disc(10.0)]);
        let new = whole.layout_with(&[disc(10.7)]);
        let change = LayoutChange::between(&whole.layout, &new);
        let (reads, fresh) = (change.reads(), change.fresh());
        let covered = change.nodes.iter().filter(|(_, c)| *c == NodeChange::Covered).count();
        assert!(covered > 0 && !fresh.is_empty() && reads.len() > fresh.len() + covered, "{} reads, {} fresh, {covered} covered", reads.len(), fresh.len());
        assert!(reads.windows(2).all(|w| w[0] < w[1]));
        let mut listed = box_solver(&[disc(10.0)]);
        let nv = whole.pop.nv;
        for node in 0..whole.layout.grid.len() {
            if reads.binary_search(&node).is_err() {
                listed.pop.scatter(&mut listed.f, node, &vec![f64::NAN; nv]);
            }
        }
        let before = whole.f.clone();
        let a = whole.set_layout(new.clone());
        let b = listed.set_layout(new);
        assert_eq!(a.mass_change.to_bits(), b.mass_change.to_bits(), "{a:?} vs {b:?}");
        assert_eq!((a.uncovered, a.covered, a.isolated), (b.uncovered, b.covered, b.isolated));
        let (mut x, mut y, mut was) = (vec![0.0f64; nv], vec![0.0f64; nv], vec![0.0f64; nv]);
        for node in 0..whole.layout.grid.len() {
            whole.pop.gather(&whole.f, node, &mut x);
            whole.pop.gather(&before, node, &mut was);
            let written = x.iter().zip(&was).any(|(p, q)| p.to_bits() != q.to_bits());
            assert_eq!(written, fresh.contains(&node), "node {node}");
            if written {
                listed.pop.gather(&listed.f, node, &mut y);
                assert!(x.iter().zip(&y).all(|(p, q)| p.to_bits() == q.to_bits()), "node {node}");
            }
        }
    }

    #[test]
    fn a_body_through_a_face_wall_gives_every_ghost_a_fluid_image() {
        // A fold-like block clamped beyond the x_min wall: its ghosts beyond the wall are
        // nearest to its lateral face, whose image point lies outside the fluid.
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let params = timestep::choose(0.05, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        let mut b = Boundaries::periodic();
        b.faces[0] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
        b.faces[1] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
        let block = Polygon::new(vec![[-1.47, 6.3], [9.6, 6.3], [9.6, 12.4], [-1.47, 12.4]], vec![[0.0; 3]; 4]);
        let o = Obstacle { shape: Shape::Polygon(block), velocity: [0.0; 3], temperature: None };
        let mut s = FluidSolver::new(eq, Grid::new(2, [24, 24, 1]), b, &[o], params, |_| Macro { rho: 1.0, u: [0.0; 3], theta: 0.6 });
        assert!(!s.layout.ghosts.is_empty());
        for g in &s.layout.ghosts {
            let w: f64 = g.image.iter().map(|(_, w)| w).sum();
            assert!((w - 1.0).abs() < 1e-12, "ghost {:?} has image weights summing to {w}", s.layout.grid.coords(g.node));
        }
        for _ in 0..20 {
            s.step().expect("finite next to the junction of the body and the wall");
        }
    }

    #[test]
    fn a_slit_narrower_than_a_cell_holds_no_fluid_node() {
        // Two blocks with a vertical slit centred on the node column x = 12: a slit of 0.8 cells
        // pinches that column out of the fluid (every node within half a cell of both walls);
        // one of 1.2 cells keeps it.
        let blocks = |w: f64| {
            let block = |x0: f64, x1: f64| Obstacle {
                shape: Shape::Polygon(Polygon::new(vec![[x0, 6.3], [x1, 6.3], [x1, 14.6], [x0, 14.6]], vec![[0.0; 3]; 4])),
                velocity: [0.0; 3],
                temperature: None,
            };
            [block(2.2, 12.0 - 0.5 * w), block(12.0 + 0.5 * w, 21.7)]
        };
        let fluid_in_slit = |w: f64| {
            let s = box_solver(&blocks(w));
            (7..=14).filter(|&y| s.layout.kind[s.layout.grid.index([12, y, 0])] == layout::NodeKind::Fluid).count()
        };
        assert_eq!(fluid_in_slit(0.8), 0);
        assert_eq!(fluid_in_slit(1.2), 8);
        // a closing slit: the pinched nodes leave the fluid with their mass, and the step runs
        let mut s = box_solver(&blocks(1.2));
        let ch = s.set_obstacles(&blocks(0.8));
        assert_eq!((ch.covered, ch.uncovered), (8, 0), "{ch:?}");
        for g in s.layout.ghosts.iter().filter(|g| s.layout.grid.coords(g.node)[0] == 12) {
            assert!(g.ratio >= 0.0 && g.ratio < layout::PINCH, "pinched ghost ratio {}", g.ratio);
        }
        s.step().expect("finite after the slit closed");
    }
}
