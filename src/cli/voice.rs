//! `phonation analyze` (the voice measures, plots and sound of a run's glottal flow) and
//! `phonation sweep` (one scene over a list of values of one key: in parallel here, or as a
//! Slurm job array, merged into one table).

use anyhow::bail;
use phonation::analysis::pitch::F0Range;
use phonation::analysis::voice::VoiceOptions;
use phonation::run::sweep;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct AnalyzeArgs {
    /// A run's output directory holding glottal_flow.csv (a glottis: the voice measures), or
    /// coupling.csv (any coupled run: its particle probes' oscillation, e.g. the flap's tip).
    pub dir: PathBuf,
    /// The last fraction (0, 1] of the run analysed.
    #[arg(long, default_value_t = 0.5)]
    pub window: f64,
    /// f0 search range (Hz).
    #[arg(long, default_value_t = 50.0)]
    pub f0_min: f64,
    #[arg(long, default_value_t = 1000.0)]
    pub f0_max: f64,
    /// The run's lung pressure (dyn/cm²): voice.json then holds the two-mass model's measures at
    /// that pressure ("two_mass_yardstick") for comparison.
    #[arg(long)]
    pub lung_pressure: Option<f64>,
}

pub fn analyze(a: AnalyzeArgs) -> anyhow::Result<()> {
    if !(a.window > 0.0 && a.window <= 1.0) {
        bail!("--window: {} must lie in (0, 1]", a.window);
    }
    if !(a.f0_min > 0.0 && a.f0_max > a.f0_min) {
        bail!("--f0-min/--f0-max: need 0 < min < max (got {}, {})", a.f0_min, a.f0_max);
    }
    if !a.dir.join("glottal_flow.csv").exists() && a.dir.join("coupling.csv").exists() {
        return analyze_particle_probes(&a.dir, a.window);
    }
    let opts = VoiceOptions { window_fraction: a.window, f0_range: F0Range { min_hz: a.f0_min, max_hz: a.f0_max }, ..VoiceOptions::default() };
    let extra = match a.lung_pressure {
        Some(p) if !p.is_finite() || p.abs() > 1e6 => bail!("--lung-pressure: {p} is not a pressure in dyn/cm² within ±10⁶"),
        Some(p) => {
            let y = phonation::run::two_mass::yardstick(p);
            match &y {
                Some(m) => println!(
                    "two-mass yardstick at {p} dyn/cm²: f0 {:.2} Hz, peak flow {:.1} cm³/s, OQ {:.3}",
                    m.f0_autocorrelation_hz, m.peak_flow, m.open_quotient
                ),
                None => println!("two-mass yardstick at {p} dyn/cm²: below its phonation threshold"),
            }
            serde_json::json!({ "two_mass_yardstick": { "lung_pressure_dyn_cm2": p, "measures": y } })
        }
        None => serde_json::json!({}),
    };
    let r = phonation::output::voice::analyze_dir(&a.dir, &opts, extra)?;
    print_voice(&r);
    for f in &r.files {
        println!("wrote {}", f.display());
    }
    // a glottis with particle probes on its folds (the 3D scenes): their paths and phases too
    if phonation::run::particle_probes::has_probes(&a.dir.join("coupling.csv")) {
        analyze_particle_probes(&a.dir, a.window)?;
    }
    Ok(())
}

/// The particle probes of a coupled run's coupling.csv over its last `window` fraction: printed,
/// and written to `particle_probes.json`.
fn analyze_particle_probes(dir: &std::path::Path, window: f64) -> anyhow::Result<()> {
    let csv = dir.join("coupling.csv");
    let (reports, paths, leads) = phonation::run::particle_probes::probe_motion_from_csv(&csv, window)?;
    for p in &reports {
        println!("{p}");
    }
    for p in &paths {
        match (&p.oscillation_dx, &p.path) {
            (Some(o), Some(e)) => println!(
                "probe {}: dx spectral peak {} Hz, largest |dx| {:.4e}; path an ellipse of semi-axes {:.4e} × {:.4e} (roundness {:.3}) at {:.1}°, {}",
                p.name,
                o.spectral_peak.map_or("none".into(), |f| format!("{f:.4}")),
                o.max_abs,
                e.semi_major,
                e.semi_minor,
                e.roundness(),
                e.angle_rad.to_degrees(),
                ["clockwise", "no area", "counter-clockwise"][(e.sense + 1) as usize]
            ),
            _ => println!("probe {}: dx does not oscillate over the window", p.name),
        }
    }
    for l in &leads {
        match l.lead_s {
            Some(s) => println!(
                "{} leads {} by {:.4e} s (cross-correlation); their fundamentals' phase: {}",
                l.leading,
                l.following,
                s,
                l.phase_deg.map_or("n/a".to_string(), |d| format!("{d:+.1}°"))
            ),
            None => println!("{} against {}: no lead (one of them does not oscillate)", l.leading, l.following),
        }
    }
    let out = dir.join("particle_probes.json");
    std::fs::write(
        &out,
        serde_json::to_string_pretty(
            &serde_json::json!({ "analysed_from": csv, "window_fraction": window, "probes": reports, "paths": paths, "leads": leads }),
        )?,
    )?;
    println!("wrote {}", out.display());
    Ok(())
}

