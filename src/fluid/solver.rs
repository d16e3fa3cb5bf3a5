//! The CPU reference FDLB solver (seed 000 §2.3): state, one step driven by
//! [`crate::stages::FDLB_STEP`], conserved totals and macroscopic fields.
//!
//! Discrete equation (2.77), rewritten for the upwind scheme:
//! ∂f_i/∂t = −(1 − A/τ) c_i·∇f_i − (A/τ) c_i·∇f⁰_i − (f_i − f⁰_i)/τ + F_i,
//! with the body-force term F_i = f⁰_i g·(c_i − u)/θ (the first-order Hermite term of
//! −g·∂f/∂c; it adds exactly ρg to the momentum and ρg·u to the energy).
//! Runge–Kutta: Heun's method (RK2).

use super::boundary::{Boundaries, StageFields, fill_boundaries};
use super::equilibrium::{Equilibrium, MACRO_FIELDS, Macro};
use super::geometry::Obstacle;
use super::grid::Grid;
use super::layout::{Layout, NodeKind};
use super::timestep::StepParams;
use super::upwind::{VelocityStencil, stencils};
use crate::stages::{FDLB_STEP, RkStage, Stage, StageKind, StageTimings};
use rayon::prelude::*;
use std::time::Instant;

/// Why a run stopped: where, when and which quantity left its admissible range.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("unstable at step {step} (t = {time:.6} lattice units), node {node:?}: {quantity} = {value:e} ({reason})")]
pub struct Instability {
    pub step: u64,
    pub time: f64,
    /// Interior node coordinates.
    pub node: [i64; 3],
    pub quantity: &'static str,
    pub value: f64,
    pub reason: String,
}

/// Totals over fluid nodes (lattice units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Totals {
    pub mass: f64,
    pub momentum: [f64; 3],
    pub energy: f64,
}

pub struct FluidSolver {
    pub eq: Equilibrium,
    pub layout: Layout,
    pub params: StepParams,
    /// Body force per unit mass g (c²/Δx), uniform.
    pub body_force: [f64; 3],
    /// Populations fⁿ (and Gⁿ), cell-major.
    pub f: Vec<f64>,
    f1: Vec<f64>,
    /// Advected field of the current stage: h = (1 − A/τ) f + (A/τ) f⁰ (the two upwind terms
    /// of (2.77) share one stencil because they are linear).
    h: Vec<f64>,
    mac: Vec<f64>,
    stencil: Vec<VelocityStencil>,
    window: (f64, f64),
    pub step_count: u64,
    pub time: f64,
    pub timings: StageTimings,
}

impl FluidSolver {
    /// Allocates the solver and sets every node to the equilibrium of `init(x)` (x in interior
    /// node coordinates).
    pub fn new(eq: Equilibrium, grid: Grid, boundaries: Boundaries, obstacles: &[Obstacle], params: StepParams, init: impl Fn([f64; 3]) -> Macro + Sync) -> Self {
        let layout = Layout::new(grid, boundaries, obstacles);
        let n = layout.grid.len();
        let nv = eq.values_per_node();
        let stencil = stencils(&eq.set.c, layout.grid.stride);
        let window = eq.set.positivity_window();
        let mut s = FluidSolver {
            f: vec![0.0; n * nv],
            f1: vec![0.0; n * nv],
            h: vec![0.0; n * nv],
            mac: vec![0.0; n * MACRO_FIELDS],
            eq,
            layout,
            params,
            body_force: [0.0; 3],
            stencil,
            window,
            step_count: 0,
            time: 0.0,
            timings: StageTimings::default(),
        };
        s.initialise(init);
        s
    }

    /// Sets every fluid node to the equilibrium of `init(x)`.
    pub fn initialise(&mut self, init: impl Fn([f64; 3]) -> Macro + Sync) {
        let nv = self.eq.values_per_node();
        let grid = &self.layout.grid;
        let kind = &self.layout.kind;
        let eq = &self.eq;
        self.f.par_chunks_mut(nv).enumerate().for_each(|(node, f)| {
            if kind[node] != NodeKind::Fluid {
                return;
            }
            let x = grid.coords(node);
            let m = init([x[0] as f64, x[1] as f64, x[2] as f64]);
            let mut w = vec![0.0; eq.set.shells.len()];
            eq.feq_into(&m, &mut w, f);
        });
        self.f1.copy_from_slice(&self.f);
    }

    /// Overwrites the populations of one fluid node (used by tests that start off equilibrium).
    pub fn node_populations_mut(&mut self, node: usize) -> &mut [f64] {
        let nv = self.eq.values_per_node();
        &mut self.f[node * nv..(node + 1) * nv]
    }

    /// Reduced-temperature window in which every equilibrium weight is positive.
    pub fn temperature_window(&self) -> (f64, f64) {
        self.window
    }

