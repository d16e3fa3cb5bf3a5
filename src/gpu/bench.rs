//! GPU speed measurements: the device's copy bandwidth measured by a copy kernel in the same
//! process, and FDLB node updates per second, as a fraction of that bandwidth.

use super::context::{GpuContext, GpuError};
use super::fdlb::GpuFluid;
use crate::bench::{LatticeSpeed, benchmark_solver};
use crate::fluid::VelocitySetKind;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// The copy kernel (shaders/copy.wgsl); the FDLB kernels are generated (super::codegen).
const COPY: &str = include_str!("../../shaders/copy.wgsl");

/// Best-of-`reps` copy bandwidth (bytes read + written per second) over `bytes`-sized buffers.
pub fn copy_bandwidth(ctx: &GpuContext, bytes: u64, reps: usize) -> f64 {
    let bytes = bytes.min(ctx.limits.max_storage_buffer_binding_size as u64) / 16 * 16;
    let dev = &ctx.device;
    let src = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("copy src"),
        contents: &vec![1u8; bytes as usize],
        usage: wgpu::BufferUsages::STORAGE,
    });
    let dst =
        dev.create_buffer(&wgpu::BufferDescriptor { label: Some("copy dst"), size: bytes, usage: wgpu::BufferUsages::STORAGE, mapped_at_creation: false });
    let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("copy"), source: wgpu::ShaderSource::Wgsl(COPY.into()) });
    let p = dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("copy"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &p.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: src.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: dst.as_entire_binding() },
        ],
    });
    let groups = (bytes / 16).div_ceil(256) as u32;
    let (gx, gy) = if groups <= 65_535 { (groups, 1) } else { (65_535, groups.div_ceil(65_535)) };
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        let mut enc = dev.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&p);
            pass.set_bind_group(0, &bg, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        ctx.queue.submit([enc.finish()]);
        let _ = dev.poll(wgpu::PollType::wait_indefinitely());
        best = best.min(t.elapsed().as_secs_f64());
    }
    2.0 * bytes as f64 / best
}

/// FDLB node updates per second on the GPU for a periodic box (f32: 4-byte values).
pub fn lattice_speed(ctx: &GpuContext, set: VelocitySetKind, n: [usize; 3], steps: u64, bandwidth: f64) -> LatticeSpeed {
    let cpu = benchmark_solver(set, n);
    let nv = cpu.eq.values_per_node() as f64;
    let bytes = 4.0 * (13.0 * nv + 10.0);
    let mut out = LatticeSpeed {
        lattice: format!("{set:?}"),
        nodes: cpu.layout.grid.n,
        steps,
        node_updates_per_s: 0.0,
        bytes_per_node_update: bytes,
        bandwidth_fraction: 0.0,
        skipped: None,
        stage_fractions: Vec::new(),
    };
    let mut gpu = match GpuFluid::from_solver(ctx, &cpu) {
        Ok(g) => g,
        Err(e @ GpuError::TooLarge { .. }) => {
            out.skipped = Some(e.to_string());
            return out;
        }
        Err(e) => panic!("{e}"),
    };
    gpu.run(2);
    gpu.wait();
    let t = Instant::now();
    gpu.run(steps);
    gpu.wait();
    let wall = t.elapsed().as_secs_f64();
    out.node_updates_per_s = steps as f64 * cpu.layout.fluid_count as f64 / wall;
    out.bandwidth_fraction = out.node_updates_per_s * bytes / bandwidth;
    if let Some(st) = gpu.profile_stages(ctx, 3) {
        let all: f64 = st.iter().map(|(_, t)| t).sum();
        out.stage_fractions = st.into_iter().map(|(n, t)| (n.to_string(), t / all.max(1e-30))).collect();
    }
    out
}
