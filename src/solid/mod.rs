//! The vocal-fold tissue: an orthotropic viscoelastic solid discretised with MPS particles
//! (seed 000 §2.1–2.2).
//!
//! | module | what | seed |
//! |---|---|---|
//! | [`material`] | orthotropic stiffness, Kelvin–Voigt viscosity, positive-definiteness check | 2.1–2.15 |
//! | [`particles`] | particle state (x, v, quaternion, ω, m, V, I, layer, body, clamp), sampling | 2.39, 2.48 |
//! | [`grid`] | uniform search grid (O(N) neighbour and contact search) | §3.1.3 |
//! | [`bonds`] | neighbour lists with initial weights, n⁰, κ, renormalisation, stiffness split | 2.16–2.21 |
//! | [`forces`] | strain/stress and bond-force kernels (elastic, viscous, torques) | 2.14–2.15, 2.38–2.51 |
//! | [`rotation`] | quaternion update, Newton–Raphson rotations, implicit angular velocity | 2.53–2.56, 2.73–2.76 |
//! | [`contact`] | distinct-element contact between bodies and with walls | 2.22–2.37 |
//! | [`implicit`] | block-Jacobi preconditioned conjugate gradients | 2.63–2.66 |
//! | `linear` | the implicit system's operator A x, matrix-free at a configuration | 2.63–2.66 |
//! | [`patch_jacobi`] | patch block-Jacobi smoother (exact inverses of 3³-particle blocks of A) | 2.63–2.66 |
//! | [`coarse`] | the preconditioner's coarse-space correction (aggregates' affine motions, probed A_c) | 2.63–2.66 |
//! | [`coarse_sparse`] | a large body's A_c block-sparse, solved by inner CG with a third level | 2.63–2.66 |
//! | `dense` | dense Cholesky for the preconditioner's small matrices | — |
//! | [`timestep`] | explicit stability limit | — |
//! | [`solver`] | explicit and implicit steps driven by the solid stage lists | 2.44–2.66 |

pub mod bench;
pub mod bonds;
pub mod coarse;
pub mod coarse_sparse;
pub mod contact;
mod dense;
pub mod fold;
pub mod forces;
mod forces_plane;
pub mod grid;
pub mod implicit;
mod linear;
pub mod material;
pub mod particles;
pub mod patch_jacobi;
pub mod rotation;
pub mod solver;
pub mod state;
pub mod timestep;

pub use contact::{ContactParams, Wall};
pub use material::Orthotropic;
pub use particles::Particles;
pub use solver::{Energies, Integrator, Preconditioner, SolidOptions, SolidSolver};
