//! The innermost loops of the CPU FDLB stages ([`super::solver`]), one row of nodes along x at a
//! time: the moment sums, the equilibrium (2.78, 2.97) with the BGK collision and body force of
//! (2.77), and the third-order upwind advection ([`super::upwind`]).
//!
//! Each value's work is one pass over the row (equilibrium, h, and the stage output together),
//! with the moment sums accumulated in registers over blocks of x, so that the row's scratch is
//! read once per value instead of once per sub-expression. The stage output is written only at
//! fluid nodes, over the row's runs of fluid nodes ([`runs`]) with plain stores: a per-node
//! select compiled to masked stores (or masked loads), 1.2–1.4× slower on the AMD cores here.
//! The arithmetic of every value is the same expression in the same order as the GPU kernels'
//! CPU twin always was (bit for bit: the golden state hashes of `run::resume_tests` hold).

use super::equilibrium::Equilibrium;
use super::layout::NodeKind;
use super::storage::Storage;

/// Nodes per block of the moment sums: 5 accumulators × 8 lanes stay in registers.
const SUM_BLOCK: usize = 8;

/// Per-row scratch of the kernels: moment sums and macroscopic fields along x.
/// One per rayon task, reused across the rows the task updates.
pub(super) struct RowScratch {
    pub rho: Vec<f64>,
    /// Momentum sums Σ c f of the moments pass.
    pub j: [Vec<f64>; 3],
    /// Energy sum Σ ½c² f (+ Σ G).
    pub en: Vec<f64>,
    pub u: [Vec<f64>; 3],
    /// Reduced temperature θ/c².
    pub theta: Vec<f64>,
    /// 1/θ.
    pub inv_theta: Vec<f64>,
    /// 1 − u²/(2θ).
    pub base: Vec<f64>,
    /// Shell weight × ρ along x, one row per shell.
    pub wr: Vec<Vec<f64>>,
    /// ζ/2 · θ: the factor of the rotational-energy populations G (2.97).
    pub rot_theta: Vec<f64>,
    /// g·u (body force, c²/Δx per unit mass).
    pub gu: Vec<f64>,
    /// The row's runs of fluid and non-fluid nodes.
    pub runs: Vec<Run>,
}

impl RowScratch {
    pub fn new(px: usize, shells: usize) -> Self {
        let z = || vec![0.0; px];
        RowScratch {
            rho: z(),
            j: [z(), z(), z()],
            en: z(),
            u: [z(), z(), z()],
            theta: z(),
            inv_theta: z(),
            base: z(),
            wr: (0..shells).map(|_| z()).collect(),
            rot_theta: z(),
            gu: z(),
            runs: Vec::new(),
        }
    }

    /// ρ = Σ f, j = Σ c f, E = Σ ½c² f + Σ G on x ∈ [x0, x1) of one row (`f_row`: value v of
    /// node x at v·px + x). Each node's sums run over the values in order. A shifted storage
    /// sums the stored departures and adds the shifts' moments once per node.
    pub fn moment_sums<S: Storage>(&mut self, eq: &Equilibrium, f_row: &[S], shift: &[f64], px: usize, x0: usize, x1: usize) {
        let mut x = x0;
        while x + SUM_BLOCK <= x1 {
            self.sum_block::<SUM_BLOCK, S>(eq, f_row, px, x);
            x += SUM_BLOCK;
        }
        while x < x1 {
            self.sum_block::<1, S>(eq, f_row, px, x);
            x += 1;
        }
        if S::SHIFTED {
            let q = eq.q();
            let mut m = [0.0; 5];
            for (v, &sv) in shift.iter().enumerate() {
                if v < q {
                    let c = eq.cf[v];
                    m[0] += sv;
                    m[1] += c[0] * sv;
                    m[2] += c[1] * sv;
                    m[3] += c[2] * sv;
                    m[4] += eq.half_c2[v] * sv;
                } else {
                    m[4] += sv;
                }
            }
            let [j0, j1, j2] = &mut self.j;
            for (a, add) in [&mut self.rho, j0, j1, j2, &mut self.en].into_iter().zip(m) {
                a[x0..x1].iter_mut().for_each(|a| *a += add);
            }
        }
    }

