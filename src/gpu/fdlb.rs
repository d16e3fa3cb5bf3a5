//! The GPU twin of [`crate::fluid::FluidSolver`]: the same stages ([`FDLB_STEP`]) recorded as
//! compute dispatches of the generated kernels ([`super::codegen`]), f32 structure-of-arrays
//! buffers, set up from a CPU solver (geometry tables, initial state) so that the two can be
//! compared stage by stage.
//!
//! Node arrays use a stride N' = N plus room for the thin walls' side ghosts
//! (`side_ghost_room`: at least a 32nd of the lattice, nodes past it), rounded up to a multiple of 64, so
//! that population ranges bound separately ([`codegen::Split`], when an array exceeds the adapter's binding limit) start
//! on 256-byte boundaries.
//!
//! Memory per node: 4 population arrays (fⁿ, f¹, fⁿ⁺¹, h) of NV f32 plus 5 macro fields and a
//! node kind: (16·NV + 24) bytes (D2Q21: 360 B, D3Q39: 648 B). Bytes moved per node update of
//! one step: stage 1 reads f (NV) and writes h, f¹ (2 NV) and 5 macros, then the advection reads
//! h and f¹ and writes f¹ (3 NV); stage 2 also reads fⁿ: (13 NV + 10)·4 bytes, neighbours of
//! the stencil assumed served from cache.

mod face_fluxes;
mod gather;
mod geometry;
mod readback;
mod stage_groups;
mod totals;
mod traction;

pub use geometry::SideGhostRoom;
pub use readback::{FlagReadFailed, GpuArray, compare_nodes};

use super::codegen::{self, Split, WORKGROUP};
use super::context::{GpuContext, GpuError};
use super::growing::GrowingBuffer;
use crate::fluid::{Equilibrium, FluidSolver};
use crate::stages::{FDLB_STEP, Stage, StageKind};
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Params {
    n_nodes: u32,
    px: u32,
    py: u32,
    pz: u32,
    nx: u32,
    ny: u32,
    nz: u32,
    hx: u32,
    hy: u32,
    hz: u32,
    count: u32,
    stage: u32,
    dt: f32,
    tau: f32,
    a: f32,
    window_lo: f32,
    window_hi: f32,
    gx: f32,
    gy: f32,
    gz: f32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, Default)]
struct Entry {
    node: u32,
    source: u32,
    code: u32,
    n_img: u32,
    rho: f32,
    theta: f32,
    ux: f32,
    uy: f32,
    uz: f32,
    ratio: f32,
    _p0: f32,
    _p1: f32,
}

const PIPE_MOMENTS: usize = 0;
const PIPE_ADVECT: usize = 1;
const PIPE_GHOST: usize = 2;
const PIPE_FACE: usize = 3;
const PIPE_PERIODIC: usize = 4;
const PIPE_THIN: usize = 5;

/// The moments kernel of a fixed list of nodes (the plugin's probes, a slice's plane).
pub struct MomentsAt {
    pipeline: wgpu::ComputePipeline,
    nodes: wgpu::Buffer,
    params: wgpu::Buffer,
    count: usize,
}

