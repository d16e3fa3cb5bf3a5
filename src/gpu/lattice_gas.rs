//! The lattice gas on the GPU (wgpu, u32 words of two cells): one compute kernel per stage of
//! [`LATTICE_GAS_STEP`] plus a one-thread kernel that advances the step counter, so that many
//! steps are recorded in one submission. Bit-identical to the CPU twin
//! ([`crate::lattice_gas::step`]): the same tables, the same counter-based random streams.
//!
//! Buffers: the state twice (the propagation reads one and writes the other), the obstacle bits
//! per word, and the collision table as the CPU builds it (key → class, class starts, members:
//! 2.9 MB + 0.3 MB + 64 MiB).

use super::context::{GpuContext, GpuError, buffer_layout, compute_pipelines, read_buffer};
use crate::lattice_gas::collision::CollisionTable;
use crate::lattice_gas::lattice::{LatticeGas, probability_threshold};
use crate::lattice_gas::velocities::Q;
use crate::stages::{LATTICE_GAS_STEP, LatticeGasStageKind};
use wgpu::util::DeviceExt;

const WG: u32 = 64;

/// (uniform?, read-only?) per binding of the generated shader: the uniform, the step counter and
/// the two state buffers read and written, the solid mask and the collision table's three arrays
/// read-only (checked against it by the `Params` mirror test).
const LAYOUT: [(bool, bool); 8] = [(true, true), (false, false), (false, false), (false, false), (false, true), (false, true), (false, true), (false, true)];

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    row_words: u32,
    ny: u32,
    nz: u32,
    words: u32,
    seed: u32,
    interference: u32,
    inlet: u32,
    groups_x: u32,
    outlet: u32,
    diagonals: u32,
    pad: [u32; 2],
    inlet_thresholds: [u32; Q],
}

pub struct GpuLatticeGas {
    device: wgpu::Device,
    queue: wgpu::Queue,
    dims: [usize; 3],
    words: u32,
    /// Bind groups with (src, dst) = (state 0, state 1) and (state 1, state 0).
    groups: [wgpu::BindGroup; 2],
    states: [wgpu::Buffer; 2],
    step_buffer: wgpu::Buffer,
    /// One pipeline per [`Kernel`].
    pipelines: [wgpu::ComputePipeline; 6],
    /// Workgroups along x of every dispatch (as uploaded in the parameters).
    groups_x: u32,
    /// Which state buffer holds the current state.
    cur: usize,
    pub step: u32,
}

/// Converts velocity-major cell words (u16) into GPU words (two cells per u32).
fn pack(cell_words: &[u16]) -> Vec<u32> {
    cell_words.chunks(2).map(|p| p[0] as u32 | (p[1] as u32) << 16).collect()
}

/// An entry point of the generated lattice-gas shader ([`super::lattice_gas_codegen`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    Collide,
    Interfere,
    /// Collide and interfere fused (what a whole step runs).
    CollideInterfere,
    Propagate,
    Boundaries,
    AdvanceStep,
}

impl Kernel {
    const ALL: [Kernel; 6] = [Kernel::Collide, Kernel::Interfere, Kernel::CollideInterfere, Kernel::Propagate, Kernel::Boundaries, Kernel::AdvanceStep];

    fn entry(self) -> &'static str {
        match self {
            Kernel::Collide => "collide",
            Kernel::Interfere => "interfere",
            Kernel::CollideInterfere => "collide_interfere",
            Kernel::Propagate => "propagate",
            Kernel::Boundaries => "boundaries",
            Kernel::AdvanceStep => "advance_step",
        }
    }

    /// The kernel of one stage of [`LATTICE_GAS_STEP`] run on its own.
    fn of(kind: LatticeGasStageKind) -> Self {
        match kind {
            LatticeGasStageKind::Collide => Kernel::Collide,
            LatticeGasStageKind::Interfere => Kernel::Interfere,
            LatticeGasStageKind::Propagate => Kernel::Propagate,
            LatticeGasStageKind::Boundaries => Kernel::Boundaries,
        }
    }
}

fn dispatch_size(threads: u32) -> (u32, u32) {
    let groups = threads.div_ceil(WG).max(1);
    if groups <= 65_535 { (groups, 1) } else { (65_535, groups.div_ceil(65_535)) }
}

