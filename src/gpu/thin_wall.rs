//! The thin-wall stencils and their side ghosts ([`crate::fluid::thin_wall`]) as the `thin_wall` kernel
//! ([`super::codegen::thin_wall`]) reads them: one entry per tap, grouped by node.

use crate::fluid::layout::Layout;
use bytemuck::{Pod, Zeroable};

/// A thin-wall stencil as the kernel's `ThinTap` struct.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct ThinTapEntry {
    node: u32,
    axis: u32,
    sign: i32,
    /// Offset (nodes) to the +s neighbour.
    step: i32,
    /// w − w_full on (0, +s, −s, −2s).
    w: [f32; 4],
    /// The nodes holding the side ghosts of the taps +s, −s, −2s ([`NO_SIDE`] where the tap has
    /// none), each weighted by the full stencil's weight of its tap (2, −6, 1); w is unused.
    side: [u32; 4],
}

/// A tap without a side ghost.
pub(super) const NO_SIDE: u32 = u32::MAX;

impl Default for ThinTapEntry {
    fn default() -> Self {
        ThinTapEntry { node: 0, axis: 0, sign: 0, step: 0, w: [0.0; 4], side: [NO_SIDE; 4] }
    }
}

/// The taps of `layout` and, per node that has any, (first tap, count): one kernel thread per
/// node walks its taps, so no two threads write the same value. The side ghost in slot k sits
/// at node n + k past the lattice's n nodes ([`super::fdlb`]'s geometry tables). Never empty (a
/// zero entry, never read, stands in for none, so that the binding holds one).
pub(super) fn entries(layout: &Layout) -> (Vec<ThinTapEntry>, Vec<[u32; 2]>) {
    let g = &layout.grid;
    let mut slot = g.len();
    let mut taps: Vec<ThinTapEntry> = Vec::with_capacity(layout.thin_taps.len().max(1));
    let mut ranges: Vec<[u32; 2]> = Vec::new();
    for t in &layout.thin_taps {
        let unit = [1i64, g.padded[0] as i64, (g.padded[0] * g.padded[1]) as i64][t.axis];
        // the layout lists the taps node by node
        if ranges.last().is_none_or(|r| taps[r[0] as usize].node != t.node as u32) {
            ranges.push([taps.len() as u32, 0]);
        }
        ranges.last_mut().expect("pushed above")[1] += 1;
        let w = t.correction().map(|x| x as f32);
        let mut side = [NO_SIDE; 4];
        for sg in &t.sides {
            side[sg.tap - 1] = slot as u32;
            slot += 1;
        }
        taps.push(ThinTapEntry { node: t.node as u32, axis: t.axis as u32, sign: t.sign as i32, step: (t.sign * unit) as i32, w, side });
    }
    if taps.is_empty() {
        taps.push(ThinTapEntry::default());
    }
    (taps, ranges)
}

/// For method 2's record of the walls' face fluxes (`thin_wall_fluxes`): the wall node that takes
/// each tap's correction — as [`crate::coupling::momentum_exchange::add_face_fluxes`] picks it,
/// the first wall among (+s, −s, −2s), else +s — with the taps grouped by that node: the tap
/// indices (into [`entries`]' list) in target order, and per target (node, first, count, 0).
/// Never empty (a zero target with no taps stands in for none).
pub(super) fn flux_targets(layout: &Layout) -> (Vec<u32>, Vec<[u32; 4]>) {
    let g = &layout.grid;
    let wall = |n: usize| !matches!(layout.kind[n], crate::fluid::layout::NodeKind::Fluid | crate::fluid::layout::NodeKind::Periodic);
    let mut by_target: Vec<(usize, u32)> = layout
        .thin_taps
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let s = t.sign as isize * g.stride[t.axis] as isize;
            let at = |d: isize| (t.node as isize + d) as usize;
            let taps = [at(s), at(-s), at(-2 * s)];
            (taps.iter().copied().find(|&n| wall(n)).unwrap_or(taps[0]), k as u32)
        })
        .collect();
    by_target.sort();
    let order: Vec<u32> = by_target.iter().map(|&(_, k)| k).collect();
    let mut targets: Vec<[u32; 4]> = Vec::new();
    for (i, &(node, _)) in by_target.iter().enumerate() {
        match targets.last_mut() {
            Some(t) if t[0] == node as u32 => t[2] += 1,
            _ => targets.push([node as u32, i as u32, 1, 0]),
        }
    }
    if targets.is_empty() {
        targets.push([0; 4]);
    }
    (if order.is_empty() { vec![0] } else { order }, targets)
}

#[cfg(test)]
mod mirror_tests {
    use super::ThinTapEntry;
    use crate::fluid::{Equilibrium, GasModel, VelocitySet, VelocitySetKind};
    use crate::gpu::codegen::{Split, thin_wall};
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    #[test]
    fn tap_entries_match_the_shader_layout() {
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let src = thin_wall(&eq, Split::whole(eq.values_per_node()));
        check_mirror("thin_wall", &src, "ThinTap", mirror!(ThinTapEntry { node, axis, sign, step, w, side }));
    }
}