pub struct GpuFluid {
    device: wgpu::Device,
    eq: crate::fluid::Equilibrium,
    probe: Option<MomentsAt>,
    /// The `gather` kernel of [`Self::download_nodes_into`], built at its first use.
    gather: Option<gather::NodeListKernel>,
    /// The `scatter` kernel of [`Self::upload_nodes_from`], built at its first use.
    scatter: Option<gather::NodeListKernel>,
    /// The `totals` kernel of [`Self::totals`], built at its first use.
    totals: Option<totals::TotalsKernel>,
    /// Method 1's traction kernels of [`Self::surface_traction`], built at their first use.
    traction: Option<traction::TractionKernel>,
    queue: wgpu::Queue,
    pub nv: usize,
    /// Padded node count of the lattice.
    pub n_nodes: usize,
    /// Node stride N' of the GPU arrays (n_nodes rounded up to a multiple of 64).
    stride: usize,
    split: Split,
    interior: u32,
    /// f buffers: [fⁿ or fⁿ⁺¹, f¹, fⁿ⁺¹ or fⁿ]; `cur` says which of 0 and 2 holds fⁿ.
    f: [wgpu::Buffer; 3],
    cur: usize,
    h: wgpu::Buffer,
    mac: wgpu::Buffer,
    kind: wgpu::Buffer,
    /// What `kind` holds, so that a geometry change uploads only the span of nodes it changed.
    kind_host: Vec<u32>,
    /// Geometry changes that needed new boundary tables' buffers and bind groups (their sizes
    /// changed); the others rewrote the tables in place ([`Self::set_geometry`]).
    pub geometry_rebinds: u64,
    /// Buffers and bind groups method 1's traction kernels have made (their buffers when they
    /// outgrow them, the bind groups once per placement of fⁿ and buffer set).
    traction_objects_made: u64,
    /// Buffers and bind groups the node-list (gather, scatter) and totals kernels have made:
    /// with their buffers, when those are made or outgrown.
    state_objects_made: u64,
    /// The staging buffers, kept, of the gather's reads, the totals' partial sums and method
    /// 1's piece forces.
    node_readback: crate::gpu::growing::Readback,
    totals_readback: crate::gpu::growing::Readback,
    piece_readback: crate::gpu::growing::Readback,
    status: wgpu::Buffer,
    /// The flag's own staging buffer, made once: reading the flag after an advance allocates
    /// nothing on the device (a read that needed memory would fail where the device's memory
    /// is full, as a state read may).
    status_staging: wgpu::Buffer,
    /// The boundary tables (rewritten in place at each geometry change, remade only when they
    /// outgrow their buffers) with their thread counts: ghosts and their image taps, face halos,
    /// periodic copies.
    ghosts: (GrowingBuffer, GrowingBuffer, u32),
    faces: (GrowingBuffer, u32),
    periodic: (GrowingBuffer, u32),
    params_stage: [wgpu::Buffer; 2],
    /// The parameters of the ghost, face and periodic fills (with their thread counts; rewritten
    /// when the counts change).
    params_count: [wgpu::Buffer; 3],
    /// The parameters every uniform of this lattice starts from.
    base: Params,
    /// Thin-wall taps, (first tap, count) per node, the node count, and the parameters of the
    /// two Runge–Kutta stages with that count.
    thin: (GrowingBuffer, GrowingBuffer, u32, [wgpu::Buffer; 2]),
    /// moments_collide, advect, ghost_fill, face_fill, periodic_copy, thin_wall (the `PIPE_*`
    /// indices).
    pipelines: [wgpu::ComputePipeline; 6],
    /// Per placement of fⁿ (buffer 0 or 2), per stage, the dispatches with their bind groups.
    groups: [Vec<Vec<(usize, wgpu::BindGroup, u32)>>; 2],
    /// Method 2's record of the walls' face fluxes, when asked for ([`Self::record_face_fluxes`]).
    face_fluxes: Option<face_fluxes::FaceFluxes>,
    pub step_count: u64,
}

fn storage(device: &wgpu::Device, label: &str, data: &[u8]) -> wgpu::Buffer {
    // Empty lists still need a binding: one zero word.
    let data: &[u8] = if data.is_empty() { &[0u8; 48] } else { data };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: data,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    })
}

fn pipeline_of(device: &wgpu::Device, label: &str, src: &str, entry: &str) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(label), source: wgpu::ShaderSource::Wgsl(src.into()) });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// Workgroup counts for `threads` threads (2D when one dimension is not enough).
fn groups(threads: u32) -> (u32, u32) {
    let w = threads.div_ceil(WORKGROUP).max(1);
    if w <= 65_535 { (w, 1) } else { (65_535, w.div_ceil(65_535)) }
}

impl GpuFluid {
    /// Uploads the state, geometry tables and parameters of a CPU solver.
    pub fn from_solver(ctx: &GpuContext, s: &FluidSolver) -> Result<Self, GpuError> {
        Self::from_device(ctx.device.clone(), ctx.queue.clone(), &ctx.limits, s)
    }

