//! Bringing back the populations of a few nodes: the `gather` kernel
//! ([`codegen::gather_populations`]) packs them node after node on the device, and only they
//! cross the bus. Method 1's traction on the GPU reads the air at one and two cells from each
//! surface piece ([`crate::coupling::traction::sampled_nodes`]): a few hundred nodes of the
//! lattice's thousands.

use super::{GpuFluid, pipeline_of};
use crate::fluid::FluidSolver;
use crate::gpu::codegen;
use bytemuck::{Pod, Zeroable};

/// The uniform of the `gather` kernel (the WGSL `GatherParams`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(super) struct GatherParams {
    /// Nodes in the list.
    count: u32,
    /// Node stride of the population arrays.
    n_nodes: u32,
    _p0: u32,
    _p1: u32,
}

/// The kernel with buffers for up to `capacity` nodes (grown by powers of two).
pub(super) struct GatherKernel {
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    nodes: wgpu::Buffer,
    out: wgpu::Buffer,
    capacity: usize,
}

impl GpuFluid {
    /// Copies the populations fⁿ of `nodes` (padded indices) into the same nodes of `s`, a
    /// solver of the same scene (f32 → f64 as [`Self::download_into`], which copies every
    /// node), with the step count and time; the other nodes of `s` are left as they are. When
    /// the read fails `s` is left as it was and false comes back.
    pub fn download_nodes_into(&mut self, nodes: &[usize], s: &mut FluidSolver) -> bool {
        if nodes.is_empty() {
            s.step_count = self.step_count;
            s.time = self.step_count as f64 * s.params.dt;
            return true;
        }
        let (count, nv) = (nodes.len(), self.nv);
        if self.gather.as_ref().is_none_or(|g| g.capacity < count) {
            let capacity = count.next_power_of_two();
            let pipeline = match self.gather.take() {
                Some(g) => g.pipeline,
                None => pipeline_of(&self.device, "gather", &codegen::gather_populations(&self.eq, self.split), "main"),
            };
            let buffer = |label, size: usize, usage| {
                self.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: size as u64, usage, mapped_at_creation: false })
            };
            use wgpu::BufferUsages as U;
            self.gather = Some(GatherKernel {
                pipeline,
                params: buffer("gather params", size_of::<GatherParams>(), U::UNIFORM | U::COPY_DST),
                nodes: buffer("gather nodes", 4 * capacity, U::STORAGE | U::COPY_DST),
                out: buffer("gathered populations", 4 * nv * capacity, U::STORAGE | U::COPY_SRC),
                capacity,
            });
        }
        let g = self.gather.as_ref().expect("built above");
        let words: Vec<u32> = nodes.iter().map(|&n| n as u32).collect();
        self.queue.write_buffer(&g.nodes, 0, bytemuck::cast_slice(&words));
        let params = GatherParams { count: count as u32, n_nodes: self.stride as u32, _p0: 0, _p1: 0 };
        self.queue.write_buffer(&g.params, 0, bytemuck::bytes_of(&params));
        let bg = self.bind(&g.pipeline, &[(0, &g.params), (1, &g.nodes), (2, &g.out)], &[(10, &self.f[self.cur])]);
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            Self::dispatch(&mut pass, &g.pipeline, &bg, count as u32);
        }
        self.queue.submit([enc.finish()]);
        let Some(raw) = crate::gpu::context::try_read_buffer(&self.device, &self.queue, &g.out) else { return false };
        let vals: &[f32] = bytemuck::cast_slice(&raw);
        let mut node_vals = vec![0.0; nv];
        for (k, &node) in nodes.iter().enumerate() {
            for (x, v) in node_vals.iter_mut().zip(&vals[k * nv..(k + 1) * nv]) {
                *x = *v as f64;
            }
            s.pop.scatter(&mut s.f, node, &node_vals);
        }
        s.step_count = self.step_count;
        s.time = self.step_count as f64 * s.params.dt;
        true
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::GatherParams;
    use crate::fluid::{Equilibrium, GasModel, VelocitySet, VelocitySetKind};
    use crate::gpu::codegen::{Split, gather_populations};
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    /// `GatherParams` lays out as the generated WGSL struct (naga reflection).
    #[test]
    fn gather_params_match_the_shader_layout() {
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let src = gather_populations(&eq, Split::whole(eq.values_per_node()));
        check_mirror("gather", &src, "GatherParams", mirror!(GatherParams { count, n_nodes, _p0, _p1 }));
    }
}
