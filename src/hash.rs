//! Counter-based random numbers shared by the CPU and the GPU (the same integer operations in
//! `shaders/hash.wgsl`): the lattice gas's random streams and the tracers' rebirths.

/// 32-bit integer hash (C. Wellons' "lowbias32", 2018).
pub const fn mix32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The WGSL twin of [`mix32`], prepended to the shaders that use it.
pub const WGSL: &str = include_str!("../shaders/hash.wgsl");
