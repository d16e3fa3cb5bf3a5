//! GPU stepping in Bevy's render world (feature `bevy`). Add [`PhonationGpuPlugin`] next to
//! [`super::PhonationPlugin`] in an app that has Bevy's `RenderPlugin`, and put [`GpuStepping`]
//! on a [`FluidSimulation`] entity: its lattice is uploaded to Bevy's render device as a
//! [`GpuFluid`], the render world records the frame's steps ([`crate::stages::FDLB_STEP`]) from
//! a system in the `RenderGraph` schedule ordered before the camera driver's set, and a probe kernel
//! writes the probes' macroscopic state together with the step index into a buffer that comes
//! back through Bevy's `Readback` into [`GpuProbes`]. Readbacks lag a few frames; the step index
//! says which step the values belong to.
//!
//! Without a render device (`MinimalPlugins`, no adapter), nothing is uploaded and the entity
//! keeps being stepped on the CPU by [`super::PhonationPlugin`] with the same ECS-facing API.
//! The same plugin steps solids ([`super::gpu_solid`]) and coupled simulations
//! ([`super::gpu_coupled`]) that carry [`GpuStepping`]. Take [`GpuStepping`] off and the
//! device's state comes back into the entity's simulation (a frame later for a fluid, whose
//! steps go into the frame's commands), which the CPU steps on from there.

use super::{FluidSimulation, PhonationSystems, StepsThisFrame};
use crate::gpu::GpuFluid;
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use bevy::render::gpu_readback::{Readback, ReadbackComplete};
use bevy::render::render_asset::RenderAssets;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderGraph, RenderGraphSystems, RenderQueue};
use bevy::render::storage::{GpuShaderBuffer, ShaderBuffer};
use std::sync::{Arc, Mutex};

/// Requests that the entity's [`FluidSimulation`], [`super::SolidSimulation`] or
/// [`super::CoupledSimulation`] be stepped on the GPU in the render world (by this module,
/// [`super::gpu_solid`] and [`super::gpu_coupled`]).
#[derive(Component, Debug, Default, Clone, Copy)]
pub struct GpuStepping;

/// The GPU lattice of an entity, shared with the render world.
#[derive(Component, Clone, ExtractComponent)]
pub struct GpuFluidHandle {
    gpu: Arc<Mutex<GpuFluid>>,
    probes: Handle<ShaderBuffer>,
    nodes: Arc<Vec<usize>>,
    /// Steps the render world records this frame.
    steps_this_frame: u32,
}

impl GpuFluidHandle {
    /// The GPU lattice (the render world records its steps).
    pub fn fluid(&self) -> &Arc<Mutex<GpuFluid>> {
        &self.gpu
    }

    /// Steps the render world records this frame.
    pub fn steps_this_frame(&self) -> u32 {
        self.steps_this_frame
    }
}

/// The air on Bevy's render device of a GPU-stepped entity — a fluid's lattice
/// ([`GpuFluidHandle`]) or a coupled solver's ([`super::GpuCoupledHandle`]) — for the kernels
/// that read it in place after the frame's steps (tracers, slices). Query it as
/// `AnyOf<(&GpuFluidHandle, &GpuCoupledHandle)>` and wrap the item.
pub struct GpuAir<'a>(pub Option<&'a GpuFluidHandle>, pub Option<&'a super::GpuCoupledHandle>);

impl GpuAir<'_> {
    /// Steps the render world runs this frame.
    pub fn steps_this_frame(&self) -> u32 {
        match self {
            GpuAir(Some(f), _) => f.steps_this_frame,
            GpuAir(None, Some(c)) => c.steps_this_frame(),
            GpuAir(None, None) => 0,
        }
    }

    /// `f` given the lattice on the device (locked while `f` runs; None without one).
    pub fn with_fluid<R>(&self, f: impl FnOnce(&GpuFluid) -> R) -> Option<R> {
        match self {
            GpuAir(Some(h), _) => Some(f(&h.gpu.lock().expect("GPU lattice lock"))),
            GpuAir(None, Some(c)) => c.engine().lock().expect("coupled engine lock").gpu_fluid().map(f),
            GpuAir(None, None) => None,
        }
    }
}

/// Probe values read back from the GPU: the step they belong to and (ρ, u_x, u_y, u_z, θ) per
/// probe of the scene, in lattice units.
#[derive(Component, Debug, Default, Clone)]
pub struct GpuProbes {
    pub step: u64,
    pub values: Vec<[f32; 5]>,
    /// Number of readbacks received.
    pub readbacks: u64,
}

pub struct PhonationGpuPlugin;

