//! Compressible thermal finite-difference lattice Boltzmann (FDLB) fluid, seed 000 §2.3:
//! velocity sets D2Q21 / D3Q39, the equilibrium (2.78) and moments (2.79–2.81), the diatomic
//! extension (2.96–2.104), 3rd-order upwind + RK2 time stepping of (2.77), boundaries, and the
//! CPU reference solver.

pub mod boundary;
pub mod boundary_fill;
mod bracket;
pub mod equilibrium;
pub mod fixtures;
pub mod geometry;
mod ghost_wall;
pub mod grid;
mod interpolation;
pub mod kernel_level_set;
pub mod layout;
mod layout_build;
pub mod level_set_queries;
mod memory_hints;
pub mod moving;
mod neighbours;
pub mod observe;
mod polygon;
mod rebuild;
mod row_kernels;
pub mod solver;
mod stage_passes;
pub mod state;
pub mod steady;
pub mod storage;
pub mod thin_wall;
pub mod timestep;
pub mod tracers;
pub mod upwind;
pub mod velocity_set;

pub use boundary::{Boundaries, Face, FaceCondition, InletProfile};
pub use equilibrium::{Equilibrium, GasModel, Macro};
pub use geometry::{KernelLevelSet, Obstacle, Polygon, Shape};
pub use grid::Grid;
pub use level_set_queries::{GhostQuery, GhostWall, LayoutPart, LevelSetQueries, OnThePool, wall_point};
pub use moving::{GeometryChange, LayoutChange, NodeChange};
pub use solver::{FluidSolver, Instability, Totals};
pub use steady::SelectiveFrequencyDamping;
pub use timestep::StepParams;
pub use velocity_set::{VelocitySet, VelocitySetKind};
