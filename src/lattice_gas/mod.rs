//! Integer lattice gas on the 4D face-centred hyper-cubic lattice (seed 002, DESIGN §2.5): the
//! second fluid backend. So far (CPU, periodic boxes): the velocity set, the collision that
//! conserves mass and 4-momentum exactly (a precomputed table of the 2²⁴ states grouped into
//! classes), the interference operation, propagation by bit operations, and the shear-wave
//! viscosity measurement. Still to come (issue 5): 64-bit packing of four cells per word,
//! inlet/outlet/obstacle boundaries, coarse-graining and the cylinder-wake scene, the GPU twin
//! with bit-exact parity, the viscosity table/plot over density and p, and the benchmark.
//!
//! | module | what | seed 002 |
//! |---|---|---|
//! | [`velocities`] | the 24 FCHC velocities (permutations of (±1, ±1, 0, 0)) | §3.3 |
//! | [`collision`] | classes of equal mass and momentum; a seeded, counter-based choice in the class | §3.3 |
//! | [`viscosity`] | kinematic viscosity from the decay of a shear wave | (issue 5) |
//! | [`lattice`] | bit storage (16 sites of a cell per word), collision pass, interference, propagation | §3.1–3.4 |

pub mod collision;
pub mod lattice;
pub mod velocities;
pub mod viscosity;
