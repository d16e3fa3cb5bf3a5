//! `phonation run`, `check` and `scenes`: every kind of scene file, read and dispatched.

use anyhow::{Context, bail};
use phonation::run::checkpoint::{Checkpoint, Checkpointing};
use phonation::run::{Backend, LevelSets, RunOptions, RunStatus, run_scene};
use phonation::scene::coupled::CoupledScene;
use phonation::scene::lattice_gas::LatticeGasScene;
use phonation::scene::solid::SolidScene;
use phonation::scene::two_mass::TwoMassScene;
use phonation::scene::{self, FluidScene, Scene, SceneKind};
use std::path::{Path, PathBuf};

pub fn scene_text(arg: &str) -> anyhow::Result<String> {
    if let Some(t) = scene::builtin(arg) {
        return Ok(t.to_string());
    }
    std::fs::read_to_string(arg).with_context(|| {
        format!("reading scene file {arg} (not a built-in scene either: {})", scene::builtins().map(|(n, _)| *n).collect::<Vec<_>>().join(", "))
    })
}

/// What `phonation run` was asked.
pub struct RunArgs {
    pub name: Option<String>,
    pub out: Option<PathBuf>,
    pub steps: Option<u64>,
    pub backend: Backend,
    pub level_sets: LevelSets,
    pub checkpoint_every: Option<u64>,
    pub resume: Option<PathBuf>,
    pub stop_at: Option<u64>,
}

/// Run a scene file or a built-in scene and write its outputs (or continue from a checkpoint).
pub fn run(a: RunArgs) -> anyhow::Result<()> {
    let resume = match &a.resume {
        Some(path) => Some(Checkpoint::read(path)?),
        None => None,
    };
    let text = match (&a.name, &resume) {
        (Some(name), Some(ck)) => {
            let t = scene_text(name)?;
            ck.check_scene(&t)?;
            t
        }
        (None, Some(ck)) => ck.scene_text.clone(),
        (name, None) => scene_text(name.as_deref().unwrap_or(scene::DEFAULT_SCENE))?,
    };
    let scene = Scene::read(&text)?;
    let dir = match (a.out, &a.resume) {
        (Some(d), _) => d,
        (None, Some(p)) => p.parent().map(Path::to_path_buf).unwrap_or_default(),
        (None, None) => PathBuf::from("out").join(scene.name()),
    };
    if let Some(ck) = &resume {
        eprintln!("resuming {} from step {} ({})", scene.name(), ck.step, ck.path.display());
        if a.steps.is_some_and(|s| s <= ck.step) {
            bail!("--steps: the run is to go beyond the checkpoint's step {}, got {}", ck.step, a.steps.unwrap());
        }
    }
    let opts = RunOptions {
        steps: a.steps,
        show_progress: true,
        backend: a.backend,
        level_sets: a.level_sets,
        checkpoint: Checkpointing { every: a.checkpoint_every, resume, scene_text: text },
        stop_at: a.stop_at,
    };
    match scene {
        Scene::Fluid(sc) => run_fluid(&sc, &dir, &opts),
        Scene::Solid(sc) => run_solid(&sc, &dir, &opts),
        Scene::LatticeGas(sc) => run_lattice_gas(&sc, &dir, &opts),
        Scene::Coupled(sc) => run_coupled(&sc, &dir, &opts),
        Scene::TwoMass(sc) => {
            if opts.checkpoint.every.is_some() || opts.checkpoint.resume.is_some() || opts.stop_at.is_some() {
                bail!("--checkpoint-every / --resume / --stop-at: a two-mass run takes seconds; it has no checkpoints");
            }
            run_two_mass(&sc, &dir, a.steps, a.backend)
        }
    }
}

