//! The plane of the lattice (z-mid in 3D) as a colour-mapped image behind the folds: speed or
//! temperature on the dark-to-yellow map, pressure or vorticity on the blue–white–red map
//! symmetric about zero, solids grey — the maps of the PNG snapshots. Drawn for coupled and
//! fluid simulations (scene units) and for the lattice gas (its coarse-grained field averaged
//! over Z, in ℓ and steps: speed, density, vorticity). Its range and unit are kept in
//! [`SliceView`] for the panel's legend. A GPU-stepped fluid ([`crate::plugin::GpuStepping`]) gets
//! its slice from a compute pass on the device instead ([`super::gpu_slice`]): its CPU mirror is
//! not stepped.

use super::{DrawSettings, DrawSystems};
use crate::fluid::FluidSolver;
use crate::lattice_gas::coarse::coarse_grain;
use crate::output::coarse::{CoarseMap, z_mean_slice};
use crate::output::fields::{Slice, slice};
use crate::output::png_map::rgba_top_down;
use crate::plugin::{CoupledSimulation, FluidSimulation, LatticeGasSimulation, StepsThisFrame};
use crate::scene::schema::Field;
use crate::units::Units;
use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};

/// On a simulation entity: its slice image and what it shows.
#[derive(Component, Debug, Clone)]
pub struct SliceView {
    pub image: Handle<Image>,
    pub field: Field,
    /// The values at the two ends of the colour scale, in `unit`.
    pub range: (f64, f64),
    /// The unit of the values (scene units; ℓ and steps for the lattice gas).
    pub unit: &'static str,
}

/// The quad entity showing the slice of simulation entity `.0`.
#[derive(Component, Debug, Clone, Copy)]
pub struct SliceOf(pub Entity);

/// Unit of a field as the legend writes it (scene units: cgs for the glottis).
pub fn unit_of(f: Field) -> &'static str {
    match f {
        Field::Density => "g/cm³",
        Field::Speed => "cm/s",
        Field::Pressure => "dyn/cm² (gauge)",
        Field::Temperature => "T/T₀",
        Field::Vorticity => "1/s",
    }
}

/// Whether a field is drawn on the signed (diverging) map.
pub fn signed(f: Field) -> bool {
    matches!(f, Field::Pressure | Field::Vorticity)
}

/// A plane to draw: its values, its size in world units, its depth and its values' unit.
pub struct Plane {
    pub slice: Slice,
    pub size: (f32, f32),
    pub z: f32,
    pub unit: &'static str,
}

/// The z-mid plane of an FDLB lattice (scene units).
pub fn fluid_plane(s: &FluidSolver, units: &Units, field: Field) -> Plane {
    let (w, h, z) = plane_geometry(s, units);
    Plane { slice: slice(s, units, field), size: (w, h), z, unit: unit_of(field) }
}

/// Where an FDLB lattice's plane is drawn: its width and height and its depth (scene units;
/// behind the bodies in 2D, at mid-depth in 3D).
pub fn plane_geometry(s: &FluidSolver, units: &Units) -> (f32, f32, f32) {
    let g = &s.layout.grid;
    let dx = units.dx as f32;
    let z = if g.dim == 3 { 0.5 * g.n[2] as f32 * dx } else { -dx };
    (g.n[0] as f32 * dx, g.n[1] as f32 * dx, z)
}

/// The lattice gas's coarse-grained field, averaged over Z, in ℓ (its cells are 2ℓ): speed,
/// density or vorticity; `None` for the fields a lattice gas does not define here (pressure,
/// temperature).
pub fn gas_plane(sim: &LatticeGasSimulation, field: Field) -> Option<Plane> {
    let (map, unit) = match field {
        Field::Speed => (CoarseMap::Speed, "ℓ/step"),
        Field::Density => (CoarseMap::Density, "particles/link"),
        Field::Vorticity => (CoarseMap::Vorticity, "1/step"),
        Field::Pressure | Field::Temperature => return None,
    };
    let f = coarse_grain(&sim.gas, sim.coarse_block);
    let d = sim.gas.dims;
    Some(Plane { slice: z_mean_slice(&f, map), size: (2.0 * d[0] as f32, 2.0 * d[1] as f32), z: -2.0, unit })
}

pub struct SlicePlugin;

impl Plugin for SlicePlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(Update, update_slices.in_set(DrawSystems::Slice));
    }
}

#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(super) fn update_slices(
    settings: Res<DrawSettings>,
    steps: Res<StepsThisFrame>,
    mut sims: Query<
        (Entity, Option<&CoupledSimulation>, Option<&FluidSimulation>, Option<&LatticeGasSimulation>, Option<&mut SliceView>),
        (
            Or<(With<CoupledSimulation>, With<FluidSimulation>, With<LatticeGasSimulation>)>,
            Without<crate::plugin::GpuFluidHandle>,
            Without<crate::plugin::GpuCoupledHandle>,
        ),
    >,
    mut quads: Query<(Entity, &SliceOf, &mut Visibility)>,
    mut images: ResMut<Assets<Image>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut commands: Commands,
) {
    // the simulations that hold a view of their slice as the frame starts: a quad of any other
    // (gone, stepped on the GPU, or cleared for a rebuild) goes with it
    let viewed: Vec<Entity> = sims.iter().filter(|(.., v)| v.is_some()).map(|(e, ..)| e).collect();
    let mut shown = Vec::new();
    if let Some(field) = settings.slice {
        for (e, coupled, fluid, gas, view) in &mut sims {
            // the image of this field is drawn and nothing moved: nothing to compute
            if steps.0 == 0 && view.as_ref().is_some_and(|v| v.field == field) {
                shown.push(e);
                continue;
            }
            let plane = match (coupled, fluid, gas) {
                (Some(c), _, _) => Some(fluid_plane(&c.solver.fluid, &c.solver.units, field)),
                (None, Some(f), _) => f.units.as_ref().map(|u| fluid_plane(&f.solver, u, field)),
                (None, None, Some(g)) => gas_plane(g, field),
                _ => continue,
            };
            // a field the simulation does not have: no slice (the panel says why)
            let Some(plane) = plane else { continue };
            shown.push(e);
            let (data, range) = rgba_top_down(&plane.slice, signed(field));
            match view {
                Some(mut v) => {
                    if let Some(mut img) = images.get_mut(&v.image) {
                        img.data = Some(data);
                    }
                    (v.field, v.range, v.unit) = (field, range, plane.unit);
                }
                None => {
                    let image = images.add(Image::new(
                        Extent3d { width: plane.slice.nx as u32, height: plane.slice.ny as u32, depth_or_array_layers: 1 },
                        TextureDimension::D2,
                        data,
                        TextureFormat::Rgba8UnormSrgb,
                        RenderAssetUsages::default(),
                    ));
                    let (w, h) = plane.size;
                    let mat = materials.add(StandardMaterial { base_color_texture: Some(image.clone()), unlit: true, ..default() });
                    commands.spawn((
                        SliceOf(e),
                        Mesh3d(meshes.add(Rectangle::new(w, h))),
                        MeshMaterial3d(mat),
                        Transform::from_xyz(0.5 * w, 0.5 * h, plane.z),
                        Visibility::default(),
                    ));
                    commands.entity(e).insert(SliceView { image, field, range, unit: plane.unit });
                }
            }
        }
    }
    for (quad, of, mut v) in &mut quads {
        if !viewed.contains(&of.0) {
            commands.entity(quad).despawn();
            continue;
        }
        *v = if shown.contains(&of.0) { Visibility::Inherited } else { Visibility::Hidden };
    }
}
