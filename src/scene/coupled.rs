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
//! # wall_temperature_ratio = 1.0   # the bodies' walls isothermal at this × T₀ (default: adiabatic)
//! output_every = 10                # coupling.csv row every this many steps
//! [[coupling.motions]]             # optional: a body with a prescribed rigid motion
//! body = 0
//! motion = { kind = "translation", velocity = [-10.0, 0.0] }
//! ```
//!
//! Lengths of the solid are in the fluid scene's units, positions from the fluid domain's
//! origin. Everything is checked before anything large is allocated.

use super::build::{FluidScene, SceneError};
use super::schema::{PopulationStorage, SceneFile};
use super::solid::{BodySpec, SolidRun, SolidScene, SolidSceneFile, SolidSpec, vec3};
use crate::coupling::{BodySurface, ConservingOptions, CoupledBody, CoupledSolver, Method, Motion, ReferenceShape, TractionModel, WeakOptions};
use crate::solid::SolidSolver;
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
    /// The bodies' surfaces as isothermal walls at this multiple of the reference temperature
    /// T₀ (the air's `numerics.temperature`); absent: adiabatic walls (zero normal temperature
    /// gradient), as before.
    pub wall_temperature_ratio: Option<f64>,
    pub output_every: Option<u64>,
    #[serde(default)]
    pub motions: Vec<MotionSpec>,
    /// Particle probes: the mean displacement of the particles whose reference position lies in
    /// the box [min, max] (e.g. a flap's tip), written to `coupling.csv` as `<name>_dx`, `_dy`.
    #[serde(default)]
    pub probes: Vec<crate::scene::solid::RegionProbe>,
}

/// The largest fluid/solid density ratio the weak coupling takes (see the check
/// `check_stability` that [`CoupledScene::new`] makes).
pub const MAX_DENSITY_RATIO: f64 = 5.0;
/// The largest fluid/solid density ratio method 2 takes (with its added mass, 2.129; see the
/// check `check_stability` that [`CoupledScene::new`] makes).
pub const MAX_DENSITY_RATIO_CONSERVING: f64 = 1.0e3;

/// Admissible particle spacing per lattice cell l₀/Δx: finer than 0.1 costs particles without
/// changing what the fluid sees; coarser than 2 leaves surface edges over two cells long,
/// whose straight walls cut corners of the body.
pub const SPACING_RATIO: (f64, f64) = (0.1, 2.0);

/// A coupled scene resolved without its lattice ([`CoupledScene::resolve`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CoupledResolved {
    pub particles: usize,
    /// Each body's surface points (method 1's surface particles; the level set's are all).
    pub surface_points: Vec<usize>,
    /// Solid sub-steps per coupled step.
    pub solid_substeps: u32,
    /// The coupled step (s).
    pub dt: f64,
}

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

/// Each method's own settings: none of the other's, method 2's kernel radius in range.
fn check_method_settings(coupling: &CouplingSpec, s: &SolidSpec, fluid: &FluidScene) -> Result<(), SceneError> {
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
                return err("coupling.traction", "is a setting of method = \"weak\"; method 2 hands the body the air's momentum link by link, not a traction");
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
    Ok(())
}

/// The solid's dimension is the lattice's, the weak coupling runs in 2D with the explicit
/// solid, and the particle spacing lies in [`SPACING_RATIO`] cells.
fn check_dimension_and_spacing(coupling: &CouplingSpec, s: &SolidSpec, fluid: &FluidScene) -> Result<(), SceneError> {
    let dim = fluid.grid.dim;
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
        return err("solid.spacing", format!("l₀/Δx = {ratio:.3} (l₀ = {}, Δx = {dx:.4e}) must lie in [{}, {}]", s.spacing, SPACING_RATIO.0, SPACING_RATIO.1));
    }
    Ok(())
}