impl GpuLatticeGas {
    /// Uploads the gas (state, obstacle, parameters) and the collision table.
    pub fn new(ctx: &GpuContext, g: &LatticeGas, table: &CollisionTable) -> Result<Self, GpuError> {
        let device = ctx.device.clone();
        let cells = g.cells();
        let words = (cells / 2) as u32;
        let state_bytes = (Q * cells * 2) as u64;
        let limit = ctx.limits.max_storage_buffer_binding_size;
        for (what, bytes) in [("lattice gas state", state_bytes), ("collision table members", 4 * table.members.len() as u64)] {
            if bytes > limit {
                return Err(GpuError::TooLarge { what, bytes, limit, unit: "bytes", limit_name: "max_storage_buffer_binding_size" });
            }
        }
        let init = |label: &str, data: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: data, usage })
        };
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let packed = pack(&g.cell_words());
        let states = [init("lattice gas state 0", bytemuck::cast_slice(&packed), storage), init("lattice gas state 1", bytemuck::cast_slice(&packed), storage)];
        let solid: Vec<u32> = g.solid.chunks(2).map(|p| p[0] as u32 | (p[1] as u32) << 1).collect();
        let solid = init("obstacle bits", bytemuck::cast_slice(&solid), wgpu::BufferUsages::STORAGE);
        let step_buffer = init("step counter", bytemuck::cast_slice(&[g.step]), storage);
        let rows = (g.dims[1] * g.dims[2]) as u32;
        // every kernel flattens (x, y) with the same groups_x (that of the larger count)
        let groups_x = dispatch_size(words.max(rows)).0;
        let params = Params {
            row_words: (g.dims[0] / 2) as u32,
            ny: g.dims[1] as u32,
            nz: g.dims[2] as u32,
            words,
            seed: g.seed,
            interference: if g.interference > 0.0 { probability_threshold(g.interference) } else { 0 },
            inlet: g.inlet.is_some() as u32,
            groups_x,
            outlet: g.inlet.is_some_and(|i| i.outlet == crate::lattice_gas::lattice::Outlet::FreeStream) as u32,
            diagonals: (g.diagonals == crate::lattice_gas::lattice::Diagonals::AllPerpendicular) as u32,
            pad: [0; 2],
            inlet_thresholds: g.inlet.map(|i| i.thresholds).unwrap_or([0; Q]),
        };
        let params = init("lattice gas params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM);
        let key_class = init("class of key", bytemuck::cast_slice(&table.key_class), wgpu::BufferUsages::STORAGE);
        let start = init("class starts", bytemuck::cast_slice(&table.start), wgpu::BufferUsages::STORAGE);
        let members = init("class members", bytemuck::cast_slice(&table.members), wgpu::BufferUsages::STORAGE);
        let layout = buffer_layout(&device, "lattice gas", &LAYOUT);
        let groups = [0usize, 1].map(|s| {
            let bufs = [&params, &step_buffer, &states[s], &states[1 - s], &solid, &key_class, &start, &members];
            let entries: Vec<wgpu::BindGroupEntry> =
                bufs.iter().enumerate().map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() }).collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("lattice gas"), layout: &layout, entries: &entries })
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("lattice gas"),
            source: wgpu::ShaderSource::Wgsl(super::lattice_gas_codegen::shader().into()),
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("lattice gas"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let mut map = compute_pipelines(&device, &module, &pl, &Kernel::ALL.map(Kernel::entry));
        let pipelines = Kernel::ALL.map(|k| map.remove(k.entry()).expect("one pipeline per entry point"));
        Ok(Self { device, queue: ctx.queue.clone(), dims: g.dims, words, groups, states, step_buffer, pipelines, groups_x, cur: 0, step: g.step })
    }

    fn record_stage(&self, pass: &mut wgpu::ComputePass, kind: LatticeGasStageKind) {
        self.record_stage_on(pass, kind, self.cur);
    }

    /// Records a stage with the bind group whose `src` is state buffer `group`.
    fn record_stage_on(&self, pass: &mut wgpu::ComputePass, kind: LatticeGasStageKind, group: usize) {
        let threads = if kind == LatticeGasStageKind::Boundaries { (self.dims[1] * self.dims[2]) as u32 } else { self.words };
        self.dispatch(pass, Kernel::of(kind), group, threads);
    }

    /// Dispatches `kernel` over `threads` threads with bind group `group`.
    fn dispatch(&self, pass: &mut wgpu::ComputePass, kernel: Kernel, group: usize, threads: u32) {
        pass.set_pipeline(&self.pipelines[kernel as usize]);
        pass.set_bind_group(0, &self.groups[group], &[]);
        pass.dispatch_workgroups(self.groups_x, threads.div_ceil(WG).div_ceil(self.groups_x).max(1), 1);
    }

    /// Advances the GPU's step counter (one thread).
    fn record_advance_step(&self, pass: &mut wgpu::ComputePass) {
        pass.set_pipeline(&self.pipelines[Kernel::AdvanceStep as usize]);
        pass.set_bind_group(0, &self.groups[self.cur], &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }

    fn record_step(&mut self, enc: &mut wgpu::CommandEncoder) {
        let mut pass = enc.begin_compute_pass(&Default::default());
        // collide and interfere work on `src` in place (fused into one kernel: the same bits, one
        // pass over the state less), propagate writes `dst`, and the boundaries kernel edits
        // `dst`, which becomes the current state below
        for s in LATTICE_GAS_STEP {
            match s.kind {
                LatticeGasStageKind::Collide => self.dispatch(&mut pass, Kernel::CollideInterfere, self.cur, self.words),
                LatticeGasStageKind::Interfere => {}
                _ => self.record_stage(&mut pass, s.kind),
            }
        }
        self.record_advance_step(&mut pass);
        drop(pass);
        self.cur = 1 - self.cur;
        self.step = self.step.wrapping_add(1);
    }

    /// Runs one stage's kernel on the current state and waits (kernel parity tests); the
    /// propagation's output becomes the current state, the step counter is not advanced.
    pub fn run_single_stage(&mut self, kind: LatticeGasStageKind) {
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            // the boundaries kernel edits `dst`: bind the current state as `dst`
            let group = if kind == LatticeGasStageKind::Boundaries { 1 - self.cur } else { self.cur };
            self.record_stage_on(&mut pass, kind, group);
        }
        self.queue.submit([enc.finish()]);
        if kind == LatticeGasStageKind::Propagate {
            self.cur = 1 - self.cur;
        }
        self.wait();
    }

    /// Records and submits `n` steps (in submissions of at most 200 steps), without waiting.
    pub fn advance(&mut self, n: u64) {
        let mut left = n;
        while left > 0 {
            let chunk = left.min(200);
            let mut enc = self.device.create_command_encoder(&Default::default());
            for _ in 0..chunk {
                self.record_step(&mut enc);
            }
            self.queue.submit([enc.finish()]);
            left -= chunk;
        }
    }

    /// Blocks until the queue is idle.
    pub fn wait(&self) {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }

    /// The current state as velocity-major cell words (as [`LatticeGas::cell_words`]).
    pub fn cell_words(&self) -> Vec<u16> {
        let raw: Vec<u32> = bytemuck::cast_slice(&read_buffer(&self.device, &self.queue, &self.states[self.cur])).to_vec();
        raw.iter().flat_map(|w| [*w as u16, (*w >> 16) as u16]).collect()
    }

    /// Copies the GPU state and step into a CPU gas of the same scene. When the read fails (a
    /// lost device, no memory for the staging buffer) `g` is left as it was and false comes
    /// back.
    pub fn download_into(&self, g: &mut LatticeGas) -> bool {
        let Some(raw) = super::context::try_read_buffer(&self.device, &self.queue, &self.states[self.cur]) else { return false };
        let words: Vec<u16> = bytemuck::cast_slice::<u8, u32>(&raw).iter().flat_map(|w| [*w as u16, (*w >> 16) as u16]).collect();
        g.set_cell_words(&words);
        g.step = self.step;
        true
    }

    /// Copies the cells of rows `y0..=y1` (every X, every Z) into the same cells of `g`, a gas of
    /// the same scene, leaving its other cells and its step as they are: what a probe over a few
    /// rows reads ([`crate::scene::lattice_gas::region_velocity`]) without the whole state. Per
    /// velocity and Z layer the rows are one contiguous run of words (X fastest, X even). When
    /// the read fails `g` is left as it was and false comes back.
    pub fn download_rows_into(&self, y0: usize, y1: usize, g: &mut LatticeGas) -> bool {
        let ([nx, _, nz], n) = (g.dims, g.cells());
        // (first u16 index, count) per velocity and layer; both even (X even)
        let runs: Vec<(usize, usize)> =
            (0..Q).flat_map(|k| (0..nz).map(move |z| (k, z))).map(|(k, z)| (k * n + g.cell_index(0, y0, z), (y1 + 1 - y0) * nx)).collect();
        let ranges: Vec<(u64, u64)> = runs.iter().map(|&(a, len)| (2 * a as u64, 2 * len as u64)).collect();
        let Some(raw) = super::context::try_read_ranges(&self.device, &self.queue, &self.states[self.cur], &ranges) else { return false };
        let words: &[u16] = bytemuck::cast_slice(&raw);
        let mut at = 0;
        for &(a, len) in &runs {
            for (i, &w) in words[at..at + len].iter().enumerate() {
                g.set_cell_word((a + i) / n, (a + i) % n, w);
            }
            at += len;
        }
        true
    }

    /// The step counter as the GPU holds it (advanced by the `advance_step` kernel).
    pub fn device_step(&self) -> u32 {
        bytemuck::cast_slice::<u8, u32>(&read_buffer(&self.device, &self.queue, &self.step_buffer))[0]
    }

    /// Runs `steps` steps with every stage in its own compute pass bracketed by timestamps and
    /// returns the GPU seconds per stage of [`LATTICE_GAS_STEP`] summed over the steps, or
    /// `None` without timestamp queries.
    pub fn profile_stages(&mut self, ctx: &GpuContext, steps: u64) -> Option<Vec<(&'static str, f64)>> {
        if !ctx.timestamps {
            return None;
        }
        let mut timer = super::context::StageTimestamps::new(&self.device, &self.queue, LATTICE_GAS_STEP.len());
        for _ in 0..steps {
            let mut enc = self.device.create_command_encoder(&Default::default());
            for (i, s) in LATTICE_GAS_STEP.iter().enumerate() {
                let mut pass = enc.begin_compute_pass(&timer.pass(i, s.name));
                self.record_stage(&mut pass, s.kind);
            }
            self.record_advance_step(&mut enc.begin_compute_pass(&Default::default()));
            timer.resolve(&mut enc);
            self.queue.submit([enc.finish()]);
            self.cur = 1 - self.cur;
            self.step = self.step.wrapping_add(1);
            timer.accumulate(&self.device, &self.queue);
        }
        Some(LATTICE_GAS_STEP.iter().zip(timer.total).map(|(s, t)| (s.name, t)).collect())
    }
}