    /// One full step (every stage of [`FDLB_STEP`]).
    pub fn step(&mut self) -> Result<(), Instability> {
        for (k, stage) in FDLB_STEP.iter().enumerate() {
            let t0 = Instant::now();
            let r = self.run_stage(stage);
            self.timings.total[k] += t0.elapsed();
            r?;
        }
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

    /// Executes one stage of the list.
    pub fn run_stage(&mut self, stage: &Stage) -> Result<(), Instability> {
        match stage.kind {
            StageKind::Moments => {
                let src = match stage.rk {
                    RkStage::First => &self.f,
                    RkStage::Second => &self.f1,
                };
                let bad = moments_pass(&self.eq, &self.layout, src, &mut self.h, &mut self.mac, self.window, self.params);
                if let Some((node, quantity, value, reason)) = bad {
                    return Err(Instability {
                        step: self.step_count,
                        time: self.time,
                        node: self.layout.grid.coords(node),
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
                let mut fields = StageFields { f, h: &mut self.h, mac: &mut self.mac };
                fill_boundaries(&self.layout, &self.eq, &mut fields, self.params);
            }
            StageKind::AdvectCollide => {
                let ctx = RhsContext {
                    eq: &self.eq,
                    layout: &self.layout,
                    stencil: &self.stencil,
                    params: self.params,
                    g: self.body_force,
                };
                match stage.rk {
                    RkStage::First => ctx.update(&self.f, &self.h, &self.mac, &mut self.f1, RkStage::First),
                    RkStage::Second => ctx.update(&self.f1, &self.h, &self.mac, &mut self.f, RkStage::Second),
                }
            }
        }
        Ok(())
    }

    /// Macroscopic state of a padded node of fⁿ.
    pub fn macro_at(&self, node: usize) -> Macro {
        let nv = self.eq.values_per_node();
        self.eq.moments(&self.f[node * nv..(node + 1) * nv])
    }

    /// Macroscopic state at interior node coordinates.
    pub fn macro_at_coords(&self, x: [i64; 3]) -> Macro {
        self.macro_at(self.layout.grid.index(x))
    }

    /// Macroscopic fields of every interior node, x fastest (solid nodes: `None`).
    pub fn interior_macros(&self) -> Vec<Option<Macro>> {
        let g = &self.layout.grid;
        let mut out = Vec::with_capacity(g.interior_len());
        for z in 0..g.n[2] as i64 {
            for y in 0..g.n[1] as i64 {
                for x in 0..g.n[0] as i64 {
                    let node = g.index([x, y, z]);
                    out.push((self.layout.kind[node] == NodeKind::Fluid).then(|| self.macro_at(node)));
                }
            }
        }
        out
    }

    /// Mass, momentum and total energy (Σ f c²/2 + Σ G) summed over fluid nodes.
    pub fn totals(&self) -> Totals {
        let nv = self.eq.values_per_node();
        let q = self.eq.q();
        let eq = &self.eq;
        let kind = &self.layout.kind;
        let (mass, mx, my, mz, energy) = self
            .f
            .par_chunks(nv)
            .enumerate()
            .filter(|(node, _)| kind[*node] == NodeKind::Fluid)
            .map(|(_, f)| {
                let mut t = (0.0, 0.0, 0.0, 0.0, 0.0);
                for i in 0..q {
                    let c = eq.cf[i];
                    t.0 += f[i];
                    t.1 += f[i] * c[0];
                    t.2 += f[i] * c[1];
                    t.3 += f[i] * c[2];
                    t.4 += f[i] * eq.half_c2[i];
                }
                for &g in &f[q..] {
                    t.4 += g;
                }
                t
            })
            .reduce(|| (0.0, 0.0, 0.0, 0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3, a.4 + b.4));
        Totals { mass, momentum: [mx, my, mz], energy }
    }

    /// Largest local Mach number |u|/c_s over fluid nodes.
    pub fn max_mach(&self) -> f64 {
        let nv = self.eq.values_per_node();
        let kind = &self.layout.kind;
        let eq = &self.eq;
        self.f
            .par_chunks(nv)
            .enumerate()
            .filter(|(node, _)| kind[*node] == NodeKind::Fluid)
            .map(|(_, f)| {
                let m = eq.moments(f);
                m.speed2().sqrt() / eq.sound_speed(m.theta)
            })
            .reduce(|| 0.0, f64::max)
    }

    /// Bytes read and written per fluid-node update of one full step by this implementation
    /// (f64, neighbours assumed served from cache): per RK stage the moments pass reads f and
    /// writes h and the 5 macro fields; the update reads h, f and the macro fields and writes f;
    /// stage 2 also reads fⁿ.
    pub fn bytes_per_node_update(&self) -> f64 {
        let nv = self.eq.values_per_node() as f64;
        let m = MACRO_FIELDS as f64;
        let stage = (nv + nv + m) + (nv + nv + m + nv);
        8.0 * (2.0 * stage + nv)
    }
}

/// Moments pass: writes the macro fields and the advected field h = (1 − A/τ) f + (A/τ) f⁰ of
/// every fluid node; returns the first node (lowest index) whose state is not admissible.
#[allow(clippy::type_complexity)]
fn moments_pass(eq: &Equilibrium, layout: &Layout, f: &[f64], h: &mut [f64], mac: &mut [f64], window: (f64, f64), p: StepParams) -> Option<(usize, &'static str, f64, String)> {
    let nv = eq.values_per_node();
    let row = layout.grid.padded[0];
    let kind = &layout.kind;
    let (k_f, k_eq) = (1.0 - p.a / p.tau, p.a / p.tau);
    h.par_chunks_mut(row * nv)
        .zip(mac.par_chunks_mut(row * MACRO_FIELDS))
        .enumerate()
        .with_min_len(rows_per_task(row * nv))
        .map(|(r, (h_row, mac_row))| {
            let mut w = vec![0.0; eq.set.shells.len()];
            let mut fe = vec![0.0; nv];
            let mut bad = None;
            for x in 0..row {
                let node = r * row + x;
                if kind[node] != NodeKind::Fluid {
                    continue;
                }
                let fn_ = &f[node * nv..(node + 1) * nv];
                let m = eq.moments(fn_);
                if bad.is_none() {
                    bad = check_state(&m, window).map(|(q, v, why)| (node, q, v, why));
                }
                let hn = &mut h_row[x * nv..(x + 1) * nv];
                if k_eq == 0.0 {
                    hn.copy_from_slice(fn_);
                } else {
                    eq.feq_into(&m, &mut w, &mut fe);
                    for v in 0..nv {
                        hn[v] = k_f * fn_[v] + k_eq * fe[v];
                    }
                }
                mac_row[x * MACRO_FIELDS..(x + 1) * MACRO_FIELDS].copy_from_slice(&[m.rho, m.u[0], m.u[1], m.u[2], m.theta]);
            }
            bad
        })
        .reduce(|| None, |a, b| match (a, b) {
            (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
            (a, b) => a.or(b),
        })
}

/// Rows per rayon task so that a task updates at least ~16k values (small grids would otherwise
/// drown in scheduling overhead).
fn rows_per_task(values_per_row: usize) -> usize {
    (16_384 / values_per_row.max(1)).max(1)
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

struct RhsContext<'a> {
    eq: &'a Equilibrium,
    layout: &'a Layout,
    stencil: &'a [VelocityStencil],
    params: StepParams,
    g: [f64; 3],
}

impl RhsContext<'_> {
    /// Runge–Kutta update of every fluid node: stage 1 writes `out = src + Δt L(src)`;
    /// stage 2 writes `out = ½ out + ½ (src + Δt L(src))` (`out` holds fⁿ).
    /// L = −c·∇h − (f − f⁰)/τ + F, with f⁰ recomputed from the node's macro fields.
    fn update(&self, src: &[f64], h: &[f64], mac: &[f64], out: &mut [f64], rk: RkStage) {
        let eq = self.eq;
        let nv = eq.values_per_node();
        let q = eq.q();
        let row = self.layout.grid.padded[0];
        let kind = &self.layout.kind;
        let StepParams { dt, tau, .. } = self.params;
        let inv_tau = 1.0 / tau;
        let has_force = self.g.iter().any(|g| *g != 0.0);
        let g = self.g;
        // Tap offsets in values (node offset × nv), flattened per velocity.
        let taps: Vec<Vec<(isize, f64)>> = self.stencil.iter().map(|s| s.taps.iter().map(|&(o, c)| (o * nv as isize, c)).collect()).collect();
        let centres: Vec<f64> = self.stencil.iter().map(|s| s.centre).collect();
        out.par_chunks_mut(row * nv).enumerate().with_min_len(rows_per_task(row * nv)).for_each(|(r, out_row)| {
            let mut w = vec![0.0; eq.set.shells.len()];
            let mut fe = vec![0.0; nv];
            for x in 0..row {
                let node = r * row + x;
                if kind[node] != NodeKind::Fluid {
                    continue;
                }
                let mm = &mac[node * MACRO_FIELDS..(node + 1) * MACRO_FIELDS];
                let m = Macro { rho: mm[0], u: [mm[1], mm[2], mm[3]], theta: mm[4] };
                eq.feq_into(&m, &mut w, &mut fe);
                let force = if has_force { (g[0] * m.u[0] + g[1] * m.u[1] + g[2] * m.u[2], 1.0 / m.theta) } else { (0.0, 0.0) };
                let o = &mut out_row[x * nv..(x + 1) * nv];
                let base = node * nv;
                for v in 0..nv {
                    let i = if v < q { v } else { v - q };
                    let centre = base + v;
                    let mut adv = centres[i] * h[centre];
                    for &(off, c) in &taps[i] {
                        adv += c * h[(centre as isize + off) as usize];
                    }
                    let fi = src[centre];
                    let ei = fe[v];
                    let mut l = -adv - (fi - ei) * inv_tau;
                    if has_force {
                        let cg = eq.cf[i];
                        l += ei * (g[0] * cg[0] + g[1] * cg[1] + g[2] * cg[2] - force.0) * force.1;
                    }
                    let new = fi + dt * l;
                    o[v] = match rk {
                        RkStage::First => new,
                        RkStage::Second => 0.5 * (o[v] + new),
                    };
                }
            }
        });
    }
}
