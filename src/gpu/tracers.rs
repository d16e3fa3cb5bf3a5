//! Passive tracers on the GPU (shaders/tracers.wgsl, f32): the twin of
//! [`crate::fluid::tracers::Tracers::advect`], reading the velocity straight from the GPU
//! fluid's macro buffer ([`crate::gpu::GpuFluid::macro_buffers`]): no copy of the field per
//! step. The tracers stay on the device (one vec4 each: position and generation) for drawing.

use super::context::{GpuContext, buffer_layout, compute_pipelines, read_buffer};
use crate::fluid::tracers::{Tracers, VelocityField};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use wgpu::util::DeviceExt;

/// shaders/tracers.wgsl with the hash it uses (shaders/hash.wgsl).
pub const SHADER: &str = concat!(include_str!("../../shaders/hash.wgsl"), include_str!("../../shaders/tracers.wgsl"));

/// (uniform?, read-only?) per binding of the shader, in binding order (checked against it by the
/// `Params` mirror test).
const LAYOUT: [(bool, bool); 5] = [(true, true), (false, true), (false, true), (false, false), (false, false)];

/// The kernel's uniform (`Params` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    n: [u32; 4],
    halo: [u32; 4],
    padded: [u32; 4],
    seed_lo: [f32; 4],
    seed_size: [f32; 4],
}

/// A velocity field in the GPU fluid's layout (macro buffer ρ, ux, uy, uz, θ per quantity with
/// stride N; node kinds, 0 = fluid), for running the tracers without a GPU fluid (tests).
pub struct FieldBuffers {
    pub mac: wgpu::Buffer,
    pub kind: wgpu::Buffer,
    pub stride: u32,
}

impl FieldBuffers {
    pub fn upload(ctx: &GpuContext, f: &VelocityField) -> Self {
        let n = f.grid.len();
        let stride = n.div_ceil(64) * 64;
        let mut mac = vec![0f32; 5 * stride];
        for k in 0..n {
            mac[k] = 1.0;
            for a in 0..3 {
                mac[(1 + a) * stride + k] = f.u[k][a];
            }
        }
        let kind: Vec<u32> = (0..stride).map(|k| if f.fluid.get(k).copied().unwrap_or(false) { 0 } else { 4 }).collect();
        let init = |label: &str, b: &[u8]| {
            ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: b, usage: wgpu::BufferUsages::STORAGE })
        };
        FieldBuffers {
            mac: init("tracer field mac", bytemuck::cast_slice(&mac)),
            kind: init("tracer field kind", bytemuck::cast_slice(&kind)),
            stride: stride as u32,
        }
    }
}

/// Tracers on the device and their kernel.
pub struct GpuTracers {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    params: Params,
    uniform: wgpu::Buffer,
    /// One vec4 per tracer: position (lattice coordinates) and generation (bits in w).
    pub tracers: wgpu::Buffer,
    reseeded: wgpu::Buffer,
    count: u32,
}

impl GpuTracers {
    /// `t` on the device, to be advected through a field on `grid` (the fluid's) whose macro
    /// buffer has stride `stride`.
    pub fn new(ctx: &GpuContext, t: &Tracers, grid: &crate::fluid::Grid, stride: u32) -> Self {
        Self::on_device(&ctx.device, t, grid, stride)
    }

    /// [`Self::new`] on any wgpu device (Bevy's render device).
    pub fn on_device(device: &wgpu::Device, t: &Tracers, grid: &crate::fluid::Grid, stride: u32) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("tracers"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = buffer_layout(device, "tracers", &LAYOUT);
        let pl =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("tracers"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let pipeline = compute_pipelines(device, &module, &pl, &["advect"]).remove("advect").expect("the entry point");
        let u = |v: [usize; 3]| v.map(|x| x as u32);
        let (lo, hi) = t.seed;
        let params = Params {
            n: {
                let n = u(grid.n);
                [n[0], n[1], n[2], grid.dim as u32]
            },
            halo: {
                let h = u(grid.halo);
                [h[0], h[1], h[2], t.positions.len() as u32]
            },
            padded: {
                let p = u(grid.padded);
                [p[0], p[1], p[2], stride]
            },
            seed_lo: [lo.x as f32, lo.y as f32, lo.z as f32, 0.0],
            seed_size: [(hi.x - lo.x) as f32, (hi.y - lo.y) as f32, (hi.z - lo.z) as f32, 0.0],
        };
        let data: Vec<[f32; 4]> = t.positions.iter().zip(&t.generation).map(|(p, g)| [p.x as f32, p.y as f32, p.z as f32, f32::from_bits(*g)]).collect();
        let init = |label: &str, b: &[u8], usage| device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: b, usage });
        let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        GpuTracers {
            pipeline,
            layout,
            params,
            uniform: init("tracers params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST),
            tracers: init("tracers", bytemuck::cast_slice(&data), rw | wgpu::BufferUsages::VERTEX),
            reseeded: init("tracers reseeded", bytemuck::cast_slice(&[0u32; 4]), rw),
            count: t.positions.len() as u32,
        }
    }

    /// Records `steps` steps of length `dt` (lattice time) through the field in `mac` / `kind`
    /// (the GPU fluid's layout) on `enc`.
    pub fn record(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, mac: &wgpu::Buffer, kind: &wgpu::Buffer, dt: f64, steps: u32) {
        self.record_on(&ctx.device, &ctx.queue, enc, mac, kind, dt, steps);
    }

    /// [`Self::record`] on any wgpu device and queue (Bevy's render world).
    #[allow(clippy::too_many_arguments)]
    pub fn record_on(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        enc: &mut wgpu::CommandEncoder,
        mac: &wgpu::Buffer,
        kind: &wgpu::Buffer,
        dt: f64,
        steps: u32,
    ) {
        self.params.seed_lo[3] = dt as f32;
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.params));
        let buffers = [&self.uniform, mac, kind, &self.tracers, &self.reseeded];
        let entries: Vec<wgpu::BindGroupEntry> =
            buffers.iter().enumerate().map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() }).collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("tracers"), layout: &self.layout, entries: &entries });
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("tracers"), timestamp_writes: None });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        for _ in 0..steps {
            pass.dispatch_workgroups(self.count.div_ceil(64).max(1), 1, 1);
        }
    }

    /// Number of tracers.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Positions, generations and the number of tracers born again so far.
    pub fn download(&self, ctx: &GpuContext) -> (Vec<DVec3>, Vec<u32>, u32) {
        self.download_on(&ctx.device, &ctx.queue)
    }

    /// [`Self::download`] on any wgpu device and queue.
    pub fn download_on(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> (Vec<DVec3>, Vec<u32>, u32) {
        let bytes = read_buffer(device, queue, &self.tracers);
        let t: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        let reseeded = bytemuck::cast_slice::<u8, u32>(&read_buffer(device, queue, &self.reseeded))[0];
        (t.iter().map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)).collect(), t.iter().map(|v| v[3].to_bits()).collect(), reseeded)
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_bindings, check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror("shaders/tracers.wgsl", super::SHADER, "Params", mirror!(Params { n, halo, padded, seed_lo, seed_size }));
        check_bindings("shaders/tracers.wgsl", super::SHADER, 0, &super::LAYOUT);
    }
}
