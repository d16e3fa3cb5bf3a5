//! The backend that advances a solver: the CPU reference, or the GPU with the CPU solver as a
//! mirror for outputs and measurements — which receives the GPU state when an output reads it
//! (fluid, lattice gas, and the coupled solver, [`super::CoupledEngine`]) or after every
//! advance (the solid). One engine per kind of solver, each a [`Solver`], so that the run loop
//! ([`super::driver`]) treats them alike; the GPU context is picked here, above the physics core.

pub use super::mirror::Readback;
use super::mirror::{Mirror, device_failure, failed_download};
use crate::fluid::{FluidSolver, Instability};
use crate::gpu::lattice_gas::GpuLatticeGas;
use crate::gpu::solid::GpuSolid;
use crate::gpu::{DeviceHealth, GpuContext, GpuError, GpuFluid};
use crate::lattice_gas::collision::CollisionTable;
use crate::lattice_gas::lattice::LatticeGas;
use crate::lattice_gas::step::LatticeGasTimings;
use crate::lattice_gas::velocities::Q;
use crate::solid::SolidSolver;
use crate::step::{Part, Site, Solver};
use serde::Serialize;

/// Which solver backend runs the scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Backend {
    Cpu,
    Gpu,
    /// The GPU when the adapter is a real (discrete or integrated) GPU, else the CPU: a software
    /// rasteriser such as lavapipe is slower than the CPU backend.
    #[default]
    Auto,
}

/// Where the GPU backend asks method 2's level-set questions each step (each node's side of a
/// body, each ghost's wall point; f64, [`crate::gpu::level_set_queries`]): on the device, or on
/// the host's threads as the CPU backend does. The layouts are the same either way (the
/// device's kernels do the CPU's operations in its order; the answers agree to round-off,
/// tested); only the speed differs: a
/// GPU whose f64 runs at 1/32–1/64 of its f32 (most consumer cards) may answer slower than the
/// host — `bench --backend gpu` times both for the method-2 scenes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LevelSets {
    /// On the device where it has f64 in shaders, else on the host.
    #[default]
    Device,
    /// On the host's threads.
    Host,
}

/// Whether an adapter of this type is a real GPU (discrete or integrated), which `Auto` takes;
/// a software rasteriser (lavapipe) or a virtual adapter is not.
pub fn is_hardware_gpu(device_type: wgpu::DeviceType) -> bool {
    matches!(device_type, wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu)
}

/// The GPU context a run should use for `backend` (None: run on the CPU), and a line saying
/// what was chosen. `Auto` takes the GPU only when the adapter is a hardware GPU; `Gpu` fails
/// when there is no adapter.
pub fn pick_gpu(backend: Backend) -> Result<(Option<GpuContext>, String), GpuError> {
    let threads = rayon::current_num_threads();
    if backend != Backend::Cpu {
        match GpuContext::new() {
            Ok(ctx) => {
                if backend == Backend::Gpu || is_hardware_gpu(ctx.info.device_type) {
                    let name = format!("gpu: {}", ctx.describe());
                    return Ok((Some(ctx), name));
                }
                return Ok((None, format!("cpu ({threads} threads; adapter {} is not a hardware GPU)", ctx.describe())));
            }
            Err(e) if backend == Backend::Gpu => return Err(e),
            Err(_) => {}
        }
    }
    Ok((None, format!("cpu ({threads} threads)")))
}

/// The health of a device just given a solver's state: a failure during the upload (out of
/// memory, most often) refuses the run before it starts.
fn uploaded(ctx: &GpuContext) -> Result<DeviceHealth, GpuError> {
    match ctx.health.settle() {
        Some(why) => Err(GpuError::Failed(why)),
        None => Ok(ctx.health.clone()),
    }
}

