//! The two passes an RK stage of the FDLB step makes over the lattice (seed 000 §2.3, (2.77)),
//! parallel over padded rows: the moments with the collision and body force into h and the stage
//! output ([`Kernels::moments_collide`], with the state check that stops an unstable run), and
//! the upwind advection of h ([`Kernels::advect`], with the thin walls' taps); the per-row
//! arithmetic is [`super::row_kernels`]. [`super::solver::FluidSolver::run_stage`] drives them.

use super::equilibrium::{Equilibrium, MACRO_FIELDS, Macro};
use super::layout::{Layout, NodeKind};
use super::memory_hints::{MemoryHints, prefetch_bytes, streaming_fence};
use super::row_kernels::{CollideConstants, CollideRows, RowScratch, advect_value, collide_value, runs};
use super::storage::{RowBlocked, Storage, shift_of};
use super::thin_wall::advect_thin_taps;
use super::timestep::StepParams;
use rayon::prelude::*;

/// [`collide_value`] for (body force, second RK stage, rotational-energy value).
#[inline(always)]
fn collide_value_of<const STREAM: bool, S: Storage>(kinds: (bool, bool, bool), rows: &CollideRows<S>, k: CollideConstants, h: &mut [S], out: &mut [S]) {
    match kinds {
        (false, false, false) => collide_value::<false, false, false, STREAM, S>(rows, k, h, out),
        (false, false, true) => collide_value::<false, false, true, STREAM, S>(rows, k, h, out),
        (false, true, false) => collide_value::<false, true, false, STREAM, S>(rows, k, h, out),
        (false, true, true) => collide_value::<false, true, true, STREAM, S>(rows, k, h, out),
        (true, false, false) => collide_value::<true, false, false, STREAM, S>(rows, k, h, out),
        (true, false, true) => collide_value::<true, false, true, STREAM, S>(rows, k, h, out),
        (true, true, false) => collide_value::<true, true, false, STREAM, S>(rows, k, h, out),
        (true, true, true) => collide_value::<true, true, true, STREAM, S>(rows, k, h, out),
    }
}

/// Rows per rayon task so that a task updates at least ~16k values (small grids would otherwise
/// drown in scheduling overhead).
fn rows_per_task(values_per_row: usize) -> usize {
    (16_384 / values_per_row.max(1)).max(1)
}

/// The padded rows (index y + z·py) in the advection's sweep order: y-slabs of a few rows, every
/// z of a slab before the next slab, so that the five planes of a slab its taps read
/// (z − 2 … z + 2) stay in cache — about 1 MiB of them, 4 to `py` rows a slab. The order changes
/// no result: each row's update reads h and writes only its own row.
pub(super) fn advect_order(row_bytes: usize, py: usize, pz: usize) -> Vec<u32> {
    let slab = ((1 << 20) / (5 * row_bytes.max(1))).clamp(4, py.max(4));
    let mut order = Vec::with_capacity(py * pz);
    for y0 in (0..py).step_by(slab) {
        for z in 0..pz {
            order.extend((y0..(y0 + slab).min(py)).map(|y| (y + z * py) as u32));
        }
    }
    order
}

fn check_state(m: &Macro, window: (f64, f64)) -> Option<(&'static str, f64, String)> {
    if !(m.rho > 0.0) || !m.rho.is_finite() {
        return Some(("density", m.rho, "density must be positive and finite".into()));
    }
    if !m.u.iter().all(|u| u.is_finite()) {
        return Some(("velocity", m.speed2().sqrt(), "velocity is not finite".into()));
    }
    if !(m.theta > window.0 && m.theta < window.1) {
        return Some((
            "temperature",
            m.theta,
            format!("reduced temperature θ/c² left the window ({:.4}, {:.4}) where every equilibrium weight is positive", window.0, window.1),
        ));
    }
    None
}

/// The row kernels of the moments and advect–collide stages.
pub(super) struct Kernels<'a> {
    pub(super) eq: &'a Equilibrium,
    pub(super) layout: &'a Layout,
    pub(super) stencil: &'a [(f64, Vec<(isize, f64)>)],
    pub(super) advect_order: &'a [u32],
    pub(super) params: StepParams,
    pub(super) g: [f64; 3],
    pub(super) pop: RowBlocked,
    /// The shift of each value (empty when unshifted: [`Storage`]).
    pub(super) shift: &'a [f64],
    pub(super) hints: MemoryHints,
}