    /// How the populations of `nodes` lattice nodes with `nv` values each are split over storage
    /// bindings on a device with `limits`, or why they do not fit (the figure needed and the
    /// adapter's): checked before anything is allocated, on the CPU or the GPU.
    pub fn fits(limits: &wgpu::Limits, nodes: usize, nv: usize) -> Result<Split, GpuError> {
        // the lattice's nodes and the least room for side ghosts ([`geometry::side_ghost_room`])
        let pop_bytes = ((nodes + (nodes / 32).max(256)).div_ceil(64) * 64 * 4) as u64;
        let limit = limits.max_storage_buffer_binding_size;
        let per_binding = ((limit / pop_bytes) as usize).min(nv);
        let total = nv as u64 * pop_bytes;
        if per_binding == 0 {
            return Err(GpuError::TooLarge { what: "one population", bytes: pop_bytes, limit, unit: "bytes", limit_name: "max_storage_buffer_binding_size" });
        }
        if total > limits.max_buffer_size {
            return Err(GpuError::TooLarge {
                what: "one population array",
                bytes: total,
                limit: limits.max_buffer_size,
                unit: "bytes",
                limit_name: "max_buffer_size",
            });
        }
        let split = Split { nv, per_binding };
        let needed = 3 + 4 * split.groups() as u32;
        if needed > limits.max_storage_buffers_per_shader_stage {
            return Err(GpuError::TooLarge {
                what: "the moments kernel",
                bytes: needed as u64,
                limit: limits.max_storage_buffers_per_shader_stage as u64,
                unit: "storage bindings",
                limit_name: "max_storage_buffers_per_shader_stage",
            });
        }
        Ok(split)
    }

