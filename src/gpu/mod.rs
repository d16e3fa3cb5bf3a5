//! GPU backend (wgpu compute, no Bevy needed): a headless device ([`context`]), kernels generated
//! from the velocity set ([`codegen`]) and the FDLB runner that records the stage list
//! ([`fdlb`]). Every kernel has a CPU twin in [`crate::fluid`]; `tests/gpu/` checks parity.

pub mod bench;
pub mod codegen;
pub mod context;
pub mod coupled;
pub mod coupling;
pub mod fdlb;
pub mod fold_surface;
pub(crate) mod growing;
pub mod lattice_gas;
pub mod lattice_gas_codegen;
pub mod level_set_queries;
pub mod marching_cubes;
pub mod scaling;
pub mod slice;
pub mod solid;
mod thin_wall;
pub mod tracers;
#[cfg(test)]
pub(crate) mod wgsl_check;

pub use context::{DeviceHealth, GpuContext, GpuError};
pub use fdlb::{GpuArray, GpuFluid};
