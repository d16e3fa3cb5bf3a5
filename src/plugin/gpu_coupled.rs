//! The coupled solver stepped on the GPU in Bevy's render world (feature `bevy`): put
//! [`GpuStepping`] on a [`CoupledSimulation`] entity in an app with [`super::PhonationGpuPlugin`]
//! and a render device, and its air and bodies are uploaded once to Bevy's render device as a
//! [`CoupledEngine`] (the run layer's GPU backend, [`crate::gpu::coupled::GpuCoupled`], both
//! coupling methods). A system of the `RenderGraph` schedule, ordered before the camera driver,
//! advances it by the frame's steps of its stage list ([`crate::stages::COUPLED_WEAK_STEP`] or
//! [`crate::stages::COUPLED_CONSERVING_STEP`]); what the main world shows comes back small:
//!
//! | per | what comes back | used by |
//! |---|---|---|
//! | coupled step, with a [`CoupledGlottis`] | the solid and the fluid nodes of the glottis's narrowest section (`CoupledEngine::observe`) | the glottal flow and area, [`super::VoiceDiagnostics`] |
//! | frame | the solid (positions, velocities, rotations, spins), the air's totals summed on the device (one partial per 1024 nodes), the air's forces on the bodies, the geometry's node counts | the fold mesh, [`super::CoupledDiagnostics`], the panel |
//!
//! The populations never cross the bus whole (the coupling's own stages bring back the nodes a
//! change of layout reads and, for method 1, the nodes its traction samples). The main world's
//! [`CoupledSimulation::solver`] keeps the step counter, the time and the solid of the last
//! frame read back; its air stays as uploaded — the drawing reads the device's instead (the
//! tracers and slice of `render::gpu_tracers` and `render::gpu_slice` (feature `render`), through
//! [`super::GpuAir`]).
//! Readbacks lag a frame or two behind the render world; [`GpuCoupledReadback::step`] says which
//! step they belong to.
//!
//! An implicit solid solves to the GPU backend's default tolerance (`solid.cg_tolerance` 10⁻⁵;
//! the CPU's default of 10⁻⁸ is below what its f32 solve reaches).
//!
//! Take [`GpuStepping`] off the entity and the device's whole state comes back into its
//! [`CoupledSimulation`] once; the CPU steps it on from there.
//!
//! Without a render device nothing is uploaded and the entity keeps being stepped on the CPU by
//! [`super::PhonationPlugin`], with the same components.
//!
//! Method 2's level-set questions (each node's side, each ghost's wall point) are asked on the
//! device where Bevy's render device has f64 in shaders — Bevy opens it with every feature of
//! the adapter unless its `WgpuSettings` say otherwise — and on the host's threads where it has
//! not. Put [`GpuLevelSets`]`(LevelSets::Host)` on the entity before it is uploaded to ask them on
//! the host anyway (a GPU whose f64 runs at 1/32–1/64 of its f32, as most consumer cards' does);
//! [`GpuCoupledReadback::backend`] says where they are asked. The results are the same either
//! way (`phonation run --level-sets`).

use super::{CoupledGlottis, CoupledSimulation, CoupledStatus, GpuStepping, PhonationSystems, StepsThisFrame};
use crate::coupling::glottis::{GlottalSample, Glottis};
use crate::coupling::traction::SurfaceForces;
use crate::fluid::{GeometryChange, Totals};
use crate::gpu::GpuContext;
use crate::run::{CoupledEngine, LevelSets};
use crate::solid::SolidSolver;
use crate::step::Solver;
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use bevy::render::renderer::{RenderAdapterInfo, RenderDevice, RenderGraph, RenderGraphSystems, RenderQueue};
use glam::{DQuat, DVec3};
use std::sync::{Arc, Mutex};

/// The GPU-resident coupled solver of an entity, shared with the render world, which steps it.
#[derive(Component, Clone, ExtractComponent)]
pub struct GpuCoupledHandle {
    engine: Arc<Mutex<CoupledEngine>>,
    glottis: Option<Arc<Glottis>>,
    inbox: Arc<Mutex<CoupledFrame>>,
    /// Steps the render world runs this frame.
    steps_this_frame: u32,
}

