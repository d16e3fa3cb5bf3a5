//! Solid scene files (TOML): bodies sampled from boxes, material layers, clamps, loads, walls,
//! contact, the integrator; and the headless run that writes `solid.csv` (energies, momenta,
//! probe displacements, CG iterations), particle snapshots as VTK and `summary.json`.
//! Every check runs before anything is allocated; errors name the field and the reason.

use super::fold::{FoldBodySpec, check_fold};
use crate::scene::SceneError;
use crate::solid::fold::Layer;
use crate::solid::particles::{sample_ball, sample_box};
use crate::solid::solver::{Integrator, SolidOptions, SolidSolver};
use crate::solid::{ContactParams, Orthotropic, Particles, Wall};
use glam::DVec3;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolidSceneFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Informational: "cgs" or "si" (the solver is unit-agnostic; use one system throughout).
    pub units: crate::scene::schema::UnitSystem,
    pub solid: SolidSpec,
    pub run: SolidRun,
    #[serde(default)]
    pub probes: Vec<RegionProbe>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolidSpec {
    /// 2 (plane strain) or 3.
    pub dimension: usize,
    /// Particle spacing l₀.
    pub spacing: f64,
    #[serde(default = "default_integrator")]
    pub integrator: Integrator,
    pub time_step: Option<f64>,
    pub influence_ratio: Option<f64>,
    pub pair_fraction: Option<f64>,
    pub safety: Option<f64>,
    #[serde(default)]
    pub gravity: Vec<f64>,
    pub cg_tolerance: Option<f64>,
    /// The implicit solve's smoother: "patches" (default) or "block_jacobi"; the coarse space is added to either on both backends.
    pub preconditioner: Option<crate::solid::Preconditioner>,
    pub materials: Vec<MaterialSpec>,
    pub bodies: Vec<BodySpec>,
    #[serde(default)]
    pub layers: Vec<Region>,
    #[serde(default)]
    pub clamps: Vec<Region>,
    #[serde(default)]
    pub loads: Vec<LoadSpec>,
    #[serde(default)]
    pub walls: Vec<WallSpec>,
    pub contact: Option<ContactParams>,
}

fn default_integrator() -> Integrator {
    Integrator::Explicit
}

/// A material: `kind = "isotropic" | "orthotropic" | "transversely_isotropic"`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialSpec {
    Isotropic {
        young: f64,
        poisson: f64,
        density: f64,
        #[serde(default)]
        viscosity: f64,
    },
    Orthotropic {
        young: [f64; 3],
        poisson: [f64; 3],
        shear: [f64; 3],
        density: f64,
        #[serde(default)]
        viscosity: f64,
    },
    TransverselyIsotropic {
        e_plane: f64,
        e_fibre: f64,
        nu_plane: f64,
        nu_fibre_plane: f64,
        g_fibre: f64,
        density: f64,
        #[serde(default)]
        viscosity: f64,
    },
}

impl MaterialSpec {
    pub fn material(&self) -> Orthotropic {
        match *self {
            MaterialSpec::Isotropic { young, poisson, density, viscosity } => Orthotropic::isotropic(young, poisson, density, viscosity),
            MaterialSpec::Orthotropic { young, poisson, shear, density, viscosity } => Orthotropic { young, poisson, shear, density, viscosity },
            MaterialSpec::TransverselyIsotropic { e_plane, e_fibre, nu_plane, nu_fibre_plane, g_fibre, density, viscosity } => {
                Orthotropic::transversely_isotropic(e_plane, e_fibre, nu_plane, nu_fibre_plane, g_fibre, density, viscosity)
            }
        }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// A box [min, max] …
    #[serde(default)]
    pub min: Vec<f64>,
    #[serde(default)]
    pub max: Vec<f64>,
    /// … or a disc (2D) / sphere (3D) of `radius` about `center`.
    #[serde(default)]
    pub center: Vec<f64>,
    pub radius: Option<f64>,
    #[serde(default)]
    pub material: usize,
    #[serde(default)]
    pub velocity: Vec<f64>,
    /// Release in the first clamped–free bending mode along x, measured from the clamp line (the
    /// far x edge of the clamps that hold the body; x = 0 if none): tip speed.
    pub first_mode_tip_speed: Option<f64>,
    /// … or a vocal fold (seed Fig. 3.9; 2D section or 3D extrusion): `material` is its body
    /// layer's.
    pub fold: Option<FoldBodySpec>,
}

/// An axis-aligned box; `material` is used by layers.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    #[serde(default)]
    pub material: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    /// Total force shared equally by the particles in the box (per unit depth in 2D).
    pub total_force: Vec<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    pub normal: Vec<f64>,
    pub offset: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolidRun {
    pub duration: f64,
    /// CSV row every this many steps (default 10).
    pub output_every: Option<u64>,
    /// Particle VTK snapshots (default 10 over the run).
    pub snapshots: Option<u64>,
}

/// Mean displacement of the particles inside a box, written to the CSV.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionProbe {
    pub name: String,
    pub min: Vec<f64>,
    pub max: Vec<f64>,
}

