//! Method 2's coupling kernels on the GPU (shaders/coupling.wgsl, f32): the level set of a body's
//! particles with its gradient and wall velocity at query points (2.124–2.126, 2.130; CPU twin
//! [`KernelLevelSet::level`] and [`KernelLevelSet::velocity_at`]), and the hand-over of each wall
//! node's momentum to the particles within r_e with kernel weights normalised per node
//! (2.127–2.128; CPU twin: the `momentum_exchange` stage of `coupling::conserving`) as two
//! gathers — per node the weights' sum, per particle its shares — deterministic, no atomics.
//!
//! These kernels are checked against their twins (tests/gpu/). The face-flux record of the
//! fluid step (what each wall node takes out of the air, 2.122–2.123) is a kernel of the GPU
//! fluid ([`super::GpuFluid::record_face_fluxes`]). The coupled step that strings them together
//! is [`super::coupled::GpuCoupled`].

use super::context::{GpuContext, buffer_layout, compute_pipelines, split_read, try_read_parts_into};
use super::growing::{GrowingBuffer, KeptBindGroup};
use crate::fluid::{Grid, KernelLevelSet};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, DVec4};
use wgpu::util::DeviceExt;

const SHADER: &str = include_str!("../../shaders/coupling.wgsl");

/// (uniform?, read-only?) per binding of the shader: the uniform, then storage bindings 1–13
/// (checked against it by the `Params` mirror test).
const LAYOUT: [(bool, bool); 14] = [
    (true, true),
    (false, true),
    (false, true),
    (false, true),
    (false, true),
    (false, true),
    (false, false),
    (false, false),
    (false, false),
    (false, false),
    (false, true),
    (false, true),
    (false, false),
    (false, true),
];

/// The kernels' uniform (`Params` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    padded: [u32; 4],
    halo: [u32; 4],
    re: f32,
    r_min: f32,
    phi: f32,
    factor: f32,
    count: u32,
    sets: u32,
    _pad1: u32,
    _pad2: u32,
}

/// One body's level set as the kernels find it (`SetGrid` in the shader): its bins' box and
/// counts, and where its points and bins start in the joint arrays.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct SetGrid {
    lo: [f32; 4],
    hi: [f32; 4],
    /// Bins per axis, .w the set's number of points.
    bins: [u32; 4],
    /// .x the set's first point, .y its first entry of the joint `bin_start`.
    first: [u32; 4],
}

/// The level sets of one call, one after the other, as the kernels read them (bindings 1–4 and
/// 13): each set's bin lists keep their own numbering, `SetGrid::first` places them.
#[derive(Default)]
struct JointSets {
    grids: Vec<SetGrid>,
    points: Vec<[f32; 4]>,
    velocities: Vec<[f32; 4]>,
    start: Vec<u32>,
    order: Vec<u32>,
}

impl JointSets {
    /// The sets in order (all with the same kernel radius and r_min, as one scene's bodies have).
    fn new(sets: &[&KernelLevelSet]) -> Self {
        let mut j = JointSets::default();
        for s in sets {
            assert!(s.re == sets[0].re && s.r_min == sets[0].r_min, "the sets of one call share their kernel");
            let (lo, hi, bins) = s.bin_box();
            let (start, order) = s.bin_lists();
            let first = [j.points.len() as u32, j.start.len() as u32, 0, 0];
            j.grids.push(SetGrid { lo: v4(lo), hi: v4(hi), bins: [bins[0] as u32, bins[1] as u32, bins[2] as u32, s.points.len() as u32], first });
            j.points.extend(s.points.iter().map(|p| v4(*p)));
            j.velocities.extend(s.velocities().iter().map(|p| v4(*p)));
            j.start.extend_from_slice(start);
            j.order.extend_from_slice(order);
        }
        j
    }
}

/// One kernel of shaders/coupling.wgsl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    LevelSetAt,
    AddNodeChanges,
    ExchangeWeights,
    ExchangeGather,
}

