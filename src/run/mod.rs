//! Headless run of a scene: steps the CPU solver, writes probes, snapshots and a summary, and
//! stops with a diagnosis (keeping every output written so far) when the run goes unstable.

use crate::fluid::{FluidSolver, Instability};
use crate::output::{fields, png_map, probes::ProbeWriter, vtk};
use crate::scene::FluidScene;
use crate::scene::build::SceneSummary;
use crate::scene::schema::Field;
use crate::state::state_hash;
use crate::step::Solver;
pub use backend::{Backend, FluidEngine, LatticeGasEngine, LevelSets, Readback, SolidEngine, is_hardware_gpu, pick_gpu};
pub use coupled_engine::CoupledEngine;
use serde::Serialize;
use std::path::{Path, PathBuf};

pub mod backend;
pub mod beam;
pub mod cavity;
pub mod checkpoint;
mod columns;
pub mod coupled;
mod coupled_engine;
pub mod driver;
pub mod flap;
mod glottal_record;
pub mod lattice_gas;
mod mirror;
pub mod particle_probes;
#[cfg(test)]
mod resume_tests;
pub mod schafer_turek;
pub mod solid;
pub mod surface;
pub mod sweep;
pub mod two_mass;
pub mod wake;

/// How a run ended.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum RunStatus {
    Completed,
    Unstable {
        diagnosis: String,
        step: u64,
        time_s: f64,
        /// Physical position of the offending node.
        position: [f64; 3],
        quantity: String,
        value: f64,
    },
}

#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    /// The backend that ran, with the adapter or thread count.
    pub backend: String,
    pub scene: SceneSummary,
    #[serde(flatten)]
    pub status: RunStatus,
    pub steps_done: u64,
    pub simulated_time_s: f64,
    /// Wall time of the steps (s), outputs excluded.
    pub wall_time_s: f64,
    pub node_updates_per_s: f64,
    pub mass_drift: f64,
    pub max_mach: f64,
    /// Fraction of the step's wall time per stage of the stage list.
    pub stage_fractions: Vec<(String, f64)>,
    /// BLAKE3 of the final state ([`crate::state::state_hash`]): equal for bit-identical runs.
    pub state_hash: String,
    /// The step this run resumed from (a checkpoint), if it did.
    pub resumed_from_step: Option<u64>,
    /// On the GPU: what came back from the device (whole states for snapshots, checkpoints and
    /// the end; the probes' nodes for each probe sample).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub readback: Option<backend::Readback>,
    /// One cylinder in a uniform stream: the Strouhal number at each probe against Williamson's
    /// ([`wake::wake_report`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wake: Option<wake::WakeReport>,
    /// The lid-driven square cavity: its centreline velocities against Ghia et al.'s
    /// ([`cavity::cavity_report`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cavity: Option<cavity::CavityReport>,
    pub files: Vec<PathBuf>,
}

/// Options that override the scene file.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Run this many steps instead of the scene's duration.
    pub steps: Option<u64>,
    pub show_progress: bool,
    pub backend: Backend,
    /// Where a method-2 scene on the GPU asks its level-set questions (ignored elsewhere).
    pub level_sets: LevelSets,
    /// Checkpoints to write and the one to continue from.
    pub checkpoint: checkpoint::Checkpointing,
    /// Stop after this step, as if the run were killed there (the output schedule stays that
    /// of the whole run; a checkpoint written before continues it).
    pub stop_at: Option<u64>,
}

pub(crate) fn snapshot(s: &FluidSolver, scene: &FluidScene, dir: &Path, k: u64, files: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for &f in &scene.file.output.png_fields {
        let name = format!("{:?}", f).to_lowercase();
        let path = dir.join(format!("snapshot_{k:03}_{name}.png"));
        let sl = fields::slice(s, &scene.units, f);
        png_map::write_png(&path, &sl, matches!(f, Field::Vorticity | Field::Pressure))?;
        files.push(path);
    }
    if scene.file.output.vtk {
        let path = dir.join(format!("snapshot_{k:03}.vtk"));
        vtk::write_vtk(&path, s, &scene.units, &format!("{} step {}", scene.file.name, s.step_count))?;
        files.push(path);
    }
    Ok(())
}

