//! The plane of the lattice (z-mid in 3D) as a colour-mapped image behind the folds: speed or
//! temperature on the dark-to-yellow map, pressure or vorticity on the blue–white–red map
//! symmetric about zero, solids grey — the maps of the PNG snapshots. Its range in physical
//! units is kept in [`SliceView`] for the panel's legend.

use super::{DrawSettings, DrawSystems};
use crate::output::fields::{Slice, slice};
use crate::output::png_map::{colour, colour_range};
use crate::plugin::{CoupledSimulation, StepsThisFrame};
use crate::scene::schema::Field;
use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};

/// On a simulation entity: its slice image and what it shows.
#[derive(Component, Debug, Clone)]
pub struct SliceView {
    pub image: Handle<Image>,
    pub field: Field,
    /// The values at the two ends of the colour scale (physical units).
    pub range: (f64, f64),
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

/// RGBA8 pixels of `s` (rows from the top, y up in the world) in the PNG snapshots' colours, and
/// the range mapped.
pub fn pixels(s: &Slice, field: Field) -> (Vec<u8>, (f64, f64)) {
    let range = colour_range(s, signed(field));
    let mut data = Vec::with_capacity(4 * s.nx * s.ny);
    for row in 0..s.ny {
        let y = s.ny - 1 - row;
        for x in 0..s.nx {
            let rgb = colour(s.values[x + s.nx * y], range, signed(field));
            data.extend_from_slice(&[rgb[0], rgb[1], rgb[2], 255]);
        }
    }
    (data, range)
}

pub struct SlicePlugin;

impl Plugin for SlicePlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(Update, update_slices.in_set(DrawSystems::Slice));
    }
}

#[allow(clippy::too_many_arguments)]
fn update_slices(
    settings: Res<DrawSettings>,
    steps: Res<StepsThisFrame>,
    mut sims: Query<(Entity, &CoupledSimulation, Option<&mut SliceView>)>,
    mut quads: Query<&mut Visibility, With<SliceOf>>,
    mut images: ResMut<Assets<Image>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut commands: Commands,
) {
    for mut v in &mut quads {
        *v = if settings.slice.is_some() { Visibility::Inherited } else { Visibility::Hidden };
    }
    let Some(field) = settings.slice else { return };
    for (e, sim, view) in &mut sims {
        let c = &sim.solver;
        let changed = view.as_ref().is_none_or(|v| v.field != field);
        if steps.0 == 0 && !changed {
            continue;
        }
        let s = slice(&c.fluid, &c.units, field);
        let (data, range) = pixels(&s, field);
        match view {
            Some(mut v) => {
                if let Some(mut img) = images.get_mut(&v.image) {
                    img.data = Some(data);
                }
                v.field = field;
                v.range = range;
            }
            None => {
                let image = images.add(Image::new(
                    Extent3d { width: s.nx as u32, height: s.ny as u32, depth_or_array_layers: 1 },
                    TextureDimension::D2,
                    data,
                    TextureFormat::Rgba8UnormSrgb,
                    RenderAssetUsages::default(),
                ));
                let g = &c.fluid.layout.grid;
                let dx = c.units.dx as f32;
                let (w, h) = (g.n[0] as f32 * dx, g.n[1] as f32 * dx);
                let z = if g.dim == 3 { 0.5 * g.n[2] as f32 * dx } else { -dx };
                let mat = materials.add(StandardMaterial { base_color_texture: Some(image.clone()), unlit: true, ..default() });
                commands.spawn((
                    SliceOf(e),
                    Mesh3d(meshes.add(Rectangle::new(w, h))),
                    MeshMaterial3d(mat),
                    Transform::from_xyz(0.5 * w, 0.5 * h, z),
                    Visibility::default(),
                ));
                commands.entity(e).insert(SliceView { image, field, range });
            }
        }
    }
}