/// The FDLB fluid on a backend. On the GPU the CPU solver is a mirror that receives the
/// device's state only when it is read: [`FluidEngine::state`] brings the whole state of the
/// step reached (once per step), [`FluidEngine::state_at`] only the populations of a few nodes
/// (a probe sample). An advance itself brings back nothing but the instability flag.
pub struct FluidEngine {
    solver: FluidSolver,
    gpu: Option<Box<GpuFluid>>,
    /// CPU with the populations stored in f32 ([`Self::with_f32_storage`]): the solver that
    /// steps; `solver` is then the f64 mirror the outputs read, refreshed when read.
    stored: Option<Box<FluidSolver<f32>>>,
    health: Option<DeviceHealth>,
    /// What runs it ("cpu (2 threads)", "gpu: …").
    pub name: String,
    /// GPU: what the mirror holds.
    mirror: Mirror,
}

impl FluidEngine {
    /// Picks the backend and, on the GPU, checks that `nodes` nodes of `nv` values fit the
    /// adapter's limits before `build` allocates the CPU solver (then uploads it): a lattice too
    /// large for the GPU is refused with the figure needed and the adapter's, before any
    /// allocation.
    pub fn for_scene(backend: Backend, nodes: usize, nv: usize, build: impl FnOnce() -> anyhow::Result<FluidSolver>) -> anyhow::Result<Self> {
        let (ctx, name) = pick_gpu(backend)?;
        let gpu = match ctx {
            Some(ctx) => {
                GpuFluid::fits(&ctx.limits, nodes, nv)?;
                let solver = build()?;
                let g = Box::new(GpuFluid::from_solver(&ctx, &solver)?);
                let health = Some(uploaded(&ctx)?);
                return Ok(Self::engine(solver, Some(g), health, name));
            }
            None => None,
        };
        Ok(Self::engine(build()?, gpu, None, name))
    }

    /// Picks the backend and uploads `solver` to the GPU when it is chosen.
    pub fn new(backend: Backend, solver: FluidSolver) -> Result<Self, GpuError> {
        let (ctx, name) = pick_gpu(backend)?;
        let (gpu, health) = match ctx {
            Some(ctx) => (Some(Box::new(GpuFluid::from_solver(&ctx, &solver)?)), Some(uploaded(&ctx)?)),
            None => (None, None),
        };
        Ok(Self::engine(solver, gpu, health, name))
    }

    fn engine(solver: FluidSolver, gpu: Option<Box<GpuFluid>>, health: Option<DeviceHealth>, name: String) -> Self {
        let mirror = Mirror::new(solver.step_count);
        Self { solver, gpu, health, name, mirror, stored: None }
    }

    /// On the CPU: step a copy of the state whose populations are stored in f32
    /// (`[numerics] storage = "f32"`; the outputs read the f64 mirror, refreshed from it when
    /// read). On the GPU nothing changes: the device stores f32 always.
    pub fn with_f32_storage(mut self) -> Self {
        if self.gpu.is_none() && self.stored.is_none() {
            self.stored = Some(Box::new(self.solver.converted()));
            self.name.push_str(", populations stored in f32");
        }
        self
    }

    /// The f32-stored solver's state copied into the mirror when the mirror is behind.
    fn refresh_from_f32(&mut self) {
        if let Some(st) = self.stored.as_deref()
            && self.mirror.whole != st.step_count
        {
            st.copy_state_into(&mut self.solver);
            self.mirror.whole = st.step_count;
        }
    }

    /// The whole state of the step reached. On the GPU it is brought back now unless the
    /// mirror already holds it. A read that fails (a lost device, no memory for the staging
    /// buffer) leaves the mirror as it was and returns the diagnosis, which the next advance
    /// returns too; after a device failure or an instability the mirror keeps the last state
    /// brought back ([`Self::mirror`], [`Self::mirrored_step`]).
    pub fn state(&mut self) -> Result<&FluidSolver, Instability> {
        self.refresh_from_f32();
        if let Some(g) = self.gpu.as_ref()
            && self.mirror.behind(g.step_count)
        {
            if !g.download_into(&mut self.solver) {
                return Err(self.failed_read());
            }
            self.mirror.whole = g.step_count;
            self.mirror.readback.whole_states += 1;
            self.mirror.readback.bytes += 4 * (g.n_nodes * g.nv) as u64;
        }
        self.mirror.pending(&self.solver)
    }

