//! Scene files: a complete description of a run in physical units (TOML), their validation,
//! and the built-in scenes of `assets/scenes/`.

pub mod build;
pub mod schema;

pub use build::{FluidScene, SceneError, load, parse};
pub use schema::SceneFile;

/// Built-in scenes, embedded so that the binary runs them from anywhere.
pub const BUILTIN: &[(&str, &str)] = &[
    ("cylinder_wake", include_str!("../../assets/scenes/cylinder_wake.toml")),
    ("lid_cavity", include_str!("../../assets/scenes/lid_cavity.toml")),
    ("glottal_jet", include_str!("../../assets/scenes/glottal_jet.toml")),
];

/// The scene `cargo run --release` runs when no scene is given.
pub const DEFAULT_SCENE: &str = "cylinder_wake";

/// Text of a built-in scene by name.
pub fn builtin(name: &str) -> Option<&'static str> {
    BUILTIN.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}
