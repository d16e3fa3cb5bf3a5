//! Fluid–structure coupling (seed 000 §2.4): the only place where the FDLB air
//! ([`crate::fluid`]) and the MPS folds ([`crate::solid`]) meet.
//!
//! | module | what | seed |
//! |---|---|---|
//! | [`surface`] | surface particles and their polygon, surface points on the reference shape | §2.4.1 |
//! | [`traction`] | the air's traction on surface pieces, spread to the particles | 2.110–2.113 |
//! | [`motion`] | bodies with a prescribed rigid motion | — |
//! | [`weak`] | method 1: weak coupling, moving ghost-node walls, explicit solid sub-steps | §2.4.1 |
//! | [`glottis`] | glottal gap, area, flow through the narrowest section, margin displacements | §3.4.1 |
//! | [`level_set`] | method 2's geometry: level set from the particles, crossings, normals | 2.124–2.126 |
//! | [`momentum_exchange`] | the momentum the air hands to each wall node, link by link | 2.120–2.123 |
//! | [`conserving`] | method 2: level-set walls, momentum shared among the particles | §2.4.2 |
//! | [`added_mass`] | method 2: the air's added mass in the solid's update | 2.129 |
//! | [`solver`] | the coupled solver: fluid + solid + either method, stage by stage | §2.4 |

pub mod added_mass;
pub mod conserving;
pub mod glottis;
pub mod level_set;
pub mod momentum_exchange;
pub mod motion;
pub mod solver;
pub mod state;
pub mod surface;
pub mod traction;
pub mod traction_plan;
pub mod weak;

pub use conserving::ConservingOptions;
pub use motion::Motion;
pub use solver::{BodyMembers, CoupledBody, CoupledSolver, CouplingSetupError, Method, solid_substeps};
pub use surface::{BodySurface, ReferenceShape, SurfaceError};
pub use traction::{SurfaceForces, TractionModel, surface_forces};
pub use weak::WeakOptions;
