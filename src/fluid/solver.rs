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

use super::boundary::Boundaries;
use super::boundary_fill::{GhostScratch, StageFields, fill_boundaries};
use super::equilibrium::{Equilibrium, MACRO_FIELDS, Macro};
use super::geometry::Obstacle;
use super::grid::Grid;
use super::layout::Layout;
pub use super::memory_hints::MemoryHints;
use super::stage_passes::{Kernels, advect_order};
use super::storage::{RowBlocked, Storage, recode_into, rest_shift};
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
    /// Scratch of the boundary fill, kept between fills ([`super::boundary_fill::GhostScratch`]).
    ghost_scratch: GhostScratch<S>,
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
            ghost_scratch: GhostScratch::default(),
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
            ghost_scratch: GhostScratch::default(),
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
        // one row of nodes at a time on the pool's threads (a row is a contiguous chunk of every
        // array): the first touch of the arrays' pages, which is most of a large scene's build
        let (pop, macro_layout, eq, shift) = (self.pop, self.macro_layout, &self.eq, &self.shift);
        let shells = eq.set.shells.len();
        self.f.par_chunks_mut(pop.row_len()).zip(self.mac.par_chunks_mut(macro_layout.row_len())).enumerate().for_each_init(
            || (vec![0.0; shells], vec![0.0; nv]),
            |(w, fe), (row, (f, mac))| {
                for x in 0..pop.px {
                    let m = &at(row * pop.px + x);
                    eq.feq_into(m, w, fe);
                    pop.scatter_populations(f, x, shift, fe);
                    macro_layout.scatter(mac, x, &[m.rho, m.u[0], m.u[1], m.u[2], m.theta]);
                }
            },
        );
        let chunk = pop.row_len();
        for copy in [&mut self.f1, &mut self.f2, &mut self.h] {
            copy.par_chunks_mut(chunk).zip(self.f.par_chunks(chunk)).for_each(|(to, from)| to.copy_from_slice(from));
        }
    }

    /// Sets every value of f, f¹, fⁿ⁺¹, h and the macroscopic fields at the periodic halo nodes
    /// to NaN: a stage that reads one of them before the boundary fill has written it spreads
    /// the NaN.
    #[cfg(test)]
    pub(crate) fn poison_periodic_halos(&mut self) {
        let nan = vec![f64::NAN; self.pop.nv];
        for node in (0..self.layout.grid.len()).filter(|&n| self.layout.kind[n] == super::layout::NodeKind::Periodic) {
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
                    ghost_scratch: &mut self.ghost_scratch,
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
