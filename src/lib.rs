//! # phonation
//!
//! Vocal-fold fluid–structure interaction: a compressible thermal finite-difference lattice
//! Boltzmann fluid (D2Q21 / D3Q39, seed 000 §2.3), with (in later milestones) an MPS
//! orthotropic viscoelastic solid, two coupling methods, a GPU backend and an integer lattice
//! gas. It ships as a headless simulator (`phonation` binary) and a Bevy plugin (feature `bevy`).
//!
//! | module | what |
//! |---|---|
//! | [`fluid`] | FDLB: velocity sets, equilibrium, boundaries, CPU reference solver |
//! | [`lattice_gas`] | FCHC integer lattice gas (second fluid backend, seed 002): collision classes, interference, bit-parallel propagation, channel and cylinder, coarse-graining, viscosity tables, scenes; GPU twin in [`gpu::lattice_gas`] |
//! | [`coupling`] | fluid–structure coupling: surfaces, tractions, prescribed motions, the weak coupling (method 1) |
//! | [`solid`] | MPS orthotropic viscoelastic solid: materials, particles, forces, contact, explicit and implicit steps |
//! | [`stages`] | the ordered stage list of one step (CPU, GPU, Bevy, timings) |
//! | [`units`] | physical (cgs / SI) ↔ lattice units, Mach scaling |
//! | [`scene`] | scene files (TOML), validation of user input, building a solver |
//! | [`output`] | probes CSV, PNG colour maps, VTK, summary JSON |
//! | [`validation`] | analytic references and validation cases (Taylor–Green, Sod, …) |
//! | [`bench`] | memory bandwidth and cells/s measurements |
//! | `plugin` | Bevy plugin (feature `bevy`, on by default) |

pub mod bench;
pub mod coupling;
pub mod engine;
pub mod fluid;
pub mod gpu;
pub mod lattice_gas;
pub mod output;
#[cfg(feature = "bevy")]
pub mod plugin;
pub mod run;
pub mod scene;
pub mod solid;
pub mod stages;
pub mod units;
pub mod validation;
