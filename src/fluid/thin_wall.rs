//! One-sided advection stencils next to walls thinner than the upwind stencil.
//!
//! The 3rd-order upwind difference ([`super::upwind`]) of a fluid node reads, along each axis
//! and for each sign s of a velocity component, the nodes at +s, −s and −2s. Behind a wall at
//! least two cells thick those are ghost nodes whose image points lie on the reader's side, so
//! the ghosts carry the reader's side of the wall. A wall thinner than that — the contact of
//! two vocal folds that close on each other, a thin plate — puts in the stencil a fluid node
//! across the wall, or a ghost whose image lies across it (a ghost holds one state and serves
//! the side its image point is on). Read as they are, these taps pass the other side's state
//! through the wall: across the closed glottis, the lung pressure leaks into the air above the
//! contact, which heats until it leaves the admissible range (the coarse glottis, case C, at its
//! second closure: see the README).
//!
//! [`thin_taps`] finds, when the geometry is built, every (fluid node, axis, sign) whose
//! stencil holds such a *far* tap, and gives it a one-sided stencil of its own side's taps
//! (weights on the nodes 0, +s, −s, −2s, times |c_a|/6; the full stencil is [3, 2, −6, 1]):
//!
//! | far taps        | substitute                         | weights          | what it is |
//! |-----------------|------------------------------------|------------------|------------|
//! | −2s             | h(−2s) = 2h(−s) − h(0)             | [2, 2, −4, 0]    | ⅔ central + ⅓ 1st-order upwind |
//! | +s              | h(+s) = 2h(0) − h(−s)              | [7, 0, −8, 1]    | ⅔ 1st- + ⅓ 2nd-order upwind |
//! | +s and −2s      | both of the above                  | [6, 0, −6, 0]    | 1st-order upwind |
//! | −s (a wall one cell thick behind the node) | no inflow from across: ∂h/∂x = 0 | [0, 0, 0, 0] | — |
//!
//! Each row's weights sum to 0 and their first moment is 6 (consistent with c·∂h/∂x, first-order
//! accurate at these few nodes), and every one is dissipative like the full stencil (the real
//! part of its Fourier symbol is ≥ 0), so the Heun step stays stable under the same limit. A ghost
//! is far when its image point (the weighted mean of its image nodes) lies strictly on the other
//! side of it along the axis; a fluid node at −2s is far when the node at −s is not fluid.
//! Geometries without thin walls have no such taps, and their results are unchanged. The GPU
//! twin is the `thin_wall` kernel ([`crate::gpu::codegen::thin_wall`]), run after each advection.

use super::equilibrium::Equilibrium;
use super::grid::Grid;
use super::layout::{Ghost, NodeKind};
use super::storage::RowBlocked;

/// The one-sided stencil of one fluid node along one axis and sign.
#[derive(Clone, Debug, PartialEq)]
pub struct ThinTap {
    /// Padded index of the reading fluid node.
    pub node: usize,
    pub axis: usize,
    /// +1 or −1: the sign of the velocity components this stencil serves.
    pub sign: i64,
    /// Weights on the nodes (0, +s, −s, −2s), times |c_a|/6.
    pub weights: [f64; 4],
}

/// The full stencil's weights on (0, +s, −s, −2s), times |c_a|/6.
pub const FULL: [f64; 4] = [3.0, 2.0, -6.0, 1.0];

impl ThinTap {
    /// What the one-sided stencil adds to the full one: w − w_full on (0, +s, −s, −2s).
    pub fn correction(&self) -> [f64; 4] {
        std::array::from_fn(|j| self.weights[j] - FULL[j])
    }
}

/// Replaces, after the advection `out −= k·c·∇h` (k = factor·Δt), the full upwind stencil by
/// the one-sided one of each tap: `out −= k·|c_a|/6·Σ (w − w_full)·h` for the values whose
/// velocity component along the tap's axis has the tap's sign. `pop`: the CPU layout of `h` and
/// `out`; `py`: padded rows per z-plane. The GPU twin is [`crate::gpu::codegen::thin_wall`].
pub fn advect_thin_taps(taps: &[ThinTap], eq: &Equilibrium, pop: RowBlocked, py: usize, k: f64, h: &[f64], out: &mut [f64]) {
    let (nv, q) = (eq.values_per_node(), eq.q());
    for t in taps {
        let mut d = [0i64; 3];
        d[t.axis] = t.sign;
        let step = pop.neighbour_offset(d, py);
        let dw = t.correction();
        for v in 0..nv {
            let c = eq.set.c[if v < q { v } else { v - q }][t.axis];
            if c.signum() as i64 != t.sign {
                continue;
            }
            let i0 = pop.index(t.node, v) as isize;
            let hv = |m: isize| h[(i0 + m * step) as usize];
            let corr = dw[0] * hv(0) + dw[1] * hv(1) + dw[2] * hv(-1) + dw[3] * hv(-2);
            out[i0 as usize] -= k * (c.unsigned_abs() as f64 / 6.0) * corr;
        }
    }
}

