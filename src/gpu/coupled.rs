//! The coupled step with the fluid and the solid on the GPU: the GPU twin of [`CoupledSolver`]
//! stepping its coupling's stage list — [`crate::stages::COUPLED_CONSERVING_STEP`] (method 2, seed
//! 000 §2.4.2) or [`crate::stages::COUPLED_WEAK_STEP`] (method 1, §2.4.1).
//!
//! Method 2:
//!
//! | stage | where it runs |
//! |---|---|
//! | `fluid_geometry` | the particles' positions and velocities come back (16 B each); the level sets' layout (ghost depths, normals, wall velocities, 2.124–2.126, 2.130) is built on the CPU ([`CoupledSolver::next_level_set_walls`]) — its costliest parts, the nodes' sides and the ghosts' wall points, answered on the device where it has f64 ([`LevelSetKernels`], one trip per body and question) — and its tables uploaded ([`GpuFluid::set_geometry`]); on a step where nodes change side, the populations of the nodes the change reads (those that change side and the fresh ones' neighbours, [`LayoutChange::reads`]) come back by the `gather` kernel so that covered nodes book their momentum and fresh ones take their neighbours' mean on the CPU, and the fresh nodes go up by the `scatter` kernel ([`GpuCoupled::round_trips`], [`GpuCoupled::round_trip_nodes`] count them) |
//! | `fluid` | one FDLB step on the GPU with the walls' face fluxes recorded after each advection (2.122–2.123, [`GpuFluid::record_face_fluxes`]) |
//! | `momentum_exchange` | the geometry stage's node changes (a short list, on steps where nodes change side) added to the face-flux record on the device; each wall node's momentum handed to the particles within r_e with normalised kernel weights (2.127–2.128) by the gather kernels of [`CouplingKernels::hand_over`] (deterministic, no atomics), the record cleared there; only the particles' forces come back, as their loads, with the exchange's run sums per workgroup |
//! | `solid` | the solid's sub-steps on the GPU ([`GpuSolid`]) with those loads and the air's added mass (2.129) |
//!
//! Method 1:
//!
//! | stage | where it runs |
//! |---|---|
//! | `fluid_geometry` | the particles come back (with their spins and rotations: the surface points turn with them); the surface polygons' walls are built on the CPU ([`CoupledSolver::next_polygon_walls`]) and their tables uploaded; on a step where nodes change side the nodes the change reads come back and the fresh nodes, filled with their neighbours' mean on the CPU ([`CoupledSolver::install_polygon_walls`]), go up, as for method 2 |
//! | `fluid` | one FDLB step on the GPU |
//! | `surface_traction` | the pieces' plan goes up ([`CoupledSolver::traction_plan`]: normals, wall velocities, the stencils of the samples at one and two cells along each normal, the particles' shares — made on the CPU from the particles it holds); on the device the traction kernels sample the air, make each piece's force (2.110–2.112) and write the surface particles' loads into the solid's load buffer (2.113) ([`GpuFluid::surface_traction`]); nothing comes back — the pieces' forces only when an output reads the solid ([`GpuCoupled::download_solid`]) |
//! | `solid` | the solid's explicit sub-steps on the GPU |
//!
//! What stays on the CPU is the geometry (a per-step layout build over the lattice, O(N)),
//! measured as the `fluid_geometry` share of the step, and for method 1 the traction's plan
//! (O(surface)). Method 1's traction brings nothing back ([`GpuCoupled::traction_nodes`] counts
//! the nodes its samples read on the device); for method 2 the wall momentum per node no
//! longer crosses the bus. The exchange's diagnostics
//! that the CPU solver sums over the run (momentum to non-body walls, mass to the walls, the
//! wall-frame momentum) are summed per workgroup by the hand-over's first kernel and over the
//! workgroups on the CPU (32 B per 64 nodes come back). Bodies with a
//! prescribed motion are moved by the CPU after every solid sub-step, as the CPU solver does,
//! and only their particles' kinematics are written to the device
//! ([`GpuSolid::upload_kinematics`]).
//!
//! A step waits for the device only where it reads something back: the particles for the
//! geometry (one trip for all their arrays, with the fluid's instability flag of the step
//! before), and for method 2 the hand-over's forces and, where the device answers the level
//! sets' questions, their answers (two per body); the fluid step, method 1's traction and the
//! solid's sub-steps are only submitted. The flag stays set once a node leaves its range, so
//! reading it one step late loses nothing: the diagnosis names the step whose fluid stage failed
//! ([`GpuCoupled::run`] reads the last step's flag before it returns, so a run never ends on an
//! unchecked step). One step in [`GpuCoupled::timing_every`] waits for the device before its
//! first stage (untimed) and after every stage as well, so that the per-stage times
//! ([`GpuCoupled::stage_shares`]) are the stages' own. (Until 2026-12-05 it did not wait before
//! the first stage: the previous step's solid sub-steps, still running on the device when the
//! timed step began, were timed as that step's `fluid_geometry`, whose read of the particles
//! waits for them.)

