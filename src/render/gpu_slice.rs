//! The slice of a GPU-stepped fluid or coupled simulation ([`crate::plugin::GpuStepping`],
//! [`crate::plugin::GpuAir`]) made on the device in the
//! render world after the frame's steps, with no round trip of the field: the plane's moments
//! from the populations, the values in scene units, the colour scale's range and the pixels
//! ([`GpuSlice`], shaders/slice.wgsl, the twin of the CPU slice checked in tests/gpu/), the
//! pixels copied into the slice's texture. Only the range comes back (8 bytes, through Bevy's
//! `Readback`) for the panel's legend ([`SliceView::range`]). CPU-stepped simulations keep the
//! CPU slice ([`super::slice`]).

use super::DrawSettings;
use super::slice::{SliceView, unit_of};
use crate::gpu::slice::GpuSlice;
use crate::plugin::{CoupledSimulation, FluidSimulation, GpuAir, GpuCoupledHandle, GpuFluidHandle};
use crate::scene::schema::Field;
use bevy::asset::RenderAssetUsages;
use bevy::image::Image;
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use bevy::render::gpu_readback::{Readback, ReadbackComplete};
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderGraph, RenderGraphSystems};
use bevy::render::storage::{GpuShaderBuffer, ShaderBuffer};
use bevy::render::texture::GpuImage;
use std::sync::Arc;

/// On a GPU-stepped fluid entity: its slice's kernels and buffers, the texture they fill, the
/// buffer the range is copied into for the readback, and the field.
#[derive(Component, Clone, ExtractComponent)]
pub struct GpuSliceHandle {
    pub slice: Arc<GpuSlice>,
    pub image: Handle<Image>,
    pub range: Handle<ShaderBuffer>,
    pub field: Field,
}

/// The quad entity that shows the GPU slice of simulation entity `.0`.
#[derive(Component, Debug, Clone, Copy)]
pub struct GpuSliceOf(pub Entity);

pub struct GpuSlicePlugin;

impl Plugin for GpuSlicePlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(ExtractComponentPlugin::<GpuSliceHandle>::default()).add_systems(
            Update,
            (drop_stale_gpu_slices.before(super::slice::update_slices), update_gpu_slices.after(super::slice::update_slices)).in_set(super::DrawSystems::Slice),
        );
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app.add_systems(
                RenderGraph,
                make_gpu_slices
                    .after(crate::plugin::gpu::step_gpu_fluids)
                    .after(crate::plugin::gpu_coupled::step_gpu_coupled)
                    .before(RenderGraphSystems::Render),
            );
        }
    }
}

/// Makes (or remakes, when the field changed) the slice of every GPU-stepped fluid with units
/// while [`DrawSettings::slice`] names a field, and the quad that shows it (where the CPU slice
/// would be: [`super::slice::fluid_plane`]'s size and depth); shows or hides the quads; takes
/// the slice off when the field is `None` or the simulation is gone.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn update_gpu_slices(
    settings: Res<DrawSettings>,
    sims: Query<(Entity, AnyOf<(&FluidSimulation, &CoupledSimulation)>, AnyOf<(&GpuFluidHandle, &GpuCoupledHandle)>, Option<&GpuSliceHandle>)>,
    mut quads: Query<(Entity, &GpuSliceOf, &mut Visibility)>,
    device: Option<Res<RenderDevice>>,
    mut images: ResMut<Assets<Image>>,
    mut buffers: ResMut<Assets<ShaderBuffer>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut commands: Commands,
) {
    let mut dropped = Vec::new();
    for (e, sim, handle, current) in &sims {
        let (solver, units) = super::air_of(sim);
        let (Some(field), Some(units), Some(device)) = (settings.slice, units.as_ref(), device.as_deref()) else {
            if current.is_some() {
                commands.entity(e).remove::<(GpuSliceHandle, SliceView)>();
                dropped.push(e);
            }
            continue;
        };
        if current.is_some_and(|c| c.field == field) {
            continue;
        }
        if current.is_some() {
            dropped.push(e);
        }
        let grid = &solver.layout.grid;
        let map = crate::output::fields::plane_map(field, units);
        let Some(slice) = GpuAir(handle.0, handle.1).with_fluid(|f| GpuSlice::new(device.wgpu_device(), f, grid, map)) else { continue };
        let (w, h) = slice.size();
        let mut image = Image::new_uninit(
            Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            TextureDimension::D2,
            TextureFormat::Rgba8UnormSrgb,
            RenderAssetUsages::RENDER_WORLD,
        );
        image.texture_descriptor.usage |= TextureUsages::COPY_DST;
        let image = images.add(image);
        let range = buffers.add(ShaderBuffer::with_size(16, RenderAssetUsages::RENDER_WORLD));
        let plane = super::slice::plane_geometry(solver, units);
        let mat = materials.add(StandardMaterial { base_color_texture: Some(image.clone()), unlit: true, ..default() });
        commands
            .spawn((
                GpuSliceOf(e),
                Mesh3d(meshes.add(Rectangle::new(plane.0, plane.1))),
                MeshMaterial3d(mat),
                Transform::from_xyz(0.5 * plane.0, 0.5 * plane.1, plane.2),
                Visibility::default(),
                Readback::buffer(range.clone()),
            ))
            .observe(read_range);
        commands.entity(e).insert((
            GpuSliceHandle { slice: Arc::new(slice), image: image.clone(), range, field },
            // the range arrives with the first readback
            SliceView { image, field, range: (f64::NAN, f64::NAN), unit: unit_of(field) },
        ));
    }
    for (quad, of, mut v) in &mut quads {
        if dropped.contains(&of.0) || !sims.contains(of.0) {
            commands.entity(quad).despawn();
            continue;
        }
        *v = if settings.slice.is_some() { Visibility::Inherited } else { Visibility::Hidden };
    }
}

