//! The MPS solid stepped on the GPU in Bevy's render world (feature `bevy`): put
//! [`GpuStepping`] on a [`SolidSimulation`] entity in an app with [`super::PhonationGpuPlugin`]
//! and a render device, and its particles are uploaded once to Bevy's render device as a
//! [`SolidEngine`] (the run layer's GPU backend, [`crate::gpu::solid::GpuSolid`], explicit or
//! implicit). A system of the `RenderGraph` schedule, ordered before the camera driver, advances
//! it by the frame's steps of its stage list ([`crate::stages::SOLID_EXPLICIT_STEP`] or
//! [`crate::stages::SOLID_IMPLICIT_STEP`]); after them the particles' moving state comes back
//! (positions, velocities, rotations, spins: 104 B per particle, once per frame) into the
//! entity's [`SolidSimulation::solver`], with the step, the time and the last conjugate-gradient
//! solve, so that the fold mesh, [`super::SolidDiagnostics`] and the panel read it as they read a
//! CPU-stepped solid. Readbacks lag a frame or two behind the render world.
//!
//! An implicit solid solves to the GPU backend's default tolerance (10⁻⁵; the CPU's default of
//! 10⁻⁸ is below what its f32 solve reaches). Without a render device nothing is uploaded and
//! the entity keeps being stepped on the CPU by [`super::PhonationPlugin`]. Take [`GpuStepping`]
//! off the entity and the device's particles come back into its [`SolidSimulation`] once; the
//! CPU steps it on from there.

use super::gpu_coupled::{RenderDeviceParam, SolidKinematics};
use super::{GpuStepping, PhonationSystems, SolidSimulation, SolidStatus, StepsThisFrame};
use crate::run::SolidEngine;
use crate::step::Solver;
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use bevy::render::renderer::{RenderGraph, RenderGraphSystems};
use std::sync::{Arc, Mutex};

/// The GPU-resident solid of an entity, shared with the render world, which steps it.
#[derive(Component, Clone, ExtractComponent)]
pub struct GpuSolidHandle {
    engine: Arc<Mutex<SolidEngine>>,
    inbox: Arc<Mutex<SolidFrame>>,
    /// Steps the render world runs this frame.
    steps_this_frame: u32,
}

impl GpuSolidHandle {
    /// The engine the render world steps (locked by it while it steps).
    pub fn engine(&self) -> &Arc<Mutex<SolidEngine>> {
        &self.engine
    }
}

/// What the render world read back since the main world last looked.
#[derive(Default)]
struct SolidFrame {
    solid: Option<SolidKinematics>,
    /// Iterations and relative residual of the last conjugate-gradient solve (implicit).
    cg: Option<(usize, f64)>,
    /// The diagnosis of the step that failed; the render world steps the entity no more.
    failure: Option<String>,
}

pub(super) fn build(app: &mut App) {
    app.add_plugins(ExtractComponentPlugin::<GpuSolidHandle>::default()).add_systems(
        Update,
        (upload_solid, receive_solid_frames, bring_back_solids, schedule_solid_steps)
            .chain()
            .before(super::solid::step_solids)
            .before(super::solid::solid_diagnostics)
            .in_set(PhonationSystems::SolidStep),
    );
    if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
        render_app.add_systems(RenderGraph, step_gpu_solids.before(RenderGraphSystems::Render));
    }
}

/// Uploads each GPU-stepping solid entity once (a copy of its solver: the main world keeps the
/// original, which receives the readbacks).
#[allow(clippy::type_complexity)]
fn upload_solid(mut commands: Commands, sims: Query<(Entity, &SolidSimulation), (With<GpuStepping>, Without<GpuSolidHandle>)>, render: RenderDeviceParam) {
    for (entity, sim) in &sims {
        let Some((ctx, name)) = render.context() else { return };
        match SolidEngine::on_device(ctx, name, sim.solver.clone(), None) {
            Ok(engine) => {
                commands.entity(entity).insert(GpuSolidHandle { engine: Arc::new(Mutex::new(engine)), inbox: Arc::default(), steps_this_frame: 0 });
            }
            Err(e) => {
                warn!("phonation: solid on {entity} stays on the CPU: {e:#}");
                commands.entity(entity).remove::<GpuStepping>();
            }
        }
    }
}

fn schedule_solid_steps(steps: Res<StepsThisFrame>, mut handles: Query<(&mut GpuSolidHandle, Option<&SolidStatus>)>) {
    for (mut h, status) in &mut handles {
        h.steps_this_frame = if matches!(status, Some(SolidStatus::Unstable(_))) { 0 } else { steps.0 };
    }
}

/// Render world: the frame's solid steps, then the particles' moving state into the inbox.
pub(crate) fn step_gpu_solids(handles: Query<&GpuSolidHandle>) {
    for h in &handles {
        if h.steps_this_frame == 0 || h.inbox.lock().expect("solid inbox").failure.is_some() {
            continue;
        }
        let mut engine = h.engine.lock().expect("solid engine");
        let result = engine.advance(h.steps_this_frame as u64);
        let mut inbox = h.inbox.lock().expect("solid inbox");
        inbox.solid = Some(SolidKinematics::of(&engine.solver));
        inbox.cg = engine.gpu_last_cg();
        inbox.failure = result.err().map(|e| e.to_string());
    }
}

/// Main world: the readback into the entity's solver; a failure marks it
/// [`SolidStatus::Unstable`].
fn receive_solid_frames(mut sims: Query<(Entity, &GpuSolidHandle, &mut SolidSimulation)>, mut commands: Commands) {
    for (entity, h, mut sim) in &mut sims {
        let (solid, cg, failure) = {
            let mut inbox = h.inbox.lock().expect("solid inbox");
            let Some(solid) = inbox.solid.take() else { continue };
            (solid, inbox.cg, inbox.failure.clone())
        };
        solid.apply(&mut sim.solver);
        if let Some((iterations, residual)) = cg {
            let last = &mut sim.solver.last.cg;
            (last.iterations, last.relative_residual) = (iterations, residual);
        }
        if let Some(why) = failure {
            warn!("phonation: solid on {entity} stopped on the GPU: {why}");
            commands.entity(entity).insert(SolidStatus::Unstable(why));
        }
    }
}

/// Main world: a solid whose [`GpuStepping`] was taken off gets the device's particles back
/// into its [`SolidSimulation`] (the engine brings them back after every advance) and is
/// stepped on the CPU from that step on; the device's copy is dropped.
fn bring_back_solids(mut sims: Query<(Entity, &GpuSolidHandle, &mut SolidSimulation), Without<GpuStepping>>, mut commands: Commands) {
    for (entity, h, mut sim) in &mut sims {
        let engine = h.engine.lock().expect("solid engine");
        let cg = sim.solver.last.cg;
        sim.solver = engine.solver.clone();
        // the main world's record of the last GPU solve (the CPU's own is not kept on the device)
        sim.solver.last.cg = cg;
        h.inbox.lock().expect("solid inbox").solid = None;
        commands.entity(entity).remove::<GpuSolidHandle>();
    }
}

/// Keeps the main world from stepping a GPU-stepped solid on the CPU.
pub(super) type CpuStepped = Without<GpuSolidHandle>;