use super::context::{GpuContext, GpuError};
use super::coupling::CouplingKernels;
use super::fdlb::GpuFluid;
use super::level_set_queries::LevelSetKernels;
use super::solid::GpuSolid;
use crate::coupling::{CoupledSolver, Method, WeakOptions};
use crate::fluid::{KernelLevelSet, LayoutChange};
use crate::stages::CoupledStageKind;
use crate::step::{Instability, Part, Site};
use glam::DVec3;
use std::time::{Duration, Instant};

/// Steps between two steps timed stage by stage ([`GpuCoupled::timing_every`]).
pub const TIMING_EVERY: u64 = 16;

/// The parts of the `fluid_geometry` stage timed apart on the timed steps
/// ([`GpuCoupled::geometry_parts`]): the wait for the particles (and the fluid's flag of the
/// step before), the walls built on the CPU (level sets or polygons, the layout near the bodies),
/// the populations of the nodes that change side across the bus (steps with changes only), and
/// the boundary tables made from the layout and written to the device; and (method 2), of the
/// walls, the level sets' questions answered on the device ([`LevelSetKernels`]: the uploads, the
/// kernel and the read back), not counted in the second part.
pub const GEOMETRY_PARTS: [&str; 5] =
    ["particles back", "walls built on the CPU", "changed nodes across the bus", "tables written", "level-set questions on the device"];

/// The host's own work in a GPU coupled step ([`GpuCoupled::host_work_per_step`]): the walls
/// built on the CPU, the boundary tables written for the device, method 1's traction plan.
pub const HOST_PARTS: [&str; 3] = ["walls built on the CPU", "tables written", "traction plan on the CPU"];

