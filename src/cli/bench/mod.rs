//! `phonation bench`: memory bandwidth, updates per second and speed-vs-error tables, on the
//! CPU and the GPU, printed and written as JSON: the CPU's tables in [`cpu`], the device's in
//! [`gpu`].

mod cpu;
mod gpu;

use std::path::PathBuf;

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchBackend {
    Cpu,
    Gpu,
    Both,
}

/// What `phonation bench` measures.
#[derive(clap::Args)]
pub struct BenchArgs {
    /// Small grids, for a smoke run.
    #[arg(long)]
    pub quick: bool,
    /// Which backends to measure.
    #[arg(long, value_enum, default_value = "cpu")]
    pub backend: BenchBackend,
    /// Also write the report as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Only one suite: fdlb, storage (f32 against f64 populations), solid, crossover (the implicit-against-explicit table of the solid suite alone), lattice_gas, coupled, two_mass, glottis, drawing, scaling
    /// (cost per update against size, on the CPU and with --backend gpu the device: only when
    /// asked for, it takes minutes) or geometry (the coupled glottis scenes' fluid_geometry stage
    /// alone, up to the 3D glottis: only when asked for).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(phonation::bench::SUITES))]
    pub only: Option<String>,
}

/// A bandwidth fraction as a percentage, or "in cache" where the benchmark's data fits in the
/// last-level cache (no memory-bandwidth figure then).
fn percent(f: Option<f64>) -> String {
    f.map_or("in cache".into(), |f| format!("{:.1}%", 100.0 * f))
}

/// One table row of a solid speed measurement (`extra` appended, e.g. a ratio to the CPU).
fn solid_row(v: &phonation::solid::bench::SolidSpeed, extra: &str) {
    println!(
        "{:11} {:>9} {:>10} {:>14.3e} {:>9.0} {:>8} {:>8} {:>8} {:>9.1} {:>8.1}{extra}",
        match v.preconditioner {
            Some(phonation::solid::Preconditioner::BlockJacobi) => "impl/bj".to_string(),
            Some(phonation::solid::Preconditioner::Patches) => "impl/ptch".to_string(),
            None if v.dim == 2 => format!("{:?} 2D", v.integrator),
            None => format!("{:?}", v.integrator),
        },
        v.particles,
        v.bonds,
        v.particle_updates_per_s,
        v.bytes_per_update,
        percent(v.bandwidth_fraction),
        v.flop_fraction.map_or("-".into(), |f| format!("{:.1}%", 100.0 * f)),
        v.scalar_flop_fraction.map_or("-".into(), |f| format!("{:.1}%", 100.0 * f)),
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
        "{:>16} {:>14.3e} {:>9.0} {:>8} {:>12.0} s{extra}",
        format!("{:?}", v.cells),
        v.site_updates_per_s,
        v.bytes_per_site_update,
        percent(v.bandwidth_fraction),
        v.projected_seed_run_s
    );
    if !v.stage_shares.is_empty() {
        println!("{:>16} stages: {}", "", stages(&v.stage_shares));
    }
}

/// Runs the suites `args` asks for, prints their tables and writes the report as JSON.
pub fn bench(args: BenchArgs) -> anyhow::Result<()> {
    let BenchArgs { quick, backend, json, only } = args;
    let wants = |suite: &str| only.as_deref().is_none_or(|o| o == suite);
    let mut report = serde_json::Map::new();
    let mut cpu_rates = cpu::CpuRates::default();
    if backend != BenchBackend::Gpu {
        let r = phonation::bench::run(quick, only.as_deref());
        cpu_rates = cpu::print_tables(&r);
        report.insert("cpu".into(), serde_json::to_value(&r)?);
    }
    if wants("drawing") {
        // the CPU twins and, with a device, the GPU kernels, measured in this process
        let ctx = if backend != BenchBackend::Cpu { Some(phonation::gpu::GpuContext::new()?) } else { None };
        report.insert("drawing".into(), gpu::drawing(ctx.as_ref(), quick)?);
    }
    if backend != BenchBackend::Cpu {
        let run = gpu::GpuRun { quick, only: only.as_deref(), cpu: &cpu_rates };
        report.insert("gpu".into(), gpu::measure(&run)?);
    }
    if let Some(p) = json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)?;
    }
    Ok(())
}

/// A table's stage shares as "name 12%, …".
fn stages<N: std::fmt::Display>(shares: &[(N, f64)]) -> String {
    let st: Vec<String> = shares.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
    st.join(", ")
}