    /// The solver with the populations of `nodes` (padded node indices) at the step reached
    /// and its step counter and time; the other nodes as last brought back. On the GPU only
    /// these nodes cross the bus (the `gather` kernel): what a probe sample reads
    /// ([`crate::output::probes::ProbeWriter::nodes`]), bit for bit what [`Self::state`] would
    /// give at them. A failed read as in [`Self::state`].
    pub fn state_at(&mut self, nodes: &[usize]) -> Result<&FluidSolver, Instability> {
        self.refresh_from_f32();
        if let Some(g) = self.gpu.as_mut()
            && self.mirror.behind(g.step_count)
        {
            if !g.download_nodes_into(nodes, &mut self.solver) {
                return Err(self.failed_read());
            }
            self.mirror.readback.gathered += nodes.len() as u64;
            self.mirror.readback.bytes += 4 * (nodes.len() * g.nv) as u64;
        }
        self.mirror.pending(&self.solver)
    }

    /// The mirror as it is: the whole state of [`Self::mirrored_step`] (on the CPU, of the
    /// step reached).
    pub fn mirror(&self) -> &FluidSolver {
        &self.solver
    }

    /// The failed read not yet returned by an advance, if any.
    pub fn read_failure(&self) -> Option<&Instability> {
        self.mirror.read_failure.as_ref()
    }

    /// What came back from the device so far (nothing on the CPU).
    pub fn readback(&self) -> Readback {
        self.mirror.readback
    }

    fn failed_read(&mut self) -> Instability {
        let step = self.step_count();
        self.mirror.failed_read(self.health.as_ref(), step, step as f64 * self.solver.params.dt, "lattice units")
    }

    /// Whether a GPU steps it.
    pub fn is_gpu(&self) -> bool {
        self.gpu.is_some()
    }

    /// The step whose whole state the solver holds: the step reached on the CPU; on the GPU
    /// the last one [`Self::state`] brought back (the uploaded one before any).
    pub fn mirrored_step(&self) -> u64 {
        match (&self.gpu, &self.stored) {
            (None, None) => self.solver.step_count,
            _ => self.mirror.whole,
        }
    }

    /// The solver with the whole state of the step reached (see [`Self::state`]; after a
    /// failure, the last one brought back).
    pub fn into_solver(mut self) -> FluidSolver {
        let _ = self.state();
        self.solver
    }

    /// Destroys the GPU device, as a driver reset would lose it (tests of the diagnosis).
    #[doc(hidden)]
    pub fn lose_device(&self) {
        if let Some(h) = &self.health {
            h.destroy_device();
        }
    }

    /// The GPU device it runs on (tests that exhaust its memory).
    #[doc(hidden)]
    pub fn gpu_device(&self) -> Option<&wgpu::Device> {
        self.health.as_ref().map(DeviceHealth::device)
    }
}

impl Solver for FluidEngine {
    fn step(&mut self) -> Result<(), Instability> {
        self.advance(1)
    }

    fn step_count(&self) -> u64 {
        match (&self.gpu, &self.stored) {
            (Some(g), _) => g.step_count,
            (None, Some(st)) => st.step_count,
            (None, None) => self.solver.step_count,
        }
    }

