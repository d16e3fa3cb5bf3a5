//! The local rebuild of a layout ([`Layout::rebuilt`]): when bodies move, only the nodes within
//! reach of the obstacles that changed are classified again, the rest copied — equal to a
//! whole rebuild (test below).

use super::boundary::{Face, FaceCondition};
use super::geometry::Obstacle;
use super::layout::Layout;
use super::level_set_queries::{LevelSetQueries, OnThePool};

/// The interior nodes (inclusive box, interior coordinates) that [`Layout::rebuilt`] recomputes;
/// every other node's kind, ghost entry and thin taps are copied from the previous layout.
#[derive(Clone, Copy, Debug)]
pub(super) struct Region {
    pub(super) lo: [i64; 3],
    pub(super) hi: [i64; 3],
}

impl Region {
    pub(super) fn contains(&self, x: [i64; 3]) -> bool {
        (0..3).all(|a| x[a] >= self.lo[a] && x[a] <= self.hi[a])
    }
}

/// What [`Layout::rebuilt`] does.
#[derive(Clone, Copy, Debug)]
pub(super) enum Rebuild {
    /// No obstacle changed: the same layout.
    Same,
    /// The region's nodes recomputed, the rest copied.
    Local(Region),
    /// The whole lattice.
    Full,
}

/// How far (cells) what the layout says of a node depends on other nodes: a ghost reads fluid
/// neighbours within two cells along an axis; its image point lies at most ~2 cells beyond the
/// wall, with a stencil one cell around it (or the nearest fluid node within two cells); a thin
/// tap reads the kinds and ghost images two cells along its axis. Six cells bound all of these.
const DEPENDENCY_REACH: i64 = 6;

impl Layout {
    /// The layout of this lattice and faces with `user_obstacles` — equal to [`Self::new`]
    /// with them (test `a_local_rebuild_equals_the_full_one`) — recomputing only the nodes near
    /// the obstacles that changed: the moving walls of a coupled step. Where a node's
    /// classification can change (the changed obstacles' old and new boxes of influence,
    /// [`super::geometry::Shape::influence_box`]) plus `DEPENDENCY_REACH` is recomputed; the rest is copied.
    /// A full rebuild when an obstacle of unbounded influence changed, when the obstacle count
    /// changed or when the region comes within reach of the domain's faces.
    pub fn rebuilt(&self, user_obstacles: &[Obstacle]) -> Self {
        self.rebuilt_with(user_obstacles, &OnThePool)
    }

    /// [`Self::rebuilt`] with the questions of kernel level sets (the nodes' sides, the ghosts'
    /// wall points) answered by `queries` (a device's twin, [`LevelSetQueries`]).
    pub fn rebuilt_with(&self, user_obstacles: &[Obstacle], queries: &dyn LevelSetQueries) -> Self {
        match self.rebuild_plan(user_obstacles) {
            Rebuild::Same => {
                let mut same = self.clone();
                same.obstacles.truncate(same.obstacles.len() - user_obstacles.len());
                same.obstacles.extend_from_slice(user_obstacles);
                same
            }
            Rebuild::Local(region) => Self::build(self.grid.clone(), self.boundaries.clone(), user_obstacles, Some((self, region)), queries),
            Rebuild::Full => Self::build(self.grid.clone(), self.boundaries.clone(), user_obstacles, None, queries),
        }
    }