/// The GPU slice of a simulation that is no longer stepped on the device (its
/// [`crate::plugin::GpuStepping`] taken off) goes (its quad with it, [`update_gpu_slices`]),
/// before the CPU's slice makes its own view.
#[allow(clippy::type_complexity)]
fn drop_stale_gpu_slices(stale: Query<Entity, (With<GpuSliceHandle>, Without<GpuFluidHandle>, Without<GpuCoupledHandle>)>, mut commands: Commands) {
    for e in &stale {
        commands.entity(e).remove::<(GpuSliceHandle, SliceView)>();
    }
}

fn read_range(event: On<ReadbackComplete>, quads: Query<&GpuSliceOf>, mut views: Query<&mut SliceView>) {
    let Ok(of) = quads.get(event.entity) else { return };
    let Ok(mut view) = views.get_mut(of.0) else { return };
    if let Some(b) = event.data.get(0..8) {
        let f = |k: usize| f32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]) as f64;
        view.range = (f(0), f(4));
    }
}

/// Render world, after the frame's fluid steps: the slice's kernels, its pixels into the
/// texture and its range into the read-back buffer — on the frames that stepped, and on the
/// first frames of a slice until its texture exists.
fn make_gpu_slices(
    mut ctx: RenderContext,
    sims: Query<(AnyOf<(&GpuFluidHandle, &GpuCoupledHandle)>, &GpuSliceHandle)>,
    images: Res<RenderAssets<GpuImage>>,
    buffers: Res<RenderAssets<GpuShaderBuffer>>,
    mut made: Local<Vec<AssetId<Image>>>,
) {
    let mut seen = Vec::new();
    for (air, s) in &sims {
        let air = GpuAir(air.0, air.1);
        let id = s.image.id();
        seen.push(id);
        if air.steps_this_frame() == 0 && made.contains(&id) {
            continue;
        }
        let (Some(image), Some(range)) = (images.get(&s.image), buffers.get(&s.range)) else { continue };
        let enc = ctx.command_encoder();
        if air.with_fluid(|gpu| s.slice.record(gpu, enc)).is_none() {
            continue;
        }
        let (w, h) = s.slice.size();
        enc.copy_buffer_to_texture(
            wgpu::TexelCopyBufferInfo {
                buffer: s.slice.pixels(),
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(s.slice.bytes_per_row()), rows_per_image: Some(h) },
            },
            image.texture.as_image_copy(),
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        enc.copy_buffer_to_buffer(s.slice.range(), 0, &range.buffer, 0, 16);
        if !made.contains(&id) {
            made.push(id);
        }
    }
    made.retain(|id| seen.contains(id));
}
