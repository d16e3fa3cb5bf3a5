//! The implicit step's solve on the device: preconditioned CG (the kernels `cg_*` of
//! shaders/solid_implicit.wgsl) with block Jacobi or the patch smoother of
//! [`crate::solid::patch_jacobi`], plus the CPU's coarse-space correction
//! ([`crate::solid::coarse`], kernels `coarse_*`, A_c⁻¹ applied as one dense product), and the
//! preconditioner's arrays in the device's layout.

use super::bindings::{Buf, Kernel};
use super::{GpuSolid, v4};
use crate::solid::Preconditioner;
use crate::solid::coarse::CoarseSpace;
use glam::DVec3;

/// The patch smoother's arrays as the device reads them (`patch_index` and `patch_inverse` in
/// shaders/solid_implicit.wgsl): [Q, the Q + 1 member offsets, the Q + 1 inverse offsets, the members].
pub(super) struct PatchArrays<'a> {
    pub index: Vec<u32>,
    /// The solver's own packed inverses (≈ 490 B per particle in 3D: not copied).
    pub inverse: &'a [f32],
}

impl Default for PatchArrays<'_> {
    /// No patches (block Jacobi): Q = 0 and its two offsets, so that the coarse space's arrays
    /// that follow are found the same way.
    fn default() -> Self {
        Self { index: vec![0, 0, 0], inverse: &[] }
    }
}

impl PatchArrays<'_> {
    pub fn patches(&self) -> u32 {
        self.index.first().copied().unwrap_or(0)
    }
}

/// The most coarse unknowns the device takes: A_c⁻¹ is dense on the device (m² f32, 144 MB
/// at this bound) and computed on the host once (≈ m³ flops).
pub const COARSE_MAX_UNKNOWNS: usize = 6000;

/// The coarse space as the device reads it, appended to the patches' arrays (CPU twin:
/// [`CoarseSpace::add_correction`]). `index` (after the patches' part) = [A aggregates, m
/// unknowns, dimension, modes, the A + 1 unknown offsets, the A + 1 member offsets, the
/// aggregate of each of the n particles (`u32::MAX` clamped), the free particles aggregate by
/// aggregate]; `values` (after the patches' inverses) = [(x − centre)/side of each particle
/// (3 n, zero where clamped), 12 × 12 mode coefficients per aggregate (row e: basis vector e,
/// rows past the aggregate's count zero), A_c⁻¹ (m × m, symmetric)].
pub(super) struct CoarseArrays {
    pub index: Vec<u32>,
    pub values: Vec<f32>,
    pub aggregates: u32,
    pub unknowns: u32,
}