    #[inline(always)]
    fn sum_block<const B: usize, S: Storage>(&mut self, eq: &Equilibrium, f_row: &[S], px: usize, x: usize) {
        let q = eq.q();
        let nv = eq.values_per_node();
        let (mut rho, mut j0, mut j1, mut j2, mut en) = ([0.0; B], [0.0; B], [0.0; B], [0.0; B], [0.0; B]);
        for v in 0..q {
            let fv: &[S; B] = f_row[v * px + x..v * px + x + B].try_into().unwrap();
            let c = eq.cf[v];
            let hc = eq.half_c2[v];
            for k in 0..B {
                let fx = fv[k].load();
                rho[k] += fx;
                j0[k] += c[0] * fx;
                j1[k] += c[1] * fx;
                j2[k] += c[2] * fx;
                en[k] += hc * fx;
            }
        }
        for v in q..nv {
            let gv: &[S; B] = f_row[v * px + x..v * px + x + B].try_into().unwrap();
            for k in 0..B {
                en[k] += gv[k].load();
            }
        }
        self.rho[x..x + B].copy_from_slice(&rho);
        self.j[0][x..x + B].copy_from_slice(&j0);
        self.j[1][x..x + B].copy_from_slice(&j1);
        self.j[2][x..x + B].copy_from_slice(&j2);
        self.en[x..x + B].copy_from_slice(&en);
    }

    /// u = j/ρ and θ = (E/ρ − u²/2)/(D/2 + ζ/2) (reduced temperature θ/c²) on x ∈ [x0, x1).
    pub fn macroscopic(&mut self, energy_dof_half: f64, x0: usize, x1: usize) {
        let (rho, en) = (&self.rho[x0..x1], &self.en[x0..x1]);
        let n = rho.len();
        let (j0, j1, j2) = (&self.j[0][x0..x1], &self.j[1][x0..x1], &self.j[2][x0..x1]);
        let [u0, u1, u2] = &mut self.u;
        let (u0, u1, u2, theta) = (&mut u0[x0..x1], &mut u1[x0..x1], &mut u2[x0..x1], &mut self.theta[x0..x1]);
        let (j0, j1, j2, en) = (&j0[..n], &j1[..n], &j2[..n], &en[..n]);
        for x in 0..n {
            let inv = 1.0 / rho[x];
            let u = [j0[x] * inv, j1[x] * inv, j2[x] * inv];
            u0[x] = u[0];
            u1[x] = u[1];
            u2[x] = u[2];
            theta[x] = (en[x] * inv - 0.5 * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2])) / energy_dof_half;
        }
    }

    /// Whether every fluid node of x ∈ [x0, x1) has a positive finite density, a finite velocity
    /// and θ inside `window` (branch-free over the row; the caller finds the failing node only
    /// when this is false).
    pub fn admissible(&self, kind: &[NodeKind], window: (f64, f64), x0: usize, x1: usize) -> bool {
        let (rho, theta) = (&self.rho[x0..x1], &self.theta[x0..x1]);
        let n = rho.len();
        let (u0, u1, u2, theta, kind) = (&self.u[0][x0..x1], &self.u[1][x0..x1], &self.u[2][x0..x1], &theta[..n], &kind[..n]);
        let (u0, u1, u2) = (&u0[..n], &u1[..n], &u2[..n]);
        let mut ok = true;
        for x in 0..n {
            let good =
                (rho[x] > 0.0) & rho[x].is_finite() & u0[x].is_finite() & u1[x].is_finite() & u2[x].is_finite() & (theta[x] > window.0) & (theta[x] < window.1);
            ok &= good | (kind[x] != NodeKind::Fluid);
        }
        ok
    }

    /// Shell weights × ρ, 1/θ, 1 − u²/(2θ) and ζθ/2 on x ∈ [x0, x1): the velocity-independent
    /// parts of (2.78) and (2.97).
    pub fn prepare_equilibrium(&mut self, eq: &Equilibrium, x0: usize, x1: usize) {
        let theta = &self.theta[x0..x1];
        let rho = &self.rho[x0..x1];
        for (s, shell) in eq.set.shells.iter().enumerate() {
            for ((w, t), r) in self.wr[s][x0..x1].iter_mut().zip(theta).zip(rho) {
                *w = shell.weight(*t) * r;
            }
        }
        let n = x1 - x0;
        let (u0, u1, u2) = (&self.u[0][x0..x1], &self.u[1][x0..x1], &self.u[2][x0..x1]);
        let (inv, base, rot) = (&mut self.inv_theta[x0..x1], &mut self.base[x0..x1], &mut self.rot_theta[x0..x1]);
        for x in 0..n {
            let i = 1.0 / theta[x];
            inv[x] = i;
            base[x] = 1.0 - 0.5 * (u0[x] * u0[x] + u1[x] * u1[x] + u2[x] * u2[x]) * i;
            rot[x] = eq.rot_half * theta[x];
        }
    }
}