fn run_two_mass(sc: &TwoMassScene, dir: &Path, steps: Option<u64>, backend: Backend) -> anyhow::Result<()> {
    if steps.is_some() {
        bail!("--steps: a two-mass scene runs for its `two_mass.duration`; set that instead");
    }
    if backend == Backend::Gpu {
        bail!("--backend gpu: the two-mass model is an ODE of four unknowns and runs on the CPU");
    }
    let s = &sc.file.two_mass;
    eprintln!(
        "two-mass scene {}: lung pressure {:.1} dyn/cm² ({:.2} cmH₂O), {} s at {} Hz ({} RK4 steps)",
        sc.file.name,
        s.lung_pressure,
        s.lung_pressure / phonation::two_mass::CM_H2O,
        s.duration,
        s.sample_rate,
        sc.steps
    );
    let r = phonation::run::two_mass::run_two_mass_scene(sc, dir)?;
    eprintln!("{} steps in {:.3} s wall; max glottal area {:.4} cm², closed {:.0} % of the time", r.steps, r.wall_s, r.max_area, 100.0 * r.closed_fraction);
    if let Some(v) = &r.voice {
        super::voice::print_voice(v);
    }
    if let Some(rf) = &r.reference {
        let pct = |e: Option<f64>| e.map_or("no oscillation".to_string(), |e| format!("{:+.1} %", 100.0 * e));
        eprintln!(
            "against Ishizaka & Flanagan at 8 cmH₂O (f0 {} Hz, peak flow {} cm³/s, OQ {}): f0 {}, peak flow {}, OQ {}",
            rf.f0_hz,
            rf.peak_flow,
            rf.open_quotient,
            pct(rf.f0_error),
            pct(rf.peak_flow_error),
            pct(rf.open_quotient_error)
        );
    }
    eprintln!("outputs in {}", dir.display());
    Ok(())
}

fn run_coupled(sc: &CoupledScene, dir: &Path, opts: &RunOptions) -> anyhow::Result<()> {
    eprintln!(
        "coupled scene {}: {:?} nodes, about {} particles, {} coupling",
        sc.fluid.file.name,
        sc.fluid.grid.n,
        sc.solid.estimated_particles,
        sc.coupling.method.name()
    );
    let r = phonation::run::coupled::run_coupled_scene(sc, dir, opts)?;
    eprintln!("backend: {}; scene built in {:.1} s", r.backend, r.build_s);
    eprintln!(
        "{} particles, {} solid sub-steps per step; {} steps, {:.4e} s simulated in {:.1} s wall ({:.1} coupled steps/s); final force {:?}; max displacement {:.3e}; fluid mass drift {:.2e}",
        r.particles, r.substeps, r.steps, r.simulated_s, r.wall_s, r.coupled_steps_per_s, r.final_forces, r.max_displacement, r.fluid_mass_drift
    );
    eprintln!("stage shares: {}", r.stage_shares.iter().map(|(n, s)| format!("{n} {:.0}%", 100.0 * s)).collect::<Vec<_>>().join(", "));
    if let Some(cg) = r.solid_cg {
        eprintln!(
            "implicit solid: {} CG solves, {:.1} iterations on average, {} at most, {} short of the tolerance (largest relative residual {:.2e})",
            cg.solves,
            cg.mean_iterations(),
            cg.max_iterations,
            cg.unconverged,
            cg.worst_relative_residual
        );
    }
    for p in &r.particle_probes {
        eprintln!("{p}");
    }
    if let Some(f) = &r.flap {
        let show = |v: Option<f64>, (lo, hi): (f64, f64), inside: bool| match v {
            Some(v) => format!("{v:.4} ({} {lo:.3}–{hi:.3})", if inside { "inside" } else { "outside" }),
            None => format!("none (fewer than two cycles; envelope {lo:.3}–{hi:.3})"),
        };
        eprintln!(
            "Wall flap (Re = {:.1}), tip probe {} over the second half: frequency {}, largest displacement {}",
            f.reynolds,
            f.tip_probe,
            show(f.frequency, f.frequency_band, f.frequency_in_band),
            show(f.tip_displacement, f.tip_displacement_band, f.tip_displacement_in_band)
        );
    }
    if let Some(st) = &r.schafer_turek {
        eprintln!(
            "Schäfer–Turek 2D-1 (Re = {:.1}; forces over {:.3}–{:.3} s, Δp at the end): C_D {:.4} ({:+.2} % against {:.4}), C_L {:.4}, Δp {:.4e} ({:+.2} % against {:.4e})",
            st.reynolds,
            st.averaged_from_s,
            st.at_time_s,
            st.drag_coefficient,
            100.0 * st.drag_error,
            phonation::run::schafer_turek::DRAG_COEFFICIENT,
            st.lift_coefficient,
            st.pressure_drop,
            100.0 * st.pressure_drop_error,
            st.pressure_drop_reference
        );
    }
    eprintln!("state hash {} (BLAKE3 of the final state: equal for bit-identical runs)", r.state_hash);
    eprintln!("outputs in {}", dir.display());
    if let Some(d) = r.instability {
        bail!("run stopped: {d} (outputs written so far are kept in {})", dir.display());
    }
    Ok(())
}

