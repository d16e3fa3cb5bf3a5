//! The CPU's tables of `phonation bench`: one printer per suite of [`BenchReport`], in the
//! order they are printed.

use super::{lattice_gas_header, lattice_gas_row, percent, solid_row, stages};
use phonation::bench::BenchReport;

/// The CPU's rates the GPU's tables are set against (same process): each lattice's node
/// updates per second, the lattice gas's site updates per second (its first row: the
/// transposed collision) and each solid row's particle updates per second by
/// "integrator/particles/dim".
#[derive(Default)]
pub struct CpuRates {
    pub lattices: Vec<(String, f64)>,
    pub lattice_gas: Option<f64>,
    pub solid: Vec<(String, f64)>,
}

/// Prints every table of `r` (the suites it ran) and returns the rates the GPU compares with.
pub fn print_tables(r: &BenchReport) -> CpuRates {
    machine(r);
    lattices(r);
    speed_vs_error(r);
    storage(r);
    solid(r);
    solid_crossover(r);
    let lattice_gas = lattice_gas(r);
    coupled(r);
    two_mass(r);
    glottis(r);
    geometry(r);
    scaling(r);
    CpuRates {
        lattices: r.lattices.iter().map(|l| (l.lattice.clone(), l.node_updates_per_s)).collect(),
        lattice_gas,
        solid: r.solid.iter().map(|v| (format!("{:?}/{}/{}d", v.integrator, v.particles, v.dim).to_lowercase(), v.particle_updates_per_s)).collect(),
    }
}

/// The machine's yardsticks: the triad's bandwidth, the vector and scalar FMA rates.
fn machine(r: &BenchReport) {
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
}

/// The FDLB lattices: node updates per second, bytes, the bandwidth fraction, the stages and
/// the memory hints' gain.
fn lattices(r: &BenchReport) {
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
        println!("         stages: {}", stages(&l.stage_fractions));
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
    }
}

/// Taylor–Green: wall time per time unit against the decay rate's error.
fn speed_vs_error(r: &BenchReport) {
    if !r.speed_vs_error.is_empty() {
        println!("speed vs error, Taylor–Green D2Q21 (Re = 10):");
        println!("{:>6} {:>14} {:>16}", "n", "wall s / t.u.", "decay-rate error");
    }
    for t in &r.speed_vs_error {
        println!("{:>6} {:>14.3e} {:>15.3}%", t.n, t.wall_per_time_unit, 100.0 * t.relative_error);
    }
}

/// f64 against f32 population storage: speed, then what f32 costs in error.
fn storage(r: &BenchReport) {
    if !r.storage.is_empty() {
        println!("FDLB population storage, f64 against f32 (blocks interleaved; arithmetic f64 in both):");
        println!("{:8} {:>16} {:>8} {:>14} {:>14} {:>10} {:>10} {:>9}", "lattice", "nodes", "storage", "updates/s", "median", "B/update", "of b/w", "speed-up");
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
}

/// The MPS solid's explicit and implicit steps.
fn solid(r: &BenchReport) {
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
        println!("          stages: {}", stages(&v.stage_shares));
    }
}

/// The implicit step against the explicit one to the same simulated time.
fn solid_crossover(r: &BenchReport) {
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
}

/// The lattice gas: the transposed collision's step first, then the site-by-site reference;
/// returns the first row's site updates per second.
fn lattice_gas(r: &BenchReport) -> Option<f64> {
    if !r.lattice_gas.is_empty() {
        lattice_gas_header();
    }
    let mut first: Option<f64> = None;
    for v in &r.lattice_gas {
        match first {
            // the reference row: the same step with the collision done site by site
            Some(fast) => lattice_gas_row(v, &format!("  ({}: the transposed collision's step is {:.2}× faster)", v.backend, fast / v.site_updates_per_s)),
            None => {
                lattice_gas_row(v, "");
                first = Some(v.site_updates_per_s);
            }
        }
    }
    first
}

/// Schäfer–Turek 2D-1 through the coupling: speed against the drag's error, both methods.
fn coupled(r: &BenchReport) {
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
        println!("     stages: {}", stages(&c.stage_shares));
    }
}

/// The two-mass model: RK4's rate against its error.
fn two_mass(r: &BenchReport) {
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
}

/// The coupled 2D glottis from rest: steps per second and their stages.
fn glottis(r: &BenchReport) {
    if !r.glottis.is_empty() {
        println!("coupled 2D glottis (weak, CPU), from rest; no error column: f0 needs tens of ms (validate --case glottis_2d)");
        println!("{:>18} {:>8} {:>9} {:>10} {:>10} {:>16}", "scene", "nodes", "particles", "dt (s)", "steps/s", "wall s / sim ms");
    }
    for g in &r.glottis {
        println!("{:>18} {:>8} {:>9} {:>10.3e} {:>10.1} {:>16.2}", g.scene, g.nodes, g.particles, g.dt, g.coupled_steps_per_s, g.wall_per_simulated_ms);
        println!("     stages: {}", stages(&g.stage_shares));
    }
}

/// The coupled scenes' `fluid_geometry` stage alone: the host's ceiling and its parts.
fn geometry(r: &BenchReport) {
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
}

/// Cost per update against size, against the last-level cache.
fn scaling(r: &BenchReport) {
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
}
