//! Parameter sweeps: one scene, one numeric key (e.g. `two_mass.lung_pressure`, or
//! `boundaries.y_min.pressure` of a glottis) set to each of a list of values, one independent
//! job per value; or the pseudo-key `resolution` ([`crate::scene::resolution`]: the lattice's
//! cells times the value, the particles' spacing divided by it), whose table is a convergence
//! study — each row's f0 against the finest row's and the wall time per simulated millisecond,
//! speed against error. Scenes that write voice measures can be swept: two-mass scenes and
//! coupled scenes with two vocal folds. Locally the jobs run in parallel (rayon);
//! with `--emit slurm` the same jobs become a Slurm job array (one scene file per task and a
//! script that runs `phonation run` on the task's file), and `--collect` merges whatever the
//! tasks wrote into the same table (`sweep.csv`, `sweep.json`, `sweep.svg`) and the phonation
//! threshold: the lowest value at which the folds oscillate.
//!
//! Layout of a sweep directory:
//! ```text
//! DIR/sweep_manifest.json   the scene, the key, the values, the jobs
//! DIR/jobs/job_000.toml     one scene per job
//! DIR/jobs/job_000/         its outputs (voice.json, glottal_flow.csv, …)
//! DIR/sweep.slurm           (--emit slurm) the job-array script
//! DIR/sweep.csv, sweep.json, sweep.svg   the merged table
//! ```

use crate::scene::SceneError;
use crate::scene::SceneKind;
use crate::scene::coupled::CoupledScene;
use crate::scene::resolution;
use crate::scene::two_mass::TwoMassScene;
use anyhow::{Context, bail};
use plotters::prelude::*;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The manifest of a sweep.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifest {
    pub scene: String,
    pub key: String,
    pub jobs: Vec<Job>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Job {
    pub id: usize,
    pub value: f64,
    /// Scene file and output directory, relative to the sweep directory.
    pub scene_file: String,
    pub out: String,
}

/// One row of the merged table (None: the job wrote no result, or the folds did not oscillate).
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub id: usize,
    pub value: f64,
    /// The job finished (its voice.json exists).
    pub done: bool,
    pub oscillating: bool,
    pub f0_hz: Option<f64>,
    pub peak_flow: Option<f64>,
    pub mean_flow: Option<f64>,
    pub open_quotient: Option<f64>,
    pub mfdr: Option<f64>,
    /// The job's wall time and simulated time (s), from its summary.json: timings, which differ
    /// between runs of the same job.
    pub wall_s: Option<f64>,
    pub simulated_s: Option<f64>,
    /// Wall seconds per simulated millisecond: the job's cost.
    pub wall_s_per_simulated_ms: Option<f64>,
    /// A resolution sweep: f0 / f0 of the finest finished row − 1 (the error against the finest
    /// run, as a convergence study reads it).
    pub f0_vs_finest: Option<f64>,
    /// The run finished without an instability (its summary.json names none); a row that is
    /// not stable has measures of the part before it stopped, which a study must not read as a
    /// result.
    pub stable: bool,
}

/// The lowest swept value at which the folds oscillate, with every lower value silent.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Threshold {
    /// The highest silent value below it (None: the lowest value swept already oscillates).
    pub below: Option<f64>,
    pub at_or_above: f64,
}

/// Set the numeric value at a dotted `key` of a scene text (the key must exist: a sweep does not
/// invent settings); `resolution` rescales the lattice and the particles instead.
pub fn set_key(text: &str, key: &str, value: f64) -> Result<String, SceneError> {
    if key == resolution::KEY {
        return resolution::text_at_resolution(text, value);
    }
    let mut table: toml::Table = toml::from_str(text).map_err(|e| SceneError::from_toml("scene", &e, text))?;
    let parts: Vec<&str> = key.split('.').collect();
    let mut t = &mut table;
    for p in &parts[..parts.len() - 1] {
        t = t.get_mut(*p).and_then(|v| v.as_table_mut()).ok_or_else(|| SceneError { field: key.into(), reason: format!("the scene has no table `{p}`") })?;
    }
    let last = parts[parts.len() - 1];
    match t.get(last) {
        Some(toml::Value::Float(_)) | Some(toml::Value::Integer(_)) => {}
        Some(other) => return Err(SceneError { field: key.into(), reason: format!("is a {}, not a number: only numbers can be swept", other.type_str()) }),
        None => return Err(SceneError { field: key.into(), reason: "the scene has no such key (write it in the scene first)".into() }),
    }
    t.insert(last.to_string(), toml::Value::Float(value));
    Ok(toml::to_string(&table).expect("a table serialises"))
}

