//! The CPU reference FDLB solver (seed 000 §2.3): state, one step driven by
//! [`crate::stages::FDLB_STEP`]; what its state says (macroscopic fields, totals) is in
//! [`super::observe`].
//!
//! Discrete equation (2.77), rewritten for the upwind scheme:
//! ∂f_i/∂t = −c_i·∇h_i − (f_i − f⁰_i)/τ + F_i,   h = (1 − A/τ) f + (A/τ) f⁰,
//! with the body-force term F_i = f⁰_i g·(c_i − u)/θ (the first-order Hermite term of
//! −g·∂f/∂c; it adds exactly ρg to the momentum and ρg·u to the energy).
//! Runge–Kutta: Heun's method (RK2): f¹ = fⁿ + Δt L(fⁿ), fⁿ⁺¹ = ½ fⁿ + ½ (f¹ + Δt L(f¹)).
//! Each stage first writes its local part (collision and force) into the stage output, then the
//! boundary fill, then subtracts the advection.

use super::boundary::{Boundaries, StageFields, fill_boundaries};
use super::equilibrium::{Equilibrium, MACRO_FIELDS, Macro};
use super::geometry::Obstacle;
use super::grid::Grid;
use super::layout::{Layout, NodeKind};
pub use super::memory_hints::MemoryHints;
use super::memory_hints::{prefetch_bytes, streaming_fence};
use super::row_kernels::{CollideConstants, CollideRows, RowScratch, advect_value, collide_value, runs};
use super::storage::{RowBlocked, Storage, recode_into, rest_shift, shift_of};
use super::thin_wall::advect_thin_taps;
use super::timestep::StepParams;
use super::upwind::stencils;
use crate::stages::{FDLB_STEP, RkStage, Stage, StageKind, StageTimings};
use rayon::prelude::*;
use std::time::Instant;

pub use super::observe::Totals;
pub use crate::step::Instability;
use crate::step::{Part, Site};

/// The solver's state and step. `S` is the number type the populations are stored in
/// ([`Storage`]: f64, the reference, or f32); [`FluidSolver::new`] makes the f64 one,
/// [`FluidSolver::with_storage`] either.
#[derive(Clone)]
pub struct FluidSolver<S: Storage = f64> {
    pub eq: Equilibrium,
    pub layout: Layout,
    pub params: StepParams,
    /// Body force per unit mass g (c²/Δx), uniform.
    pub body_force: [f64; 3],
    /// Populations fⁿ (and Gⁿ), row-blocked ([`RowBlocked`]).
    pub f: Vec<S>,
    f1: Vec<S>,
    /// Output of the second stage (fⁿ⁺¹), swapped with `f` at the end of a step, so that fⁿ
    /// stays intact when a step fails.
    f2: Vec<S>,
    /// Advected field of the current stage: h = (1 − A/τ) f + (A/τ) f⁰ (the two upwind terms
    /// of (2.77) share one stencil because they are linear).
    h: Vec<S>,
    /// Macro fields ρ, u_x, u_y, u_z, θ of the current stage, row-blocked.
    mac: Vec<f64>,
    /// h of the thin walls' side ghosts in the current stage ([`super::thin_wall`]).
    side_h: Vec<f64>,
    /// The state at rest the stored populations depart from (the initial state's mean density
    /// and temperature), and its equilibrium per value rounded to `S` — the shift of a shifted
    /// storage ([`Storage`]; empty when `S` is not shifted).
    rest: Macro,
    pub(super) shift: Vec<f64>,
    /// Layout of populations and of macro fields.
    pub pop: RowBlocked,
    pub macro_layout: RowBlocked,
    /// Per velocity: centre coefficient and (value offset, coefficient) taps.
    stencil: Vec<(f64, Vec<(isize, f64)>)>,
    /// The padded rows in the advection's sweep order ([`advect_order`]).
    advect_order: Vec<u32>,
    window: (f64, f64),
    /// Streaming stores and rows fetched ahead ([`MemoryHints`]): chosen from the arrays' size
    /// against the last-level cache.
    hints: MemoryHints,
    pub step_count: u64,
    pub time: f64,
    pub timings: StageTimings,
}

impl FluidSolver {
    /// Allocates the solver (populations stored in f64) and sets every node to the equilibrium
    /// of `init(x)` (x in interior node coordinates; halo and solid nodes too, so that every
    /// stored value is finite).
    pub fn new(
        eq: Equilibrium,
        grid: Grid,
        boundaries: Boundaries,
        obstacles: &[Obstacle],
        params: StepParams,
        init: impl Fn([f64; 3]) -> Macro + Sync,
    ) -> Self {
        Self::with_storage(eq, grid, boundaries, obstacles, params, init)
    }

