//! One step interface for every solver — the fluid (FDLB), the solid (MPS), the lattice gas
//! and the coupled fluid–structure solver, on either backend: the same step counter
//! ([`Solver::step_count`], `u64`), the same failure ([`Instability`]) and the same per-stage
//! timings, so that the run loop ([`crate::run::driver`]), the Bevy plugin and the benchmarks
//! treat them alike. Lives below the physics core (like [`crate::stages`] and
//! [`crate::error`]) so that each solver implements it without importing anything above it.

use std::fmt;

/// Which part of a simulation went wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    Fluid,
    Solid,
    /// The coupling between them (a body that moved too far in one step).
    Coupling,
    /// The GPU the solver ran on (lost, out of memory, or a command rejected).
    Device,
}

impl Part {
    /// What happened to it: a solver goes unstable, a device fails.
    pub fn verb(&self) -> &'static str {
        match self {
            Part::Device => "failed",
            _ => "unstable",
        }
    }
}

impl fmt::Display for Part {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Part::Fluid => "fluid",
            Part::Solid => "solid",
            Part::Coupling => "coupling",
            Part::Device => "device",
        })
    }
}

/// Where it went wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Site {
    /// A lattice node (interior node coordinates).
    Node([i64; 3]),
    /// A particle of the solid (its index).
    Particle(usize),
    /// A body of the solid (its body index).
    Body(u16),
    /// The whole state (a failure of the device, not of one place).
    Everywhere,
}

impl fmt::Display for Site {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Site::Node(x) => write!(f, "node {x:?}"),
            Site::Particle(i) => write!(f, "particle {i}"),
            Site::Body(b) => write!(f, "body {b}"),
            Site::Everywhere => f.write_str("the whole state"),
        }
    }
}

/// Why a solver stopped: which part, where, when, and which quantity left its admissible range.
/// Every solver reports this one type.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{part} {} at step {step} (t = {time:.6} {time_unit}), {site}: {quantity} = {value:e} ({reason})", .part.verb())]
pub struct Instability {
    pub part: Part,
    pub step: u64,
    /// Simulated time, in `time_unit`.
    pub time: f64,
    /// "lattice units" (the fluid) or "s" (the solid and the coupled solver).
    pub time_unit: &'static str,
    pub site: Site,
    pub quantity: &'static str,
    /// The offending value (NaN where it is not known, e.g. on the GPU).
    pub value: f64,
    pub reason: String,
}

impl Instability {
    /// The node coordinates, for a fluid instability.
    pub fn node(&self) -> Option<[i64; 3]> {
        match self.site {
            Site::Node(x) => Some(x),
            _ => None,
        }
    }
}

/// A solver advanced step by step.
pub trait Solver {
    /// Advances one step; stops with the diagnosis when the state leaves its admissible range
    /// (the state is then that of the failed step, not to be trusted).
    fn step(&mut self) -> Result<(), Instability>;

    /// Steps taken since the solver was built.
    fn step_count(&self) -> u64;

    /// Advances `n` steps, stopping at the first instability. Backends that work in batches
    /// (the GPU) override it.
    fn advance(&mut self, n: u64) -> Result<(), Instability> {
        for _ in 0..n {
            self.step()?;
        }
        Ok(())
    }

    /// Each stage's share of the wall time of the steps so far, by the stage names of
    /// [`crate::stages`] (empty where the backend does not time its stages).
    fn stage_shares(&self) -> Vec<(&'static str, f64)>;
}
