//! The coupled solver on a backend: the CPU reference, or the GPU ([`GpuCoupled`], both
//! methods) with the CPU solver as a mirror that receives the device's state only when an
//! output reads it, as [`super::FluidEngine`] does for the fluid:
//!
//! | read | what comes back |
//! |---|---|
//! | [`CoupledEngine::totals`] (a `coupling.csv` row's air mass and momentum) | one partial sum per 1024 nodes (`GpuFluid::totals`) |
//! | [`CoupledEngine::observe`] (the row's particles; a probe or glottis sample) | the solid (small beside the air) and the fluid nodes the reader lists |
//! | [`CoupledEngine::state`] (snapshots, checkpoints, the end) | the whole state, once per step |
//!
//! An advance brings back nothing the outputs read (the coupling's own stages bring back what
//! they need: the particles, method 1's traction nodes, the nodes a change of layout reads).

use super::backend::{Backend, LevelSets, gpu_cg_tolerance, pick_gpu};
use super::mirror::{Mirror, Readback, device_failure};
use crate::coupling::CoupledSolver;
use crate::fluid::{Instability, Totals};
use crate::gpu::coupled::GpuCoupled;
use crate::gpu::{DeviceHealth, GpuError};
use crate::solid::implicit::CgTally;
use crate::step::Solver;

/// The coupled solver on a backend (see the module table for what a GPU run brings back).
pub struct CoupledEngine {
    on: CoupledOn,
    health: Option<DeviceHealth>,
    pub name: String,
    /// GPU: what the mirror holds (its whole state's step).
    mirror: Mirror,
    /// GPU: the step whose solid the mirror holds.
    solid_at: u64,
}

/// Where the coupled solver runs.
enum CoupledOn {
    Cpu(Box<CoupledSolver>),
    Gpu(Box<GpuCoupled>),
}

impl CoupledEngine {
    /// Picks the backend and uploads `solver` to the GPU when it is chosen (both coupling
    /// methods; a scene the GPU backend does not run is refused by `--backend gpu` naming the
    /// field, and run on the CPU by `auto`, which says why). `cg_tolerance`: the scene's
    /// `solid.cg_tolerance`, as for [`super::SolidEngine::new`] (checked before anything is
    /// uploaded).
    pub fn new(backend: Backend, solver: CoupledSolver, cg_tolerance: Option<f64>) -> anyhow::Result<Self> {
        let (ctx, name) = pick_gpu(backend)?;
        let step = solver.step_count;
        let engine = |on, health, name| Self { on, health, name, mirror: Mirror::new(step), solid_at: step };
        let Some(ctx) = ctx else { return Ok(engine(CoupledOn::Cpu(Box::new(solver)), None, name)) };
        if let Err(why) = GpuCoupled::supports(&solver) {
            if backend == Backend::Gpu {
                return Err(why.into());
            }
            let name = format!("cpu ({} threads; the GPU backend does not run this scene: {why})", rayon::current_num_threads());
            return Ok(engine(CoupledOn::Cpu(Box::new(solver)), None, name));
        }
        Self::on_device(ctx, name, solver, cg_tolerance)
    }

    /// `solver` uploaded to the device of `ctx` (one the caller opened, or Bevy's render device
    /// shared through [`crate::gpu::GpuContext::shared`]); a scene the GPU backend does not run
    /// is refused naming the field (by [`GpuCoupled::new`]), as is a `cg_tolerance` its f32
    /// solve cannot reach.
    pub fn on_device(ctx: crate::gpu::GpuContext, name: String, solver: CoupledSolver, cg_tolerance: Option<f64>) -> anyhow::Result<Self> {
        let tolerance = gpu_cg_tolerance(cg_tolerance)?;
        let step = solver.step_count;
        let health = ctx.health.clone();
        let mut g = GpuCoupled::new(ctx, solver)?;
        g.solid.cg_tolerance = tolerance;
        if let Some(why) = health.settle() {
            return Err(GpuError::Failed(why).into());
        }
        let name = super::backend::with_preconditioner_note(name, &g.solid);
        Ok(Self { on: CoupledOn::Gpu(Box::new(g)), health: Some(health), name, mirror: Mirror::new(step), solid_at: step })
    }

    /// Where a method-2 scene on the GPU asks its level-set questions from now on; the
    /// backend's name says where they are asked (nothing changes on the CPU, or for method 1,
    /// whose walls are polygons the host builds).
    pub fn ask_level_sets(&mut self, on: LevelSets) {
        let CoupledOn::Gpu(g) = &mut self.on else { return };
        if g.cpu.exchange().is_none() {
            return;
        }
        g.device_level_sets = on == LevelSets::Device;
        let base = self.name.split("; level-set questions").next().unwrap_or_default().to_string();
        let where_ = match (g.level_sets_on_device(), on) {
            (true, _) => "on the device (f64)",
            (false, LevelSets::Host) => "on the host (as asked)",
            (false, LevelSets::Device) => "on the host (the device has no f64 in shaders)",
        };
        self.name = format!("{base}; level-set questions {where_}");
    }

    /// The mirror as it is: on the CPU the solver itself; on the GPU the CPU side of the last
    /// reads (its whole state that of [`Self::mirrored_step`]).
    pub fn solver(&self) -> &CoupledSolver {
        match &self.on {
            CoupledOn::Cpu(c) => c,
            CoupledOn::Gpu(g) => &g.cpu,
        }
    }

    /// The step whose whole state [`Self::solver`] holds.
    pub fn mirrored_step(&self) -> u64 {
        match &self.on {
            CoupledOn::Cpu(c) => c.step_count,
            CoupledOn::Gpu(_) => self.mirror.whole,
        }
    }

