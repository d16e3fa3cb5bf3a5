//! Method 2's ghost wall points on the device (shaders/ghost_wall.wgsl, f64): the GPU twin of
//! [`KernelLevelSet::ghost_wall`] (2.124–2.126: Newton's steps along ∇L and two bracketed
//! searches for the zero contour), the part of the level-set walls that a coupled step of a thick
//! body spends most of its host time on (55 % of `glottis_3d_coarse`'s geometry stage, callgrind).
//! The layout asks it for every ghost of a body at once ([`GhostWalls`]).
//!
//! In f64 because a ghost's image stencil switches where its image point crosses a cell face:
//! wall points to f32 round-off (~10⁻⁵ cells) would switch stencils that the CPU does not, and
//! the switches, not round-off, set how far two runs part (a towed disc: 5·10⁻² in the
//! populations). The kernel writes the CPU's operations in the CPU's order; drivers may still
//! contract a product and a sum, so the two agree to round-off, not bit for bit (test
//! `ghost_walls_on_the_device_match_the_cpu` in tests/gpu/coupling.rs). A device without
//! SHADER_F64 (Metal; a device Bevy opened without it) has no kernel: [`GhostWallKernel::new`]
//! says None and the walls stay on the CPU.

use super::context::{GpuContext, buffer_layout, compute_pipelines, dispatch_grid, try_read_parts_into};
use super::growing::GrowingBuffer;
use crate::fluid::{GhostQuery, GhostWalls, KernelLevelSet, OnThePool};
use bytemuck::{Pod, Zeroable};
use std::sync::Mutex;
use std::time::{Duration, Instant};

const SHADER: &str = include_str!("../../shaders/ghost_wall.wgsl");

/// The kernel's uniform (`Params` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    lo: [f64; 4],
    hi: [f64; 4],
    re: f64,
    r_min: f64,
    phi: f64,
    _pad0: f64,
    bins: [u32; 4],
    count: u32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
}

/// Storage bindings after the uniform: the bin-ordered points, the bins' starts, the bins' sums,
/// the queries, the walls.
const BINDINGS: usize = 5;

/// The buffers the calls reuse (rewritten per call, remade only when a call outgrows them) and
/// the bind group over them.
struct Buffers {
    params: wgpu::Buffer,
    data: Vec<GrowingBuffer>,
    staging: GrowingBuffer,
    group: Option<(wgpu::BindGroup, Vec<wgpu::Buffer>)>,
    groups_made: u64,
}

/// What the kernel's calls have cost so far.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GhostWallWork {
    /// Calls (one per body and step).
    pub calls: u64,
    /// Ghosts answered.
    pub ghosts: u64,
    /// Wall time of the calls: the upload, the kernel and the read back.
    pub time: Duration,
    /// Calls whose read failed, answered on the CPU instead.
    pub failed: u64,
}

/// The compiled kernel and its buffers.
pub struct GhostWallKernel {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    buffers: Mutex<Option<Buffers>>,
    work: Mutex<GhostWallWork>,
}