    /// On the GPU: `n` steps and the device's instability flag; the state stays on the device
    /// until [`FluidEngine::state`] or [`FluidEngine::state_at`] reads it. After an instability
    /// or a device failure the mirror keeps the last state brought back.
    fn advance(&mut self, n: u64) -> Result<(), Instability> {
        if let Some(e) = self.mirror.read_failure.take() {
            return Err(e);
        }
        if let Some(st) = self.stored.as_deref_mut() {
            return st.run(n);
        }
        let Some(g) = self.gpu.as_mut() else { return self.solver.run(n) };
        let s = &self.solver;
        let kept = self.mirror.whole;
        g.run(n);
        if let Some(why) = self.health.as_ref().and_then(|h| h.settle()) {
            self.mirror.failed = true;
            return Err(device_failure(why, g.step_count, g.step_count as f64 * s.params.dt, "lattice units", n, kept));
        }
        let Ok(flag) = g.instability() else {
            // the flag could not be read: the device failed, not the air
            self.mirror.failed = true;
            let why = self.health.as_ref().and_then(|h| h.settle()).unwrap_or_else(|| "reading the instability flag back failed".into());
            return Err(device_failure(why, g.step_count, g.step_count as f64 * s.params.dt, "lattice units", n, kept));
        };
        if let Some((node, code)) = flag {
            self.mirror.failed = true;
            let quantity = GpuFluid::status_quantity(code);
            return Err(Instability {
                part: Part::Fluid,
                step: g.step_count,
                time: g.step_count as f64 * s.params.dt,
                time_unit: "lattice units",
                site: Site::Node(s.layout.grid.coords(node)),
                quantity,
                value: f64::NAN,
                reason: format!(
                    "{quantity} left its admissible range on the GPU within the last {n} steps (the last whole state brought back is step {kept}'s)"
                ),
            });
        }
        Ok(())
    }

    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        match (&self.gpu, &self.stored) {
            (Some(_), _) => Vec::new(),
            (None, Some(st)) => st.stage_shares(),
            (None, None) => self.solver.stage_shares(),
        }
    }
}

/// The MPS solid on a backend. On the GPU, [`SolidEngine::solver`] mirrors the GPU state after
/// every [`Solver::advance`].
pub struct SolidEngine {
    pub solver: SolidSolver,
    gpu: Option<GpuSolid>,
    health: Option<DeviceHealth>,
    pub name: String,
}

impl SolidEngine {
    /// Picks the backend and uploads `solver` to the GPU when it is chosen. `cg_tolerance`: the
    /// scene's `solid.cg_tolerance` when it sets one. The CPU solve (f64) takes it from the
    /// solver's options; the GPU's (f32) takes it too, and refuses one below what f32 reaches
    /// ([`GPU_CG_FLOOR`]); without one the GPU uses [`GPU_CG_DEFAULT`] (the CPU default, 10⁻⁸,
    /// is out of f32's reach).
    pub fn new(backend: Backend, solver: SolidSolver, cg_tolerance: Option<f64>) -> anyhow::Result<Self> {
        match pick_gpu(backend)? {
            (Some(ctx), name) => Self::on_device(ctx, name, solver, cg_tolerance),
            (None, name) => Ok(Self { solver, gpu: None, health: None, name }),
        }
    }

    /// `solver` uploaded to the device of `ctx` (one the caller opened, or Bevy's render device
    /// shared through [`GpuContext::shared`]), `cg_tolerance` as for [`Self::new`].
    pub fn on_device(ctx: GpuContext, name: String, mut solver: SolidSolver, cg_tolerance: Option<f64>) -> anyhow::Result<Self> {
        let mut g = GpuSolid::from_solver(&ctx, &mut solver)?;
        let health = Some(uploaded(&ctx)?);
        g.cg_tolerance = gpu_cg_tolerance(cg_tolerance)?;
        let name = with_preconditioner_note(name, &g);
        Ok(Self { solver, gpu: Some(g), health, name })
    }

    /// Iterations and relative residual of the last GPU conjugate-gradient solve (None on the
    /// CPU, whose solver reports it in `solver.last.cg`).
    pub fn gpu_last_cg(&self) -> Option<(usize, f64)> {
        self.gpu.as_ref().map(|g| g.last_cg)
    }
}

/// The backend's name, with why the device's implicit solve fell back to block Jacobi from
/// the patches, or went without the coarse space, when it did (printed as the run's backend
/// and kept in `summary.json`).
pub(super) fn with_preconditioner_note(name: String, g: &GpuSolid) -> String {
    let mut name = name;
    for why in [&g.preconditioner_note, &g.coarse_note].into_iter().flatten() {
        name = format!("{name}; implicit solve: {why}");
    }
    name
}