    /// The whole state of the step reached (on the GPU brought back now unless the mirror holds
    /// it). A failed read leaves the mirror as it was and returns the diagnosis, which the next
    /// advance returns too.
    pub fn state(&mut self) -> Result<&CoupledSolver, Instability> {
        if let CoupledOn::Gpu(g) = &mut self.on
            && self.mirror.behind(g.cpu.step_count)
        {
            let forces = g.forces_bytes();
            if !g.download_into() {
                return Err(Self::failed_read(&mut self.mirror, self.health.as_ref(), &g.cpu));
            }
            let step = g.cpu.step_count;
            (self.mirror.whole, self.solid_at) = (step, step);
            self.mirror.readback.whole_states += 1;
            self.mirror.readback.bytes += 4 * (g.fluid.n_nodes * g.fluid.nv) as u64 + g.solid.state_bytes() + forces;
        }
        self.mirror.pending(self.solver())
    }

    /// The solver with its solid and the populations of the fluid nodes `nodes` lists (given
    /// the solid of the step reached: a glottis's section moves with the folds) at the step
    /// reached; the other fluid nodes as last brought back. On the CPU the solver itself.
    pub fn observe(&mut self, nodes: impl FnOnce(&CoupledSolver) -> Vec<usize>) -> Result<&CoupledSolver, Instability> {
        if let CoupledOn::Gpu(g) = &mut self.on
            && self.mirror.behind(g.cpu.step_count)
        {
            let step = g.cpu.step_count;
            if self.solid_at != step {
                let forces = g.forces_bytes();
                if !g.download_solid() {
                    return Err(Self::failed_read(&mut self.mirror, self.health.as_ref(), &g.cpu));
                }
                self.solid_at = step;
                self.mirror.readback.bytes += g.solid.state_bytes() + forces;
            }
            let list = nodes(&g.cpu);
            if !g.fluid.download_nodes_into(&list, &mut g.cpu.fluid) {
                return Err(Self::failed_read(&mut self.mirror, self.health.as_ref(), &g.cpu));
            }
            self.mirror.readback.gathered += list.len() as u64;
            self.mirror.readback.bytes += 4 * (list.len() * g.fluid.nv) as u64;
        }
        self.mirror.pending(self.solver())
    }

    /// The air's totals (mass, momentum, energy; lattice units) at the step reached: on the
    /// GPU summed on the device (`GpuFluid::totals`, f32 partial sums: within a few 10⁻⁸ of the
    /// CPU's sums of the same state).
    pub fn totals(&mut self) -> Result<Totals, Instability> {
        match &mut self.on {
            CoupledOn::Cpu(c) => Ok(c.fluid.totals()),
            CoupledOn::Gpu(g) => {
                if let Some(e) = &self.mirror.read_failure {
                    return Err(e.clone());
                }
                match g.fluid.totals() {
                    Some(t) => {
                        self.mirror.readback.totals += 1;
                        self.mirror.readback.bytes += g.fluid.totals_bytes();
                        Ok(t)
                    }
                    None => Err(Self::failed_read(&mut self.mirror, self.health.as_ref(), &g.cpu)),
                }
            }
        }
    }

    /// What came back from the device for the outputs (nothing on the CPU).
    pub fn readback(&self) -> Readback {
        self.mirror.readback
    }

    /// The air on the device (None on the CPU), for kernels that read it in place: the Bevy
    /// plugin's tracers and slices.
    pub fn gpu_fluid(&self) -> Option<&crate::gpu::GpuFluid> {
        match &self.on {
            CoupledOn::Cpu(_) => None,
            CoupledOn::Gpu(g) => Some(&g.fluid),
        }
    }

    /// The implicit solid's CG solves so far on whichever backend steps it (none with the
    /// explicit solid), and the last one's iterations and relative residual.
    pub fn cg(&self) -> (CgTally, (usize, f64)) {
        match &self.on {
            CoupledOn::Cpu(c) => (c.solid.cg_tally, (c.solid.last.cg.iterations, c.solid.last.cg.relative_residual)),
            CoupledOn::Gpu(g) => (g.solid.cg_tally, g.solid.last_cg),
        }
    }

    /// Whether a GPU steps it.
    pub fn is_gpu(&self) -> bool {
        matches!(self.on, CoupledOn::Gpu(_))
    }

    fn failed_read(mirror: &mut Mirror, health: Option<&DeviceHealth>, c: &CoupledSolver) -> Instability {
        mirror.failed_read(health, c.step_count, c.time, "s")
    }
}

impl Solver for CoupledEngine {
    fn step(&mut self) -> Result<(), Instability> {
        self.advance(1)
    }

    fn step_count(&self) -> u64 {
        self.solver().step_count
    }

    /// On the GPU: `n` coupled steps; nothing comes back for the outputs until they read it. When
    /// a step goes unstable the whole state of the failed step is brought back (the run loop
    /// writes it as its last snapshot).
    fn advance(&mut self, n: u64) -> Result<(), Instability> {
        if let Some(e) = self.mirror.read_failure.take() {
            return Err(e);
        }
        let g = match &mut self.on {
            CoupledOn::Cpu(c) => return c.run(n),
            CoupledOn::Gpu(g) => g,
        };
        let kept = self.mirror.whole;
        let r = g.run(n);
        if let Some(why) = self.health.as_ref().and_then(|h| h.settle()) {
            self.mirror.failed = true;
            let c = &g.cpu;
            return Err(device_failure(why, c.step_count, c.time, "s", n, kept));
        }
        if r.is_err() {
            let _ = self.state();
            self.mirror.failed = true;
        }
        r
    }

    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        match &self.on {
            CoupledOn::Cpu(c) => c.stage_shares(),
            CoupledOn::Gpu(g) => g.stage_shares(),
        }
    }
}
