//! How a [`Layout`] is built, pass by pass, once per scene and once per coupled step when walls
//! move (seed 000 §2.4: the moving walls' nodes are classified again at every step). In order:
//!
//! 1. the recomputed nodes: every node, or a region's ([`super::rebuild`]), the rest copied;
//! 2. **owners**: which obstacle contains (or pinches) each node;
//! 3. **kinds**: fluid, face halo, periodic copy or inactive, from its owner and place;
//! 4. **reach**: solid nodes within two cells of the fluid become ghosts, unread halos inactive;
//! 5. **ghosts**: each ghost's wall point, image stencil and wall velocity;
//! 6. **halo lists**: the face halos and periodic copies, merged with the previous layout's;
//! 7. **thin taps**: the stencils next to walls thinner than the upwind stencil;
//! 8. **wall faces**: the fluid nodes next to a wall.
//!
//! The passes over the recomputed nodes and the ghosts run on the pool's threads, collected in
//! node order (the same answers as one by one); the lists' merges are serial. Each part tells
//! [`LevelSetQueries::part_timed`] how long it took ([`LayoutPart`]). Units: lattice cells.

use super::boundary::{Boundaries, Face, FaceCondition};
use super::geometry::{Obstacle, Outside, Shape};
use super::grid::{Grid, HALO};
use super::interpolation::interpolation_stencil;
use super::layout::{FaceHalo, Ghost, HaloReach, Layout, NodeKind, PAR_NODES, PINCH, PeriodicRun, ghost_wall_velocity};
use super::level_set_queries::{GhostQuery, GhostWall, LayoutPart, LevelSetQueries, PartClock, wall_point};
use super::neighbours::{fluid_node, fluid_within_reach, nearest_fluid, wall_face_nodes};
use super::rebuild::Region;
use super::thin_wall::{ThinTap, WallGeometry, thin_taps};
use rayon::prelude::*;

impl Layout {
    /// [`Layout::new`], or with `previous`: only the nodes of the region recomputed (it stays
    /// three cells clear of the periodic faces, and takes in the halo of any other face it
    /// reaches), the rest copied. What the kernel level sets among the obstacles are asked — the
    /// nodes' sides, the ghosts' wall points — `level_sets` answers, one call per set and
    /// question ([`LevelSetQueries`]).
    pub(super) fn build(
        grid: Grid,
        boundaries: Boundaries,
        user_obstacles: &[Obstacle],
        previous: Option<(&Layout, Region)>,
        level_sets: &dyn LevelSetQueries,
    ) -> Self {
        let mut clock = PartClock::start(level_sets);
        let obstacles = with_face_walls(&grid, &boundaries, user_obstacles);
        let todo = recomputed_nodes(&grid, previous.map(|p| p.1));
        let mut kind = match previous {
            None => vec![NodeKind::Inactive; grid.len()],
            Some((p, _)) => p.kind.clone(),
        };
        let points: Vec<[f64; 3]> = todo.par_iter().with_min_len(PAR_NODES).map(|&idx| lattice_point(grid.coords(idx))).collect();
        let passes = Passes { grid: &grid, boundaries: &boundaries, obstacles: &obstacles, periodic_axis: boundaries.periodic_axes(grid.dim), todo: &todo };
        clock.done(LayoutPart::Nodes);

        let level_set_side = passes.level_set_sides(level_sets, &points);
        clock.skip();
        let owner = passes.owners(&level_set_side, &points);
        clock.done(LayoutPart::Owners);
        passes.kinds(&owner, &mut kind);
        clock.done(LayoutPart::Kinds);
        passes.reach(&owner, &mut kind);
        clock.done(LayoutPart::Reach);

        let ghost_of = passes.ghost_owners(&owner, &kind);
        let level_set_wall = passes.level_set_walls(&ghost_of, &kind, level_sets, &mut clock);
        clock.done(LayoutPart::GhostList);
        let ghosts = passes.ghosts(&ghost_of, &level_set_wall, &kind);
        clock.done(LayoutPart::Images);

        let (face_halos, periodic) = passes.halos(&kind);
        let (ghosts, face_halos, periodic) = match previous {
            None => (ghosts, face_halos, periodic),
            Some((p, r)) => merge_with_previous(&grid, p, r, ghosts, face_halos, periodic),
        };
        let periodic = periodic_runs(&grid, periodic);
        let fluid_count = kind.par_iter().with_min_len(64 * PAR_NODES).filter(|k| **k == NodeKind::Fluid).count();
        clock.done(LayoutPart::HaloLists);

        let geo = WallGeometry { grid: &grid, kind: &kind, ghosts: &ghosts, obstacles: &obstacles, periodic: &passes.periodic_axis };
        let thin_taps = match previous {
            None => thin_taps(&geo, None),
            Some((p, r)) => {
                let mut taps: Vec<ThinTap> = p.thin_taps.iter().filter(|t| !r.contains(grid.coords(t.node))).cloned().collect();
                taps.extend(thin_taps(&geo, Some(&todo)));
                // stable: a node's taps keep their order
                taps.sort_by_key(|t| t.node);
                taps
            }
        };
        clock.done(LayoutPart::ThinTaps);
        let wall_faces = wall_face_nodes(&grid, &kind, ghosts.iter().map(|g| g.node).chain(face_halos.iter().map(|h| h.node)));
        clock.done(LayoutPart::WallFaces);
        Layout { grid, boundaries, obstacles, kind, ghosts, face_halos, periodic, fluid_count, thin_taps, wall_faces }
    }
}

