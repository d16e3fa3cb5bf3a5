//! What a layout's node kinds say about a node's neighbours along the lattice axes: the fluid
//! node within two cells that makes a solid node a ghost, the fluid node at a point through
//! periodic images, the fluid nodes next to a wall. Asked by [`super::layout::Layout`]'s build
//! of every rebuilt node at every step of a moving body, and by the thin walls' taps.

use super::grid::Grid;
use super::layout::NodeKind;

/// The fluid node nearest to `x` (interior coordinates) along an axis within two cells —
/// ±1 before ±2, x before y before z — the one that makes a solid node a ghost; `None` when
/// there is none.
pub(super) fn nearest_fluid(grid: &Grid, kind: &[NodeKind], x: [i64; 3]) -> Option<[i64; 3]> {
    // plain loops: asked of every solid node near a moving body at every step, where the
    // iterator chain's closures cost twice the reads
    for d in [1i64, 2] {
        for a in 0..grid.dim {
            for s in [-d, d] {
                let mut y = x;
                y[a] += s;
                if grid.contains(y) && kind[grid.index(y)] == NodeKind::Fluid {
                    return Some(y);
                }
            }
        }
    }
    None
}

/// Whether a fluid node lies within two cells of node `idx` (a padded index) along an axis:
/// [`nearest_fluid`]`(…).is_some()`, read by strides where the four neighbours along every axis
/// lie in the padded grid (all but the nodes at its edge): asked of every solid node near a
/// moving body at every step.
pub(super) fn fluid_within_reach(grid: &Grid, kind: &[NodeKind], idx: usize) -> bool {
    let x = grid.coords(idx);
    let clear = (0..grid.dim).all(|a| x[a] - 2 >= -(grid.halo[a] as i64) && x[a] + 2 < (grid.n[a] + grid.halo[a]) as i64);
    if !clear {
        return nearest_fluid(grid, kind, x).is_some();
    }
    (0..grid.dim).any(|a| {
        let s = grid.stride[a];
        [idx - 2 * s, idx - s, idx + s, idx + 2 * s].into_iter().any(|j| kind[j] == NodeKind::Fluid)
    })
}

/// The fluid nodes next to one of `walls` along an axis, ascending and each once. With `walls`
/// every ghost and face halo of a layout this is every fluid node with a non-fluid,
/// non-periodic axis neighbour: a node next to a fluid node is within its stencil's reach, so
/// it is a ghost (solid), a face halo or a periodic copy, never inactive — O(walls), not a scan
/// of the lattice.
pub(super) fn wall_face_nodes(grid: &Grid, kind: &[NodeKind], walls: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut nodes = Vec::new();
    for w in walls {
        for a in 0..grid.dim {
            let s = grid.stride[a];
            for n in [w.checked_sub(s), Some(w + s)].into_iter().flatten() {
                if kind.get(n) == Some(&NodeKind::Fluid) {
                    nodes.push(n);
                }
            }
        }
    }
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

/// The padded index of the fluid node at interior coordinates `x` (through the periodic images
/// along the axes marked in `periodic`), `None` when that node is not fluid or lies outside.
pub(super) fn fluid_node(grid: &Grid, kind: &[NodeKind], periodic: &[bool; 3], x: [i64; 3]) -> Option<usize> {
    let mut y = x;
    for a in 0..3 {
        if periodic[a] {
            y[a] = y[a].rem_euclid(grid.n[a] as i64);
        }
    }
    if !grid.contains(y) {
        return None;
    }
    let i = grid.index(y);
    (kind[i] == NodeKind::Fluid).then_some(i)
}
