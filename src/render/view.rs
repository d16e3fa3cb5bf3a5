//! The camera and frame capture of an app that shows a simulation: [`FrameSimulation`] points a
//! camera at the lattice of the first simulation (coupled, fluid or lattice gas; orthographic, the whole domain in view, the
//! 2D plane face-on) whenever a simulation is (re)built; [`CapturePlugin`] renders a number of
//! frames, saves a screenshot of the primary window and exits (the examples' `--frames N
//! --screenshot FILE`).

use crate::plugin::{CoupledSimulation, FluidSimulation, LatticeGasSimulation};
use bevy::camera::{OrthographicProjection, Projection, ScalingMode};
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use std::path::PathBuf;

/// On a `Camera3d`: keep the simulation's domain in view.
#[derive(Component, Debug, Clone, Copy, Default)]
pub struct FrameSimulation;

/// The domain of a simulation in world units (scene units): lower and upper corner.
fn domain(grid: &crate::fluid::Grid, dx: f64) -> (Vec3, Vec3) {
    let n = Vec3::new(grid.n[0] as f32, grid.n[1] as f32, if grid.dim == 3 { grid.n[2] as f32 } else { 0.0 });
    (Vec3::ZERO, n * dx as f32)
}

/// Points the [`FrameSimulation`] cameras at the first simulation's domain when that domain
/// changes (a new scene) or a camera is added, and leaves them alone otherwise (an app may move
/// them).
pub fn frame_simulations(
    coupled: Query<&CoupledSimulation>,
    fluids: Query<&FluidSimulation>,
    gases: Query<&LatticeGasSimulation>,
    added: Query<(), Added<FrameSimulation>>,
    mut framed: Local<Option<(Vec3, Vec3)>>,
    mut cams: Query<(&mut Transform, &mut Projection), With<FrameSimulation>>,
) {
    let Some((lo, hi)) = coupled
        .iter()
        .next()
        .map(|c| domain(&c.solver.fluid.layout.grid, c.solver.units.dx))
        .or_else(|| fluids.iter().next().map(|f| domain(&f.solver.layout.grid, f.units.map_or(1.0, |u| u.dx))))
        // the lattice gas in ℓ (cells are 2ℓ), seen as its Z-averaged plane
        .or_else(|| gases.iter().next().map(|g| (Vec3::ZERO, Vec3::new(2.0 * g.gas.dims[0] as f32, 2.0 * g.gas.dims[1] as f32, 0.0))))
    else {
        return;
    };
    if *framed == Some((lo, hi)) && added.is_empty() {
        return;
    }
    *framed = Some((lo, hi));
    let size = hi - lo;
    let centre = 0.5 * (lo + hi);
    for (mut t, mut p) in &mut cams {
        let dist = 4.0 * size.max_element().max(1e-6);
        *t = Transform::from_translation(centre + Vec3::new(0.0, 0.0, dist + 0.5 * size.z)).looking_at(centre, Vec3::Y);
        *p = Projection::Orthographic(OrthographicProjection {
            // room on the left for the panel
            scaling_mode: ScalingMode::AutoMin { min_width: size.x * 1.9, min_height: size.y * 1.08 },
            near: 0.0,
            far: 2.0 * dist + size.z,
            ..OrthographicProjection::default_3d()
        });
        t.translation.x -= 0.4 * size.x;
    }
}

/// Render `frames` frames, then save the primary window to `path` and exit.
#[derive(Resource, Debug, Clone)]
pub struct CapturePlugin {
    pub frames: u32,
    pub path: PathBuf,
}

impl Plugin for CapturePlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(self.clone()).add_systems(Last, capture);
    }
}

fn capture(cfg: Res<CapturePlugin>, mut frame: Local<u32>, mut commands: Commands, mut exit: MessageWriter<AppExit>) {
    *frame += 1;
    if *frame == cfg.frames {
        commands.spawn(Screenshot::primary_window()).observe(save_to_disk(cfg.path.clone()));
    }
    // the capture is read back and written a few frames later
    if *frame > cfg.frames && (cfg.path.exists() || *frame > cfg.frames + 120) {
        if *frame > cfg.frames + 120 {
            error!("phonation: no screenshot at {} after 120 frames", cfg.path.display());
            exit.write(AppExit::error());
        } else {
            exit.write(AppExit::Success);
        }
    }
}