/// The GPU solid's CG tolerance for the scene's `solid.cg_tolerance` (see [`SolidEngine::new`]).
pub(super) fn gpu_cg_tolerance(cg_tolerance: Option<f64>) -> anyhow::Result<f64> {
    Ok(match cg_tolerance {
        Some(t) if t < GPU_CG_FLOOR => anyhow::bail!(crate::error::SceneError {
            field: "solid.cg_tolerance".into(),
            reason: format!(
                "{t:e} is below what the GPU's single-precision conjugate gradient reaches ({GPU_CG_FLOOR:e}); use at least that, or --backend cpu"
            ),
        }),
        Some(t) => t,
        None => GPU_CG_DEFAULT,
    })
}

/// The smallest relative residual the GPU's f32 conjugate gradient is asked for: a few hundred
/// ε_f32 (measured: the implicit solid's kernels agree with the CPU to 1e-6 at this tolerance).
pub const GPU_CG_FLOOR: f64 = 1e-6;
/// The GPU's tolerance when the scene sets none.
pub const GPU_CG_DEFAULT: f64 = 1e-5;

impl Solver for SolidEngine {
    fn step(&mut self) -> Result<(), Instability> {
        self.advance(1)
    }

    fn step_count(&self) -> u64 {
        self.solver.step_count
    }

    fn advance(&mut self, n: u64) -> Result<(), Instability> {
        let Some(g) = self.gpu.as_mut() else { return Solver::advance(&mut self.solver, n) };
        g.run(n);
        if let Some(why) = self.health.as_ref().and_then(|h| h.settle()) {
            let s = &self.solver;
            return Err(device_failure(why, s.step_count + n, s.time + n as f64 * s.dt, "s", n, s.step_count));
        }
        let kept = self.solver.step_count;
        if !g.download_into(&mut self.solver) {
            let s = &self.solver;
            return Err(failed_download(self.health.as_ref(), s.step_count + n, s.time + n as f64 * s.dt, "s", n, kept));
        }
        // the device's last solve and its tally stand for the CPU copy's (solid.csv's
        // cg_iterations and cg_residual columns)
        if self.solver.options.integrator == crate::solid::Integrator::Implicit {
            let (iterations, relative_residual) = g.last_cg;
            self.solver.last.cg = crate::solid::implicit::CgReport { iterations, relative_residual, converged: relative_residual <= g.cg_tolerance };
            self.solver.cg_tally = g.cg_tally;
        }
        match self.solver.non_finite() {
            None => Ok(()),
            Some(i) => Err(self.solver.instability_at(i)),
        }
    }

    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        match self.gpu {
            None => self.solver.stage_shares(),
            Some(_) => Vec::new(),
        }
    }
}

/// The integer lattice gas on a backend. It cannot go unstable (its state is bits; particle
/// number and momentum are conserved exactly by every collision), so on the CPU
/// [`Solver::step`] always succeeds (a GPU can fail). The gas's `step` is the position of its
/// random streams (`u32`, wrapping, as on the GPU); the step counter is [`Solver::step_count`].
/// On the GPU the CPU gas is a mirror that receives the device's state only when it is read:
/// [`LatticeGasEngine::state`] the whole state (once per step), [`LatticeGasEngine::state_rows`]
/// a band of rows (a probe).
pub struct LatticeGasEngine {
    gas: LatticeGas,
    table: &'static CollisionTable,
    gpu: Option<GpuLatticeGas>,
    health: Option<DeviceHealth>,
    step_count: u64,
    /// GPU: what the mirror holds (`readback.gathered`: cells of probe bands).
    mirror: Mirror,
    pub timings: LatticeGasTimings,
    pub name: String,
}

