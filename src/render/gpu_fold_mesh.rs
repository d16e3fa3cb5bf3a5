//! The bodies of every [`CoupledSimulation`] and [`SolidSimulation`] as a surface made on the
//! GPU each frame they stepped, in the render world, and drawn from the buffers the kernels
//! wrote — no readback of the mesh. The CPU builds each body's level set L (seed 000 2.124:
//! the particles and their bins, O(N), [`SurfaceSource`]); the render world samples L on a grid
//! and runs marching cubes on the device ([`GpuFoldSurface`], the twin of
//! [`crate::mesh::particle_field::body_surfaces`], checked against it in tests/gpu/) into
//! storage buffers that a material ([`FoldSurfaceMaterial`], shaders/fold_surface_draw.wgsl)
//! draws, one colour per body. The buffers have room for twice the triangles of the first
//! surface; the triangle count comes back (4 bytes, through Bevy's `Readback`) for the panel
//! and to make more room when a surface outgrows it. Apps without a render device, or with
//! [`super::DrawSettings::folds_on_gpu`] off, get the CPU mesh ([`super::fold_mesh`]).

use super::DrawSettings;
use super::fold_mesh::BODY_COLOURS;
use crate::gpu::fold_surface::GpuFoldSurface;
use crate::gpu::marching_cubes::SurfaceBuffers;
use crate::plugin::{CoupledSimulation, SolidSimulation, StepsThisFrame};
use crate::run::surface::SurfaceSource;
use bevy::asset::{RenderAssetUsages, uuid_handle};
use bevy::camera::visibility::NoFrustumCulling;
use bevy::mesh::{MeshVertexBufferLayoutRef, PrimitiveTopology};
use bevy::pbr::{Material, MaterialPipeline, MaterialPipelineKey, MaterialPlugin};
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use bevy::render::gpu_readback::{Readback, ReadbackComplete};
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{AsBindGroup, RenderPipelineDescriptor, ShaderType, SpecializedMeshPipelineError};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderGraph, RenderGraphSystems};
use bevy::render::storage::{GpuShaderBuffer, ShaderBuffer};
use bevy::shader::{Shader, ShaderRef};
use std::collections::HashMap;
use std::sync::Arc;

const FOLD_SURFACE_SHADER: Handle<Shader> = uuid_handle!("2b7e9c41-5a3d-4e8f-b1c6-7d0a9e3f5c12");

/// The most triangles a surface's buffers hold: the draw's vertex index travels in an f32
/// (exact to 2²⁴ vertices).
pub const MAX_TRIANGLES: u32 = (1 << 24) / 3;

/// The bodies' colours (linear RGBA, [`BODY_COLOURS`]) and the light's direction (world, unit).
#[derive(Clone, Copy, Debug, ShaderType)]
pub struct FoldColours {
    pub body: [Vec4; 4],
    pub light: Vec4,
}

impl Default for FoldColours {
    fn default() -> Self {
        FoldColours { body: BODY_COLOURS.map(Vec4::from_array), light: Vec3::new(0.3, 0.5, 1.0).normalize().extend(0.0) }
    }
}

/// The material that draws a surface from the kernels' buffers: positions and normals (three
/// vec4 per triangle, the normal's w the body), the counter, the colours.
#[derive(Asset, TypePath, AsBindGroup, Debug, Clone)]
pub struct FoldSurfaceMaterial {
    #[storage(0, read_only)]
    pub positions: Handle<ShaderBuffer>,
    #[storage(1, read_only)]
    pub normals: Handle<ShaderBuffer>,
    #[storage(2, read_only)]
    pub counter: Handle<ShaderBuffer>,
    #[uniform(3)]
    pub colours: FoldColours,
}

impl Material for FoldSurfaceMaterial {
    fn vertex_shader() -> ShaderRef {
        ShaderRef::Handle(FOLD_SURFACE_SHADER)
    }

    fn fragment_shader() -> ShaderRef {
        ShaderRef::Handle(FOLD_SURFACE_SHADER)
    }

    fn enable_prepass() -> bool {
        false
    }

    fn enable_shadows() -> bool {
        false
    }

    /// Both faces drawn: a surface is seen from inside when the camera is.
    fn specialize(
        _pipeline: &MaterialPipeline,
        descriptor: &mut RenderPipelineDescriptor,
        _layout: &MeshVertexBufferLayoutRef,
        _key: MaterialPipelineKey<Self>,
    ) -> Result<(), SpecializedMeshPipelineError> {
        descriptor.primitive.cull_mode = None;
        Ok(())
    }
}

