//! The soak (`phonation validate --case soak`): a small closed 2D coupled case run for a long
//! time — an elastic disc, clamped at its core and set vibrating, in air inside four walls, weak
//! coupling — watching what must stay bounded: the air's mass (a closed box: only the nodes the
//! moving disc covers and uncovers change it), its total energy, the momentum of air and disc,
//! the disc's displacement, and the largest change of each in one step.

use crate::coupling::CoupledSolver;
use crate::scene::coupled::CoupledScene;

/// The soak's scene (SI): 64 × 48 cells of 1 cm, D2Q21 air at Mach 0.1 (scaled), a disc of
/// radius 8 cells, its core clamped, its free part started at 5 cm/s.
pub const SCENE: &str = r#"
name = "soak"
description = "Closed box, vibrating clamped elastic disc, weak coupling"
units = "si"

[domain]
lattice = "d2q21"
size = [0.64, 0.48]
cells = [64, 48]

[gas]
model = "monatomic"
density = 1.0
viscosity = 1.0e-3
sound_speed = 343.0

[numerics]
temperature = 0.6
mach_scaling = { reference_velocity = 0.3, mach = 0.1 }

[boundaries]
x_min = { type = "wall" }
x_max = { type = "wall" }
y_min = { type = "wall" }
y_max = { type = "wall" }

[run]
duration = 1.0

[output]
probe_every = 100
snapshots = 0

[solid]
dimension = 2
spacing = 0.005
materials = [{ kind = "isotropic", young = 2.0, poisson = 0.3, density = 1.0, viscosity = 0.01 }]
bodies = [{ center = [0.32, 0.24], radius = 0.08, velocity = [0.2, 0.0] }]
clamps = [{ min = [0.295, 0.215], max = [0.345, 0.265] }]

[coupling]
method = "weak"
traction = "pressure_and_shear"
"#;

/// What the soak measured.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SoakReport {
    pub steps: u64,
    pub wall_s: f64,
    pub simulated_s: f64,
    /// |M(t) − M(0)| / M(0), largest over the run; and the largest change in one step.
    pub mass_drift: f64,
    pub mass_step: f64,
    /// The air's total energy (lattice units, internal energy included): largest relative
    /// departure from the start, and largest change in one step.
    pub energy_drift: f64,
    pub energy_step: f64,
    /// |air + disc momentum| over the run, relative to the largest |disc momentum| (the walls
    /// exchange momentum with the air, so this is bounded, not conserved).
    pub momentum_max: f64,
    /// The disc's largest displacement (m) and its largest change in one step (m).
    pub max_displacement: f64,
    pub displacement_step: f64,
    pub uncovered: usize,
    pub covered: usize,
    /// None when it ran to the end.
    pub instability: Option<String>,
}

fn max_displacement(c: &CoupledSolver) -> f64 {
    let p = &c.solid.particles;
    (0..p.len()).map(|i| (p.position[i] - p.reference[i]).length()).fold(0.0, f64::max)
}

/// Runs the soak for `steps` coupled steps.
pub fn soak(steps: u64) -> anyhow::Result<SoakReport> {
    let sc = CoupledScene::parse(SCENE)?;
    let mut c = sc.build()?;
    let t0 = std::time::Instant::now();
    let first = c.fluid.totals();
    let (m0, e0) = (first.mass, first.energy);
    let (mut prev_m, mut prev_e, mut prev_d) = (m0, e0, 0.0);
    let mut r = SoakReport::default();
    let mut disc_p: f64 = 1e-300;
    for _ in 0..steps {
        if let Err(e) = c.step() {
            r.instability = Some(e.to_string());
            break;
        }
        let t = c.fluid.totals();
        let d = max_displacement(&c);
        r.mass_drift = r.mass_drift.max((t.mass - m0).abs() / m0);
        r.mass_step = r.mass_step.max((t.mass - prev_m).abs() / m0);
        r.energy_drift = r.energy_drift.max((t.energy - e0).abs() / e0.abs());
        r.energy_step = r.energy_step.max((t.energy - prev_e).abs() / e0.abs());
        r.max_displacement = r.max_displacement.max(d);
        r.displacement_step = r.displacement_step.max((d - prev_d).abs());
        let (air, disc) = (c.fluid_momentum(&t), c.solid.particles.linear_momentum());
        disc_p = disc_p.max(disc.length());
        r.momentum_max = r.momentum_max.max((air + disc + c.added_mass_momentum()).length());
        (prev_m, prev_e, prev_d) = (t.mass, t.energy, d);
    }
    r.momentum_max /= disc_p;
    r.steps = c.step_count;
    r.simulated_s = c.time;
    r.wall_s = t0.elapsed().as_secs_f64();
    r.uncovered = c.geometry.uncovered;
    r.covered = c.geometry.covered;
    Ok(r)
}

/// Steps of `phonation validate --case soak` (64 s simulated, ≈ 10 min on 2 cores).
pub const SOAK_STEPS: u64 = 100_000;

/// The bounds of the soak, with their reasons; (figure, measured, bound text, pass).
pub fn rows(r: &SoakReport, fluid_nodes: f64) -> Vec<(String, f64, String, bool)> {
    vec![
        // a closed box: the air's mass changes only where the disc covers or uncovers nodes
        // (a node's mass ≈ M/N each); a few nodes per step at most (the surface moves < 1 cell)
        ("largest mass change in one step (nodes' worth)".into(), r.mass_step * fluid_nodes, "≤ 4".into(), r.mass_step * fluid_nodes <= 4.0),
        // covered and uncovered nodes balance: the drift stays within 1 % (≈ 30 nodes' worth)
        ("mass drift |M − M₀|/M₀".into(), r.mass_drift, "≤ 1e-2".into(), r.mass_drift <= 1e-2),
        ("energy drift |E − E₀|/E₀ (internal included)".into(), r.energy_drift, "≤ 1e-2".into(), r.energy_drift <= 1e-2),
        // walls exchange momentum with the air: bounded by a few times the disc's own
        ("max |P_air + P_disc| / max |P_disc|".into(), r.momentum_max, "≤ 3".into(), r.momentum_max <= 3.0),
        // the disc is viscously damped: it never exceeds its first swing (≈ 0.9 cm)
        ("largest displacement (cm)".into(), 100.0 * r.max_displacement, "≤ 2".into(), r.max_displacement <= 0.02),
        ("largest displacement change in one step (cells)".into(), 100.0 * r.displacement_step, "≤ 0.1".into(), r.displacement_step <= 0.001),
        ("steps run without instability".into(), r.steps as f64, "all".into(), r.instability.is_none()),
    ]
}

/// Fluid nodes of the soak's lattice (64 × 48 less the disc).
pub fn fluid_nodes() -> f64 {
    64.0 * 48.0 - std::f64::consts::PI * 8.0 * 8.0
}

#[cfg(test)]
mod tests {
    /// A short soak (1000 steps, 0.64 s, the disc's first swings) within the long one's bounds,
    /// having covered and uncovered nodes.
    #[test]
    fn a_short_soak_stays_within_the_bounds() {
        let r = super::soak(1000).unwrap();
        println!("{}", serde_json::to_string_pretty(&r).unwrap());
        for (figure, m, bound, pass) in super::rows(&r, super::fluid_nodes()) {
            assert!(pass, "{figure} = {m:e} (bound {bound})");
        }
        assert!(r.covered > 0 && r.uncovered > 0, "the disc moves across nodes: {r:?}");
    }
}
