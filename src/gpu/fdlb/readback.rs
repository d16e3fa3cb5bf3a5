//! Reading the GPU fluid back: its arrays in the CPU's node order, its state into a CPU solver
//! (for outputs and checkpoints), the instability flag, and the comparisons the parity tests
//! use.

use super::GpuFluid;
use crate::fluid::FluidSolver;
use crate::fluid::layout::NodeKind;
use crate::fluid::storage::RowBlocked;

/// Which node array to read back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuArray {
    /// fⁿ (after a full step) — the state.
    State,
    /// f¹, the first Runge–Kutta stage's output.
    FirstStage,
    /// fⁿ⁺¹ being built by the second stage (before [`GpuFluid::finish_step`]).
    SecondStage,
    /// The advected field h of the last moments pass.
    Advected,
    /// Macro fields ρ, u_x, u_y, u_z, θ.
    Macro,
}

/// Reading the instability flag back failed (the device lost): nothing is known of the
/// steps since the last read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlagReadFailed;

impl GpuFluid {
    /// The instability flag: the first node out of range and its code
    /// ([`Self::status_quantity`]), None while every node is in range. Read through the flag's
    /// own staging buffer, so it allocates nothing; a read that fails (the device lost) is
    /// [`FlagReadFailed`], never a flag.
    pub fn instability(&self) -> Result<Option<(usize, u32)>, FlagReadFailed> {
        crate::gpu::context::try_read_into(&self.device, &self.queue, &self.status, &self.status_staging)
            .map(|raw| Self::decode_status(&raw))
            .ok_or(FlagReadFailed)
    }

    /// The buffer of the instability flag (first node out of range and its code; it stays set),
    /// for a read that brings it back with other data in one trip ([`Self::decode_status`]).
    pub fn status_buffer(&self) -> &wgpu::Buffer {
        &self.status
    }

    /// [`Self::instability`] from the bytes of [`Self::status_buffer`].
    pub fn decode_status(raw: &[u8]) -> Option<(usize, u32)> {
        let s: &[u32] = bytemuck::cast_slice(raw);
        (s[0] != u32::MAX).then(|| (s[0] as usize, s[1]))
    }

    /// The quantity a status code of [`Self::instability`] names, as the moments kernel sets it
    /// (`gpu::codegen`: 1 density, 2 velocity, 3 temperature out of its window).
    pub fn status_quantity(code: u32) -> &'static str {
        ["", "density", "velocity", "temperature"].get(code as usize).copied().unwrap_or("state")
    }

    /// Blocks until the queue is idle.
    pub fn wait(&self) {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }

    pub(super) fn read_buffer(&self, b: &wgpu::Buffer) -> Vec<u8> {
        crate::gpu::context::read_buffer(&self.device, &self.queue, b)
    }

    /// Reads an array back: structure of arrays, value v of node at `v·N + node` with N the
    /// lattice's padded node count (the GPU stride padding removed).
    pub fn download(&self, which: GpuArray) -> Vec<f32> {
        let b = match which {
            GpuArray::State => &self.f[self.cur],
            GpuArray::FirstStage => &self.f[1],
            GpuArray::SecondStage => &self.f[2 - self.cur],
            GpuArray::Advected => &self.h,
            GpuArray::Macro => &self.mac,
        };
        let raw: Vec<f32> = bytemuck::cast_slice(&self.read_buffer(b)).to_vec();
        raw.chunks(self.stride).flat_map(|c| c[..self.n_nodes].iter().copied()).collect()
    }

    /// Copies the GPU state into a CPU solver of the same scene (f64, CPU layout), with the step
    /// count and time, so that the CPU-side outputs (probes, snapshots) can be written. When the
    /// read fails (a lost device, no memory for the staging buffer) `s` is left as it was and
    /// false comes back.
    pub fn download_into(&self, s: &mut FluidSolver) -> bool {
        let Some(raw) = crate::gpu::context::try_read_buffer(&self.device, &self.queue, &self.f[self.cur]) else { return false };
        let raw: &[f32] = bytemuck::cast_slice(&raw);
        let gpu: Vec<f32> = raw.chunks(self.stride).flat_map(|c| c[..self.n_nodes].iter().copied()).collect();
        let n = self.n_nodes;
        let nv = self.nv;
        let mut vals = vec![0.0; nv];
        for node in 0..n {
            for (v, x) in vals.iter_mut().enumerate() {
                *x = gpu[v * n + node] as f64;
            }
            s.pop.scatter(&mut s.f, node, &vals);
        }
        s.step_count = self.step_count;
        s.time = self.step_count as f64 * s.params.dt;
        true
    }

    /// Largest |GPU − CPU| / scale over the fluid nodes of the state, with scale the largest
    /// |CPU value| of each population (the populations span several orders of magnitude).
    pub fn max_relative_difference(&self, cpu: &FluidSolver) -> f64 {
        compare_nodes(&self.download(GpuArray::State), cpu, &cpu.f, cpu.pop, &[NodeKind::Fluid])
    }
}

/// max over value v of (max |gpu − cpu| / max |cpu|) over the nodes whose kind is in `kinds`;
/// `gpu` as returned by [`GpuFluid::download`], `cpu_arr` an array of `cpu` in `layout`.
pub fn compare_nodes(gpu: &[f32], cpu: &FluidSolver, cpu_arr: &[f64], layout: RowBlocked, kinds: &[NodeKind]) -> f64 {
    let n = cpu.layout.grid.len();
    let nv = layout.nv;
    let mut vals = vec![0.0; nv];
    let mut scale = vec![0.0f64; nv];
    let mut diff = vec![0.0f64; nv];
    for node in 0..n {
        if !kinds.contains(&cpu.layout.kind[node]) {
            continue;
        }
        layout.gather(cpu_arr, node, &mut vals);
        for v in 0..nv {
            scale[v] = scale[v].max(vals[v].abs());
            diff[v] = diff[v].max((gpu[v * n + node] as f64 - vals[v]).abs());
        }
    }
    (0..nv).map(|v| diff[v] / scale[v].max(1e-30)).fold(0.0, f64::max)
}