    /// The stage arrays (f¹, fⁿ⁺¹ being built, h, macro fields), for parity checks against
    /// the GPU backend.
    pub fn stage_arrays(&self) -> (&[f64], &[f64], &[f64], &[f64]) {
        (&self.f1, &self.f2, &self.h, &self.mac)
    }
}

impl<S: Storage> FluidSolver<S> {
    /// [`FluidSolver::new`] with the populations stored as `S` (`FluidSolver::<f32>::with_storage`).
    pub fn with_storage(
        eq: Equilibrium,
        grid: Grid,
        boundaries: Boundaries,
        obstacles: &[Obstacle],
        params: StepParams,
        init: impl Fn([f64; 3]) -> Macro + Sync,
    ) -> Self {
        let layout = Layout::new(grid, boundaries, obstacles);
        let g = &layout.grid;
        let n = g.len();
        let nv = eq.values_per_node();
        let pop = RowBlocked { px: g.padded[0], nv };
        let macro_layout = RowBlocked { px: g.padded[0], nv: MACRO_FIELDS };
        let stencil =
            stencils(&eq.set.c).into_iter().map(|s| (s.centre, s.taps.iter().map(|&(d, c)| (pop.neighbour_offset(d, g.padded[1]), c)).collect())).collect();
        let window = eq.set.positivity_window();
        let advect_order = advect_order(pop.row_len() * 8, g.padded[1], g.padded[2]);
        let mut s = FluidSolver {
            f: vec![S::default(); n * nv],
            f1: vec![S::default(); n * nv],
            f2: vec![S::default(); n * nv],
            h: vec![S::default(); n * nv],
            side_h: Vec::new(),
            mac: vec![0.0; n * MACRO_FIELDS],
            rest: Macro::default(),
            shift: Vec::new(),
            pop,
            macro_layout,
            eq,
            layout,
            params,
            body_force: [0.0; 3],
            stencil,
            advect_order,
            window,
            hints: MemoryHints { streaming_stores: false, prefetch_rows: false },
            step_count: 0,
            time: 0.0,
            timings: StageTimings::default(),
        };
        s.hints = MemoryHints::choose(s.footprint_bytes(), s.pop.px, crate::machine::last_level_cache_bytes());
        s.initialise(init);
        s
    }

    /// f¹, fⁿ⁺¹ and h as stored (tests).
    #[cfg(test)]
    fn stage_arrays_stored(&self) -> [&[S]; 3] {
        [&self.f1, &self.f2, &self.h]
    }

    /// Bytes of the solver's per-node arrays: the four population arrays (fⁿ, f¹, fⁿ⁺¹, h) and
    /// the macroscopic fields.
    pub fn footprint_bytes(&self) -> usize {
        self.layout.grid.len() * (4 * self.eq.values_per_node() * std::mem::size_of::<S>() + MACRO_FIELDS * 8)
    }

    /// How the passes move their bytes (chosen at construction from [`Self::footprint_bytes`]
    /// against the last-level cache: [`MemoryHints::choose`]).
    pub fn memory_hints(&self) -> MemoryHints {
        self.hints
    }

    /// Chooses how the passes move their bytes (benchmarks and tests: the results are the same
    /// bits either way).
    pub fn set_memory_hints(&mut self, hints: MemoryHints) {
        self.hints = hints;
    }

    /// The same solver with its populations stored as `T`, every value rounded once (exact from
    /// f32 to f64; from f64 to f32 exact for a state that came from f32 storage of the same
    /// initial state: [`Storage`]).
    pub fn converted<T: Storage>(&self) -> FluidSolver<T> {
        let shift = rest_shift::<T>(&self.eq, &self.rest);
        let recoded = |a: &[S]| {
            let mut out = vec![T::default(); a.len()];
            recode_into(self.pop, a, &self.shift, &shift, &mut out);
            out
        };
        let mut converted = FluidSolver {
            eq: self.eq.clone(),
            layout: self.layout.clone(),
            params: self.params,
            body_force: self.body_force,
            f: recoded(&self.f),
            f1: recoded(&self.f1),
            f2: recoded(&self.f2),
            h: recoded(&self.h),
            mac: self.mac.clone(),
            side_h: self.side_h.clone(),
            rest: self.rest,
            shift,
            pop: self.pop,
            macro_layout: self.macro_layout,
            stencil: self.stencil.clone(),
            advect_order: self.advect_order.clone(),
            window: self.window,
            hints: self.hints,
            step_count: self.step_count,
            time: self.time,
            timings: self.timings.clone(),
        };
        // its own footprint against the cache (f32 arrays are half the f64 ones)
        converted.hints = MemoryHints::choose(converted.footprint_bytes(), converted.pop.px, crate::machine::last_level_cache_bytes());
        converted
    }

