//! Coupled scenes: a fluid scene (every table of [`SceneFile`]) plus a `[solid]` table (as in
//! solid scenes, [`SolidSpec`]: materials, bodies — boxes, or discs with `center` and
//! `radius` —, layers, clamps, loads) and a `[coupling]` table:
//!
//! ```toml
//! [coupling]
//! method = "weak"                  # seed §2.4.1, or "momentum_conserving" (§2.4.2)
//! traction = "pressure_and_shear"  # weak only; or "seed_pressure" (2.110: static + dynamic pressure)
//! piece_length = 1.0               # weak only: longest surface piece of the traction quadrature (cells)
//! # kernel_radius = 2.0            # momentum_conserving only: r_e of the level set (cells)
//! output_every = 10                # coupling.csv row every this many steps
//! [[coupling.motions]]             # optional: a body with a prescribed rigid motion
//! body = 0
//! motion = { kind = "translation", velocity = [-10.0, 0.0] }
//! ```
//!
//! Lengths of the solid are in the fluid scene's units, positions from the fluid domain's
//! origin. Everything is checked before anything large is allocated.

use super::build::{FluidScene, SceneError};
use super::fold::{FoldBodySpec, FoldSide};
use super::schema::SceneFile;
use super::solid::{BodySpec, SolidRun, SolidScene, SolidSceneFile, SolidSpec, vec3};
use crate::coupling::glottis::Glottis;
use crate::coupling::{BodySurface, ConservingOptions, CoupledBody, CoupledSolver, Method, Motion, ReferenceShape, TractionModel, WeakOptions};
use glam::DVec3;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CouplingMethod {
    /// Method 1 (seed §2.4.1).
    #[default]
    Weak,
    /// Method 2 (seed §2.4.2).
    MomentumConserving,
}

impl CouplingMethod {
    /// The name scene files use.
    pub fn name(self) -> &'static str {
        match self {
            CouplingMethod::Weak => "weak",
            CouplingMethod::MomentumConserving => "momentum_conserving",
        }
    }
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
    /// Method 1's traction model (default pressure and shear).
    pub traction: Option<TractionModel>,
    /// Method 1's longest surface piece (cells, default 1).
    pub piece_length: Option<f64>,
    /// Method 2's kernel radius r_e of the level set (cells, default 2).
    pub kernel_radius: Option<f64>,
    pub output_every: Option<u64>,
    #[serde(default)]
    pub motions: Vec<MotionSpec>,
    /// Particle probes: the mean displacement of the particles whose reference position lies in
    /// the box [min, max] (e.g. a flap's tip), written to `coupling.csv` as `<name>_dx`, `_dy`.
    #[serde(default)]
    pub probes: Vec<crate::scene::solid::RegionProbe>,
}