fn run_lattice_gas(sc: &LatticeGasScene, dir: &Path, opts: &RunOptions) -> anyhow::Result<()> {
    let lg = &sc.file.lattice_gas;
    eprintln!("lattice-gas scene {}: {:?} cells, fill {}, p = {}", sc.file.name, lg.cells, lg.density, lg.interference);
    let r = phonation::run::lattice_gas::run_lattice_gas_scene(sc, dir, opts)?;
    eprintln!("backend: {}", r.backend);
    eprintln!("{} steps in {:.1} s ({:.3e} site updates/s); particles {} → {}", r.steps, r.wall_s, r.site_updates_per_s, r.particles_start, r.particles_end);
    match (r.wake_peak, r.strouhal) {
        (Some(p), Some(st)) => eprintln!("wake: periodic shedding, f = {:.4e} /step ({:.1} periods), St = {st:.3}", p.frequency, p.periods),
        (Some(p), None) => eprintln!("wake: no periodic shedding (peak prominence {:.1}, {:.1} periods)", p.prominence, p.periods),
        _ => {}
    }
    eprintln!("state hash {} (BLAKE3 of the final state: equal for bit-identical runs)", r.state_hash);
    eprintln!("outputs in {}", dir.display());
    Ok(())
}

fn run_solid(sc: &SolidScene, dir: &Path, opts: &RunOptions) -> anyhow::Result<()> {
    eprintln!("solid scene {}: about {} particles, {:?} integrator", sc.file.name, sc.estimated_particles, sc.file.solid.integrator);
    let r = phonation::run::solid::run_solid_scene(sc, dir, opts)?;
    eprintln!("backend: {}", r.backend);
    eprintln!(
        "{} particles, {} bonds, Δt = {:.3e} (explicit limit {:.3e}), {} steps, {:.4e} s simulated in {:.1} s wall ({:.3e} particle updates/s), energy drift {:.2e}",
        r.particles, r.bonds, r.dt, r.explicit_limit, r.steps, r.simulated_time, r.wall_s, r.particle_updates_per_s, r.energy_drift
    );
    if let Some(b) = &r.beam {
        print_beam(b);
    }
    eprintln!("state hash {} (BLAKE3 of the final state: equal for bit-identical runs)", r.state_hash);
    eprintln!("outputs in {}", dir.display());
    if let Some(d) = r.instability {
        bail!("run stopped: {d} (outputs written so far are kept in {})", dir.display());
    }
    Ok(())
}

fn run_fluid(sc: &FluidScene, dir: &Path, opts: &RunOptions) -> anyhow::Result<()> {
    let steps = opts.steps;
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
    let report = run_scene(sc, dir, opts)?;
    eprintln!("backend: {}", report.backend);
    eprintln!(
        "{} steps, {:.4e} s simulated in {:.1} s wall ({:.3e} node updates/s), mass drift {:.2e}, max Mach {:.3}",
        report.steps_done, report.simulated_time_s, report.wall_time_s, report.node_updates_per_s, report.mass_drift, report.max_mach
    );
    if let Some(w) = &report.wake {
        print_wake(w);
    }
    if let Some(c) = &report.cavity {
        let ghia = c.ghia_max_deviation.map_or(format!("Ghia et al.'s tables are at Re = {}: no comparison", phonation::run::cavity::GHIA_REYNOLDS), |d| {
            format!("largest |u − Ghia| {:.2} % of the lid's speed", 100.0 * d)
        });
        eprintln!("lid-driven cavity (side {}, lid {}, Re = {:.1}, {:.1} lid transits): {ghia}", c.side, c.lid_speed, c.reynolds, c.lid_transits);
    }
    eprintln!("state hash {} (BLAKE3 of the final state: equal for bit-identical runs)", report.state_hash);
    eprintln!("outputs in {}", dir.display());
    if let RunStatus::Unstable { diagnosis, .. } = &report.status {
        bail!("run stopped: {diagnosis} (outputs written so far are kept in {})", dir.display());
    }
    Ok(())
}