    /// What [`Self::rebuilt`] recomputes for `user_obstacles`.
    pub(super) fn rebuild_plan(&self, user_obstacles: &[Obstacle]) -> Rebuild {
        let g = &self.grid;
        // the face walls come first in `obstacles`
        let walls = Face::ALL.iter().filter(|f| f.axis() < g.dim && matches!(self.boundaries.face(**f), FaceCondition::Wall { .. })).count();
        if self.obstacles.len() != walls + user_obstacles.len() {
            return Rebuild::Full;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for (old, new) in self.obstacles[walls..].iter().zip(user_obstacles) {
            if old == new {
                continue;
            }
            for o in [old, new] {
                let Some((a, b)) = o.shape.influence_box() else { return Rebuild::Full };
                for k in 0..g.dim {
                    lo[k] = lo[k].min(a[k]);
                    hi[k] = hi[k].max(b[k]);
                }
            }
        }
        if lo[0] > hi[0] {
            return Rebuild::Same;
        }
        let mut region = Region { lo: [0; 3], hi: [0; 3] };
        for a in 0..g.dim {
            // the nodes whose classification can change, grown by what depends on them
            region.lo[a] = lo[a].floor() as i64 - 1 - DEPENDENCY_REACH;
            region.hi[a] = hi[a].ceil() as i64 + 1 + DEPENDENCY_REACH;
            let periodic = matches!(self.boundaries.faces[2 * a], FaceCondition::Periodic);
            if periodic && (region.lo[a] < 3 || region.hi[a] > g.n[a] as i64 - 4) {
                // within reach of a periodic face (its images wrap): the whole lattice
                return Rebuild::Full;
            }
            // at a wall, slip, inlet or outlet face the region takes in that face's halo
            region.lo[a] = region.lo[a].max(-(g.halo[a] as i64));
            region.hi[a] = region.hi[a].min((g.n[a] + g.halo[a]) as i64 - 1);
        }
        Rebuild::Local(region)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::KernelLevelSet;
    use crate::fluid::boundary::Boundaries;
    use crate::fluid::geometry::Polygon;
    use crate::fluid::geometry::Shape;
    use crate::fluid::grid::Grid;
    use crate::fluid::layout::NodeKind;
    use crate::fluid::neighbours::{fluid_within_reach, nearest_fluid};

    fn assert_same(local: &Layout, full: &Layout, label: &str) {
        assert_eq!(local.obstacles, full.obstacles, "{label}: obstacles");
        assert!(
            local.kind == full.kind,
            "{label}: node kinds differ at {:?}",
            (0..full.kind.len()).find(|&i| local.kind[i] != full.kind[i]).map(|i| full.grid.coords(i))
        );
        assert_eq!(local.ghosts, full.ghosts, "{label}: ghosts");
        assert_eq!(local.face_halos, full.face_halos, "{label}: face halos");
        assert_eq!(local.periodic, full.periodic, "{label}: periodic runs");
        assert_eq!(local.thin_taps, full.thin_taps, "{label}: thin taps");
        assert_eq!(local.fluid_count, full.fluid_count, "{label}: fluid count");
        assert_eq!(local.wall_faces, full.wall_faces, "{label}: wall faces");
        assert_eq!(full.wall_faces, wall_faces_by_scan(full), "{label}: wall faces against a scan of the lattice");
        // the reach test by strides is the search by coordinates at every node, the padded
        // grid's edges included
        let g = &full.grid;
        let by_strides = (0..g.len()).find(|&i| fluid_within_reach(g, &full.kind, i) != nearest_fluid(g, &full.kind, g.coords(i)).is_some());
        assert_eq!(by_strides.map(|i| g.coords(i)), None, "{label}: the reach test by strides differs");
    }

    /// Every fluid node with a non-fluid, non-periodic axis neighbour, by a scan of the lattice
    /// (what `Layout::wall_faces` lists from the ghosts and face halos).
    fn wall_faces_by_scan(l: &Layout) -> Vec<usize> {
        let wall = |n: usize| !matches!(l.kind[n], NodeKind::Fluid | NodeKind::Periodic);
        let g = &l.grid;
        (0..g.len()).filter(|&n| l.kind[n] == NodeKind::Fluid && (0..g.dim).any(|a| wall(n + g.stride[a]) || wall(n - g.stride[a]))).collect()
    }

    /// A disc of particles (spacing 0.4 cells, radius `r`) at `c`, moving at `v`.
    fn disc(c: [f64; 3], r: f64, v: [f64; 3], dim: usize) -> Obstacle {
        let mut pts = Vec::new();
        let k = (r / 0.4).ceil() as i64;
        for i in -k..=k {
            for j in -k..=k {
                for l in if dim == 3 { -k..=k } else { 0..=0 } {
                    let d = [0.4 * i as f64, 0.4 * j as f64, 0.4 * l as f64];
                    if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() <= r {
                        pts.push([c[0] + d[0], c[1] + d[1], c[2] + d[2]]);
                    }
                }
            }
        }
        let n = pts.len();
        Obstacle {
            shape: Shape::KernelLevelSet(std::sync::Arc::new(KernelLevelSet::new(pts, vec![v; n], 1.5, 0.75, 6.0))),
            velocity: [0.0; 3],
            temperature: None,
        }
    }

    /// Walls that move a fraction of a cell per step (level sets and a polygon, next to a
    /// static box and each other, pinching the gap between them, then reaching a wall face and
    /// an outlet, where the region takes in their halos): at every step the local rebuild from
    /// the previous layout equals the layout built from scratch, in 2D and 3D; near a periodic
    /// face, or when the static box changes, the whole lattice is rebuilt.
    #[test]
    fn a_local_rebuild_equals_the_full_one() {
        // (dimension, lattice, x faces periodic)
        for (dim, n, periodic_x) in [(2, [80, 52, 1], false), (3, [48, 44, 34], false), (2, [80, 52, 1], true)] {
            let grid = Grid::new(dim, n);
            let mut b = Boundaries::periodic();
            if !periodic_x {
                b.faces[0] = FaceCondition::VelocityInlet { velocity: [0.05, 0.0, 0.0], theta: 0.6, profile: Default::default() };
                b.faces[1] = FaceCondition::Outlet;
            }
            b.faces[2] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
            b.faces[3] = FaceCondition::Slip;
            let zc = if dim == 3 { 17.0 } else { 0.0 };
            let rigid = |grow: f64| Obstacle {
                shape: Shape::Cuboid { min: [22.0, 14.0, -50.0], max: [26.0 + grow, 20.0, 50.0] },
                velocity: [0.0; 3],
                temperature: None,
            };
            let at = |t: f64| -> Vec<Obstacle> {
                // a disc that passes the box, runs into a second one and heads for the bottom
                // wall; the second drifts up (their gap closes: pinched nodes, then overlap);
                // in 2D a square polygon drifting to the outlet
                let mut o = vec![
                    rigid(0.0),
                    disc([16.0 + 0.37 * t, 26.0 - 0.31 * t, zc], 3.1, [0.37, -0.31, 0.0], dim),
                    disc([32.0, 18.0 + 0.05 * t, zc], 2.6, [0.0, 0.05, 0.0], dim),
                ];
                if dim == 2 {
                    let x = 60.0 + 0.23 * t;
                    let verts = vec![[x, 22.0], [x + 5.0, 22.0], [x + 5.0, 27.0], [x, 27.0]];
                    o.push(Obstacle { shape: Shape::Polygon(Polygon::new(verts, vec![[0.23, 0.0, 0.0]; 4])), velocity: [0.0; 3], temperature: None });
                }
                o
            };
            let label = format!("{dim}D{}", if periodic_x { ", periodic in x" } else { "" });
            let mut layout = Layout::new(grid.clone(), b.clone(), &at(0.0));
            let (mut local, mut at_faces, mut full) = (0, 0, 0);
            for step in 1..=46 {
                let mut obstacles = at(step.min(45) as f64);
                if step == 46 {
                    // the static box grows: a shape without a box of influence
                    obstacles[0] = rigid(1.0);
                }
                match layout.rebuild_plan(&obstacles) {
                    Rebuild::Local(r) => {
                        local += 1;
                        at_faces += (0..dim).any(|a| r.lo[a] < 0 || r.hi[a] >= n[a] as i64) as usize;
                    }
                    Rebuild::Full => full += 1,
                    Rebuild::Same => panic!("{label}: the walls moved"),
                }
                let next = layout.rebuilt(&obstacles);
                assert_same(&next, &Layout::new(grid.clone(), b.clone(), &obstacles), &format!("{label} step {step}"));
                layout = next;
            }
            // the unchanged walls: the same layout
            let last = layout.obstacles[layout.obstacles.len() - at(45.0).len()..].to_vec();
            assert!(matches!(layout.rebuild_plan(&last), Rebuild::Same));
            assert_same(&layout.rebuilt(&last), &layout, &format!("{label} unchanged"));
            eprintln!(
                "{label}: {local} local rebuilds ({at_faces} taking in a face's halo), {full} whole ones, {} ghosts, {} thin taps at the end",
                layout.ghosts.len(),
                layout.thin_taps.len()
            );
            if periodic_x {
                // the polygon comes within reach of the periodic outlet side
                assert!(full >= 2 && local >= 10, "{label}: {local} local, {full} whole");
            } else {
                assert!(local == 45 && at_faces >= 1 && full == 1, "{label}: {local} local ({at_faces} at faces), {full} whole");
            }
        }
    }
}
