//! What the layout asks of a body's kernel level set, answered on the device
//! (shaders/level_set_queries.wgsl, f64): each node's side of the wall (the GPU twin of
//! [`KernelLevelSet::outside_distance`]) and each ghost node's wall point (of
//! [`KernelLevelSet::ghost_wall`], 2.124–2.126: Newton's steps along ∇L and two bracketed
//! searches for the zero contour, with the wall velocity there, 2.130) — most of method 2's per-step geometry on the CPU
//! (`glottis_3d_coarse`: 6 and 16.7 ms of a 34 ms stage on two cores). The layout asks each
//! question once per body and step ([`LevelSetQueries`]); each call uploads the body's
//! bin-ordered points, bin starts and bin sums with the queries and reads the answers back (one
//! wait).
//!
//! In f64 because a node's side and a ghost's image stencil switch at a threshold (the stencil
//! where the image point crosses a cell face): answers to f32 round-off (~10⁻⁵ cells) would
//! switch some that the CPU does not, and the switches, not round-off, set how far two runs part
//! (a towed disc: 5·10⁻² in the populations). The kernels write the CPU's operations in the CPU's
//! order; drivers may still contract a product and a sum, so the two agree to round-off, not bit
//! for bit (tests `level_set_queries_on_the_device_match_the_cpu` in tests/gpu/coupling.rs and
//! `a_coupled_step_with_level_sets_on_the_device_builds_the_cpus_layout` in
//! tests/gpu/coupled_steps.rs). A device without SHADER_F64 (Metal; a device Bevy opened without it)
//! has no kernels: [`LevelSetKernels::new`] says None and the questions stay on the CPU.

use super::context::{GpuContext, buffer_layout, compute_pipelines, dispatch_grid, try_read_parts_into};
use super::growing::{GrowingBuffer, KeptBindGroup};
use crate::fluid::{GhostQuery, GhostWall, KernelLevelSet, LevelSetQueries, OnThePool};
use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;
use std::sync::Mutex;
use std::time::{Duration, Instant};

const SHADER: &str = include_str!("../../shaders/level_set_queries.wgsl");

/// (uniform?, read-only?) per binding of the shader: the uniform, the [`BINDINGS`] storage
/// buffers, the answers written last (checked against it by the `Params` mirror test).
const LAYOUT: [(bool, bool); 1 + BINDINGS] = [(true, true), (false, true), (false, true), (false, true), (false, true), (false, true), (false, false)];

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

/// Points per task of the host's loops over the nodes asked about.
const PAR_POINTS: usize = 4096;

/// The `outside_distance` kernel's answer for a point inside (`INSIDE` in the shader): every
/// distance outside is ≥ 0 (or NaN where the CPU's is).
const INSIDE: f64 = -1.0;

/// Storage bindings after the uniform: the bin-ordered points, the bins' starts, the bins' sums,
/// the bin-ordered velocities, the queries, the answers.
const BINDINGS: usize = 6;

/// The storage bindings written once per binning (the bins and what they order): the first
/// [`BINNED`] of [`BINDINGS`].
const BINNED: usize = 4;

/// f64s per ghost_wall answer: the signed distance, the normal, the wall velocity.
const GHOST_WALL_ANSWER: usize = 7;

/// The buffers the calls for one of the layout's level sets (one body) reuse — its bins
/// (written when the set is another binning than the one they hold: once a step for both
/// questions), the queries and the answers (rewritten per call, remade only when a call
/// outgrows them) — and the bind group over them.
struct Slot {
    /// The [`KernelLevelSet::id`] of the bins held.
    set: u64,
    params: wgpu::Buffer,
    data: Vec<GrowingBuffer>,
    staging: GrowingBuffer,
    group: KeptBindGroup,
}

/// Bodies whose bins the device holds at once (the layout's level set `which` in slot
/// `which % SLOTS`): a scene with more sends some bodies' bins for each question (the same
/// answers, more uploads).
const SLOTS: usize = 4;

/// What the kernels' calls have cost so far.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelSetWork {
    /// Calls (one per body, question and step).
    pub calls: u64,
    /// Points and ghosts answered on the device.
    pub queries: u64,
    /// Bodies' bins sent to the device (once per binning while the device holds it: once a
    /// step for both questions of a scene of up to four bodies).
    pub bins_sent: u64,
    /// Wall time of the calls: the uploads, the kernel and the read back.
    pub time: Duration,
    /// Calls whose read failed, answered on the CPU instead.
    pub failed: u64,
}

/// One kernel of shaders/level_set_queries.wgsl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    OutsideDistance,
    GhostWall,
}

impl Kernel {
    const ALL: [Kernel; 2] = [Kernel::OutsideDistance, Kernel::GhostWall];
    fn entry(self) -> &'static str {
        match self {
            Kernel::OutsideDistance => "outside_distance",
            Kernel::GhostWall => "ghost_wall",
        }
    }
}

