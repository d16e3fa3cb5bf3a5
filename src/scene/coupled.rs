//! Coupled scenes: a fluid scene (every table of [`SceneFile`]) plus a `[solid]` table (as in
//! solid scenes, [`SolidSpec`]: materials, bodies — boxes, or discs with `center` and
//! `radius` —, layers, clamps, loads) and a `[coupling]` table:
//!
//! ```toml
//! [coupling]
//! method = "weak"                  # seed §2.4.1; "momentum_conserving" (§2.4.2) is not built yet
//! traction = "pressure_and_shear"  # or "seed_pressure" (2.110: static + dynamic pressure only)
//! piece_length = 1.0               # longest surface piece of the traction quadrature (cells)
//! output_every = 10                # coupling.csv row every this many steps
//! [[coupling.motions]]             # optional: a body with a prescribed rigid motion
//! body = 0
//! motion = { kind = "translation", velocity = [-10.0, 0.0] }
//! ```
//!
//! Lengths of the solid are in the fluid scene's units, positions from the fluid domain's
//! origin. Everything is checked before anything large is allocated.

use super::build::{FluidScene, SceneError};
use super::schema::SceneFile;
use super::solid::{BodySpec, SolidRun, SolidScene, SolidSceneFile, SolidSpec, vec3};
use crate::coupling::{BodySurface, CoupledBody, Motion, ReferenceShape, TractionModel, WeakCoupling, WeakOptions};
use glam::DVec3;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CouplingMethod {
    /// Method 1 (seed §2.4.1).
    #[default]
    Weak,
    /// Method 2 (seed §2.4.2): refused until it is built.
    MomentumConserving,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    pub body: usize,
    pub motion: Motion,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingSpec {
    #[serde(default)]
    pub method: CouplingMethod,
    #[serde(default)]
    pub traction: TractionModel,
    pub piece_length: Option<f64>,
    pub output_every: Option<u64>,
    #[serde(default)]
    pub motions: Vec<MotionSpec>,
}

/// Admissible particle spacing per lattice cell l₀/Δx: finer than 0.1 costs particles without
/// changing what the fluid sees; coarser than 2 leaves surface edges over two cells long,
/// whose straight walls cut corners of the body.
pub const SPACING_RATIO: (f64, f64) = (0.1, 2.0);

/// A validated coupled scene.
#[derive(Clone, Debug)]
pub struct CoupledScene {
    pub fluid: FluidScene,
    pub solid: SolidScene,
    pub coupling: CouplingSpec,
}

fn err<T>(field: impl Into<String>, reason: impl Into<String>) -> Result<T, SceneError> {
    Err(SceneError { field: field.into(), reason: reason.into() })
}

impl CoupledScene {
    pub fn parse(text: &str) -> Result<Self, SceneError> {
        let mut table: toml::Table = toml::from_str(text).map_err(|e| SceneError::from_toml("scene", &e, text))?;
        let coupling =
            table.remove("coupling").ok_or_else(|| SceneError { field: "coupling".into(), reason: "a coupled scene needs a [coupling] table".into() })?;
        let solid = table.remove("solid").ok_or_else(|| SceneError { field: "solid".into(), reason: "a coupled scene needs a [solid] table".into() })?;
        let coupling: CouplingSpec =
            coupling.try_into().map_err(|e: toml::de::Error| SceneError { field: "coupling".into(), reason: e.message().to_string() })?;
        let solid: SolidSpec = solid.try_into().map_err(|e: toml::de::Error| SceneError { field: "solid".into(), reason: e.message().to_string() })?;
        let fluid_text = toml::to_string(&table).expect("a TOML table serialises");
        let file: SceneFile = toml::from_str(&fluid_text).map_err(|e| SceneError::from_toml("scene", &e, &fluid_text))?;
        Self::new(file, solid, coupling)
    }

    pub fn new(file: SceneFile, solid: SolidSpec, coupling: CouplingSpec) -> Result<Self, SceneError> {
        let solid_file = SolidSceneFile {
            name: file.name.clone(),
            description: file.description.clone(),
            units: file.units,
            solid,
            run: SolidRun { duration: file.run.duration, output_every: None, snapshots: None },
            probes: Vec::new(),
        };
        let fluid = FluidScene::new(file)?;
        let solid = SolidScene::new(solid_file)?;
        let s = &solid.file.solid;
        let dim = fluid.grid.dim;
        if coupling.method == CouplingMethod::MomentumConserving {
            return err("coupling.method", "\"momentum_conserving\" (seed §2.4.2) is not built yet; use \"weak\"");
        }
        if s.dimension != dim {
            return err("solid.dimension", format!("the fluid lattice is {dim}D, the solid {}D", s.dimension));
        }
        if dim == 3 {
            return err("solid.dimension", "coupled scenes run in 2D for now (3D surfaces are not triangulated yet)");
        }
        if s.integrator != crate::solid::Integrator::Explicit {
            return err("solid.integrator", "the weak coupling (method 1) uses the explicit solid step");
        }
        let dx = fluid.units.dx;
        let ratio = s.spacing / dx;
        if !(ratio >= SPACING_RATIO.0 && ratio <= SPACING_RATIO.1) {
            return err(
                "solid.spacing",
                format!("l₀/Δx = {ratio:.3} (l₀ = {}, Δx = {dx:.4e}) must lie in [{}, {}]", s.spacing, SPACING_RATIO.0, SPACING_RATIO.1),
            );
        }
        if let Some(p) = coupling.piece_length
            && !(p.is_finite() && p > 0.0 && p <= 4.0)
        {
            return err("coupling.piece_length", format!("must be in (0, 4] cells, got {p}"));
        }
        if coupling.output_every == Some(0) {
            return err("coupling.output_every", "must be at least 1");
        }
        let size = &fluid.file.domain.size;
        for (k, b) in s.bodies.iter().enumerate() {
            let (lo, hi) = body_bounds(b, dim);
            for a in 0..dim {
                if lo[a] < 0.0 || hi[a] > size[a] {
                    return err(
                        format!("solid.bodies[{k}]"),
                        format!("extends over [{}, {}] along axis {a}, outside the domain [0, {}]", lo[a], hi[a], size[a]),
                    );
                }
            }
        }
        for (k, m) in coupling.motions.iter().enumerate() {
            if m.body >= s.bodies.len() {
                return err(format!("coupling.motions[{k}].body"), format!("no body {} (there are {})", m.body, s.bodies.len()));
            }
            if coupling.motions[..k].iter().any(|o| o.body == m.body) {
                return err(format!("coupling.motions[{k}].body"), format!("body {} already has a motion", m.body));
            }
            let finite = match &m.motion {
                Motion::Translation { velocity } => velocity.iter().all(|v| v.is_finite()),
                Motion::Rotation { centre, angular_velocity } => centre.iter().all(|v| v.is_finite()) && angular_velocity.is_finite(),
                Motion::Harmonic { amplitude, frequency } => amplitude.iter().all(|v| v.is_finite()) && frequency.is_finite() && *frequency >= 0.0,
            };
            if !finite {
                return err(format!("coupling.motions[{k}].motion"), "every value must be finite (and the frequency ≥ 0)");
            }
        }
        Ok(CoupledScene { fluid, solid, coupling })
    }

    /// Builds the coupled solver: samples the particles, checks that no free particle lies in
    /// a rigid obstacle, builds each body's surface, allocates the fluid.
    pub fn build(&self) -> Result<WeakCoupling, SceneError> {
        let solid = self.solid.build()?;
        let p = &solid.particles;
        let units = self.fluid.units;
        for (j, o) in self.fluid.obstacles.iter().enumerate() {
            if let Some(i) = (0..p.len()).find(|&i| {
                let x = p.reference[i];
                !p.fixed[i] && o.shape.sdf([units.position_to_lattice(x.x), units.position_to_lattice(x.y), 0.0]) < 0.0
            }) {
                return err(
                    format!("solid.bodies[{}]", p.body[i]),
                    format!("particle {i} at {:?} lies inside obstacles[{j}] and is not clamped", p.reference[i].to_array()),
                );
            }
        }
        let mut bodies = Vec::new();
        for (k, b) in self.solid.file.solid.bodies.iter().enumerate() {
            let surface = BodySurface::build(p, k as u16, &reference_shape(b, p.dim))
                .map_err(|e| SceneError { field: format!("solid.bodies[{k}]"), reason: e.to_string() })?;
            let motion = self.coupling.motions.iter().find(|m| m.body == k).map(|m| m.motion.clone());
            bodies.push(CoupledBody { surface, motion });
        }
        let fluid = self.fluid.build_solver();
        let options = WeakOptions { traction: self.coupling.traction, piece_length: self.coupling.piece_length.unwrap_or(1.0), ..Default::default() };
        WeakCoupling::new(fluid, solid, units, bodies, self.fluid.obstacles.clone(), options)
            .map_err(|e| SceneError { field: "coupling".into(), reason: e.to_string() })
    }
}

/// The bounding box of a validated body of a `dim`-dimensional solid.
fn body_bounds(b: &BodySpec, dim: usize) -> (DVec3, DVec3) {
    let v = |a: &[f64]| vec3("", a, dim, false).expect("validated");
    match b.radius {
        Some(r) => (v(&b.center) - DVec3::splat(r), v(&b.center) + DVec3::splat(r)),
        None => (v(&b.min), v(&b.max)),
    }
}

fn reference_shape(b: &BodySpec, dim: usize) -> ReferenceShape {
    let v = |a: &[f64]| vec3("", a, dim, false).expect("validated");
    match b.radius {
        Some(r) => ReferenceShape::Disc { centre: v(&b.center), radius: r },
        None => ReferenceShape::Box { min: v(&b.min), max: v(&b.max) },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn builtin() -> &'static str {
        crate::scene::COUPLED_BUILTIN[0].1
    }

    #[test]
    fn the_built_in_coupled_scene_builds_and_runs() {
        let sc = CoupledScene::parse(builtin()).unwrap();
        assert!(
            crate::scene::SceneKind::of(builtin()) == crate::scene::SceneKind::Coupled
                && crate::scene::SceneKind::of(crate::scene::BUILTIN[0].1) != crate::scene::SceneKind::Coupled
        );
        let mut c = sc.build().unwrap();
        // D = 0.1 m at l₀ = 0.005 m: a disc of ≈ π·10² particles, one surface polygon.
        assert!((300..330).contains(&c.solid.particles.len()), "{}", c.solid.particles.len());
        assert_eq!(c.bodies.len(), 1);
        c.run(20).unwrap();
        // The flow pushes the cylinder downstream.
        assert!(c.forces.total[0].x > 0.0, "{:?}", c.forces.total);
    }

    #[test]
    fn bad_coupled_scenes_are_refused_with_the_field_and_the_reason() {
        let cases: [(&str, &str, &str); 7] = [
            ("method = \"weak\"", "method = \"momentum_conserving\"", "coupling.method"),
            ("spacing = 0.005 ", "spacing = 0.05 ", "solid.spacing"),
            ("center = [0.2, 0.2], radius = 0.05", "center = [2.18, 0.2], radius = 0.05", "solid.bodies[0]"),
            ("dimension = 2", "dimension = 2\nintegrator = \"implicit\"", "solid.integrator"),
            ("output_every = 10", "output_every = 0", "coupling.output_every"),
            (
                "output_every = 10",
                "output_every = 10\nmotions = [{ body = 3, motion = { kind = \"translation\", velocity = [1.0, 0.0] } }]",
                "coupling.motions[0].body",
            ),
            ("traction = \"pressure_and_shear\"", "traction = \"shear_only\"", "coupling"),
        ];
        for (from, to, field) in cases {
            assert!(builtin().contains(from), "{from}");
            let text = builtin().replacen(from, to, 1);
            let e = CoupledScene::parse(&text).err().unwrap_or_else(|| panic!("{to} accepted"));
            assert_eq!(e.field, field, "{to}: {e}");
        }
        // A free body inside a rigid obstacle is refused when built (before the fluid is allocated).
        let text = builtin().replacen("[run]", "[[obstacles]]\nshape = \"cylinder\"\ncenter = [0.2, 0.2]\nradius = 0.08\n\n[run]", 1);
        let e = CoupledScene::parse(&text).unwrap().build().err().expect("overlap refused");
        assert_eq!(e.field, "solid.bodies[0]", "{e}");
    }
}
