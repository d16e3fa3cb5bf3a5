//! The questions the layout asks of a body's kernel level set (seed 000 §2.4.2, 2.124–2.126)
//! for many points at once — on which side of the wall each node lies
//! ([`KernelLevelSet::outside_distance`]) and where each ghost node's wall point is
//! ([`KernelLevelSet::ghost_wall`]) and the wall's velocity there ([`KernelLevelSet::velocity_at`],
//! 2.130) —, so that a backend can answer them in one trip: the CPU's
//! answers on the pool's threads ([`OnThePool`]), or a device's twin (`gpu::level_set_queries`,
//! f64) to round-off. Together they are most of method 2's per-step geometry on the CPU
//! (`glottis_3d_coarse`: the ghosts' wall points 16.7 ms and the sides 6 ms of a 34 ms stage).
//!
//! Units: lattice cells.

use super::kernel_level_set::KernelLevelSet;
use super::layout::PAR_NODES;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// A ghost node inside a kernel level set and the fluid node that makes it a ghost (lattice
/// coordinates): what [`KernelLevelSet::ghost_wall`] is asked.
pub type GhostQuery = ([f64; 3], [f64; 3]);

/// What a ghost node learns of its wall: [`KernelLevelSet::ghost_wall`]'s signed distance
/// (cells, negative inside) and outward normal, and the wall velocity (2.130, c units) at the
/// wall point [`wall_point`] makes of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GhostWall {
    pub distance: f64,
    pub normal: [f64; 3],
    pub velocity: [f64; 3],
}

/// The wall point of a node at `p` whose wall lies at signed distance `d` along the outward
/// normal `n`: p − d n (cells), as the layout and every answer of [`GhostWall`] take it.
pub fn wall_point(p: [f64; 3], d: f64, n: [f64; 3]) -> [f64; 3] {
    [p[0] - d * n[0], p[1] - d * n[1], p[2] - d * n[2]]
}

/// The parts of the layout's own work ([`super::layout::Layout`]'s build, in its order) whose
/// wall time [`LevelSetQueries::part_timed`] hears of: the host's share of a coupled step's
/// `fluid_geometry` stage, split.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutPart {
    /// The obstacles, the recomputed nodes' list and points, the kinds copied.
    Nodes,
    /// Which obstacle contains (or pinches) each recomputed node.
    Owners,
    /// Each node's kind from its owner and place.
    Kinds,
    /// Solid nodes with fluid within two cells along an axis (ghosts), face halos read.
    Reach,
    /// The ghosts in node order with their obstacle, and the level sets' ghost questions made.
    GhostList,
    /// Each ghost's image stencil (and the wall velocity of a ghost of another shape than a
    /// level set).
    Images,
    /// The face halos and periodic copies, the lists merged with the previous layout's, the
    /// fluid nodes counted.
    HaloLists,
    /// The upwind stencils next to thin walls ([`super::thin_wall::thin_taps`]).
    ThinTaps,
    /// The nodes next to a wall ([`super::layout::Layout::wall_faces`]).
    WallFaces,
}

impl LayoutPart {
    pub const ALL: [LayoutPart; 9] = [
        LayoutPart::Nodes,
        LayoutPart::Owners,
        LayoutPart::Kinds,
        LayoutPart::Reach,
        LayoutPart::GhostList,
        LayoutPart::Images,
        LayoutPart::HaloLists,
        LayoutPart::ThinTaps,
        LayoutPart::WallFaces,
    ];

    /// A short name (snake case), as the geometry bench prints it.
    pub fn name(self) -> &'static str {
        match self {
            LayoutPart::Nodes => "nodes",
            LayoutPart::Owners => "owners",
            LayoutPart::Kinds => "kinds",
            LayoutPart::Reach => "reach",
            LayoutPart::GhostList => "ghost_list",
            LayoutPart::Images => "images",
            LayoutPart::HaloLists => "halo_lists",
            LayoutPart::ThinTaps => "thin_taps",
            LayoutPart::WallFaces => "wall_faces",
        }
    }
}

/// The layout's clock: the wall time since its last mark, told to `to` as a part's.
pub(super) struct PartClock<'a> {
    at: Instant,
    to: &'a dyn LevelSetQueries,
}

impl<'a> PartClock<'a> {
    pub(super) fn start(to: &'a dyn LevelSetQueries) -> Self {
        PartClock { at: Instant::now(), to }
    }

    /// The time since the last mark was `part`'s.
    pub(super) fn done(&mut self, part: LayoutPart) {
        let now = Instant::now();
        self.to.part_timed(part, now - self.at);
        self.at = now;
    }

    /// The time since the last mark was no part's (a question, timed by whoever answers it).
    pub(super) fn skip(&mut self) {
        self.at = Instant::now();
    }
}

/// Who answers the layout's questions of a kernel level set
/// ([`super::layout::Layout`] asks each set once per question and step). `which` says which of
/// the layout's obstacles the set is — the same body at every step —, so that a device can keep
/// each body's bins apart and send them once for both questions.
pub trait LevelSetQueries: Sync {
    /// [`KernelLevelSet::outside_distance`] at each of `points`, in order (None inside).
    fn outside_distances(&self, which: usize, set: &KernelLevelSet, points: &[[f64; 3]]) -> Vec<Option<f64>>;

    /// [`KernelLevelSet::ghost_wall`]'s signed distance and outward normal for each of
    /// `queries`, in order, with [`KernelLevelSet::velocity_at`] at the wall point.
    fn ghost_walls(&self, which: usize, set: &KernelLevelSet, queries: &[GhostQuery]) -> Vec<GhostWall>;

    /// Hears the wall time of each part of the layout's own work (the questions above not
    /// included), once or more per part and build; nothing by default. The geometry bench
    /// (`phonation bench --only geometry`) sums them.
    fn part_timed(&self, _part: LayoutPart, _elapsed: Duration) {}
}

/// The CPU's answers on the pool's threads, bit for bit those of the set's own methods.
#[derive(Clone, Copy, Debug, Default)]
pub struct OnThePool;

impl LevelSetQueries for OnThePool {
    fn outside_distances(&self, _: usize, set: &KernelLevelSet, points: &[[f64; 3]]) -> Vec<Option<f64>> {
        points.par_iter().with_min_len(PAR_NODES).map(|&p| set.outside_distance(p)).collect()
    }

    fn ghost_walls(&self, _: usize, set: &KernelLevelSet, queries: &[GhostQuery]) -> Vec<GhostWall> {
        queries
            .par_iter()
            .with_min_len(PAR_NODES / 8)
            .map(|&(p, q)| {
                let (distance, normal) = set.ghost_wall(p, q);
                GhostWall { distance, normal, velocity: set.velocity_at(wall_point(p, distance, normal)) }
            })
            .collect()
    }
}
