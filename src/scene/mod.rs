//! Scene files: a complete description of a run in physical units (TOML), their validation,
//! and the built-in scenes of `assets/scenes/`.

pub mod build;
pub mod coupled;
mod fluid_parts;
pub mod fold;
pub mod glottis;
pub mod kind;
pub mod lattice_gas;
pub mod resolution;
pub mod schema;
pub mod solid;
pub mod two_mass;

pub use build::{FluidScene, SceneError, load, parse};
pub use kind::{Scene, SceneKind};
pub use schema::SceneFile;

/// Built-in scenes, embedded so that the binary runs them from anywhere.
pub const BUILTIN: &[(&str, &str)] = &[
    ("cylinder_wake", include_str!("../../assets/scenes/cylinder_wake.toml")),
    ("lid_cavity", include_str!("../../assets/scenes/lid_cavity.toml")),
    ("glottal_jet", include_str!("../../assets/scenes/glottal_jet.toml")),
];

/// Built-in lattice-gas scenes (seed 002).
pub const LATTICE_GAS_BUILTIN: &[(&str, &str)] = &[
    ("lattice_gas_wake", include_str!("../../assets/scenes/lattice_gas/cylinder_wake.toml")),
    ("lattice_gas_wake_large", include_str!("../../assets/scenes/lattice_gas/cylinder_wake_large.toml")),
];

/// Built-in solid scenes (MPS solid only).
pub const SOLID_BUILTIN: &[(&str, &str)] = &[
    ("cantilever", include_str!("../../assets/scenes/solid/cantilever.toml")),
    ("oscillating_plate", include_str!("../../assets/scenes/solid/oscillating_plate.toml")),
    ("orthotropic_block", include_str!("../../assets/scenes/solid/orthotropic_block.toml")),
    ("two_blocks", include_str!("../../assets/scenes/solid/two_blocks.toml")),
];

/// Built-in coupled (fluid–structure) scenes.
pub const COUPLED_BUILTIN: &[(&str, &str)] = &[
    ("fsi_cylinder", include_str!("../../assets/scenes/coupled/fsi_cylinder.toml")),
    ("fsi_cylinder_conserving", include_str!("../../assets/scenes/coupled/fsi_cylinder_conserving.toml")),
    ("wall_flap", include_str!("../../assets/scenes/coupled/wall_flap.toml")),
    ("wall_flap_conserving", include_str!("../../assets/scenes/coupled/wall_flap_conserving.toml")),
    ("wall_flap_3d", include_str!("../../assets/scenes/coupled/wall_flap_3d.toml")),
    ("glottis_2d_a", include_str!("../../assets/scenes/glottis/glottis_2d_a.toml")),
    ("glottis_2d_b", include_str!("../../assets/scenes/glottis/glottis_2d_b.toml")),
    ("glottis_2d_c", include_str!("../../assets/scenes/glottis/glottis_2d_c.toml")),
    ("glottis_2d_d", include_str!("../../assets/scenes/glottis/glottis_2d_d.toml")),
    ("glottis_2d_coarse", include_str!("../../assets/scenes/glottis/glottis_2d_coarse.toml")),
    ("glottis_3d", include_str!("../../assets/scenes/glottis/glottis_3d.toml")),
    ("glottis_3d_coarse", include_str!("../../assets/scenes/glottis/glottis_3d_coarse.toml")),
];

/// Built-in two-mass (Ishizaka–Flanagan) scenes.
pub const TWO_MASS_BUILTIN: &[(&str, &str)] = &[("two_mass", include_str!("../../assets/scenes/two_mass/two_mass.toml"))];

/// The scene `cargo run --release` runs when no scene is given.
pub const DEFAULT_SCENE: &str = "cylinder_wake";

/// Every built-in scene, (name, text), fluid scenes first.
pub fn builtins() -> impl Iterator<Item = &'static (&'static str, &'static str)> {
    BUILTIN.iter().chain(SOLID_BUILTIN).chain(LATTICE_GAS_BUILTIN).chain(COUPLED_BUILTIN).chain(TWO_MASS_BUILTIN)
}

/// Text of a built-in scene by name.
pub fn builtin(name: &str) -> Option<&'static str> {
    builtins().find(|(n, _)| *n == name).map(|(_, t)| *t)
}
