//! GPU speed measurements: the device's copy bandwidth measured by a copy kernel in the same
//! process, and FDLB node updates per second, as a fraction of that bandwidth; the drawing, the
//! coupled step against the CPU, and the solid's benchmark block.

use super::context::{GpuContext, GpuError};
use super::fdlb::GpuFluid;
use super::solid::GpuSolid;
use crate::bench::{LatticeSpeed, benchmark_solver};
use crate::fluid::VelocitySetKind;
use crate::solid::{Integrator, Preconditioner};
use std::time::Instant;
use wgpu::util::DeviceExt;

/// The copy kernel (shaders/copy.wgsl); the FDLB kernels are generated (super::codegen).
const COPY: &str = include_str!("../../shaders/copy.wgsl");

/// Best-of-`reps` copy bandwidth (bytes read + written per second) over `bytes`-sized buffers.
pub fn copy_bandwidth(ctx: &GpuContext, bytes: u64, reps: usize) -> f64 {
    let bytes = bytes.min(ctx.limits.max_storage_buffer_binding_size) / 16 * 16;
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
        median_node_updates_per_s: 0.0,
        worst_node_updates_per_s: 0.0,
        repetitions: 1,
        bytes_per_node_update: bytes,
        bandwidth_fraction: None,
        skipped: None,
        stage_fractions: Vec::new(),
        memory_hints: None,
        readback: None,
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
    (out.median_node_updates_per_s, out.worst_node_updates_per_s) = (out.node_updates_per_s, out.node_updates_per_s);
    out.bandwidth_fraction = Some(out.node_updates_per_s * bytes / bandwidth);
    out.readback = Some(readback_cost(&mut gpu, cpu, wall / steps as f64));
    if let Some(st) = gpu.profile_stages(ctx, 3) {
        let all: f64 = st.iter().map(|(_, t)| t).sum();
        out.stage_fractions = st.into_iter().map(|(n, t)| (n.to_string(), t / all.max(1e-30))).collect();
    }
    out
}

/// What one probe sample of a GPU run costs (best of 5): the whole state brought back into the
/// CPU mirror, as the run loop did at every sample, against 4 nodes' populations gathered on the
/// device, as it does now; `step_s` is one step's wall time.
fn readback_cost(gpu: &mut GpuFluid, mut cpu: crate::fluid::FluidSolver, step_s: f64) -> crate::bench::ReadbackCost {
    let n = cpu.layout.grid.n;
    let nodes: Vec<usize> = (0..4).map(|k| cpu.layout.grid.index([(n[0] * k / 4) as i64, (n[1] / 2) as i64, (n[2] / 2) as i64])).collect();
    let best = |f: &mut dyn FnMut()| crate::bench::best_of(5, f);
    let whole_s = best(&mut || assert!(gpu.download_into(&mut cpu), "the state came back"));
    let gathered_s = best(&mut || assert!(gpu.download_nodes_into(&nodes, &mut cpu), "the nodes came back"));
    crate::bench::ReadbackCost { whole_s, gathered_s, nodes: nodes.len(), whole_steps: whole_s / step_s, gathered_steps: gathered_s / step_s }
}

/// Speed of the drawing kernels, CPU twin and (when a device is given) GPU kernel measured in
/// one process: marching cubes on a sphere's signed distance (cells per second) and tracers in a
/// solid-body rotation (tracer steps per second).
#[derive(Clone, Debug, serde::Serialize)]
pub struct DrawingSpeed {
    pub kernel: String,
    /// Grid nodes per axis (marching cubes) or tracers.
    pub size: String,
    /// Cells or tracer steps per second on the CPU (rayon threads: 1, the twins are serial).
    pub cpu_per_s: f64,
    pub gpu_per_s: Option<f64>,
    /// Triangles of the surface (marching cubes).
    pub triangles: Option<usize>,
}