    /// The same on a device opened elsewhere (Bevy's render device). `limits`: the device's.
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue, limits: &wgpu::Limits, s: &FluidSolver) -> Result<Self, GpuError> {
        let eq = &s.eq;
        let nv = eq.values_per_node();
        let g = &s.layout.grid;
        let n = g.len();
        // the lattice's nodes, then room for the thin walls' side ghosts ([`geometry::Tables::of`])
        let stride = (n + geometry::side_ghost_room(s)).div_ceil(64) * 64;
        let split = Self::fits(limits, n, nv)?;
        let f0 = geometry::state_array(s, stride);
        let fb = bytemuck::cast_slice(&f0);
        let f = [storage(&device, "f", fb), storage(&device, "f1", fb), storage(&device, "f2", fb)];
        let h = storage(&device, "h", fb);
        let mac = storage(&device, "mac", bytemuck::cast_slice(&vec![0f32; 5 * stride]));
        let status = storage(&device, "status", bytemuck::cast_slice(&[u32::MAX, 0u32]));
        let status_staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("status staging"),
            size: status.size(),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let t = geometry::Tables::of(s, stride).expect("the room is made for twice the side ghosts of s");
        let kind = storage(&device, "kind", bytemuck::cast_slice(&t.kind));
        let base = Params::of(s, stride);
        let uniform = |p: Params| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("params"),
                contents: bytemuck::bytes_of(&p),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
        };
        let params_stage = [uniform(Params { stage: 1, ..base }), uniform(Params { stage: 2, ..base })];
        let counts = t.counts();
        let params_count = counts.map(|c| uniform(Params { count: c, ..base }));
        let thin_count = t.thin_ranges.len() as u32;
        let params_thin = [uniform(Params { stage: 1, count: thin_count, ..base }), uniform(Params { stage: 2, count: thin_count, ..base })];

        let mut gpu = GpuFluid {
            pipelines: pipelines(&device, eq, split),
            thin: (
                GrowingBuffer::storage(&device, "thin taps", bytemuck::cast_slice(&t.thin_taps)),
                GrowingBuffer::storage(&device, "thin ranges", bytemuck::cast_slice(&t.thin_ranges)),
                thin_count,
                params_thin,
            ),
            groups: [Vec::new(), Vec::new()],
            ghosts: (
                GrowingBuffer::storage(&device, "ghosts", bytemuck::cast_slice(&t.ghosts)),
                GrowingBuffer::storage(&device, "images", bytemuck::cast_slice(&t.images)),
                counts[0],
            ),
            faces: (GrowingBuffer::storage(&device, "faces", bytemuck::cast_slice(&t.faces)), counts[1]),
            periodic: (GrowingBuffer::storage(&device, "periodic", bytemuck::cast_slice(&t.periodic)), counts[2]),
            base,
            interior: g.interior_len() as u32,
            eq: eq.clone(),
            probe: None,
            gather: None,
            scatter: None,
            traction: None,
            totals: None,
            face_fluxes: None,
            nv,
            n_nodes: n,
            stride,
            split,
            f,
            cur: 0,
            h,
            mac,
            kind,
            kind_host: t.kind.clone(),
            geometry_rebinds: 0,
            traction_objects_made: 0,
            state_objects_made: 0,
            node_readback: Default::default(),
            totals_readback: Default::default(),
            piece_readback: Default::default(),
            status,
            status_staging,
            params_stage,
            params_count,
            device,
            queue,
            step_count: s.step_count,
        };
        gpu.groups = gpu.stage_groups();
        Ok(gpu)
    }

    /// Bind group of `p` (automatic layout: exactly the bindings its entry point uses).
    /// `whole`: (binding, buffer) bound entirely; `arrays`: (first binding, population array)
    /// bound as the ranges of [`Split`].
    fn bind(&self, p: &wgpu::ComputePipeline, whole: &[(u32, &wgpu::Buffer)], arrays: &[(u32, &wgpu::Buffer)]) -> wgpu::BindGroup {
        let layout = p.get_bind_group_layout(0);
        let mut entries: Vec<wgpu::BindGroupEntry> = whole.iter().map(|&(i, b)| wgpu::BindGroupEntry { binding: i, resource: b.as_entire_binding() }).collect();
        let pop = (self.stride * 4) as u64;
        for &(first, b) in arrays {
            for g in 0..self.split.groups() {
                entries.push(wgpu::BindGroupEntry {
                    binding: first + g as u32,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: b,
                        offset: (g * self.split.per_binding) as u64 * pop,
                        size: std::num::NonZeroU64::new(self.split.len(g) as u64 * pop),
                    }),
                });
            }
        }
        self.device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &layout, entries: &entries })
    }

    /// The bind groups of `p` with the buffers `whole` and the state array fⁿ from binding 10,
    /// one per placement of fⁿ (buffer 0 or 2: index `cur / 2`): the node-list and totals
    /// kernels make them once with their buffers, so that a running coupled step makes none.
    fn state_groups(&self, p: &wgpu::ComputePipeline, whole: &[(u32, &wgpu::Buffer)]) -> [wgpu::BindGroup; 2] {
        [0, 2].map(|c| self.bind(p, whole, &[(10, &self.f[c])]))
    }

    /// Submits one dispatch of `p` over `threads` threads on its own, with the bind group of
    /// fⁿ's placement among `groups` ([`Self::state_groups`]).
    fn submit_on_state(&self, p: &wgpu::ComputePipeline, groups: &[wgpu::BindGroup; 2], threads: u32) {
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            Self::dispatch(&mut pass, p, &groups[self.cur / 2], threads);
        }
        self.queue.submit([enc.finish()]);
    }

    fn dispatch(pass: &mut wgpu::ComputePass, p: &wgpu::ComputePipeline, bg: &wgpu::BindGroup, threads: u32) {
        if threads == 0 {
            return;
        }
        let (x, y) = groups(threads);
        pass.set_pipeline(p);
        pass.set_bind_group(0, bg, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Records one stage of [`FDLB_STEP`] (index `k`) into `pass`, and after an advection the
    /// face fluxes when they are recorded.
    fn record_stage(&self, pass: &mut wgpu::ComputePass, k: usize) {
        for (p, bg, threads) in &self.groups[self.cur / 2][k] {
            Self::dispatch(pass, &self.pipelines[*p], bg, *threads);
        }
        if let Some(ff) = &self.face_fluxes
            && FDLB_STEP[k].kind == StageKind::Advect
        {
            Self::dispatch(pass, &ff.pipeline, &ff.group, self.stride as u32);
            Self::dispatch(pass, &ff.thin.0, &ff.thin.1, ff.thin.2);
        }
    }

    /// Runs one stage on its own (for per-kernel parity tests). After the last stage of a step,
    /// call [`Self::finish_step`].
    pub fn run_stage(&mut self, stage: &Stage) {
        let k = FDLB_STEP.iter().position(|s| s == stage).expect("a stage of FDLB_STEP");
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            self.record_stage(&mut pass, k);
        }
        self.queue.submit([enc.finish()]);
    }

    /// Swaps fⁿ and fⁿ⁺¹ at the end of a step.
    pub fn finish_step(&mut self) {
        self.cur = 2 - self.cur;
        self.step_count += 1;
    }

    /// Runs `n` full steps, submitting the stage list of each step in one compute pass.
    pub fn run(&mut self, n: u64) {
        let mut done = 0;
        while done < n {
            let batch = (n - done).min(16);
            let mut enc = self.device.create_command_encoder(&Default::default());
            self.record_steps(&mut enc, batch);
            self.queue.submit([enc.finish()]);
            done += batch;
        }
    }

    /// Records `n` full steps into `enc` (one compute pass per step), e.g. Bevy's render-graph
    /// encoder; the state buffers swap as the steps are recorded.
    pub fn record_steps(&mut self, enc: &mut wgpu::CommandEncoder, n: u64) {
        for _ in 0..n {
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                for k in 0..FDLB_STEP.len() {
                    self.record_stage(&mut pass, k);
                }
            }
            self.finish_step();
        }
    }

    /// Records the probe kernel: the macroscopic state of `nodes` after the recorded steps, with
    /// the step index, into `out` (u32 words: 1 + 5 per probe, see [`codegen::probes`]).
    pub fn record_probes(&mut self, enc: &mut wgpu::CommandEncoder, nodes: &[usize], out: &wgpu::Buffer) {
        if self.probe.as_ref().is_none_or(|p| p.count != nodes.len()) {
            self.probe = Some(self.moments_at(nodes));
        }
        let p = self.probe.as_ref().unwrap();
        self.record_moments(enc, p, out);
    }

    /// The probe kernel ([`codegen::probes`]) for a fixed list of nodes: [`Self::record_moments`]
    /// writes their moments from the current populations.
    pub fn moments_at(&self, nodes: &[usize]) -> MomentsAt {
        let words: Vec<u32> = nodes.iter().map(|&n| n as u32).collect();
        MomentsAt {
            pipeline: pipeline_of(&self.device, "probes", &codegen::probes(&self.eq, self.split), "main"),
            nodes: storage(&self.device, "probe nodes", bytemuck::cast_slice(&words)),
            params: self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("probe params"),
                size: 16,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            count: nodes.len(),
        }
    }

    /// Records the moments of `m`'s nodes into `out` (at least 1 + 5 · count words: the step
    /// index, then ρ, u_x, u_y, u_z, θ per node as f32 bits, lattice units), from the
    /// populations of the last completed step.
    pub fn record_moments(&self, enc: &mut wgpu::CommandEncoder, m: &MomentsAt, out: &wgpu::Buffer) {
        self.queue.write_buffer(&m.params, 0, bytemuck::cast_slice(&[self.step_count as u32, m.count as u32, self.stride as u32, 0]));
        let bg = self.bind(&m.pipeline, &[(0, &m.params), (1, &m.nodes), (2, out)], &[(10, &self.f[self.cur])]);
        let mut pass = enc.begin_compute_pass(&Default::default());
        Self::dispatch(&mut pass, &m.pipeline, &bg, m.count.max(1) as u32);
    }

    /// Runs `steps` steps with every stage in its own compute pass bracketed by timestamps, and
    /// returns the GPU time per stage of [`FDLB_STEP`] summed over the steps (seconds), or
    /// `None` when the adapter has no timestamp queries.
    pub fn profile_stages(&mut self, ctx: &GpuContext, steps: u64) -> Option<Vec<(&'static str, f64)>> {
        if !ctx.timestamps {
            return None;
        }
        let mut timer = super::context::StageTimestamps::new(&self.device, &self.queue, FDLB_STEP.len());
        for _ in 0..steps {
            let mut enc = self.device.create_command_encoder(&Default::default());
            for (k, stage) in FDLB_STEP.iter().enumerate() {
                let mut pass = enc.begin_compute_pass(&timer.pass(k, stage.name));
                self.record_stage(&mut pass, k);
            }
            timer.resolve(&mut enc);
            self.queue.submit([enc.finish()]);
            self.finish_step();
            timer.accumulate(&self.device, &self.queue);
        }
        Some(FDLB_STEP.iter().zip(timer.total).map(|(s, t)| (s.name, t)).collect())
    }

    /// The macro buffer (ρ, ux, uy, uz, θ of every padded node, quantity k at `k · stride +
    /// node`, written by the moments pass of each RK2 stage: after a step, the moments of its
    /// second stage's predictor state, not of the populations the step ended with — those are
    /// [`Self::record_moments`]'s), the node kinds (0 = fluid) and the stride: what the tracer
    /// kernel reads without a copy.
    pub fn macro_buffers(&self) -> (&wgpu::Buffer, &wgpu::Buffer, u32) {
        (&self.mac, &self.kind, (self.mac.size() / (5 * 4)) as u32)
    }
}