impl Kernel {
    const ALL: [Kernel; 4] = [Kernel::LevelSetAt, Kernel::AddNodeChanges, Kernel::ExchangeWeights, Kernel::ExchangeGather];
    /// The WGSL entry point.
    fn entry(self) -> &'static str {
        match self {
            Kernel::LevelSetAt => "level_set_at",
            Kernel::AddNodeChanges => "add_node_changes",
            Kernel::ExchangeWeights => "exchange_weights",
            Kernel::ExchangeGather => "exchange_gather",
        }
    }
}

/// Number of buffer bindings after the uniform (bindings 1–13 of shaders/coupling.wgsl).
const BINDINGS: usize = 13;
/// The binding of the wall momentum per node.
const WALL: usize = 7;
/// The binding of the per-workgroup sums of the exchange's diagnostics.
const DIAG_PARTIALS: usize = 12;

/// What one hand-over's wall nodes add to the exchange's run sums (lattice units; CPU twin: the
/// sums of method 2's `momentum_exchange` stage, [`crate::coupling::conserving::Exchange`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExchangeDiagnostics {
    /// Momentum of the nodes with no particle within r_e (walls that are no coupled body).
    pub walls: DVec3,
    /// Mass the wall nodes took out of the air.
    pub mass: f64,
    /// Σ (p − u_w m): the momentum the walls took in their own frame.
    pub wall_frame: DVec3,
}

/// Workgroups of 64 that [`CouplingKernels::run`] dispatches for `count` threads.
fn workgroups(count: u32) -> u32 {
    let w = count.div_ceil(64).max(1);
    if w <= 65_535 { w } else { 65_535 * w.div_ceil(65_535) }
}

