//! The bodies of every [`CoupledSimulation`] and [`SolidSimulation`] as a triangle mesh: the
//! level set of their particles through marching cubes ([`crate::run::surface`]), rebuilt on
//! the frames the simulation stepped, one colour per body (the two folds of a glottis apart).
//! World units are the scene's (cm for the glottis). This is the CPU path: in an app that
//! renders, the same surface is made on the GPU ([`super::gpu_fold_mesh`]) unless
//! [`super::DrawSettings::folds_on_gpu`] is off.

use super::{DrawSettings, DrawSystems};
use crate::mesh::TriangleMesh;
use crate::plugin::{CoupledSimulation, SolidSimulation, StepsThisFrame};
use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;

/// Body colours (linear RGBA): rose for the first fold, a deeper rose for the second, then
/// other hues.
pub const BODY_COLOURS: [[f32; 4]; 4] = [[0.55, 0.08, 0.14, 1.0], [0.42, 0.05, 0.12, 1.0], [0.1, 0.25, 0.6, 1.0], [0.2, 0.45, 0.12, 1.0]];

/// The mesh entity drawing the bodies of simulation entity `.0`.
#[derive(Component, Debug, Clone, Copy)]
pub struct FoldMeshOf(pub Entity);

/// On a simulation entity: the handle of its bodies' mesh, and the triangles last drawn.
#[derive(Component, Debug, Clone)]
pub struct FoldMesh {
    pub mesh: Handle<Mesh>,
    pub triangles: usize,
}

pub struct FoldMeshPlugin;

impl Plugin for FoldMeshPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(Update, update_fold_meshes.in_set(DrawSystems::FoldMesh));
    }
}

/// A Bevy mesh of `m` (positions and normals as f32, a colour per vertex from its body tag).
pub fn to_bevy_mesh(m: &TriangleMesh) -> Mesh {
    let pos: Vec<[f32; 3]> = m.positions.iter().map(|p| p.as_vec3().to_array()).collect();
    let nor: Vec<[f32; 3]> = m.normals.iter().map(|n| n.as_vec3().to_array()).collect();
    let col: Vec<[f32; 4]> = (0..m.positions.len()).map(|i| BODY_COLOURS[m.scalars.get(i).map_or(0, |s| *s as usize) % BODY_COLOURS.len()]).collect();
    let idx: Vec<u32> = m.triangles.iter().flatten().copied().collect();
    Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, pos)
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, nor)
        .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, col)
        .with_inserted_indices(Indices::U32(idx))
}

#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub(super) fn update_fold_meshes(
    settings: Res<DrawSettings>,
    steps: Res<StepsThisFrame>,
    mut sims: ParamSet<(Query<(Entity, &CoupledSimulation, Option<&mut FoldMesh>)>, Query<(Entity, &SolidSimulation, Option<&mut FoldMesh>)>)>,
    mut drawn: Query<(Entity, &mut Visibility), With<FoldMeshOf>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: Option<ResMut<Assets<StandardMaterial>>>,
    device: Option<Res<bevy::render::renderer::RenderDevice>>,
    mut commands: Commands,
) {
    if super::gpu_fold_mesh::on_gpu(&settings, device.as_deref()) {
        // the surfaces are made on the GPU (super::gpu_fold_mesh): no CPU mesh
        for (e, _) in &drawn {
            commands.entity(e).despawn();
        }
        for (e, _, fm) in &sims.p0() {
            if fm.is_some() {
                commands.entity(e).remove::<FoldMesh>();
            }
        }
        for (e, _, fm) in &sims.p1() {
            if fm.is_some() {
                commands.entity(e).remove::<FoldMesh>();
            }
        }
        return;
    }
    for (_, mut vis) in &mut drawn {
        *vis = if settings.folds { Visibility::Inherited } else { Visibility::Hidden };
    }
    if !settings.folds {
        return;
    }
    let mut surfaces: Vec<(Entity, Option<Handle<Mesh>>, TriangleMesh)> = Vec::new();
    for (e, sim, fm) in &sims.p0() {
        if fm.is_none() || steps.0 > 0 {
            surfaces.push((e, fm.map(|f| f.mesh.clone()), crate::run::surface::coupled_surface(&sim.solver)));
        }
    }
    for (e, sim, fm) in &sims.p1() {
        if fm.is_none() || steps.0 > 0 {
            surfaces.push((e, fm.map(|f| f.mesh.clone()), crate::run::surface::solid_surface(&sim.solver)));
        }
    }
    for (e, handle, surface) in surfaces {
        let mesh = to_bevy_mesh(&surface);
        match handle {
            Some(h) => {
                if let Some(mut m) = meshes.get_mut(&h) {
                    *m = mesh;
                }
                commands.entity(e).insert(FoldMesh { mesh: h, triangles: surface.triangles.len() });
            }
            None => {
                let h = meshes.add(mesh);
                commands.entity(e).insert(FoldMesh { mesh: h.clone(), triangles: surface.triangles.len() });
                if let Some(mats) = materials.as_deref_mut() {
                    let mat =
                        mats.add(StandardMaterial { base_color: Color::WHITE, perceptual_roughness: 0.6, double_sided: true, cull_mode: None, ..default() });
                    commands.spawn((FoldMeshOf(e), Mesh3d(h), MeshMaterial3d(mat), Transform::default(), Visibility::default()));
                }
            }
        }
    }
}
