//! The scene file format (TOML), in physical units. Every table rejects unknown keys.
//! See `assets/scenes/*.toml` for complete examples and README.md for a field reference.

use crate::fluid::{GasModel, VelocitySetKind};
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// "cgs" (cm, g, s, dyn/cm²) or "si" (m, kg, s, Pa).
    pub units: UnitSystem,
    pub domain: Domain,
    pub gas: Gas,
    #[serde(default)]
    pub numerics: Numerics,
    pub boundaries: FaceSpecs,
    #[serde(default)]
    pub obstacles: Vec<ObstacleSpec>,
    #[serde(default)]
    pub initial: Initial,
    pub run: RunSpec,
    #[serde(default)]
    pub probes: Vec<ProbeSpec>,
    #[serde(default)]
    pub output: OutputSpec,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UnitSystem {
    Cgs,
    Si,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    pub lattice: VelocitySetKind,
    /// Physical extent per axis (2 or 3 entries).
    pub size: Vec<f64>,
    /// Nodes per axis (same length as `size`); the spacing must be equal on every axis.
    pub cells: Vec<i64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gas {
    #[serde(default = "default_gas_model")]
    pub model: GasModel,
    /// Reference density ρ₀.
    pub density: f64,
    /// Dynamic viscosity μ.
    pub viscosity: f64,
    /// Physical sound speed at the reference state; defaults to air at 20 °C.
    pub sound_speed: Option<f64>,
}

fn default_gas_model() -> GasModel {
    GasModel::Diatomic
}

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Numerics {
    /// Reference reduced temperature θ₀/c² of the lattice (inside the positivity window).
    pub temperature: Option<f64>,
    /// Fixed physical time step (s); automatic when absent.
    pub time_step: Option<f64>,
    /// Fixed relaxation time τ in lattice time units (then A = τ − ν/θ₀).
    pub tau: Option<f64>,
    /// Fraction of the advection stability limit used by the automatic step (0, 1].
    pub courant_safety: Option<f64>,
    /// Artificial sound speed: run with Mach number `mach` at `reference_velocity`.
    pub mach_scaling: Option<MachScaling>,
    /// Refuse grids whose state would need more than this many bytes (default: 3/4 of RAM).
    pub max_memory_bytes: Option<f64>,
    /// The number type of the populations on the CPU (default f64). "f32" halves the bytes a
    /// step moves (1.2–1.3× faster here) at a measured cost: the Taylor–Green decay rate moves
    /// by 7·10⁻⁸ of itself, the Sod plateaus by 8·10⁻⁷ (`phonation bench --only storage`).
    /// Fluid-only scenes, headless runs (the Bevy plugin steps f64); the GPU stores f32
    /// whatever this says.
    pub storage: Option<PopulationStorage>,
}

/// The number type the CPU stores the populations in ([`crate::fluid::storage::Storage`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PopulationStorage {
    #[default]
    F64,
    F32,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachScaling {
    pub reference_velocity: ReferenceVelocity,
    pub mach: f64,
}

/// The speed a Mach-scaled scene runs at lattice Mach `mach`: a number (scene units), or
/// `"bernoulli"`: the Bernoulli jet √(2Δp/ρ₀) of the largest pressure difference between the
/// scene's pressure faces and the initial gauge pressure 0, so that a sweep over a face's
/// pressure keeps the jet at the same lattice Mach number.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ReferenceVelocity {
    Speed(f64),
    Named(String),
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaceSpecs {
    pub x_min: FaceSpec,
    pub x_max: FaceSpec,
    pub y_min: FaceSpec,
    pub y_max: FaceSpec,
    pub z_min: Option<FaceSpec>,
    pub z_max: Option<FaceSpec>,
}

impl FaceSpecs {
    /// The six faces with their keys, in axis order (x_min, x_max, y_min, …); the z faces are
    /// `None` when the scene leaves them out.
    pub fn named(&self) -> [(&'static str, Option<&FaceSpec>); 6] {
        [
            ("x_min", Some(&self.x_min)),
            ("x_max", Some(&self.x_max)),
            ("y_min", Some(&self.y_min)),
            ("y_max", Some(&self.y_max)),
            ("z_min", self.z_min.as_ref()),
            ("z_max", self.z_max.as_ref()),
        ]
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum FaceSpec {
    Periodic,
    /// No-slip wall; `velocity` makes it a moving lid; `temperature_ratio` (T_wall/T₀) makes it
    /// isothermal, otherwise adiabatic.
    Wall {
        #[serde(default)]
        velocity: Vec<f64>,
        temperature_ratio: Option<f64>,
    },
    /// Constant pressure (gauge, relative to the reference pressure) — the lung side.
    PressureInlet {
        pressure: f64,
        #[serde(default = "one")]
        temperature_ratio: f64,
    },
    /// `velocity`: uniform, or the peak on the centre line with `profile = "parabolic"`.
    VelocityInlet {
        velocity: Vec<f64>,
        #[serde(default = "one")]
        temperature_ratio: f64,
        #[serde(default)]
        profile: crate::fluid::boundary::InletProfile,
    },
    /// Zero-gradient outflow: every population copied from the first interior node. Sound
    /// leaves through it nearly unreflected, as into an endless duct of the domain's width.
    Outlet,
    /// Constant pressure (gauge, default 0: the atmosphere) where the air leaves, the velocity
    /// from the first interior node — the fixed-pressure outflow of most vocal-fold FSI models
    /// (e.g. Thomson, Mongeau & Frankel 2005). Acoustically a pressure-release end: it reflects
    /// sound back, so that the air between it and the folds is an inertance, not a radiation
    /// resistance (README, "What the air takes from the folds").
    PressureOutlet {
        #[serde(default)]
        pressure: f64,
        #[serde(default = "one")]
        temperature_ratio: f64,
    },
    /// Free-slip wall (symmetry plane): no normal flow, no shear stress.
    Slip,
}

fn one() -> f64 {
    1.0
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case", deny_unknown_fields)]
pub enum ObstacleSpec {
    /// Disc in 2D, infinite cylinder along z in 3D.
    Cylinder {
        center: Vec<f64>,
        radius: f64,
    },
    Sphere {
        center: Vec<f64>,
        radius: f64,
    },
    Box {
        min: Vec<f64>,
        max: Vec<f64>,
    },
}

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Initial {
    /// Uniform initial velocity.
    #[serde(default)]
    pub velocity: Vec<f64>,
    /// Relative amplitude of a deterministic transverse velocity kick that breaks symmetry.
    #[serde(default)]
    pub perturbation: f64,
    /// Uniform body force per unit mass (acceleration), e.g. to drive a periodic channel.
    #[serde(default)]
    pub body_force: Vec<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// Simulated physical time (s).
    pub duration: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    pub name: String,
    pub position: Vec<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Probe sampling interval in steps.
    #[serde(default = "default_probe_every")]
    pub probe_every: u64,
    /// Number of field snapshots over the run (PNG + VTK), 0 for none.
    #[serde(default = "default_snapshots")]
    pub snapshots: u64,
    /// Fields drawn as PNG colour maps.
    #[serde(default = "default_fields")]
    pub png_fields: Vec<Field>,
    #[serde(default = "yes")]
    pub vtk: bool,
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec { probe_every: default_probe_every(), snapshots: default_snapshots(), png_fields: default_fields(), vtk: true }
    }
}

fn default_probe_every() -> u64 {
    10
}
fn default_snapshots() -> u64 {
    4
}
fn default_fields() -> Vec<Field> {
    vec![Field::Speed, Field::Pressure]
}
fn yes() -> bool {
    true
}

/// A scalar field of the flow.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Field {
    Density,
    Speed,
    Pressure,
    Temperature,
    Vorticity,
}