fn err<T>(field: impl Into<String>, reason: impl Into<String>) -> Result<T, SceneError> {
    Err(SceneError { field: field.into(), reason: reason.into() })
}

pub(crate) fn vec3(field: &str, v: &[f64], dim: usize, allow_empty: bool) -> Result<DVec3, SceneError> {
    crate::scene::build::vector(field, v, dim, allow_empty).map(DVec3::from_array)
}

pub(crate) fn inside(x: DVec3, min: DVec3, max: DVec3, dim: usize) -> bool {
    (0..dim).all(|a| x[a] >= min[a] && x[a] <= max[a])
}

/// A validated solid scene, ready to allocate.
#[derive(Clone, Debug)]
pub struct SolidScene {
    pub file: SolidSceneFile,
    pub materials: Vec<Orthotropic>,
    pub estimated_particles: usize,
    pub steps: Option<u64>,
}

/// Largest particle count a scene may ask for.
pub const MAX_PARTICLES: f64 = 5.0e7;

/// The dimension (2 or 3), the spacing (> 0) and the materials (at least one, each with a
/// positive definite stiffness): the materials.
fn check_materials(s: &SolidSpec) -> Result<Vec<Orthotropic>, SceneError> {
    let dim = s.dimension;
    if dim != 2 && dim != 3 {
        return err("solid.dimension", format!("must be 2 or 3, got {dim}"));
    }
    if !(s.spacing.is_finite() && s.spacing > 0.0) {
        return err("solid.spacing", format!("must be finite and > 0, got {}", s.spacing));
    }
    if s.materials.is_empty() {
        return err("solid.materials", "at least one material is needed");
    }
    let materials: Vec<Orthotropic> = s.materials.iter().map(|m| m.material()).collect();
    for (k, m) in materials.iter().enumerate() {
        m.stiffness(&format!("solid.materials[{k}]"))?;
    }
    Ok(materials)
}

/// Every body (at least one) with its material among the `materials` given, its velocity and
/// its shape: a fold, a ball or a box. The estimated particle count of all of them.
fn check_bodies(file: &SolidSceneFile, materials: usize) -> Result<f64, SceneError> {
    let s = &file.solid;
    if s.bodies.is_empty() {
        return err("solid.bodies", "at least one body is needed");
    }
    let mut count = 0.0;
    for (k, b) in s.bodies.iter().enumerate() {
        let f = format!("solid.bodies[{k}]");
        if b.material >= materials {
            return err(format!("{f}.material"), format!("no material {} (there are {materials})", b.material));
        }
        vec3(&format!("{f}.velocity"), &b.velocity, s.dimension, true)?;
        if let Some(v) = b.first_mode_tip_speed
            && !v.is_finite()
        {
            return err(format!("{f}.first_mode_tip_speed"), format!("must be finite, got {v}"));
        }
        count += match &b.fold {
            Some(fold) => {
                if b.radius.is_some() || !b.min.is_empty() || !b.max.is_empty() || !b.center.is_empty() {
                    return err(format!("{f}.fold"), "a body is a box, a ball or a fold, not several");
                }
                check_fold(fold, &f, s, file.units, materials)?
            }
            None => ball_or_box_particles(b, &f, s)?,
        };
    }
    Ok(count)
}

/// A ball (center, radius ≥ one spacing) or a box (min, max, at least one spacing along every
/// axis) named `f`: its estimated particle count.
fn ball_or_box_particles(b: &BodySpec, f: &str, s: &SolidSpec) -> Result<f64, SceneError> {
    let dim = s.dimension;
    match b.radius {
        Some(r) => {
            if !b.min.is_empty() || !b.max.is_empty() {
                return err(format!("{f}.radius"), "a body is a box (min, max) or a ball (center, radius), not both");
            }
            vec3(&format!("{f}.center"), &b.center, dim, false)?;
            if !(r.is_finite() && r >= s.spacing) {
                return err(format!("{f}.radius"), format!("must be finite and at least one particle spacing ({}), got {r}", s.spacing));
            }
            let ball = if dim == 2 { std::f64::consts::PI * r * r } else { 4.0 / 3.0 * std::f64::consts::PI * r.powi(3) };
            Ok(ball / s.spacing.powi(dim as i32))
        }
        None => {
            if !b.center.is_empty() {
                return err(format!("{f}.center"), "a ball needs a radius");
            }
            let (lo, hi) = (vec3(&format!("{f}.min"), &b.min, dim, false)?, vec3(&format!("{f}.max"), &b.max, dim, false)?);
            for a in 0..dim {
                if hi[a] - lo[a] < s.spacing {
                    return err(format!("{f}.max"), format!("the box is thinner than one particle spacing along axis {a} ({} < {})", hi[a] - lo[a], s.spacing));
                }
            }
            Ok((0..dim).map(|a| ((hi[a] - lo[a]) / s.spacing).floor()).product::<f64>())
        }
    }
}