impl GpuCoupledHandle {
    /// The engine the render world steps (locked by it while it steps).
    pub fn engine(&self) -> &Arc<Mutex<CoupledEngine>> {
        &self.engine
    }

    /// Steps the render world runs this frame.
    pub fn steps_this_frame(&self) -> u32 {
        self.steps_this_frame
    }
}

/// What the render world read back for the main world since it last looked.
#[derive(Default)]
struct CoupledFrame {
    step: u64,
    time: f64,
    /// One per coupled step, in order (with a glottis).
    samples: Vec<GlottalSample>,
    solid: Option<SolidKinematics>,
    totals: Option<Totals>,
    forces: Option<SurfaceForces>,
    geometry: GeometryChange,
    /// The diagnosis of the step that failed; the render world steps the entity no more.
    failure: Option<String>,
    fresh: bool,
}

/// A solid's moving state as read back (what the fold mesh, the energies and the momenta read).
pub(super) struct SolidKinematics {
    step: u64,
    time: f64,
    position: Vec<DVec3>,
    velocity: Vec<DVec3>,
    rotation: Vec<DQuat>,
    spin: Vec<DVec3>,
}

impl SolidKinematics {
    pub(super) fn of(s: &SolidSolver) -> Self {
        let p = &s.particles;
        SolidKinematics {
            step: s.step_count,
            time: s.time,
            position: p.position.clone(),
            velocity: p.velocity.clone(),
            rotation: p.rotation.clone(),
            spin: p.spin.clone(),
        }
    }

    /// Into `s` (the main world's copy of the solver).
    pub(super) fn apply(self, s: &mut SolidSolver) {
        let p = &mut s.particles;
        (p.position, p.velocity, p.rotation, p.spin) = (self.position, self.velocity, self.rotation, self.spin);
        (s.step_count, s.time) = (self.step, self.time);
    }
}

/// Where a GPU-stepped coupled entity's method-2 level-set questions are asked, read when the
/// entity is uploaded (absent: [`LevelSets::Device`], on the device where it has f64 in
/// shaders); the run layer's [`CoupledEngine::ask_level_sets`].
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GpuLevelSets(pub LevelSets);

/// The last frame read back from the render world for a GPU-stepped coupled entity.
#[derive(Component, Debug, Clone, Default)]
pub struct GpuCoupledReadback {
    /// The backend the entity was uploaded to, as `phonation run` names it: the device, and for
    /// method 2 where its level-set questions are asked ([`GpuLevelSets`]).
    pub backend: String,
    /// The coupled step the figures belong to.
    pub step: u64,
    /// The air's totals at that step (lattice units), summed on the device.
    pub totals: Option<Totals>,
    /// Readbacks received.
    pub readbacks: u64,
}

pub(super) fn build(app: &mut App) {
    app.add_plugins(ExtractComponentPlugin::<GpuCoupledHandle>::default()).add_systems(
        Update,
        (upload_coupled, receive_coupled_frames, bring_back_coupled, schedule_coupled_steps)
            .chain()
            .before(super::coupled::step_coupled)
            .before(super::coupled::coupled_diagnostics)
            .in_set(PhonationSystems::CoupledStep),
    );
    if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
        render_app.add_systems(RenderGraph, step_gpu_coupled.before(RenderGraphSystems::Render));
    }
}

