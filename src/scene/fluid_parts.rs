//! The parts of a fluid scene's validation ([`super::FluidScene::new`]), each checked before
//! anything large is allocated and translated to lattice units: the lattice, the gas and its
//! units, the faces, the rigid obstacles, the time step and the memory the solver will take.

use super::build::{err, finite_positive, reference_velocity, vector, wall_theta_in_window};
use super::schema::*;
use crate::error::SceneError;
use crate::fluid::equilibrium::MACRO_FIELDS;
use crate::fluid::{Boundaries, FaceCondition, Grid, Obstacle, Shape, StepParams, VelocitySet, timestep};
use crate::units::Units;

fn available_memory() -> f64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("MemAvailable")).and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok()))
        .map(|kb| kb * 1024.0)
        .unwrap_or(8.0 * 1024.0 * 1024.0 * 1024.0)
}

/// The fastest speed the scene sets in the air (scene units) and the field that sets it (named
/// when it is too fast for the lattice): the walls, inlets, a pressure inlet's Bernoulli speed
/// and the initial flow.
#[derive(Default)]
pub(super) struct Fastest {
    pub(super) speed: f64,
    pub(super) field: String,
}

impl Fastest {
    pub(super) fn note(&mut self, speed: f64, field: String) {
        if speed > self.speed {
            self.speed = speed;
            self.field = field;
        }
    }
}

/// The gas and the reference state in lattice units: what the faces, the obstacles and the time
/// step are translated with.
pub(super) struct GasUnits {
    pub(super) units: Units,
    pub(super) rho0: f64,
    /// The real gas's speed of sound (scene units).
    pub(super) c_real: f64,
    pub(super) gamma: f64,
    /// The reference state's reduced temperature θ₀.
    pub(super) theta0: f64,
    pub(super) mach_scaled: bool,
    /// `numerics.mach_scaling.mach` (0 without Mach scaling).
    pub(super) reference_mach: f64,
    /// Kinematic viscosity (lattice units).
    pub(super) nu: f64,
}

/// The lattice spacing (scene units) and node counts of `domain` (1 along unused axes); the
/// cells must be square.
pub(super) fn lattice_cells(d: &Domain, dim: usize) -> Result<(f64, [usize; 3]), SceneError> {
    if d.size.len() != dim {
        return err("domain.size", format!("lattice {:?} is {dim}D, so size needs {dim} entries, got {}", d.lattice, d.size.len()));
    }
    if d.cells.len() != dim {
        return err("domain.cells", format!("needs {dim} entries, got {}", d.cells.len()));
    }
    for a in 0..dim {
        finite_positive(&format!("domain.size[{a}]"), d.size[a])?;
        if d.cells[a] < 1 {
            return err(format!("domain.cells[{a}]"), format!("must be at least 1, got {}", d.cells[a]));
        }
    }
    let dx = d.size[0] / d.cells[0] as f64;
    for a in 1..dim {
        let dxa = d.size[a] / d.cells[a] as f64;
        if ((dxa - dx) / dx).abs() > 1e-6 {
            return err(format!("domain.cells[{a}]"), format!("spacing {dxa} differs from the x spacing {dx}; cells must be square"));
        }
    }
    Ok((dx, std::array::from_fn(|a| if a < dim { d.cells[a] as usize } else { 1 })))
}

impl GasUnits {
    /// The gas of `file` (heat-capacity ratio `gamma`, its equilibrium's) on `set`'s lattice of
    /// spacing `dx`: its density, viscosity and sound speed, the reference temperature inside
    /// the positivity window, the Mach scaling.
    pub(super) fn of(file: &SceneFile, set: &VelocitySet, dx: f64, gamma: f64) -> Result<Self, SceneError> {
        let g = &file.gas;
        let rho0 = finite_positive("gas.density", g.density)?;
        let mu = finite_positive("gas.viscosity", g.viscosity)?;
        let c_real = match g.sound_speed {
            Some(c) => finite_positive("gas.sound_speed", c)?,
            None => match file.units {
                UnitSystem::Cgs => 34_300.0,
                UnitSystem::Si => 343.0,
            },
        };
        let window = set.positivity_window();
        let nm = &file.numerics;
        let theta0 = nm.temperature.unwrap_or(0.6);
        if !(theta0 > window.0 + 0.02 && theta0 < window.1 - 0.02) {
            return err(
                "numerics.temperature",
                format!(
                    "reduced temperature {theta0} must lie inside ({:.3}, {:.3}), 0.02 away from the edges of the window where every {:?} weight is positive",
                    window.0, window.1, file.domain.lattice
                ),
            );
        }
        let (c_eff, mach_scaled, reference_mach) = match &nm.mach_scaling {
            Some(ms) => {
                let u = reference_velocity(&ms.reference_velocity, &file.boundaries, rho0)?;
                let ma = ms.mach;
                if !(ma > 0.0 && ma <= 0.5) {
                    return err("numerics.mach_scaling.mach", format!("must be in (0, 0.5], got {ma}"));
                }
                (u / ma, true, ma)
            }
            None => (c_real, false, 0.0),
        };
        let units = Units::new(dx, rho0, c_eff, theta0, gamma);
        let nu = units.kinematic_viscosity_to_lattice(mu / rho0);
        Ok(GasUnits { units, rho0, c_real, gamma, theta0, mach_scaled, reference_mach, nu })
    }
}