impl GhostWallKernel {
    /// The kernel on `ctx`'s device, or None when the device has no f64 in shaders
    /// (`wgpu::Features::SHADER_F64`).
    pub fn new(ctx: &GpuContext) -> Option<Self> {
        if !ctx.device.features().contains(wgpu::Features::SHADER_F64) {
            return None;
        }
        let device = &ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("ghost wall"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let kinds = [(true, true), (false, true), (false, true), (false, true), (false, true), (false, false)];
        let layout = buffer_layout(device, "ghost wall", &kinds);
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ghost wall"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = compute_pipelines(device, &module, &pl, &["ghost_wall"]).remove("ghost_wall").expect("the entry point's pipeline");
        Some(GhostWallKernel {
            device: ctx.device.clone(),
            queue: ctx.queue.clone(),
            pipeline,
            layout,
            buffers: Mutex::new(None),
            work: Mutex::new(GhostWallWork::default()),
        })
    }

    /// What the calls have cost so far.
    pub fn work(&self) -> GhostWallWork {
        *self.work.lock().expect("the work's lock")
    }

    /// Buffers and bind groups the calls have made so far: the same after a call means the
    /// call made none.
    pub fn objects_made(&self) -> u64 {
        let b = self.buffers.lock().expect("the buffers' lock");
        b.as_ref().map_or(0, |b| 1 + b.staging.made() + b.groups_made + b.data.iter().map(GrowingBuffer::made).sum::<u64>())
    }

    /// The wall of each of `queries` in `set` (signed distance in cells, outward normal), as
    /// [`KernelLevelSet::ghost_wall`] gives them to round-off; None when the read failed.
    pub fn try_ghost_walls(&self, set: &KernelLevelSet, queries: &[GhostQuery]) -> Option<Vec<(f64, [f64; 3])>> {
        if queries.is_empty() {
            return Some(Vec::new());
        }
        let (device, queue) = (&self.device, &self.queue);
        let (lo, hi, bins) = set.bin_box();
        let (start, _) = set.bin_lists();
        let (sorted, sums) = set.binned_points();
        let count = u32::try_from(queries.len()).expect("fewer than 2³² ghosts");
        let p = Params {
            lo: [lo[0], lo[1], lo[2], 0.0],
            hi: [hi[0], hi[1], hi[2], 0.0],
            re: set.re,
            r_min: set.r_min,
            phi: set.phi,
            bins: [bins[0] as u32, bins[1] as u32, bins[2] as u32, set.points.len() as u32],
            count,
            ..Default::default()
        };
        let q: Vec<f64> = queries.iter().flat_map(|(a, b)| a.iter().chain(b).copied()).collect();
        let out_bytes = 32 * queries.len() as u64;
        let inputs: [&[u8]; 4] = [bytemuck::cast_slice(sorted), bytemuck::cast_slice(start), bytemuck::cast_slice(sums), bytemuck::cast_slice(&q)];
        let mut guard = self.buffers.lock().expect("the buffers' lock");
        let b = guard.get_or_insert_with(|| {
            // a body's points keep their number, but its box (the bins) and its surface (the
            // ghosts) grow as it bends — the small flap's bins by 1.7× and its ghosts by 1.6×
            // from their fewest over 120 steps —, so the first call makes room for three times
            // its bins and ghosts, and later calls of a bending body make no buffer
            let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
            let room: [u64; BINDINGS] =
                [inputs[0].len() as u64, 3 * inputs[1].len() as u64, 3 * inputs[2].len() as u64, 3 * inputs[3].len() as u64, 3 * out_bytes];
            Buffers {
                params: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("ghost wall params"),
                    size: std::mem::size_of::<Params>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                data: room.iter().map(|&r| GrowingBuffer::with_room(device, "ghost wall", storage, r)).collect(),
                staging: GrowingBuffer::with_room(device, "ghost wall readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST, 3 * out_bytes),
                group: None,
                groups_made: 0,
            }
        });
        let t0 = Instant::now();
        queue.write_buffer(&b.params, 0, bytemuck::bytes_of(&p));
        for (buf, d) in b.data.iter_mut().zip(inputs) {
            buf.write(device, queue, d);
        }
        b.data[4].reserve(device, out_bytes);
        b.staging.reserve(device, out_bytes);
        let bound: Vec<wgpu::Buffer> = std::iter::once(b.params.clone()).chain(b.data.iter().map(|d| d.buffer().clone())).collect();
        if b.group.as_ref().is_none_or(|(_, was)| *was != bound) {
            let entries: Vec<wgpu::BindGroupEntry> =
                bound.iter().enumerate().map(|(k, buf)| wgpu::BindGroupEntry { binding: k as u32, resource: buf.as_entire_binding() }).collect();
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("ghost wall"), layout: &self.layout, entries: &entries });
            b.group = Some((group, bound.clone()));
            b.groups_made += 1;
        }
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("ghost_wall"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &b.group.as_ref().expect("made above").0, &[]);
            let ((gx, gy), _) = dispatch_grid(queries.len());
            pass.dispatch_workgroups(gx, gy, 1);
        }
        let read = try_read_parts_into(device, queue, enc, &[(&bound[5], 0, out_bytes)], b.staging.buffer());
        let mut work = self.work.lock().expect("the work's lock");
        work.calls += 1;
        work.ghosts += queries.len() as u64;
        work.time += t0.elapsed();
        let Some(bytes) = read else {
            work.failed += 1;
            return None;
        };
        let w: &[f64] = bytemuck::cast_slice(&bytes);
        Some(w.chunks_exact(4).map(|c| (c[0], [c[1], c[2], c[3]])).collect())
    }
}

impl GhostWalls for GhostWallKernel {
    /// On the device; on the CPU when the read fails (the device lost: the step's other reads
    /// fail too, and the run stops with that diagnosis).
    fn ghost_walls(&self, set: &KernelLevelSet, queries: &[GhostQuery]) -> Vec<(f64, [f64; 3])> {
        self.try_ghost_walls(set, queries).unwrap_or_else(|| OnThePool.ghost_walls(set, queries))
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror("shaders/ghost_wall.wgsl", super::SHADER, "Params", mirror!(Params { lo, hi, re, r_min, phi, _pad0, bins, count, _pad1, _pad2, _pad3 }));
    }
}
