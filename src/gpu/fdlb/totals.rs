//! The fluid's totals (mass, momentum, energy) summed on the device: the `totals` kernel
//! ([`codegen::totals`]) leaves one partial sum per 1024 nodes, the CPU adds them in f64. A
//! reader of the totals alone (a coupled run's csv row) then brings back 20 bytes per 1024
//! nodes instead of the lattice.

use super::{GpuFluid, pipeline_of};
use crate::fluid::Totals;
use crate::gpu::codegen::{self, TOTALS_PER_THREAD, WORKGROUP};
use bytemuck::{Pod, Zeroable};

/// The uniform of the `totals` kernel (the WGSL `TotalsParams`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(super) struct TotalsParams {
    /// Node stride of the arrays (every node below it is summed if its kind is fluid).
    n_nodes: u32,
    /// Workgroups that sum nodes (those past it in a two-dimensional dispatch write nothing).
    groups: u32,
    _p0: u32,
    _p1: u32,
}

/// The kernel, its uniform, its partial sums and its bind groups (built at the first use).
pub(super) struct TotalsKernel {
    pipeline: wgpu::ComputePipeline,
    /// The uniform, written once; held with the bind groups that read it.
    _params: wgpu::Buffer,
    out: wgpu::Buffer,
    groups: u32,
    /// One per placement of fⁿ ([`GpuFluid::state_groups`]).
    bind: [wgpu::BindGroup; 2],
}

impl GpuFluid {
    /// Bytes one [`Self::totals`] brings back: 20 per workgroup of 1024 nodes.
    pub fn totals_bytes(&self) -> u64 {
        20 * (self.stride as u64).div_ceil((WORKGROUP * TOTALS_PER_THREAD) as u64).max(1)
    }

    /// Mass, momentum and energy of fⁿ over the fluid nodes (lattice units), as
    /// [`crate::fluid::FluidSolver::totals`] sums them, summed on the device in f32 per 1024
    /// nodes and over those partial sums in f64; `None` when the read fails. Against the CPU's
    /// f64 sum of the same f32 values the difference is f32 round-off of the partial sums: a few
    /// 10⁻⁷ of Σ|terms| (test `gpu_totals_match_the_cpu_sums`).
    pub fn totals(&mut self) -> Option<Totals> {
        if self.totals.is_none() {
            let pipeline = pipeline_of(&self.device, "totals", &codegen::totals(&self.eq, self.split), "main");
            let groups = (self.stride as u32).div_ceil(WORKGROUP * TOTALS_PER_THREAD).max(1);
            use wgpu::BufferUsages as U;
            let buffer =
                |label, size: u64, usage| self.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false });
            let params = buffer("totals params", size_of::<TotalsParams>() as u64, U::UNIFORM | U::COPY_DST);
            let p = TotalsParams { n_nodes: self.stride as u32, groups, _p0: 0, _p1: 0 };
            self.queue.write_buffer(&params, 0, bytemuck::bytes_of(&p));
            let out = buffer("totals partial sums", 20 * groups as u64, U::STORAGE | U::COPY_SRC);
            let bind = self.state_groups(&pipeline, &[(0, &params), (1, &self.kind), (2, &out)]);
            // two buffers and the two bind groups
            self.state_objects_made += 4;
            self.totals = Some(TotalsKernel { pipeline, _params: params, out, groups, bind });
        }
        let k = self.totals.as_ref().expect("built above");
        self.submit_on_state(&k.pipeline, &k.bind, k.groups * WORKGROUP);
        let raw = self.totals_readback.read(&self.device, &self.queue, &[&k.out])?.pop().expect("one buffer read");
        let partial: &[f32] = bytemuck::cast_slice(&raw);
        let mut t = [0.0f64; 5];
        for p in partial.chunks_exact(5) {
            t.iter_mut().zip(p).for_each(|(a, b)| *a += *b as f64);
        }
        Some(Totals { mass: t[0], momentum: [t[1], t[2], t[3]], energy: t[4] })
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::TotalsParams;
    use crate::fluid::{Equilibrium, GasModel, VelocitySet, VelocitySetKind};
    use crate::gpu::codegen::{Split, totals};
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    /// `TotalsParams` lays out as the generated WGSL struct (naga reflection).
    #[test]
    fn totals_params_match_the_shader_layout() {
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let src = totals(&eq, Split::whole(eq.values_per_node()));
        check_mirror("totals", &src, "TotalsParams", mirror!(TotalsParams { n_nodes, groups, _p0, _p1 }));
    }
}
