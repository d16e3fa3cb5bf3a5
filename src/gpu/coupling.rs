//! Method 2's coupling kernels on the GPU (shaders/coupling.wgsl, f32): the level set of a body's
//! particles with its gradient and wall velocity at query points (2.124–2.126, 2.130; CPU twin
//! [`KernelLevelSet::level`] and [`KernelLevelSet::velocity_at`]), and the hand-over of each wall
//! node's momentum to the particles within r_e with kernel weights normalised per node
//! (2.127–2.128; CPU twin: the `momentum_exchange` stage of `coupling::conserving`) as two
//! gathers — per node the weights' sum, per particle its shares — deterministic, no atomics.
//!
//! These kernels are checked against their twins (tests/gpu.rs). The face-flux record of the
//! fluid step (what each wall node takes out of the air, 2.122–2.123) is a kernel of the GPU
//! fluid ([`super::GpuFluid::record_face_fluxes`]). The coupled step that strings them together
//! is [`super::coupled::GpuCoupled`].

use super::context::{GpuContext, buffer_layout, compute_pipelines, read_buffer};
use crate::fluid::{Grid, KernelLevelSet};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, DVec4};
use wgpu::util::DeviceExt;

const SHADER: &str = include_str!("../../shaders/coupling.wgsl");

/// The kernels' uniform (`Params` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    lo: [f32; 4],
    hi: [f32; 4],
    bins: [u32; 4],
    padded: [u32; 4],
    halo: [u32; 4],
    re: f32,
    r_min: f32,
    phi: f32,
    factor: f32,
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// One kernel of shaders/coupling.wgsl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    LevelSetAt,
    ExchangeWeights,
    ExchangeGather,
}

impl Kernel {
    const ALL: [Kernel; 3] = [Kernel::LevelSetAt, Kernel::ExchangeWeights, Kernel::ExchangeGather];
    /// The WGSL entry point.
    fn entry(self) -> &'static str {
        match self {
            Kernel::LevelSetAt => "level_set_at",
            Kernel::ExchangeWeights => "exchange_weights",
            Kernel::ExchangeGather => "exchange_gather",
        }
    }
}

/// The compiled kernels (one pipeline layout, pipelines indexed by [`Kernel`]); buffers are
/// made per call.
pub struct CouplingKernels {
    pipelines: [wgpu::ComputePipeline; 3],
    layout: wgpu::BindGroupLayout,
}

fn v4(p: [f64; 3]) -> [f32; 4] {
    [p[0] as f32, p[1] as f32, p[2] as f32, 0.0]
}