/// Fluid and solid of a coupled scene on the GPU (either coupling method).
pub struct GpuCoupled {
    /// The CPU side: the scene's solver, which holds the geometry (layout, level sets), the
    /// exchange's bookkeeping, the scene's loads and the step counter. Its particles are
    /// brought from the GPU at every step; its fluid populations at the nodes a change of
    /// layout reads, (method 1) at the nodes the traction samples, and all of them by
    /// [`Self::download_into`].
    pub cpu: CoupledSolver,
    pub fluid: GpuFluid,
    pub solid: GpuSolid,
    kernels: CouplingKernels,
    ctx: GpuContext,
    /// Wall time per stage of the coupling's stage list over the timed steps (one in
    /// [`Self::timing_every`]: on those each stage ends with a wait on the device, so the times
    /// are the stages' own; the other steps wait only where they read data back).
    pub timings: Vec<Duration>,
    /// Every this many steps one is timed stage by stage (1: every step, each stage then waits
    /// for the device — the stage timings of every step at the cost of one wait per stage).
    pub timing_every: u64,
    /// Steps on which nodes changed side, so that the populations of the nodes the change
    /// reads came back and those of the fresh nodes went up.
    pub round_trips: u64,
    /// Nodes whose populations crossed the bus for those changes (both ways).
    pub round_trip_nodes: u64,
    /// A change of layout brings the whole state back and sends it all up again instead of the
    /// nodes it reads and writes: the reference the node lists are checked against (the device
    /// ends bit for bit the same), off by default.
    pub whole_round_trips: bool,
    /// The particles of the bodies with a prescribed motion (ascending).
    prescribed: Vec<usize>,
    /// Stencil entries (node reads) method 1's traction kernels made on the device, summed over
    /// the steps; none of them crosses the bus.
    pub traction_nodes: u64,
    /// Method 1: the plan of the last traction stage, whose pieces' forces the device holds,
    /// and whether [`Self::cpu`]'s forces are older than them.
    traction_plan: Option<crate::coupling::traction_plan::TractionPlan>,
    forces_stale: bool,
    /// The step and time of a fluid stage whose instability flag has not been read yet (read
    /// with the next step's particles, or by [`Self::check_fluid`]).
    fluid_unchecked: Option<(u64, f64)>,
    /// Wall time of each of [`GEOMETRY_PARTS`] over the timed steps (a part of the
    /// `fluid_geometry` entry of [`Self::timings`]).
    pub geometry_parts: [Duration; 5],
    /// Method 2's level-set questions (the nodes' sides, the ghosts' wall points) answered on
    /// the device, where it has f64 in shaders.
    level_sets: Option<LevelSetKernels>,
    /// Whether method 2's level-set questions (the nodes' sides, the ghosts' wall points) are
    /// answered on the device (when it can: see [`Self::level_sets_on_device`]); true by
    /// default, false to answer them on the CPU as the CPU backend does (tests compare the two).
    pub device_level_sets: bool,
    /// Whether the step under way is one of the timed ones.
    timing_now: bool,
    /// Steps timed stage by stage so far (the denominator of [`Self::host_work_per_step`]).
    pub timed_steps: u64,
    /// Method 1: wall time of the traction plans made on the CPU ([`CoupledSolver::traction_plan`])
    /// over the timed steps (a part of the `surface_traction` entry of [`Self::timings`]).
    pub traction_plan_time: Duration,
}

impl GpuCoupled {
    /// Uploads a coupled solver (its fluid, its solid — with the added mass for method 2 —, and
    /// method 2's face-flux record); refuses what this backend does not run, naming the field.
    pub fn new(ctx: GpuContext, mut cpu: CoupledSolver) -> Result<Self, GpuError> {
        Self::supports(&cpu)?;
        let mut fluid = GpuFluid::from_solver(&ctx, &cpu.fluid)?;
        if let Some(ex) = cpu.exchange() {
            fluid.record_face_fluxes(&cpu.fluid, ex.reference());
        }
        let solid = GpuSolid::from_solver(&ctx, &mut cpu.solid)?;
        let kernels = CouplingKernels::new(&ctx);
        let level_sets = matches!(cpu.method, Method::Conserving(_)).then(|| LevelSetKernels::new(&ctx)).flatten();
        let timings = vec![Duration::ZERO; cpu.stages().len()];
        let prescribed = {
            let p = &cpu.solid.particles;
            let moved: Vec<u16> = cpu.bodies.iter().filter(|b| b.motion.is_some()).map(|b| b.surface.body).collect();
            (0..p.len()).filter(|&i| moved.contains(&p.body[i])).collect()
        };
        Ok(GpuCoupled {
            cpu,
            fluid,
            solid,
            kernels,
            ctx,
            timings,
            timing_every: TIMING_EVERY,
            round_trips: 0,
            round_trip_nodes: 0,
            whole_round_trips: false,
            prescribed,
            traction_nodes: 0,
            traction_plan: None,
            forces_stale: false,
            fluid_unchecked: None,
            geometry_parts: [Duration::ZERO; 5],
            level_sets,
            device_level_sets: true,
            timing_now: false,
            timed_steps: 0,
            traction_plan_time: Duration::ZERO,
        })
    }