/// The six faces' conditions in lattice units (periodic faces in pairs; isothermal faces and
/// inlets inside the positivity window), each set speed noted in `fastest`.
pub(super) fn face_conditions(file: &SceneFile, set: &VelocitySet, gas: &GasUnits, fastest: &mut Fastest) -> Result<Boundaries, SceneError> {
    let (dim, units, theta0) = (set.dim, &gas.units, gas.theta0);
    let faces = file.boundaries.named();
    let mut conds: Vec<FaceCondition> = Vec::new();
    for (k, (name, spec)) in faces.iter().enumerate() {
        let field = format!("boundaries.{name}");
        let axis = k / 2;
        let c = match (spec, axis < dim) {
            (None, true) => return err(field, "missing: a 3D lattice needs conditions on the z faces"),
            (Some(_), false) => return err(field, "a 2D lattice has no z faces"),
            (None, false) => FaceCondition::Periodic,
            (Some(s), true) => match s {
                FaceSpec::Periodic => FaceCondition::Periodic,
                FaceSpec::Wall { velocity, temperature_ratio } => {
                    let v = vector(&format!("{field}.velocity"), velocity, dim, true)?;
                    if v[axis] != 0.0 {
                        return err(
                            format!("{field}.velocity"),
                            format!("a wall moves in its own plane: component {axis} (normal to it) must be 0, got {}", v[axis]),
                        );
                    }
                    fastest.note(v.iter().map(|x| x.abs()).fold(0.0, f64::max), format!("{field}.velocity"));
                    let t = match temperature_ratio {
                        Some(r) => Some(theta0 * finite_positive(&format!("{field}.temperature_ratio"), *r)?),
                        None => None,
                    };
                    FaceCondition::Wall { velocity: v.map(|x| units.velocity_to_lattice(x)), temperature: t }
                }
                FaceSpec::PressureInlet { pressure, temperature_ratio } | FaceSpec::PressureOutlet { pressure, temperature_ratio } => {
                    if !pressure.is_finite() {
                        return err(format!("{field}.pressure"), "must be finite");
                    }
                    let th = theta0 * finite_positive(&format!("{field}.temperature_ratio"), *temperature_ratio)?;
                    let p = units.gauge_pressure_to_lattice(*pressure);
                    if p <= 0.0 {
                        return err(format!("{field}.pressure"), format!("gauge pressure {pressure} gives a non-positive absolute pressure"));
                    }
                    fastest.note((2.0 * pressure.abs() / gas.rho0).sqrt(), format!("{field}.pressure"));
                    FaceCondition::PressureInlet { rho: p / th, theta: th }
                }
                FaceSpec::VelocityInlet { velocity, temperature_ratio, profile } => {
                    let v = vector(&format!("{field}.velocity"), velocity, dim, false)?;
                    fastest.note(v.iter().map(|x| x.abs()).fold(0.0, f64::max), format!("{field}.velocity"));
                    let th = theta0 * finite_positive(&format!("{field}.temperature_ratio"), *temperature_ratio)?;
                    FaceCondition::VelocityInlet { velocity: v.map(|x| units.velocity_to_lattice(x)), theta: th, profile: *profile }
                }
                FaceSpec::Outlet => FaceCondition::Outlet,
                FaceSpec::Slip => FaceCondition::Slip,
            },
        };
        conds.push(c);
    }
    for a in 0..dim {
        let (lo, hi) = (&conds[2 * a], &conds[2 * a + 1]);
        if matches!(lo, FaceCondition::Periodic) != matches!(hi, FaceCondition::Periodic) {
            return err(format!("boundaries.{}", ["x_max", "y_max", "z_max"][a]), "periodic faces must come in pairs on the same axis");
        }
    }
    for (k, c) in conds.iter().enumerate() {
        if let FaceCondition::Wall { temperature: Some(t), .. }
        | FaceCondition::PressureInlet { theta: t, .. }
        | FaceCondition::VelocityInlet { theta: t, .. } = c
        {
            wall_theta_in_window(set, *t, format!("boundaries.{}.temperature_ratio", faces[k].0))?;
        }
    }
    Ok(Boundaries { faces: conds.try_into().expect("six faces") })
}

/// A point of the scene (`field`) inside the domain, in lattice units (z = 0 in 2D).
pub(super) fn lattice_point(field: &str, p: &[f64], d: &Domain, dim: usize, units: &Units) -> Result<[f64; 3], SceneError> {
    let v = vector(field, p, dim, false)?;
    for a in 0..dim {
        if v[a] < 0.0 || v[a] > d.size[a] {
            return err(field, format!("coordinate {} lies outside the domain [0, {}]", v[a], d.size[a]));
        }
    }
    Ok(std::array::from_fn(|a| if a < dim { units.position_to_lattice(v[a]) } else { 0.0 }))
}

