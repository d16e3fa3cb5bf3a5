//! Headless run of a coupled scene (CPU): steps [`CoupledSolver`], writes `coupling.csv`
//! (forces on each body, displacements, momenta, fluid mass, uncovered/covered nodes — flushed
//! per row), fluid probes and snapshots, particle and surface VTK snapshots and `summary.json`. A run that
//! goes unstable stops with the diagnosis and keeps everything written so far (plus a last
//! snapshot of the last finite state).

use super::driver::{Outcome, Tick};
use super::glottal_record::{GLOTTAL_COLUMNS, GlottalRecord, glottal_from_values, glottal_values};
use super::{CoupledEngine, RunOptions, checkpoint};
use crate::analysis::voice::VoiceOptions;
use crate::coupling::CoupledSolver;
use crate::coupling::glottis::{GlottalSample, Glottis};
use crate::fluid::Totals;
use crate::output::probes::ProbeWriter;
use crate::output::voice::write_voice_outputs;
pub use crate::run::particle_probes::ParticleProbeReport;
use crate::run::particle_probes::probe_reports;
use crate::run::solid::write_vtk;
use crate::scene::coupled::CoupledScene;
use crate::solid::implicit::CgTally;
use crate::state::state_hash;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Serialize)]
pub struct CoupledReport {
    pub name: String,
    pub backend: String,
    pub method: String,
    pub nodes: [usize; 3],
    pub particles: usize,
    /// Solid sub-steps per fluid step.
    pub substeps: u32,
    /// Fluid (= coupled) step (s).
    pub dt: f64,
    pub steps: u64,
    pub simulated_s: f64,
    /// Wall time of the stepping (s).
    pub wall_s: f64,
    /// Wall time before the first step (s): the scene's solver built (particles, bonds, the
    /// solid's stable step, the air's lattice and first walls) and handed to the backend.
    pub build_s: f64,
    pub coupled_steps_per_s: f64,
    /// Each stage's share of the coupled step's wall time.
    pub stage_shares: Vec<(String, f64)>,
    /// The air's force on each body at the end (scene units; per unit depth in 2D).
    pub final_forces: Vec<[f64; 3]>,
    pub max_displacement: f64,
    pub fluid_mass_drift: f64,
    pub uncovered: usize,
    pub covered: usize,
    /// Method 2's momentum exchange summed over the run (on either backend), `None` for method 1.
    pub exchange: Option<ExchangeReport>,
    /// The implicit solid's CG solves of this run (method 2, either backend; a resumed run's
    /// since it resumed), `None` with the explicit solid.
    pub solid_cg: Option<CgTally>,
    /// Each particle probe (`coupling.probes`): its transverse displacement's oscillation over
    /// the second half of the run.
    pub particle_probes: Vec<ParticleProbeReport>,
    /// A glottis scene (two folds): what the glottis did and the voice measures.
    pub glottis: Option<GlottisReport>,
    /// The Schäfer–Turek 2D-1 channel: C_D and Δp against the benchmark
    /// ([`super::schafer_turek::schafer_turek_report`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub schafer_turek: Option<super::schafer_turek::SchaferTurekReport>,
    /// The Wall flexible flap: the tip's frequency and largest displacement against the
    /// published envelope ([`super::flap::flap_report`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flap: Option<super::flap::FlapReport>,
    /// None when the run finished; else what went wrong, where and when.
    pub instability: Option<String>,
    /// BLAKE3 of the final state ([`crate::state::state_hash`]): equal for bit-identical runs.
    pub state_hash: String,
    /// The step this run resumed from (a checkpoint), if it did.
    pub resumed_from_step: Option<u64>,
    /// GPU runs: what came back from the device for the outputs (None on the CPU).
    pub readback: Option<super::Readback>,
    pub files: Vec<PathBuf>,
}

/// Method 2's exchange over the run (scene units; per unit depth in 2D): see
/// [`crate::coupling::conserving::Exchange`].
#[derive(Clone, Debug, Serialize)]
pub struct ExchangeReport {
    /// Momentum handed to walls that are no coupled body (rigid obstacles, faces).
    pub momentum_to_walls: [f64; 3],
    /// Momentum the bodies received from the nodes they covered, less what the nodes they
    /// uncovered took.
    pub node_changes: [f64; 3],
    /// Mass the walls took out of the air (lattice units; ≈ 0 for closed bodies).
    pub mass_to_walls: f64,
    /// Σ (p − u_w m): the momentum the walls took in their own frame (a diagnostic).
    pub wall_frame_momentum: [f64; 3],
}

