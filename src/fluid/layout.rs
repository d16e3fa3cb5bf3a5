//! Classification of every padded node (fluid, ghost, inlet/outlet halo, periodic halo,
//! inactive), the tables the boundary fill walks through and the stencils (with side ghosts) next to
//! thin walls. Built once per scene, and once per step when bodies move ([`super::moving`]).

use super::boundary::{Boundaries, Face, FaceCondition};
use super::geometry::{Obstacle, Outside, Shape, dot};
use super::grid::{Grid, HALO};
use super::interpolation::interpolation_stencil;
use super::level_set_queries::{GhostQuery, GhostWall, LayoutPart, LevelSetQueries, OnThePool, PartClock, wall_point};
use super::neighbours::{fluid_node, fluid_within_reach, nearest_fluid, wall_face_nodes};
use super::rebuild::Region;
use super::thin_wall::{ThinTap, WallGeometry, thin_taps};
use rayon::prelude::*;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum NodeKind {
    /// Updated by the solver.
    Fluid = 0,
    /// Solid node within reach of a fluid stencil: filled from its image point.
    Ghost = 1,
    /// Inlet or outlet halo node.
    FaceHalo = 2,
    /// Copy of a node on the other side of a periodic axis.
    Periodic = 3,
    /// Never read.
    Inactive = 4,
}

/// A ghost node with its image-point interpolation stencil.
#[derive(Clone, Debug, PartialEq)]
pub struct Ghost {
    pub node: usize,
    /// (node, weight) of fluid nodes around the image point; weights sum to 1.
    pub image: Vec<(usize, f64)>,
    /// d_ghost / d_image ∈ [−1, 0): linear extrapolation factor through the wall; in
    /// [0, PINCH) for a node pinched between two walls (interpolation between wall and image).
    pub ratio: f64,
    pub wall_velocity: [f64; 3],
    pub wall_temperature: Option<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FaceHalo {
    pub node: usize,
    pub face: Face,
    /// First interior node on the same line normal to the face (a slip face: the interior node
    /// as far inside as the halo node is outside, its mirror image).
    pub source: usize,
}

/// `len` consecutive periodic halo nodes from padded index `dst`, the images of the interior
/// nodes from `src`, all read by the same advection stencils.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PeriodicRun {
    pub dst: usize,
    pub src: usize,
    pub len: usize,
    pub reach: HaloReach,
}

/// Which advection stencils read a halo node. The third-order upwind difference of a fluid node
/// ([`super::upwind`]) reads, along each axis a separately, the nodes at +s, −s and −2s for the
/// velocities of sign s = sign c_a (the one-sided stencils of [`super::thin_wall`] read a subset
/// of these), so a halo node outside the interior along two or more axes is read by no stencil,
/// and one outside along one axis only by the velocities whose component along it reaches it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HaloReach {
    /// Outside the interior along more than one axis (an edge or a corner of the halo).
    Unread,
    /// Outside along `axis` only: `depth` −1, −2 below the interior (coordinate −1, −2) or +1,
    /// +2 above it (coordinate n, n + 1).
    Axis { axis: usize, depth: i8 },
}

impl HaloReach {
    /// The reach of the halo node at interior coordinates `x` (outside the interior).
    pub fn of(grid: &Grid, x: [i64; 3]) -> Self {
        let mut outside = (0..3).filter(|&a| x[a] < 0 || x[a] >= grid.n[a] as i64);
        match (outside.next(), outside.next()) {
            (Some(a), None) => {
                let n = grid.n[a] as i64;
                let depth = if x[a] < 0 { x[a] } else { x[a] - n + 1 };
                HaloReach::Axis { axis: a, depth: depth as i8 }
            }
            _ => HaloReach::Unread,
        }
    }

    /// Number of [`HaloReach::Axis`] reaches: 3 axes × 4 depths.
    pub const AXIS_REACHES: usize = 12;

    /// The index of an [`HaloReach::Axis`] reach below [`Self::AXIS_REACHES`]: 4 · axis + the
    /// depth's index (−2, −1, +1, +2 → 0, 1, 2, 3); `None` for [`HaloReach::Unread`].
    pub fn index(&self) -> Option<usize> {
        match *self {
            HaloReach::Unread => None,
            HaloReach::Axis { axis, depth } => Some(4 * axis + [0, 1, 0, 2, 3][(depth + 2) as usize]),
        }
    }

