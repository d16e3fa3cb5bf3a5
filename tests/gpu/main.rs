//! GPU backend (wgpu; lavapipe in CI) against the CPU reference: every kernel of the stage list
//! after one stage, and whole steps. f32 on the GPU against f64 on the CPU: tolerances are
//! relative to each population's largest magnitude.
//!
//! Without an adapter these tests fail in CI (CI=true) and are skipped loudly elsewhere.
//!
//! One test binary (each links the GPU stack once), a module per part of the core: `fluid`,
//! `solid`, `lattice_gas`, `coupling` (its kernels), `coupled_steps` (whole coupled steps),
//! `drawing` (what the plugin draws) and `runs` (the run layer on the GPU backend), with what
//! they share in `support`.

#[path = "../common/mod.rs"]
mod common;

mod coupled_steps;
mod coupling;
mod drawing;
mod fluid;
mod lattice_gas;
mod runs;
mod solid;
mod support;