/// What the glottis of a coupled run did (scene units, cgs: cm, cm², cm³/s).
#[derive(Clone, Debug, Serialize)]
pub struct GlottisReport {
    pub lung_pressure: Option<f64>,
    pub samples: usize,
    /// Glottal area at the start, its smallest and largest value.
    pub initial_area: f64,
    pub min_area: f64,
    pub max_area: f64,
    /// Fraction of the samples with the folds touching (gap ≤ 0).
    pub closed_fraction: f64,
    /// Fraction of the samples with no fluid node in the narrowest section: the glottis closed
    /// at the lattice's resolution (a gap narrower than about a cell), with zero flow.
    pub no_flow_fraction: f64,
    pub mean_flow: f64,
    pub max_flow: f64,
    pub largest_lower_margin: f64,
    pub largest_upper_margin: f64,
    pub oscillating: bool,
    pub f0_hz: Option<f64>,
    pub open_quotient: Option<f64>,
    /// (max − min)/mean AC flow of the last five pulses: ≤ 0.1 for a settled oscillation.
    pub amplitude_spread_last5: Option<f64>,
    /// Time (s) by which the lower margin's lateral motion leads the upper one's over the
    /// analysed window (positive: the lower margin opens and closes first): the lag of the
    /// margins' best cross-correlation.
    pub lower_margin_lead_s: Option<f64>,
    /// The margins' vertical phase difference at f0 (as in voice.json): the lower margin's
    /// fundamental ahead of the upper one's, in degrees and seconds.
    pub vertical_phase: Option<crate::analysis::lag::PhaseLead>,
    /// The air's work on the folds per cycle over the voice window, by part and in all, against
    /// their peak kinetic energy (as in voice.json).
    pub aerodynamic_energy_transfer: Option<crate::output::voice::EnergyTransfer>,
    /// The medial surface's shape at the pulses' closures (as in voice.json): from below when
    /// the lower margin is the nearer to the mid-line.
    pub closure_shape: Option<crate::analysis::closure::ClosureShape>,
    /// Why there are no voice measures (too short, steady, …).
    pub no_voice: Option<String>,
}

/// The particles of each of the scene's particle probes (`coupling.probes`; the build refused
/// a probe that selects none).
fn particle_probes(sc: &CoupledScene, c: &CoupledSolver) -> Vec<(String, Vec<usize>)> {
    sc.coupling.probes.iter().enumerate().map(|(k, pr)| (pr.name.clone(), sc.probe_particles(&c.solid.particles, k))).collect()
}

fn csv_header(c: &CoupledSolver, probes: &[(String, Vec<usize>)]) -> String {
    let mut h = String::from("step,time_s");
    for b in &c.bodies {
        let k = b.surface.body;
        h += &format!(",force_x_{k},force_y_{k},mean_dx_{k},mean_dy_{k}");
    }
    for (name, _) in probes {
        h += &format!(",{name}_dx,{name}_dy");
    }
    h += ",max_displacement,fluid_px,fluid_py,solid_px,solid_py,transit_px,transit_py,fluid_mass,uncovered,covered";
    if implicit(c) {
        h += ",cg_iterations,cg_residual";
    }
    h
}

/// Whether the solid steps implicitly (method 2): `coupling.csv` then carries the last CG
/// solve's iterations and relative residual.
fn implicit(c: &CoupledSolver) -> bool {
    c.solid.options.integrator == crate::solid::Integrator::Implicit
}

/// Each particle probe's mean displacement.
fn probe_displacements(c: &CoupledSolver, probes: &[(String, Vec<usize>)]) -> Vec<glam::DVec3> {
    let p = &c.solid.particles;
    probes.iter().map(|(_, sel)| sel.iter().map(|&i| p.position[i] - p.reference[i]).sum::<glam::DVec3>() / sel.len() as f64).collect()
}