    /// Copies the state a step starts from — the populations fⁿ, the step counter, the time —
    /// into `other`, a solver of the same lattice, layout and initial state stored as `T` (what
    /// every observation reads: [`super::observe`]).
    pub fn copy_state_into<T: Storage>(&self, other: &mut FluidSolver<T>) {
        assert_eq!(self.f.len(), other.f.len(), "copy_state_into: not the same lattice");
        recode_into(self.pop, &self.f, &self.shift, &other.shift, &mut other.f);
        other.step_count = self.step_count;
        other.time = self.time;
    }

    /// The shift of each value of a shifted storage (empty for f64: [`Storage`]).
    pub fn storage_shift(&self) -> &[f64] {
        &self.shift
    }

    /// Sets every node to the equilibrium of `init(x)`; the shifts of a shifted storage become
    /// the equilibrium at rest of the state's mean density and temperature.
    pub fn initialise(&mut self, init: impl Fn([f64; 3]) -> Macro + Sync) {
        let nv = self.eq.values_per_node();
        let mut w = vec![0.0; self.eq.set.shells.len()];
        let mut fe = vec![0.0; nv];
        let n = self.layout.grid.len();
        let grid = &self.layout.grid;
        let at = |node: usize| {
            let x = grid.coords(node);
            init([x[0] as f64, x[1] as f64, x[2] as f64])
        };
        // two passes over `init` (cheap, analytic), so that no per-node state is held
        let (rho, theta) = (0..n).map(&at).fold((0.0, 0.0), |(r, t), m| (r + m.rho, t + m.theta));
        self.rest = Macro { rho: rho / n.max(1) as f64, u: [0.0; 3], theta: theta / n.max(1) as f64 };
        self.shift = rest_shift::<S>(&self.eq, &self.rest);
        for node in 0..n {
            let m = &at(node);
            self.eq.feq_into(m, &mut w, &mut fe);
            self.pop.scatter_populations(&mut self.f, node, &self.shift, &fe);
            self.macro_layout.scatter(&mut self.mac, node, &[m.rho, m.u[0], m.u[1], m.u[2], m.theta]);
        }
        self.f1.copy_from_slice(&self.f);
        self.f2.copy_from_slice(&self.f);
        self.h.copy_from_slice(&self.f);
    }

    /// Sets every value of f, f¹, fⁿ⁺¹, h and the macroscopic fields at the periodic halo nodes
    /// to NaN: a stage that reads one of them before the boundary fill has written it spreads
    /// the NaN.
    #[cfg(test)]
    pub(crate) fn poison_periodic_halos(&mut self) {
        let nan = vec![f64::NAN; self.pop.nv];
        for node in (0..self.layout.grid.len()).filter(|&n| self.layout.kind[n] == NodeKind::Periodic) {
            for a in [&mut self.f, &mut self.f1, &mut self.f2, &mut self.h] {
                self.pop.scatter(a, node, &nan);
            }
            self.macro_layout.scatter(&mut self.mac, node, &[f64::NAN; MACRO_FIELDS]);
        }
    }

    /// Populations of one node of fⁿ.
    pub fn node_populations(&self, node: usize) -> Vec<f64> {
        let mut out = vec![0.0; self.pop.nv];
        self.pop.gather_populations(&self.f, node, &self.shift, &mut out);
        out
    }

    /// Overwrites the populations of one node of fⁿ.
    pub fn set_node_populations(&mut self, node: usize, vals: &[f64]) {
        self.pop.scatter_populations(&mut self.f, node, &self.shift, vals);
    }

    /// h of the thin walls' side ghosts in the current stage, slot by slot
    /// ([`super::thin_wall::side_ghost_count`]).
    pub fn side_ghost_values(&self) -> &[f64] {
        &self.side_h
    }

    /// Reduced-temperature window in which every equilibrium weight is positive.
    pub fn temperature_window(&self) -> (f64, f64) {
        self.window
    }

    /// One full step (every stage of [`FDLB_STEP`]).
    pub fn step(&mut self) -> Result<(), Instability> {
        self.step_observed(|_, _| {})
    }

    /// One full step, calling `after(stage, self)` after every stage (the coupling reads the
    /// advected field of each advection stage, [`Self::stage_arrays`]).
    pub fn step_observed(&mut self, after: impl FnMut(&Stage, &Self) + Send) -> Result<(), Instability> {
        // on one of rayon's workers, so that the stages' parallel loops start inside the pool
        // (see `SolidSolver::step`)
        rayon::scope(|_| self.step_observed_in_pool(after))
    }