/// The layers (with a material among the `materials` given), clamps, loads and walls (a
/// non-zero normal): their vectors of the scene's dimension.
fn check_regions(s: &SolidSpec, materials: usize) -> Result<(), SceneError> {
    let dim = s.dimension;
    let corners = |f: String, min: &[f64], max: &[f64]| -> Result<(), SceneError> {
        vec3(&format!("{f}.min"), min, dim, false)?;
        vec3(&format!("{f}.max"), max, dim, false)?;
        Ok(())
    };
    for (k, r) in s.layers.iter().enumerate() {
        corners(format!("solid.layers[{k}]"), &r.min, &r.max)?;
        if r.material >= materials {
            return err(format!("solid.layers[{k}].material"), format!("no material {} (there are {materials})", r.material));
        }
    }
    for (k, r) in s.clamps.iter().enumerate() {
        corners(format!("solid.clamps[{k}]"), &r.min, &r.max)?;
    }
    for (k, l) in s.loads.iter().enumerate() {
        corners(format!("solid.loads[{k}]"), &l.min, &l.max)?;
        vec3(&format!("solid.loads[{k}].total_force"), &l.total_force, dim, false)?;
    }
    for (k, w) in s.walls.iter().enumerate() {
        let n = vec3(&format!("solid.walls[{k}].normal"), &w.normal, dim, false)?;
        if n.length() == 0.0 {
            return err(format!("solid.walls[{k}].normal"), "must not be zero");
        }
    }
    Ok(())
}

/// The contact parameters (stiffnesses > 0, friction and damping ≥ 0, μ_d ≤ μ_s), which walls
/// need.
fn check_contact(s: &SolidSpec) -> Result<(), SceneError> {
    let Some(c) = &s.contact else {
        return if s.walls.is_empty() { Ok(()) } else { err("solid.contact", "walls need contact parameters") };
    };
    for (f, v) in [("normal_stiffness", c.normal_stiffness), ("tangential_stiffness", c.tangential_stiffness)] {
        if !(v.is_finite() && v > 0.0) {
            return err(format!("solid.contact.{f}"), format!("must be finite and > 0, got {v}"));
        }
    }
    for (f, v) in [("static_friction", c.static_friction), ("dynamic_friction", c.dynamic_friction), ("damping", c.damping)] {
        if !(v.is_finite() && v >= 0.0) {
            return err(format!("solid.contact.{f}"), format!("must be finite and ≥ 0, got {v}"));
        }
    }
    if c.dynamic_friction > c.static_friction {
        return err("solid.contact.dynamic_friction", format!("μ_d = {} exceeds μ_s = {}", c.dynamic_friction, c.static_friction));
    }
    Ok(())
}

impl SolidScene {
    pub fn parse(text: &str) -> Result<Self, SceneError> {
        let file: SolidSceneFile = toml::from_str(text).map_err(|e| SceneError::from_toml("solid", &e, text))?;
        Self::new(file)
    }

    /// Checks every field (the first bad one is the error, named) before anything is sampled:
    /// the dimension, spacing and materials, the bodies and their particle count, the regions,
    /// contact and walls, gravity, the run and the probes.
    pub fn new(file: SolidSceneFile) -> Result<Self, SceneError> {
        let materials = check_materials(&file.solid)?;
        let count = check_bodies(&file, materials.len())?;
        if count > MAX_PARTICLES {
            return err("solid.spacing", format!("{count:.3e} particles exceed the limit {MAX_PARTICLES:.0e}"));
        }
        check_regions(&file.solid, materials.len())?;
        check_contact(&file.solid)?;
        let dim = file.solid.dimension;
        vec3("solid.gravity", &file.solid.gravity, dim, true)?;
        if !(file.run.duration.is_finite() && file.run.duration > 0.0) {
            return err("run.duration", format!("must be finite and > 0, got {}", file.run.duration));
        }
        for (k, p) in file.probes.iter().enumerate() {
            vec3(&format!("probes[{k}].min"), &p.min, dim, false)?;
            vec3(&format!("probes[{k}].max"), &p.max, dim, false)?;
        }
        Ok(Self { file, materials, estimated_particles: count as usize, steps: None })
    }