/// One row of `coupling.csv`; `probe_d`: each particle probe's displacement
/// ([`probe_displacements`]); `cg`: the last CG solve's iterations and relative residual.
fn csv_row(c: &CoupledSolver, probe_d: &[glam::DVec3], totals: &Totals, cg: (usize, f64)) -> String {
    let p = &c.solid.particles;
    let mut r = format!("{},{:.9e}", c.step_count, c.time);
    for (k, b) in c.bodies.iter().enumerate() {
        let f = c.forces.total.get(k).copied().unwrap_or_default();
        let (mut d, mut n) = (glam::DVec3::ZERO, 0.0);
        for i in 0..p.len() {
            if p.body[i] == b.surface.body {
                d += p.position[i] - p.reference[i];
                n += 1.0;
            }
        }
        d /= n;
        r += &format!(",{:.9e},{:.9e},{:.9e},{:.9e}", f.x, f.y, d.x, d.y);
    }
    for d in probe_d {
        r += &format!(",{:.9e},{:.9e}", d.x, d.y);
    }
    let max_d = (0..p.len()).map(|i| (p.position[i] - p.reference[i]).length()).fold(0.0, f64::max);
    let fm = c.fluid_momentum(totals);
    let sm = p.linear_momentum();
    let tm = c.added_mass_momentum();
    r += &format!(
        ",{max_d:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.12e},{},{}",
        fm.x, fm.y, sm.x, sm.y, tm.x, tm.y, totals.mass, c.geometry.uncovered, c.geometry.covered
    );
    if implicit(c) {
        r += &format!(",{},{:.3e}", cg.0, cg.1);
    }
    r
}

/// What a coupled run writes as it goes — `coupling.csv`, the fluid probes, the glottal record,
/// the snapshots — each row flushed as it is written (a run that stops keeps them), with what
/// its summary and checkpoints need of them.
struct Outputs<'a> {
    sc: &'a CoupledScene,
    dir: &'a Path,
    csv: std::io::BufWriter<std::fs::File>,
    probes: ProbeWriter,
    glottal: Option<GlottalRecord>,
    particle_probes: Vec<(String, Vec<usize>)>,
    /// Each particle probe's transverse displacement, sampled every `output_every` steps.
    probe_samples: Vec<(f64, Vec<f64>)>,
    files: Vec<PathBuf>,
    /// The snapshots written.
    k_snap: u64,
    /// The air's mass at the start (the run's, not the resumed part's).
    m0: f64,
}

impl<'a> Outputs<'a> {
    /// The files of a run of `sc` into `dir` (continued when `resumed`), the glottal record
    /// for a glottis (`glottis`) sampled every `probe_every` steps.
    fn open(sc: &'a CoupledScene, dir: &'a Path, c: &CoupledSolver, glottis: bool, probe_every: u64, resumed: bool) -> anyhow::Result<Self> {
        let files = vec![dir.join("coupling.csv"), dir.join("probes.csv")];
        let csv = std::io::BufWriter::new(checkpoint::output_file(&files[0], resumed)?);
        let probes = ProbeWriter::open(&files[1], &c.fluid, &sc.fluid.probes, resumed)?;
        let mut out =
            Outputs { sc, dir, csv, probes, glottal: None, particle_probes: particle_probes(sc, c), probe_samples: Vec::new(), files, k_snap: 0, m0: 0.0 };
        if glottis {
            let path = out.glottal_path();
            out.glottal = Some(GlottalRecord::open(&path, c.dt() * probe_every as f64, resumed)?);
            out.files.push(path);
        }
        Ok(out)
    }

    fn glottal_path(&self) -> PathBuf {
        self.dir.join("glottal_flow.csv")
    }

    /// A fresh run's first rows: the header and the state at step 0.
    fn start(&mut self, c: &CoupledSolver, glottis: Option<&Glottis>) -> anyhow::Result<()> {
        writeln!(self.csv, "{}", csv_header(c, &self.particle_probes))?;
        let totals = c.fluid.totals();
        self.row(c, &totals, (0, 0.0), true)?;
        self.probes.sample(&c.fluid, &self.sc.fluid.units)?;
        if let (Some(g), Some(r)) = (glottis, &mut self.glottal) {
            r.push(g.sample(c))?;
        }
        self.m0 = totals.mass;
        Ok(())
    }