/// The measures, one per line, as a voice scientist reads them.
pub fn print_voice(r: &phonation::output::voice::VoiceReport) {
    match &r.measures {
        Some(m) => {
            println!(
                "f0 {:.2} Hz (spectrum {}), {} pulses in [{:.4}, {:.4}] s",
                m.f0_autocorrelation_hz,
                m.f0_spectrum_hz.map_or("-".into(), |f| format!("{f:.2} Hz")),
                m.pulses,
                m.window_s[0],
                m.window_s[1]
            );
            println!("flow: peak {:.1}, mean {:.1}, AC {:.1}, min {:.1} cm³/s; MFDR {:.4e} cm³/s²", m.peak_flow, m.mean_flow, m.ac_flow, m.min_flow, m.mfdr);
            println!(
                "OQ {:.3}, SQ {:.3}, ClQ {:.3}, QOQ {:.3}, NAQ {:.4}, H1–H2 {:.2} dB; amplitude spread over the last 5 pulses {}",
                m.open_quotient,
                m.speed_quotient,
                m.closing_quotient,
                m.quasi_open_quotient,
                m.naq,
                m.h1_h2_db,
                if m.amplitude_spread_last5.is_nan() { "n/a (fewer than 5 pulses)".to_string() } else { format!("{:.2} %", 100.0 * m.amplitude_spread_last5) }
            );
        }
        None => println!("no voice: {}", r.no_voice.as_deref().unwrap_or("?")),
    }
    if let Some(e) = &r.energy {
        let parts: Vec<String> = e.parts.iter().zip(&e.work_per_cycle_erg).map(|(p, w)| format!("{p} {w:.4e}")).collect();
        println!(
            "the air's work on the folds per cycle ({} cycles, from one upward crossing of the area's mean to the next): {:.4e} erg ({}), {:+.2} % of their peak kinetic energy {:.4e} erg",
            e.per_cycle.len(),
            e.total_work_per_cycle_erg,
            parts.join(", "),
            100.0 * e.work_over_peak_kinetic_energy,
            e.peak_kinetic_energy_erg
        );
    }
    if let Some(c) = &r.closure {
        println!(
            "the glottis closes from below at {} of {} closures; lower − upper margin at closure {:+.3e} cm on average ({})",
            (c.from_below * c.closures as f64).round(),
            c.closures,
            c.lower_minus_upper,
            if c.lower_minus_upper < 0.0 { "divergent" } else { "convergent" }
        );
    }
    if let Some(v) = &r.vertical_phase {
        println!(
            "vertical phase difference: the lower margin {:+.1}° ({:+.3e} s) ahead of the upper at f0, over {} periods (fundamentals {:.3e} and {:.3e} cm)",
            v.degrees, v.lead_s, v.periods, v.amplitudes[0], v.amplitudes[1]
        );
    }
    println!("sound: {:.2} s at {} Hz, {}", r.audio.seconds, r.audio.sample_rate_hz, r.audio.source);
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Emit {
    /// A Slurm job-array script (sweep.slurm) and one scene file per task; nothing runs here.
    Slurm,
}

#[derive(clap::Args)]
pub struct SweepArgs {
    /// Scene file or built-in name (not with --collect).
    #[arg(required_unless_present = "collect")]
    pub scene: Option<String>,
    /// The dotted scene key to sweep, e.g. two_mass.lung_pressure or (a glottis)
    /// boundaries.y_min.pressure; `resolution` scales the lattice's cells by each value and
    /// divides the particles' spacing by it (a convergence study: f0 against the finest run).
    #[arg(long, default_value = "two_mass.lung_pressure")]
    pub key: String,
    /// Values of the key (in the key's own units); negative ones too (`--values -5,5`).
    #[arg(long, value_delimiter = ',', conflicts_with = "range", allow_hyphen_values = true)]
    pub values: Vec<f64>,
    /// START,STOP,COUNT: COUNT evenly spaced values from START to STOP (START may be negative).
    #[arg(long, value_delimiter = ',', num_args = 1, allow_hyphen_values = true)]
    pub range: Option<Vec<f64>>,
    /// Sweep directory (default out/sweep_<scene>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the jobs for a cluster instead of running them here.
    #[arg(long, value_enum)]
    pub emit: Option<Emit>,
    /// With --emit slurm: each task's wall-time limit (Slurm's --time, e.g. 01:00:00 or
    /// 2-00:00:00; a glottis on the seed's lattice takes hours on one core).
    #[arg(long, default_value = "01:00:00")]
    pub time: String,
    /// Merge the results the jobs of this sweep directory wrote.
    #[arg(long, conflicts_with_all = ["scene", "emit"])]
    pub collect: Option<PathBuf>,
}

pub fn sweep(a: SweepArgs) -> anyhow::Result<()> {
    if let Some(dir) = &a.collect {
        let (rows, t) = sweep::collect(dir)?;
        return print_sweep(dir, &sweep::manifest(dir)?.key, &rows, t);
    }
    let name = a.scene.expect("clap requires a scene without --collect");
    let values = match &a.range {
        Some(r) => {
            let count_ok = r.len() == 3 && r[2] >= 2.0 && r[2].fract() == 0.0 && r[2] <= 10_000.0;
            if !count_ok || !r[0].is_finite() || !r[1].is_finite() {
                bail!("--range: START,STOP,COUNT with COUNT a whole number in [2, 10000] (got {r:?})");
            }
            let n = r[2] as usize;
            (0..n).map(|i| r[0] + (r[1] - r[0]) * i as f64 / (n - 1) as f64).collect()
        }
        None => a.values.clone(),
    };
    if let Some(v) = values.iter().find(|v| !v.is_finite()) {
        bail!("--values: {v} is not a finite number");
    }
    let text = super::run::scene_text(&name)?;
    let stem = std::path::Path::new(&name).file_stem().map_or(name.clone(), |s| s.to_string_lossy().into_owned());
    let dir = a.out.unwrap_or_else(|| PathBuf::from("out").join(format!("sweep_{stem}")));
    let m = sweep::prepare(&dir, &text, &stem, &a.key, &values)?;
    match a.emit {
        Some(Emit::Slurm) => {
            let script = sweep::emit_slurm(&dir, &m, &a.time)?;
            println!("{} jobs written under {}", m.jobs.len(), dir.join("jobs").display());
            println!("submit: sbatch {}", script.display());
            println!("then:   phonation sweep --collect {}", dir.display());
            Ok(())
        }
        None => {
            let start = std::time::Instant::now();
            let (rows, t) = sweep::run_local(&dir, &m)?;
            println!("{} jobs in {:.2} s on {} threads", rows.len(), start.elapsed().as_secs_f64(), rayon::current_num_threads());
            print_sweep(&dir, &m.key, &rows, t)
        }
    }
}

fn print_sweep(dir: &std::path::Path, key: &str, rows: &[sweep::Row], t: Option<sweep::Threshold>) -> anyhow::Result<()> {
    let f = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
    let resolution = key == phonation::scene::resolution::KEY;
    println!(
        "{:>14} {:>6} {:>10} {:>12} {:>12} {:>8} {:>14}{}",
        "value",
        "osc.",
        "f0 (Hz)",
        "peak cm³/s",
        "mean cm³/s",
        "OQ",
        "wall s / ms",
        if resolution { "  f0 vs finest" } else { "" }
    );
    for r in rows {
        let state = if !r.done {
            "n/a"
        } else if r.oscillating {
            "yes"
        } else {
            "no"
        };
        let vs = if resolution { format!("  {:>+12}", r.f0_vs_finest.map_or("-".into(), |v| format!("{:+.2} %", 100.0 * v))) } else { String::new() };
        println!(
            "{:>14.6} {:>6} {:>10} {:>12} {:>12} {:>8} {:>14}{vs}",
            r.value,
            state,
            f(r.f0_hz, 2),
            f(r.peak_flow, 1),
            f(r.mean_flow, 1),
            f(r.open_quotient, 3),
            f(r.wall_s_per_simulated_ms, 4)
        );
    }
    match t {
        _ if resolution => {}
        Some(sweep::Threshold { below: Some(b), at_or_above }) => println!("phonation threshold between {b} and {at_or_above}"),
        Some(sweep::Threshold { below: None, at_or_above }) => println!("oscillates already at the lowest value, {at_or_above}"),
        None => println!("no oscillation at any value swept"),
    }
    let missing = rows.iter().filter(|r| !r.done).count();
    if missing > 0 {
        println!("{missing} job(s) have not written their results yet");
    }
    for n in ["sweep.csv", "sweep.json", "sweep.svg"] {
        println!("wrote {}", dir.join(n).display());
    }
    Ok(())
}
