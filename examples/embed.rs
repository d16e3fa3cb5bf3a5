//! The shortest embedding: a Bevy app with phonation's plugin group and a coupled scene.
//!
//!     cargo run --release --example embed [-- --frames 30 --screenshot embed.png]

use bevy::prelude::*;
use phonation::plugin::CoupledSimulation;
use phonation::render::PhonationPlugins;
use phonation::render::view::{CapturePlugin, FrameSimulation};
use phonation::scene::{builtin, coupled::CoupledScene};

fn main() {
    let mut app = App::new();
    app.add_plugins((DefaultPlugins, PhonationPlugins)).add_systems(Startup, setup);
    let args: Vec<String> = std::env::args().collect();
    if let [_, f, n, s, path] = &args[..]
        && f == "--frames"
        && s == "--screenshot"
    {
        app.add_plugins(CapturePlugin { frames: n.parse().expect("--frames N"), path: path.into() });
    }
    app.run();
}

fn setup(mut commands: Commands) {
    let scene = CoupledScene::parse(builtin("wall_flap").unwrap()).unwrap();
    commands.spawn(CoupledSimulation { solver: scene.build().unwrap() });
    commands.spawn((Camera3d::default(), FrameSimulation));
    commands.spawn((DirectionalLight::default(), Transform::from_xyz(0.3, 0.5, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
}