/// Every (fluid node, axis, sign) whose upwind stencil reaches across a thin wall, with its
/// one-sided weights (see the module docs).
/// `periodic[a]`: axis a is periodic (an image node across the periodic face counts at its
/// nearest periodic copy). `only`: the reading nodes to consider (ascending), all when None.
pub fn thin_taps(grid: &Grid, kind: &[NodeKind], ghosts: &[Ghost], periodic: &[bool; 3], only: Option<&[usize]>) -> Vec<ThinTap> {
    let mut ghost_of = vec![usize::MAX; grid.len()];
    for (k, g) in ghosts.iter().enumerate() {
        ghost_of[g.node] = k;
    }
    // Image point of each ghost (mean of its image nodes' coordinates, by weight).
    let image: Vec<[f64; 3]> = ghosts
        .iter()
        .map(|g| {
            let at = grid.coords(g.node);
            let mut c = [0.0; 3];
            for &(i, w) in &g.image {
                let x = grid.coords(i);
                for a in 0..3 {
                    let mut d = x[a] - at[a];
                    if periodic[a] {
                        let n = grid.n[a] as i64;
                        d = (d + n / 2).rem_euclid(n) - n / 2;
                    }
                    c[a] += w * (at[a] + d) as f64;
                }
            }
            c
        })
        .collect();
    let mut out = Vec::new();
    let all: Vec<usize>;
    let nodes = match only {
        Some(v) => v,
        None => {
            all = (0..grid.len()).collect();
            &all
        }
    };
    for &node in nodes {
        if kind[node] != NodeKind::Fluid {
            continue;
        }
        let r = grid.coords(node);
        for axis in 0..grid.dim {
            for sign in [1i64, -1] {
                let at = |d: i64| {
                    let mut y = r;
                    y[axis] += d * sign;
                    grid.index(y)
                };
                // Is the ghost at displacement d (in units of s) on the reader's side?
                let far_ghost = |i: usize, d: i64| {
                    let k = ghost_of[i];
                    k != usize::MAX && {
                        let t = r[axis] + d * sign;
                        (image[k][axis] - t as f64) * ((r[axis] - t) as f64) < 0.0
                    }
                };
                let (ahead, behind, behind2) = (at(1), at(-1), at(-2));
                let far_ahead = far_ghost(ahead, 1);
                let far_behind = far_ghost(behind, -1);
                let far_behind2 = far_ghost(behind2, -2) || (kind[behind2] == NodeKind::Fluid && kind[behind] != NodeKind::Fluid);
                let weights = match (far_ahead, far_behind, far_behind2) {
                    (_, true, _) => [0.0; 4],
                    (false, false, true) => [2.0, 2.0, -4.0, 0.0],
                    (true, false, false) => [7.0, 0.0, -8.0, 1.0],
                    (true, false, true) => [6.0, 0.0, -6.0, 0.0],
                    (false, false, false) => continue,
                };
                out.push(ThinTap { node, axis, sign, weights });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_one_sided_stencil_is_consistent() {
        // Σ w = 0 (a constant has no derivative) and Σ w·x = 6 (x has derivative 1, after the
        // factor 1/6) with x = (0, +1, −1, −2).
        let x = [0.0, 1.0, -1.0, -2.0];
        for w in [FULL, [2.0, 2.0, -4.0, 0.0], [7.0, 0.0, -8.0, 1.0], [6.0, 0.0, -6.0, 0.0]] {
            let m0: f64 = w.iter().sum();
            let m1: f64 = w.iter().zip(x).map(|(w, x)| w * x).sum();
            assert!(m0.abs() < 1e-15 && (m1 - 6.0).abs() < 1e-15, "{w:?}: {m0} {m1}");
        }
        // Dissipative for every wavenumber: Re Σ w e^{ikx} ≥ 0 (the full stencil: 2(1 − cos k)²).
        for w in [FULL, [2.0, 2.0, -4.0, 0.0], [7.0, 0.0, -8.0, 1.0], [6.0, 0.0, -6.0, 0.0]] {
            for j in 0..=200 {
                let k = std::f64::consts::PI * j as f64 / 200.0;
                let re: f64 = w.iter().zip(x).map(|(w, x)| w * (k * x).cos()).sum();
                assert!(re >= -1e-12, "{w:?} at k = {k}: {re}");
            }
        }
    }
}

#[cfg(test)]
mod leak_tests {
    use crate::fluid::*;

    /// A channel (pressure inlet at y = 0 at 5 % over the rest density, outlet at the top, side
    /// walls) closed by a plate of `thickness` cells across its whole width, centred between
    /// the node rows 16 and 17 (thickness 2: both rows solid) or on row 16 (thickness 1).
    fn closed_channel(thickness: usize) -> FluidSolver {
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let params = timestep::choose(0.05, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        let mut b = Boundaries::periodic();
        b.faces[0] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
        b.faces[1] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
        b.faces[2] = FaceCondition::PressureInlet { rho: 1.05, theta: 0.6 };
        b.faces[3] = FaceCondition::Outlet;
        let (y0, y1) = if thickness == 2 { (15.6, 17.4) } else { (15.6, 16.4) };
        let plate = Polygon::new(vec![[-5.0, y0], [30.0, y0], [30.0, y1], [-5.0, y1]], vec![[0.0; 3]; 4]);
        let o = Obstacle { shape: Shape::Polygon(plate), velocity: [0.0; 3], temperature: None };
        FluidSolver::new(eq, Grid::new(2, [24, 32, 1]), b, &[o], params, |_| Macro { rho: 1.0, u: [0.0; 3], theta: 0.6 })
    }

    /// Largest |ρ − 1| above the plate after `steps` steps, and the mean density below it.
    fn run(mut s: FluidSolver, steps: usize, y_above: i64) -> (f64, f64) {
        for _ in 0..steps {
            s.step().expect("finite");
        }
        let (mut above, mut below, mut n) = (0.0f64, 0.0, 0.0);
        for x in 0..24 {
            for y in 0..32 {
                let i = s.layout.grid.index([x, y, 0]);
                if s.layout.kind[i] != layout::NodeKind::Fluid {
                    continue;
                }
                let rho = s.macro_at(i).rho;
                if y >= y_above {
                    above = above.max((rho - 1.0).abs());
                } else {
                    below += rho;
                    n += 1.0;
                }
            }
        }
        (above, below / n)
    }

    #[test]
    fn a_plate_thinner_than_the_stencil_holds_back_the_pressure() {
        for (thickness, y_above) in [(2, 18), (1, 17)] {
            let s = closed_channel(thickness);
            assert!(!s.layout.thin_taps.is_empty(), "a {thickness}-cell plate has thin taps");
            let (above, below) = run(s, 300, y_above);
            // The pressure wave has filled the lower part; the upper part is untouched to
            // round-off (every stencil above reads only its own side, at rest).
            assert!(below > 1.01, "{thickness}-cell plate: mean ρ below {below}");
            assert!(above < 1e-12, "{thickness}-cell plate: ρ above moved by {above:e}");
            // Without the one-sided stencils the plate leaks.
            let mut leaky = closed_channel(thickness);
            leaky.layout.thin_taps.clear();
            let (above, _) = run(leaky, 300, y_above);
            assert!(above > 1e-4, "{thickness}-cell plate without one-sided stencils: ρ above moved by {above:e} only");
        }
    }

    #[test]
    fn a_thick_body_next_to_a_periodic_face_has_no_thin_taps() {
        // A disc ten cells across has none: in the middle of a periodic box, or half a cell
        // from its periodic faces, where the image nodes of its ghosts lie beyond the face and
        // count at their near periodic copy (the far copy would look like the other side).
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let params = timestep::choose(0.05, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        for c in [[12.3, 11.6], [5.5, 11.6], [18.5, 11.6], [12.3, 5.4], [11.7, 18.6]] {
            let o = Obstacle { shape: Shape::Cylinder { center: [c[0], c[1], 0.0], radius: 5.0 }, velocity: [0.0; 3], temperature: None };
            let s =
                FluidSolver::new(eq.clone(), Grid::new(2, [24, 24, 1]), Boundaries::periodic(), &[o], params, |_| Macro { rho: 1.0, u: [0.0; 3], theta: 0.6 });
            assert!(!s.layout.ghosts.is_empty());
            assert!(s.layout.thin_taps.is_empty(), "disc at {c:?}: {} thin taps", s.layout.thin_taps.len());
        }
    }
}
