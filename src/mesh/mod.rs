//! Surfaces for drawing and for ParaView: marching cubes on a scalar field
//! ([`marching_cubes`]), and the field of a body's particles ([`particle_field`]: the
//! coupling's level set, 2.124) that it is run on, so that the folds are seen as the wall the
//! air sees. Geometry only: no GPU, no Bevy (the GPU twin is [`crate::gpu::marching_cubes`]).

pub mod marching_cubes;
pub mod particle_field;

pub use marching_cubes::{ScalarGrid, TriangleMesh, extract};
