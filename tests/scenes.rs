//! Scene files: bad input is refused before allocation with an error naming the field; the
//! built-in scenes validate; a headless run writes its outputs; an unstable run stops with a
//! diagnosis and keeps what it wrote.

use phonation::run::{Backend, RunOptions, RunStatus, run_scene};
use phonation::scene;

#[test]
fn bad_scene_files_are_refused_with_the_field_and_the_reason() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_scenes");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        let expect = text.lines().next().unwrap().strip_prefix("# expect: ").expect("first line names the field");
        let err = scene::load(&text).err().unwrap_or_else(|| panic!("{} was accepted", path.display()));
        assert!(err.field.starts_with(expect), "{}: expected field {expect}, got {err}", path.display());
        assert!(!err.reason.is_empty());
        n += 1;
    }
    assert!(n >= 10, "only {n} bad scenes");
}

#[test]
fn the_base_of_the_bad_scenes_is_valid() {
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap();
    let s = scene::load(&text).unwrap();
    assert_eq!(s.grid.n, [40, 20, 1]);
    // Mach scaling: the reference velocity runs at lattice Mach 0.1.
    let u = s.units.velocity_to_lattice(10.0);
    assert!((u / (1.4f64 * 0.6).sqrt() - 0.1).abs() < 1e-12);
}

#[test]
fn builtin_scenes_validate() {
    for (name, text) in scene::BUILTIN {
        let s = scene::load(text).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(s.steps > 0 && s.params.dt > 0.0, "{name}");
        assert!(s.params.a >= 0.0 && s.params.a < s.params.tau, "{name}: {:?}", s.params);
    }
}

