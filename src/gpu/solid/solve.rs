//! The implicit step's solve on the device: preconditioned CG (the kernels `cg_*` of
//! shaders/solid_implicit.wgsl) with block Jacobi or the patch smoother of
//! [`crate::solid::patch_jacobi`] (without the CPU's coarse space), and the patches' arrays in
//! the device's layout.

use super::bindings::{Buf, Kernel};
use super::{GpuSolid, v4};
use crate::solid::Preconditioner;
use glam::DVec3;

/// The patch smoother's arrays as the device reads them (`patch_index` and `patch_inverse` in
/// shaders/solid_implicit.wgsl): [Q, the Q + 1 member offsets, the Q + 1 inverse offsets, the members].
#[derive(Default)]
pub(super) struct PatchArrays<'a> {
    pub index: Vec<u32>,
    /// The solver's own packed inverses (≈ 490 B per particle in 3D: not copied).
    pub inverse: &'a [f32],
}

impl PatchArrays<'_> {
    pub fn patches(&self) -> u32 {
        self.index.first().copied().unwrap_or(0)
    }
}

/// The most particles of one patch the device's smoother takes (its workgroup holds r_P:
/// `PATCH_UNKNOWNS` = 3 × this in shaders/solid_implicit.wgsl).
pub const PATCH_MAX_PARTICLES: usize = 64;

/// The patches in the device's layout, or why they cannot go there (a patch larger than
/// [`PATCH_MAX_PARTICLES`], an inverse beyond the binding size `limit`).
pub(super) fn device_patches(pj: &crate::solid::patch_jacobi::PatchJacobi, limit: u64) -> Result<PatchArrays<'_>, String> {
    let (members, start, inverse, inverse_start) = pj.flat();
    let largest = pj.largest_patch();
    if largest > PATCH_MAX_PARTICLES {
        return Err(format!("a patch of {largest} particles (the device's smoother takes {PATCH_MAX_PARTICLES}): block Jacobi on the GPU"));
    }
    let bytes = 4 * inverse.len() as u64;
    if bytes > limit || inverse.len() > u32::MAX as usize {
        return Err(format!("the patches' inverses take {bytes} B, beyond max_storage_buffer_binding_size = {limit} B: block Jacobi on the GPU"));
    }
    let mut index = Vec::with_capacity(1 + start.len() + inverse_start.len() + members.len());
    index.push((start.len() - 1) as u32);
    index.extend(start.iter().chain(inverse_start).map(|&x| x as u32));
    index.extend(members);
    Ok(PatchArrays { index, inverse })
}

impl GpuSolid {
    /// z = blockdiag(A_PP⁻¹) r by the device's patch smoother alone (`cg_patches`; z = 0 at
    /// clamped particles): the twin of [`crate::solid::patch_jacobi::PatchJacobi::apply`], for
    /// parity tests. `None` when the device uses block Jacobi. Overwrites the CG vectors.
    pub fn apply_patches(&mut self, r: &[DVec3]) -> Option<Vec<DVec3>> {
        if self.preconditioner != Preconditioner::Patches {
            return None;
        }
        let n = self.n;
        let mut vecs = vec![[0f32; 4]; 7 * n];
        for (i, ri) in r.iter().enumerate() {
            vecs[n + i] = v4(*ri, 0.0);
        }
        self.queue.write_buffer(&self.buffers[Buf::Cg], 0, bytemuck::cast_slice(&vecs));
        self.submit(&[Kernel::CgPatches]);
        let all = self.read_f32(Buf::Cg);
        Some((0..n).map(|i| DVec3::new(all[4 * (2 * n + i)] as f64, all[4 * (2 * n + i) + 1] as f64, all[4 * (2 * n + i) + 2] as f64)).collect())
    }