/// The compiled kernels and their buffers.
pub struct LevelSetKernels {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipelines: [wgpu::ComputePipeline; 2],
    layout: wgpu::BindGroupLayout,
    slots: Mutex<Vec<Slot>>,
    work: Mutex<LevelSetWork>,
}

impl LevelSetKernels {
    /// The kernels on `ctx`'s device, or None when the device has no f64 in shaders
    /// (`wgpu::Features::SHADER_F64`).
    pub fn new(ctx: &GpuContext) -> Option<Self> {
        if !ctx.device.features().contains(wgpu::Features::SHADER_F64) {
            return None;
        }
        let device = &ctx.device;
        let module =
            device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("level set queries"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = buffer_layout(device, "level set queries", &LAYOUT);
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("level set queries"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let mut map = compute_pipelines(device, &module, &pl, &Kernel::ALL.map(Kernel::entry));
        let pipelines = Kernel::ALL.map(|k| map.remove(k.entry()).expect("one pipeline per entry point"));
        Some(LevelSetKernels {
            device: ctx.device.clone(),
            queue: ctx.queue.clone(),
            pipelines,
            layout,
            slots: Mutex::new(Vec::new()),
            work: Mutex::new(LevelSetWork::default()),
        })
    }

    /// What the calls have cost so far.
    pub fn work(&self) -> LevelSetWork {
        *self.work.lock().expect("the work's lock")
    }

    /// Buffers and bind groups the calls have made so far: the same after a call means the
    /// call made none.
    pub fn objects_made(&self) -> u64 {
        let slots = self.slots.lock().expect("the slots' lock");
        slots.iter().map(|b| 1 + b.staging.made() + b.group.made() + b.data.iter().map(GrowingBuffer::made).sum::<u64>()).sum()
    }

    /// [`KernelLevelSet::outside_distance`] at each of `points` to round-off (None inside); None
    /// when the read failed. The points outside the set's bin box (where no particle is within
    /// r_e, so L = −φ) are answered here, by the set itself.
    pub fn try_outside_distances(&self, which: usize, set: &KernelLevelSet, points: &[[f64; 3]]) -> Option<Vec<Option<f64>>> {
        let (lo, hi, _) = set.bin_box();
        let in_box = |p: &[f64; 3]| (0..3).all(|a| p[a] >= lo[a] && p[a] <= hi[a]);
        // on the pool's threads: the layout asks about every node of the region it rebuilds
        // (42,408 a step for `glottis_3d_coarse`; the region grows with the lattice), many of
        // them beyond this body's bins
        let near: Vec<usize> = (0..points.len()).into_par_iter().with_min_len(PAR_POINTS).filter(|&i| in_box(&points[i])).collect();
        let q: Vec<f64> = near.iter().flat_map(|&i| points[i]).collect();
        let bytes = self.run(which, set, Kernel::OutsideDistance, &q, near.len(), 8)?;
        // the read's bytes need not be aligned for f64
        let d: Vec<f64> = bytemuck::pod_collect_to_vec(&bytes);
        let mut out: Vec<Option<f64>> = points.par_iter().with_min_len(PAR_POINTS).map(|p| if in_box(p) { None } else { set.outside_distance(*p) }).collect();
        for (&i, &d) in near.iter().zip(&d) {
            out[i] = (d != INSIDE).then_some(d);
        }
        Some(out)
    }

    /// The wall of each of `queries` in `set` (signed distance in cells, outward normal, and
    /// the wall velocity at the wall point, c units), as [`KernelLevelSet::ghost_wall`] and
    /// [`KernelLevelSet::velocity_at`] give them to round-off; None when the read failed.
    pub fn try_ghost_walls(&self, which: usize, set: &KernelLevelSet, queries: &[GhostQuery]) -> Option<Vec<GhostWall>> {
        let q: Vec<f64> = queries.iter().flat_map(|(a, b)| a.iter().chain(b).copied()).collect();
        let bytes = self.run(which, set, Kernel::GhostWall, &q, queries.len(), 8 * GHOST_WALL_ANSWER as u64)?;
        let w: Vec<f64> = bytemuck::pod_collect_to_vec(&bytes);
        Some(w.chunks_exact(GHOST_WALL_ANSWER).map(|c| GhostWall { distance: c[0], normal: [c[1], c[2], c[3]], velocity: [c[4], c[5], c[6]] }).collect())
    }

    /// Runs `kernel` over `count` queries (`q`, their coordinates) of `set` (the layout's level
    /// set `which`, whose bins its slot holds) and reads back `answer` bytes for each; None when
    /// the read failed.
    fn run(&self, which: usize, set: &KernelLevelSet, kernel: Kernel, q: &[f64], count: usize, answer: u64) -> Option<Vec<u8>> {
        if count == 0 {
            return Some(Vec::new());
        }
        let (device, queue) = (&self.device, &self.queue);
        let (lo, hi, bins) = set.bin_box();
        let (start, _) = set.bin_lists();
        let (sorted, sums) = set.binned_points();
        let p = Params {
            lo: [lo[0], lo[1], lo[2], 0.0],
            hi: [hi[0], hi[1], hi[2], 0.0],
            re: set.re,
            r_min: set.r_min,
            phi: set.phi,
            bins: [bins[0] as u32, bins[1] as u32, bins[2] as u32, set.points.len() as u32],
            count: u32::try_from(count).expect("fewer than 2³² queries"),
            ..Default::default()
        };
        let out_bytes = answer * count as u64;
        let inputs: [&[u8]; BINDINGS - 1] = [
            bytemuck::cast_slice(sorted),
            bytemuck::cast_slice(start),
            bytemuck::cast_slice(sums),
            bytemuck::cast_slice(set.binned_velocities()),
            bytemuck::cast_slice(q),
        ];
        let t0 = Instant::now();
        let mut slots = self.slots.lock().expect("the slots' lock");
        let k = which % SLOTS;
        while slots.len() <= k {
            // a body's points keep their number, but its box (the bins), its surface (the
            // ghosts) and the nodes near it grow as it bends — the small flap's bins by 1.7× and
            // its ghosts by 1.6× from their fewest over 120 steps —, so a slot starts with room
            // for three times its first call's bins and queries, and later calls of a bending
            // body make no buffer
            let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
            let room: [u64; BINDINGS] = [
                inputs[0].len() as u64,
                3 * inputs[1].len() as u64,
                3 * inputs[2].len() as u64,
                inputs[3].len() as u64,
                3 * inputs[4].len() as u64,
                3 * out_bytes,
            ];
            slots.push(Slot {
                set: u64::MAX,
                params: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("level set query params"),
                    size: std::mem::size_of::<Params>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                data: room.iter().map(|&r| GrowingBuffer::with_room(device, "level set queries", storage, r)).collect(),
                staging: GrowingBuffer::with_room(device, "level set answers", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST, 3 * out_bytes),
                group: KeptBindGroup::default(),
            });
        }
        let b = &mut slots[k];
        queue.write_buffer(&b.params, 0, bytemuck::bytes_of(&p));
        // the bins, once per binning; the queries, each call
        let from = if b.set == set.id() { BINNED } else { 0 };
        let bins_sent = (from == 0) as u64;
        for (buf, d) in b.data.iter_mut().zip(inputs).skip(from) {
            buf.write(device, queue, d);
        }
        b.set = set.id();
        b.data[BINDINGS - 1].reserve(device, out_bytes);
        b.staging.reserve(device, out_bytes);
        let bound: Vec<wgpu::Buffer> = std::iter::once(b.params.clone()).chain(b.data.iter().map(|d| d.buffer().clone())).collect();
        let group = b.group.over(device, &self.layout, "level set queries", &bound);
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(kernel.entry()), timestamp_writes: None });
            pass.set_pipeline(&self.pipelines[kernel as usize]);
            pass.set_bind_group(0, group, &[]);
            let ((gx, gy), _) = dispatch_grid(count);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        let read = try_read_parts_into(device, queue, enc, &[(&bound[BINDINGS], 0, out_bytes)], b.staging.buffer());
        let mut work = self.work.lock().expect("the work's lock");
        work.calls += 1;
        work.queries += count as u64;
        work.bins_sent += bins_sent;
        work.time += t0.elapsed();
        if read.is_none() {
            work.failed += 1;
        }
        read
    }
}

/// On the device; on the CPU when a read fails (the device lost: the step's other reads fail
/// too, and the run stops with that diagnosis).
impl LevelSetQueries for LevelSetKernels {
    fn outside_distances(&self, which: usize, set: &KernelLevelSet, points: &[[f64; 3]]) -> Vec<Option<f64>> {
        self.try_outside_distances(which, set, points).unwrap_or_else(|| OnThePool.outside_distances(which, set, points))
    }

    fn ghost_walls(&self, which: usize, set: &KernelLevelSet, queries: &[GhostQuery]) -> Vec<GhostWall> {
        self.try_ghost_walls(which, set, queries).unwrap_or_else(|| OnThePool.ghost_walls(which, set, queries))
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_bindings, check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror(
            "shaders/level_set_queries.wgsl",
            super::SHADER,
            "Params",
            mirror!(Params { lo, hi, re, r_min, phi, _pad0, bins, count, _pad1, _pad2, _pad3 }),
        );
        check_bindings("shaders/level_set_queries.wgsl", super::SHADER, 0, &super::LAYOUT);
    }
}