/// Write the manifest and one scene file per value; every job's scene is checked before any
/// runs, so that a value out of range is refused with its field up front.
pub fn prepare(dir: &Path, scene_text: &str, scene_name: &str, key: &str, values: &[f64]) -> anyhow::Result<Manifest> {
    if values.is_empty() {
        bail!("--values: no values to sweep");
    }
    let kind = SceneKind::of(scene_text);
    match kind {
        SceneKind::TwoMass => {}
        SceneKind::Coupled if CoupledScene::parse(scene_text)?.has_glottis() => {}
        _ => bail!("sweep: `{scene_name}` writes no voice measures (two-mass scenes and coupled scenes with a left and a right vocal fold do)"),
    }
    if kind == SceneKind::TwoMass && key == resolution::KEY {
        bail!("--key resolution: a two-mass scene has no lattice");
    }
    let mut texts = Vec::new();
    for &v in values {
        let text = set_key(scene_text, key, v)?;
        let checked = match kind {
            SceneKind::TwoMass => TwoMassScene::parse(&text).map(|_| ()),
            _ => CoupledScene::parse(&text).map(|_| ()),
        };
        checked.with_context(|| format!("the job with {key} = {v}"))?;
        texts.push(text);
    }
    std::fs::create_dir_all(dir.join("jobs"))?;
    let mut jobs = Vec::new();
    for (id, (text, &value)) in texts.iter().zip(values).enumerate() {
        let scene_file = format!("jobs/job_{id:03}.toml");
        std::fs::write(dir.join(&scene_file), format!("# sweep job {id}: {key} = {value}\n{text}"))?;
        jobs.push(Job { id, value, scene_file, out: format!("jobs/job_{id:03}") });
    }
    let m = Manifest { scene: scene_name.into(), key: key.into(), jobs };
    std::fs::write(dir.join("sweep_manifest.json"), serde_json::to_string_pretty(&m)?)?;
    Ok(m)
}

/// Run one job of a prepared sweep in this process.
pub fn run_job(dir: &Path, job: &Job) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(dir.join(&job.scene_file))?;
    let out = dir.join(&job.out);
    if SceneKind::of(&text) == SceneKind::TwoMass {
        crate::run::two_mass::run_two_mass_scene(&TwoMassScene::parse(&text)?, &out)?;
    } else {
        let report = crate::run::coupled::run_coupled_scene(&CoupledScene::parse(&text)?, &out, &crate::run::RunOptions::default())?;
        if let Some(why) = report.instability {
            bail!("unstable: {why} (outputs so far kept in {})", out.display());
        }
    }
    Ok(())
}

/// Run every job in parallel (rayon), then collect.
/// A job that fails (a coupled run that goes unstable) is reported on stderr and left in the
/// table as it ended (`stable` false, or not done): the other jobs' rows are kept.
pub fn run_local(dir: &Path, m: &Manifest) -> anyhow::Result<(Vec<Row>, Option<Threshold>)> {
    let failed: Vec<String> =
        m.jobs.par_iter().filter_map(|j| run_job(dir, j).err().map(|e| format!("job {} ({} = {}): {e:#}", j.id, m.key, j.value))).collect();
    for f in &failed {
        eprintln!("sweep: {f}");
    }
    collect(dir)
}

