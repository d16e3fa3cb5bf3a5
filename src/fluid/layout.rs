//! Classification of every padded node (fluid, ghost, inlet/outlet halo, periodic halo,
//! inactive), the tables the boundary fill walks through and the stencils (with side ghosts) next to
//! thin walls. Built once per scene, and once per step when bodies move ([`super::moving`]);
//! the build's passes are in `fluid/layout_build.rs`.

use super::boundary::{Boundaries, Face};
use super::geometry::{Obstacle, Shape, dot};
use super::grid::{Grid, HALO};
use super::level_set_queries::OnThePool;
use super::neighbours::fluid_node;
use super::thin_wall::ThinTap;

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
    /// Every node of `grid` classified, with `boundaries`' faces and `user_obstacles` (the
    /// passes: `fluid/layout_build.rs`).
    pub fn new(grid: Grid, boundaries: Boundaries, user_obstacles: &[Obstacle]) -> Self {
        Self::build(grid, boundaries, user_obstacles, None, &OnThePool)
    }

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