/// Uploads each GPU-stepping coupled entity once (a copy of its solver: the main world keeps
/// the original as the mirror it shows).
#[allow(clippy::type_complexity)]
fn upload_coupled(
    mut commands: Commands,
    sims: Query<(Entity, &CoupledSimulation, Option<&CoupledGlottis>, Option<&GpuLevelSets>), (With<GpuStepping>, Without<GpuCoupledHandle>)>,
    render: RenderDeviceParam,
) {
    for (entity, sim, glottis, level_sets) in &sims {
        let Some((ctx, name)) = render.context() else { return };
        let mut engine = match CoupledEngine::on_device(ctx, name, sim.solver.clone(), None) {
            Ok(e) => e,
            Err(e) => {
                warn!("phonation: coupled simulation on {entity} stays on the CPU: {e:#}");
                commands.entity(entity).remove::<GpuStepping>();
                continue;
            }
        };
        engine.ask_level_sets(level_sets.map_or_else(LevelSets::default, |l| l.0));
        let readback = GpuCoupledReadback { backend: engine.name.clone(), ..default() };
        let handle = GpuCoupledHandle {
            engine: Arc::new(Mutex::new(engine)),
            glottis: glottis.map(|g| Arc::new(g.glottis.clone())),
            inbox: Arc::default(),
            steps_this_frame: 0,
        };
        commands.entity(entity).insert((handle, readback));
    }
}

/// Bevy's render device, queue and adapter in the main world (absent without a renderer).
#[derive(bevy::ecs::system::SystemParam)]
pub(super) struct RenderDeviceParam<'w> {
    device: Option<Res<'w, RenderDevice>>,
    queue: Option<Res<'w, RenderQueue>>,
    info: Option<Res<'w, RenderAdapterInfo>>,
}

impl RenderDeviceParam<'_> {
    /// Bevy's render device as a [`GpuContext`] (its failures left to Bevy) and its name; None
    /// without a renderer.
    pub(super) fn context(&self) -> Option<(GpuContext, String)> {
        let (device, queue, info) = (self.device.as_deref()?, self.queue.as_deref()?, self.info.as_deref()?);
        let q: &wgpu::Queue = &queue.0;
        let adapter: &wgpu::AdapterInfo = &info.0;
        let ctx = GpuContext::shared(device.wgpu_device().clone(), q.clone(), adapter.clone(), device.limits());
        let name = format!("gpu: {} (Bevy's render device)", ctx.describe());
        Some((ctx, name))
    }
}

fn schedule_coupled_steps(steps: Res<StepsThisFrame>, mut handles: Query<(&mut GpuCoupledHandle, Option<&CoupledStatus>)>) {
    for (mut h, status) in &mut handles {
        h.steps_this_frame = if matches!(status, Some(CoupledStatus::Unstable(_))) { 0 } else { steps.0 };
    }
}

/// Render world: the frame's coupled steps (each stage waits on the device, as the run layer's
/// GPU backend does), the glottis sampled after each, then the frame's small readback.
pub(crate) fn step_gpu_coupled(handles: Query<&GpuCoupledHandle>) {
    for h in &handles {
        if h.steps_this_frame == 0 || h.inbox.lock().expect("coupled inbox").failure.is_some() {
            continue;
        }
        let mut engine = h.engine.lock().expect("coupled engine");
        let mut samples = Vec::new();
        let mut failure = None;
        for _ in 0..h.steps_this_frame {
            if let Err(e) = engine.step() {
                failure = Some(e.to_string());
                break;
            }
            if let Some(g) = &h.glottis {
                let mut section = None;
                match engine.observe(|c| {
                    let s = g.section(c);
                    let nodes = s.nodes.clone();
                    section = Some(s);
                    nodes
                }) {
                    Ok(c) => samples.push(section.expect("the section of the step").sample(&c.fluid)),
                    Err(e) => {
                        failure = Some(e.to_string());
                        break;
                    }
                }
            }
        }
        let totals = if failure.is_none() { engine.totals().map_err(|e| failure = Some(e.to_string())).ok() } else { None };
        let read = engine.observe(|_| Vec::new());
        let mut inbox = h.inbox.lock().expect("coupled inbox");
        if let Ok(c) = read {
            inbox.solid = Some(SolidKinematics::of(&c.solid));
            (inbox.step, inbox.time) = (c.step_count, c.time);
            inbox.forces = Some(c.forces.clone());
            inbox.geometry = c.geometry;
        }
        inbox.samples.append(&mut samples);
        inbox.totals = totals.or(inbox.totals);
        if inbox.failure.is_none() {
            inbox.failure = failure;
        }
        inbox.fresh = true;
    }
}

