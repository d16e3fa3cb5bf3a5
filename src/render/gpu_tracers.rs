//! Tracers of a GPU-stepped fluid or coupled simulation ([`crate::plugin::GpuStepping`],
//! [`crate::plugin::GpuAir`]) advected and drawn on the GPU,
//! with no round trip through the CPU: the tracer kernel ([`crate::gpu::tracers::GpuTracers`],
//! RK2 through the GPU fluid's macro buffer, checked against its CPU twin in tests/gpu/) runs
//! in the render world right after the frame's fluid steps, its positions are copied (device to
//! device) into a storage buffer that a line material ([`TracerLineMaterial`],
//! shaders/tracer_lines.wgsl) reads in its vertex shader, one streak per tracer from where it
//! was a frame ago to where it is. The CPU tracers ([`super::tracers`]) draw the CPU-stepped
//! simulations.

use super::DrawSettings;
use crate::gpu::tracers::GpuTracers;
use crate::plugin::{CoupledSimulation, FluidSimulation, GpuAir, GpuCoupledHandle, GpuFluidHandle};
use bevy::asset::{RenderAssetUsages, uuid_handle};
use bevy::camera::visibility::NoFrustumCulling;
use bevy::mesh::PrimitiveTopology;
use bevy::pbr::{Material, MaterialPlugin};
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::AsBindGroup;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderGraph, RenderGraphSystems, RenderQueue};
use bevy::render::storage::{GpuShaderBuffer, ShaderBuffer};
use bevy::shader::{Shader, ShaderRef};
use std::sync::{Arc, Mutex};

const TRACER_LINES_SHADER: Handle<Shader> = uuid_handle!("6f2c3a8e-4d51-4f0b-9a7e-2b6c1d9e8f30");

/// The line material of the GPU tracers: the storage buffer of positions (now, a frame ago) and
/// the displacement per frame (cells) mapped to the top of the colour scale.
#[derive(Asset, TypePath, AsBindGroup, Debug, Clone)]
pub struct TracerLineMaterial {
    #[storage(0, read_only)]
    pub tracers: Handle<ShaderBuffer>,
    #[uniform(1)]
    pub scale: Vec4,
}

impl Material for TracerLineMaterial {
    fn vertex_shader() -> ShaderRef {
        ShaderRef::Handle(TRACER_LINES_SHADER)
    }

    fn fragment_shader() -> ShaderRef {
        ShaderRef::Handle(TRACER_LINES_SHADER)
    }

    fn enable_prepass() -> bool {
        false
    }

    fn enable_shadows() -> bool {
        false
    }
}

/// On a GPU-stepped fluid entity: its tracers on the device and the buffer they are drawn from.
#[derive(Component, Clone, ExtractComponent)]
pub struct GpuTracerHandle {
    pub tracers: Arc<Mutex<GpuTracers>>,
    /// 2n vec4: positions now (0..n) and a frame ago (n..2n).
    pub drawn: Handle<ShaderBuffer>,
    /// Lattice time of one fluid step.
    pub dt: f64,
}

/// The line entity that draws the GPU tracers of simulation entity `.0`.
#[derive(Component, Debug, Clone, Copy)]
pub struct GpuTracersOf(pub Entity);

pub struct GpuTracerPlugin;

impl Plugin for GpuTracerPlugin {
    fn build(&self, app: &mut App) {
        app.world_mut()
            .resource_mut::<Assets<Shader>>()
            .insert(TRACER_LINES_SHADER.id(), Shader::from_wgsl(include_str!("../../shaders/tracer_lines.wgsl"), "phonation/shaders/tracer_lines.wgsl"))
            .expect("a fixed shader handle");
        app.add_plugins((MaterialPlugin::<TracerLineMaterial>::default(), ExtractComponentPlugin::<GpuTracerHandle>::default()))
            .add_systems(Update, (drop_stale_gpu_tracers.before(super::tracers::advance_tracers), spawn_gpu_tracers).in_set(super::DrawSystems::Tracers));
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.add_systems(
                RenderGraph,
                advect_gpu_tracers
                    .after(crate::plugin::gpu::step_gpu_fluids)
                    .after(crate::plugin::gpu_coupled::step_gpu_coupled)
                    .before(RenderGraphSystems::Render),
            );
        }
    }
}