/// Times `steps` GPU steps of [`crate::lattice_gas::bench::benchmark_gas`] (after a warm-up),
/// with per-stage shares from timestamp queries when the adapter has them (the profile runs
/// collide and interfere as separate kernels; the timed steps fuse them).
pub fn lattice_gas_speed(ctx: &GpuContext, cells: [usize; 3], steps: u64, bandwidth: f64) -> Result<crate::lattice_gas::bench::LatticeGasSpeed, GpuError> {
    let table = CollisionTable::shared();
    let g = crate::lattice_gas::bench::benchmark_gas(cells);
    let mut gpu = GpuLatticeGas::new(ctx, &g, table)?;
    gpu.advance(2);
    gpu.wait();
    let t0 = std::time::Instant::now();
    gpu.advance(steps);
    gpu.wait();
    let s = t0.elapsed().as_secs_f64();
    let shares = match gpu.profile_stages(ctx, 3) {
        Some(t) => {
            let all: f64 = t.iter().map(|(_, x)| x).sum();
            t.into_iter().map(|(n, x)| (n.to_string(), x / all.max(1e-30))).collect()
        }
        None => Vec::new(),
    };
    Ok(crate::lattice_gas::bench::speed_of(false, ctx.describe(), &g, steps, s, crate::lattice_gas::bench::BYTES_PER_SITE_UPDATE, bandwidth, shares))
}