/// The scalars of a stage's collision: h = k_f f + k_eq f⁰ (k_f = 1 − A/τ, k_eq = A/τ), the time
/// step Δt and Δt/τ (lattice units).
#[derive(Clone, Copy)]
pub(super) struct CollideConstants {
    pub k_f: f64,
    pub k_eq: f64,
    pub dt: f64,
    pub dt_tau: f64,
}

/// One value's rows (x ∈ [x0, x1) of one row of nodes) and its velocity.
pub(super) struct CollideRows<'a, S> {
    /// Velocity c_i and g·c_i.
    pub c: [f64; 3],
    pub gc: f64,
    /// The value's shell weight × ρ.
    pub wr: &'a [f64],
    pub u: [&'a [f64]; 3],
    pub inv_theta: &'a [f64],
    pub base: &'a [f64],
    pub rot_theta: &'a [f64],
    pub gu: &'a [f64],
    /// The stage input, and fⁿ in the second stage (empty in the first).
    pub f: &'a [S],
    pub f_n: &'a [S],
    /// The row's runs of fluid and non-fluid nodes ([`runs`]), relative to x0.
    pub runs: &'a [Run],
    /// The value's storage shift (0 when unshifted: [`Storage`]).
    pub shift: f64,
}

/// A run of nodes along x: (start, end, fluid).
pub(super) type Run = (usize, usize, bool);

/// The row split into maximal runs of fluid and of non-fluid nodes: (start, end, fluid). The
/// kernels write the stage output over fluid runs with plain stores (a per-node select became a
/// masked store, which is slow on the AMD cores here).
pub(super) fn runs(kind: &[NodeKind]) -> impl Iterator<Item = Run> + '_ {
    let mut start = 0;
    std::iter::from_fn(move || {
        if start >= kind.len() {
            return None;
        }
        let fluid = kind[start] == NodeKind::Fluid;
        let len = kind[start..].iter().position(|k| (*k == NodeKind::Fluid) != fluid).unwrap_or(kind.len() - start);
        let run = (start, start + len, fluid);
        start += len;
        Some(run)
    })
}

/// One value along a row: f⁰ = w ρ [1 + ξ + ξ²/2 + ξ³/6 − u²/(2θ)(1 + ξ)] (2.78, written
/// b + ξ(b + ξ(½ + ξ/6)) with b = 1 − u²/(2θ), ξ = c·u/θ; times ζθ/2 for G, 2.97), the body
/// force term F = f⁰ g·(c − u)/θ, h = k_f f + k_eq f⁰ (every node), and the local part of the
/// RK stage, `out = f − Δt/τ (f − f⁰) + Δt F` (first stage) or
/// `out = ½ (fⁿ + f − Δt/τ (f − f⁰) + Δt F)` (second stage), written at fluid nodes only.
/// With `STREAM`, h and the output are written with streaming stores
/// ([`super::memory_hints`]), and the caller ends its task with
/// [`super::memory_hints::streaming_fence`].
#[inline(always)]
pub(super) fn collide_value<const FORCE: bool, const SECOND: bool, const ROTATIONAL: bool, const STREAM: bool, S: Storage>(
    r: &CollideRows<S>,
    k: CollideConstants,
    h: &mut [S],
    out: &mut [S],
) {
    for &(a, b, fluid) in r.runs {
        if fluid {
            collide_run::<FORCE, SECOND, ROTATIONAL, true, STREAM, S>(r, k, a, b, h, out);
        } else {
            collide_run::<FORCE, SECOND, ROTATIONAL, false, STREAM, S>(r, k, a, b, h, out);
        }
    }
}

/// Nodes per chunk of the streaming path: computed into the stack, then streamed out.
const STREAM_CHUNK: usize = 32;