/// The position (cells) of the node at interior coordinates `x`.
fn lattice_point(x: [i64; 3]) -> [f64; 3] {
    [x[0] as f64, x[1] as f64, x[2] as f64]
}

/// The face walls of `boundaries` as half-spaces half a cell outside the last interior node,
/// followed by the scene's obstacles.
fn with_face_walls(grid: &Grid, boundaries: &Boundaries, user_obstacles: &[Obstacle]) -> Vec<Obstacle> {
    let mut obstacles = Vec::new();
    for face in Face::ALL {
        let a = face.axis();
        if a >= grid.dim {
            continue;
        }
        if let FaceCondition::Wall { velocity, temperature } = boundaries.face(face) {
            let mut normal = [0.0; 3];
            // The wall lies half a cell outside the last interior node.
            let offset = if face.is_max() {
                normal[a] = -1.0;
                -(grid.n[a] as f64 - 0.5)
            } else {
                normal[a] = 1.0;
                -0.5
            };
            obstacles.push(Obstacle { shape: Shape::HalfSpace { normal, offset }, velocity: *velocity, temperature: *temperature });
        }
    }
    obstacles.extend_from_slice(user_obstacles);
    obstacles
}

/// The padded indices of the nodes a build recomputes, ascending: all, or the region's (the
/// others keep their kinds, ghost entries and thin taps).
fn recomputed_nodes(grid: &Grid, region: Option<Region>) -> Vec<usize> {
    let Some(r) = region else { return (0..grid.len()).collect() };
    let mut v = Vec::new();
    for z in r.lo[2]..=r.hi[2] {
        for y in r.lo[1]..=r.hi[1] {
            for x in r.lo[0]..=r.hi[0] {
                v.push(grid.index([x, y, z]));
            }
        }
    }
    v
}

/// The obstacle a recomputed node belongs to, as the owners' pass finds it.
#[derive(Clone, Copy, Debug)]
enum Owner {
    /// In no obstacle and pinched by none: fluid, or a halo node.
    Free,
    /// Inside obstacle `k`, or pinched with `k` the nearer of the two.
    One(usize),
    /// Inside two or more: the deepest owns it, found only where that matters (a ghost).
    Several,
}

