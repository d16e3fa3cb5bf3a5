//! Validation of a scene file and its translation to lattice units. Every check runs before
//! anything large is allocated; an error names the field and the reason.

use super::fluid_parts::{Fastest, GasUnits, face_conditions, lattice_cells, lattice_point, memory_estimate, rigid_obstacles, step_params};
use super::schema::*;
use crate::fluid::{Boundaries, Equilibrium, FluidSolver, Grid, Macro, Obstacle, StepParams, VelocitySet};
use crate::units::Units;
use serde::Serialize;

pub use crate::error::SceneError;

pub(super) fn err<T>(field: impl Into<String>, reason: impl Into<String>) -> Result<T, SceneError> {
    Err(SceneError { field: field.into(), reason: reason.into() })
}

/// A wall's reduced temperature `theta` must lie inside `set`'s positivity window (every
/// weight of the equilibrium positive, [`VelocitySet::positivity_window`]): the one check of
/// the domain's isothermal faces and inlets and of the coupled bodies' isothermal walls.
pub(crate) fn wall_theta_in_window(set: &VelocitySet, theta: f64, field: impl Into<String>) -> Result<(), SceneError> {
    let window = set.positivity_window();
    if theta > window.0 && theta < window.1 {
        return Ok(());
    }
    err(field, format!("θ = {theta:.4} leaves the positivity window ({:.3}, {:.3})", window.0, window.1))
}