/// On a simulation entity whose bodies' surface is made on the GPU: the buffers the kernels
/// write and the material reads, their room, the surface to make, and the triangle count last
/// read back.
#[derive(Component, Clone, ExtractComponent)]
pub struct GpuFoldMesh {
    pub positions: Handle<ShaderBuffer>,
    pub normals: Handle<ShaderBuffer>,
    /// `[0]`: the triangles the kernels emitted (may exceed `capacity`).
    pub counter: Handle<ShaderBuffer>,
    /// Triangles the buffers hold.
    pub capacity: u32,
    /// The bodies' level sets as of the last frame that stepped (the render world makes the
    /// surface when this changes).
    pub source: Arc<SurfaceSource>,
    /// Triangles counted by the last readback (`None` before the first).
    pub triangles: Option<u32>,
    /// Steps were taken while the folds were hidden: the source is rebuilt when they show.
    stale: bool,
}

/// The entity that draws the GPU surface of simulation entity `.0`.
#[derive(Component, Debug, Clone, Copy)]
pub struct GpuFoldMeshOf(pub Entity);

pub struct GpuFoldMeshPlugin;

impl Plugin for GpuFoldMeshPlugin {
    fn build(&self, app: &mut App) {
        app.world_mut()
            .resource_mut::<Assets<Shader>>()
            .insert(
                FOLD_SURFACE_SHADER.id(),
                Shader::from_wgsl(include_str!("../../shaders/fold_surface_draw.wgsl"), "phonation/shaders/fold_surface_draw.wgsl"),
            )
            .expect("a fixed shader handle");
        app.add_plugins((MaterialPlugin::<FoldSurfaceMaterial>::default(), ExtractComponentPlugin::<GpuFoldMesh>::default())).add_systems(
            Update,
            (update_gpu_fold_meshes, spawn_gpu_fold_meshes).chain().after(super::fold_mesh::update_fold_meshes).in_set(super::DrawSystems::FoldMesh),
        );
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.add_systems(RenderGraph, make_gpu_fold_surfaces.before(RenderGraphSystems::Render));
        }
    }
}

/// The GPU surface is used for a simulation when the app renders and the settings ask for it.
pub(super) fn on_gpu(settings: &DrawSettings, device: Option<&RenderDevice>) -> bool {
    settings.folds_on_gpu && device.is_some()
}

/// Keeps each GPU surface's source current (rebuilt on frames that stepped, while the folds
/// show), shows or hides it, and takes it off a simulation that no longer wants it, is gone, or
/// outgrew its buffers (it is made again, with more room, by [`spawn_gpu_fold_meshes`]).
#[allow(clippy::type_complexity)]
fn update_gpu_fold_meshes(
    settings: Res<DrawSettings>,
    steps: Res<StepsThisFrame>,
    device: Option<Res<RenderDevice>>,
    mut sims: Query<(Entity, &mut GpuFoldMesh, Option<&CoupledSimulation>, Option<&SolidSimulation>)>,
    mut drawn: Query<(Entity, &GpuFoldMeshOf, &mut Visibility)>,
    mut commands: Commands,
) {
    let wanted = on_gpu(&settings, device.as_deref());
    let mut dropped = Vec::new();
    for (e, mut fm, coupled, solid) in &mut sims {
        let outgrown = fm.triangles.is_some_and(|t| t > fm.capacity);
        if outgrown {
            info!("phonation: {e}'s surface has {} triangles, more than its buffers' {}: made again with more room", fm.triangles.unwrap_or(0), fm.capacity);
        }
        if !wanted || outgrown || (coupled.is_none() && solid.is_none()) {
            commands.entity(e).remove::<GpuFoldMesh>();
            dropped.push(e);
            continue;
        }
        if steps.0 > 0 || fm.stale {
            if !settings.folds {
                fm.stale = true;
            } else if let Some(c) = coupled {
                (fm.source, fm.stale) = (Arc::new(SurfaceSource::coupled(&c.solver)), false);
            } else if let Some(s) = solid {
                (fm.source, fm.stale) = (Arc::new(SurfaceSource::solid(&s.solver)), false);
            }
        }
    }
    for (line, of, mut v) in &mut drawn {
        if dropped.contains(&of.0) || !sims.contains(of.0) {
            commands.entity(line).despawn();
            continue;
        }
        *v = if settings.folds { Visibility::Inherited } else { Visibility::Hidden };
    }
}

