//! Integer lattice gas on the 4D face-centred hyper-cubic lattice (seed 002, DESIGN §2.5): the
//! second fluid backend. This module holds, so far, the velocity set and the collision that
//! conserves mass and 4-momentum exactly (a precomputed table of the 2²⁴ states grouped into
//! classes). Propagation, the interference operation, boundaries, scenes and the GPU twin are
//! the rest of issue 5.
//!
//! | module | what | seed 002 |
//! |---|---|---|
//! | [`velocities`] | the 24 FCHC velocities (permutations of (±1, ±1, 0, 0)) | §3.3 |
//! | [`collision`] | classes of equal mass and momentum; a seeded, counter-based choice in the class | §3.3 |

pub mod collision;
pub mod velocities;