/// A validated scene in lattice units, ready to allocate.
#[derive(Clone, Debug)]
pub struct FluidScene {
    pub file: SceneFile,
    pub units: Units,
    pub set: VelocitySet,
    pub grid: Grid,
    pub boundaries: Boundaries,
    pub obstacles: Vec<Obstacle>,
    pub params: StepParams,
    /// Kinematic viscosity in lattice units.
    pub nu: f64,
    pub initial_velocity: [f64; 3],
    pub perturbation: f64,
    pub body_force: [f64; 3],
    pub steps: u64,
    /// (name, interior node coordinates, rounded to the nearest node)
    pub probes: Vec<(String, [i64; 3])>,
    /// Lattice Mach number of the reference velocity (Mach scaling) or of the largest velocity
    /// the scene prescribes.
    pub reference_mach: f64,
    /// Mach number of the largest set speed in the real gas (`gas.sound_speed`): what the
    /// Mach-scaled lattice stands for.
    pub real_mach: f64,
    pub mach_scaled: bool,
    pub estimated_bytes: f64,
    /// Speed of sound of the real gas (`gas.sound_speed`, or air's), scene units.
    pub real_sound_speed: f64,
    /// Speed of sound on the lattice, √(γ θ₀) (lattice units).
    pub lattice_sound_speed: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneSummary {
    pub name: String,
    pub lattice: String,
    pub nodes: [usize; 3],
    pub units: Units,
    pub params: StepParams,
    pub nu_lattice: f64,
    pub steps: u64,
    pub reference_mach: f64,
    /// Mach number of the largest set speed in the real gas (`gas.sound_speed`): what the
    /// Mach-scaled lattice stands for.
    pub real_mach: f64,
    pub mach_scaled: bool,
}

/// The FDLB equilibrium is a low-Mach expansion: a speed the scene sets (`field`, scene units)
/// is refused above lattice Mach 0.5, the bound of `numerics.mach_scaling.mach` (or when NaN).
fn check_lattice_mach(field: &str, speed: f64, lattice_mach: f64, mach_scaled: bool) -> Result<(), SceneError> {
    if lattice_mach.is_nan() || lattice_mach > 0.5 {
        let hint = if mach_scaled { " (raise numerics.mach_scaling.reference_velocity, or lower this speed)" } else { "" };
        return err(field, format!("speed {speed:e} is lattice Mach {lattice_mach:.3}, above 0.5{hint}"));
    }
    Ok(())
}

/// Parses TOML text (unknown keys and wrong types are errors that name the dotted key).
pub fn parse(text: &str) -> Result<SceneFile, SceneError> {
    toml::from_str(text)
        .map_err(|e| SceneError { field: e.span().map(|s| key_path(text, s.start)).unwrap_or_else(|| "<file>".into()), reason: e.message().to_string() })
}

/// Dotted path (`table.key`) of the key on the line holding byte `pos`.
fn key_path(text: &str, pos: usize) -> String {
    let before = &text[..pos.min(text.len())];
    let line_start = before.rfind('\n').map(|i| i + 1).unwrap_or(0);
    let line = text[line_start..].lines().next().unwrap_or("");
    let table =
        before[..line_start].lines().rev().find_map(|l| l.trim().strip_prefix('[').map(|t| t.trim_start_matches('[').trim_end_matches(']').trim().to_string()));
    let key = line.split('=').next().unwrap_or("").trim().trim_start_matches('[').trim_end_matches(']');
    match (table, key.is_empty()) {
        (Some(t), false) if !line.trim_start().starts_with('[') => format!("{t}.{key}"),
        (Some(t), _) => t,
        (None, false) => key.to_string(),
        (None, true) => "<file>".into(),
    }
}

/// Parses and validates a scene.
pub fn load(text: &str) -> Result<FluidScene, SceneError> {
    FluidScene::new(parse(text)?)
}

pub(super) fn finite_positive(field: &str, v: f64) -> Result<f64, SceneError> {
    if v.is_finite() && v > 0.0 { Ok(v) } else { err(field, format!("must be positive and finite, got {v}")) }
}

/// The Mach scaling's reference speed (scene units): the number given, or for `"bernoulli"`
/// √(2Δp/ρ₀) with Δp the largest gauge pressure difference between the pressure faces
/// (`pressure_inlet`, `pressure_outlet`) and the initial state's gauge 0.
pub(super) fn reference_velocity(r: &ReferenceVelocity, faces: &FaceSpecs, rho0: f64) -> Result<f64, SceneError> {
    const FIELD: &str = "numerics.mach_scaling.reference_velocity";
    match r {
        ReferenceVelocity::Speed(u) => finite_positive(FIELD, *u),
        ReferenceVelocity::Named(name) if name == "bernoulli" => {
            let mut pressures = vec![0.0];
            for (face, spec) in faces.named() {
                if let Some(FaceSpec::PressureInlet { pressure, .. } | FaceSpec::PressureOutlet { pressure, .. }) = spec {
                    if !pressure.is_finite() {
                        return err(format!("boundaries.{face}.pressure"), "must be finite");
                    }
                    pressures.push(*pressure);
                }
            }
            let hi = pressures.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let lo = pressures.iter().cloned().fold(f64::INFINITY, f64::min);
            let dp = hi - lo;
            if dp <= 0.0 {
                return err(FIELD, "\"bernoulli\" needs a pressure face whose gauge pressure is not 0 (the jet speed comes from the pressure difference)");
            }
            Ok((2.0 * dp / rho0).sqrt())
        }
        ReferenceVelocity::Named(other) => err(FIELD, format!("a speed (scene units) or \"bernoulli\", got \"{other}\"")),
    }
}

/// A `dim`-component vector of a scene file (z = 0 in 2D); `allow_empty`: [] means zero.
pub(crate) fn vector(field: &str, v: &[f64], dim: usize, allow_empty: bool) -> Result<[f64; 3], SceneError> {
    if v.is_empty() && allow_empty {
        return Ok([0.0; 3]);
    }
    if v.len() != dim {
        return err(field, format!("needs {dim} components in a {dim}D scene, got {}", v.len()));
    }
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return err(field, format!("component {x} is not finite"));
    }
    Ok(std::array::from_fn(|a| if a < dim { v[a] } else { 0.0 }))
}