/// Main world: what the render world read back goes into the entity's solver (step, time,
/// solid, forces, geometry counts), its glottis's flow history and [`GpuCoupledReadback`]; a
/// failure marks it [`CoupledStatus::Unstable`].
#[allow(clippy::type_complexity)]
fn receive_coupled_frames(
    mut sims: Query<(Entity, &GpuCoupledHandle, &mut CoupledSimulation, &mut GpuCoupledReadback, Option<&mut CoupledGlottis>)>,
    mut commands: Commands,
) {
    for (entity, h, mut sim, mut readback, glottis) in &mut sims {
        let Some(frame) = h.inbox.lock().expect("coupled inbox").take() else { continue };
        if let Some(why) = frame.apply(&mut sim.solver, glottis.map(|g| g.into_inner()), &mut readback) {
            warn!("phonation: coupled simulation on {entity} stopped on the GPU: {why}");
            commands.entity(entity).insert(CoupledStatus::Unstable(why));
        }
    }
}

/// Main world: an entity whose [`GpuStepping`] was taken off gets the device's whole state
/// back into its [`CoupledSimulation`] (after the glottis samples the render world had not
/// handed over yet) and is stepped on the CPU from that step on; the device's copy is dropped.
#[allow(clippy::type_complexity)]
fn bring_back_coupled(
    mut sims: Query<(Entity, &GpuCoupledHandle, &mut CoupledSimulation, &mut GpuCoupledReadback, Option<&mut CoupledGlottis>), Without<GpuStepping>>,
    mut commands: Commands,
) {
    for (entity, h, mut sim, mut readback, glottis) in &mut sims {
        // the engine first: the render world fills the inbox while it holds the engine
        let mut engine = h.engine.lock().expect("coupled engine");
        let frame = h.inbox.lock().expect("coupled inbox").take();
        let failure = frame.and_then(|f| f.apply(&mut sim.solver, glottis.map(|g| g.into_inner()), &mut readback));
        match engine.state() {
            Ok(c) => sim.solver = c.clone(),
            Err(e) => warn!("phonation: coupled simulation on {entity}: the device's state could not be read back ({e}); it goes on from the last readback"),
        }
        if let Some(why) = failure {
            commands.entity(entity).insert(CoupledStatus::Unstable(why));
        }
        commands.entity(entity).remove::<(GpuCoupledHandle, GpuCoupledReadback)>();
    }
}

impl CoupledFrame {
    /// What is new since the main world last looked (None: nothing).
    fn take(&mut self) -> Option<CoupledFrame> {
        if !self.fresh {
            return None;
        }
        self.fresh = false;
        Some(CoupledFrame {
            step: self.step,
            time: self.time,
            samples: std::mem::take(&mut self.samples),
            solid: self.solid.take(),
            totals: self.totals,
            forces: self.forces.take(),
            geometry: self.geometry,
            failure: self.failure.clone(),
            fresh: true,
        })
    }

    /// Into the main world's solver, glottis and readback figures; the failure it carries.
    fn apply(self, s: &mut crate::coupling::CoupledSolver, glottis: Option<&mut CoupledGlottis>, readback: &mut GpuCoupledReadback) -> Option<String> {
        (s.step_count, s.time) = (self.step, self.time);
        if let Some(k) = self.solid {
            k.apply(&mut s.solid);
        }
        if let Some(f) = self.forces {
            s.forces = f;
        }
        s.geometry = self.geometry;
        if let Some(g) = glottis {
            let keep = (g.history_s / s.dt()).ceil() as usize;
            for sample in &self.samples {
                g.area = sample.area;
                g.flow.push_back(sample.flow);
            }
            while g.flow.len() > keep {
                g.flow.pop_front();
            }
        }
        readback.step = self.step;
        readback.totals = self.totals;
        readback.readbacks += 1;
        self.failure
    }
}

/// Keeps the main world from stepping a GPU-stepped entity on the CPU.
pub(super) type CpuStepped = Without<GpuCoupledHandle>;
