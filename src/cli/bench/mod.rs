//! `phonation bench`: memory bandwidth, updates per second and speed-vs-error tables, on the
//! CPU and the GPU, printed and written as JSON.

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
        let st: Vec<String> = v.stage_shares.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
        println!("{:>16} stages: {}", "", st.join(", "));
    }
}

pub fn bench(args: BenchArgs) -> anyhow::Result<()> {
    let BenchArgs { quick, backend, json, only } = args;
    let wants = |suite: &str| only.as_deref().is_none_or(|o| o == suite);
    let mut report = serde_json::Map::new();
    let mut cpu_speeds = Vec::new();
    let mut cpu_gas: Option<f64> = None;
    if backend != BenchBackend::Gpu {
        let r = phonation::bench::run(quick, only.as_deref());
        let t = &r.triad;
        println!(
            "CPU: {} threads, STREAM-like triad bandwidth {:.2} GB/s (best of {}; median {:.2}, worst {:.2}; 3 arrays of {} MiB); last-level cache {} MiB",
            r.threads,
            r.triad_bandwidth_gb_s,
            t.repetitions,
            t.median / 1e9,
            t.worst / 1e9,
            t.array_bytes >> 20,
            r.last_level_cache_bytes >> 20
        );
        println!(
            "CPU: f64 peak {:.1} GFLOP/s (FMA chains in registers, all threads; best of {}, median {:.1})",
            r.fma_peak.best / 1e9,
            r.fma_peak.repetitions,
            r.fma_peak.median / 1e9
        );
        if let Some(p) = r.scalar_fma_peak {
            println!(
                "CPU: scalar f64 FMA rate {:.1} GFLOP/s (one f64 per instruction, the roof of code that does not vectorise; best of {}, median {:.1})",
                p.best / 1e9,
                p.repetitions,
                p.median / 1e9
            );
        }
        if !r.lattices.is_empty() {
            println!("{:8} {:>16} {:>16} {:>10} {:>10}", "lattice", "nodes", "updates/s", "B/update", "of b/w");
        }
        for l in &r.lattices {
            println!(
                "{:8} {:>16} {:>16.3e} {:>10.0} {:>10}",
                l.lattice,
                format!("{:?}", l.nodes),
                l.node_updates_per_s,
                l.bytes_per_node_update,
                percent(l.bandwidth_fraction)
            );
            let st: Vec<String> = l.stage_fractions.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
            println!("         stages: {}", st.join(", "));
            if let Some(h) = &l.memory_hints {
                let chosen: Vec<&str> =
                    [(h.streaming_stores, "streaming stores"), (h.prefetch_rows, "rows fetched ahead")].iter().filter(|c| c.0).map(|c| c.1).collect();
                match (chosen.is_empty(), h.without_node_updates_per_s) {
                    (true, _) | (_, None) => println!("         memory hints: none at this size"),
                    (false, Some(w)) => println!(
                        "         memory hints: {}; without them {:.3e} (median {:.3e}), blocks interleaved: {:.2}× with",
                        chosen.join(", "),
                        w,
                        h.without_median_node_updates_per_s.unwrap_or(w),
                        l.node_updates_per_s / w
                    ),
                }
            }
            if l.repetitions > 1 {
                println!(
                    "         best of {} blocks of {} steps; median {:.3e}, worst {:.3e}",
                    l.repetitions, l.steps, l.median_node_updates_per_s, l.worst_node_updates_per_s
                );
            }
            cpu_speeds.push((l.lattice.clone(), l.node_updates_per_s));
        }
        if !r.speed_vs_error.is_empty() {
            println!("speed vs error, Taylor–Green D2Q21 (Re = 10):");
            println!("{:>6} {:>14} {:>16}", "n", "wall s / t.u.", "decay-rate error");
        }
        for t in &r.speed_vs_error {
            println!("{:>6} {:>14.3e} {:>15.3}%", t.n, t.wall_per_time_unit, 100.0 * t.relative_error);
        }
        if !r.storage.is_empty() {
            println!("FDLB population storage, f64 against f32 (blocks interleaved; arithmetic f64 in both):");
            println!(
                "{:8} {:>16} {:>8} {:>14} {:>14} {:>10} {:>10} {:>9}",
                "lattice", "nodes", "storage", "updates/s", "median", "B/update", "of b/w", "speed-up"
            );
        }
        for v in &r.storage {
            for (l, up) in [(&v.f64, String::new()), (&v.f32, format!("{:.2}× ({:.2}× median)", v.speedup, v.median_speedup))] {
                println!(
                    "{:8} {:>16} {:>8} {:>14.3e} {:>14.3e} {:>10.0} {:>10} {up}",
                    l.lattice,
                    format!("{:?}", l.nodes),
                    if up.is_empty() { "f64" } else { "f32" },
                    l.node_updates_per_s,
                    l.median_node_updates_per_s,
                    l.bytes_per_node_update,
                    percent(l.bandwidth_fraction)
                );
            }
        }
        if !r.storage_errors.is_empty() {
            println!("{:46} {:>12} {:>12} {:>14}", "what f32 storage costs", "f64 error", "f32 error", "|f32 − f64|");
        }
        for e in &r.storage_errors {
            println!("{:46} {:>11.3e} {:>12.3e} {:>14.3e}", e.case, e.f64_error, e.f32_error, e.f32_minus_f64);
        }
        if !r.solid.is_empty() {
            println!(
                "MPS solid (3D unless marked 2D, r_e = 2.1 l0; implicit at 10× the explicit limit, CG to 1e-8 with the coarse space and the patch (ptch) or block-Jacobi (bj) smoother):"
            );
            println!(
                "{:11} {:>9} {:>10} {:>14} {:>9} {:>8} {:>8} {:>8} {:>9} {:>8}",
                "step", "particles", "bonds", "updates/s", "B/update", "of b/w", "of flops", "scalar", "CG it.", "Δt/lim"
            );
        }
        for v in &r.solid {
            solid_row(v, "");
            let st: Vec<String> = v.stage_shares.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
            println!("          stages: {}", st.join(", "));
        }
        if let Some(first) = r.solid_crossover.first() {
            println!(
                "implicit against explicit to the same simulated time ({} particles; cost: wall per simulated s over the explicit row's; ! = a CG solve stopped short of its tolerance):",
                first.particles
            );
            println!(
                "{:>9} {:>8} {:9} {:>7} {:>6} {:>7}  {:>11} {:>11} {:>7} {:>10}",
                "viscosity", "lim/lim0", "step", "Δt/lim", "steps", "CG it.", "s/step", "s/sim. s", "cost", "error"
            );
        }
        for c in &r.solid_crossover {
            println!(
                "{:>9.3e} {:>8.3} {:9} {:>7.2} {:>6} {:>7.1}{} {:>11.3e} {:>11.3e} {:>7.2} {:>10.2e}",
                c.viscosity,
                c.limit_over_inviscid_limit,
                format!("{:?}", c.integrator).to_lowercase(),
                c.time_step_over_explicit_limit,
                c.steps,
                c.cg_iterations,
                if c.cg_converged { " " } else { "!" },
                c.wall_per_step_s,
                c.wall_per_simulated_s,
                c.cost_over_explicit,
                c.displacement_error
            );
        }
        if !r.lattice_gas.is_empty() {
            lattice_gas_header();
        }
        for v in &r.lattice_gas {
            match cpu_gas {
                // the reference row: the same step with the collision done site by site
                Some(fast) => lattice_gas_row(v, &format!("  ({}: the transposed collision's step is {:.2}× faster)", v.backend, fast / v.site_updates_per_s)),
                None => {
                    lattice_gas_row(v, "");
                    cpu_gas = Some(v.site_updates_per_s);
                }
            }
        }
        if !r.coupled.is_empty() {
            println!("coupled, clamped elastic cylinder, Schäfer–Turek 2D-1 (Mach 0.1): speed vs error, method 1 (weak) and 2 (momentum-conserving)");
            println!(
                "{:>8} {:>4} {:>8} {:>9} {:>8} {:>12} {:>14} {:>8} {:>10} {:>10}",
                "method", "D", "nodes", "particles", "substeps", "steps/s", "wall s / sim s", "C_D", "vs finest", "vs 5.5795"
            );
        }
        for c in &r.coupled {
            println!(
                "{:>8} {:>4} {:>8} {:>9} {:>8} {:>12.1} {:>14.1} {:>8.4} {:>9.2}% {:>9.2}%",
                c.method,
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
        if !r.two_mass.is_empty() {
            println!("two-mass model (Ishizaka–Flanagan, 8 cmH₂O, 0.4 s): RK4 rate vs error (against 32 × 44.1 kHz)");
            println!("{:>12} {:>14} {:>14} {:>10} {:>10} {:>12}", "rate (Hz)", "steps/s", "wall s/sim s", "f0 (Hz)", "f0 err", "peak err");
        }
        for t in &r.two_mass {
            println!(
                "{:>12.0} {:>14.3e} {:>14.4} {:>10.3} {:>9.4}% {:>11.4}%",
                t.rate_hz,
                t.steps_per_s,
                t.wall_per_simulated_s,
                t.f0_hz,
                100.0 * t.f0_error,
                100.0 * t.peak_flow_error
            );
        }
        if !r.glottis.is_empty() {
            println!("coupled 2D glottis (weak, CPU), from rest; no error column: f0 needs tens of ms (validate --case glottis_2d)");
            println!("{:>18} {:>8} {:>9} {:>10} {:>10} {:>16}", "scene", "nodes", "particles", "dt (s)", "steps/s", "wall s / sim ms");
        }
        for g in &r.glottis {
            println!("{:>18} {:>8} {:>9} {:>10.3e} {:>10.1} {:>16.2}", g.scene, g.nodes, g.particles, g.dt, g.coupled_steps_per_s, g.wall_per_simulated_ms);
            let st: Vec<String> = g.stage_shares.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
            println!("     stages: {}", st.join(", "));
        }
        if !r.geometry.is_empty() {
            println!(
                "the fluid_geometry stage alone (CPU, {} threads; every particle moved ±{} cells a step): what building the walls costs the host per coupled step",
                r.threads,
                phonation::bench::GEOMETRY_BENCH_CELLS
            );
            println!("  (\"device's\": the level sets' questions, which the GPU backend asks of a device with f64; the rest is the host's own work)");
            println!(
                "{:>18} {:>20} {:>9} {:>9} {:>6} {:>10} {:>10} {:>10} {:>16}",
                "scene", "method", "nodes", "particles", "steps", "ms/step", "device's", "host's", "host ceiling/s"
            );
        }
        for g in &r.geometry {
            println!(
                "{:>18} {:>20} {:>9} {:>9} {:>6} {:>10.3} {:>10.3} {:>10.3} {:>16.1}",
                g.scene,
                g.method,
                g.nodes,
                g.particles,
                g.steps,
                1e3 * g.seconds_per_step,
                1e3 * g.device_answerable_seconds_per_step,
                1e3 * (g.seconds_per_step - g.device_answerable_seconds_per_step),
                g.ceiling_with_device_questions_steps_per_s
            );
            let parts: Vec<String> = g.host_parts.iter().map(|p| format!("{} {:.2}", p.part, 1e3 * p.seconds_per_step)).collect();
            println!("     host's parts, ms/step: {}", parts.join(", "));
        }
        if !r.scaling.is_empty() {
            println!(
                "cost per update against size (CPU, {} threads; flat ns/update = linear cost; data vs the {} MiB last-level cache):",
                r.threads,
                r.last_level_cache_bytes >> 20
            );
            println!("{:>18} {:>12} {:>8} {:>14} {:>12} {:>10}", "kernel", "size", "steps", "updates/s", "ns/update", "data MiB");
        }
        for row in &r.scaling {
            println!(
                "{:>18} {:>12} {:>8} {:>14.3e} {:>12.2} {:>10.1}",
                row.kernel,
                row.size,
                row.steps,
                row.updates_per_s,
                row.ns_per_update,
                row.data_bytes as f64 / (1 << 20) as f64
            );
        }
        report.insert("cpu".into(), serde_json::to_value(&r)?);
    }
    if wants("drawing") {
        // the CPU twins and, with a device, the GPU kernels, measured in this process
        let ctx = if backend != BenchBackend::Cpu { Some(phonation::gpu::GpuContext::new()?) } else { None };
        let (n, tracers) = if quick { (48, 20_000) } else { (128, 100_000) };
        let mut rows = phonation::gpu::bench::drawing_speed(ctx.as_ref(), n, tracers);
        // the glottis's folds as the plugin draws them
        let glottis = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("glottis_2d_c").expect("a built-in scene"))?.build()?;
        let source = phonation::run::surface::SurfaceSource::coupled(&glottis);
        rows.push(phonation::gpu::bench::fold_surface_speed(ctx.as_ref(), "glottis_2d_c", &source.sets, source.spacing, source.dim));
        println!("drawing kernels (CPU twin serial{}):", ctx.as_ref().map(|c| format!("; GPU {}", c.describe())).unwrap_or_default());
        println!("{:>26} {:>8} {:>14} {:>14} {:>10} {:>10}", "kernel", "size", "CPU /s", "GPU /s", "GPU/CPU", "triangles");
        for r in &rows {
            println!(
                "{:>26} {:>8} {:>14.3e} {:>14} {:>10} {:>10}",
                r.kernel,
                r.size,
                r.cpu_per_s,
                r.gpu_per_s.map(|g| format!("{g:.3e}")).unwrap_or("-".into()),
                r.gpu_per_s.map(|g| format!("{:.1}×", g / r.cpu_per_s)).unwrap_or("-".into()),
                r.triangles.map(|t| t.to_string()).unwrap_or_default()
            );
        }
        report.insert("drawing".into(), serde_json::to_value(&rows)?);
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
                // issue 16 asks for 128³ and 256³ (2.6 GB per population array in f32; reported as
                // skipped where the device's buffers are smaller)
                (phonation::fluid::VelocitySetKind::D3q39, [256, 256, 256]),
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
                        "{:8} {:>16} {:>16.3e} {:>10.0} {:>10}{vs_cpu}",
                        l.lattice,
                        format!("{:?}", l.nodes),
                        l.node_updates_per_s,
                        l.bytes_per_node_update,
                        percent(l.bandwidth_fraction)
                    );
                    if !l.stage_fractions.is_empty() {
                        let st: Vec<String> = l.stage_fractions.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
                        println!("         GPU stages (timestamps): {}", st.join(", "));
                    }
                    if let Some(r) = &l.readback {
                        println!(
                            "         a probe sample: whole state back {:.3e} s ({:.2e} steps), {} nodes gathered {:.3e} s ({:.2e} steps)",
                            r.whole_s, r.whole_steps, r.nodes, r.gathered_s, r.gathered_steps
                        );
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
                        let key = format!("{}/{}/{}d", v["integrator"].as_str().unwrap_or(""), v["particles"], v["dim"]);
                        (key.to_lowercase(), v["particle_updates_per_s"].as_f64().unwrap_or(0.0))
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
            use phonation::solid::{Integrator, Preconditioner};
            // the implicit solve with the patches (the default) and with block Jacobi: the
            // smoother's gain on the device, method against method in one process
            let implicit_steps = if quick { 2 } else { 5 };
            for (integ, pre, steps) in [
                (Integrator::Explicit, Preconditioner::Patches, if quick { 10 } else { 50 }),
                (Integrator::Implicit, Preconditioner::Patches, implicit_steps),
                (Integrator::Implicit, Preconditioner::BlockJacobi, implicit_steps),
            ] {
                match phonation::gpu::bench::solid_speed(&ctx, side, integ, pre, steps, bw) {
                    Ok(v) => {
                        let key = format!("{:?}/{}/{}d", v.integrator, v.particles, v.dim).to_lowercase();
                        // against the CPU's default (patches and the coarse space)
                        let vs = (pre == Preconditioner::Patches)
                            .then(|| cpu_solid.iter().find(|(k, _)| *k == key))
                            .flatten()
                            .map(|(_, c)| format!("  {:.2}× the CPU", v.particle_updates_per_s / c))
                            .unwrap_or_default();
                        solid_row(&v, &vs);
                        gpu_solid.push(v);
                    }
                    Err(e) => println!("{integ:?} ({pre:?}) {side}³ skipped: {e}"),
                }
            }
        }
        let mut gpu_gas = Vec::new();
        let mut gpu_gas_readback = Vec::new();
        if wants("lattice_gas") {
            lattice_gas_header();
            // (512 × 256 × 4: the lattice of lattice_gas_wake_large)
            let sizes: Vec<[usize; 3]> = if quick { vec![[32, 16, 8], [512, 256, 4]] } else { vec![[128, 64, 32], [512, 256, 4], [512, 256, 128]] };
            for cells in sizes {
                match phonation::gpu::lattice_gas::lattice_gas_speed(&ctx, cells, if quick { 5 } else { 100 }, bw) {
                    Ok(v) => {
                        let vs = cpu_gas.map(|c| format!("  {:.1}× the CPU", v.site_updates_per_s / c)).unwrap_or_default();
                        lattice_gas_row(&v, &vs);
                        // the large wake's probe band: 2 × coarse_block = 16 ℓ either side, 9 rows
                        let step_s = 16.0 * (cells[0] * cells[1] * cells[2]) as f64 / v.site_updates_per_s;
                        if let Ok(r) = phonation::gpu::lattice_gas::readback_cost(&ctx, cells, 9, step_s) {
                            println!(
                                "         a probe sample: whole state back {:.3e} s ({:.2e} steps), {} cells (9 rows) {:.3e} s ({:.2e} steps)",
                                r.whole_s, r.whole_steps, r.nodes, r.gathered_s, r.gathered_steps
                            );
                            gpu_gas_readback.push(r);
                        }
                        gpu_gas.push(v);
                    }
                    Err(e) => println!("lattice gas {cells:?} skipped: {e}"),
                }
            }
        }
        let mut gpu_coupled = Vec::new();
        let mut coupled_scenes: Vec<(&str, String)> = Vec::new();
        if wants("coupled") {
            // the Wall flap (method 2) at its built-in resolution (D = 20 cells) and at D = 30
            let flap = phonation::scene::builtin("wall_flap_conserving").expect("built in");
            let finer = flap.replace("cells = [390, 240]", "cells = [585, 360]").replace("kernel_radius = 1.0 ", "kernel_radius = 1.5 ");
            coupled_scenes.extend([("wall_flap_conserving, D = 20", flap.to_string()), ("wall_flap_conserving, D = 30", finer)]);
        }
        if wants("glottis") {
            // the coupled 2D glottis (method 1, as the seed): the coarse scene and the seed's lattice
            coupled_scenes.push(("glottis_2d_coarse", phonation::scene::builtin("glottis_2d_coarse").expect("built in").to_string()));
            // the coarse 3D glottis (method 2): thick folds, whose ghosts' wall points the
            // geometry spends most of its time on
            coupled_scenes.push(("glottis_3d_coarse", phonation::scene::builtin("glottis_3d_coarse").expect("built in").to_string()));
            if !quick {
                coupled_scenes.push(("glottis_2d_c", phonation::scene::builtin("glottis_2d_c").expect("built in").to_string()));
            }
        }
        if !coupled_scenes.is_empty() {
            println!("GPU coupled step against the CPU in the same process (the Wall flap and the 3D glottis: method 2; the 2D glottis: method 1):");
            for (label, text) in coupled_scenes {
                let sc = phonation::scene::coupled::CoupledScene::parse(&text)?;
                let steps = if quick { 5 } else { 50 };
                match phonation::gpu::bench::coupled_speed(label, || sc.build().expect("a built-in scene builds"), steps) {
                    Ok(v) => {
                        let st: Vec<String> = v.gpu_stage_shares.iter().map(|(n, f)| format!("{n} {:.0}%", 100.0 * f)).collect();
                        println!(
                            "{:>30} {:>7} nodes {:>6} particles ×{} sub-steps: {:.2} steps/s ({:.2}× the CPU), {:.0} s per simulated s; coupling stages {:.0}% ({}); {} changes of layout, {:.0} nodes' populations across the bus each",
                            v.scene,
                            v.nodes,
                            v.particles,
                            v.solid_substeps,
                            v.gpu_steps_per_s,
                            v.gpu_steps_per_s / v.cpu_steps_per_s,
                            v.gpu_wall_per_simulated_s,
                            100.0 * v.gpu_coupling_share,
                            st.join(", "),
                            v.round_trips,
                            v.nodes_per_round_trip
                        );
                        let parts: Vec<String> = v.gpu_geometry_parts.iter().map(|(n, f)| format!("{n} {:.1}%", 100.0 * f)).collect();
                        println!(
                            "{:>30} fluid_geometry's parts: {}; {} device buffers or bind-group sets made in the timed steps",
                            "",
                            parts.join(", "),
                            v.gpu_device_objects_made
                        );
                        if let Some(host) = v.gpu_steps_per_s_cpu_level_sets {
                            println!(
                                "{:>30} level sets on the device: {:.2} steps/s against {host:.2} with them on the CPU ({:.2}×)",
                                "",
                                v.gpu_steps_per_s,
                                v.gpu_steps_per_s / host
                            );
                        }
                        let host: Vec<String> = v.gpu_host_work_s.iter().map(|(n, t)| format!("{n} {:.3} ms", 1e3 * t)).collect();
                        println!(
                            "{:>30} the host's own work per step: {} — at most {:.0} steps/s on any device driven by this host",
                            "",
                            host.join(", "),
                            v.gpu_host_ceiling_steps_per_s
                        );
                        gpu_coupled.push(v);
                    }
                    Err(e) => println!("{label} skipped: {e}"),
                }
            }
        }
        let (gpu_scaling, gpu_scaling_skipped) = if only.as_deref() == Some("scaling") { gpu_scaling_table(&ctx, quick, bw) } else { (Vec::new(), Vec::new()) };
        report.insert(
            "gpu".into(),
            serde_json::json!({ "adapter": ctx.describe(), "copy_bandwidth_gb_s": bw / 1e9, "lattices": gpu, "solid": gpu_solid, "lattice_gas": gpu_gas, "lattice_gas_readback": gpu_gas_readback, "coupled": gpu_coupled, "scaling": gpu_scaling, "scaling_skipped": gpu_scaling_skipped }),
        );
    }
    if let Some(p) = json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)?;
    }
    Ok(())
}