impl FluidScene {
    /// Validates `file` (every error names its field, before anything large is allocated) and
    /// translates it to lattice units.
    pub fn new(file: SceneFile) -> Result<Self, SceneError> {
        let set = VelocitySet::new(file.domain.lattice);
        let dim = set.dim;
        let (dx, n) = lattice_cells(&file.domain, dim)?;
        let eq = Equilibrium::new(set.clone(), file.gas.model);
        let gas = GasUnits::of(&file, &set, dx, eq.gamma())?;
        let (units, theta0, gamma) = (gas.units, gas.theta0, gas.gamma);
        let mut fastest = Fastest::default();
        let boundaries = face_conditions(&file, &set, &gas, &mut fastest)?;
        let obstacles = rigid_obstacles(&file, dim, &units)?;

        // Initial state and forcing.
        let ini = &file.initial;
        let u0 = vector("initial.velocity", &ini.velocity, dim, true)?;
        fastest.note(u0.iter().map(|x| x.abs()).fold(0.0, f64::max), "initial.velocity".into());
        check_lattice_mach(&fastest.field, fastest.speed, units.velocity_to_lattice(fastest.speed) / (gamma * theta0).sqrt(), gas.mach_scaled)?;
        if !(ini.perturbation.is_finite() && ini.perturbation.abs() <= 0.5) {
            return err("initial.perturbation", format!("must be in [−0.5, 0.5], got {}", ini.perturbation));
        }
        let gforce = vector("initial.body_force", &ini.body_force, dim, true)?;

        let nm = &file.numerics;
        let params = step_params(nm, &set, &gas)?;
        let duration = finite_positive("run.duration", file.run.duration)?;
        let steps = (units.time_to_lattice(duration) / params.dt).ceil() as u64;
        if steps > 1_000_000_000 {
            return err("run.duration", format!("needs {steps} steps"));
        }

        let mut probes = Vec::new();
        for (k, p) in file.probes.iter().enumerate() {
            let x = lattice_point(&format!("probes[{k}].position"), &p.position, &file.domain, dim, &units)?;
            let node = std::array::from_fn(|a| if a < dim { (x[a].round() as i64).clamp(0, n[a] as i64 - 1) } else { 0 });
            probes.push((p.name.clone(), node));
        }
        if file.output.probe_every == 0 {
            return err("output.probe_every", "must be at least 1");
        }

        // Memory estimate before allocation.
        let grid = Grid::new(dim, n);
        let estimated_bytes = memory_estimate(&grid, eq.values_per_node(), nm)?;

        let reference_mach = if gas.mach_scaled { gas.reference_mach } else { units.velocity_to_lattice(fastest.speed) / (gamma * theta0).sqrt() };
        Ok(FluidScene {
            units,
            set,
            grid,
            boundaries,
            obstacles,
            params,
            nu: gas.nu,
            initial_velocity: u0.map(|u| units.velocity_to_lattice(u)),
            perturbation: ini.perturbation,
            body_force: gforce.map(|g| units.acceleration_to_lattice(g)),
            steps,
            probes,
            reference_mach,
            real_mach: fastest.speed / gas.c_real,
            mach_scaled: gas.mach_scaled,
            real_sound_speed: gas.c_real,
            lattice_sound_speed: (gamma * theta0).sqrt(),
            estimated_bytes,
            file,
        })
    }