/// The coarse space in the device's layout for particles at `reference`, or why not: more than
/// [`COARSE_MAX_UNKNOWNS`] unknowns, values beyond the binding size `limit` once `patch_bytes`
/// of patch inverses precede them, an A_c that does not factorise.
pub(super) fn device_coarse(c: &CoarseSpace, reference: &[DVec3], patch_bytes: u64, limit: u64) -> Result<CoarseArrays, String> {
    let (m, offsets, of) = (c.unknowns(), c.offsets(), c.aggregate_of());
    let a = offsets.len() - 1;
    let n = reference.len();
    if m > COARSE_MAX_UNKNOWNS {
        return Err(format!("{m} coarse unknowns (the device takes {COARSE_MAX_UNKNOWNS}): the smoother alone on the GPU"));
    }
    let bytes = patch_bytes + 4 * (3 * n + 144 * a + m * m) as u64;
    if bytes > limit {
        return Err(format!(
            "the preconditioner's values take {bytes} B with the coarse space, beyond max_storage_buffer_binding_size = {limit} B: the smoother alone on the GPU"
        ));
    }
    let inverse = c.dense_inverse().ok_or("A_c does not factorise in the dense form: the smoother alone on the GPU")?;
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); a];
    for (i, &j) in of.iter().enumerate() {
        if j != u32::MAX {
            members[j as usize].push(i as u32);
        }
    }
    let mut index = vec![a as u32, m as u32, if c.modes() == 6 { 2 } else { 3 }, c.modes() as u32];
    index.extend(offsets.iter().map(|&o| o as u32));
    let mut start = 0u32;
    index.push(0);
    for list in &members {
        start += list.len() as u32;
        index.push(start);
    }
    index.extend(of);
    index.extend(members.iter().flatten());
    let mut values = Vec::with_capacity(3 * n + 144 * a + m * m);
    for (i, x) in reference.iter().enumerate() {
        let rel = match of[i] {
            u32::MAX => DVec3::ZERO,
            j => (*x - c.basis_of(j as usize).0) / c.side,
        };
        values.extend([rel.x as f32, rel.y as f32, rel.z as f32]);
    }
    for j in 0..a {
        let basis = c.basis_of(j).1;
        for e in 0..12 {
            values.extend((0..12).map(|k| basis.get(e).map_or(0.0, |b| b[k] as f32)));
        }
    }
    values.extend(inverse.iter().map(|&x| x as f32));
    Ok(CoarseArrays { index, values, aggregates: a as u32, unknowns: m as u32 })
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

    /// z + P A_c⁻¹ Pᵀ r by the device's coarse-space kernels (`coarse_restrict`,
    /// `coarse_solve`, `coarse_prolong`): the twin of
    /// [`crate::solid::coarse::CoarseSpace::add_correction`], for parity tests. `None` when the
    /// device has no coarse space. Overwrites the CG vectors.
    pub fn add_coarse_correction(&mut self, r: &[DVec3], z: &[DVec3]) -> Option<Vec<DVec3>> {
        if self.coarse_unknowns == 0 {
            return None;
        }
        let n = self.n;
        let mut vecs = vec![[0f32; 4]; 7 * n];
        for i in 0..n {
            vecs[n + i] = v4(r[i], 0.0);
            vecs[2 * n + i] = v4(z[i], 0.0);
        }
        self.queue.write_buffer(&self.buffers[Buf::Cg], 0, bytemuck::cast_slice(&vecs));
        self.submit(&Self::COARSE);
        let all = self.read_f32(Buf::Cg);
        Some((0..n).map(|i| DVec3::new(all[4 * (2 * n + i)] as f64, all[4 * (2 * n + i) + 1] as f64, all[4 * (2 * n + i) + 2] as f64)).collect())
    }

    /// The coarse-space correction z += P A_c⁻¹ Pᵀ r: g = Pᵀ r, u = A_c⁻¹ g, z += P u.
    const COARSE: [Kernel; 3] = [Kernel::CoarseRestrict, Kernel::CoarseSolve, Kernel::CoarseProlong];

    /// The implicit step's solve A ΔV = B (seed (2.63)–(2.66)): B, then CG preconditioned by
    /// block Jacobi or the patches, plus the coarse space where the device holds it,
    /// `check_every` iterations per submission, the residual read back after each.
    pub(super) fn conjugate_gradient(&mut self) {
        let patches = self.preconditioner == Preconditioner::Patches;
        let coarse = self.coarse_unknowns > 0;
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
            }
            if coarse {
                for e in Self::COARSE {
                    self.dispatch(&mut pass, e);
                }
            }
            if patches || coarse {
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
                    if coarse {
                        for e in Self::COARSE {
                            self.dispatch(&mut pass, e);
                        }
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

    /// The coarse space in the device's layout: the header [A, m, dimension, modes], the
    /// unknown offsets, the members' offsets, each particle's aggregate and the members, the
    /// same as the CPU's; the scaled positions, the coefficient rows (zero past an aggregate's
    /// basis) and A_c⁻¹ in the values; and a binding one byte too small refused, saying why.
    #[test]
    fn the_coarse_space_goes_to_the_device_in_its_layout_or_says_why_not() {
        let mut s = crate::solid::bench::benchmark_block(8, Integrator::Implicit);
        s.prepare_preconditioner();
        let c = s.coarse_space().expect("a coarse space");
        let x = &s.particles.reference;
        let n = x.len();
        let d = device_coarse(c, x, 0, u64::MAX).expect("fits");
        let (a, m) = (d.aggregates as usize, d.unknowns as usize);
        assert_eq!((a + 1, m), (c.offsets().len(), c.unknowns()));
        assert_eq!(&d.index[..4], &[a as u32, m as u32, 3, 12]);
        assert!(c.offsets().iter().zip(&d.index[4..5 + a]).all(|(o, i)| *o as u32 == *i));
        let starts = &d.index[5 + a..6 + 2 * a];
        let of = &d.index[6 + 2 * a..6 + 2 * a + n];
        let members = &d.index[6 + 2 * a + n..];
        assert_eq!(of, c.aggregate_of());
        assert_eq!(members.len(), starts[a] as usize);
        assert_eq!(members.len(), of.iter().filter(|&&j| j != u32::MAX).count());
        assert!(of.contains(&u32::MAX), "the clamped face is in no aggregate");
        for j in 0..a {
            let (centre, basis) = c.basis_of(j);
            for &i in &members[starts[j] as usize..starts[j + 1] as usize] {
                assert_eq!(of[i as usize] as usize, j);
                let rel = (x[i as usize] - centre) / c.side;
                assert!((0..3).all(|k| (d.values[3 * i as usize + k] as f64 - rel[k]).abs() < 1e-6));
            }
            let rows = &d.values[3 * n + 144 * j..3 * n + 144 * (j + 1)];
            for e in 0..12 {
                let want = |k: usize| basis.get(e).map_or(0.0, |b| b[k] as f32);
                assert!((0..12).all(|k| rows[12 * e + k] == want(k)), "aggregate {j} row {e}");
            }
        }
        let inverse = c.dense_inverse().unwrap();
        let tail = &d.values[3 * n + 144 * a..];
        assert_eq!(tail.len(), m * m);
        assert!(tail.iter().zip(&inverse).all(|(f, e)| *f == *e as f32));
        let bytes = 4 * d.values.len() as u64;
        let why = device_coarse(c, x, 0, bytes - 1).err().expect("one byte short");
        assert!(why.contains("max_storage_buffer_binding_size") && why.contains("smoother alone"), "{why}");
        assert!(device_coarse(c, x, 0, bytes).is_ok());
    }
}