    /// A resumed run's record (`r`, the checkpoint's): the files, snapshots, glottal and
    /// particle-probe samples written before, the air's initial mass.
    fn resume(&mut self, r: &serde_json::Value) -> anyhow::Result<()> {
        self.files.extend(checkpoint::names(&r["files"]).into_iter().map(|n| self.dir.join(n)));
        if let Some(g) = &mut self.glottal {
            let v = checkpoint::from_bits(&r["glottal_samples"], "glottal_samples")?;
            // written before the air's power joined the record: 6 columns
            let columns = r["glottal_columns"].as_u64().unwrap_or(6) as usize;
            if columns != GLOTTAL_COLUMNS.len() {
                anyhow::bail!(
                    "--resume: the checkpoint's glottal record has {columns} columns and this version writes {} (glottal_flow.csv gained the air's power on the folds); rerun the scene from its start",
                    GLOTTAL_COLUMNS.len()
                );
            }
            g.samples = v.chunks_exact(GLOTTAL_COLUMNS.len()).map(glottal_from_values).collect();
        }
        self.m0 = checkpoint::from_bits(&r["m0"], "m0")?[0];
        self.k_snap = r["k_snap"].as_u64().unwrap_or(0);
        // the particle probes' samples before the checkpoint (absent from checkpoints written
        // before 2026-12-08: the analysis then starts at the resume, as it did)
        if !r["probe_samples"].is_null() {
            let v = checkpoint::from_bits(&r["probe_samples"], "probe_samples")?;
            let width = 1 + self.particle_probes.len();
            anyhow::ensure!(
                v.len().is_multiple_of(width),
                "checkpoint run record: probe_samples holds {} values, not a multiple of 1 + {} probes",
                v.len(),
                self.particle_probes.len()
            );
            self.probe_samples = v.chunks_exact(width).map(|c| (c[0], c[1..].to_vec())).collect();
        }
        Ok(())
    }

    /// A `coupling.csv` row of the state `c` (its last CG solve `cg`); `sampled`: a row of the
    /// uniform schedule (not the last step's extra row), whose probe displacements the
    /// oscillation's analysis takes.
    fn row(&mut self, c: &CoupledSolver, totals: &Totals, cg: (usize, f64), sampled: bool) -> std::io::Result<()> {
        let d = probe_displacements(c, &self.particle_probes);
        writeln!(self.csv, "{}", csv_row(c, &d, totals, cg))?;
        self.csv.flush()?;
        if sampled {
            self.probe_samples.push((c.time, d.iter().map(|d| d.y).collect()));
        }
        Ok(())
    }

    /// Snapshot `k`: the air's fields, the particles and the bodies' surfaces.
    fn snapshot(&mut self, c: &CoupledSolver, k: u64) -> std::io::Result<()> {
        super::snapshot(&c.fluid, &self.sc.fluid, self.dir, k, &mut self.files)?;
        let path = self.dir.join(format!("particles_{k:03}.vtk"));
        write_vtk(&c.solid, &path)?;
        self.files.push(path);
        let path = self.dir.join(format!("surface_{k:03}.vtk"));
        crate::output::mesh::write_mesh_vtk(&path, &super::surface::coupled_surface(c), &format!("phonation body surfaces t = {:.6e} s", c.time))?;
        self.files.push(path);
        Ok(())
    }

    /// What a checkpoint records of the outputs so that a resumed run continues them.
    fn checkpoint_record(&self) -> serde_json::Value {
        let glottal_path = self.glottal_path();
        let names = checkpoint::file_names(self.files[2..].iter().filter(|f| **f != glottal_path));
        let samples: Vec<f64> = self.glottal.iter().flat_map(|r| r.samples.iter().flat_map(glottal_values)).collect();
        // each particle-probe sample as (t, dy per probe), so a resumed run analyses the whole run
        let probe_samples: Vec<f64> = self.probe_samples.iter().flat_map(|(t, dy)| std::iter::once(*t).chain(dy.iter().copied())).collect();
        serde_json::json!({"m0": checkpoint::bits(&[self.m0]), "k_snap": self.k_snap, "files": names, "glottal_samples": checkpoint::bits(&samples), "glottal_columns": GLOTTAL_COLUMNS.len(), "probe_samples": checkpoint::bits(&probe_samples)})
    }

    /// The output files a checkpoint stands with.
    fn checkpointed_outputs(&self) -> Vec<&'static str> {
        let mut outputs = vec!["coupling.csv", "probes.csv"];
        if self.glottal.is_some() {
            outputs.push("glottal_flow.csv");
        }
        outputs
    }
}