    /// Whether the advection stencil of velocity `c` reads the node: at depth ±1 every velocity
    /// with c_a ≠ 0 (its −s or +s tap), at −2 those with c_a > 0 and at +2 those with c_a < 0
    /// (the −2s tap).
    pub fn read_by(&self, c: [i32; 3]) -> bool {
        match *self {
            HaloReach::Unread => false,
            HaloReach::Axis { axis, depth } => match depth {
                -1 | 1 => c[axis] != 0,
                -2 => c[axis] > 0,
                2 => c[axis] < 0,
                d => unreachable!("the halo is {HALO} nodes deep, not {d}"),
            },
        }
    }
}

#[derive(Clone, Debug)]
pub struct Layout {
    pub grid: Grid,
    pub boundaries: Boundaries,
    /// Face walls turned into half-spaces, followed by the scene's obstacles.
    pub obstacles: Vec<Obstacle>,
    pub kind: Vec<NodeKind>,
    pub ghosts: Vec<Ghost>,
    pub face_halos: Vec<FaceHalo>,
    /// Periodic copies as runs of consecutive nodes along x that the same stencils read.
    pub periodic: Vec<PeriodicRun>,
    pub fluid_count: usize,
    /// The stencils of the fluid nodes next to walls thinner than the upwind stencil, with
    /// their side ghosts ([`super::thin_wall`]); empty for geometries without such walls.
    pub thin_taps: Vec<ThinTap>,
    /// The fluid nodes with a wall (a ghost or face-halo node) next to them along an axis,
    /// ascending: the nodes through whose faces the air hands momentum to the walls
    /// (`coupling::momentum_exchange`), found from the ghosts and face halos.
    pub wall_faces: Vec<usize>,
}

/// Nodes per task of the layout's parallel loops (level-set evaluations, kinds, reach tests,
/// thin-wall taps): enough to outweigh a
/// task's cost on the pool, few enough to spread a body's few thousand nodes over the threads.
pub(super) const PAR_NODES: usize = 256;

/// Distance (cells) from two obstacles within which a node between them is pinched out of the
/// fluid: a slit narrower than one cell holds no fluid node.
pub const PINCH: f64 = 0.5;

impl Layout {
    pub fn new(grid: Grid, boundaries: Boundaries, user_obstacles: &[Obstacle]) -> Self {
        Self::build(grid, boundaries, user_obstacles, None, &OnThePool)
    }

    /// [`Self::new`], or with `previous`: only the nodes of the region recomputed (it stays
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

