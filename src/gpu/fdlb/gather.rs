//! The populations of a few nodes across the bus, either way: the `gather` kernel
//! ([`codegen::gather_populations`]) packs them node after node on the device, and only they
//! come back; the `scatter` kernel ([`codegen::scatter_populations`]) writes packed values
//! into their nodes, and only they go up: a moving body's change of layout reads the nodes that
//! change side and their neighbours and writes the fresh nodes ([`crate::fluid::LayoutChange`]),
//! a probe or glottal sample reads a few nodes. (Method 1's traction read its sampled nodes this
//! way until it ran on the device, [`super::GpuFluid::surface_traction`].)

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

/// A node-list kernel (gather or scatter) with buffers for up to `capacity` nodes (at least
/// [`NODE_LIST_ROOM`], grown by powers of two) and its bind groups, made with them.
pub(super) struct NodeListKernel {
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    nodes: wgpu::Buffer,
    /// The packed populations (`vals[k · nv + v]`).
    values: wgpu::Buffer,
    capacity: usize,
    /// One per placement of fⁿ ([`GpuFluid::state_groups`]).
    groups: [wgpu::BindGroup; 2],
}

/// Nodes the node-list kernels have room for when they are first made: a moving body's change
/// of layout reads tens to hundreds of nodes on the steps where nodes change side, so that their
/// buffers are made once and not again as the changes vary (4 KiB of node indices and 4·nv KiB
/// of populations, nv values per node).
pub(super) const NODE_LIST_ROOM: usize = 1024;

/// Which way a node-list kernel moves populations.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Way {
    Gather,
    Scatter,
}

impl GpuFluid {
    /// Makes the `way` kernel (built at its first use) ready for `nodes`: room for them, their
    /// list and the uniform written.
    fn prepare_node_list(&mut self, way: Way, nodes: &[usize]) {
        let (count, nv) = (nodes.len(), self.nv);
        let slot = match way {
            Way::Gather => &mut self.gather,
            Way::Scatter => &mut self.scatter,
        };
        if slot.as_ref().is_none_or(|g| g.capacity < count) {
            let old = slot.take();
            let capacity = count.next_power_of_two().max(NODE_LIST_ROOM);
            let pipeline = match old {
                Some(g) => g.pipeline,
                None => match way {
                    Way::Gather => pipeline_of(&self.device, "gather", &codegen::gather_populations(&self.eq, self.split), "main"),
                    Way::Scatter => pipeline_of(&self.device, "scatter", &codegen::scatter_populations(&self.eq, self.split), "main"),
                },
            };
            let buffer = |label, size: usize, usage| {
                self.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: size as u64, usage, mapped_at_creation: false })
            };
            use wgpu::BufferUsages as U;
            let values_usage = match way {
                Way::Gather => U::STORAGE | U::COPY_SRC,
                Way::Scatter => U::STORAGE | U::COPY_DST,
            };
            let params = buffer("node list params", size_of::<GatherParams>(), U::UNIFORM | U::COPY_DST);
            let list = buffer("node list", 4 * capacity, U::STORAGE | U::COPY_DST);
            let values = buffer("node list populations", 4 * nv * capacity, values_usage);
            let groups = self.state_groups(&pipeline, &[(0, &params), (1, &list), (2, &values)]);
            // three buffers and the two bind groups; the gather's reads get a staging buffer
            // with room for as many nodes (`node_readback` counts it)
            self.state_objects_made += 5;
            if way == Way::Gather {
                self.node_readback.reserve(&self.device, values.size());
            }
            let kernel = Some(NodeListKernel { pipeline, params, nodes: list, values, capacity, groups });
            match way {
                Way::Gather => self.gather = kernel,
                Way::Scatter => self.scatter = kernel,
            }
        }
        let g = match way {
            Way::Gather => self.gather.as_ref(),
            Way::Scatter => self.scatter.as_ref(),
        }
        .expect("built above");
        let words: Vec<u32> = nodes.iter().map(|&n| n as u32).collect();
        self.queue.write_buffer(&g.nodes, 0, bytemuck::cast_slice(&words));
        let params = GatherParams { count: count as u32, n_nodes: self.stride as u32, _p0: 0, _p1: 0 };
        self.queue.write_buffer(&g.params, 0, bytemuck::bytes_of(&params));
    }
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
        let nv = self.nv;
        self.prepare_node_list(Way::Gather, nodes);
        let g = self.gather.as_ref().expect("built by prepare_node_list");
        self.submit_on_state(&g.pipeline, &g.groups, nodes.len() as u32);
        // only the listed nodes' values (the buffer has room for more)
        let Some(raw) = self.node_readback.read_parts(&self.device, &self.queue, &[(&g.values, 0, 4 * (nodes.len() * nv) as u64)]) else { return false };
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

    /// Writes the populations fⁿ of `nodes` (padded indices) of `s`, a solver of the same
    /// scene, into the device's state (f64 → f32 as [`Self::upload_state`], which writes every
    /// node); the other nodes are left as they are.
    pub fn upload_nodes_from(&mut self, nodes: &[usize], s: &FluidSolver) {
        if nodes.is_empty() {
            return;
        }
        let nv = self.nv;
        let mut vals = vec![0f32; nodes.len() * nv];
        let mut node_vals = vec![0.0; nv];
        for (k, &node) in nodes.iter().enumerate() {
            s.pop.gather(&s.f, node, &mut node_vals);
            for (x, v) in vals[k * nv..(k + 1) * nv].iter_mut().zip(&node_vals) {
                *x = *v as f32;
            }
        }
        self.prepare_node_list(Way::Scatter, nodes);
        let k = self.scatter.as_ref().expect("built by prepare_node_list");
        self.queue.write_buffer(&k.values, 0, bytemuck::cast_slice(&vals));
        self.submit_on_state(&k.pipeline, &k.groups, nodes.len() as u32);
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