/// Runs `sc` for its duration (or `opts.steps`), writing into `dir`, with checkpoints and
/// resume as `opts.checkpoint` says, on the backend `opts.backend` picks (the GPU runs method 2,
/// [`crate::gpu::coupled::GpuCoupled`]; `auto` takes it only on a hardware GPU).
pub fn run_coupled_scene(sc: &CoupledScene, dir: &Path, opts: &RunOptions) -> anyhow::Result<CoupledReport> {
    let ck = &opts.checkpoint;
    ck.validate()?;
    let built = std::time::Instant::now();
    let mut c = sc.build()?;
    std::fs::create_dir_all(dir)?;
    let record = ck.restore(&mut c, dir)?.cloned();
    let mut engine = CoupledEngine::new(opts.backend, c, sc.solid.file.solid.cg_tolerance)?;
    engine.ask_level_sets(opts.level_sets);
    let build_s = built.elapsed().as_secs_f64();
    let c = engine.solver();
    let resumed_from_step = record.is_some().then_some(c.step_count);
    let schedule = Schedule::of(sc, opts);
    let glottis = sc.glottis(c);
    let mut out = Outputs::open(sc, dir, c, glottis.is_some(), schedule.probe_every, record.is_some())?;
    match &record {
        Some(r) => out.resume(r)?,
        None => out.start(c, glottis.as_ref())?,
    }
    let events = Events { schedule, glottis: glottis.as_ref(), probe_nodes: out.probes.nodes(), checkpoint: ck };
    let progress = opts.show_progress.then_some("coupled steps");
    let outcome = super::driver::drive_until(&mut engine, schedule.total, opts.stop_at, &schedule.periods(ck), progress, |e, t| out.at(e, t, &events))?;
    if ck.writes() {
        out.files.push(dir.join(checkpoint::FILE_NAME));
    }
    out.finish(&mut engine, outcome, build_s, resumed_from_step)
}

/// When a coupled run writes what (steps): `coupling.csv`'s rows every `every`, the fluid
/// probes and the glottal record every `probe_every`, `snaps` snapshots spread over the run.
#[derive(Clone, Copy, Debug)]
struct Schedule {
    total: u64,
    every: u64,
    probe_every: u64,
    snaps: u64,
}

impl Schedule {
    /// The schedule of `sc` run as `opts` says (its duration or `opts.steps`).
    fn of(sc: &CoupledScene, opts: &RunOptions) -> Self {
        Schedule {
            total: opts.checkpoint.total(opts.steps, sc.fluid.steps),
            every: sc.coupling.output_every.unwrap_or(10),
            probe_every: sc.fluid.file.output.probe_every.max(1),
            snaps: sc.fluid.file.output.snapshots,
        }
    }

    /// The run loop's periods, in the order [`Outputs::at`] reads its tick's hits: the csv
    /// rows, the probes, the snapshots, the checkpoints.
    fn periods(&self, ck: &checkpoint::Checkpointing) -> [u64; 4] {
        // the snapshots spread evenly over the run (never, without any)
        let snap_every = self.total.checked_div(self.snaps).map_or(u64::MAX, |k| k.max(1));
        [self.every, self.probe_every, snap_every, ck.period()]
    }
}

/// What the output events of a run read besides the state: the schedule, the glottis (a
/// glottis scene), the fluid probes' nodes and the checkpoints to write.
struct Events<'a> {
    schedule: Schedule,
    glottis: Option<&'a Glottis>,
    probe_nodes: Vec<usize>,
    checkpoint: &'a checkpoint::Checkpointing,
}