    /// Whether this backend runs `cpu`'s scene, or why not (naming the field): both coupling
    /// methods run.
    pub fn supports(cpu: &CoupledSolver) -> Result<(), GpuError> {
        match cpu.method {
            Method::Conserving(_) | Method::Weak(_) => Ok(()),
        }
    }

    /// Completed coupled steps.
    pub fn step_count(&self) -> u64 {
        self.cpu.step_count
    }

    /// One coupled step, stage by stage (timed stage by stage when it is one of the
    /// [`Self::timing_every`]).
    pub fn step(&mut self) -> Result<(), Instability> {
        let timed = self.cpu.step_count.is_multiple_of(self.timing_every.max(1));
        self.timing_now = timed;
        self.timed_steps += timed as u64;
        if timed {
            // the steps before were only submitted: their work still on the device (the solid's
            // sub-steps) would be timed as this step's first stage, whose read of the particles
            // waits for it
            let _ = self.ctx.device.poll(wgpu::PollType::wait_indefinitely());
        }
        for (k, st) in self.cpu.stages().iter().enumerate() {
            let t0 = Instant::now();
            let r = self.run_stage(st.kind);
            if timed {
                let _ = self.ctx.device.poll(wgpu::PollType::wait_indefinitely());
                self.timings[k] += t0.elapsed();
            }
            r?;
        }
        self.cpu.step_count += 1;
        self.cpu.time += self.cpu.dt();
        Ok(())
    }

    /// Runs `n` coupled steps, stopping at the first instability; the last step's fluid is
    /// checked before it returns ([`Self::check_fluid`]).
    pub fn run(&mut self, n: u64) -> Result<(), Instability> {
        (0..n).try_for_each(|_| self.step())?;
        self.check_fluid()
    }

    /// Reads the fluid's instability flag if a fluid stage since the last read has not been
    /// checked (a [`Self::step`] leaves its own for the next step's particle read): the
    /// diagnosis of the step whose fluid left its range, or Ok.
    pub fn check_fluid(&mut self) -> Result<(), Instability> {
        let Some(at) = self.fluid_unchecked.take() else { return Ok(()) };
        match self.fluid.instability() {
            Ok(Some((node, code))) => Err(self.fluid_instability(node, code, at)),
            Ok(None) => Ok(()),
            Err(_) => Err(self.failed_read(&format!("reading the fluid's instability flag of step {} back failed (the device lost)", at.0))),
        }
    }

    /// The diagnosis of the fluid's flag (first node out of range, its code) set by the fluid
    /// stage of the step and time `at`.
    fn fluid_instability(&self, node: usize, code: u32, (step, time): (u64, f64)) -> Instability {
        let quantity = GpuFluid::status_quantity(code);
        Instability {
            part: Part::Fluid,
            step,
            time,
            time_unit: "s",
            site: Site::Node(self.cpu.fluid.layout.grid.coords(node)),
            quantity,
            value: f64::NAN,
            reason: format!("{quantity} left its admissible range on the GPU"),
        }
    }

    /// Clears every timer (the stages', the geometry's parts, the traction plans', the count of
    /// timed steps), e.g. after warm-up steps that compiled the pipelines.
    pub fn reset_timings(&mut self) {
        self.timings.iter_mut().for_each(|t| *t = Duration::ZERO);
        self.geometry_parts = Default::default();
        (self.timed_steps, self.traction_plan_time) = (0, Duration::ZERO);
    }