#[test]
fn headless_run_writes_probes_snapshots_and_summary() {
    let s = scene::load(&std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap()).unwrap();
    let dir = std::env::temp_dir().join(format!("phonation-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let r = run_scene(&s, &dir, &RunOptions { steps: Some(40), show_progress: false, backend: Backend::Cpu, ..Default::default() }).unwrap();
    assert!(matches!(r.status, RunStatus::Completed));
    assert_eq!(r.steps_done, 40);
    let csv = std::fs::read_to_string(dir.join("probes.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert!(lines[0].starts_with("step,time_s,p_pressure,p_density,p_ux,p_uy"));
    assert_eq!(lines.len(), 1 + 1 + 4); // header, step 0, every 10 steps
    let last: Vec<f64> = lines.last().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
    assert_eq!(last[0], 40.0);
    assert!(last[4] > 0.0, "flow goes downstream at the probe: {last:?}");
    for f in ["snapshot_001_speed.png", "snapshot_001_pressure.png", "snapshot_001.vtk", "summary.json"] {
        assert!(dir.join(f).metadata().unwrap().len() > 100, "{f}");
    }
    let vtk = std::fs::read(dir.join("snapshot_001.vtk")).unwrap();
    assert!(vtk.starts_with(b"# vtk DataFile Version 3.0"));
    let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "completed");
    assert!(summary["mass_drift"].as_f64().unwrap().abs() < 0.05);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unstable_run_stops_with_a_diagnosis_and_keeps_outputs() {
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap();
    let mut s = scene::load(&text).unwrap();
    // Force an unstable step past the checks (four times the advection limit).
    s.params.dt = 1.0;
    s.params.tau = 1.0;
    s.params.a = 0.0;
    let dir = std::env::temp_dir().join(format!("phonation-unstable-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let r = run_scene(&s, &dir, &RunOptions { steps: Some(2000), show_progress: false, backend: Backend::Cpu, ..Default::default() }).unwrap();
    let RunStatus::Unstable { step, quantity, position, .. } = &r.status else { panic!("expected instability, got {:?}", r.status) };
    assert!(*step < 2000 && ["density", "temperature", "velocity"].contains(&quantity.as_str()));
    assert!(position[0] >= 0.0 && position[0] <= 1.0 && position[1] >= 0.0 && position[1] <= 0.5);
    let csv = std::fs::read_to_string(dir.join("probes.csv")).unwrap();
    assert!(csv.lines().count() >= 2, "probe rows written before the blow-up are kept");
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    assert!(summary.contains("\"status\": \"unstable\"") && summary.contains("unstable at step"));
    assert!(dir.join("snapshot_999.vtk").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `phonation sweep --emit slurm` writes a job array whose tasks, each run as Slurm would run
/// it (the script with SLURM_ARRAY_TASK_ID set), give after `--collect` the same table as the
/// sweep run here in parallel; the threshold of the two-mass model lies between 1500 and 2500
/// dyn/cm² (a finer sweep puts it between 2000 and 2500, 2.0–2.5 cmH₂O).
#[test]
fn a_slurm_sweep_collects_to_the_table_of_the_local_sweep() {
    let exe = env!("CARGO_BIN_EXE_phonation");
    let root = std::env::temp_dir().join(format!("phonation-sweep-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let (local, cluster) = (root.join("local"), root.join("slurm"));
    let values = "1500,2500,3500,8000";
    let run = |args: &[&str]| {
        let o = std::process::Command::new(exe).args(args).output().unwrap();
        assert!(o.status.success(), "phonation {args:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let printed = run(&["sweep", "two_mass", "--values", values, "--out", local.to_str().unwrap()]);
    assert!(printed.contains("phonation threshold between 1500 and 2500"), "{printed}");
    run(&["sweep", "two_mass", "--values", values, "--out", cluster.to_str().unwrap(), "--emit", "slurm"]);
    let script = std::fs::read_to_string(cluster.join("sweep.slurm")).unwrap();
    assert!(script.contains("#SBATCH --array=0-3"), "{script}");
    assert!(!cluster.join("jobs/job_000/voice.json").exists(), "--emit runs nothing");
    for id in 0..4 {
        let o = std::process::Command::new("bash")
            .arg(cluster.join("sweep.slurm"))
            .env("SLURM_ARRAY_TASK_ID", id.to_string())
            .env("PHONATION", exe)
            .output()
            .unwrap();
        assert!(o.status.success(), "task {id}: {}", String::from_utf8_lossy(&o.stderr));
    }
    run(&["sweep", "--collect", cluster.to_str().unwrap()]);
    let table = |d: &std::path::Path| std::fs::read_to_string(d.join("sweep.csv")).unwrap();
    assert_eq!(table(&local), table(&cluster));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(cluster.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json["phonation_threshold"]["below"], 1500.0);
    assert_eq!(json["phonation_threshold"]["at_or_above"], 2500.0);
    let f0 = json["rows"][3]["f0_hz"].as_f64().unwrap();
    assert!((f0 / 167.2 - 1.0).abs() < 0.01, "f0 at 8000 dyn/cm² {f0}");
    std::fs::remove_dir_all(&root).ok();
}

/// A collect before the tasks ran lists them as not done instead of failing.
#[test]
fn collecting_an_unfinished_sweep_says_which_jobs_are_missing() {
    let exe = env!("CARGO_BIN_EXE_phonation");
    let dir = std::env::temp_dir().join(format!("phonation-sweep-missing-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let ok = std::process::Command::new(exe)
        .args(["sweep", "two_mass", "--values", "3000,4000", "--emit", "slurm", "--out", dir.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(ok.success());
    let o = std::process::Command::new(exe).args(["sweep", "--collect", dir.to_str().unwrap()]).output().unwrap();
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("2 job(s) have not written their results yet"));
    // a bad value is refused before any job is written, naming the field
    let bad = std::process::Command::new(exe)
        .args(["sweep", "two_mass", "--key", "two_mass.duration", "--values", "0.1,-1", "--out", dir.join("bad").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("two_mass.duration"), "{err}");
    assert!(!dir.join("bad/jobs").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// `phonation analyze` re-measures a run's glottal_flow.csv and, given the lung pressure, puts
/// the two-mass yardstick next to it in voice.json.
#[test]
fn analyze_rewrites_the_voice_outputs_with_the_two_mass_yardstick() {
    let exe = env!("CARGO_BIN_EXE_phonation");
    let dir = std::env::temp_dir().join(format!("phonation-analyze-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let ok = std::process::Command::new(exe).args(["run", "two_mass", "--out", dir.to_str().unwrap()]).output().unwrap();
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    std::fs::remove_file(dir.join("voice.json")).unwrap();
    let o = std::process::Command::new(exe).args(["analyze", dir.to_str().unwrap(), "--lung-pressure", "7845.32"]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("voice.json")).unwrap()).unwrap();
    let f0 = v["measures"]["f0_autocorrelation_hz"].as_f64().unwrap();
    let yard = v["two_mass_yardstick"]["measures"]["f0_autocorrelation_hz"].as_f64().unwrap();
    // the run is the standard model at this pressure: the yardstick (a 0.4 s run) agrees
    assert!((f0 / yard - 1.0).abs() < 1e-3, "{f0} vs {yard}");
    // a CSV that is not uniformly sampled is refused with the reason
    std::fs::write(dir.join("glottal_flow.csv"), "t_s,flow_cm3_s\n0,1\n0.1,2\n0.3,3\n").unwrap();
    let bad = std::process::Command::new(exe).args(["analyze", dir.to_str().unwrap()]).output().unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("not uniformly spaced"));
    std::fs::remove_dir_all(&dir).ok();
}