/// The scene's rigid obstacles in lattice units, each inside the domain.
pub(super) fn rigid_obstacles(file: &SceneFile, dim: usize, units: &Units) -> Result<Vec<Obstacle>, SceneError> {
    let d = &file.domain;
    let mut obstacles = Vec::new();
    for (k, o) in file.obstacles.iter().enumerate() {
        let f = format!("obstacles[{k}]");
        let shape = match o {
            ObstacleSpec::Cylinder { center, radius } => {
                let c = lattice_point(&format!("{f}.center"), center, d, dim, units)?;
                let r = finite_positive(&format!("{f}.radius"), *radius)?;
                for a in 0..2 {
                    if center[a] - r < 0.0 || center[a] + r > d.size[a] {
                        return err(format!("{f}.radius"), format!("the cylinder (centre {center:?}, radius {r}) does not fit inside the domain"));
                    }
                }
                Shape::Cylinder { center: c, radius: units.length_to_lattice(r) }
            }
            ObstacleSpec::Sphere { center, radius } => {
                if dim != 3 {
                    return err(&f, "a sphere needs a 3D lattice; use a cylinder in 2D");
                }
                let c = lattice_point(&format!("{f}.center"), center, d, dim, units)?;
                let r = finite_positive(&format!("{f}.radius"), *radius)?;
                Shape::Sphere { center: c, radius: units.length_to_lattice(r) }
            }
            ObstacleSpec::Box { min, max } => {
                let lo = lattice_point(&format!("{f}.min"), min, d, dim, units)?;
                let hi = lattice_point(&format!("{f}.max"), max, d, dim, units)?;
                if (0..dim).any(|a| hi[a] <= lo[a]) {
                    return err(format!("{f}.max"), "every component must exceed min");
                }
                let (mut lo, mut hi) = (lo, hi);
                if dim == 2 {
                    lo[2] = -1e9;
                    hi[2] = 1e9;
                }
                Shape::Cuboid { min: lo, max: hi }
            }
        };
        obstacles.push(Obstacle { shape, velocity: [0.0; 3], temperature: None });
    }
    Ok(obstacles)
}

/// The time step, τ and A (lattice units): chosen from the viscosity and the Courant safety,
/// or `numerics.time_step`, with `numerics.tau` when it is given.
pub(super) fn step_params(nm: &Numerics, set: &VelocitySet, gas: &GasUnits) -> Result<StepParams, SceneError> {
    let (nu, theta0) = (gas.nu, gas.theta0);
    let safety = nm.courant_safety.unwrap_or(timestep::DEFAULT_COURANT_SAFETY);
    if !(safety > 0.0 && safety <= 1.0) {
        return err("numerics.courant_safety", format!("must be in (0, 1], got {safety}"));
    }
    let fixed_dt = match nm.time_step {
        Some(dt) => Some(gas.units.time_to_lattice(finite_positive("numerics.time_step", dt)?)),
        None => None,
    };
    let mut params = timestep::choose(nu, theta0, set.max_l1_speed(), fixed_dt, safety)
        .map_err(|e| SceneError { field: if fixed_dt.is_some() { "numerics.time_step".into() } else { "gas.viscosity".into() }, reason: e.to_string() })?;
    if let Some(tau) = nm.tau {
        let tau = finite_positive("numerics.tau", tau)?;
        if tau < nu / theta0 {
            return err("numerics.tau", format!("τ = {tau} is below ν/θ₀ = {:.5}; A = τ − ν/θ₀ would be negative", nu / theta0));
        }
        params.tau = tau;
        params.a = tau - nu / theta0;
        timestep::check(params, set.max_l1_speed()).map_err(|e| SceneError { field: "numerics.tau".into(), reason: e.to_string() })?;
    }
    Ok(params)
}

/// The bytes the fluid solver of `grid` will hold, refused (naming `domain.cells`) above
/// `numerics.max_memory_bytes` or three quarters of the memory available.
pub(super) fn memory_estimate(grid: &Grid, values_per_node: usize, nm: &Numerics) -> Result<f64, SceneError> {
    let nv = values_per_node as f64;
    // f, the first stage's output, the second stage's output and the advected field: four
    // population arrays (FluidSolver), the macro fields and the node kinds
    // (f32 storage: the four arrays in f32 for the steps, and the f64 solver the outputs read)
    let pop_bytes = match nm.storage.unwrap_or_default() {
        PopulationStorage::F64 => 8.0 * 4.0 * nv,
        PopulationStorage::F32 => 4.0 * 4.0 * nv + 8.0 * 4.0 * nv,
    };
    let estimated_bytes = grid.len() as f64 * (pop_bytes + 8.0 * MACRO_FIELDS as f64 + 1.0);
    let limit = nm.max_memory_bytes.unwrap_or(0.75 * available_memory());
    if estimated_bytes > limit {
        return err(
            "domain.cells",
            format!("the grid needs {:.2} GiB of memory, more than the {:.2} GiB allowed", estimated_bytes / 2f64.powi(30), limit / 2f64.powi(30)),
        );
    }
    Ok(estimated_bytes)
}