/// What a binding holds for one call.
enum Binding<'a> {
    /// These bytes, written into the binding's own buffer ([`Buffers`]).
    Data(&'a [u8]),
    /// The binding's own buffer with room for this many bytes, which the call's kernels write
    /// in full before anything reads them (nothing goes up).
    Output(u64),
    /// The binding's own buffer as it is (the kernels of the call do not touch it).
    Unused,
    /// A buffer that lives on the device (the fluid's face-flux record, the scaled array).
    Resident(&'a wgpu::Buffer),
}

/// The buffers the kernels' calls reuse: each binding's own (rewritten per call, remade only
/// when a call's data outgrow it), the uniform with each kernel's parameters beside it, the
/// staging buffer of the reads, and the bind group with the buffers it binds (made again only
/// when one of them changed).
struct Buffers {
    params: wgpu::Buffer,
    /// Each kernel's parameters of a call, one after the other, copied into `params` before it.
    per_kernel: GrowingBuffer,
    data: Vec<GrowingBuffer>,
    staging: GrowingBuffer,
    group: KeptBindGroup,
}

impl Buffers {
    fn new(device: &wgpu::Device) -> Self {
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        Buffers {
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("coupling params"),
                size: std::mem::size_of::<Params>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            // room for every kernel's parameters in one call
            per_kernel: GrowingBuffer::with_room(
                device,
                "coupling kernel params",
                wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                (Kernel::ALL.len() * std::mem::size_of::<Params>()) as u64,
            ),
            // 4 KiB each to start with: a few hundred particles' or changed nodes' entries
            data: (0..BINDINGS).map(|_| GrowingBuffer::with_room(device, "coupling", storage, 4096)).collect(),
            staging: GrowingBuffer::with_room(device, "coupling readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST, 0),
            group: KeptBindGroup::default(),
        }
    }

    /// Buffers made so far (each growing buffer's first one included).
    fn made(&self) -> u64 {
        self.per_kernel.made() + self.staging.made() + self.data.iter().map(GrowingBuffer::made).sum::<u64>()
    }
}

/// The compiled kernels (one pipeline layout, pipelines indexed by `Kernel`) and the buffers
/// their calls reuse (`Buffers`; with the per-node scaled momentum): a hand-over of a
/// running coupled scene makes no buffer or bind group ([`Self::objects_made`]).
pub struct CouplingKernels {
    pipelines: [wgpu::ComputePipeline; 4],
    layout: wgpu::BindGroupLayout,
    /// `exchange_weights`' output, one vec4 per node, reused while the lattice fits in it.
    scaled: std::sync::Mutex<Option<wgpu::Buffer>>,
    /// Made at the first call.
    buffers: std::sync::Mutex<Option<Buffers>>,
}

fn v4(p: [f64; 3]) -> [f32; 4] {
    [p[0] as f32, p[1] as f32, p[2] as f32, 0.0]
}

impl CouplingKernels {
    pub fn new(ctx: &GpuContext) -> Self {
        let device = &ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("coupling"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = buffer_layout(device, "coupling", &LAYOUT);
        let pl =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("coupling"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let mut map = compute_pipelines(device, &module, &pl, &Kernel::ALL.map(Kernel::entry));
        let pipelines = Kernel::ALL.map(|k| map.remove(k.entry()).expect("one pipeline per entry point"));
        CouplingKernels { pipelines, layout, scaled: std::sync::Mutex::new(None), buffers: std::sync::Mutex::new(None) }
    }

    /// The parameters of `sets` (their kernel; φ of a single set, 0 for several).
    fn params(sets: &[&KernelLevelSet]) -> Params {
        let first = sets.first().expect("at least one level set");
        Params {
            re: first.re as f32,
            r_min: first.r_min as f32,
            phi: if sets.len() == 1 { first.phi as f32 } else { 0.0 },
            sets: sets.len() as u32,
            ..Default::default()
        }
    }

    /// Buffers and bind groups the calls have made so far: the same after a call means the call
    /// made none (the scaled array counts once made).
    pub fn objects_made(&self) -> u64 {
        let b = self.buffers.lock().expect("the buffers' lock");
        let scaled = self.scaled.lock().expect("the scaled buffer's lock").is_some() as u64;
        b.as_ref().map_or(0, |b| b.made() + b.group.made()) + scaled
    }

    /// Runs `kernels` in order over `count` threads each, with the given bindings, then clears
    /// the bindings named in `clear` and reads back those named in `read` (a binding of data:
    /// as many bytes as the data; a resident buffer: all of it), in one trip.
    fn run(&self, ctx: &GpuContext, p: Params, data: [Binding; BINDINGS], kernels: &[(Kernel, u32)], clear: &[usize], read: &[usize]) -> Vec<Vec<u8>> {
        let (device, queue) = (&ctx.device, &ctx.queue);
        let mut guard = self.buffers.lock().expect("the buffers' lock");
        let b = guard.get_or_insert_with(|| Buffers::new(device));
        for (buf, d) in b.data.iter_mut().zip(&data) {
            match d {
                Binding::Data(d) => {
                    buf.write(device, queue, d);
                }
                Binding::Output(bytes) => {
                    buf.reserve(device, *bytes);
                }
                Binding::Unused | Binding::Resident(_) => {}
            }
        }
        // each kernel's thread count goes in through its own copy of the parameters
        let size = std::mem::size_of::<Params>() as u64;
        let each: Vec<Params> = kernels.iter().map(|&(_, count)| Params { count, ..p }).collect();
        b.per_kernel.write(device, queue, bytemuck::cast_slice(&each));
        // binding k (0 the uniform)
        let bound: Vec<wgpu::Buffer> = std::iter::once(b.params.clone())
            .chain(data.iter().zip(&b.data).map(|(d, own)| match d {
                Binding::Resident(r) => (*r).clone(),
                _ => own.buffer().clone(),
            }))
            .collect();
        let group = b.group.over(device, &self.layout, "coupling", &bound);
        let mut enc = device.create_command_encoder(&Default::default());
        for (i, &(kernel, count)) in kernels.iter().enumerate() {
            enc.copy_buffer_to_buffer(b.per_kernel.buffer(), i as u64 * size, &b.params, 0, size);
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(kernel.entry()), timestamp_writes: None });
            pass.set_pipeline(&self.pipelines[kernel as usize]);
            pass.set_bind_group(0, group, &[]);
            let w = workgroups(count);
            if w <= 65_535 { pass.dispatch_workgroups(w, 1, 1) } else { pass.dispatch_workgroups(65_535, w / 65_535, 1) }
        }
        for &k in clear {
            enc.clear_buffer(&bound[k], 0, None);
        }
        let lengths: Vec<u64> = read
            .iter()
            .map(|&k| match &data[k - 1] {
                Binding::Data(d) => d.len() as u64,
                Binding::Output(bytes) => *bytes,
                _ => bound[k].size(),
            })
            .collect();
        let parts: Vec<(&wgpu::Buffer, u64, u64)> = read.iter().zip(&lengths).map(|(&k, &len)| (&bound[k], 0, len)).collect();
        b.staging.reserve(device, lengths.iter().sum());
        let all = try_read_parts_into(device, queue, enc, &parts, b.staging.buffer()).unwrap_or_else(|| vec![0; lengths.iter().sum::<u64>() as usize]);
        split_read(&all, lengths)
    }

    /// L, ∇L, the wall velocity and Σw at each of `queries` (lattice coordinates): the GPU twin of
    /// [`KernelLevelSet::level`] and [`KernelLevelSet::velocity_at`].
    pub fn level_set_at(&self, ctx: &GpuContext, set: &KernelLevelSet, queries: &[[f64; 3]]) -> Vec<(f64, DVec3, DVec3, f64)> {
        let joint = JointSets::new(&[set]);
        let q: Vec<[f32; 4]> = queries.iter().map(|p| v4(*p)).collect();
        let data = [
            Binding::Data(bytemuck::cast_slice(&joint.points)),
            Binding::Data(bytemuck::cast_slice(&joint.velocities)),
            Binding::Data(bytemuck::cast_slice(&joint.start)),
            Binding::Data(bytemuck::cast_slice(&joint.order)),
            Binding::Data(bytemuck::cast_slice(&q)),
            Binding::Output(32 * queries.len() as u64),
            Binding::Unused,
            Binding::Unused,
            Binding::Unused,
            Binding::Unused,
            Binding::Unused,
            Binding::Unused,
            Binding::Data(bytemuck::cast_slice(&joint.grids)),
        ];
        let bytes = self.run(ctx, Self::params(&[set]), data, &[(Kernel::LevelSetAt, queries.len() as u32)], &[], &[6]);
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
    /// `momentum_exchange` stage, with the wall momentum uploaded ([`Self::hand_over`] takes it
    /// from a buffer on the device).
    pub fn momentum_to_particles(&self, ctx: &GpuContext, set: &KernelLevelSet, grid: &Grid, wall: &[DVec4], factor: f64) -> Vec<DVec3> {
        assert_eq!(wall.len(), grid.len(), "one wall value per lattice node");
        let w: Vec<[f32; 4]> = wall.iter().map(|v| [v.x as f32, v.y as f32, v.z as f32, v.w as f32]).collect();
        let buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("wall momentum"),
            contents: bytemuck::cast_slice(&w),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        self.hand_over(ctx, &[set], grid, &buffer, &[], factor).0
    }

    /// Method 2's momentum_exchange stage with the wall momentum on the device: `wall` holds one
    /// `vec4<f32>` per node of `grid` (at least; the GPU fluid's face-flux record,
    /// [`super::GpuFluid::face_flux_buffer`]); the geometry stage's node changes `changes`
    /// (node, momentum and mass, lattice units) are added to it, each node's momentum goes to
    /// the particles of `sets` (the bodies' level sets, in order: the weights are normalised over
    /// all of them at once, as the CPU's stage does) within r_e with normalised kernel weights, and
    /// `wall` is cleared for the next step. The sets (their points, velocities and bins, as they
    /// are: nothing is binned again) and the node changes go up, and the particles' forces
    /// (×`factor`, the sets' points in order) come back,
    /// with the nodes' contributions to the exchange's run sums (summed per workgroup on the
    /// device, 32 B per 64 nodes, and over the workgroups here in f64).
    pub fn hand_over(
        &self,
        ctx: &GpuContext,
        sets: &[&KernelLevelSet],
        grid: &Grid,
        wall: &wgpu::Buffer,
        changes: &[(usize, DVec4)],
        factor: f64,
    ) -> (Vec<DVec3>, ExchangeDiagnostics) {
        assert!(wall.size() >= (16 * grid.len()) as u64, "one wall value per lattice node");
        let joint = JointSets::new(sets);
        // distinct nodes, so that no two threads of add_node_changes write one entry
        let mut merged: Vec<(usize, DVec4)> = changes.to_vec();
        merged.sort_by_key(|c| c.0);
        merged.dedup_by(|b, a| {
            let same = a.0 == b.0;
            if same {
                a.1 += b.1;
            }
            same
        });
        let change_momentum: Vec<[f32; 4]> = merged.iter().map(|(_, v)| [v.x as f32, v.y as f32, v.z as f32, v.w as f32]).collect();
        let change_node: Vec<u32> = merged.iter().map(|(n, _)| u32::try_from(*n).expect("node index fits u32")).collect();
        let mut guard = self.scaled.lock().expect("the scaled buffer's lock");
        if guard.as_ref().is_none_or(|b| b.size() < wall.size()) {
            *guard = Some(ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("scaled wall momentum"),
                size: wall.size(),
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            }));
        }
        let scaled = guard.as_ref().expect("made above");
        let mut p = Self::params(sets);
        p.padded = [grid.padded[0] as u32, grid.padded[1] as u32, grid.padded[2] as u32, 0];
        p.halo = [grid.halo[0] as u32, grid.halo[1] as u32, grid.halo[2] as u32, 0];
        p.factor = factor as f32;
        let n = joint.points.len();
        let data = [
            Binding::Data(bytemuck::cast_slice(&joint.points)),
            Binding::Data(bytemuck::cast_slice(&joint.velocities)),
            Binding::Data(bytemuck::cast_slice(&joint.start)),
            Binding::Data(bytemuck::cast_slice(&joint.order)),
            // the gather reads the particles' positions from `points` (binding 1)
            Binding::Unused,
            Binding::Unused,
            Binding::Resident(wall),
            Binding::Resident(scaled),
            Binding::Output(16 * n as u64),
            Binding::Data(bytemuck::cast_slice(&change_momentum)),
            Binding::Data(bytemuck::cast_slice(&change_node)),
            // two vec4 per workgroup of `exchange_weights`
            Binding::Output(32 * workgroups(grid.len() as u32) as u64),
            Binding::Data(bytemuck::cast_slice(&joint.grids)),
        ];
        let mut kernels = Vec::new();
        if !merged.is_empty() {
            kernels.push((Kernel::AddNodeChanges, merged.len() as u32));
        }
        kernels.extend([(Kernel::ExchangeWeights, grid.len() as u32), (Kernel::ExchangeGather, n as u32)]);
        let bytes = self.run(ctx, p, data, &kernels, &[WALL], &[9, DIAG_PARTIALS]);
        let f: &[[f32; 4]] = bytemuck::cast_slice(&bytes[0]);
        let forces = f.iter().map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)).collect();
        let d: &[[f32; 4]] = bytemuck::cast_slice(&bytes[1]);
        let mut diag = ExchangeDiagnostics::default();
        for pair in d.chunks_exact(2) {
            let (a, b) = (pair[0].map(f64::from), pair[1].map(f64::from));
            diag.walls += DVec3::new(a[0], a[1], a[2]);
            diag.mass += a[3];
            diag.wall_frame += DVec3::new(b[0], b[1], b[2]);
        }
        (forces, diag)
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::{Params, SetGrid};
    use crate::gpu::wgsl_check::{check_bindings, check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror("shaders/coupling.wgsl", super::SHADER, "Params", mirror!(Params { padded, halo, re, r_min, phi, factor, count, sets, _pad1, _pad2 }));
        check_bindings("shaders/coupling.wgsl", super::SHADER, 0, &super::LAYOUT);
    }

    #[test]
    fn set_grid_matches_the_shader_layout() {
        check_mirror("shaders/coupling.wgsl", super::SHADER, "SetGrid", mirror!(SetGrid { lo, hi, bins, first }));
    }
}
