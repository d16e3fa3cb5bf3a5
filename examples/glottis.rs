//! The interactive 2D glottis: the vocal folds (case C by default) in the air from the lungs,
//! with the egui panel (presets A–D, the Wall flap, the cylinder wake in air and in the lattice
//! gas; lung pressure, fold moduli, coupling method, pause / step, what to draw, the glottal
//! flow and f0 as they come).
//!
//!     cargo run --release --example glottis
//!     cargo run --release --example glottis -- --preset glottis_2d_coarse --steps-per-frame 20
//!     cargo run --release --example glottis -- --preset lattice_gas_wake
//!     cargo run --release --example glottis -- --preset cylinder_wake --air-on-gpu
//!     cargo run --release --example glottis -- --air-on-gpu     # the glottis's air and folds on the GPU
//!     cargo run --release --example glottis -- --frames 30 --screenshot glottis.png
//!
//! The simulation runs on the CPU backend (the window's panel says so) and the GPU draws it —
//! the folds' surface made on the GPU from the particles; with `--air-on-gpu` (or the panel's
//! checkbox) a fluid preset's air, or a coupled preset's air and folds, step on the GPU in the
//! render world, the tracers and slice made there too.

use bevy::prelude::*;
use phonation::plugin::{PhonationGpuPlugin, SimulationControl};
use phonation::render::PhonationPlugins;
use phonation::render::panel::{PanelState, PanelTarget};
use phonation::render::view::{CapturePlugin, FrameSimulation};

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1).cloned())
}

fn main() {
    let preset = arg("--preset").unwrap_or_else(|| "glottis_2d_c".into());
    let steps = arg("--steps-per-frame").and_then(|s| s.parse().ok()).unwrap_or(5);
    let air_on_gpu = std::env::args().any(|a| a == "--air-on-gpu");
    let backend = if air_on_gpu { "stepped on the GPU" } else { "CPU backend" };
    let window = Window { title: format!("phonation — {preset} ({backend})"), resolution: (1280, 800).into(), ..default() };
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin { primary_window: Some(window), ..default() }))
        .add_plugins((PhonationPlugins, PhonationGpuPlugin))
        .insert_resource(PanelState { preset, air_on_gpu, ..default() })
        .insert_resource(SimulationControl { steps_per_frame: steps, ..default() })
        .insert_resource(ClearColor(Color::srgb(0.08, 0.08, 0.1)))
        .add_systems(Startup, setup);
    if let (Some(frames), Some(path)) = (arg("--frames").and_then(|f| f.parse().ok()), arg("--screenshot")) {
        app.add_plugins(CapturePlugin { frames, path: path.into() });
    }
    app.run();
}

fn setup(mut commands: Commands) {
    commands.spawn(PanelTarget::default());
    commands.spawn((Camera3d::default(), FrameSimulation));
    commands.spawn((DirectionalLight { illuminance: 8000.0, ..default() }, Transform::from_xyz(0.3, 0.5, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
    commands.insert_resource(GlobalAmbientLight { brightness: 400.0, ..default() });
}