#[inline(always)]
fn collide_run<const FORCE: bool, const SECOND: bool, const ROTATIONAL: bool, const FLUID: bool, const STREAM: bool, S: Storage>(
    r: &CollideRows<S>,
    k: CollideConstants,
    a: usize,
    b: usize,
    h: &mut [S],
    out: &mut [S],
) {
    let (wr, u0, u1, u2, inv, base, rot, gu, f) =
        (&r.wr[a..b], &r.u[0][a..b], &r.u[1][a..b], &r.u[2][a..b], &r.inv_theta[a..b], &r.base[a..b], &r.rot_theta[a..b], &r.gu[a..b], &r.f[a..b]);
    let n = b - a;
    let f_n = if SECOND { &r.f_n[a..b] } else { &r.f_n[..0] };
    let (h, out) = (&mut h[a..b], if FLUID { &mut out[a..b] } else { &mut out[..0] });
    let (c, sv) = (r.c, r.shift);
    // h and the stage output of node x
    let node = |x: usize| -> (S, S) {
        let xi = (c[0] * u0[x] + c[1] * u1[x] + c[2] * u2[x]) * inv[x];
        let bx = base[x];
        let poly = bx + xi * (bx + xi * (0.5 + xi * (1.0 / 6.0)));
        let mut fe = wr[x] * poly;
        if ROTATIONAL {
            fe *= rot[x];
        }
        let fx = f[x].decode(sv);
        let hx = S::encode(k.k_f * fx + k.k_eq * fe, sv);
        if !FLUID {
            return (hx, S::default());
        }
        let src = if FORCE { k.dt * fe * (r.gc - gu[x]) * inv[x] } else { 0.0 };
        (hx, S::encode(if SECOND { 0.5 * (f_n[x].decode(sv) + fx - k.dt_tau * (fx - fe) + src) } else { fx - k.dt_tau * (fx - fe) + src }, sv))
    };
    if !STREAM {
        for x in 0..n {
            let (hx, ox) = node(x);
            h[x] = hx;
            if FLUID {
                out[x] = ox;
            }
        }
        return;
    }
    let (mut hb, mut ob) = ([S::default(); STREAM_CHUNK], [S::default(); STREAM_CHUNK]);
    for start in (0..n).step_by(STREAM_CHUNK) {
        let m = STREAM_CHUNK.min(n - start);
        for j in 0..m {
            (hb[j], ob[j]) = node(start + j);
        }
        S::copy_streaming(&mut h[start..start + m], &hb[..m]);
        if FLUID {
            S::copy_streaming(&mut out[start..start + m], &ob[..m]);
        }
    }
}

/// `out −= k · (centre h + Σ_t c_t h_t)` at fluid nodes along a row: the upwind derivative of one
/// value with its `T` taps ([`super::upwind::stencils`]: 3 per axis the velocity moves along),
/// summed in the stencil's order. A shifted storage (shift `sv`) works on the stored departures
/// throughout: the stencil's coefficients sum to zero, so the shift drops out of the derivative.
#[inline(always)]
pub(super) fn advect_value<const T: usize, S: Storage>(centre: f64, h: &[S], taps: [(&[S], f64); T], k: f64, sv: f64, runs: &[Run], out: &mut [S]) {
    for &(a, b, fluid) in runs {
        if !fluid {
            continue;
        }
        let (h, out) = (&h[a..b], &mut out[a..b]);
        let taps = taps.map(|(t, c)| (&t[a..b], c));
        for x in 0..b - a {
            let mut s = centre * h[x].load();
            for (t, c) in &taps {
                s += c * t[x].load();
            }
            out[x] = S::store_departure(out[x].load() - k * s, sv);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_cover_the_row_in_alternating_maximal_pieces() {
        use NodeKind::{Fluid, Ghost as Solid};
        let kinds = [Fluid, Fluid, Solid, Fluid, Solid, Solid, Solid, Fluid];
        let r: Vec<Run> = runs(&kinds).collect();
        assert_eq!(r, vec![(0, 2, true), (2, 3, false), (3, 4, true), (4, 7, false), (7, 8, true)]);
        assert_eq!(runs(&[Fluid; 5]).collect::<Vec<_>>(), vec![(0, 5, true)]);
        assert_eq!(runs(&[]).count(), 0);
    }
}