    /// The implicit step's solve A ΔV = B (seed (2.63)–(2.66)): B, then CG preconditioned by
    /// block Jacobi or the patches, `check_every` iterations per submission, the residual read
    /// back after each.
    pub(super) fn conjugate_gradient(&mut self) {
        let patches = self.preconditioner == Preconditioner::Patches;
        // internal force of the state → cg[6n..7n); K v → force; then B, r, z, p
        let mut enc = self.device.create_command_encoder(&Default::default());
        let bytes = self.buffers[Buf::Force].size();
        enc.copy_buffer_to_buffer(&self.buffers[Buf::Force], 0, &self.buffers[Buf::Cg], 6 * bytes, bytes);
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            self.dispatch(&mut pass, Kernel::PrepareKv);
            for e in Self::LINEAR {
                self.dispatch(&mut pass, e);
            }
            self.dispatch(&mut pass, Kernel::CgRhs);
            if patches {
                self.dispatch(&mut pass, Kernel::CgPatches);
                self.dispatch(&mut pass, Kernel::CgFirstDirection);
            }
        }
        self.queue.submit([enc.finish()]);
        let mut it = 0;
        let mut rel = f64::INFINITY;
        let check_every = 8;
        while it < self.cg_max_iterations {
            let mut enc = self.device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                for _ in 0..check_every {
                    for e in Self::LINEAR {
                        self.dispatch(&mut pass, e);
                    }
                    for e in [Kernel::CgApply, Kernel::CgDots, Kernel::CgSum, Kernel::CgKeep] {
                        self.dispatch(&mut pass, e);
                    }
                    if patches {
                        // x, r; then z by the patches (block Jacobi's z would be overwritten)
                        self.dispatch(&mut pass, Kernel::CgUpdateResidual);
                        self.dispatch(&mut pass, Kernel::CgPatches);
                    } else {
                        self.dispatch(&mut pass, Kernel::CgUpdate);
                    }
                    for e in [Kernel::CgDots, Kernel::CgSum, Kernel::CgDirection] {
                        self.dispatch(&mut pass, e);
                    }
                }
            }
            self.queue.submit([enc.finish()]);
            it += check_every;
            let sc = self.read_f32(Buf::Scalars);
            rel = (sc[2] as f64).max(0.0).sqrt() / (sc[3] as f64).sqrt().max(1e-300);
            if sc[3] == 0.0 {
                rel = 0.0;
            }
            if rel <= self.cg_tolerance || !rel.is_finite() {
                break;
            }
        }
        self.last_cg = (it, rel);
        self.cg_tally.add(it, rel, rel <= self.cg_tolerance);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solid::Integrator;
    use crate::solid::patch_jacobi::PatchJacobi;

    /// The device's layout of the patches: [Q, Q + 1 member offsets, Q + 1 inverse offsets, the
    /// members], the same patches as the CPU's; and the two fallbacks to block Jacobi, each
    /// saying why: a patch above [`PATCH_MAX_PARTICLES`] (5³ = 125 particles), inverses beyond
    /// the binding size.
    #[test]
    fn the_patches_go_to_the_device_in_its_layout_or_say_why_not() {
        let s = crate::solid::bench::benchmark_block(8, Integrator::Implicit);
        let pj = PatchJacobi::new(&s.disc, &s.particles, s.dt);
        let a = device_patches(&pj, u64::MAX).expect("27-particle patches fit");
        let q = pj.patches();
        assert_eq!(a.patches() as usize, q);
        let (members, start, inverse, inverse_start) = pj.flat();
        assert_eq!(a.index.len(), 1 + 2 * (q + 1) + members.len());
        for k in 0..=q {
            assert_eq!(a.index[1 + k] as usize, start[k]);
            assert_eq!(a.index[2 + q + k] as usize, inverse_start[k]);
        }
        assert_eq!(&a.index[3 + 2 * q..], members);
        assert_eq!(a.inverse, inverse);
        let too_small = device_patches(&pj, 4 * inverse.len() as u64 - 1).err().expect("one byte short");
        assert!(too_small.contains("max_storage_buffer_binding_size"), "{too_small}");
        let big = PatchJacobi::with_patch_side(&s.disc, &s.particles, s.dt, 5.0 * s.particles.spacing);
        assert!(big.largest_patch() > PATCH_MAX_PARTICLES);
        let why = device_patches(&big, u64::MAX).err().expect("a 5³ patch is refused");
        assert!(why.contains("block Jacobi"), "{why}");
    }
}