    /// Each stage's share of the wall time so far.
    pub fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        crate::stages::time_shares(self.cpu.stages().iter().map(|s| s.name).zip(&self.timings))
    }

    /// Each of [`GEOMETRY_PARTS`] as a share of the timed steps' wall time (they add up to the
    /// `fluid_geometry` share of [`Self::stage_shares`], less what the stage spends between them).
    pub fn geometry_part_shares(&self) -> Vec<(&'static str, f64)> {
        let total: Duration = self.timings.iter().sum();
        GEOMETRY_PARTS.iter().zip(&self.geometry_parts).map(|(n, t)| (*n, if total.is_zero() { 0.0 } else { t.as_secs_f64() / total.as_secs_f64() })).collect()
    }

    /// The step's work that the host does alone, whatever the device, in seconds per timed step
    /// ([`HOST_PARTS`]): the walls built on the CPU and the tables written for the device
    /// (parts of [`GEOMETRY_PARTS`]) and, for method 1, the traction's plan. Their sum bounds
    /// the steps per second on any device driven by this host (the waits for the device, the
    /// transfers and method 2's force scatter come on top).
    pub fn host_work_per_step(&self) -> Vec<(&'static str, f64)> {
        let per = |t: Duration| if self.timed_steps == 0 { 0.0 } else { t.as_secs_f64() / self.timed_steps as f64 };
        let mut parts = vec![(HOST_PARTS[0], per(self.geometry_parts[1])), (HOST_PARTS[1], per(self.geometry_parts[3]))];
        if matches!(self.cpu.method, Method::Weak(_)) {
            parts.push((HOST_PARTS[2], per(self.traction_plan_time)));
        }
        parts
    }

    /// The buffers and bind-group sets made on the device for the coupled step's per-step work
    /// since the upload, their first ones included: the boundary tables' and thin-wall flux
    /// tables' buffers and the stage bind groups remade when a table outgrew its buffer
    /// ([`GpuFluid::step_objects_made`], [`GpuFluid::geometry_rebinds`]), method 1's traction
    /// buffers and bind groups, method 2's hand-over buffers and bind groups, the particles'
    /// staging buffer, and the buffers, bind groups and staging buffers of the population round
    /// trips of steps where nodes change side, of the fluid's totals and of the piece forces'
    /// reads (made once, and again only when a round trip outgrows them). Constant over steps
    /// that made none: the steady state of a coupled run (test
    /// `a_coupled_step_makes_no_buffers_once_running` in tests/gpu/coupled_steps.rs).
    pub fn device_objects_made(&self) -> u64 {
        self.fluid.geometry_rebinds
            + self.fluid.step_objects_made()
            + self.kernels.objects_made()
            + self.solid.readback_buffers_made()
            + self.level_sets.as_ref().map_or(0, LevelSetKernels::objects_made)
    }

    /// Whether method 2's level-set questions are answered on the device: a method-2 scene on
    /// a device with f64 in shaders, unless [`Self::device_level_sets`] is off.
    pub fn level_sets_on_device(&self) -> bool {
        self.level_sets.is_some() && self.device_level_sets
    }

    /// What answering the level-set questions on the device has cost so far (None where they
    /// are answered on the CPU).
    pub fn level_set_work(&self) -> Option<super::level_set_queries::LevelSetWork> {
        self.level_sets.as_ref().map(LevelSetKernels::work)
    }

    /// Adds the time since `t0` to geometry part `k` on a timed step, and returns now.
    fn time_part(&mut self, k: usize, t0: Instant) -> Instant {
        let now = Instant::now();
        if self.timing_now {
            self.geometry_parts[k] += now - t0;
        }
        now
    }

    /// Runs one stage of the step (the step counter advances in [`Self::step`] only).
    pub fn run_stage(&mut self, kind: CoupledStageKind) -> Result<(), Instability> {
        let weak = match self.cpu.method {
            Method::Weak(o) => Some(o),
            Method::Conserving(_) => None,
        };
        match (kind, weak) {
            (CoupledStageKind::FluidGeometry, Some(o)) => self.polygon_geometry(o),
            (CoupledStageKind::FluidGeometry, None) => self.fluid_geometry(),
            (CoupledStageKind::Fluid, _) => self.fluid_step(),
            (CoupledStageKind::MomentumExchange, None) => {
                self.momentum_exchange();
                Ok(())
            }
            (CoupledStageKind::SurfaceTraction, Some(o)) => self.surface_traction(o),
            (CoupledStageKind::Solid, _) => self.solid_substeps(),
            // a stage of the other method's list
            (CoupledStageKind::MomentumExchange, Some(_)) | (CoupledStageKind::SurfaceTraction, None) => Ok(()),
        }
    }

    /// The particles' positions and velocities from the device (with their spins and rotations
    /// when `turning`: method 1's surface points sit at offsets that turn with their particle,
    /// [`crate::coupling::surface`]), checked; the previous step's fluid instability flag comes
    /// back in the same trip, and a fluid that left its range is the diagnosis (before any
    /// solid values it made non-finite).
    fn download_particles(&mut self, turning: bool) -> Result<(), Instability> {
        let unchecked = self.fluid_unchecked.take();
        let status = self.fluid.status_buffer();
        let extra: &[&wgpu::Buffer] = if unchecked.is_some() { &[status] } else { &[] };
        let read = if turning {
            let (steps, time) = (self.cpu.solid.step_count, self.cpu.solid.time);
            let read = self.solid.download_into_with(&mut self.cpu.solid, extra);
            (self.cpu.solid.step_count, self.cpu.solid.time) = (steps, time);
            read
        } else if let Some((position, velocity, rest)) = self.solid.download_kinematics(extra) {
            let p = &mut self.cpu.solid.particles;
            (p.position, p.velocity) = (position, velocity);
            Some(rest)
        } else {
            None
        };
        let Some(rest) = read else {
            self.fluid_unchecked = unchecked;
            return Err(self.failed_read("reading the particles back for the walls' geometry failed"));
        };
        if let (Some(at), Some(raw)) = (unchecked, rest.first())
            && let Some((node, code)) = GpuFluid::decode_status(raw)
        {
            return Err(self.fluid_instability(node, code, at));
        }
        if let Some(i) = self.cpu.solid.non_finite() {
            let mut e = self.cpu.solid.instability_at(i);
            (e.step, e.time) = (self.cpu.step_count, self.cpu.time);
            return Err(e);
        }
        Ok(())
    }

    /// Method 1's walls: the surface polygons at the particles' current positions, built by the
    /// CPU mirror (whose populations are the device's, brought back by the last traction stage);
    /// the populations go up when nodes changed side (see the module table).
    fn polygon_geometry(&mut self, o: WeakOptions) -> Result<(), Instability> {
        let t = Instant::now();
        self.download_particles(true)?;
        let t = self.time_part(0, t);
        let Some(walls) = self.cpu.next_polygon_walls(o)? else {
            self.time_part(1, t);
            return Ok(());
        };
        let change = walls.changes_nodes(&self.cpu.fluid.layout).then(|| walls.change(&self.cpu.fluid.layout).clone());
        self.install_walls(t, change, |cpu| cpu.install_polygon_walls(walls))
    }

    /// The second half of either method's geometry stage, from the walls built at `t`: when
    /// nodes change side (`change`), the populations the change reads come back first and the
    /// fresh nodes go up after `install` (which puts the walls into the CPU mirror); then the
    /// tables go to the device. Each part timed as [`GEOMETRY_PARTS`] says.
    fn install_walls(&mut self, t: Instant, change: Option<LayoutChange>, install: impl FnOnce(&mut CoupledSolver)) -> Result<(), Instability> {
        let t = self.time_part(1, t);
        let t = match change {
            Some(change) => {
                self.bring_back(&change)?;
                let t = self.time_part(2, t);
                install(&mut self.cpu);
                let t = self.time_part(1, t);
                self.send_up(&change);
                self.time_part(2, t)
            }
            None => {
                install(&mut self.cpu);
                self.time_part(1, t)
            }
        };
        self.fluid.set_geometry(&self.cpu.fluid).map_err(|e| self.side_ghosts_outgrown(e))?;
        self.time_part(3, t);
        Ok(())
    }

    /// Before a change of layout: the populations it reads into the CPU mirror — the nodes that
    /// change side and the fresh nodes' neighbours ([`LayoutChange::reads`], by the `gather`
    /// kernel), or the whole state with [`Self::whole_round_trips`].
    fn bring_back(&mut self, change: &LayoutChange) -> Result<(), Instability> {
        self.round_trips += 1;
        let ok = if self.whole_round_trips {
            self.round_trip_nodes += self.fluid.n_nodes as u64;
            self.fluid.download_into(&mut self.cpu.fluid)
        } else {
            let reads = change.reads();
            self.round_trip_nodes += reads.len() as u64;
            self.fluid.download_nodes_into(&reads, &mut self.cpu.fluid)
        };
        if ok {
            return Ok(());
        }
        Err(self.failed_read("reading back the nodes that change side failed"))
    }

    /// The diagnosis of walls that need more side ghosts than the device's arrays hold: the run
    /// stops at this step with its outputs (the device state is that of the step before).
    fn side_ghosts_outgrown(&self, e: crate::gpu::fdlb::SideGhostRoom) -> Instability {
        let reason = format!("{e}: run it on the CPU backend, or on a device with the walls' thin parts present at the start");
        self.device_stop("side ghosts", e.needed as f64, reason)
    }

    /// The diagnosis of a read within a step that failed (the device lost or out of memory).
    fn failed_read(&self, reason: &str) -> Instability {
        self.device_stop("device state", f64::NAN, reason.into())
    }

    /// A stop of this step for the device's sake (not the physics'), naming what and why.
    fn device_stop(&self, quantity: &'static str, value: f64, reason: String) -> Instability {
        Instability { part: Part::Device, step: self.cpu.step_count, time: self.cpu.time, time_unit: "s", site: Site::Everywhere, quantity, value, reason }
    }

    /// After a change of layout: the populations it wrote (the fresh nodes, by the `scatter`
    /// kernel), or the whole state with [`Self::whole_round_trips`].
    fn send_up(&mut self, change: &LayoutChange) {
        if self.whole_round_trips {
            self.fluid.upload_state(&self.cpu.fluid);
        } else {
            let fresh = change.fresh();
            self.round_trip_nodes += fresh.len() as u64;
            self.fluid.upload_nodes_from(&fresh, &self.cpu.fluid);
        }
    }

    /// Method 1's tractions (2.110–2.113) on the device, from the plan of the particles the
    /// CPU holds (brought back by this step's geometry stage), as the surface particles' loads
    /// in the solid's load buffer.
    fn surface_traction(&mut self, o: WeakOptions) -> Result<(), Instability> {
        let t = Instant::now();
        let plan = self.cpu.traction_plan(o);
        if self.timing_now {
            self.traction_plan_time += t.elapsed();
        }
        self.fluid.surface_traction(&plan, self.cpu.base_loads(), self.solid.load_buffer());
        self.traction_nodes += plan.stencil.len() as u64;
        self.traction_plan = Some(plan);
        self.forces_stale = true;
        Ok(())
    }

    /// The device's pieces' forces of the last traction stage into [`Self::cpu`]'s forces (and
    /// the loads they give), when they are newer; false when the read failed.
    fn refresh_forces(&mut self) -> bool {
        if !self.forces_stale {
            return true;
        }
        let Some(plan) = &self.traction_plan else { return true };
        let Some(piece_force) = self.fluid.download_piece_forces() else { return false };
        self.cpu.set_surface_forces(plan.forces(&piece_force));
        self.forces_stale = false;
        true
    }

    /// Bytes the pieces' forces carry when [`Self::download_solid`] brings them back (method 1).
    pub fn forces_bytes(&self) -> u64 {
        if self.forces_stale { self.fluid.piece_forces_bytes() } else { 0 }
    }

    /// The walls at the particles' current positions (see the module table).
    fn fluid_geometry(&mut self) -> Result<(), Instability> {
        let t = Instant::now();
        self.download_particles(false)?;
        let t = self.time_part(0, t);
        let device = self.level_sets.as_ref().filter(|_| self.device_level_sets);
        let on_device = device.map_or(Duration::ZERO, |k| k.work().time);
        let walls = match device {
            Some(k) => self.cpu.next_level_set_walls_with(k)?,
            None => self.cpu.next_level_set_walls()?,
        };
        let spent = device.map_or(Duration::ZERO, |k| k.work().time) - on_device;
        let change = walls.changes_nodes(&self.cpu.fluid.layout).then(|| walls.change(&self.cpu.fluid.layout).clone());
        let done = self.install_walls(t, change, |cpu| cpu.install_level_set_walls(walls));
        if self.timing_now {
            // the device's share of the walls (timed with them) as a part of its own
            self.geometry_parts[4] += spent;
            self.geometry_parts[1] = self.geometry_parts[1].saturating_sub(spent);
        }
        done
    }

    /// One fluid step (with the face fluxes recorded for method 2), only submitted: its
    /// instability flag is read with the next step's particles or by [`Self::check_fluid`].
    fn fluid_step(&mut self) -> Result<(), Instability> {
        self.fluid.run(1);
        if self.fluid_unchecked.is_none() {
            self.fluid_unchecked = Some((self.cpu.step_count, self.cpu.time));
        }
        Ok(())
    }

    /// Each wall node's momentum (face fluxes + the geometry stage's node changes) to the
    /// particles near it, as their loads over the step.
    fn momentum_exchange(&mut self) {
        let changes = self.cpu.take_node_change_momentum();
        let (sets, index) = self.cpu.exchange_sets();
        let sets: Vec<&KernelLevelSet> = sets.iter().map(|s| &**s).collect();
        let factor = self.cpu.momentum_unit() / self.cpu.dt();
        let wall = self.fluid.face_flux_buffer().expect("GpuCoupled::new records the face fluxes");
        let (shares, diag) = self.kernels.hand_over(&self.ctx, &sets, &self.cpu.fluid.layout.grid, wall, &changes, factor);
        let mut force = vec![DVec3::ZERO; self.cpu.solid.particles.len()];
        for (&i, f) in index.iter().zip(shares) {
            force[i] = f;
        }
        self.cpu.add_exchange_diagnostics(diag.walls, diag.mass, diag.wall_frame);
        self.cpu.set_air_forces(force);
        self.solid.upload_loads(&self.cpu.solid);
    }

    /// The solid's sub-steps over the fluid step; with prescribed bodies one at a time, each
    /// followed by their motion at its end (as [`CoupledSolver`] does).
    fn solid_substeps(&mut self) -> Result<(), Instability> {
        if self.prescribed.is_empty() {
            self.solid.run(self.cpu.substeps as u64);
        } else {
            let dts = self.cpu.solid.dt;
            for k in 0..self.cpu.substeps {
                self.solid.run(1);
                self.cpu.apply_motions(self.cpu.time + (k + 1) as f64 * dts);
                self.solid.upload_kinematics(&self.cpu.solid, &self.prescribed);
            }
        }
        Ok(())
    }

    /// Copies the solid's state (particles, rotations, contact anchors) into [`Self::cpu`], with
    /// method 1's air forces of the last traction stage (the pieces' forces, 16 B each);
    /// false when a read failed (the solid, or the forces, left as they were).
    pub fn download_solid(&mut self) -> bool {
        self.solid.download_into(&mut self.cpu.solid) && self.refresh_forces()
    }

    /// Copies the whole GPU state (populations, particles) into [`Self::cpu`] for outputs; false
    /// when a read failed (each part is left as it was when its own read fails).
    pub fn download_into(&mut self) -> bool {
        self.fluid.download_into(&mut self.cpu.fluid) & self.download_solid()
    }
}