/// What every pass of one build reads: the lattice and its faces, the obstacles (face walls
/// first), the periodic axes and the recomputed nodes (ascending padded indices).
struct Passes<'a> {
    grid: &'a Grid,
    boundaries: &'a Boundaries,
    obstacles: &'a [Obstacle],
    periodic_axis: [bool; 3],
    todo: &'a [usize],
}

impl Passes<'_> {
    /// Each kernel level set's side of every recomputed node at `points`
    /// ([`super::KernelLevelSet::outside_distance`]: one evaluation of L, the sum stopped as
    /// soon as it is positive), asked of `level_sets` for all the nodes at once; `None` for
    /// the other shapes.
    fn level_set_sides(&self, level_sets: &dyn LevelSetQueries, points: &[[f64; 3]]) -> Vec<Option<Vec<Option<f64>>>> {
        self.obstacles
            .iter()
            .enumerate()
            .map(|(k, o)| match &o.shape {
                Shape::KernelLevelSet(ls) => Some(level_sets.outside_distances(k, ls, points)),
                _ => None,
            })
            .collect()
    }

    /// The obstacle node `i` at `p` belongs to: deepest-first, the one that contains the point
    /// with the largest (least negative) sdf. A node outside every obstacle but within half a
    /// cell of two of them is *pinched* (a slit narrower than a cell, e.g. a closing glottis):
    /// it leaves the fluid too, with the nearest of the two (d ≥ 0), since a fluid node
    /// squeezed between two walls that close on it is compressed without bound. Most nodes lie
    /// inside one obstacle or none: their side comes from `Shape::outside_distance_below` (a
    /// level set's from `sides`; a polygon's edges within `PINCH` of the node). Where two
    /// obstacles contain the node only the fact is kept ([`Owner::Several`]): which of them
    /// owns it matters to a ghost alone, and the depths that decide it (a level set's by Newton
    /// steps) are taken for the ghosts ([`Self::deepest`]).
    #[inline]
    fn owner(&self, sides: &[Option<Vec<Option<f64>>>], i: usize, p: [f64; 3]) -> Owner {
        let mut inside: Option<usize> = None;
        let mut near: [Option<(usize, f64)>; 2] = [None, None];
        for (k, o) in self.obstacles.iter().enumerate() {
            let side = match &sides[k] {
                Some(d) => Outside::of(d[i], PINCH),
                None => o.shape.outside_distance_below(p, PINCH),
            };
            match side {
                Outside::Inside => {
                    if inside.is_some() {
                        return Owner::Several;
                    }
                    inside = Some(k);
                }
                Outside::Within(d) => {
                    if near[0].is_none_or(|(_, nd)| d < nd) {
                        near[1] = near[0];
                        near[0] = Some((k, d));
                    } else if near[1].is_none_or(|(_, nd)| d < nd) {
                        near[1] = Some((k, d));
                    }
                }
                Outside::Beyond => {}
            }
        }
        match inside.or(if near[1].is_some() { near[0].map(|(k, _)| k) } else { None }) {
            Some(k) => Owner::One(k),
            None => Owner::Free,
        }
    }

    /// Every recomputed node's [`Self::owner`] (independent of each other: on the pool's
    /// threads, in order).
    fn owners(&self, sides: &[Option<Vec<Option<f64>>>], points: &[[f64; 3]]) -> Vec<Owner> {
        points.par_iter().enumerate().with_min_len(PAR_NODES).map(|(i, &p)| self.owner(sides, i, p)).collect()
    }

    /// The deepest of the obstacles that contain `p`: a node inside one has sdf < 0 there
    /// exactly (`Shape::outside_distance`'s contract), so one is found.
    fn deepest(&self, p: [f64; 3]) -> usize {
        let mut deepest: Option<(usize, f64)> = None;
        for (k, o) in self.obstacles.iter().enumerate() {
            let d = o.shape.sdf(p);
            if d < 0.0 && deepest.is_none_or(|(_, bd)| d > bd) {
                deepest = Some((k, d));
            }
        }
        deepest.expect("a node inside two obstacles has a negative sdf in each").0
    }

    /// Each recomputed node's kind from its owner and place: inside an obstacle inactive (until
    /// [`Self::reach`]), else fluid in the interior, a periodic copy outside it along periodic
    /// axes only, a face halo outside it along one other axis, inactive in the halo's edges.
    fn kinds(&self, owner: &[Owner], kind: &mut [NodeKind]) {
        let grid = self.grid;
        let side = |idx: usize, owner: &Owner| -> NodeKind {
            if !matches!(owner, Owner::Free) {
                return NodeKind::Inactive;
            }
            let x = grid.coords(idx);
            let (mut outside, mut all_periodic) = (0, true);
            for a in 0..3 {
                if x[a] < 0 || x[a] >= grid.n[a] as i64 {
                    outside += 1;
                    all_periodic &= self.periodic_axis[a];
                }
            }
            match outside {
                0 => NodeKind::Fluid,
                _ if all_periodic => NodeKind::Periodic,
                1 => NodeKind::FaceHalo,
                _ => NodeKind::Inactive,
            }
        };
        let sides: Vec<NodeKind> = self.todo.par_iter().zip(owner).with_min_len(PAR_NODES).map(|(&idx, o)| side(idx, o)).collect();
        for (&idx, k) in self.todo.iter().zip(&sides) {
            kind[idx] = *k;
        }
    }

    /// Solid nodes within axis reach of a fluid node become ghosts; face halos stay only where
    /// a fluid stencil reads them (not in corners). Both read the fluid nodes only, which this
    /// does not change: found on the pool's threads, then applied.
    fn reach(&self, owner: &[Owner], kind: &mut [NodeKind]) {
        let walls: Vec<Option<NodeKind>> = self
            .todo
            .par_iter()
            .zip(owner)
            .with_min_len(PAR_NODES)
            .map(|(&idx, o)| match (o, kind[idx]) {
                (Owner::One(_) | Owner::Several, _) => fluid_within_reach(self.grid, kind, idx).then_some(NodeKind::Ghost),
                (Owner::Free, NodeKind::FaceHalo) => (!fluid_within_reach(self.grid, kind, idx)).then_some(NodeKind::Inactive),
                _ => None,
            })
            .collect();
        for (&idx, w) in self.todo.iter().zip(&walls) {
            if let Some(k) = w {
                kind[idx] = *k;
            }
        }
    }

    /// The recomputed ghosts (node, obstacle) in node order, the owner of a ghost inside
    /// several obstacles found now ([`Self::deepest`]; on the pool's threads).
    fn ghost_owners(&self, owner: &[Owner], kind: &[NodeKind]) -> Vec<(usize, usize)> {
        self.todo
            .par_iter()
            .zip(owner)
            .with_min_len(PAR_NODES)
            .filter(|&(&idx, _)| kind[idx] == NodeKind::Ghost)
            .map(|(&idx, owner)| match *owner {
                Owner::One(k) => (idx, k),
                Owner::Several => (idx, self.deepest(lattice_point(self.grid.coords(idx)))),
                Owner::Free => unreachable!("a ghost is inside (or pinched by) a solid"),
            })
            .collect()
    }

    /// A level set's ghosts' wall points: the nearest of Newton's and two searches', one toward
    /// the fluid node that makes the node a ghost (`fluid::ghost_wall`), and the wall's
    /// velocity there (2.130), asked of `level_sets` one set at a time (the questions' time
    /// left out of `clock`'s parts); `None` for the ghosts of other shapes and those with no
    /// fluid node within two cells along an axis.
    fn level_set_walls(
        &self,
        ghost_of: &[(usize, usize)],
        kind: &[NodeKind],
        level_sets: &dyn LevelSetQueries,
        clock: &mut PartClock,
    ) -> Vec<Option<GhostWall>> {
        let grid = self.grid;
        let mut walls: Vec<Option<GhostWall>> = vec![None; ghost_of.len()];
        for (k, o) in self.obstacles.iter().enumerate() {
            let Shape::KernelLevelSet(ls) = &o.shape else { continue };
            let (at, queries): (Vec<usize>, Vec<GhostQuery>) = ghost_of
                .par_iter()
                .enumerate()
                .with_min_len(PAR_NODES)
                .filter(|(_, g)| g.1 == k)
                .filter_map(|(i, &(idx, _))| nearest_fluid(grid, kind, grid.coords(idx)).map(|q| (i, (lattice_point(grid.coords(idx)), lattice_point(q)))))
                .unzip();
            if queries.is_empty() {
                continue;
            }
            clock.done(LayoutPart::GhostList);
            let answers = level_sets.ghost_walls(k, ls, &queries);
            clock.skip();
            for (i, w) in at.into_iter().zip(answers) {
                walls[i] = Some(w);
            }
        }
        walls
    }

    /// Each ghost's image stencil (the fluid nodes around the ghost's mirror image across its
    /// wall, at least a cell beyond it) and wall velocity, on the pool's threads, in node order.
    fn ghosts(&self, ghost_of: &[(usize, usize)], level_set_wall: &[Option<GhostWall>], kind: &[NodeKind]) -> Vec<Ghost> {
        let grid = self.grid;
        // a node used for interpolation resolved to a fluid node (through periodic images)
        let fluid_at = |x: [i64; 3]| fluid_node(grid, kind, &self.periodic_axis, x);
        ghost_of
            .par_iter()
            .zip(level_set_wall)
            .with_min_len(PAR_NODES / 8)
            .map(|(&(idx, k), found)| {
                let p = lattice_point(grid.coords(idx));
                let o = &self.obstacles[k];
                let (d, nrm) = match (&o.shape, found) {
                    (_, Some(w)) => (w.distance, w.normal),
                    // a level set's ghost with no fluid node within two cells along an axis
                    (Shape::KernelLevelSet(_), None) => (o.shape.sdf(p), o.shape.normal(p)),
                    (shape, None) => shape.sdf_and_normal(p),
                };
                let wall = wall_point(p, d, nrm);
                let d_img = (-d).max(1.0);
                let img = [wall[0] + d_img * nrm[0], wall[1] + d_img * nrm[1], wall[2] + d_img * nrm[2]];
                let mut image = interpolation_stencil(grid, img, &fluid_at);
                if image.is_empty() {
                    // The image point fell where no fluid is near (a body that crosses a
                    // face wall: the nearest surface of a node beyond the wall can face away
                    // from the fluid): the nearest fluid node to the ghost itself, which is
                    // within two cells along an axis by the definition of a ghost.
                    image = interpolation_stencil(grid, p, &fluid_at);
                }
                // a level set's wall velocity came with its wall point (the same
                // `velocity_at(wall)` on the CPU)
                let v = match found {
                    Some(w) => w.velocity,
                    None => ghost_wall_velocity(o, wall),
                };
                Ghost { node: idx, image, ratio: d / d_img, wall_velocity: v, wall_temperature: o.temperature }
            })
            .collect()
    }

    /// The recomputed face halos and periodic copies (destination, source), in node order
    /// (found on the pool's threads: the region of the 3D glottis has 1.23·10⁶ nodes, of which
    /// a few are either).
    fn halos(&self, kind: &[NodeKind]) -> (Vec<FaceHalo>, Vec<(usize, usize)>) {
        let grid = self.grid;
        let halos: Vec<usize> =
            self.todo.par_iter().with_min_len(64 * PAR_NODES).copied().filter(|&i| matches!(kind[i], NodeKind::FaceHalo | NodeKind::Periodic)).collect();
        let mut face_halos = Vec::new();
        let mut periodic = Vec::new();
        for idx in halos {
            let x = grid.coords(idx);
            match kind[idx] {
                NodeKind::FaceHalo => {
                    let a = (0..3).find(|&a| x[a] < 0 || x[a] >= grid.n[a] as i64).unwrap();
                    let face = if x[a] < 0 { Face::ALL[2 * a] } else { Face::ALL[2 * a + 1] };
                    let mut s = x;
                    let n_a = grid.n[a] as i64;
                    s[a] = match (self.boundaries.face(face), x[a] < 0) {
                        // The mirror image across the plane half a cell outside the last node.
                        (FaceCondition::Slip, true) => -1 - x[a],
                        (FaceCondition::Slip, false) => 2 * n_a - 1 - x[a],
                        (_, true) => 0,
                        (_, false) => n_a - 1,
                    };
                    face_halos.push(FaceHalo { node: idx, face, source: grid.index(s) });
                }
                NodeKind::Periodic => {
                    // the interior node it copies, through the periodic axes
                    let mut s = x;
                    for a in 0..3 {
                        if self.periodic_axis[a] {
                            s[a] = s[a].rem_euclid(grid.n[a] as i64);
                        }
                    }
                    periodic.push((idx, grid.index(s)));
                }
                _ => {}
            }
        }
        (face_halos, periodic)
    }
}