    fn step_observed_in_pool(&mut self, mut after: impl FnMut(&Stage, &Self)) -> Result<(), Instability> {
        for (k, stage) in FDLB_STEP.iter().enumerate() {
            let t0 = Instant::now();
            let r = self.run_stage(stage);
            self.timings.total[k] += t0.elapsed();
            r?;
            after(stage, self);
        }
        std::mem::swap(&mut self.f, &mut self.f2);
        self.timings.steps += 1;
        self.step_count += 1;
        self.time += self.params.dt;
        Ok(())
    }

    /// Runs `n` steps, stopping at the first instability.
    pub fn run(&mut self, n: u64) -> Result<(), Instability> {
        for _ in 0..n {
            self.step()?;
        }
        Ok(())
    }

    /// Each stage's share of the wall time of the steps so far ([`FDLB_STEP`]'s names).
    pub fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        self.timings.report()
    }

    /// Executes one stage of the list.
    pub fn run_stage(&mut self, stage: &Stage) -> Result<(), Instability> {
        let ctx = Kernels {
            eq: &self.eq,
            layout: &self.layout,
            stencil: &self.stencil,
            advect_order: &self.advect_order,
            params: self.params,
            g: self.body_force,
            pop: self.pop,
            shift: &self.shift,
            hints: self.hints,
        };
        match stage.kind {
            StageKind::MomentsCollide => {
                let r = match stage.rk {
                    RkStage::First => ctx.moments_collide(&self.f, None, &mut self.h, &mut self.mac, &mut self.f1, self.window),
                    RkStage::Second => ctx.moments_collide(&self.f1, Some(&self.f), &mut self.h, &mut self.mac, &mut self.f2, self.window),
                };
                if let Some((node, quantity, value, reason)) = r {
                    return Err(Instability {
                        part: Part::Fluid,
                        step: self.step_count,
                        time: self.time,
                        time_unit: "lattice units",
                        site: Site::Node(self.layout.grid.coords(node)),
                        quantity,
                        value,
                        reason,
                    });
                }
            }
            StageKind::Boundaries => {
                let f = match stage.rk {
                    RkStage::First => &mut self.f,
                    RkStage::Second => &mut self.f1,
                };
                let mut fields = StageFields {
                    f,
                    h: &mut self.h,
                    mac: &mut self.mac,
                    side_h: &mut self.side_h,
                    shift: &self.shift,
                    pop: self.pop,
                    mac_layout: self.macro_layout,
                };
                fill_boundaries(&self.layout, &self.eq, &mut fields, self.params);
            }
            StageKind::Advect => match stage.rk {
                RkStage::First => ctx.advect(&self.h, &self.side_h, &mut self.f1, 1.0),
                RkStage::Second => ctx.advect(&self.h, &self.side_h, &mut self.f2, 0.5),
            },
        }
        Ok(())
    }

    /// Bytes read and written per fluid-node update of one full step by this implementation
    /// (populations of `S`, macro fields f64, neighbours assumed served from cache): per RK stage
    /// the moments–collision pass reads the stage input (and fⁿ in stage 2) and writes h, the 5
    /// macro fields and the stage output; the advection reads h and the stage output and writes
    /// the stage output.
    pub fn bytes_per_node_update(&self) -> f64 {
        let nv = self.eq.values_per_node() as f64;
        let m = MACRO_FIELDS as f64;
        let pop = std::mem::size_of::<S>() as f64;
        let first = pop * (nv + nv + nv) + 8.0 * m + pop * (nv + nv + nv);
        let second = first + pop * nv;
        first + second
    }
}

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
fn advect_order(row_bytes: usize, py: usize, pz: usize) -> Vec<u32> {
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
struct Kernels<'a> {
    eq: &'a Equilibrium,
    layout: &'a Layout,
    stencil: &'a [(f64, Vec<(isize, f64)>)],
    advect_order: &'a [u32],
    params: StepParams,
    g: [f64; 3],
    pop: RowBlocked,
    /// The shift of each value (empty when unshifted: [`Storage`]).
    shift: &'a [f64],
    hints: MemoryHints,
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
    fn moments_collide<S: Storage>(
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
    fn advect<S: Storage>(&self, h: &[S], side_h: &[f64], out: &mut [S], factor: f64) {
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

impl<S: Storage> crate::step::Solver for FluidSolver<S> {
    fn step(&mut self) -> Result<(), Instability> {
        FluidSolver::step(self)
    }
    fn step_count(&self) -> u64 {
        self.step_count
    }
    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        FluidSolver::stage_shares(self)
    }
}

#[cfg(test)]
#[path = "solver_tests.rs"]
mod tests;
