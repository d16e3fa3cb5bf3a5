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
    let r = run_scene(&s, &dir, &RunOptions { steps: Some(40), show_progress: false, backend: Backend::Cpu }).unwrap();
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
    let r = run_scene(&s, &dir, &RunOptions { steps: Some(2000), show_progress: false, backend: Backend::Cpu }).unwrap();
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