/// Runs `scene`, writing into `dir` (created if needed). Returns the report, also written as
/// `summary.json`; an unstable run is reported in it, not as an `Err`.
pub fn run_scene(scene: &FluidScene, dir: &Path, opts: &RunOptions) -> anyhow::Result<RunReport> {
    let ck = &opts.checkpoint;
    ck.validate()?;
    let units = scene.units;
    let total = opts.checkpoint.total(opts.steps, scene.steps);
    let nv = crate::fluid::Equilibrium::new(scene.set.clone(), scene.file.gas.model).values_per_node();
    let mut record = None;
    let mut engine = FluidEngine::for_scene(opts.backend, scene.grid.len(), nv, || {
        let mut solver = scene.build_solver();
        std::fs::create_dir_all(dir)?;
        record = ck.restore(&mut solver, dir)?.cloned();
        Ok(solver)
    })?;
    if scene.file.numerics.storage == Some(crate::scene::schema::PopulationStorage::F32) {
        engine = engine.with_f32_storage();
    }
    let resumed = record.is_some();
    let resumed_from_step = resumed.then_some(ck.resume.as_ref().map_or(0, |c| c.step));
    let mut files = vec![dir.join("probes.csv")];
    let mut probes = ProbeWriter::open(&files[0], engine.mirror(), &scene.probes, resumed)?;
    let probe_nodes = probes.nodes();
    let snaps = scene.file.output.snapshots;
    let snap_every = total.checked_div(snaps).map_or(u64::MAX, |k| k.max(1));
    let (m0, mut k_snap) = match &record {
        Some(r) => {
            files.extend(checkpoint::names(&r["files"]).into_iter().map(|n| dir.join(n)));
            (checkpoint::from_bits(&r["m0"], "m0")?[0], r["k_snap"].as_u64().unwrap_or(0))
        }
        None => {
            probes.sample(engine.mirror(), &units)?;
            (engine.mirror().totals().mass, 0)
        }
    };
    let progress = opts.show_progress.then_some("steps");
    let outcome = driver::drive_until(&mut engine, total, opts.stop_at, &[scene.file.output.probe_every, snap_every, ck.period()], progress, |e, t| {
        // A probe sample brings back the probes' nodes only; snapshots and checkpoints the
        // state. A read that fails writes nothing: the next advance (or the end) reports it.
        if t.hit[0] || t.last {
            let Ok(s) = e.state_at(&probe_nodes) else { return Ok(()) };
            probes.sample(s, &units)?;
        }
        if t.hit[1] && k_snap < snaps {
            let Ok(s) = e.state() else { return Ok(()) };
            k_snap += 1;
            snapshot(s, scene, dir, k_snap, &mut files)?;
        }
        if t.hit[2] {
            let Ok(s) = e.state() else { return Ok(()) };
            let record = serde_json::json!({"m0": checkpoint::bits(&[m0]), "k_snap": k_snap, "files": checkpoint::file_names(&files[1..])});
            ck.save(dir, t.step, total, s, record, &["probes.csv"])?;
        }
        Ok(())
    })?;
    // a read that failed at the last event has no advance after it to report it
    let instability = outcome.instability.clone().or_else(|| engine.read_failure().cloned());
    let readback = engine.is_gpu().then(|| engine.readback());
    let stage_fractions = engine.stage_shares().into_iter().map(|(n, f)| (n.to_string(), f)).collect();
    let name = engine.name.clone();
    // A final snapshot of whatever state the run reached (if unstable, the last one brought
    // back from a GPU, the last finite one on the CPU).
    let s = &engine.into_solver();
    let status = match &instability {
        Some(e) => {
            snapshot(s, scene, dir, 999, &mut files)?;
            unstable(e, scene)
        }
        None => RunStatus::Completed,
    };
    let wall = outcome.wall_s;
    let steps_done = s.step_count;
    let steps_here = steps_done - resumed_from_step.unwrap_or(0);
    let mut report = RunReport {
        backend: name,
        scene: scene.summary(),
        status,
        steps_done,
        simulated_time_s: units.time_to_physical(s.time),
        wall_time_s: wall,
        node_updates_per_s: steps_here as f64 * s.layout.fluid_count as f64 / wall.max(1e-9),
        mass_drift: (s.totals().mass - m0) / m0,
        max_mach: s.max_mach(),
        stage_fractions,
        state_hash: state_hash(s),
        resumed_from_step,
        readback,
        wake: wake::wake_report(scene, &dir.join("probes.csv"))?,
        cavity: cavity::cavity_report(scene, s),
        files,
    };
    if ck.writes() {
        report.files.push(dir.join(checkpoint::FILE_NAME));
    }
    report.files.push(write_summary(dir, &report)?);
    Ok(report)
}

/// Writes `report` as `dir/summary.json` and returns the path.
pub(crate) fn write_summary(dir: &Path, report: &impl Serialize) -> anyhow::Result<PathBuf> {
    let summary = dir.join("summary.json");
    std::fs::write(&summary, serde_json::to_string_pretty(report)?)?;
    Ok(summary)
}

fn unstable(e: &Instability, scene: &FluidScene) -> RunStatus {
    let u = &scene.units;
    let node = e.node().unwrap_or_default();
    let pos = std::array::from_fn(|a| if a < scene.grid.dim { (node[a] as f64 + 0.5) * u.dx } else { 0.0 });
    RunStatus::Unstable {
        diagnosis: e.to_string(),
        step: e.step,
        time_s: u.time_to_physical(e.time),
        position: pos,
        quantity: e.quantity.to_string(),
        value: e.value,
    }
}
