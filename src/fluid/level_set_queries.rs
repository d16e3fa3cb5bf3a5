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