/// The region's ghosts, face halos and periodic copies merged, in node order, with the previous
/// layout's `p` outside the region `r`.
fn merge_with_previous(
    grid: &Grid,
    p: &Layout,
    r: Region,
    ghosts: Vec<Ghost>,
    face_halos: Vec<FaceHalo>,
    periodic: Vec<(usize, usize)>,
) -> (Vec<Ghost>, Vec<FaceHalo>, Vec<(usize, usize)>) {
    let outside = |node: usize| !r.contains(grid.coords(node));
    let ghosts = merge_in_node_order(ghosts, p.ghosts.iter().filter(|g| outside(g.node)).cloned(), |g| g.node);
    let face_halos = merge_in_node_order(face_halos, p.face_halos.iter().filter(|h| outside(h.node)).cloned(), |h| h.node);
    let previous_periodic = p.periodic.iter().flat_map(|r| (0..r.len).map(move |k| (r.dst + k, r.src + k))).filter(|&(d, _)| outside(d));
    let periodic = merge_in_node_order(periodic, previous_periodic, |&(d, _)| d);
    (ghosts, face_halos, periodic)
}

/// The periodic copies (destination, source; in node order) as runs of consecutive pairs along
/// a row that the same stencils read.
fn periodic_runs(grid: &Grid, periodic: Vec<(usize, usize)>) -> Vec<PeriodicRun> {
    const { assert!(HALO >= 2) };
    let px = grid.padded[0];
    let mut runs: Vec<PeriodicRun> = Vec::new();
    for (d, s) in periodic {
        let reach = HaloReach::of(grid, grid.coords(d));
        if let Some(last) = runs.last_mut()
            && d == last.dst + last.len
            && s == last.src + last.len
            && d / px == last.dst / px
            && s / px == last.src / px
            && reach == last.reach
        {
            last.len += 1;
            continue;
        }
        runs.push(PeriodicRun { dst: d, src: s, len: 1, reach });
    }
    runs
}

/// `ours` and `theirs`, each in node order and with no node in both (a rebuilt region's lists
/// and the previous layout's entries outside it), merged in node order — what a stable sort of
/// the two together gives, each entry moved once (the 3D glottis's 173,000 ghosts a step).
fn merge_in_node_order<T>(ours: Vec<T>, theirs: impl Iterator<Item = T>, node: impl Fn(&T) -> usize) -> Vec<T> {
    debug_assert!(ours.windows(2).all(|w| node(&w[0]) < node(&w[1])), "the region's entries in node order");
    let mut out = Vec::with_capacity(ours.len() + theirs.size_hint().0);
    let mut theirs = theirs.peekable();
    for o in ours {
        while let Some(t) = theirs.next_if(|t| node(t) < node(&o)) {
            out.push(t);
        }
        out.push(o);
    }
    out.extend(theirs);
    debug_assert!(out.windows(2).all(|w| node(&w[0]) < node(&w[1])), "the merged entries in node order");
    out
}