    /// Allocates the solver in its initial state.
    pub fn build_solver(&self) -> FluidSolver {
        let eq = Equilibrium::new(self.set.clone(), self.file.gas.model);
        let (u0, th0, amp) = (self.initial_velocity, self.units.theta0, self.perturbation);
        let n = self.grid.n;
        let speed = u0.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-3);
        let init = move |x: [f64; 3]| {
            // A smooth transverse kick, zero on the domain faces, that breaks the up-down symmetry.
            let sy = (std::f64::consts::PI * (x[1] + 0.5) / n[1] as f64).sin();
            let sx = (2.0 * std::f64::consts::PI * (x[0] + 0.5) / n[0] as f64).sin();
            let mut u = u0;
            u[1] += amp * speed * sx * sy;
            Macro { rho: 1.0, u, theta: th0 }
        };
        let mut s = FluidSolver::new(eq, self.grid.clone(), self.boundaries.clone(), &self.obstacles, self.params, init);
        s.body_force = self.body_force;
        s
    }

    /// Counts a speed that another part of the scene sets in the air (a body's prescribed
    /// motion, `field`) as the fluid's own set speeds are counted: refused above lattice Mach
    /// 0.5, and in the Mach numbers of the summary (the real gas's; the lattice's without Mach
    /// scaling). `speed` in scene units.
    pub fn count_set_speed(&mut self, field: &str, speed: f64) -> Result<(), SceneError> {
        let lattice_mach = self.units.velocity_to_lattice(speed) / self.lattice_sound_speed;
        check_lattice_mach(field, speed, lattice_mach, self.mach_scaled)?;
        self.real_mach = self.real_mach.max(speed / self.real_sound_speed);
        if !self.mach_scaled {
            self.reference_mach = self.reference_mach.max(lattice_mach);
        }
        Ok(())
    }

    pub fn summary(&self) -> SceneSummary {
        SceneSummary {
            name: self.file.name.clone(),
            lattice: format!("{:?}", self.file.domain.lattice),
            nodes: self.grid.n,
            units: self.units,
            params: self.params,
            nu_lattice: self.nu,
            steps: self.steps,
            reference_mach: self.reference_mach,
            real_mach: self.real_mach,
            mach_scaled: self.mach_scaled,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `reference_velocity = "bernoulli"` is the jet √(2Δp/ρ₀) of the scene's largest pressure
    /// difference: the coarse glottis's 8000 dyn/cm² give the 3676 cm/s its file writes by hand
    /// (to 2·10⁻⁵), twice the lung pressure √2 times that, and a lattice that has no pressure
    /// face, or a name that is not "bernoulli", is refused naming the key.
    #[test]
    fn a_bernoulli_reference_velocity_follows_the_pressure_faces() {
        let coarse = crate::scene::builtin("glottis_2d_coarse").unwrap();
        let by_hand = "reference_velocity = 3676.0";
        assert!(coarse.contains(by_hand));
        let try_fluid_part = |text: &str| -> Result<FluidScene, SceneError> {
            let mut t: toml::Table = toml::from_str(text).unwrap();
            for k in ["solid", "coupling"] {
                t.remove(k);
            }
            FluidScene::new(parse(&toml::to_string(&t).unwrap())?)
        };
        let fluid_part = |text: &str| try_fluid_part(text).unwrap();
        let bernoulli = coarse.replace(by_hand, "reference_velocity = \"bernoulli\"");
        // an integer speed is still a speed
        let integer = fluid_part(&coarse.replace(by_hand, "reference_velocity = 3676"));
        assert_eq!(integer.units.velocity, fluid_part(coarse).units.velocity);
        let (hand, auto) = (fluid_part(coarse), fluid_part(&bernoulli));
        let jet = (2.0 * 8000.0 / 1.184e-3f64).sqrt();
        assert!((auto.units.velocity / hand.units.velocity - jet / 3676.0).abs() < 1e-12);
        assert!((jet / 3676.0 - 1.0).abs() < 2e-5);
        let doubled = crate::run::sweep::set_key(&bernoulli, "boundaries.y_min.pressure", 16000.0).unwrap();
        assert!((fluid_part(&doubled).units.velocity / auto.units.velocity - 2f64.sqrt()).abs() < 1e-12);
        // a pressure outlet below the atmosphere's pressure counts too: Δp is inlet − outlet
        let below = bernoulli.replace("y_max = { type = \"outlet\" }", "y_max = { type = \"pressure_outlet\", pressure = -8000.0 }");
        assert!((fluid_part(&below).units.velocity / auto.units.velocity - 2f64.sqrt()).abs() < 1e-12);

        let cavity = crate::scene::builtin("lid_cavity").unwrap().to_string();
        let mut t: toml::Table = toml::from_str(&cavity).unwrap();
        let numerics = t.entry("numerics").or_insert(toml::Value::Table(Default::default())).as_table_mut().unwrap();
        numerics.insert(
            "mach_scaling".into(),
            toml::Value::Table(toml::toml! { reference_velocity = "bernoulli"
            mach = 0.1 }),
        );
        let e = FluidScene::new(parse(&toml::to_string(&t).unwrap()).unwrap()).unwrap_err();
        assert_eq!(e.field, "numerics.mach_scaling.reference_velocity");
        assert!(e.reason.contains("pressure face"), "{}", e.reason);
        let e = try_fluid_part(&bernoulli.replace("\"bernoulli\"", "\"jet\"")).expect_err("refused");
        assert_eq!(e.field, "numerics.mach_scaling.reference_velocity");
        assert!(e.reason.contains("\"jet\""), "{}", e.reason);
    }
}