impl Kernels<'_> {
    /// Interior x-range of padded rows and whether padded row `r` is an interior row.
    fn interior(&self, r: usize) -> Option<(usize, usize)> {
        let g = &self.layout.grid;
        let y = r % g.padded[1];
        let z = r / g.padded[1];
        let inside = y >= g.halo[1] && y < g.halo[1] + g.n[1] && z >= g.halo[2] && z < g.halo[2] + g.n[2];
        inside.then_some((g.halo[0], g.halo[0] + g.n[0]))
    }

    /// Moments–collision pass on every interior row: macro fields, h = (1 − A/τ) f + (A/τ) f⁰,
    /// and the local part of the stage output, `out = f + Δt(−(f − f⁰)/τ + F)` (stage 1) or
    /// `out = ½ fⁿ + ½ (f + Δt(−(f − f⁰)/τ + F))` (stage 2, `base` = fⁿ), at fluid nodes.
    /// Returns the first fluid node (lowest index) whose state is not admissible.
    #[allow(clippy::type_complexity)]
    pub(super) fn moments_collide<S: Storage>(
        &self,
        f: &[S],
        base: Option<&[S]>,
        h: &mut [S],
        mac: &mut [f64],
        out: &mut [S],
        window: (f64, f64),
    ) -> Option<(usize, &'static str, f64, String)> {
        let eq = self.eq;
        let nv = eq.values_per_node();
        let q = eq.q();
        let px = self.pop.px;
        let kind = &self.layout.kind;
        let StepParams { dt, tau, a } = self.params;
        let (k_f, k_eq) = (1.0 - a / tau, a / tau);
        let dt_tau = dt / tau;
        let edh = eq.energy_dof_half;
        let g = self.g;
        let has_force = g.iter().any(|g| *g != 0.0);
        let (prefetch, stream) = (self.hints.prefetch_rows, self.hints.streaming_stores);
        h.par_chunks_mut(px * nv)
            .zip(mac.par_chunks_mut(px * MACRO_FIELDS))
            .zip(out.par_chunks_mut(px * nv))
            .enumerate()
            .with_min_len(rows_per_task(px * nv))
            .map_init(
                || RowScratch::new(px, eq.set.shells.len()),
                |s, (r, ((h_row, mac_row), out_row))| {
                    let (x0, x1) = self.interior(r)?;
                    let f_row = &f[r * px * nv..(r + 1) * px * nv];
                    let kind_row = &kind[r * px..(r + 1) * px];
                    s.moment_sums(eq, f_row, self.shift, px, x0, x1);
                    s.macroscopic(edh, x0, x1);
                    if !s.admissible(&kind_row[x0..x1], window, x0, x1) {
                        for x in x0..x1 {
                            if kind_row[x] == NodeKind::Fluid {
                                let m = Macro { rho: s.rho[x], u: [s.u[0][x], s.u[1][x], s.u[2][x]], theta: s.theta[x] };
                                if let Some((qty, val, why)) = check_state(&m, window) {
                                    return Some((r * px + x, qty, val, why));
                                }
                            }
                        }
                    }
                    s.prepare_equilibrium(eq, x0, x1);
                    if has_force {
                        for x in x0..x1 {
                            s.gu[x] = g[0] * s.u[0][x] + g[1] * s.u[1][x] + g[2] * s.u[2][x];
                        }
                    }
                    s.runs.clear();
                    s.runs.extend(runs(&kind_row[x0..x1]));
                    let consts = CollideConstants { k_f, k_eq, dt, dt_tau };
                    let next_f = f.get((r + 1) * px * nv..(r + 2) * px * nv).filter(|_| prefetch);
                    let next_base = base.and_then(|b| b.get((r + 1) * px * nv..(r + 2) * px * nv)).filter(|_| prefetch);
                    for v in 0..nv {
                        if let Some(nf) = next_f {
                            prefetch_bytes(nf[v * px..].as_ptr() as usize, px * std::mem::size_of::<S>());
                        }
                        if let Some(nb) = next_base {
                            prefetch_bytes(nb[v * px..].as_ptr() as usize, px * std::mem::size_of::<S>());
                        }
                        let i = if v < q { v } else { v - q };
                        let ci = eq.cf[i];
                        let gc = g[0] * ci[0] + g[1] * ci[1] + g[2] * ci[2];
                        let range = v * px + x0..v * px + x1;
                        let base_row = base.map(|b| &b[r * px * nv + range.start..r * px * nv + range.end]);
                        let rows = CollideRows {
                            c: ci,
                            gc,
                            wr: &s.wr[eq.set.shell_of[i]][x0..x1],
                            u: [&s.u[0][x0..x1], &s.u[1][x0..x1], &s.u[2][x0..x1]],
                            inv_theta: &s.inv_theta[x0..x1],
                            base: &s.base[x0..x1],
                            rot_theta: &s.rot_theta[x0..x1],
                            gu: &s.gu[x0..x1],
                            f: &f_row[range.clone()],
                            f_n: base_row.unwrap_or_default(),
                            runs: &s.runs,
                            shift: shift_of(self.shift, v),
                        };
                        let (hv, ov) = (&mut h_row[range.clone()], &mut out_row[range]);
                        let kinds = (has_force, base.is_some(), v >= q);
                        if stream {
                            collide_value_of::<true, S>(kinds, &rows, consts, hv, ov);
                        } else {
                            collide_value_of::<false, S>(kinds, &rows, consts, hv, ov);
                        }
                    }
                    let fields = [&s.rho, &s.u[0], &s.u[1], &s.u[2], &s.theta];
                    for (k, fld) in fields.iter().enumerate() {
                        mac_row[k * px + x0..k * px + x1].copy_from_slice(&fld[x0..x1]);
                    }
                    if stream {
                        streaming_fence();
                    }
                    None
                },
            )
            .reduce(
                || None,
                |a, b| match (a, b) {
                    (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
                    (a, b) => a.or(b),
                },
            )
    }

    /// Advection: `out −= factor · Δt · c·∇h` at fluid nodes (3rd-order upwind, [`super::upwind`]).
    pub(super) fn advect<S: Storage>(&self, h: &[S], side_h: &[f64], out: &mut [S], factor: f64) {
        let eq = self.eq;
        let nv = eq.values_per_node();
        let q = eq.q();
        let px = self.pop.px;
        let kind = &self.layout.kind;
        let k = factor * self.params.dt;
        // rows in y-slab order ([`advect_order`])
        let row_len = px * nv;
        let out_addr = out.as_ptr() as usize;
        let g = &self.layout.grid;
        // the row whose h the next row's taps reach first: two planes on (3D), two rows on (2D)
        let ahead = if g.dim == 3 { 2 * g.padded[1] } else { 2 };
        let prefetch = self.hints.prefetch_rows;
        let mut slots: Vec<Option<&mut [S]>> = out.chunks_mut(row_len).map(Some).collect();
        let order = self.advect_order;
        let rows: Vec<(usize, usize, &mut [S])> = order
            .iter()
            .enumerate()
            .map(|(i, &r)| (r as usize, order.get(i + 1).map_or(r as usize, |&n| n as usize), slots[r as usize].take().expect("each row once")))
            .collect();
        rows.into_par_iter().with_min_len(rows_per_task(row_len)).for_each_init(Vec::new, |row_runs, (r, next, out_row)| {
            let Some((x0, x1)) = self.interior(r) else { return };
            row_runs.clear();
            row_runs.extend(runs(&kind[r * px + x0..r * px + x1]));
            for v in 0..nv {
                if prefetch {
                    let seg = std::mem::size_of::<S>() * px;
                    prefetch_bytes(out_addr + (next * row_len + v * px) * std::mem::size_of::<S>(), seg);
                    if let Some(hn) = h.get((next + ahead) * row_len + v * px..(next + ahead) * row_len + (v + 1) * px) {
                        prefetch_bytes(hn.as_ptr() as usize, seg);
                    }
                }
                let i = if v < q { v } else { v - q };
                let (centre, taps) = &self.stencil[i];
                let base = (r * nv + v) * px;
                let hc = &h[base + x0..base + x1];
                let tap = |t: usize| {
                    let start = (base as isize + taps[t].0) as usize;
                    (&h[start + x0..start + x1], taps[t].1)
                };
                let ov = &mut out_row[v * px + x0..v * px + x1];
                let sv = shift_of(self.shift, v);
                match taps.len() {
                    0 => advect_value::<0, S>(*centre, hc, [], k, sv, row_runs, ov),
                    3 => advect_value::<3, S>(*centre, hc, [tap(0), tap(1), tap(2)], k, sv, row_runs, ov),
                    6 => advect_value::<6, S>(*centre, hc, std::array::from_fn(tap), k, sv, row_runs, ov),
                    9 => advect_value::<9, S>(*centre, hc, std::array::from_fn(tap), k, sv, row_runs, ov),
                    t => unreachable!("an upwind stencil has 3 taps per axis, not {t}"),
                }
            }
        });
        let py = self.layout.grid.padded[1];
        advect_thin_taps(&self.layout.thin_taps, eq, self.pop, self.shift, py, k, h, side_h, out);
    }
}