/// Write the Slurm job-array script: task i runs `phonation run jobs/job_i.toml`, each with the
/// wall-time limit `time` (Slurm's `--time`: `MM`, `HH:MM:SS`, `D-HH:MM:SS`, …).
/// `phonation` is this executable unless `PHONATION` names another at run time.
pub fn emit_slurm(dir: &Path, m: &Manifest, time: &str) -> anyhow::Result<PathBuf> {
    if time.is_empty() || !time.chars().all(|c| c.is_ascii_digit() || c == ':' || c == '-') {
        bail!("--time: {time:?} is not a Slurm time limit (digits, ':' and '-', e.g. 01:00:00 or 2-00:00:00)");
    }
    let abs = std::fs::canonicalize(dir)?;
    let exe = std::env::current_exe().map(|p| p.display().to_string()).unwrap_or_else(|_| "phonation".into());
    std::fs::create_dir_all(dir.join("logs"))?;
    let script = format!(
        r#"#!/bin/bash
# A phonation sweep as a Slurm job array: {n} independent jobs, {key} over {values:?}.
# Submit:  sbatch {path}
# Then:    phonation sweep --collect {abs}
#SBATCH --job-name=phonation-sweep-{name}
#SBATCH --array=0-{last}
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --time={time}
#SBATCH --output={abs}/logs/%A_%a.out
set -euo pipefail
cd "${{SWEEP_DIR:-{abs}}}"
PHONATION="${{PHONATION:-{exe}}}"
ID=$(printf '%03d' "$SLURM_ARRAY_TASK_ID")
"$PHONATION" run "jobs/job_$ID.toml" --out "jobs/job_$ID"
"#,
        n = m.jobs.len(),
        key = m.key,
        values = m.jobs.iter().map(|j| j.value).collect::<Vec<_>>(),
        path = abs.join("sweep.slurm").display(),
        abs = abs.display(),
        name = m.scene,
        last = m.jobs.len() - 1,
        time = time,
    );
    let path = dir.join("sweep.slurm");
    std::fs::write(&path, script)?;
    Ok(path)
}

/// The manifest of the sweep directory `dir`.
pub fn manifest(dir: &Path) -> anyhow::Result<Manifest> {
    let text = std::fs::read_to_string(dir.join("sweep_manifest.json")).with_context(|| format!("{} is not a sweep directory", dir.display()))?;
    Ok(serde_json::from_str(&text)?)
}

/// Merge the jobs' results into `sweep.csv`, `sweep.json` and `sweep.svg`; jobs that have not
/// written their voice.json are listed as not done.
pub fn collect(dir: &Path) -> anyhow::Result<(Vec<Row>, Option<Threshold>)> {
    let m = manifest(dir)?;
    let mut rows = Vec::new();
    for j in &m.jobs {
        let voice = std::fs::read_to_string(dir.join(&j.out).join("voice.json")).ok().and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
        let get = |k: &str| voice.as_ref().and_then(|v| v["measures"][k].as_f64());
        let summary = std::fs::read_to_string(dir.join(&j.out).join("summary.json")).ok().and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
        let timing = |k: &str| summary.as_ref().and_then(|v| v[k].as_f64());
        let (wall_s, simulated_s) = (timing("wall_s"), timing("simulated_s"));
        rows.push(Row {
            id: j.id,
            value: j.value,
            done: voice.is_some(),
            oscillating: voice.as_ref().is_some_and(|v| v["oscillating"] == true),
            f0_hz: get("f0_autocorrelation_hz"),
            peak_flow: get("peak_flow"),
            mean_flow: get("mean_flow"),
            open_quotient: get("open_quotient"),
            mfdr: get("mfdr"),
            wall_s,
            simulated_s,
            wall_s_per_simulated_ms: wall_s.zip(simulated_s).filter(|&(_, t)| t > 0.0).map(|(w, t)| w / (1e3 * t)),
            f0_vs_finest: None,
            stable: summary.as_ref().is_some_and(|v| v["instability"].is_null()),
        });
    }
    rows.sort_by(|a, b| a.value.total_cmp(&b.value));
    if m.key == resolution::KEY {
        set_f0_vs_finest(&mut rows);
    }
    // a phonation threshold belongs to a physical parameter, not to the lattice's resolution
    let threshold = if m.key == resolution::KEY { None } else { threshold(&rows) };
    let fmt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6e}"));
    let mut csv = format!(
        "{},done,oscillating,f0_hz,peak_flow_cm3_s,mean_flow_cm3_s,open_quotient,mfdr_cm3_s2,f0_vs_finest,stable,wall_s,simulated_s,wall_s_per_simulated_ms\n",
        m.key
    );
    for r in &rows {
        csv += &format!(
            "{:.6e},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.value,
            r.done,
            r.oscillating,
            fmt(r.f0_hz),
            fmt(r.peak_flow),
            fmt(r.mean_flow),
            fmt(r.open_quotient),
            fmt(r.mfdr),
            fmt(r.f0_vs_finest),
            r.stable,
            fmt(r.wall_s),
            fmt(r.simulated_s),
            fmt(r.wall_s_per_simulated_ms)
        );
    }
    std::fs::write(dir.join("sweep.csv"), csv)?;
    let missing: Vec<usize> = rows.iter().filter(|r| !r.done).map(|r| r.id).collect();
    std::fs::write(
        dir.join("sweep.json"),
        serde_json::to_string_pretty(
            &serde_json::json!({"scene": m.scene, "key": m.key, "rows": rows, "phonation_threshold": threshold, "jobs_not_done": missing}),
        )?,
    )?;
    plot(&dir.join("sweep.svg"), &m.key, &rows)?;
    Ok((rows, threshold))
}