/// Puts tracers on the device of every GPU-stepped fluid (born as the CPU tracers are,
/// [`super::tracers::FlowTracers::at_inlet`]) and spawns the line mesh that draws them; shows or
/// hides the lines with [`DrawSettings::tracers`], and despawns those whose simulation is gone.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn spawn_gpu_tracers(
    settings: Res<DrawSettings>,
    sims: Query<(Entity, AnyOf<(&FluidSimulation, &CoupledSimulation)>, AnyOf<(&GpuFluidHandle, &GpuCoupledHandle)>), Without<GpuTracerHandle>>,
    owners: Query<(), With<GpuTracerHandle>>,
    mut lines: Query<(Entity, &GpuTracersOf, &mut Visibility)>,
    device: Option<Res<RenderDevice>>,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<TracerLineMaterial>>,
    mut commands: Commands,
) {
    for (line, of, mut v) in &mut lines {
        // the lines of a simulation that is gone (or lost its tracers) go too
        if !owners.contains(of.0) {
            commands.entity(line).despawn();
            continue;
        }
        *v = if settings.tracers { Visibility::Inherited } else { Visibility::Hidden };
    }
    let Some(device) = device else { return };
    for (e, sim, handle) in &sims {
        let (s, units) = super::air_of(sim);
        let Some(stride) = GpuAir(handle.0, handle.1).with_fluid(|f| f.macro_buffers().2) else { continue };
        let seeded = super::tracers::FlowTracers::at_inlet(s, settings.tracer_count).tracers;
        let gpu = GpuTracers::on_device(device.wgpu_device(), &seeded, &s.layout.grid, stride);
        let n = seeded.positions.len();
        let start: Vec<[f32; 4]> = seeded.positions.iter().chain(&seeded.positions).map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0]).collect();
        let mut buffer = ShaderBuffer::from(start);
        buffer.buffer_description.usage |= wgpu::BufferUsages::COPY_DST;
        let drawn = buffers.add(buffer);
        // one line per tracer; a vertex's position is (tracer, end, 0) for the shader
        let mut mesh = Mesh::new(PrimitiveTopology::LineList, RenderAssetUsages::RENDER_WORLD);
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, (0..n).flat_map(|k| [[k as f32, 0.0, 0.0], [k as f32, 1.0, 0.0]]).collect::<Vec<[f32; 3]>>());
        let dx = units.map_or(1.0, |u| u.dx) as f32;
        let z = if s.layout.grid.dim == 3 { 0.5 * dx } else { 0.3 * dx };
        let material = materials.add(TracerLineMaterial { tracers: drawn.clone(), scale: Vec4::new(0.25, 0.0, 0.0, 0.0) });
        commands.spawn((
            GpuTracersOf(e),
            Mesh3d(meshes.add(mesh)),
            MeshMaterial3d(material),
            // lattice coordinates (cell centres at +½) to scene units
            Transform::from_xyz(0.5 * dx, 0.5 * dx, z).with_scale(Vec3::splat(dx)),
            NoFrustumCulling,
            if settings.tracers { Visibility::Inherited } else { Visibility::Hidden },
        ));
        commands.entity(e).insert(GpuTracerHandle { tracers: Arc::new(Mutex::new(gpu)), drawn, dt: s.params.dt });
    }
}

/// The GPU tracers of a simulation that is no longer stepped on the device (its
/// [`crate::plugin::GpuStepping`] taken off): they go (their lines with them, next frame), and
/// the CPU's tracers take over.
#[allow(clippy::type_complexity)]
fn drop_stale_gpu_tracers(stale: Query<Entity, (With<GpuTracerHandle>, Without<GpuFluidHandle>, Without<GpuCoupledHandle>)>, mut commands: Commands) {
    for e in &stale {
        commands.entity(e).remove::<GpuTracerHandle>();
    }
}

/// Render world, after the frame's fluid steps: the positions a frame ago, the kernel over the
/// frame's steps, the positions now — all on the device.
fn advect_gpu_tracers(
    mut ctx: RenderContext,
    sims: Query<(AnyOf<(&GpuFluidHandle, &GpuCoupledHandle)>, &GpuTracerHandle)>,
    buffers: Res<RenderAssets<GpuShaderBuffer>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    for (air, tracers) in &sims {
        let air = GpuAir(air.0, air.1);
        let steps = air.steps_this_frame();
        let Some(drawn) = buffers.get(&tracers.drawn) else { continue };
        if steps == 0 {
            continue;
        }
        air.with_fluid(|fluid| {
            let (mac, kind, _) = fluid.macro_buffers();
            let mut t = tracers.tracers.lock().expect("GPU tracers lock");
            let bytes = 16 * t.count() as u64;
            let q: &wgpu::Queue = &queue.0;
            let enc = ctx.command_encoder();
            enc.copy_buffer_to_buffer(&t.tracers, 0, &drawn.buffer, bytes, bytes);
            t.record_on(device.wgpu_device(), q, enc, mac, kind, tracers.dt, steps);
            enc.copy_buffer_to_buffer(&t.tracers, 0, &drawn.buffer, 0, bytes);
        });
    }
}