impl CouplingKernels {
    pub fn new(ctx: &GpuContext) -> Self {
        let device = &ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("coupling"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        // uniform, then (read-only?) storage bindings 1–9
        let kinds = [
            (true, true),
            (false, true),
            (false, true),
            (false, true),
            (false, true),
            (false, true),
            (false, false),
            (false, true),
            (false, false),
            (false, false),
        ];
        let layout = buffer_layout(device, "coupling", &kinds);
        let pl =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("coupling"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let mut map = compute_pipelines(device, &module, &pl, &Kernel::ALL.map(Kernel::entry));
        let pipelines = Kernel::ALL.map(|k| map.remove(k.entry()).expect("one pipeline per entry point"));
        CouplingKernels { pipelines, layout }
    }

    fn params(set: &KernelLevelSet) -> Params {
        let (lo, hi, bins) = set.bin_box();
        Params {
            lo: v4(lo),
            hi: v4(hi),
            bins: [bins[0] as u32, bins[1] as u32, bins[2] as u32, set.points.len() as u32],
            re: set.re as f32,
            r_min: set.r_min as f32,
            phi: set.phi as f32,
            ..Default::default()
        }
    }

    /// Runs `entries` in order over `count` threads each, with the given buffers (None: a
    /// one-element placeholder), and reads back the buffers named in `read`.
    fn run(&self, ctx: &GpuContext, p: Params, data: [Option<&[u8]>; 9], kernels: &[(Kernel, u32)], read: &[usize]) -> Vec<Vec<u8>> {
        let device = &ctx.device;
        let mut buffers = vec![device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("coupling params"),
            contents: bytemuck::bytes_of(&p),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        })];
        for d in data {
            let placeholder = [0u8; 16];
            buffers.push(device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("coupling"),
                contents: d.filter(|d| !d.is_empty()).unwrap_or(&placeholder),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            }));
        }
        let entries_bg: Vec<wgpu::BindGroupEntry> =
            buffers.iter().enumerate().map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() }).collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("coupling"), layout: &self.layout, entries: &entries_bg });
        let mut enc = device.create_command_encoder(&Default::default());
        for &(kernel, count) in kernels {
            // each kernel's thread count goes in through its own uniform copy
            let mut q = p;
            q.count = count;
            let ub = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("coupling params"),
                contents: bytemuck::bytes_of(&q),
                usage: wgpu::BufferUsages::COPY_SRC,
            });
            enc.copy_buffer_to_buffer(&ub, 0, &buffers[0], 0, std::mem::size_of::<Params>() as u64);
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(kernel.entry()), timestamp_writes: None });
            pass.set_pipeline(&self.pipelines[kernel as usize]);
            pass.set_bind_group(0, &group, &[]);
            let w = count.div_ceil(64).max(1);
            if w <= 65_535 { pass.dispatch_workgroups(w, 1, 1) } else { pass.dispatch_workgroups(65_535, w.div_ceil(65_535), 1) }
        }
        ctx.queue.submit([enc.finish()]);
        read.iter().map(|&k| read_buffer(device, &ctx.queue, &buffers[k])).collect()
    }

    /// L, ∇L, the wall velocity and Σw at each of `queries` (lattice coordinates): the GPU twin of
    /// [`KernelLevelSet::level`] and [`KernelLevelSet::velocity_at`].
    pub fn level_set_at(&self, ctx: &GpuContext, set: &KernelLevelSet, queries: &[[f64; 3]]) -> Vec<(f64, DVec3, DVec3, f64)> {
        let (start, order) = set.bin_lists();
        let pts: Vec<[f32; 4]> = set.points.iter().map(|p| v4(*p)).collect();
        let vel: Vec<[f32; 4]> = set.velocities.iter().map(|p| v4(*p)).collect();
        let q: Vec<[f32; 4]> = queries.iter().map(|p| v4(*p)).collect();
        let out = vec![[0f32; 4]; 2 * queries.len()];
        let data = [
            Some(bytemuck::cast_slice(&pts)),
            Some(bytemuck::cast_slice(&vel)),
            Some(bytemuck::cast_slice(start)),
            Some(bytemuck::cast_slice(order)),
            Some(bytemuck::cast_slice(&q)),
            Some(bytemuck::cast_slice(&out)),
            None,
            None,
            None,
        ];
        let bytes = self.run(ctx, Self::params(set), data, &[(Kernel::LevelSetAt, queries.len() as u32)], &[6]);
        let o: &[[f32; 4]] = bytemuck::cast_slice(&bytes[0]);
        (0..queries.len())
            .map(|k| {
                let (a, b) = (o[2 * k], o[2 * k + 1]);
                (a[0] as f64, DVec3::new(a[1] as f64, a[2] as f64, a[3] as f64), DVec3::new(b[0] as f64, b[1] as f64, b[2] as f64), b[3] as f64)
            })
            .collect()
    }

    /// The force on each particle of `set` (its points in lattice coordinates) from the wall
    /// momentum `wall` of every node of `grid` (xyz momentum, w mass, lattice units), times
    /// `factor` (physical momentum per lattice unit over the step): the GPU twin of method 2's
    /// `momentum_exchange` stage.
    pub fn momentum_to_particles(&self, ctx: &GpuContext, set: &KernelLevelSet, grid: &Grid, wall: &[DVec4], factor: f64) -> Vec<DVec3> {
        assert_eq!(wall.len(), grid.len(), "one wall value per lattice node");
        let (start, order) = set.bin_lists();
        let pts: Vec<[f32; 4]> = set.points.iter().map(|p| v4(*p)).collect();
        let w: Vec<[f32; 4]> = wall.iter().map(|v| [v.x as f32, v.y as f32, v.z as f32, v.w as f32]).collect();
        let zeros = vec![[0f32; 4]; wall.len()];
        let force = vec![[0f32; 4]; pts.len()];
        let mut p = Self::params(set);
        p.padded = [grid.padded[0] as u32, grid.padded[1] as u32, grid.padded[2] as u32, 0];
        p.halo = [grid.halo[0] as u32, grid.halo[1] as u32, grid.halo[2] as u32, 0];
        p.factor = factor as f32;
        let data = [
            Some(bytemuck::cast_slice(&pts)),
            Some(bytemuck::cast_slice(&pts)),
            Some(bytemuck::cast_slice(start)),
            Some(bytemuck::cast_slice(order)),
            Some(bytemuck::cast_slice(&pts)),
            None,
            Some(bytemuck::cast_slice(&w)),
            Some(bytemuck::cast_slice(&zeros)),
            Some(bytemuck::cast_slice(&force)),
        ];
        let bytes = self.run(ctx, p, data, &[(Kernel::ExchangeWeights, wall.len() as u32), (Kernel::ExchangeGather, pts.len() as u32)], &[9]);
        let f: &[[f32; 4]] = bytemuck::cast_slice(&bytes[0]);
        f.iter().map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)).collect()
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror(
            "shaders/coupling.wgsl",
            super::SHADER,
            "Params",
            mirror!(Params { lo, hi, bins, padded, halo, re, r_min, phi, factor, count, _pad0, _pad1, _pad2 }),
        );
    }
}
