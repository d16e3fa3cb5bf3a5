//! `phonation`: the headless command line. `phonation` with no arguments runs the default
//! built-in scene; `run`, `check`, `scenes`, `analyze`, `sweep`, `bench`, `validate`, and for
//! the lattice gas `viscosity` and `isotropy`, are the subcommands (one module each in `cli/`).

mod cli;

use anyhow::bail;
use clap::{Parser, Subcommand};
use phonation::run::{Backend, LevelSets};
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "phonation", version, about = "Vocal-fold FSI simulator: headless runs, benchmarks and validation")]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
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
        /// GPU backend, method-2 scenes: where each step's level-set questions (each node's
        /// side, each ghost's wall point; f64) are asked — on the device (where it has f64) or
        /// on the host's threads, for GPUs whose f64 is slow. Both give the same layouts (the answers
        /// agree to round-off).
        #[arg(long, value_enum, default_value = "device")]
        level_sets: LevelSets,
        /// Write OUT/checkpoint.bin every this many steps (atomically; the latest replaces the
        /// previous one).
        #[arg(long, value_name = "STEPS")]
        checkpoint_every: Option<u64>,
        /// Continue a run from its checkpoint, bit for bit, into the checkpoint's directory
        /// (unless --out says otherwise). The scene is the one stored in the checkpoint; a scene
        /// given as well must be the same. --steps is then the step to run to.
        #[arg(long, value_name = "CHECKPOINT")]
        resume: Option<PathBuf>,
        /// Stop after this step as if the run were killed there (outputs follow the whole
        /// run's schedule; continue from a checkpoint written before it).
        #[arg(long, value_name = "STEP")]
        stop_at: Option<u64>,
    },
    /// Validate a scene file and print what it resolves to, without running it.
    Check { scene: String },
    /// List the built-in scenes.
    Scenes,
    /// Voice measures, plots and sound (voice.json, SVG, WAV) of a run's glottal_flow.csv.
    Analyze(cli::voice::AnalyzeArgs),
    /// One scene over a list of values of one key: jobs in parallel here, or a Slurm job array
    /// (--emit slurm), merged into one table (--collect), with the phonation threshold.
    Sweep(cli::voice::SweepArgs),
    /// Memory bandwidth, node updates per second and speed-vs-error tables.
    Bench(cli::bench::BenchArgs),
    /// Lattice-gas viscosity from shear-wave decay over fill densities and interference
    /// probabilities: a table (CSV, JSON) and a plot (SVG).
    Viscosity(cli::lattice_gas::ViscosityArgs),
    /// Lattice gas at rest: equilibrium noise and the isotropy of the velocity families over
    /// time, per interference probability: a table (CSV, JSON) and a plot (SVG).
    Isotropy(cli::lattice_gas::IsotropyArgs),
    /// Run the validation cases against their references; exits non-zero if any fails.
    Validate {
        /// Only this case (an exact name), or every case whose name contains this.
        #[arg(long)]
        case: Option<String>,
        /// Also write the outcomes as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// List the cases (those --case selects) with what each checks and roughly what it
        /// costs, without running any.
        #[arg(long)]
        list: bool,
    },
}

fn main() -> anyhow::Result<()> {
    // Mesa's software Vulkan prints errors when XDG_RUNTIME_DIR is unset (seen when `auto`
    // probes for an adapter); point it at the temp directory.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // SAFETY: first statement of main, before any other thread exists.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
    let cli = Cli::parse();
    match cli.command.unwrap_or(Command::Run {
        scene: None,
        out: None,
        steps: None,
        backend: Backend::Auto,
        level_sets: LevelSets::Device,
        checkpoint_every: None,
        resume: None,
        stop_at: None,
    }) {
        Command::Run { scene: name, out, steps, backend, level_sets, checkpoint_every, resume, stop_at } => {
            cli::run::run(cli::run::RunArgs { name, out, steps, backend, level_sets, checkpoint_every, resume, stop_at })?
        }
        Command::Check { scene: name } => cli::run::check(name)?,
        Command::Scenes => cli::run::scenes(),
        Command::Analyze(a) => cli::voice::analyze(a)?,
        Command::Sweep(a) => cli::voice::sweep(a)?,
        Command::Viscosity(a) => cli::lattice_gas::viscosity(a)?,
        Command::Isotropy(a) => cli::lattice_gas::isotropy(a)?,
        Command::Bench(a) => cli::bench::bench(a)?,
        Command::Validate { case, list: true, .. } => {
            print!("{}", phonation::validation::suite::listing(&phonation::validation::suite::select(case.as_deref())?));
        }
        Command::Validate { case, json, list: false } => {
            let outcomes = phonation::validation::suite::run(case.as_deref())?;
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
