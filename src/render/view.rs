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

/// Render `frames` frames, then save the primary window to `path` and exit; before it, print
/// the frames per second and simulation steps per second of the frames after the first third
/// (a headless app's speed, on whatever adapter it renders with).
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

/// Wall time and simulation steps of the frames after the first third (the first frames
/// compile pipelines and upload the scene).
#[derive(Default)]
struct FrameClock {
    start: Option<(std::time::Instant, u32)>,
    steps: u64,
}

fn capture(
    cfg: Res<CapturePlugin>,
    steps: Option<Res<crate::plugin::StepsThisFrame>>,
    mut frame: Local<u32>,
    mut clock: Local<FrameClock>,
    mut commands: Commands,
    mut exit: MessageWriter<AppExit>,
) {
    *frame += 1;
    let warm = (cfg.frames / 3).max(1);
    if *frame == warm {
        clock.start = Some((std::time::Instant::now(), warm));
    } else if *frame > warm && *frame <= cfg.frames {
        clock.steps += steps.map_or(0, |s| s.0 as u64);
    }
    if *frame == cfg.frames {
        if let Some(line) = clock.start.and_then(|(t0, f0)| frame_rates(cfg.frames - f0, clock.steps, t0.elapsed().as_secs_f64())) {
            println!("phonation: frames {}–{}: {line}", warm + 1, cfg.frames);
        }
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

/// "F frames/s, S simulation steps/s (N steps per frame)" for `frames` frames of `steps` steps
/// in all over `seconds` of wall time (None for no frames or no time).
pub fn frame_rates(frames: u32, steps: u64, seconds: f64) -> Option<String> {
    (frames > 0 && seconds > 0.0).then(|| {
        format!(
            "{:.2} frames/s, {:.1} simulation steps/s ({:.1} steps per frame; {frames} frames in {seconds:.2} s)",
            frames as f64 / seconds,
            steps as f64 / seconds,
            steps as f64 / frames as f64
        )
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn frame_rates_divide_by_the_wall_time() {
        assert_eq!(super::frame_rates(20, 100, 4.0).as_deref(), Some("5.00 frames/s, 25.0 simulation steps/s (5.0 steps per frame; 20 frames in 4.00 s)"));
        assert_eq!(super::frame_rates(0, 0, 1.0), None);
        assert_eq!(super::frame_rates(3, 0, 0.0), None);
    }
}
