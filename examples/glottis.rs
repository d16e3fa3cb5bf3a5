//! The interactive 2D glottis: the vocal folds (case C by default) in the air from the lungs,
//! with the egui panel (presets A–D, the Wall flap, the cylinder wake in air and in the lattice
//! gas; lung pressure, fold moduli, coupling method, pause / step, what to draw, the glottal
//! flow and f0 as they come).
//!
//!     cargo run --release --example glottis
//!     cargo run --release --example glottis -- --preset glottis_2d_coarse --steps-per-frame 20
//!     cargo run --release --example glottis -- --preset lattice_gas_wake
//!     cargo run --release --example glottis -- --preset cylinder_wake --air-on-gpu
//!     cargo run --release --example glottis -- --air-on-gpu     # on the GPU even if it is lavapipe
//!     cargo run --release --example glottis -- --cpu            # on the CPU even on a hardware GPU
//!     cargo run --release --example glottis -- --adiabatic-walls    # the folds' walls adiabatic (the presets': isothermal at T₀)
//!     cargo run --release --example glottis -- --frames 30 --screenshot glottis.png
//!
//! On a hardware GPU the simulation (a fluid preset's air, a coupled preset's air and folds)
//! steps on the render device in the render world, its tracers and slice made there too; without
//! one it runs on the CPU backend, the glottis cases A–D at half the seed's lattice
//! (`render::presets::choose_backend`). The window's title and the panel say which; the GPU
//! draws it either way (the folds' surface made on the GPU from the particles).

use bevy::prelude::*;
use bevy::render::renderer::RenderAdapterInfo;
use phonation::plugin::{PhonationGpuPlugin, SimulationControl};
use phonation::render::PhonationPlugins;
use phonation::render::panel::{PanelState, PanelTarget, WallHeat};
use phonation::render::presets::choose_backend;
use phonation::render::view::{CapturePlugin, FrameSimulation};

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1).cloned())
}

fn main() {
    let preset = arg("--preset").unwrap_or_else(|| "glottis_2d_c".into());
    let steps = arg("--steps-per-frame").and_then(|s| s.parse().ok()).unwrap_or(5);
    let flag = |f: &str| std::env::args().any(|a| a == f);
    let forced = if flag("--air-on-gpu") {
        Some(true)
    } else if flag("--cpu") {
        Some(false)
    } else {
        None
    };
    let walls = if flag("--isothermal-walls") {
        Some(WallHeat::Isothermal)
    } else if flag("--adiabatic-walls") {
        Some(WallHeat::Adiabatic)
    } else {
        None
    };
    let window = Window { title: format!("phonation — {preset}"), resolution: (1280, 800).into(), ..default() };
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin { primary_window: Some(window), ..default() }))
        .add_plugins((PhonationPlugins, PhonationGpuPlugin))
        .insert_resource(PanelState { preset, air_on_gpu: forced == Some(true), walls, ..default() })
        .insert_resource(SimulationControl { steps_per_frame: steps, ..default() })
        .insert_resource(ClearColor(Color::srgb(0.08, 0.08, 0.1)))
        .add_systems(
            Startup,
            (setup, move |info: Option<Res<RenderAdapterInfo>>, state: ResMut<PanelState>, windows: Query<&mut Window>| choose(forced, info, state, windows)),
        );
    if let (Some(frames), Some(path)) = (arg("--frames").and_then(|f| f.parse().ok()), arg("--screenshot")) {
        app.add_plugins(CapturePlugin { frames, path: path.into() });
    }
    app.run();
}

/// The backend (forced by a flag, or the adapter's choice) in the window's title.
fn choose(forced: Option<bool>, info: Option<Res<RenderAdapterInfo>>, mut state: ResMut<PanelState>, mut windows: Query<&mut Window>) {
    let line = match forced {
        Some(true) => "stepped on the GPU (--air-on-gpu)".to_string(),
        Some(false) => choose_backend(&mut state, None).replace("no render device", "--cpu"),
        None => choose_backend(&mut state, info.as_ref().map(|i| (i.0.name.as_str(), i.0.device_type))),
    };
    for mut w in &mut windows {
        w.title = format!("{} ({line})", w.title);
    }
    println!("phonation: {} — {line}", state.preset);
}

fn setup(mut commands: Commands) {
    commands.spawn(PanelTarget::default());
    commands.spawn((Camera3d::default(), FrameSimulation));
    commands.spawn((DirectionalLight { illuminance: 8000.0, ..default() }, Transform::from_xyz(0.3, 0.5, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
    commands.insert_resource(GlobalAmbientLight { brightness: 400.0, ..default() });
}