/// Admissible particle spacing per lattice cell l₀/Δx: finer than 0.1 costs particles without
/// changing what the fluid sees; coarser than 2 leaves surface edges over two cells long,
/// whose straight walls cut corners of the body.
/// The largest fluid/solid density ratio the weak coupling takes (see the check in
/// [`CoupledScene::parse`]).
pub const MAX_DENSITY_RATIO: f64 = 5.0;
/// The largest fluid/solid density ratio method 2 takes (with its added mass, 2.129; see the
/// check in [`CoupledScene::parse`]).
pub const MAX_DENSITY_RATIO_CONSERVING: f64 = 1.0e3;

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
        match coupling.method {
            CouplingMethod::Weak => {
                if coupling.kernel_radius.is_some() {
                    return err(
                        "coupling.kernel_radius",
                        "is a setting of method = \"momentum_conserving\" (the level set's kernel); the weak coupling has a surface polygon",
                    );
                }
            }
            CouplingMethod::MomentumConserving => {
                if coupling.traction.is_some() {
                    return err(
                        "coupling.traction",
                        "is a setting of method = \"weak\"; method 2 hands the body the air's momentum link by link, not a traction",
                    );
                }
                if coupling.piece_length.is_some() {
                    return err("coupling.piece_length", "is a setting of method = \"weak\" (its traction quadrature)");
                }
                if let Some(r) = coupling.kernel_radius {
                    let min = (1.0f64).max(2.0 * s.spacing / fluid.units.dx);
                    if !(r.is_finite() && r >= min && r <= 4.0) {
                        return err(
                            "coupling.kernel_radius",
                            format!("must lie in [{min:.3}, 4] cells (at least one cell and two particle spacings, so that the level set is smooth), got {r}"),
                        );
                    }
                }
            }
        }
        if s.dimension != dim {
            return err("solid.dimension", format!("the fluid lattice is {dim}D, the solid {}D", s.dimension));
        }
        if dim == 3 && coupling.method == CouplingMethod::Weak {
            return err(
                "coupling.method",
                "the weak coupling runs in 2D only (3D surfaces are not triangulated yet); use \"momentum_conserving\", whose level sets need no surface mesh",
            );
        }
        if coupling.method == CouplingMethod::Weak && s.integrator != crate::solid::Integrator::Explicit {
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
        for (k, p) in coupling.probes.iter().enumerate() {
            let f = format!("coupling.probes[{k}]");
            let lo = crate::scene::solid::vec3(&format!("{f}.min"), &p.min, dim, false)?;
            let hi = crate::scene::solid::vec3(&format!("{f}.max"), &p.max, dim, false)?;
            if (0..dim).any(|a| lo[a] > hi[a]) {
                return err(format!("{f}.max"), "must not be below min on any axis");
            }
            if p.name.is_empty() || !p.name.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_') {
                return err(format!("{f}.name"), format!("must be a non-empty column name of letters, digits and _, got {:?}", p.name));
            }
        }
        if coupling.output_every == Some(0) {
            return err("coupling.output_every", "must be at least 1");
        }
        // The weak coupling hands the air's force to the solid one step late: with air denser
        // than the body its added mass makes that explicit exchange unstable. Measured: a free
        // disc hit by a pressure pulse is stable at ρ_f/ρ_s = 5 and diverges at 6.7
        // (validation::fsi::added_mass_stability); a clamped one (fsi_cylinder) holds to 30;
        // at 10⁶ it diverged in the first step (the fuzzed reader found it). The free body's
        // limit is the bound. Method 2 puts the air's added mass into the solid's update
        // (2.129): the same free disc is stable at every ratio tried up to 10⁶; its bound,
        // MAX_DENSITY_RATIO_CONSERVING, keeps three decades of that untried elsewhere.
        let rho_f = fluid.file.gas.density;
        let (limit, which) = match coupling.method {
            CouplingMethod::Weak => (MAX_DENSITY_RATIO, "the weak coupling"),
            CouplingMethod::MomentumConserving => (MAX_DENSITY_RATIO_CONSERVING, "method 2 (measured on a free disc)"),
        };
        if let Some(rho_s) = solid.materials.iter().map(|m| m.density).reduce(f64::min)
            && rho_f / rho_s > limit
        {
            return err(
                "gas.density",
                format!(
                    "{rho_f} is {:.3e} times the lightest solid material's density {rho_s}; {which} is unstable or untried above a ratio of {limit:e} (added mass)",
                    rho_f / rho_s
                ),
            );
        }
        // The air's viscous traction on a surface particle acts, across the one-step lag of the
        // weak coupling, as a damper c ≈ μ l₀^(d−1)/Δx (shear stress μ v/Δx on its face) on a
        // mass m = ρ_s l₀^d: explicit, it is stable only for Δt c/m < 2, i.e.
        // Δt < 2 ρ_s l₀ Δx / μ (the fuzzed reader found the divergence at μ × 10⁶).
        if let Some(rho_s) = solid.materials.iter().map(|m| m.density).reduce(f64::min) {
            let mu = fluid.file.gas.viscosity;
            let dt = fluid.params.dt * fluid.units.time();
            let limit = 2.0 * rho_s * s.spacing * dx / mu;
            if dt >= limit {
                return err(
                    "gas.viscosity",
                    format!(
                        "{mu} makes the air's viscous traction too stiff for the weak coupling: its fluid step {dt:.3e} must stay below 2 ρ_s l₀ Δx / μ = {limit:.3e}"
                    ),
                );
            }
        }
        let size = &fluid.file.domain.size;
        for (k, b) in s.bodies.iter().enumerate() {
            let (lo, hi) = body_bounds(b, dim, s.spacing);
            let what = if b.fold.is_some() { "its free part (all but the clamped lateral strip)" } else { "it" };
            for a in 0..dim {
                if lo[a] < 0.0 || hi[a] > size[a] {
                    return err(
                        format!("solid.bodies[{k}]"),
                        format!("{what} extends over [{}, {}] along axis {a}, outside the domain [0, {}]", lo[a], hi[a], size[a]),
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
    /// The particles whose reference position lies in particle probe `k`'s box.
    pub fn probe_particles(&self, p: &crate::solid::Particles, k: usize) -> Vec<usize> {
        let pr = &self.coupling.probes[k];
        let v = |x: &[f64]| crate::scene::solid::vec3("", x, p.dim, false).expect("validated by the scene");
        let (lo, hi) = (v(&pr.min), v(&pr.max));
        (0..p.len()).filter(|&i| crate::scene::solid::inside(p.reference[i], lo, hi, p.dim)).collect()
    }

    pub fn build(&self) -> Result<CoupledSolver, SceneError> {
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
        for (k, pr) in self.coupling.probes.iter().enumerate() {
            if self.probe_particles(p, k).is_empty() {
                return err(format!("coupling.probes[{k}]"), format!("the box of probe {:?} holds no particle's reference position", pr.name));
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
        let c = &self.coupling;
        let method = match c.method {
            CouplingMethod::Weak => {
                Method::Weak(WeakOptions { traction: c.traction.unwrap_or_default(), piece_length: c.piece_length.unwrap_or(1.0), ..Default::default() })
            }
            CouplingMethod::MomentumConserving => {
                let d = ConservingOptions::default();
                Method::Conserving(ConservingOptions { kernel_radius: c.kernel_radius.unwrap_or(d.kernel_radius), ..d })
            }
        };
        CoupledSolver::new(fluid, solid, units, bodies, self.fluid.obstacles.clone(), method)
            .map_err(|e| SceneError { field: "coupling".into(), reason: e.to_string() })
    }
}

impl CoupledScene {
    /// The glottis when the solid has exactly one left and one right fold about the same
    /// mid-line: glottal gap, flow and margins are then sampled during a run.
    pub fn glottis(&self, c: &CoupledSolver) -> Option<Glottis> {
        let folds: Vec<(usize, &FoldBodySpec)> = self.solid.file.solid.bodies.iter().enumerate().filter_map(|(k, b)| b.fold.as_ref().map(|f| (k, f))).collect();
        let [(a, fa), (b, fb)] = folds[..] else { return None };
        let ((l, _), (r, fr)) = match (fa.side, fb.side) {
            (FoldSide::Left, FoldSide::Right) => ((a, fa), (b, fb)),
            (FoldSide::Right, FoldSide::Left) => ((b, fb), (a, fa)),
            _ => return None,
        };
        if fa.origin[0] != fb.origin[0] {
            return None;
        }
        let sec = &fr.section;
        let m = 0.5 * sec.gap;
        // the margins of the medial surface (in 3D at mid-length)
        let (lower, upper) = if self.fluid.grid.dim == 3 {
            (fr.to_scene_3d([m, 0.5 * sec.length, sec.height - sec.t2]), fr.to_scene_3d([m, 0.5 * sec.length, sec.height]))
        } else {
            (fr.to_scene([m, sec.height - sec.t2]), fr.to_scene([m, sec.height]))
        };
        Some(Glottis::new(c, l, r, fr.origin[0], sec.length, lower, upper))
    }

    /// Sets the folds' layers to a body–cover case: the fold bodies' `material` to in-plane
    /// Young's modulus `body`, their `cover_material` to `cover` (shear moduli scaled with them,
    /// Poisson ratios kept). Materials shared with non-fold bodies change for those too.
    pub fn set_fold_moduli(&mut self, cover: f64, body: f64) {
        let folds: Vec<(usize, usize)> = self.solid.file.solid.bodies.iter().filter_map(|b| b.fold.as_ref().map(|f| (b.material, f.cover_material))).collect();
        for (b, c) in folds {
            for (m, e) in [(b, body), (c, cover)] {
                let mat = &mut self.solid.materials[m];
                *mat = mat.scaled(e / mat.young[0]);
            }
        }
    }

    /// The lung pressure: the gauge pressure of the inlet on the tracheal face (y_min), if any.
    pub fn lung_pressure(&self) -> Option<f64> {
        match self.fluid.file.boundaries.y_min {
            crate::scene::schema::FaceSpec::PressureInlet { pressure, .. } => Some(pressure),
            _ => None,
        }
    }
}

/// The bounding box of a validated body of a `dim`-dimensional solid (of a fold: its free part).
fn body_bounds(b: &BodySpec, dim: usize, spacing: f64) -> (DVec3, DVec3) {
    let v = |a: &[f64]| vec3("", a, dim, false).expect("validated");
    if let Some(f) = &b.fold {
        return f.free_bounds(spacing);
    }
    match b.radius {
        Some(r) => (v(&b.center) - DVec3::splat(r), v(&b.center) + DVec3::splat(r)),
        None => (v(&b.min), v(&b.max)),
    }
}

fn reference_shape(b: &BodySpec, dim: usize) -> ReferenceShape {
    let v = |a: &[f64]| vec3("", a, dim, false).expect("validated");
    if let Some(f) = &b.fold {
        return if dim == 3 { ReferenceShape::Sampled } else { ReferenceShape::Outline(f.outline()) };
    }
    match b.radius {
        Some(r) if dim == 3 => ReferenceShape::Ball { centre: v(&b.center), radius: r },
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
        let cases: [(&str, &str, &str); 9] = [
            ("method = \"weak\"", "method = \"momentum_conserving\"", "coupling.traction"),
            ("output_every = 10", "output_every = 10\nkernel_radius = 2.0", "coupling.kernel_radius"),
            ("method = \"weak\"\ntraction = \"pressure_and_shear\"", "method = \"momentum_conserving\"\nkernel_radius = 0.5", "coupling.kernel_radius"),
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

    fn glottis_text(name: &str) -> &'static str {
        crate::scene::builtin(name).unwrap()
    }

    #[test]
    fn the_glottis_scenes_carry_the_seed_folds_and_titze_cases() {
        use crate::solid::fold::{BodyCoverCase, FoldSection};
        for (name, case) in
            [("glottis_2d_a", BodyCoverCase::A), ("glottis_2d_b", BodyCoverCase::B), ("glottis_2d_c", BodyCoverCase::C), ("glottis_2d_d", BodyCoverCase::D)]
        {
            let sc = CoupledScene::parse(glottis_text(name)).unwrap();
            let s = &sc.solid.file.solid;
            // body = material 0, cover = material 1, in-plane E and ν = 0.97, fibre decoupled
            let (cover, body) = case.young();
            assert_eq!((s.materials.len(), sc.solid.materials[0].young[0], sc.solid.materials[1].young[0]), (2, body, cover), "{name}");
            for m in &sc.solid.materials {
                assert_eq!(m.poisson, [0.97, 0.0, 0.0], "{name}");
                assert!((m.shear[2] - m.young[0] / (2.0 * 1.97)).abs() < 1e-3 * m.shear[2], "{name}: G_xy = E/(2(1+ν))");
                assert_eq!((m.density, m.viscosity), (1.043, 5.0), "{name}");
            }
            for b in &s.bodies {
                let f = b.fold.as_ref().unwrap();
                assert_eq!((&f.section, f.cover_material, b.material), (&FoldSection::default(), 1, 0), "{name}");
            }
            assert_eq!(sc.lung_pressure(), Some(8000.0), "{name}");
            assert_eq!((sc.fluid.grid.n[0], sc.fluid.grid.n[1]), (124, 128), "{name}");
            // the coarse scene set to this case (as `validate --case glottis_2d` does) carries
            // the same layers
            let mut coarse = CoupledScene::parse(glottis_text("glottis_2d_coarse")).unwrap();
            coarse.set_fold_moduli(cover, body);
            for (a, b) in coarse.solid.materials.iter().zip(&sc.solid.materials) {
                for k in 0..3 {
                    assert!((a.young[k] / b.young[k] - 1.0).abs() < 1e-12 && (a.shear[k] / b.shear[k] - 1.0).abs() < 1e-3, "{name}: {a:?} vs {b:?}");
                }
                assert_eq!((a.poisson, a.density, a.viscosity), (b.poisson, b.density, b.viscosity));
            }
        }
    }

    /// The CPU-sized 3D glottis (seed §3.4.3) builds the two extruded folds of the seed's
    /// three layers — cover 1/9, the thyroarytenoid layer outside the quarter ellipse, the body —
    /// mirrored about the mid-line, the glottis widening by 0.06 cm from the anterior to the
    /// posterior end, the anterior face clamped and the posterior face clamped but its cover;
    /// coupled by method 2 it takes steps with a finite state.
    #[test]
    fn the_3d_glottis_builds_three_layer_folds_and_runs() {
        let sc = CoupledScene::parse(glottis_text("glottis_3d_coarse")).unwrap();
        let mut c = sc.build().unwrap();
        let p = &c.solid.particles;
        let section = crate::solid::fold::FoldSection::default();
        let l0 = p.spacing;
        // each fold holds its volume in particles of l₀³ (within the lattice sampling's 2 %)
        let expected = 2.0 * section.area() * section.length / l0.powi(3);
        assert!((p.len() as f64 / expected - 1.0).abs() < 0.02, "{} particles, expected {expected:.0}", p.len());
        let share = |m: u16| p.material.iter().filter(|x| **x == m).count() as f64 / p.len() as f64;
        let (cover, ta) = (share(1), share(2));
        assert!((cover - 1.0 / 9.0).abs() < 0.015, "cover fraction {cover}");
        // outside a quarter ellipse of semi-axes width × length: 1 − π/4 of the section's
        // bounding box, less the cover — a sizeable layer
        assert!(ta > 0.05 && ta < 0.3, "thyroarytenoid fraction {ta}");
        let x0 = 1.6625 / 2.0;
        let (l, r): (Vec<usize>, Vec<usize>) = (0..p.len()).partition(|&i| p.body[i] == 0);
        assert_eq!(l.len(), r.len());
        assert!(l.iter().all(|&i| p.reference[i].x < x0) && r.iter().all(|&i| p.reference[i].x > x0));
        // the medial surface of the right fold: G/2 from the mid-line at the anterior end,
        // G/2 + 0.03 cm at the posterior end
        let medial = |z: f64| r.iter().filter(|&&i| (p.reference[i].z - z).abs() < 0.5 * l0).map(|&i| p.reference[i].x - x0).fold(f64::INFINITY, f64::min);
        let (front, back) = (medial(0.5 * l0), medial(section.length - 0.5 * l0));
        assert!((back - front - 0.06 * (1.0 - l0 / section.length) / 2.0).abs() < 0.6 * l0, "medial surface at {front} (anterior), {back} (posterior)");
        // anterior face clamped, posterior cover free
        let at = |z: f64, m: u16| r.iter().filter(|&&i| (p.reference[i].z - z).abs() < 0.5 * l0 && p.material[i] == m).map(|&i| p.fixed[i]).collect::<Vec<_>>();
        assert!(at(0.5 * l0, 1).iter().all(|f| *f), "the anterior face is clamped");
        // (but where the cover meets the clamped lateral strip)
        let back_cover = at(section.length - 0.5 * l0, 1);
        let free = back_cover.iter().filter(|f| !**f).count() as f64 / back_cover.len() as f64;
        assert!(free > 0.8, "the posterior cover is free: {free} of it");
        assert!(at(section.length - 0.5 * l0, 0).iter().all(|f| *f), "the posterior body is clamped");
        // the lattice sees mirror-image folds: every node's kind equals its mirror's about x₀
        // (a sheared sample's surface once broke this: 90 nodes, see BodySurface::build)
        let (g, kind) = (&c.fluid.layout.grid, &c.fluid.layout.kind);
        let n = g.n;
        let asymmetric = (0..n[2] as i64)
            .flat_map(|z| (0..n[1] as i64).flat_map(move |y| (0..n[0] as i64).map(move |x| [x, y, z])))
            .filter(|x| kind[g.index(*x)] != kind[g.index([n[0] as i64 - 1 - x[0], x[1], x[2]])])
            .count();
        assert_eq!(asymmetric, 0, "nodes whose mirror image has another kind");
        c.run(3).expect("the 3D glottis steps");
        assert!(c.solid.non_finite().is_none() && c.fluid.totals().mass.is_finite());
        // the 3D glottal readouts: the narrowest section between the folds' walls as the air
        // sees them lies within the folds' height, and its area is the opening's, (G + 0.06/2)·L
        // (G at the anterior end widening linearly by 0.06 cm), within 0.4 cells per line
        // (each wall within 0.2 cells of the face its particles sample:
        // coupling::glottis `the_narrowest_3d_section_of_two_slab_folds`)
        let glottis = sc.glottis(&c).expect("two folds");
        let s = glottis.sample(&c);
        let (y0, h) = (0.4, section.height);
        assert!(s.narrowest_y > y0 && s.narrowest_y < y0 + h + 0.05, "narrowest section at y = {}", s.narrowest_y);
        let opening = (section.gap + 0.03) * section.length;
        let dx = c.units.dx;
        assert!((s.area - opening).abs() < 0.4 * dx * section.length, "area {} cm², the opening {opening} cm²", s.area);
        assert!(s.flow.is_finite() && s.gap > 0.0);
        eprintln!("3D glottis after 3 steps: area {:.3e} cm², gap {:.3e} cm at y = {:.3} cm, flow {:.3e} cm³/s", s.area, s.gap, s.narrowest_y, s.flow);
    }

    #[test]
    fn the_glottis_builds_two_folds_with_their_layers_clamps_and_gap() {
        let sc = CoupledScene::parse(glottis_text("glottis_2d_coarse")).unwrap();
        let c = sc.build().unwrap();
        let p = &c.solid.particles;
        let section = crate::solid::fold::FoldSection::default();
        let l0 = p.spacing;
        // each fold holds its section's area in particles of l₀² (within the lattice sampling's 2 %)
        let expected = 2.0 * section.area() / (l0 * l0);
        assert!((p.len() as f64 / expected - 1.0).abs() < 0.02, "{} particles, expected {expected:.0}", p.len());
        // the cover (material 1) is 1/9 of each fold
        let cover = p.material.iter().filter(|m| **m == 1).count() as f64 / p.len() as f64;
        assert!((cover - 1.0 / 9.0).abs() < 0.01, "cover fraction {cover}");
        // the clamped particles are those within fixed_depth = 0.025 cm of a lateral face (x₀ ± (G/2 + width))
        let x0 = 1.513671875 / 2.0;
        let lateral = 0.5 * section.gap + section.width;
        for i in 0..p.len() {
            let depth = lateral - (p.reference[i].x - x0).abs();
            assert_eq!(p.fixed[i], depth < 0.025, "particle {i} at depth {depth}");
        }
        assert!(p.fixed.iter().any(|f| *f));
        // the left fold mirrors the right one
        let (l, r): (Vec<usize>, Vec<usize>) = (0..p.len()).partition(|&i| p.body[i] == 0);
        assert_eq!(l.len(), r.len());
        assert!(l.iter().all(|&i| p.reference[i].x < x0) && r.iter().all(|&i| p.reference[i].x > x0));
        // the glottis: the seed's initial gap G = 0.021 cm at the medial surface, no flow at rest,
        // margins at rest
        let g = sc.glottis(&c).expect("two folds make a glottis");
        let s = g.sample(&c);
        assert!((s.gap - section.gap).abs() < 1e-9, "gap {}", s.gap);
        assert!((s.area - section.gap * section.length).abs() < 1e-9, "area {}", s.area);
        assert!(s.narrowest_y > 0.45 + section.height - section.t2 - 1e-9 && s.narrowest_y < 0.45 + section.height + 1e-9, "narrowest at {}", s.narrowest_y);
        assert_eq!((s.flow, s.lower_margin, s.upper_margin), (0.0, 0.0, 0.0));
        // the lower margin sits at the foot of the vertical medial surface, the upper one at its top
        for (k, want) in [(g.lower_margin[1], 0.45 + section.height - section.t2), (g.upper_margin[1], 0.45 + section.height)] {
            assert!((p.reference[k].y - want).abs() < 1.5 * l0, "margin particle at {:?}, expected y ≈ {want}", p.reference[k]);
        }
    }

    #[test]
    fn the_glottal_flow_is_the_volume_flux_through_the_narrowest_section() {
        // Air moving up at a uniform 1000 cm/s with density ρ₀ (1.02 ρ₀): the probe reads
        // u × (the fluid nodes' width between the folds) × the fold length (× 1.02).
        let text = glottis_text("glottis_2d_a").replace("spacing = 0.006103515625", "spacing = 0.0042");
        let sc = CoupledScene::parse(&text).unwrap();
        let mut c = sc.build().unwrap();
        let g = sc.glottis(&c).unwrap();
        let u = c.units;
        let before = g.sample(&c);
        let row = u.position_to_lattice(before.narrowest_y).round() as i64;
        let grid = c.fluid.layout.grid.clone();
        let open: usize = (0..grid.n[0] as i64).filter(|&i| c.fluid.layout.kind[grid.index([i, row, 0])] == crate::fluid::layout::NodeKind::Fluid).count();
        assert!(open >= 1, "the 0.021 cm gap holds {open} nodes of {} cm", u.dx);
        for rho in [1.0, 1.02] {
            let theta = u.theta0;
            let uy = u.velocity_to_lattice(1000.0);
            c.fluid.initialise(|_| crate::fluid::Macro { rho, u: [0.0, uy, 0.0], theta });
            let s = g.sample(&c);
            let want = rho * 1000.0 * open as f64 * u.dx * 1.4;
            assert!((s.flow - want).abs() < 1e-9 * want, "flow {} vs {want}", s.flow);
        }
    }

    #[test]
    fn bad_fold_bodies_are_refused_with_the_field() {
        let base = glottis_text("glottis_2d_coarse");
        let left = "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, fixed_depth = 0.025 }, material = 0 }";
        assert!(base.contains(left));
        let cases: [(&str, &str); 8] = [
            // settings of the 3D fold in a 2D scene
            ("{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, opening = 0.06 }, material = 0 }", "solid.bodies[0].fold.opening"),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, ta_material = 1 }, material = 0 }",
                "solid.bodies[0].fold.ta_material",
            ),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, fixed_depth = 0.025 }, material = 0, radius = 0.1 }",
                "solid.bodies[0].fold",
            ),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 5, fixed_depth = 0.025 }, material = 0 }",
                "solid.bodies[0].fold.cover_material",
            ),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, fixed_depth = 0.025, section = { t2 = 0.6 } }, material = 0 }",
                "solid.bodies[0].fold.section.t2",
            ),
            ("{ fold = { side = \"left\", origin = [0.7568359375], cover_material = 1, fixed_depth = 0.025 }, material = 0 }", "solid.bodies[0].fold.origin"),
            // the free part of the fold would reach past the domain's side wall
            ("{ fold = { side = \"left\", origin = [0.7, 0.45], cover_material = 1, fixed_depth = 0.025 }, material = 0 }", "solid.bodies[0]"),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, fixed_depth = 0.9 }, material = 0 }",
                "solid.bodies[0].fold.fixed_depth",
            ),
        ];
        for (to, field) in cases {
            let e = CoupledScene::parse(&base.replacen(left, to, 1)).err().unwrap_or_else(|| panic!("{to} accepted"));
            assert_eq!(e.field, field, "{to}: {e}");
        }
        // the 3D fold: a missing thyroarytenoid material, an opening as wide as the fold
        let base3 = glottis_text("glottis_3d_coarse");
        for (from, to, field) in
            [("ta_material = 2", "ta_material = 3", "solid.bodies[0].fold.ta_material"), ("opening = 0.06", "opening = 0.9", "solid.bodies[0].fold.opening")]
        {
            assert!(base3.contains(from));
            let e = CoupledScene::parse(&base3.replacen(from, to, 1)).err().unwrap_or_else(|| panic!("{to} accepted"));
            assert_eq!(e.field, field, "{to}: {e}");
        }
        // particles coarser than the cover layer (≈ 0.02 cm)
        let e = CoupledScene::parse(&base.replace("spacing = 0.01220703125", "spacing = 0.024")).err().unwrap();
        assert_eq!(e.field, "solid.spacing", "{e}");
        // the seed's cm defaults in an SI scene
        let e = CoupledScene::parse(&base.replace("units = \"cgs\"", "units = \"si\"")).err().unwrap();
        assert_eq!(e.field, "solid.bodies[0].fold.section", "{e}");
    }
}
