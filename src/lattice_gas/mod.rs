//! Integer lattice gas on the 4D face-centred hyper-cubic lattice (seed 002, DESIGN §2.5): the
//! second fluid backend. The velocity set, the collision that conserves mass and 4-momentum
//! exactly (a precomputed table of the 2²⁴ states grouped into classes), the interference
//! operation (meant by the seed to lower the viscosity: in the Boltzmann approximation it does,
//! by at most a few per cent ([`mean_field`]); in the simulation it first leaves ν unchanged and
//! then drives the velocity populations away from isotropy ([`isotropy`]), which raises the
//! shear-wave damping ([`viscosity`])), propagation by bit operations on u64 words (four cells
//! each), channel boundaries and a cylinder obstacle, coarse-graining into a velocity field, the
//! shear-wave viscosity measurement (scene files: `crate::scene::lattice_gas`), and the GPU twin (`crate::gpu::lattice_gas`).
//!
//! | module | what | seed 002 |
//! |---|---|---|
//! | [`velocities`] | the 24 FCHC velocities (permutations of (±1, ±1, 0, 0)) | §3.3 |
//! | [`collision`] | classes of equal mass and momentum; a seeded, counter-based choice in the class | §3.3 |
//! | [`bits`] | vertex bits of a cell, lane-wise flips, propagation moves, interference on a lane | §3.2–3.4 |
//! | [`lattice`] | the state: blocks of 24 u64 words (4 cells), obstacle cells, inlet, fill | §3.1–3.2, 3.5 |
//! | [`step`] | collide, interfere, propagate, boundaries — [`crate::stages::LATTICE_GAS_STEP`] | §3.3–3.5 |
//! | [`coarse`] | momentum coarse-grained over blocks of cells → velocity field (CSV, VTK, PNG) | §3.5 |
//! | [`viscosity`] | kinematic viscosity from the decay of a shear wave; tables over density and p | (issue 5) |
//! | [`mean_field`] | the interference in the Boltzmann approximation: transfer, viscosity shift −p K(d)/48 | §3.4 (issue 5) |
//! | [`isotropy`] | the gas at rest: equilibrium noise, velocity-family shares over time | §4 (2) (issue 5) |
//! | [`spectrum`] | dominant frequency of a probe signal (Strouhal number of the wake) | (issue 5) |
//! | [`bench`](mod@bench) | site updates per second, fraction of bandwidth, projected time of the seed's run | §3.5 |

pub mod bench;
pub mod bits;
pub mod coarse;
pub mod collision;
pub mod isotropy;
pub mod lattice;
pub mod mean_field;
pub mod spectrum;
pub mod state;
pub mod step;
pub mod velocities;
pub mod viscosity;