/// The traction's pieces, the particle probes, the output interval and the walls' temperature.
fn check_settings(coupling: &CouplingSpec, fluid: &FluidScene) -> Result<(), SceneError> {
    let dim = fluid.grid.dim;
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
    if let Some(r) = coupling.wall_temperature_ratio {
        if !(r.is_finite() && r > 0.0) {
            return err("coupling.wall_temperature_ratio", format!("must be a positive multiple of T₀, got {r}"));
        }
        super::build::wall_theta_in_window(&fluid.set, r * fluid.units.theta0, "coupling.wall_temperature_ratio")?;
    }
    Ok(())
}

/// The bounds of the explicit exchanges measured or derived for each method: the air's density
/// against the lightest material's (added mass) and, for the weak coupling, its viscous
/// traction against the surface particles' mass.
fn check_stability(coupling: &CouplingSpec, solid: &SolidScene, fluid: &FluidScene) -> Result<(), SceneError> {
    let (s, dx) = (&solid.file.solid, fluid.units.dx);
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
    Ok(())
}

/// Every body (a fold's free part) inside the domain, a fold attached to its side wall.
fn check_bodies_inside(s: &SolidSpec, fluid: &FluidScene) -> Result<(), SceneError> {
    let dim = fluid.grid.dim;
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
        if let Some(f) = &b.fold {
            f.check_attached(&format!("solid.bodies[{k}].fold"), size)?;
        }
    }
    Ok(())
}