impl LatticeGasEngine {
    pub fn new(backend: Backend, gas: LatticeGas) -> Result<Self, GpuError> {
        let table = CollisionTable::shared();
        let (ctx, name) = pick_gpu(backend)?;
        let (gpu, health) = match &ctx {
            Some(ctx) => (Some(GpuLatticeGas::new(ctx, &gas, table)?), Some(uploaded(ctx)?)),
            None => (None, None),
        };
        Ok(Self { gas, table, gpu, health, step_count: 0, mirror: Mirror::new(0), timings: LatticeGasTimings::default(), name })
    }

    /// The engine of a gas restored from a checkpoint taken at step `step_count` (the gas keeps
    /// its own wrapping random-stream position).
    pub fn starting_at(mut self, step_count: u64) -> Self {
        self.step_count = step_count;
        self.mirror.whole = step_count;
        self
    }

    /// Whether a GPU steps it.
    pub fn is_gpu(&self) -> bool {
        self.gpu.is_some()
    }

    /// The whole state of the step reached (on the GPU brought back now unless the mirror
    /// holds it). A read that fails leaves the mirror as it was and returns the device's
    /// diagnosis, which the next advance returns too.
    pub fn state(&mut self) -> Result<&LatticeGas, Instability> {
        if let Some(g) = self.gpu.as_ref()
            && self.mirror.behind(self.step_count)
        {
            if !g.download_into(&mut self.gas) {
                return Err(self.failed_read());
            }
            self.mirror.whole = self.step_count;
            self.mirror.readback.whole_states += 1;
            self.mirror.readback.bytes += 2 * (Q * self.gas.cells()) as u64;
        }
        self.mirror.pending(&self.gas)
    }

    /// The gas with the cells of rows `y0..=y1` (every X and Z) at the step reached, the others
    /// as last brought back: on the GPU only that band crosses the bus. A failed read as in
    /// [`Self::state`].
    pub fn state_rows(&mut self, y0: usize, y1: usize) -> Result<&LatticeGas, Instability> {
        if let Some(g) = self.gpu.as_ref()
            && self.mirror.behind(self.step_count)
        {
            if !g.download_rows_into(y0, y1, &mut self.gas) {
                return Err(self.failed_read());
            }
            let cells = (y1 + 1 - y0) * self.gas.dims[0] * self.gas.dims[2];
            self.mirror.readback.gathered += cells as u64;
            self.mirror.readback.bytes += 2 * (Q * cells) as u64;
        }
        self.mirror.pending(&self.gas)
    }

    /// The mirror as it is (on the CPU, the state of the step reached).
    pub fn mirror(&self) -> &LatticeGas {
        &self.gas
    }

    /// The failed read not yet returned by an advance, if any.
    pub fn read_failure(&self) -> Option<&Instability> {
        self.mirror.read_failure.as_ref()
    }

    /// What came back from the device so far (nothing on the CPU).
    pub fn readback(&self) -> Readback {
        self.mirror.readback
    }

    fn failed_read(&mut self) -> Instability {
        let step = self.step_count;
        self.mirror.failed_read(self.health.as_ref(), step, step as f64, "lattice units")
    }

    /// The gas with the whole state of the step reached (after a failure, the last one brought
    /// back).
    pub fn into_gas(mut self) -> LatticeGas {
        let _ = self.state();
        self.gas
    }
}

impl Solver for LatticeGasEngine {
    fn step(&mut self) -> Result<(), Instability> {
        self.advance(1)
    }

    fn step_count(&self) -> u64 {
        self.step_count
    }

    fn advance(&mut self, n: u64) -> Result<(), Instability> {
        if let Some(e) = self.mirror.read_failure.take() {
            return Err(e);
        }
        match self.gpu.as_mut() {
            Some(g) => {
                g.advance(n);
                if let Some(why) = self.health.as_ref().and_then(|h| h.settle()) {
                    self.mirror.failed = true;
                    return Err(device_failure(why, self.step_count + n, (self.step_count + n) as f64, "lattice units", n, self.mirror.whole));
                }
            }
            None => {
                for _ in 0..n {
                    self.gas.advance_timed(self.table, &mut self.timings);
                }
            }
        }
        self.step_count += n;
        Ok(())
    }

    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        self.timings.report()
    }
}