impl Outputs<'_> {
    /// The writes of one event of the run loop (`t.hit` in [`Schedule::periods`]' order). On
    /// the GPU each read brings back what it needs (see run::coupled_engine); a read that fails
    /// writes nothing more at this event, and the next advance (or the end) stops the run with
    /// it.
    fn at(&mut self, e: &mut CoupledEngine, t: &Tick, ev: &Events) -> anyhow::Result<()> {
        let answered = (!(t.hit[0] || t.last) || self.csv_event(e, t.hit[0])?)
            && (!(t.hit[1] || t.last) || self.probe_event(e, t.hit[1], ev)?)
            && (!(t.hit[2] && self.k_snap < ev.schedule.snaps) || self.snapshot_event(e)?);
        if answered && t.hit[3] {
            let Ok(c) = e.state() else { return Ok(()) };
            ev.checkpoint.save(self.dir, t.step, ev.schedule.total, c, self.checkpoint_record(), &self.checkpointed_outputs())?;
        }
        Ok(())
    }

    /// A `coupling.csv` row (`sampled`: of the uniform schedule, not the last step's extra
    /// row: the oscillation needs a constant interval); false where the device did not answer.
    fn csv_event(&mut self, e: &mut CoupledEngine, sampled: bool) -> anyhow::Result<bool> {
        let Ok(totals) = e.totals() else { return Ok(false) };
        let (_, last_cg) = e.cg();
        let Ok(c) = e.observe(|_| Vec::new()) else { return Ok(false) };
        self.row(c, &totals, last_cg, sampled)?;
        Ok(true)
    }

    /// The fluid probes' row and (`sampled`: of the uniform schedule, which the voice measures
    /// need) the glottal record's sample, the glottis's narrowest section read with the probes'
    /// nodes; false where the device did not answer.
    fn probe_event(&mut self, e: &mut CoupledEngine, sampled: bool, ev: &Events) -> anyhow::Result<bool> {
        let mut section = None;
        let Ok(c) = e.observe(|c| {
            let mut nodes = ev.probe_nodes.clone();
            if let Some(g) = ev.glottis {
                let s = g.section(c);
                nodes.extend(&s.nodes);
                section = Some(s);
            }
            nodes
        }) else {
            return Ok(false);
        };
        self.probes.sample(&c.fluid, &self.sc.fluid.units)?;
        if sampled && let Some(r) = &mut self.glottal {
            let s = section.unwrap_or_else(|| ev.glottis.expect("a glottal record has a glottis").section(c));
            r.push(s.sample(&c.fluid))?;
        }
        Ok(true)
    }

    /// The next snapshot; false where the device did not answer.
    fn snapshot_event(&mut self, e: &mut CoupledEngine) -> anyhow::Result<bool> {
        let Ok(c) = e.state() else { return Ok(false) };
        self.k_snap += 1;
        self.snapshot(c, self.k_snap)?;
        Ok(true)
    }

    /// The run's end: a last snapshot after an instability, the voice outputs of a glottis,
    /// and the report, written as `summary.json`.
    fn finish(mut self, engine: &mut CoupledEngine, outcome: Outcome, build_s: f64, resumed_from_step: Option<u64>) -> anyhow::Result<CoupledReport> {
        let (sc, dir) = (self.sc, self.dir);
        let wall = outcome.wall_s;
        let instability = outcome.instability;
        // the air's mass at the end from the same sums as the csv rows (on the GPU, the device's)
        let final_mass = engine.totals().map(|t| t.mass).unwrap_or(f64::NAN);
        // the whole state of the step reached (after a device failure: the last one brought back)
        let _ = engine.state();
        let readback = engine.is_gpu().then(|| engine.readback());
        let (cg_tally, _) = engine.cg();
        let c = engine.solver();
        if instability.is_some() {
            self.snapshot(c, 999)?;
        }
        let glottis_report = match &self.glottal {
            Some(r) => Some(glottal_outputs(sc, dir, r, &mut self.files)?),
            None => None,
        };
        let p = &c.solid.particles;
        let steps_here = c.step_count - resumed_from_step.unwrap_or(0);
        let particle_probes = probe_reports(&self.particle_probes.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>(), &self.probe_samples, 0.5);
        let flap = super::flap::flap_report(sc, &particle_probes);
        let m0 = self.m0;
        let mut report = CoupledReport {
            name: sc.fluid.file.name.clone(),
            backend: engine.name.clone(),
            method: sc.coupling.method.name().into(),
            nodes: sc.fluid.grid.n,
            particles: p.len(),
            substeps: c.substeps,
            dt: c.dt(),
            steps: c.step_count,
            simulated_s: c.time,
            wall_s: wall,
            build_s,
            coupled_steps_per_s: steps_here as f64 / wall.max(1e-9),
            stage_shares: crate::step::Solver::stage_shares(engine).into_iter().map(|(n, s)| (n.to_string(), s)).collect(),
            final_forces: c.forces.total.iter().map(|f| f.to_array()).collect(),
            max_displacement: (0..p.len()).map(|i| (p.position[i] - p.reference[i]).length()).fold(0.0, f64::max),
            fluid_mass_drift: (final_mass - m0) / m0,
            readback,
            uncovered: c.geometry.uncovered,
            covered: c.geometry.covered,
            exchange: c.exchange().map(|e| ExchangeReport {
                momentum_to_walls: e.walls.to_array(),
                node_changes: e.node_changes.to_array(),
                mass_to_walls: e.mass_to_walls,
                wall_frame_momentum: e.wall_frame.to_array(),
            }),
            solid_cg: implicit(c).then_some(cg_tally),
            particle_probes,
            glottis: glottis_report,
            schafer_turek: super::schafer_turek::schafer_turek_report(sc, c, &dir.join("coupling.csv"))?,
            flap,
            instability: instability.map(|e| e.to_string()),
            state_hash: state_hash(c),
            resumed_from_step,
            files: self.files,
        };
        report.files.push(super::write_summary(dir, &report)?);
        Ok(report)
    }
}