    /// Samples the particles and builds the solver (checks the time step).
    pub fn build(&self) -> Result<SolidSolver, SceneError> {
        let s = &self.file.solid;
        let dim = s.dimension;
        let v3 = |v: &[f64]| vec3("", v, dim, true).expect("validated");
        let mut p = Particles::new(dim, s.spacing);
        let mut first_mode = Vec::new();
        for (k, b) in s.bodies.iter().enumerate() {
            let (lo, hi) = if b.radius.is_some() || b.fold.is_some() { (DVec3::ZERO, DVec3::ZERO) } else { (v3(&b.min), v3(&b.max)) };
            let start = p.len();
            // (position, material before the scene's layers, clamped by the body itself)
            let points: Vec<(DVec3, usize, bool)> = match (&b.fold, b.radius) {
                (Some(fold), _) => fold
                    .sample_in(dim, s.spacing)
                    .into_iter()
                    .map(|(x, layer, fixed)| {
                        let mat = match layer {
                            Layer::Cover => fold.cover_material,
                            Layer::Thyroarytenoid => fold.ta_material.unwrap_or(b.material),
                            Layer::Body => b.material,
                        };
                        (x, mat, fixed)
                    })
                    .collect(),
                (None, Some(r)) => sample_ball(dim, v3(&b.center), r, s.spacing).into_iter().map(|x| (x, b.material, false)).collect(),
                (None, None) => sample_box(dim, lo, hi, s.spacing).into_iter().map(|x| (x, b.material, false)).collect(),
            };
            for (x, own, clamped) in points {
                let mat = s.layers.iter().rev().find(|r| inside(x, v3(&r.min), v3(&r.max), dim)).map_or(own, |r| r.material);
                let fixed = clamped || s.clamps.iter().any(|r| inside(x, v3(&r.min), v3(&r.max), dim));
                p.push(x, self.materials[mat].density, mat as u16, k as u16, fixed);
                if !fixed {
                    *p.velocity.last_mut().unwrap() = v3(&b.velocity);
                }
            }
            if let Some(v) = b.first_mode_tip_speed {
                // The clamp line: the far x edge of the clamps that hold this body (x = 0 if none).
                let root = s
                    .clamps
                    .iter()
                    .filter(|r| (start..p.len()).any(|i| inside(p.reference[i], v3(&r.min), v3(&r.max), dim)))
                    .map(|r| v3(&r.max).x)
                    .reduce(f64::max)
                    .unwrap_or(0.0);
                first_mode.push((start..p.len(), root, hi.x - root, v));
            }
        }
        for (range, root, length, v) in first_mode {
            let fl = crate::analysis::beam::first_mode_shape(length, length);
            for i in range {
                let x = p.reference[i].x - root;
                if !p.fixed[i] && x >= 0.0 {
                    p.velocity[i] = DVec3::new(0.0, v * crate::analysis::beam::first_mode_shape(x, length) / fl, 0.0);
                }
            }
        }
        for (k, l) in s.loads.iter().enumerate() {
            let sel: Vec<usize> = (0..p.len()).filter(|&i| inside(p.reference[i], v3(&l.min), v3(&l.max), dim)).collect();
            if sel.is_empty() {
                return err(format!("solid.loads[{k}]"), "the box contains no particle");
            }
            for &i in &sel {
                p.load[i] += v3(&l.total_force) / sel.len() as f64;
            }
        }
        let d = SolidOptions::default();
        let opts = SolidOptions {
            influence_ratio: s.influence_ratio.unwrap_or(d.influence_ratio),
            pair_fraction: s.pair_fraction.unwrap_or(d.pair_fraction),
            integrator: s.integrator,
            time_step: s.time_step,
            safety: s.safety.unwrap_or(d.safety),
            gravity: v3(&s.gravity),
            contact: s.contact.clone(),
            walls: s.walls.iter().map(|w| Wall { normal: v3(&w.normal).normalize(), offset: w.offset }).collect(),
            cg_tolerance: s.cg_tolerance.unwrap_or(d.cg_tolerance),
            preconditioner: s.preconditioner.unwrap_or(d.preconditioner),
            ..d
        };
        SolidSolver::new(p, self.materials.clone(), opts)
    }
}
