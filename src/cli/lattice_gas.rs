//! The lattice-gas measurement commands: `viscosity` and `isotropy`.

use anyhow::bail;
use std::path::PathBuf;

/// Lattice-gas viscosity from shear-wave decay over fill densities and interference probabilities.
#[derive(clap::Args)]
pub struct ViscosityArgs {
    /// Fill densities (particles per link).
    #[arg(long, value_delimiter = ',', default_value = "0.1,0.2,0.3,0.4")]
    pub densities: Vec<f64>,
    /// Interference probabilities p.
    #[arg(long, value_delimiter = ',', default_value = "0,0.1,0.2,0.3,0.4,0.5,0.6,0.8,1")]
    pub interference: Vec<f64>,
    /// Diagonals the interference exchanges along: c_k's own plane (own_plane) or every
    /// family of squares with a diagonal perpendicular to c_k (all_perpendicular).
    #[arg(long, value_enum, default_value = "own_plane")]
    pub diagonals: phonation::lattice_gas::lattice::Diagonals,
    /// Box of nx × n × n cells (nx a multiple of 4); the shear wave spans X.
    #[arg(long, default_value_t = 32)]
    pub nx: usize,
    #[arg(long, default_value_t = 8)]
    pub n: usize,
    /// Steps; the decay is fitted from step 20 on.
    #[arg(long, default_value_t = 600)]
    pub steps: u32,
    /// Amplitude U of the initial u_Y (ℓ/step), in (0, 0.4].
    #[arg(long, default_value_t = 0.1)]
    pub amplitude: f64,
    /// Independent seeds per point (mean and standard error).
    #[arg(long, default_value_t = 4)]
    pub seeds: usize,
    /// Output directory.
    #[arg(long, default_value = "out/viscosity")]
    pub out: PathBuf,
}

/// Lattice gas at rest: equilibrium noise and the isotropy of the velocity families over time.
#[derive(clap::Args)]
pub struct IsotropyArgs {
    /// Fill density (particles per link).
    #[arg(long, default_value_t = 0.2)]
    pub density: f64,
    /// Interference probabilities p.
    #[arg(long, value_delimiter = ',', default_value = "0,0.01,0.02,0.05,0.1,0.2,0.4,1")]
    pub interference: Vec<f64>,
    /// Diagonals the interference exchanges along: c_k's own plane (own_plane) or every
    /// family of squares with a diagonal perpendicular to c_k (all_perpendicular).
    #[arg(long, value_enum, default_value = "own_plane")]
    pub diagonals: phonation::lattice_gas::lattice::Diagonals,
    /// Box of n³ cells (n a multiple of 4).
    #[arg(long, default_value_t = 8)]
    pub n: usize,
    #[arg(long, default_value_t = 8000)]
    pub steps: u32,
    /// Sample every this many steps.
    #[arg(long, default_value_t = 50)]
    pub every: u32,
    /// Independent seeds per p.
    #[arg(long, default_value_t = 4)]
    pub seeds: usize,
    /// Output directory.
    #[arg(long, default_value = "out/isotropy")]
    pub out: PathBuf,
}

pub fn viscosity(args: ViscosityArgs) -> anyhow::Result<()> {
    let ViscosityArgs { densities, interference, diagonals, nx, n, steps, amplitude, seeds, out } = args;
    use phonation::lattice_gas::viscosity::{ShearWaveSetup, viscosity_table, write_table};
    use phonation::scene::lattice_gas::{density_problem, interference_problem};
    if nx < 8 || nx % 4 != 0 || n == 0 {
        bail!("--nx must be a multiple of 4 and at least 8, --n at least 1 (got {nx}, {n})");
    }
    if steps < 40 {
        bail!("--steps: {steps} is too few: the decay is fitted from step 20 on, so at least 40");
    }
    if let Some(reason) = densities.iter().find_map(|&d| density_problem(d)) {
        bail!("--densities: {reason}");
    }
    if let Some(reason) = interference.iter().find_map(|&p| interference_problem(p)) {
        bail!("--interference: {reason}");
    }
    if seeds == 0 {
        bail!("--seeds must be at least 1");
    }
    if !(amplitude > 0.0 && amplitude <= 0.4) {
        bail!("--amplitude: {amplitude} must lie in (0, 0.4] ℓ/step (the wave stays near linear)");
    }
    if let Some(d) = densities.iter().find(|&&d| d * (1.0 + 2.0 * amplitude) > 1.0) {
        bail!("--amplitude: {amplitude} at density {d} asks for link occupations d (1 + 2U) = {:.3} > 1", d * (1.0 + 2.0 * amplitude));
    }
    let setup = ShearWaveSetup { nx, n, steps, amplitude, diagonals };
    let rows = viscosity_table(&densities, &interference, &setup, seeds);
    let files = write_table(&out, &rows)?;
    println!("{:>8} {:>6} {:>12} {:>10} {:>11} {:>15}", "density", "p", "ν (ℓ²/step)", "± s.e.", "mean field", "smallest share");
    for r in &rows {
        let mean_field = phonation::lattice_gas::viscosity::mean_field_line(&rows, r.density, r.interference).map_or("-".into(), |v| format!("{v:.4}"));
        println!("{:>8.3} {:>6.3} {:>12.4} {:>10.4} {:>11} {:>15.3}", r.density, r.interference, r.viscosity, r.standard_error, mean_field, r.smallest_share);
    }
    for d in &densities {
        match phonation::lattice_gas::viscosity::zero_crossing(&rows, *d) {
            Some(p) => println!("fill {d}: ν turns negative at p ≈ {p:.3}"),
            None => println!("fill {d}: ν stays positive over the p measured"),
        }
    }
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

pub fn isotropy(args: IsotropyArgs) -> anyhow::Result<()> {
    let IsotropyArgs { density, interference, diagonals, n, steps, every, seeds, out } = args;
    use phonation::lattice_gas::isotropy::{isotropy_table, write_isotropy};
    use phonation::scene::lattice_gas::{density_problem, interference_problem};
    if n < 4 || n % 4 != 0 {
        bail!("--n must be a multiple of 4 and at least 4 (got {n})");
    }
    if let Some(reason) = density_problem(density) {
        bail!("--density: {reason}");
    }
    if let Some(reason) = interference.iter().find_map(|&p| interference_problem(p)) {
        bail!("--interference: {reason}");
    }
    if seeds == 0 || every == 0 || steps < every {
        bail!("--seeds and --every must be at least 1 and --steps at least --every (got {seeds}, {every}, {steps})");
    }
    let runs = isotropy_table(density, &interference, diagonals, n, steps, every, seeds);
    let files = write_isotropy(&out, &runs)?;
    println!("{:>6} {:>6} {:>12} {:>14} {:>16}", "p", "seed", "onset step", "growth /step", "smallest share");
    for r in &runs {
        let last = r.history.last().expect("step 0 is always sampled");
        println!(
            "{:>6.3} {:>6} {:>12} {:>14} {:>16.3}",
            r.interference,
            r.seed,
            r.onset_step.map_or("-".into(), |s| s.to_string()),
            r.growth_rate.map_or("-".into(), |g| format!("{g:.2e}")),
            last.smallest_share()
        );
    }
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