/// Measures [`DrawingSpeed`] at `n`³ (marching cubes) and `tracers` tracers on a 256² field.
pub fn drawing_speed(ctx: Option<&GpuContext>, n: usize, tracers: usize) -> Vec<DrawingSpeed> {
    use crate::fluid::tracers::{Tracers, VelocityField};
    use crate::mesh::{ScalarGrid, extract};
    use glam::DVec3;
    let mut out = Vec::new();
    let c = DVec3::splat(0.5 * (n as f64 - 1.0) + 0.13);
    let grid = ScalarGrid::sample([n; 3], DVec3::ZERO, 1.0, |x| 0.35 * n as f64 - (x - c).length());
    let cells = grid.cells() as f64;
    let best = |f: &mut dyn FnMut()| crate::bench::best_of(3, f);
    let mut triangles = 0;
    let cpu = best(&mut || triangles = extract(&grid, 0.0).triangles.len());
    let gpu = ctx.map(|ctx| {
        let mc = super::marching_cubes::GpuMarchingCubes::new(ctx);
        mc.kernel_seconds(ctx, &grid, 0.0, triangles as u32 + 64, 5)
    });
    out.push(DrawingSpeed {
        kernel: "marching cubes (sphere)".into(),
        size: format!("{n}³"),
        cpu_per_s: cells / cpu,
        gpu_per_s: gpu.map(|s| cells / s),
        triangles: Some(triangles),
    });
    let g = crate::fluid::Grid::new(2, [256, 256, 1]);
    let centre = DVec3::new(127.5, 127.5, 0.0);
    let field = VelocityField::analytic(g.clone(), |x| DVec3::new(-(x.y - centre.y), x.x - centre.x, 0.0) * 0.001);
    let seed = (DVec3::new(20.0, 20.0, 0.0), DVec3::new(235.0, 235.0, 0.0));
    let steps = 20;
    let mut t = Tracers::new(tracers, seed);
    let cpu = best(&mut || {
        for _ in 0..steps {
            t.advect(&field, 1.0);
        }
    });
    let gpu = ctx.map(|ctx| {
        let buffers = super::tracers::FieldBuffers::upload(ctx, &field);
        let mut gt = super::tracers::GpuTracers::new(ctx, &Tracers::new(tracers, seed), &g, buffers.stride);
        (0..5)
            .map(|_| {
                let t0 = Instant::now();
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                gt.record(ctx, &mut enc, &buffers.mac, &buffers.kind, 1.0, steps);
                ctx.queue.submit([enc.finish()]);
                let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
                t0.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
    });
    let work = (tracers * steps as usize) as f64;
    out.push(DrawingSpeed {
        kernel: "tracers (RK2, 256²)".into(),
        size: format!("{tracers}"),
        cpu_per_s: work / cpu,
        gpu_per_s: gpu.map(|s| work / s),
        triangles: None,
    });
    out
}

/// The bodies' surface made from their level sets `sets` (grid spacing `h`, dimension `dim`),
/// on the CPU ([`crate::mesh::particle_field::body_surfaces`]) and on the GPU
/// ([`super::fold_surface::GpuFoldSurface::record`]: the particles and bins go up, the level
/// set and marching cubes run, nothing comes back — what the plugin does on a frame that
/// stepped); best of three (CPU) and five (GPU) in this process, per grid node sampled.
pub fn fold_surface_speed(ctx: Option<&GpuContext>, label: &str, sets: &[crate::fluid::KernelLevelSet], h: f64, dim: usize) -> DrawingSpeed {
    use crate::mesh::particle_field::{SurfaceGrid, body_surfaces};
    let nodes: usize = sets.iter().filter(|s| !s.points.is_empty()).map(|s| SurfaceGrid::around(s, h, dim).nodes()).sum();
    let mut triangles = 0;
    let cpu = (0..3)
        .map(|_| {
            let t = Instant::now();
            triangles = body_surfaces(sets, h, dim, |p| p).triangles.len();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    let gpu = ctx.map(|ctx| {
        let surface = super::fold_surface::GpuFoldSurface::new(&ctx.device);
        let out = super::marching_cubes::OwnedSurface::new(&ctx.device, triangles as u32 + 64);
        (0..5)
            .map(|_| {
                let t = Instant::now();
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                surface.record(&ctx.device, &mut enc, sets, h, dim, &out.buffers());
                ctx.queue.submit([enc.finish()]);
                let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
    });
    DrawingSpeed {
        kernel: "folds' surface (L + cubes)".into(),
        size: label.into(),
        cpu_per_s: nodes as f64 / cpu,
        gpu_per_s: gpu.map(|s| nodes as f64 / s),
        triangles: Some(triangles),
    }
}

/// The coupled step of one scene (either method) on the GPU ([`super::coupled::GpuCoupled`])
/// and on the CPU, the same number of steps in one process.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CoupledGpuSpeed {
    pub scene: String,
    pub nodes: usize,
    pub particles: usize,
    pub solid_substeps: u32,
    pub steps: u64,
    pub gpu_steps_per_s: f64,
    pub cpu_steps_per_s: f64,
    /// GPU wall seconds per simulated second.
    pub gpu_wall_per_simulated_s: f64,
    pub gpu_stage_shares: Vec<(String, f64)>,
    /// The coupling's own stages (fluid_geometry + momentum_exchange or surface_traction) as a
    /// share of a GPU step (the goal: ≤ 25 % at the flap's size on a real GPU).
    pub gpu_coupling_share: f64,
    /// GPU steps on which nodes changed side (the nodes the change reads came back, the fresh
    /// ones went up).
    pub round_trips: u64,
    /// Nodes whose populations crossed the bus for those changes (both ways), per change.
    pub nodes_per_round_trip: f64,
    /// The parts of the `fluid_geometry` stage ([`super::coupled::GEOMETRY_PARTS`]) as shares of
    /// a GPU step.
    pub gpu_geometry_parts: Vec<(String, f64)>,
    /// Buffers and bind-group sets the timed GPU steps made for their per-step work
    /// ([`super::coupled::GpuCoupled::device_objects_made`]; 0 in the steady state).
    pub gpu_device_objects_made: u64,
    /// Method 2 on a device with f64 in shaders: the GPU steps per second with the level sets'
    /// questions (the nodes' sides, the ghosts' wall points) answered on the CPU instead
    /// ([`super::coupled::GpuCoupled::device_level_sets`] off), timed in the same process after
    /// the run above; None where they are answered on the CPU anyway.
    pub gpu_steps_per_s_cpu_level_sets: Option<f64>,
    /// The host's own work per GPU step, seconds ([`super::coupled::GpuCoupled::host_work_per_step`]).
    pub gpu_host_work_s: Vec<(String, f64)>,
    /// 1 / their sum: the most GPU steps per second this host lets any device take with the
    /// geometry built on the host.
    pub gpu_host_ceiling_steps_per_s: f64,
}

/// Times `steps` coupled steps of the solver `build` makes, on the GPU (a device of its own,
/// after two untimed steps that compile and warm it) and on the CPU.
pub fn coupled_speed(scene: &str, build: impl Fn() -> crate::coupling::CoupledSolver, steps: u64) -> Result<CoupledGpuSpeed, GpuError> {
    let mut cpu = build();
    let (nodes, particles, substeps) = (cpu.fluid.layout.grid.interior_len(), cpu.solid.particles.len(), cpu.substeps);
    let t = Instant::now();
    let cpu_ok = cpu.run(steps).is_ok();
    let cpu_wall = t.elapsed().as_secs_f64();
    let mut g = super::coupled::GpuCoupled::new(GpuContext::new()?, build())?;
    let warm = g.run(2).is_ok();
    g.reset_timings();
    // at least one step of the timed ones is timed stage by stage (a `--quick` run of 5 steps
    // met no multiple of the default 16 and printed every share as 0 %)
    g.timing_every = g.timing_every.min(steps.max(1));
    let (trips, trip_nodes, objects) = (g.round_trips, g.round_trip_nodes, g.device_objects_made());
    let t = Instant::now();
    let gpu_ok = warm && g.run(steps).is_ok();
    let gpu_wall = t.elapsed().as_secs_f64();
    if !(cpu_ok && gpu_ok) {
        return Err(GpuError::Failed(format!("{scene}: the coupled run went unstable within {steps} steps (cpu ok: {cpu_ok}, gpu ok: {gpu_ok})")));
    }
    // the same steps with the level sets' questions answered on the CPU, where the device answers them
    let cpu_level_sets = if g.level_sets_on_device() {
        let mut h = super::coupled::GpuCoupled::new(GpuContext::new()?, build())?;
        h.device_level_sets = false;
        let warm = h.run(2).is_ok();
        let t = Instant::now();
        let ok = warm && h.run(steps).is_ok();
        ok.then(|| steps as f64 / t.elapsed().as_secs_f64())
    } else {
        None
    };
    let shares: Vec<(String, f64)> = g.stage_shares().into_iter().map(|(n, s)| (n.to_string(), s)).collect();
    let host: Vec<(String, f64)> = g.host_work_per_step().into_iter().map(|(n, t)| (n.to_string(), t)).collect();
    let host_total: f64 = host.iter().map(|(_, t)| t).sum();
    let coupling = shares.iter().filter(|(n, _)| matches!(n.as_str(), "fluid_geometry" | "momentum_exchange" | "surface_traction")).map(|(_, s)| s).sum();
    Ok(CoupledGpuSpeed {
        scene: scene.into(),
        nodes,
        particles,
        solid_substeps: substeps,
        steps,
        gpu_steps_per_s: steps as f64 / gpu_wall,
        cpu_steps_per_s: steps as f64 / cpu_wall,
        gpu_wall_per_simulated_s: gpu_wall / (steps as f64 * g.cpu.dt()),
        gpu_stage_shares: shares,
        gpu_coupling_share: coupling,
        round_trips: g.round_trips - trips,
        nodes_per_round_trip: (g.round_trip_nodes - trip_nodes) as f64 / (g.round_trips - trips).max(1) as f64,
        gpu_geometry_parts: g.geometry_part_shares().into_iter().map(|(n, s)| (n.to_string(), s)).collect(),
        gpu_device_objects_made: g.device_objects_made() - objects,
        gpu_steps_per_s_cpu_level_sets: cpu_level_sets,
        gpu_host_work_s: host,
        gpu_host_ceiling_steps_per_s: 1.0 / host_total,
    })
}

/// Particle updates per second of the GPU solid on the benchmark block of
/// [`crate::solid::bench::benchmark_block`] with the implicit solve's `preconditioner` (the
/// patches fall back to block Jacobi where they do not fit: the row says which ran), with the
/// coarse space where the device holds it (its probing and A_c⁻¹ in the setup time);
/// `bandwidth` is the device's copy bandwidth (B/s).
pub fn solid_speed(
    ctx: &GpuContext,
    side: usize,
    integrator: Integrator,
    preconditioner: Preconditioner,
    steps: u64,
    bandwidth: f64,
) -> Result<crate::solid::bench::SolidSpeed, GpuError> {
    let t0 = std::time::Instant::now();
    let mut s = crate::solid::bench::benchmark_block(side, integrator);
    s.options.preconditioner = preconditioner;
    let mut g = GpuSolid::from_solver(ctx, &mut s)?;
    let setup = t0.elapsed().as_secs_f64();
    g.run(1);
    g.wait();
    let t = std::time::Instant::now();
    let mut iters = 0;
    for _ in 0..(if integrator == Integrator::Implicit { steps } else { 1 }) {
        g.run(if integrator == Integrator::Implicit { 1 } else { steps });
        iters += g.last_cg.0;
    }
    g.wait();
    let wall = t.elapsed().as_secs_f64();
    let mut v = crate::solid::bench::speed_of(false, &s, steps, wall, iters, setup, Vec::new(), bandwidth);
    // the device solve's smoother (the patches, or block Jacobi where they do not fit), with the
    // coarse space as on the CPU where the device holds it (`coarse_note` otherwise)
    v.preconditioner = v.preconditioner.map(|_| g.preconditioner);
    Ok(v)
}