impl Params {
    /// The uniform of `s`'s lattice (`stride` nodes a population array) for the first RK2 stage
    /// and no count; the dispatches' uniforms copy it with their stage or count.
    fn of(s: &FluidSolver, stride: usize) -> Self {
        let g = &s.layout.grid;
        let window = s.temperature_window();
        Params {
            n_nodes: stride as u32,
            px: g.padded[0] as u32,
            py: g.padded[1] as u32,
            pz: g.padded[2] as u32,
            nx: g.n[0] as u32,
            ny: g.n[1] as u32,
            nz: g.n[2] as u32,
            hx: g.halo[0] as u32,
            hy: g.halo[1] as u32,
            hz: g.halo[2] as u32,
            count: 0,
            stage: 1,
            dt: s.params.dt as f32,
            tau: s.params.tau as f32,
            a: s.params.a as f32,
            window_lo: window.0 as f32,
            window_hi: window.1 as f32,
            gx: s.body_force[0] as f32,
            gy: s.body_force[1] as f32,
            gz: s.body_force[2] as f32,
        }
    }
}

/// The six kernels of a step, compiled from the WGSL generated for `eq` and `split`: moments
/// and collision, advection, the ghost, face and periodic fills, the thin walls' taps.
fn pipelines(device: &wgpu::Device, eq: &Equilibrium, split: Split) -> [wgpu::ComputePipeline; 6] {
    let bsrc = codegen::boundaries(eq, split);
    [
        pipeline_of(device, "moments_collide", &codegen::moments_collide(eq, split), "main"),
        pipeline_of(device, "advect", &codegen::advect(eq, split), "main"),
        pipeline_of(device, "ghost_fill", &bsrc, "ghost_fill"),
        pipeline_of(device, "face_fill", &bsrc, "face_fill"),
        pipeline_of(device, "periodic_copy", &bsrc, "periodic_copy"),
        pipeline_of(device, "thin_wall", &codegen::thin_wall(eq, split), "main"),
    ]
}

#[cfg(test)]
mod mirror_tests {
    use super::{Entry, Params};
    use crate::fluid::{Equilibrium, GasModel, VelocitySet, VelocitySetKind};
    use crate::gpu::codegen::{Split, boundaries};
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    /// `Params` and `Entry` lay out as the generated WGSL structs (naga reflection).
    #[test]
    fn params_and_entries_match_the_shader_layout() {
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D3q39), GasModel::Diatomic);
        let src = boundaries(&eq, Split::whole(eq.values_per_node()));
        check_mirror(
            "fdlb boundaries",
            &src,
            "Params",
            mirror!(Params { n_nodes, px, py, pz, nx, ny, nz, hx, hy, hz, count, stage, dt, tau, a, window_lo, window_hi, gx, gy, gz }),
        );
        check_mirror("fdlb boundaries", &src, "Entry", mirror!(Entry { node, source, code, n_img, rho, theta, ux, uy, uz, ratio, _p0, _p1 }));
    }
}