/// Writes the voice outputs of a glottis run (what it has, even when it
/// stopped early) and sums up what the glottis did.
fn glottal_outputs(sc: &CoupledScene, dir: &Path, record: &GlottalRecord, files: &mut Vec<PathBuf>) -> anyhow::Result<GlottisReport> {
    let series = record.series();
    let lung = sc.lung_pressure();
    let yardstick = lung
        .and_then(crate::run::two_mass::yardstick)
        .map(|m| serde_json::json!({ "f0_hz": m.f0_autocorrelation_hz, "peak_flow_cm3_s": m.peak_flow, "open_quotient": m.open_quotient }));
    let extra = serde_json::json!({
        "scene": sc.fluid.file.name,
        "model": if sc.fluid.grid.dim == 3 {
            "3D coupled glottis (seed §3.4.3): FDLB air, MPS folds; the narrowest section between the folds' level-set walls: real areas and flows"
        } else {
            "2D coupled glottis (seed §3.4.1): FDLB air, MPS folds; flows and areas per fold length"
        },
        "lung_pressure_dyn_cm2": lung,
        "two_mass_yardstick": yardstick,
    });
    let voice = write_voice_outputs(dir, &series, &VoiceOptions::default(), extra)?;
    files.extend(voice.files.iter().cloned());
    let s = &record.samples;
    let n = s.len().max(1) as f64;
    let fold = |f: fn(&GlottalSample) -> f64, init: f64, op: fn(f64, f64) -> f64| s.iter().map(f).fold(init, op);
    let m = voice.measures.as_ref();
    Ok(GlottisReport {
        lung_pressure: lung,
        samples: s.len(),
        initial_area: s.first().map_or(0.0, |g| g.area),
        min_area: fold(|g| g.area, f64::INFINITY, f64::min),
        max_area: fold(|g| g.area, 0.0, f64::max),
        closed_fraction: s.iter().filter(|g| g.gap <= 0.0).count() as f64 / n,
        no_flow_fraction: s.iter().filter(|g| g.flow == 0.0).count() as f64 / n,
        mean_flow: s.iter().map(|g| g.flow).sum::<f64>() / n,
        max_flow: fold(|g| g.flow, f64::NEG_INFINITY, f64::max),
        largest_lower_margin: fold(|g| g.lower_margin.abs(), 0.0, f64::max),
        largest_upper_margin: fold(|g| g.upper_margin.abs(), 0.0, f64::max),
        oscillating: m.is_some(),
        f0_hz: m.map(|m| m.f0_autocorrelation_hz),
        open_quotient: m.map(|m| m.open_quotient),
        amplitude_spread_last5: m.map(|m| m.amplitude_spread_last5),
        lower_margin_lead_s: m.and_then(|m| {
            // over the voice window, lags up to half a period
            let start = (m.window_s[0] / series.dt) as usize;
            let half_period = (0.5 / m.f0_autocorrelation_hz / series.dt) as usize;
            let col = |name: &str| series.column(name).map(|v| &v[start.min(v.len())..]);
            let (lower, upper) = (col(crate::output::voice::LOWER_MARGIN_COLUMN)?, col(crate::output::voice::UPPER_MARGIN_COLUMN)?);
            crate::analysis::lag::lead_time(lower, upper, series.dt, half_period)
        }),
        aerodynamic_energy_transfer: voice.energy.clone(),
        closure_shape: voice.closure.clone(),
        vertical_phase: voice.vertical_phase,
        no_voice: voice.no_voice.clone(),
    })
}

#[cfg(test)]
#[path = "coupled_tests.rs"]
mod tests;