        let n = grid.len();
        let periodic_axis = boundaries.periodic_axes(grid.dim);
        let pos = |x: [i64; 3]| [x[0] as f64, x[1] as f64, x[2] as f64];
        // the nodes recomputed: all, or the region's (the others keep their kinds, ghost
        // entries and thin taps)
        let todo: Vec<usize> = match previous {
            None => (0..n).collect(),
            Some((_, r)) => {
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
        };
        let mut kind = match previous {
            None => vec![NodeKind::Inactive; n],
            Some((p, _)) => p.kind.clone(),
        };
        // each kernel level set's side of every recomputed node (`KernelLevelSet::outside_distance`:
        // one evaluation of L, the sum stopped as soon as it is positive), asked of `level_sets`
        // for all the nodes at once
        let points: Vec<[f64; 3]> = todo.par_iter().with_min_len(PAR_NODES).map(|&idx| pos(grid.coords(idx))).collect();
        clock.done(LayoutPart::Nodes);
        let level_set_side: Vec<Option<Vec<Option<f64>>>> = obstacles
            .iter()
            .enumerate()
            .map(|(k, o)| match &o.shape {
                Shape::KernelLevelSet(ls) => Some(level_sets.outside_distances(k, ls, &points)),
                _ => None,
            })
            .collect();
        // The obstacle a node belongs to: deepest-first, the one that contains the point with
        // the largest (least negative) sdf. A node outside every obstacle but within half a cell
        // of two of them is *pinched* (a slit narrower than a cell, e.g. a closing glottis): it
        // leaves the fluid too, with the nearest of the two (d ≥ 0), since a fluid node squeezed
        // between two walls that close on it is compressed without bound.
        // Most nodes lie inside one obstacle or none: their side comes from
        // `Shape::outside_distance_below` (a level set's from `level_set_side` above; a
        // polygon's edges within `PINCH` of the node). Where two obstacles contain the node
        // only the fact is kept ([`Owner::Several`]): which of them owns it matters to a ghost
        // alone, and the depths that decide it (a level set's by Newton steps) are taken for
        // the ghosts below (`deepest`).
        let containing = |i: usize, p: [f64; 3]| -> Owner {
            let mut inside: Option<usize> = None;
            let mut near: [Option<(usize, f64)>; 2] = [None, None];
            for (k, o) in obstacles.iter().enumerate() {
                let side = match &level_set_side[k] {
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
        };
        // the deepest of the obstacles that contain `p`: a node inside one has sdf < 0 there
        // exactly (`Shape::outside_distance`'s contract), so one is found
        let deepest = |p: [f64; 3]| -> usize {
            let mut deepest: Option<(usize, f64)> = None;
            for (k, o) in obstacles.iter().enumerate() {
                let d = o.shape.sdf(p);
                if d < 0.0 && deepest.is_none_or(|(_, bd)| d > bd) {
                    deepest = Some((k, d));
                }
            }
            deepest.expect("a node inside two obstacles has a negative sdf in each").0
        };

        // which nodes lie in (or are pinched by) an obstacle: independent of each other, so
        // found on the pool's threads (in order: the same answers as one by one); kept for the
        // ghosts below
        clock.skip();
        let owner: Vec<Owner> = points.par_iter().enumerate().with_min_len(PAR_NODES).map(|(i, &p)| containing(i, p)).collect();
        clock.done(LayoutPart::Owners);
        // each recomputed node's kind from its obstacle and its place (on the pool's threads)
        let side = |idx: usize, owner: &Owner| -> NodeKind {
            if !matches!(owner, Owner::Free) {
                return NodeKind::Inactive;
            }
            let x = grid.coords(idx);
            let (mut outside, mut all_periodic) = (0, true);
            for a in 0..3 {
                if x[a] < 0 || x[a] >= grid.n[a] as i64 {
                    outside += 1;
                    all_periodic &= periodic_axis[a];
                }
            }
            match outside {
                0 => NodeKind::Fluid,
                _ if all_periodic => NodeKind::Periodic,
                1 => NodeKind::FaceHalo,
                _ => NodeKind::Inactive,
            }
        };
        let sides: Vec<NodeKind> = todo.par_iter().zip(&owner).with_min_len(PAR_NODES).map(|(&idx, o)| side(idx, o)).collect();
        for (&idx, k) in todo.iter().zip(&sides) {
            kind[idx] = *k;
        }
        clock.done(LayoutPart::Kinds);

        // Solid nodes within axis reach of a fluid node become ghosts; face halos stay only
        // where a fluid stencil reads them (not in corners). Both read the fluid nodes only,
        // which this does not change: found on the pool's threads, then applied.
        let reach = |idx: usize, kind: &[NodeKind]| fluid_within_reach(&grid, kind, idx);
        let walls: Vec<Option<NodeKind>> = todo
            .par_iter()
            .zip(&owner)
            .with_min_len(PAR_NODES)
            .map(|(&idx, o)| match (o, kind[idx]) {
                (Owner::One(_) | Owner::Several, _) => reach(idx, &kind).then_some(NodeKind::Ghost),
                (Owner::Free, NodeKind::FaceHalo) => (!reach(idx, &kind)).then_some(NodeKind::Inactive),
                _ => None,
            })
            .collect();
        for (&idx, w) in todo.iter().zip(&walls) {
            if let Some(k) = w {
                kind[idx] = *k;
            }
        }
        clock.done(LayoutPart::Reach);

        // Resolve a node used for interpolation to a fluid node (through periodic images).
        let wrap = |x: [i64; 3]| -> [i64; 3] {
            let mut y = x;
            for a in 0..3 {
                if periodic_axis[a] {
                    y[a] = y[a].rem_euclid(grid.n[a] as i64);
                }
            }
            y
        };
        let fluid_at = |x: [i64; 3]| fluid_node(&grid, &kind, &periodic_axis, x);

        // the ghosts (node, obstacle) in node order, the owner of a ghost inside several
        // obstacles found now (on the pool's threads)
        let ghost_of: Vec<(usize, usize)> = todo
            .par_iter()
            .zip(&owner)
            .with_min_len(PAR_NODES)
            .filter(|&(&idx, _)| kind[idx] == NodeKind::Ghost)
            .map(|(&idx, owner)| match *owner {
                Owner::One(k) => (idx, k),
                Owner::Several => (idx, deepest(pos(grid.coords(idx)))),
                Owner::Free => unreachable!("a ghost is inside (or pinched by) a solid"),
            })
            .collect();
        // a level set's wall point: the nearest of Newton's and two searches', one toward the
        // fluid node that makes the node a ghost (`fluid::ghost_wall`), and the wall's velocity
        // there (2.130), asked of `level_sets` one set at a time
        let mut level_set_wall: Vec<Option<GhostWall>> = vec![None; ghost_of.len()];
        for (k, o) in obstacles.iter().enumerate() {
            let Shape::KernelLevelSet(ls) = &o.shape else { continue };
            let (at, queries): (Vec<usize>, Vec<GhostQuery>) = ghost_of
                .par_iter()
                .enumerate()
                .with_min_len(PAR_NODES)
                .filter(|(_, g)| g.1 == k)
                .filter_map(|(i, &(idx, _))| nearest_fluid(&grid, &kind, grid.coords(idx)).map(|q| (i, (pos(grid.coords(idx)), pos(q)))))
                .unzip();
            if queries.is_empty() {
                continue;
            }
            clock.done(LayoutPart::GhostList);
            let answers = level_sets.ghost_walls(k, ls, &queries);
            clock.skip();
            for (i, w) in at.into_iter().zip(answers) {
                level_set_wall[i] = Some(w);
            }
        }
        clock.done(LayoutPart::GhostList);
        // each ghost's image stencil and wall velocity, on the pool's threads, collected in
        // node order
        let mut ghosts: Vec<Ghost> = ghost_of
            .par_iter()
            .zip(&level_set_wall)
            .with_min_len(PAR_NODES / 8)
            .map(|(&(idx, k), found)| {
                let p = pos(grid.coords(idx));
                let o = &obstacles[k];
                let (d, nrm) = match (&o.shape, found) {
                    (_, Some(w)) => (w.distance, w.normal),
                    // a level set's ghost with no fluid node within two cells along an axis
                    (Shape::KernelLevelSet(_), None) => (o.shape.sdf(p), o.shape.normal(p)),
                    (shape, None) => shape.sdf_and_normal(p),
                };
                let wall = wall_point(p, d, nrm);
                let d_img = (-d).max(1.0);
                let img = [wall[0] + d_img * nrm[0], wall[1] + d_img * nrm[1], wall[2] + d_img * nrm[2]];
                let mut image = interpolation_stencil(&grid, img, &fluid_at);
                if image.is_empty() {
                    // The image point fell where no fluid is near (a body that crosses a
                    // face wall: the nearest surface of a node beyond the wall can face away
                    // from the fluid): the nearest fluid node to the ghost itself, which is
                    // within two cells along an axis by the definition of a ghost.
                    image = interpolation_stencil(&grid, p, &fluid_at);
                }
                // a level set's wall velocity came with its wall point (the same
                // `velocity_at(wall)` on the CPU)
                let v = match found {
                    Some(w) => w.velocity,
                    None => ghost_wall_velocity(o, wall),
                };
                Ghost { node: idx, image, ratio: d / d_img, wall_velocity: v, wall_temperature: o.temperature }
            })
            .collect();
        clock.done(LayoutPart::Images);
        // the recomputed face halos and periodic copies (found on the pool's threads, in node
        // order: the region of the 3D glottis has 1.23·10⁶ nodes, of which a few are either)
        let halos: Vec<usize> =
            todo.par_iter().with_min_len(64 * PAR_NODES).copied().filter(|&i| matches!(kind[i], NodeKind::FaceHalo | NodeKind::Periodic)).collect();
        let mut face_halos = Vec::new();
        let mut periodic = Vec::new();
        for idx in halos {
            match kind[idx] {
                NodeKind::FaceHalo => {
                    let x = grid.coords(idx);
                    let a = (0..3).find(|&a| x[a] < 0 || x[a] >= grid.n[a] as i64).unwrap();
                    let face = if x[a] < 0 { Face::ALL[2 * a] } else { Face::ALL[2 * a + 1] };
                    let mut s = x;
                    let n_a = grid.n[a] as i64;
                    s[a] = match (boundaries.face(face), x[a] < 0) {
                        // The mirror image across the plane half a cell outside the last node.
                        (FaceCondition::Slip, true) => -1 - x[a],
                        (FaceCondition::Slip, false) => 2 * n_a - 1 - x[a],
                        (_, true) => 0,
                        (_, false) => n_a - 1,
                    };
                    face_halos.push(FaceHalo { node: idx, face, source: grid.index(s) });
                }
                NodeKind::Periodic => {
                    let s = wrap(grid.coords(idx));
                    periodic.push((idx, grid.index(s)));
                }
                _ => {}
            }
        }
        if let Some((p, r)) = previous {
            // the previous ghosts, face halos and periodic copies outside the region, merged
            // with the region's in node order
            let outside = |node: usize| !r.contains(grid.coords(node));
            ghosts = merge_in_node_order(ghosts, p.ghosts.iter().filter(|g| outside(g.node)).cloned(), |g| g.node);
            face_halos = merge_in_node_order(face_halos, p.face_halos.iter().filter(|h| outside(h.node)).cloned(), |h| h.node);
            let previous_periodic = p.periodic.iter().flat_map(|r| (0..r.len).map(move |k| (r.dst + k, r.src + k))).filter(|&(d, _)| outside(d));
            periodic = merge_in_node_order(periodic, previous_periodic, |&(d, _)| d);
        }
        const { assert!(HALO >= 2) };
        // Merge consecutive pairs along a row that the same stencils read into runs.
        let px = grid.padded[0];
        let mut runs: Vec<PeriodicRun> = Vec::new();
        for (d, s) in periodic {
            let reach = HaloReach::of(&grid, grid.coords(d));
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
        let periodic = runs;
        let fluid_count = kind.par_iter().with_min_len(64 * PAR_NODES).filter(|k| **k == NodeKind::Fluid).count();
        clock.done(LayoutPart::HaloLists);
        let geo = WallGeometry { grid: &grid, kind: &kind, ghosts: &ghosts, obstacles: &obstacles, periodic: &periodic_axis };
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

/// The obstacle a recomputed node belongs to, as [`Layout::build`]'s owners' pass finds it.
#[derive(Clone, Copy, Debug)]
enum Owner {
    /// In no obstacle and pinched by none: fluid, or a halo node.
    Free,
    /// Inside obstacle `k`, or pinched with `k` the nearer of the two.
    One(usize),
    /// Inside two or more: the deepest owns it, found only where that matters (a ghost).
    Several,
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

impl Layout {
    /// The padded index of the fluid node at interior coordinates `x`, through periodic
    /// images; `None` when that node is not fluid or lies outside the padded grid.
    pub fn fluid_node_at(&self, x: [i64; 3]) -> Option<usize> {
        fluid_node(&self.grid, &self.kind, &self.boundaries.periodic_axes(self.grid.dim), x)
    }
}

/// The wall velocity a ghost extrapolates through the wall point `wall` of obstacle `o`: the
/// tangential part only for a face wall (a lid), the whole velocity for an obstacle.
pub(super) fn ghost_wall_velocity(o: &Obstacle, wall: [f64; 3]) -> [f64; 3] {
    let v = o.velocity_at(wall);
    match &o.shape {
        Shape::HalfSpace { normal, .. } => {
            let vn = dot(v, *normal);
            [v[0] - vn * normal[0], v[1] - vn * normal[1], v[2] - vn * normal[2]]
        }
        _ => v,
    }
}