/// The prescribed motions: one per body, finite, and their largest speed counted with the
/// air's set speeds ([`FluidScene::count_set_speed`]: refused above lattice Mach 0.5).
fn count_motions(coupling: &CouplingSpec, s: &SolidSpec, fluid: &mut FluidScene) -> Result<(), SceneError> {
    let dim = fluid.grid.dim;
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
        // the body's largest speed (a rotation's at the farthest corner of its box)
        let speed = match &m.motion {
            Motion::Translation { velocity } => DVec3::from_array(*velocity).length(),
            Motion::Rotation { centre, angular_velocity } => {
                let (lo, hi) = body_bounds(&s.bodies[m.body], dim, s.spacing);
                let c = DVec3::from_array(*centre);
                let far = (0..8)
                    .map(|i| DVec3::new([lo.x, hi.x][i & 1], [lo.y, hi.y][(i >> 1) & 1], [lo.z, hi.z][i >> 2]) - c)
                    .map(|d| d.length())
                    .fold(0.0, f64::max);
                angular_velocity.abs() * far
            }
            Motion::Harmonic { amplitude, frequency } => std::f64::consts::TAU * frequency * DVec3::from_array(*amplitude).length(),
        };
        fluid.count_set_speed(&format!("coupling.motions[{k}].motion"), speed)?;
    }
    Ok(())
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

    /// Validates a coupled scene: the air's part ([`FluidScene::new`]), the solid's
    /// ([`SolidScene::new`]), then what the coupling asks of both — each error names its field.
    pub fn new(file: SceneFile, solid: SolidSpec, coupling: CouplingSpec) -> Result<Self, SceneError> {
        let solid_file = SolidSceneFile {
            name: file.name.clone(),
            description: file.description.clone(),
            units: file.units,
            solid,
            run: SolidRun { duration: file.run.duration, output_every: None, snapshots: None },
            probes: Vec::new(),
        };
        if file.numerics.storage == Some(PopulationStorage::F32) {
            return err("numerics.storage", "\"f32\" is for fluid-only scenes: the coupling reads the air's stage arrays in f64 (leave it out, or \"f64\")");
        }
        let mut fluid = FluidScene::new(file)?;
        let solid = SolidScene::new(solid_file)?;
        let s = &solid.file.solid;
        check_method_settings(&coupling, s, &fluid)?;
        check_dimension_and_spacing(&coupling, s, &fluid)?;
        check_settings(&coupling, &fluid)?;
        check_stability(&coupling, &solid, &fluid)?;
        check_bodies_inside(s, &fluid)?;
        count_motions(&coupling, s, &mut fluid)?;
        Ok(CoupledScene { fluid, solid, coupling })
    }

    /// The particles whose reference position lies in particle probe `k`'s box.
    pub fn probe_particles(&self, p: &crate::solid::Particles, k: usize) -> Vec<usize> {
        let pr = &self.coupling.probes[k];
        let v = |x: &[f64]| crate::scene::solid::vec3("", x, p.dim, false).expect("validated by the scene");
        let (lo, hi) = (v(&pr.min), v(&pr.max));
        (0..p.len()).filter(|&i| crate::scene::solid::inside(p.reference[i], lo, hi, p.dim)).collect()
    }

    /// Builds the coupled solver: the solid and its bodies, checked (`solid_and_bodies`), then the
    /// fluid's lattice.
    pub fn build(&self) -> Result<CoupledSolver, SceneError> {
        let (solid, bodies) = self.solid_and_bodies()?;
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
        CoupledSolver::new(fluid, solid, self.fluid.units, bodies, self.fluid.obstacles.clone(), method)
            .map_err(|e| SceneError { field: "coupling".into(), reason: e.to_string() })
    }

    /// What `phonation check` reports of a coupled scene, with every check of [`Self::build`]
    /// that the particles need, without allocating the air's lattice (for `glottis_3d`, 2.3·10⁶
    /// D3Q39 nodes: gigabytes and most of a build's time): the particles, each body's surface
    /// points, the coupled step and the solid's sub-steps in it (as [`CoupledSolver::new`] sets
    /// them).
    pub fn resolve(&self) -> Result<CoupledResolved, SceneError> {
        let (solid, bodies) = self.solid_and_bodies()?;
        let dt = self.fluid.params.dt * self.fluid.units.time();
        Ok(CoupledResolved {
            particles: solid.particles.len(),
            surface_points: bodies.iter().map(|b| b.surface.particles.len()).collect(),
            solid_substeps: crate::coupling::solid_substeps(dt, solid.dt),
            dt,
        })
    }

    /// The solid and its coupled bodies (each body's surface, motion and wall temperature),
    /// checked: no free particle in a rigid obstacle, every particle probe holding a particle,
    /// every body's surface built.
    fn solid_and_bodies(&self) -> Result<(SolidSolver, Vec<CoupledBody>), SceneError> {
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
        // every body's wall at the same temperature (or adiabatic)
        let wall_temperature = self.coupling.wall_temperature_ratio.map(|r| r * units.theta0);
        for (k, b) in self.solid.file.solid.bodies.iter().enumerate() {
            let surface = BodySurface::build(p, k as u16, &reference_shape(b, p.dim))
                .map_err(|e| SceneError { field: format!("solid.bodies[{k}]"), reason: e.to_string() })?;
            let motion = self.coupling.motions.iter().find(|m| m.body == k).map(|m| m.motion.clone());
            bodies.push(CoupledBody { surface, motion, wall_temperature });
        }
        Ok((solid, bodies))
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
        let cases: [(&str, &str, &str); 12] = [
            ("output_every = 10", "output_every = 10\nwall_temperature_ratio = 0.0", "coupling.wall_temperature_ratio"),
            ("output_every = 10", "output_every = 10\nwall_temperature_ratio = nan", "coupling.wall_temperature_ratio"),
            // θ = 1.95 × 0.6 = 1.17 is past D2Q21's window (0.370, 1.148)
            ("output_every = 10", "output_every = 10\nwall_temperature_ratio = 1.95", "coupling.wall_temperature_ratio"),
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
        // …and by `check` (which allocates no lattice), with the same field and reason
        let r = CoupledScene::parse(&text).unwrap().resolve().expect_err("overlap refused");
        assert_eq!(r, e);
    }

    /// `phonation check` resolves a coupled scene without its lattice: the same particles,
    /// surface points, coupled step and solid sub-steps as the built solver, for both methods,
    /// a prescribed motion and the 2D glottis's two folds.
    #[test]
    fn resolving_a_scene_gives_what_its_build_gives() {
        let towed = builtin().replacen(
            "output_every = 10",
            "output_every = 10\nmotions = [{ body = 0, motion = { kind = \"translation\", velocity = [0.01, 0.0] } }]",
            1,
        );
        let texts = ["fsi_cylinder", "fsi_cylinder_conserving", "glottis_2d_coarse"].map(|n| (n, crate::scene::builtin(n).unwrap().to_string()));
        for (name, text) in texts.into_iter().chain([("towed fsi_cylinder", towed)]) {
            let sc = CoupledScene::parse(&text).unwrap();
            assert_eq!(sc.coupling.motions.len(), usize::from(name.starts_with("towed")));
            let r = sc.resolve().unwrap();
            let c = sc.build().unwrap();
            let built = CoupledResolved {
                particles: c.solid.particles.len(),
                surface_points: c.bodies.iter().map(|b| b.surface.particles.len()).collect(),
                solid_substeps: c.substeps,
                dt: c.dt(),
            };
            assert_eq!(r, built, "{name}");
        }
    }

    /// `wall_temperature_ratio` makes the bodies' walls isothermal, and only theirs: every ghost
    /// node of the cylinder's wall carries θ_w = ratio × θ₀ (the channel's walls stay
    /// adiabatic), and a wall 10 % warmer than the air heats the air next to it, where an
    /// adiabatic one leaves it at θ₀ within its compressibility (Mach 0.1: ~10⁻³).
    #[test]
    fn isothermal_body_walls_carry_their_temperature_and_heat_the_air_next_to_them() {
        let near_body_theta = |ratio: Option<f64>| -> (f64, usize) {
            let text = match ratio {
                Some(r) => builtin().replacen("output_every = 10", &format!("output_every = 10\nwall_temperature_ratio = {r}"), 1),
                None => builtin().to_string(),
            };
            let mut c = CoupledScene::parse(&text).unwrap().build().unwrap();
            let theta0 = c.units.theta0;
            let centre = [c.units.position_to_lattice(0.2), c.units.position_to_lattice(0.2)];
            let radius = 0.05 / c.units.dx;
            let grid = c.fluid.layout.grid.clone();
            let distance = |node: usize| {
                let x = grid.coords(node);
                ((x[0] as f64 - centre[0]).powi(2) + (x[1] as f64 - centre[1]).powi(2)).sqrt() - radius
            };
            let (mut body_ghosts, mut channel_ghosts) = (0, 0);
            for g in &c.fluid.layout.ghosts {
                if distance(g.node) < 2.0 {
                    assert_eq!(g.wall_temperature, ratio.map(|r| r * theta0), "a ghost of the cylinder's wall");
                    body_ghosts += 1;
                } else {
                    assert_eq!(g.wall_temperature, None, "a ghost of the channel's (adiabatic) walls");
                    channel_ghosts += 1;
                }
            }
            assert!(body_ghosts > 20 && channel_ghosts > 100, "{body_ghosts} / {channel_ghosts}");
            c.run(200).unwrap();
            let near: Vec<usize> = (0..grid.len()).filter(|&n| c.fluid.layout.kind[n] == crate::fluid::layout::NodeKind::Fluid && distance(n) < 1.5).collect();
            let mean = near.iter().map(|&n| c.fluid.macro_at(n).theta).sum::<f64>() / near.len() as f64;
            (mean / theta0, c.fluid.layout.ghosts.iter().filter(|g| g.wall_temperature.is_some()).count())
        };
        // adiabatic: the air at the body is warmed only by its compression (the stagnation
        // point, and the impulsive start's pressure waves; measured +0.89 %)
        let (adiabatic, isothermal_ghosts) = near_body_theta(None);
        assert!((adiabatic - 1.0).abs() < 0.02 && isothermal_ghosts == 0, "adiabatic: θ/θ₀ = {adiabatic}");
        let (warm, isothermal_ghosts) = near_body_theta(Some(1.1));
        assert!(isothermal_ghosts > 20, "the walls stay isothermal as they are rebuilt: {isothermal_ghosts}");
        // the wall's 10 % excess reaches the air next to it, partly (heat is carried off by the
        // flow): at least a fifth of it above the adiabatic run, and not past the wall's
        assert!(warm - adiabatic > 0.02 && warm < 1.1 + (adiabatic - 1.0), "a wall at 1.1 θ₀: θ/θ₀ = {warm}, adiabatic {adiabatic}");
        println!("near the body after 200 steps: θ/θ₀ = {adiabatic} (adiabatic), {warm} (isothermal at 1.1)");
    }
}