/// The device's cost per update against size (`--only scaling --backend gpu`), printed as the
/// CPU's table is, with each row's fraction of the copy kernel's bandwidth `bw`.
fn gpu_scaling_table(ctx: &phonation::gpu::GpuContext, quick: bool, bw: f64) -> (Vec<phonation::gpu::scaling::GpuScalingRow>, Vec<String>) {
    use phonation::gpu::scaling::{ScalingSizes, scaling_table};
    let sizes = if quick { ScalingSizes::quick() } else { ScalingSizes::full() };
    println!("cost per update against size (GPU; flat ns/update once the device is filled = linear cost):");
    let (rows, skipped) = scaling_table(ctx, &sizes, if quick { 0.05 } else { 0.3 }, bw);
    println!("{:>18} {:>12} {:>8} {:>14} {:>12} {:>10} {:>12}", "kernel", "size", "steps", "updates/s", "ns/update", "B/update", "of copy b/w");
    for r in &rows {
        println!(
            "{:>18} {:>12} {:>8} {:>14.3e} {:>12.3} {:>10.0} {:>11.1}%",
            r.kernel,
            r.size,
            r.steps,
            r.updates_per_s,
            r.ns_per_update,
            r.bytes_per_update,
            100.0 * r.bandwidth_fraction
        );
    }
    for s in &skipped {
        println!("{:>18} skipped: {s}", "");
    }
    (rows, skipped)
}