/// The beam's tip against beam theory: its period and, under a tip load, its deflection.
fn print_beam(b: &phonation::run::beam::BeamReport) {
    let t = &b.theory;
    let section = if t.dim == 2 { "plane strain".to_string() } else { format!("width {}", t.width) };
    eprintln!(
        "clamped beam (L = {} from x = {}, h = {}, {section}): beam theory's first period {:.4e} s",
        t.length, b.root_x, t.thickness, b.first_period_theory
    );
    let Some(probe) = &b.tip_probe else {
        eprintln!("  no probe holds the tip: nothing measured");
        return;
    };
    match &b.vibration {
        Some(v) => {
            eprintln!("  tip probe {probe}: period {:.4e} s over {} cycles, {:+.2} % against beam theory", v.period, v.cycles, 100.0 * v.error_vs_theory)
        }
        None => eprintln!("  tip probe {probe}: fewer than two cycles, no period"),
    }
    if let Some(l) = &b.tip_load
        && let (Some(d), Some(e)) = (l.deflection_end, l.error_vs_theory)
    {
        let swing = l.last_period_swing.map_or(String::new(), |s| format!(" (swinging {:.1} % of it over the last period)", 100.0 * s));
        eprintln!("  tip load {}: static deflection {:.4e} by beam theory, {d:.4e} at the end, {:+.2} %{swing}", l.load, l.deflection_theory, 100.0 * e);
    }
}

/// The wake's Strouhal number at each probe, against Williamson's where his fit holds.
fn print_wake(w: &phonation::run::wake::WakeReport) {
    let reference = match w.williamson_strouhal {
        Some(st) => format!("Williamson's St at Re = {:.1}: {st:.4}", w.reynolds),
        None => format!("Re = {:.1}, outside Williamson's fit (49–178)", w.reynolds),
    };
    eprintln!("wake of the cylinder (D = {}, U = {}; {}, from t = {:.3} s): {reference}", w.diameter, w.inflow_speed, w.transverse, w.from_time_s);
    for p in &w.probes {
        match (&p.shedding, p.error_vs_williamson) {
            (Some(s), err) => eprintln!(
                "  probe {}: St = {:.4} ({:.4} Hz, {} cycles){}",
                p.probe,
                s.strouhal,
                s.frequency,
                s.cycles,
                err.map_or(String::new(), |e| format!(", {:+.1} % against Williamson", 100.0 * e))
            ),
            (None, _) => eprintln!("  probe {}: no periodic shedding (fewer than three cycles)", p.probe),
        }
    }
}

/// Validate a scene and print what it resolves to.
pub fn check(name: String) -> anyhow::Result<()> {
    let summary = match Scene::read(&scene_text(&name)?)? {
        Scene::TwoMass(sc) => serde_json::to_value(&sc)?,
        Scene::Coupled(sc) => {
            // every check of a build but the air's lattice, which it does not allocate
            let mut v = serde_json::to_value(sc.resolve()?)?;
            v["name"] = serde_json::to_value(&sc.fluid.file.name)?;
            v["fluid"] = serde_json::to_value(sc.fluid.summary())?;
            v["method"] = serde_json::to_value(sc.coupling.method)?;
            v
        }
        Scene::LatticeGas(sc) => {
            let lg = &sc.file.lattice_gas;
            let cells: usize = lg.cells.iter().product();
            serde_json::json!({"name": sc.file.name, "cells": lg.cells, "sites": 16 * cells, "state_bytes": 48 * cells, "density": lg.density, "interference": lg.interference, "steps": lg.steps, "probe": sc.probe})
        }
        Scene::Solid(sc) => {
            let s = sc.build()?;
            serde_json::json!({"name": sc.file.name, "particles": s.particles.len(), "bonds": s.disc.bonds.len(), "dt": s.dt, "explicit_limit": s.explicit_limit, "integrator": s.options.integrator})
        }
        Scene::Fluid(sc) => serde_json::to_value(sc.summary())?,
    };
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}

/// List the built-in scenes.
pub fn scenes() {
    for (n, t) in scene::builtins() {
        let (tag, d) = match Scene::read(t) {
            Ok(s) => (
                match s.kind() {
                    SceneKind::Fluid => "",
                    SceneKind::Solid => "[solid] ",
                    SceneKind::LatticeGas => "[lattice gas] ",
                    SceneKind::Coupled => "[coupled] ",
                    SceneKind::TwoMass => "[two-mass] ",
                },
                s.description().to_string(),
            ),
            Err(e) => ("[broken] ", e.to_string()),
        };
        println!("{n:22} {tag}{d}");
    }
}