/// What one probe sample of a GPU lattice-gas run costs (best of 5): the whole state brought
/// back into the CPU mirror, as the run loop did at every sample, against a band of `rows` rows
/// (every X and Z), as it does now; in seconds and in steps of `step_s` each.
pub fn readback_cost(ctx: &GpuContext, cells: [usize; 3], rows: usize, step_s: f64) -> Result<crate::bench::ReadbackCost, GpuError> {
    let table = CollisionTable::shared();
    let mut g = crate::lattice_gas::bench::benchmark_gas(cells);
    let mut gpu = GpuLatticeGas::new(ctx, &g, table)?;
    gpu.advance(2);
    gpu.wait();
    let best = |f: &mut dyn FnMut()| crate::bench::best_of(5, f);
    let y0 = cells[1].saturating_sub(rows) / 2;
    let y1 = (y0 + rows).min(cells[1]) - 1;
    let whole_s = best(&mut || assert!(gpu.download_into(&mut g), "the state came back"));
    let gathered_s = best(&mut || assert!(gpu.download_rows_into(y0, y1, &mut g), "the rows came back"));
    let band = (y1 + 1 - y0) * cells[0] * cells[2];
    Ok(crate::bench::ReadbackCost { whole_s, gathered_s, nodes: band, whole_steps: whole_s / step_s, gathered_steps: gathered_s / step_s })
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_bindings, check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        let src = crate::gpu::lattice_gas_codegen::shader();
        check_mirror(
            "lattice_gas",
            &src,
            "Params",
            mirror!(Params { row_words, ny, nz, words, seed, interference, inlet, groups_x, outlet, diagonals, pad, inlet_thresholds }),
        );
        check_bindings("lattice_gas", &src, 0, &super::LAYOUT);
    }

    /// The kernels by name are exactly the generated shader's entry points.
    #[test]
    fn the_kernels_are_the_shaders_entry_points() {
        let src = crate::gpu::lattice_gas_codegen::shader();
        let module = crate::gpu::wgsl_check::validate("lattice_gas", &src);
        let mut entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
        let mut ours: Vec<&str> = super::Kernel::ALL.iter().map(|k| k.entry()).collect();
        entries.sort();
        ours.sort();
        assert_eq!(entries, ours);
    }
}