impl Plugin for PhonationGpuPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(ExtractComponentPlugin::<GpuFluidHandle>::default()).add_systems(
            Update,
            (
                upload_to_gpu.before(super::step_simulations),
                (bring_back_fluids.before(super::step_simulations), schedule_gpu_steps.after(super::plan_steps)).chain(),
            )
                .in_set(PhonationSystems::Step),
        );
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            // Before `RenderGraphSystems::Render`, where Bevy's camera driver records the views.
            render_app.add_systems(RenderGraph, step_gpu_fluids.before(RenderGraphSystems::Render));
        }
        super::gpu_coupled::build(app);
        super::gpu_solid::build(app);
    }
}

#[allow(clippy::type_complexity)]
fn upload_to_gpu(
    mut commands: Commands,
    sims: Query<(Entity, &FluidSimulation), (With<GpuStepping>, Without<GpuFluidHandle>)>,
    device: Option<Res<RenderDevice>>,
    queue: Option<Res<RenderQueue>>,
    buffers: Option<ResMut<Assets<ShaderBuffer>>>,
) {
    // (an app without Bevy's renderer has neither a device nor shader buffers)
    let (Some(device), Some(queue), Some(mut buffers)) = (device, queue, buffers) else { return };
    for (entity, sim) in &sims {
        let q: &wgpu::Queue = &queue.0;
        let gpu = match GpuFluid::from_device(device.wgpu_device().clone(), q.clone(), &device.limits(), &sim.solver) {
            Ok(g) => g,
            Err(e) => {
                warn!("phonation: {entity} stays on the CPU: {e}");
                commands.entity(entity).remove::<GpuStepping>();
                continue;
            }
        };
        let nodes: Vec<usize> = sim.probes.iter().map(|(_, n)| *n).collect();
        let mut buffer = ShaderBuffer::from(vec![0u32; 1 + 5 * nodes.len().max(1)]);
        buffer.buffer_description.usage |= wgpu::BufferUsages::COPY_SRC;
        let probes = buffers.add(buffer);
        commands
            .entity(entity)
            .insert((
                GpuFluidHandle { gpu: Arc::new(Mutex::new(gpu)), probes: probes.clone(), nodes: Arc::new(nodes), steps_this_frame: 0 },
                GpuProbes::default(),
                Readback::buffer(probes),
            ))
            .observe(read_probes);
    }
}

fn read_probes(event: On<ReadbackComplete>, mut probes: Query<&mut GpuProbes>) {
    let Ok(mut p) = probes.get_mut(event.entity) else { return };
    let words: Vec<u32> = event.data.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    if words.is_empty() {
        return;
    }
    p.step = words[0] as u64;
    p.values = words[1..].chunks_exact(5).map(|c| std::array::from_fn(|j| f32::from_bits(c[j]))).collect();
    p.readbacks += 1;
}

/// The frame's steps for the render world; none for a fluid whose [`GpuStepping`] was taken
/// off (it is on its way back, [`bring_back_fluids`]).
fn schedule_gpu_steps(steps: Res<StepsThisFrame>, mut handles: Query<(&mut GpuFluidHandle, Has<GpuStepping>)>) {
    for (mut h, stepping) in &mut handles {
        h.steps_this_frame = if stepping { steps.0 } else { 0 };
    }
}

/// Main world: a fluid whose [`GpuStepping`] was taken off is stepped no more on the device; a
/// frame later, when the render world has submitted every step it recorded into a frame,
/// its populations, step and time come back into its [`FluidSimulation`] and the CPU steps it
/// on from there (the device's copy, probes and their readback are dropped).
fn bring_back_fluids(
    mut sims: Query<(Entity, &GpuFluidHandle, &mut FluidSimulation), Without<GpuStepping>>,
    mut waiting: Local<Vec<Entity>>,
    mut commands: Commands,
) {
    let mut next = Vec::new();
    for (entity, h, mut sim) in &mut sims {
        if !waiting.contains(&entity) {
            // this frame records no steps for it
            next.push(entity);
            continue;
        }
        let gpu = h.gpu.lock().expect("GPU lattice lock");
        if !gpu.download_into(&mut sim.solver) {
            warn!("phonation: {entity}: the device's state could not be read back; it goes on from its initial state on the CPU");
        }
        commands.entity(entity).remove::<(GpuFluidHandle, GpuProbes, Readback)>();
    }
    *waiting = next;
}

/// Render world: records this frame's steps and the probe kernel into the frame's encoder.
pub(crate) fn step_gpu_fluids(mut ctx: RenderContext, handles: Query<&GpuFluidHandle>, buffers: Res<RenderAssets<GpuShaderBuffer>>) {
    for h in &handles {
        let Some(out) = buffers.get(&h.probes) else { continue };
        let mut gpu = h.gpu.lock().expect("GPU lattice lock");
        let enc = ctx.command_encoder();
        gpu.record_steps(enc, h.steps_this_frame as u64);
        gpu.record_probes(enc, &h.nodes, &out.buffer);
    }
}