/// A resolution sweep's error column: each f0 against that of the finest (largest factor) row
/// that has one.
fn set_f0_vs_finest(rows: &mut [Row]) {
    let finest = rows.iter().rev().filter(|r| r.stable).find_map(|r| r.f0_hz);
    for r in rows.iter_mut() {
        r.f0_vs_finest = r.f0_hz.zip(finest).map(|(f, f_ref)| f / f_ref - 1.0);
    }
}

/// The lowest oscillating value above which (in the sweep's order) nothing lower oscillates,
/// among the finished jobs (a job not yet done is no evidence of silence).
pub fn threshold(rows: &[Row]) -> Option<Threshold> {
    let done: Vec<&Row> = rows.iter().filter(|r| r.done).collect();
    let first = done.iter().position(|r| r.oscillating)?;
    Some(Threshold { below: first.checked_sub(1).map(|i| done[i].value), at_or_above: done[first].value })
}

/// f0, peak flow and the wall time per simulated ms against the swept value (three panels;
/// open red circles: finished jobs whose folds did not oscillate).
fn plot(path: &Path, key: &str, rows: &[Row]) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (800, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((3, 1));
    let x0 = rows.first().map_or(0.0, |r| r.value);
    let x1 = rows.last().map_or(1.0, |r| r.value).max(x0 + 1e-9);
    type Pick = fn(&Row) -> Option<f64>;
    let picks: [(&str, Pick); 3] =
        [("f0 (Hz)", |r| r.f0_hz), ("peak flow (cm³/s)", |r| r.peak_flow), ("wall s per simulated ms", |r| r.wall_s_per_simulated_ms)];
    for (area, (label, pick)) in panels.iter().zip(picks) {
        let pts: Vec<(f64, f64)> = rows.iter().filter_map(|r| pick(r).map(|v| (r.value, v))).collect();
        let hi = pts.iter().fold(0.0f64, |m, p| m.max(p.1)).max(1e-9) * 1.1;
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{label} against {key} (open circles: no oscillation)"), ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, 0.0..hi)?;
        chart.configure_mesh().x_desc(key).y_desc(label).draw()?;
        chart.draw_series(LineSeries::new(pts.clone(), BLUE.stroke_width(2)))?;
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))?;
        chart.draw_series(rows.iter().filter(|r| r.done && !r.oscillating).map(|r| Circle::new((r.value, 0.0), 4, RED.stroke_width(1))))?;
    }
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_key_changes_one_number_and_refuses_what_it_cannot_set() {
        let text = "name = \"t\"\n[two_mass]\nlung_pressure = 7845\nduration = 0.1\n";
        let t = set_key(text, "two_mass.lung_pressure", 1234.5).unwrap();
        assert!(t.contains("lung_pressure = 1234.5") && t.contains("duration = 0.1"), "{t}");
        assert_eq!(set_key(text, "two_mass.pressure", 1.0).unwrap_err().field, "two_mass.pressure");
        assert_eq!(set_key(text, "fluid.x", 1.0).unwrap_err().field, "fluid.x");
        assert!(set_key(text, "name", 1.0).unwrap_err().reason.contains("not a number"));
    }

    #[test]
    fn threshold_is_the_first_oscillating_value() {
        let row = |value: f64, oscillating: bool| Row {
            id: 0,
            value,
            done: true,
            oscillating,
            f0_hz: None,
            peak_flow: None,
            mean_flow: None,
            open_quotient: None,
            mfdr: None,
            wall_s: None,
            simulated_s: None,
            wall_s_per_simulated_ms: None,
            f0_vs_finest: None,
            stable: true,
        };
        assert_eq!(threshold(&[row(1.0, false), row(2.0, false), row(3.0, true), row(4.0, true)]), Some(Threshold { below: Some(2.0), at_or_above: 3.0 }));
        assert_eq!(threshold(&[row(1.0, false)]), None);
        // a resolution sweep's error column: f0 against the finest row that has one
        // (the finest row with an f0 that is stable: an unstable run's f0 is no reference)
        let mut rows = [row(0.5, true), row(0.75, true), row(1.0, true), row(1.5, false), row(2.0, true)];
        for (r, f) in rows.iter_mut().zip([Some(360.0), Some(200.0), Some(150.0), None, Some(90.0)]) {
            r.f0_hz = f;
        }
        rows[4].stable = false;
        set_f0_vs_finest(&mut rows);
        let vs: Vec<Option<f64>> = rows.iter().map(|r| r.f0_vs_finest).collect();
        assert_eq!(vs, [Some(360.0 / 150.0 - 1.0), Some(200.0 / 150.0 - 1.0), Some(0.0), None, Some(90.0 / 150.0 - 1.0)]);
        assert_eq!(threshold(&[row(1.0, true)]), Some(Threshold { below: None, at_or_above: 1.0 }));
        // a job not yet done is skipped, not read as silent
        let mut pending = [row(1.0, false), row(2.0, false), row(3.0, true)];
        pending[1].done = false;
        assert_eq!(threshold(&pending), Some(Threshold { below: Some(1.0), at_or_above: 3.0 }));
    }

    /// `collect` reads a job that went unstable as not stable (from its summary.json), keeps
    /// its measures, and does not take its f0 as the finest reference of a resolution sweep.
    #[test]
    fn an_unstable_job_is_collected_as_not_stable() {
        let dir = std::env::temp_dir().join(format!("phonation-sweep-unstable-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let jobs = (0..2).map(|id| Job { id, value: [0.5, 1.0][id], scene_file: format!("jobs/job_{id:03}.toml"), out: format!("jobs/job_{id:03}") }).collect();
        let m = Manifest { scene: "s".into(), key: resolution::KEY.into(), jobs };
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("sweep_manifest.json"), serde_json::to_string(&m).unwrap()).unwrap();
        for (id, f0, instability) in [(0, 360.0, serde_json::Value::Null), (1, 90.0, "fluid unstable at step 7".into())] {
            let out = dir.join(format!("jobs/job_{id:03}"));
            std::fs::create_dir_all(&out).unwrap();
            std::fs::write(out.join("voice.json"), serde_json::json!({"oscillating": true, "measures": {"f0_autocorrelation_hz": f0}}).to_string()).unwrap();
            std::fs::write(out.join("summary.json"), serde_json::json!({"instability": instability, "wall_s": 2.0, "simulated_s": 1e-3}).to_string()).unwrap();
        }
        let (rows, _) = collect(&dir).unwrap();
        assert_eq!(rows.iter().map(|r| r.stable).collect::<Vec<_>>(), [true, false]);
        assert_eq!(rows[1].f0_hz, Some(90.0));
        assert_eq!(rows[0].f0_vs_finest, Some(0.0), "the stable row is its own finest");
        assert_eq!(rows[0].wall_s_per_simulated_ms, Some(2.0));
        let csv = std::fs::read_to_string(dir.join("sweep.csv")).unwrap();
        assert!(csv.lines().nth(2).unwrap().contains(",false,2.000000e0,"), "{csv}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