/// Gives every coupled or solid simulation without one a GPU surface: buffers with room for
/// twice the triangles of its present surface (counted on the CPU once), the mesh entity that
/// draws them (three vertices per triangle of room, each carrying its index) and the readback
/// of the counter.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn spawn_gpu_fold_meshes(
    settings: Res<DrawSettings>,
    device: Option<Res<RenderDevice>>,
    coupled: Query<(Entity, &CoupledSimulation), Without<GpuFoldMesh>>,
    solids: Query<(Entity, &SolidSimulation), (Without<GpuFoldMesh>, Without<CoupledSimulation>)>,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<FoldSurfaceMaterial>>,
    mut commands: Commands,
) {
    if !settings.folds || !on_gpu(&settings, device.as_deref()) {
        return;
    }
    let sources = coupled.iter().map(|(e, c)| (e, SurfaceSource::coupled(&c.solver))).chain(solids.iter().map(|(e, s)| (e, SurfaceSource::solid(&s.solver))));
    for (e, source) in sources {
        let capacity = (2 * source.mesh().triangles.len() as u32 + 1024).min(MAX_TRIANGLES);
        let vertices = 3 * capacity as usize;
        let mut storage = |bytes: usize| buffers.add(ShaderBuffer::with_size(bytes, RenderAssetUsages::RENDER_WORLD));
        let (positions, normals, counter) = (storage(16 * vertices), storage(16 * vertices), storage(16));
        let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::RENDER_WORLD);
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, (0..vertices).map(|k| [k as f32, 0.0, 0.0]).collect::<Vec<[f32; 3]>>());
        let material = materials.add(FoldSurfaceMaterial {
            positions: positions.clone(),
            normals: normals.clone(),
            counter: counter.clone(),
            colours: FoldColours::default(),
        });
        let (offset, scale) = (source.offset.as_vec3(), source.scale as f32);
        commands
            .spawn((
                GpuFoldMeshOf(e),
                Mesh3d(meshes.add(mesh)),
                MeshMaterial3d(material),
                // the level sets' coordinates to scene units: x ↦ (x + offset) · scale
                Transform::from_translation(offset * scale).with_scale(Vec3::splat(scale)),
                NoFrustumCulling,
                Readback::buffer(counter.clone()),
            ))
            .observe(read_triangle_count);
        commands.entity(e).insert(GpuFoldMesh { positions, normals, counter, capacity, source: Arc::new(source), triangles: None, stale: false });
    }
}

fn read_triangle_count(event: On<ReadbackComplete>, lines: Query<&GpuFoldMeshOf>, mut sims: Query<&mut GpuFoldMesh>) {
    let Ok(of) = lines.get(event.entity) else { return };
    let Ok(mut fm) = sims.get_mut(of.0) else { return };
    if let Some(b) = event.data.get(0..4) {
        fm.triangles = Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    }
}

/// Render world: for each surface whose source changed since it was last made (and whose
/// buffers exist), the level sets go up and the kernels run into the frame's encoder.
fn make_gpu_fold_surfaces(
    mut ctx: RenderContext,
    sims: Query<&GpuFoldMesh>,
    buffers: Res<RenderAssets<GpuShaderBuffer>>,
    device: Res<RenderDevice>,
    mut kernels: Local<Option<GpuFoldSurface>>,
    mut made: Local<HashMap<AssetId<ShaderBuffer>, Arc<SurfaceSource>>>,
) {
    let device = device.wgpu_device();
    let kernels = kernels.get_or_insert_with(|| GpuFoldSurface::new(device));
    let mut seen = Vec::new();
    for fm in &sims {
        let key = fm.counter.id();
        seen.push(key);
        if made.get(&key).is_some_and(|s| Arc::ptr_eq(s, &fm.source)) {
            continue;
        }
        let (Some(p), Some(n), Some(c)) = (buffers.get(&fm.positions), buffers.get(&fm.normals), buffers.get(&fm.counter)) else { continue };
        let out = SurfaceBuffers { counter: &c.buffer, positions: &p.buffer, normals: &n.buffer, capacity: fm.capacity };
        let s = &fm.source;
        kernels.record(device, ctx.command_encoder(), &s.sets, s.spacing, s.dim, &out);
        made.insert(key, fm.source.clone());
    }
    made.retain(|k, _| seen.contains(k));
}
