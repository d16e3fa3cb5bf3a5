//! `phonation`: the headless command line. `phonation` with no arguments runs the default
//! built-in scene; `run`, `bench`, `validate`, `scenes`, `check`, and for the lattice gas
//! `viscosity` and `isotropy`, are the subcommands.

use anyhow::{Context, bail};
use clap::{Parser, Subcommand};
use phonation::run::{Backend, RunOptions, RunStatus, run_scene};
use phonation::scene;
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "phonation", version, about = "Vocal-fold FSI simulator: headless runs, benchmarks and validation")]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum BenchBackend {
    Cpu,
    Gpu,
    Both,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene file (or a built-in scene by name) and write its outputs.
    Run {
        /// Scene file path or built-in name (see `phonation scenes`).
        scene: Option<String>,
        /// Output directory (default: out/<scene name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Run this many steps instead of the scene's duration.
        #[arg(long)]
        steps: Option<u64>,
        /// Solver backend: cpu, gpu, or auto (a hardware GPU when present, else the CPU).
        #[arg(long, value_enum, default_value = "auto")]
        backend: Backend,
    },
    /// Validate a scene file and print what it resolves to, without running it.
    Check { scene: String },
    /// List the built-in scenes.
    Scenes,
    /// Memory bandwidth, node updates per second and speed-vs-error tables.
    Bench {
        /// Small grids, for a smoke run.
        #[arg(long)]
        quick: bool,
        /// Which backends to measure.
        #[arg(long, value_enum, default_value = "cpu")]
        backend: BenchBackend,
        /// Also write the report as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Only one suite: fdlb, solid or lattice_gas.
        #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(phonation::bench::SUITES))]
        only: Option<String>,
    },
    /// Lattice-gas viscosity from shear-wave decay over fill densities and interference
    /// probabilities: a table (CSV, JSON) and a plot (SVG).
    Viscosity {
        /// Fill densities (particles per link).
        #[arg(long, value_delimiter = ',', default_value = "0.1,0.2,0.3,0.4")]
        densities: Vec<f64>,
        /// Interference probabilities p.
        #[arg(long, value_delimiter = ',', default_value = "0,0.1,0.2,0.3,0.4,0.5,0.6,0.8,1")]
        interference: Vec<f64>,
        /// Diagonals the interference exchanges along: c_k's own plane (own_plane) or every
        /// family of squares with a diagonal perpendicular to c_k (all_perpendicular).
        #[arg(long, value_enum, default_value = "own_plane")]
        diagonals: phonation::lattice_gas::lattice::Diagonals,
        /// Box of nx × n × n cells (nx a multiple of 4); the shear wave spans X.
        #[arg(long, default_value_t = 32)]
        nx: usize,
        #[arg(long, default_value_t = 8)]
        n: usize,
        /// Steps; the decay is fitted from step 20 on.
        #[arg(long, default_value_t = 600)]
        steps: u32,
        /// Amplitude U of the initial u_Y (ℓ/step), in (0, 0.4].
        #[arg(long, default_value_t = 0.1)]
        amplitude: f64,
        /// Independent seeds per point (mean and standard error).
        #[arg(long, default_value_t = 4)]
        seeds: usize,
        /// Output directory.
        #[arg(long, default_value = "out/viscosity")]
        out: PathBuf,
    },
    /// Lattice gas at rest: equilibrium noise and the isotropy of the velocity families over
    /// time, per interference probability: a table (CSV, JSON) and a plot (SVG).
    Isotropy {
        /// Fill density (particles per link).
        #[arg(long, default_value_t = 0.2)]
        density: f64,
        /// Interference probabilities p.
        #[arg(long, value_delimiter = ',', default_value = "0,0.01,0.02,0.05,0.1,0.2,0.4,1")]
        interference: Vec<f64>,
        /// Diagonals the interference exchanges along: c_k's own plane (own_plane) or every
        /// family of squares with a diagonal perpendicular to c_k (all_perpendicular).
        #[arg(long, value_enum, default_value = "own_plane")]
        diagonals: phonation::lattice_gas::lattice::Diagonals,
        /// Box of n³ cells (n a multiple of 4).
        #[arg(long, default_value_t = 8)]
        n: usize,
        #[arg(long, default_value_t = 8000)]
        steps: u32,
        /// Sample every this many steps.
        #[arg(long, default_value_t = 50)]
        every: u32,
        /// Independent seeds per p.
        #[arg(long, default_value_t = 4)]
        seeds: usize,
        /// Output directory.
        #[arg(long, default_value = "out/isotropy")]
        out: PathBuf,
    },
    /// Run the validation cases against their references; exits non-zero if any fails.
    Validate {
        /// Only cases whose name contains this.
        #[arg(long)]
        case: Option<String>,
        /// Also write the outcomes as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
}

/// One table row of a solid speed measurement (`extra` appended, e.g. a ratio to the CPU).
fn solid_row(v: &phonation::solid::bench::SolidSpeed, extra: &str) {
    println!(
        "{:9} {:>10} {:>10} {:>14.3e} {:>9.0} {:>7.1}% {:>9.1} {:>8.1}{extra}",
        format!("{:?}", v.integrator),
        v.particles,
        v.bonds,
        v.particle_updates_per_s,
        v.bytes_per_update,
        100.0 * v.bandwidth_fraction,
        v.cg_iterations,
        v.time_step_over_explicit_limit
    );
}

fn lattice_gas_header() {
    println!("FCHC lattice gas (fill 0.2, p = 0.1; seed's run = 512×256×128 cells × 39,000 steps):");
    println!("{:>16} {:>14} {:>9} {:>8} {:>14}", "cells", "site upd./s", "B/site", "of b/w", "seed's run");
}

/// One table row of a lattice-gas speed measurement (`extra` appended, e.g. a ratio to the CPU).
fn lattice_gas_row(v: &phonation::lattice_gas::bench::LatticeGasSpeed, extra: &str) {
    println!(
        "{:>16} {:>14.3e} {:>9.0} {:>7.1}% {:>12.0} s{extra}",
        format!("{:?}", v.cells),
        v.site_updates_per_s,
        v.bytes_per_site_update,
        100.0 * v.bandwidth_fraction,
        v.projected_seed_run_s
    );
    if !v.stage_shares.is_empty() {
        let st: Vec<String> = v.stage_shares.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
        println!("{:>16} stages: {}", "", st.join(", "));
    }
}

fn scene_text(arg: &str) -> anyhow::Result<String> {
    if let Some(t) = scene::builtin(arg) {
        return Ok(t.to_string());
    }
    std::fs::read_to_string(arg).with_context(|| {
        format!("reading scene file {arg} (not a built-in scene either: {})", scene::BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "))
    })
}

fn main() -> anyhow::Result<()> {
    // Mesa's software Vulkan prints errors when XDG_RUNTIME_DIR is unset (seen when `auto`
    // probes for an adapter); point it at the temp directory.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // SAFETY: first statement of main, before any other thread exists.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
    let cli = Cli::parse();
    match cli.command.unwrap_or(Command::Run { scene: None, out: None, steps: None, backend: Backend::Auto }) {
        Command::Run { scene: name, out, steps, backend } => {
            let name = name.unwrap_or_else(|| scene::DEFAULT_SCENE.to_string());
            let text = scene_text(&name)?;
            if phonation::scene::coupled::is_coupled_scene(&text) {
                let sc = phonation::scene::coupled::CoupledScene::parse(&text)?;
                let dir = out.unwrap_or_else(|| PathBuf::from("out").join(&sc.fluid.file.name));
                if backend == Backend::Gpu {
                    bail!("--backend gpu: the coupled solver runs on the CPU only for now");
                }
                eprintln!(
                    "coupled scene {}: {:?} nodes, about {} particles, {:?} coupling",
                    sc.fluid.file.name, sc.fluid.grid.n, sc.solid.estimated_particles, sc.coupling.method
                );
                let r = phonation::run::coupled::run_coupled_scene(&sc, &dir, steps, true)?;
                eprintln!("backend: {}", r.backend);
                eprintln!(
                    "{} particles, {} solid sub-steps per step; {} steps, {:.4e} s simulated in {:.1} s wall ({:.1} coupled steps/s); final force {:?}; max displacement {:.3e}; fluid mass drift {:.2e}",
                    r.particles, r.substeps, r.steps, r.simulated_s, r.wall_s, r.coupled_steps_per_s, r.final_forces, r.max_displacement, r.fluid_mass_drift
                );
                eprintln!("stage shares: {}", r.stage_shares.iter().map(|(n, s)| format!("{n} {:.0}%", 100.0 * s)).collect::<Vec<_>>().join(", "));
                eprintln!("outputs in {}", dir.display());
                if let Some(d) = r.instability {
                    bail!("run stopped: {d} (outputs written so far are kept in {})", dir.display());
                }
                return Ok(());
            }
            if phonation::scene::lattice_gas::is_lattice_gas_scene(&text) {
                let sc = phonation::scene::lattice_gas::LatticeGasScene::parse(&text)?;
                let dir = out.unwrap_or_else(|| PathBuf::from("out").join(&sc.file.name));
                let lg = &sc.file.lattice_gas;
                eprintln!("lattice-gas scene {}: {:?} cells, fill {}, p = {}", sc.file.name, lg.cells, lg.density, lg.interference);
                let r = phonation::scene::lattice_gas::run_lattice_gas_scene(&sc, &dir, steps, backend)?;
                eprintln!("backend: {}", r.backend);
                eprintln!(
                    "{} steps in {:.1} s ({:.3e} site updates/s); particles {} → {}",
                    r.steps, r.wall_s, r.site_updates_per_s, r.particles_start, r.particles_end
                );
                match (r.wake_peak, r.strouhal) {
                    (Some(p), Some(st)) => eprintln!("wake: periodic shedding, f = {:.4e} /step ({:.1} periods), St = {st:.3}", p.frequency, p.periods),
                    (Some(p), None) => eprintln!("wake: no periodic shedding (peak prominence {:.1}, {:.1} periods)", p.prominence, p.periods),
                    _ => {}
                }
                eprintln!("outputs in {}", dir.display());
                return Ok(());
            }
            if phonation::scene::solid::is_solid_scene(&text) {
                let sc = phonation::scene::solid::SolidScene::parse(&text)?;
                let dir = out.unwrap_or_else(|| PathBuf::from("out").join(&sc.file.name));
                eprintln!("solid scene {}: about {} particles, {:?} integrator", sc.file.name, sc.estimated_particles, sc.file.solid.integrator);
                let r = phonation::scene::solid::run_solid_scene(&sc, &dir, steps, backend)?;
                eprintln!("backend: {}", r.backend);
                eprintln!(
                    "{} particles, {} bonds, Δt = {:.3e} (explicit limit {:.3e}), {} steps, {:.4e} s simulated in {:.1} s wall ({:.3e} particle updates/s), energy drift {:.2e}",
                    r.particles, r.bonds, r.dt, r.explicit_limit, r.steps, r.simulated_time, r.wall_s, r.particle_updates_per_s, r.energy_drift
                );
                eprintln!("outputs in {}", dir.display());
                if let Some(d) = r.instability {
                    bail!("run stopped: {d} (outputs written so far are kept in {})", dir.display());
                }
                return Ok(());
            }
            let sc = scene::load(&text)?;
            let dir = out.unwrap_or_else(|| PathBuf::from("out").join(&sc.file.name));
            let sum = sc.summary();
            eprintln!(
                "scene {}: {:?} {:?} nodes, Δt = {:.4} (τ = {:.4}, A = {:.4}), ν = {:.5} lattice, {} steps, Mach {:.3}{}",
                sum.name,
                sc.file.domain.lattice,
                sum.nodes,
                sum.params.dt,
                sum.params.tau,
                sum.params.a,
                sum.nu_lattice,
                steps.unwrap_or(sum.steps),
                sum.reference_mach,
                if sum.mach_scaled { " (Mach-scaled)" } else { "" }
            );
            let report = run_scene(&sc, &dir, &RunOptions { steps, show_progress: true, backend })?;
            eprintln!("backend: {}", report.backend);
            eprintln!(
                "{} steps, {:.4e} s simulated in {:.1} s wall ({:.3e} node updates/s), mass drift {:.2e}, max Mach {:.3}",
                report.steps_done, report.simulated_time_s, report.wall_time_s, report.node_updates_per_s, report.mass_drift, report.max_mach
            );
            eprintln!("outputs in {}", dir.display());
            if let RunStatus::Unstable { diagnosis, .. } = &report.status {
                bail!("run stopped: {diagnosis} (outputs written so far are kept in {})", dir.display());
            }
        }
        Command::Check { scene: name } => {
            let text = scene_text(&name)?;
            if phonation::scene::coupled::is_coupled_scene(&text) {
                let sc = phonation::scene::coupled::CoupledScene::parse(&text)?;
                let c = sc.build()?;
                println!(
                    "{}",
                    serde_json::json!({"name": sc.fluid.file.name, "fluid": sc.fluid.summary(), "particles": c.solid.particles.len(), "surface_points": c.bodies.iter().map(|b| b.surface.particles.len()).collect::<Vec<_>>(), "solid_substeps": c.substeps, "dt": c.dt(), "method": sc.coupling.method})
                );
                return Ok(());
            }
            if phonation::scene::lattice_gas::is_lattice_gas_scene(&text) {
                let sc = phonation::scene::lattice_gas::LatticeGasScene::parse(&text)?;
                let lg = &sc.file.lattice_gas;
                let cells: usize = lg.cells.iter().product();
                println!(
                    "{}",
                    serde_json::json!({"name": sc.file.name, "cells": lg.cells, "sites": 16 * cells, "state_bytes": 48 * cells, "density": lg.density, "interference": lg.interference, "steps": lg.steps, "probe": sc.probe})
                );
                return Ok(());
            }
            if phonation::scene::solid::is_solid_scene(&text) {
                let sc = phonation::scene::solid::SolidScene::parse(&text)?;
                let s = sc.build()?;
                println!(
                    "{}",
                    serde_json::json!({"name": sc.file.name, "particles": s.particles.len(), "bonds": s.disc.bonds.len(), "dt": s.dt, "explicit_limit": s.explicit_limit, "integrator": s.options.integrator})
                );
                return Ok(());
            }
            let sc = scene::load(&text)?;
            println!("{}", serde_json::to_string_pretty(&sc.summary())?);
        }
        Command::Scenes => {
            for (n, t) in scene::BUILTIN {
                let d = scene::parse(t).map(|s| s.description).unwrap_or_default();
                println!("{n:18} {d}");
            }
            for (n, t) in scene::LATTICE_GAS_BUILTIN {
                let d = phonation::scene::lattice_gas::LatticeGasScene::parse(t).map(|s| s.file.description).unwrap_or_default();
                println!("{n:18} [lattice gas] {d}");
            }
            for (n, t) in scene::COUPLED_BUILTIN {
                let d = phonation::scene::coupled::CoupledScene::parse(t).map(|s| s.fluid.file.description).unwrap_or_default();
                println!("{n:18} [coupled] {d}");
            }
            for (n, t) in scene::SOLID_BUILTIN {
                let d = phonation::scene::solid::SolidScene::parse(t).map(|s| s.file.description).unwrap_or_default();
                println!("{n:18} [solid] {d}");
            }
        }
        Command::Viscosity { densities, interference, diagonals, nx, n, steps, amplitude, seeds, out } => {
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
                println!(
                    "{:>8.3} {:>6.3} {:>12.4} {:>10.4} {:>11} {:>15.3}",
                    r.density, r.interference, r.viscosity, r.standard_error, mean_field, r.smallest_share
                );
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
        }
        Command::Isotropy { density, interference, diagonals, n, steps, every, seeds, out } => {
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
        }
        Command::Bench { quick, backend, json, only } => {
            let wants = |suite: &str| only.as_deref().is_none_or(|o| o == suite);
            let mut report = serde_json::Map::new();
            let mut cpu_speeds = Vec::new();
            let mut cpu_gas: Option<f64> = None;
            if backend != BenchBackend::Gpu {
                let r = phonation::bench::run(quick, only.as_deref());
                println!("CPU: {} threads, STREAM-like triad bandwidth {:.2} GB/s", r.threads, r.triad_bandwidth_gb_s);
                if !r.lattices.is_empty() {
                    println!("{:8} {:>16} {:>16} {:>10} {:>10}", "lattice", "nodes", "updates/s", "B/update", "of b/w");
                }
                for l in &r.lattices {
                    println!(
                        "{:8} {:>16} {:>16.3e} {:>10.0} {:>9.1}%",
                        l.lattice,
                        format!("{:?}", l.nodes),
                        l.node_updates_per_s,
                        l.bytes_per_node_update,
                        100.0 * l.bandwidth_fraction
                    );
                    let st: Vec<String> = l.stage_fractions.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
                    println!("         stages: {}", st.join(", "));
                    cpu_speeds.push((l.lattice.clone(), l.node_updates_per_s));
                }
                if !r.speed_vs_error.is_empty() {
                    println!("speed vs error, Taylor–Green D2Q21 (Re = 10):");
                    println!("{:>6} {:>14} {:>16}", "n", "wall s / t.u.", "decay-rate error");
                }
                for t in &r.speed_vs_error {
                    println!("{:>6} {:>14.3e} {:>15.3}%", t.n, t.wall_per_time_unit, 100.0 * t.relative_error);
                }
                if !r.solid.is_empty() {
                    println!("MPS solid (3D, r_e = 2.1 l0):");
                    println!(
                        "{:9} {:>10} {:>10} {:>14} {:>9} {:>8} {:>9} {:>8}",
                        "step", "particles", "bonds", "updates/s", "B/update", "of b/w", "CG it.", "Δt/lim"
                    );
                }
                for v in &r.solid {
                    solid_row(v, "");
                    let st: Vec<String> = v.stage_shares.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
                    println!("          stages: {}", st.join(", "));
                }
                if !r.lattice_gas.is_empty() {
                    lattice_gas_header();
                }
                for v in &r.lattice_gas {
                    lattice_gas_row(v, "");
                    cpu_gas = Some(v.site_updates_per_s);
                }
                if !r.coupled.is_empty() {
                    println!("coupled, weak (method 1), clamped elastic cylinder, Schäfer–Turek 2D-1 (Mach 0.1): speed vs error");
                    println!(
                        "{:>4} {:>8} {:>9} {:>8} {:>12} {:>14} {:>8} {:>10} {:>10}",
                        "D", "nodes", "particles", "substeps", "steps/s", "wall s / sim s", "C_D", "vs finest", "vs 5.5795"
                    );
                }
                for c in &r.coupled {
                    println!(
                        "{:>4} {:>8} {:>9} {:>8} {:>12.1} {:>14.1} {:>8.4} {:>9.2}% {:>9.2}%",
                        c.cells_per_diameter,
                        c.nodes,
                        c.particles,
                        c.solid_substeps,
                        c.coupled_steps_per_s,
                        c.wall_per_simulated_s,
                        c.drag_coefficient,
                        100.0 * c.error_vs_finest,
                        100.0 * c.error_vs_reference
                    );
                    let st: Vec<String> = c.stage_shares.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
                    println!("     stages: {}", st.join(", "));
                }
                report.insert("cpu".into(), serde_json::to_value(&r)?);
            }
            if backend != BenchBackend::Cpu {
                let ctx = phonation::gpu::GpuContext::new()?;
                let bw = phonation::gpu::bench::copy_bandwidth(&ctx, if quick { 64 << 20 } else { 1 << 30 }, 10);
                println!("GPU: {}, copy-kernel bandwidth {:.2} GB/s", ctx.describe(), bw / 1e9);
                let sizes: Vec<(phonation::fluid::VelocitySetKind, [usize; 3])> = if !wants("fdlb") {
                    vec![]
                } else if quick {
                    vec![(phonation::fluid::VelocitySetKind::D2q21, [256, 256, 1]), (phonation::fluid::VelocitySetKind::D3q39, [32, 32, 32])]
                } else {
                    vec![
                        (phonation::fluid::VelocitySetKind::D2q21, [1024, 1024, 1]),
                        (phonation::fluid::VelocitySetKind::D3q39, [128, 128, 128]),
                        (phonation::fluid::VelocitySetKind::D3q39, [64, 64, 64]),
                    ]
                };
                let mut gpu = Vec::new();
                for (set, n) in sizes {
                    let l = phonation::gpu::bench::lattice_speed(&ctx, set, n, if quick { 5 } else { 20 }, bw);
                    match &l.skipped {
                        Some(why) => println!("{:8} {:>16} skipped: {why}", l.lattice, format!("{:?}", l.nodes)),
                        None => {
                            let vs_cpu = cpu_speeds
                                .iter()
                                .find(|(n, _)| *n == l.lattice)
                                .map(|(_, c)| format!("  {:.2}× the CPU backend", l.node_updates_per_s / c))
                                .unwrap_or_default();
                            println!(
                                "{:8} {:>16} {:>16.3e} {:>10.0} {:>9.1}%{vs_cpu}",
                                l.lattice,
                                format!("{:?}", l.nodes),
                                l.node_updates_per_s,
                                l.bytes_per_node_update,
                                100.0 * l.bandwidth_fraction
                            );
                            if !l.stage_fractions.is_empty() {
                                let st: Vec<String> = l.stage_fractions.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
                                println!("         GPU stages (timestamps): {}", st.join(", "));
                            }
                        }
                    }
                    gpu.push(l);
                }
                let cpu_solid: Vec<(String, f64)> = report
                    .get("cpu")
                    .and_then(|c| c.get("solid"))
                    .and_then(|s| s.as_array())
                    .map(|a| {
                        a.iter()
                            .map(|v| {
                                (format!("{}/{}", v["integrator"].as_str().unwrap_or(""), v["particles"]), v["particle_updates_per_s"].as_f64().unwrap_or(0.0))
                            })
                            .collect()
                    })
                    .unwrap_or_default();
                let mut gpu_solid = Vec::new();
                if wants("solid") {
                    println!("GPU MPS solid:");
                }
                for side in if !wants("solid") {
                    vec![]
                } else if quick {
                    vec![20usize]
                } else {
                    vec![46, 100]
                } {
                    for (integ, steps) in [
                        (phonation::solid::Integrator::Explicit, if quick { 10 } else { 50 }),
                        (phonation::solid::Integrator::Implicit, if quick { 2 } else { 5 }),
                    ] {
                        match phonation::gpu::solid::solid_speed(&ctx, side, integ, steps, bw) {
                            Ok(v) => {
                                let key = format!("{:?}/{}", v.integrator, v.particles).to_lowercase();
                                let vs = cpu_solid
                                    .iter()
                                    .find(|(k, _)| *k == key)
                                    .map(|(_, c)| format!("  {:.2}× the CPU", v.particle_updates_per_s / c))
                                    .unwrap_or_default();
                                solid_row(&v, &vs);
                                gpu_solid.push(v);
                            }
                            Err(e) => println!("{:?} {side}³ skipped: {e}", integ),
                        }
                    }
                }
                let mut gpu_gas = Vec::new();
                if wants("lattice_gas") {
                    lattice_gas_header();
                    let sizes: Vec<[usize; 3]> = if quick { vec![[32, 16, 8]] } else { vec![[128, 64, 32], [512, 256, 128]] };
                    for cells in sizes {
                        match phonation::gpu::lattice_gas::lattice_gas_speed(&ctx, cells, if quick { 5 } else { 100 }, bw) {
                            Ok(v) => {
                                let vs = cpu_gas.map(|c| format!("  {:.1}× the CPU", v.site_updates_per_s / c)).unwrap_or_default();
                                lattice_gas_row(&v, &vs);
                                gpu_gas.push(v);
                            }
                            Err(e) => println!("lattice gas {cells:?} skipped: {e}"),
                        }
                    }
                }
                report.insert(
                    "gpu".into(),
                    serde_json::json!({ "adapter": ctx.describe(), "copy_bandwidth_gb_s": bw / 1e9, "lattices": gpu, "solid": gpu_solid, "lattice_gas": gpu_gas }),
                );
            }
            if let Some(p) = json {
                std::fs::write(p, serde_json::to_string_pretty(&report)?)?;
            }
        }
        Command::Validate { case, json } => {
            let outcomes = phonation::validation::suite::run(case.as_deref());
            let mut failed = 0;
            for o in &outcomes {
                println!("{}", o);
                if !o.pass {
                    failed += 1;
                }
            }
            if let Some(p) = json {
                std::fs::write(p, serde_json::to_string_pretty(&outcomes)?)?;
            }
            println!("validate: {} passed, {} failed", outcomes.len() - failed, failed);
            if failed > 0 {
                bail!("{failed} validation case(s) out of tolerance");
            }
        }
    }
    Ok(())
}
