//! Checkpoint, resume and determinism of every kind of scene on the CPU: a run interrupted
//! after its checkpoint (its outputs run on past it, as when a job is killed) and resumed from
//! it ends bit-identical to the run that never stopped — state hash and every CSV byte for
//! byte —; damaged, foreign and other-version checkpoints are refused before the output
//! directory is touched; the state hash of a short run of each kind is golden and independent
//! of the thread count.

use super::checkpoint::{Checkpoint, CheckpointError, Checkpointing, FILE_NAME, FORMAT_VERSION};
use super::{Backend, RunOptions};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("phonation-resume-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn opts(text: &str, steps: u64, every: Option<u64>, stop_at: Option<u64>, resume: Option<Checkpoint>) -> RunOptions {
    RunOptions {
        steps: Some(steps),
        show_progress: false,
        backend: Backend::Cpu,
        checkpoint: Checkpointing { every, resume, scene_text: text.to_string() },
        stop_at,
        ..Default::default()
    }
}

/// Runs `text` on the CPU into `dir`; returns the final state hash.
fn run(text: &str, dir: &Path, o: &RunOptions) -> String {
    match Scene::read(text).unwrap() {
        Scene::Fluid(sc) => super::run_scene(&sc, dir, o).unwrap().state_hash,
        Scene::Solid(sc) => super::solid::run_solid_scene(&sc, dir, o).unwrap().state_hash,
        Scene::LatticeGas(sc) => super::lattice_gas::run_lattice_gas_scene(&sc, dir, o).unwrap().state_hash,
        Scene::Coupled(sc) => super::coupled::run_coupled_scene(&sc, dir, o).unwrap().state_hash,
        Scene::TwoMass(_) => unreachable!("no checkpoints"),
    }
}

/// The whole run of `n` steps against one stopped at 3n/4 with a checkpoint at n/2, resumed
/// from that checkpoint: identical hashes and `csvs`; the resumed run goes on writing
/// checkpoints at the same period. Returns the checkpoint of step n/2 and its path.
fn interrupted_equals_whole(tag: &str, text: &str, n: u64, csvs: &[&str]) -> (Checkpoint, PathBuf) {
    let (whole, cut) = (tmp(&format!("{tag}-whole")), tmp(&format!("{tag}-cut")));
    let h_whole = run(text, &whole, &opts(text, n, None, None, None));
    let h_stopped = run(text, &cut, &opts(text, n, Some(n / 2), Some(3 * n / 4), None));
    assert_ne!(h_stopped, h_whole, "{tag}: the stopped run must differ from the whole one (else the test proves nothing)");
    let ck_path = cut.join(FILE_NAME);
    let ck = Checkpoint::read(&ck_path).unwrap();
    assert_eq!(ck.step, n / 2, "{tag}: the checkpoint of step n/2 (none at the stop)");
    for f in csvs {
        let (a, b) = (std::fs::read(whole.join(f)).unwrap(), std::fs::read(cut.join(f)).unwrap());
        assert!(b.len() < a.len() && a.starts_with(&b), "{tag}: {f} of the stopped run is a prefix of the whole run's");
    }
    let h_resumed = run(text, &cut, &opts(text, n, None, None, Some(ck.clone())));
    assert_eq!(Checkpoint::read(&ck_path).unwrap().step, n, "{tag}: the resumed run checkpoints at the same period");
    assert_eq!(h_resumed, h_whole, "{tag}: resumed state differs from the whole run's");
    for f in csvs {
        let (a, b) = (std::fs::read_to_string(whole.join(f)).unwrap(), std::fs::read_to_string(cut.join(f)).unwrap());
        assert!(a == b, "{tag}: {f} differs after the resume ({} vs {} lines)", a.lines().count(), b.lines().count());
    }
    let _ = std::fs::remove_dir_all(&whole);
    (ck, ck_path)
}

const FLUID: &str = include_str!("../../assets/scenes/lid_cavity.toml");
const SOLID: &str = include_str!("../../assets/scenes/solid/two_blocks.toml");
const IMPLICIT: &str = include_str!("../../assets/scenes/solid/cantilever.toml");
const GLOTTIS: &str = include_str!("../../assets/scenes/glottis/glottis_2d_coarse.toml");
const CONSERVING: &str = include_str!("../../assets/scenes/coupled/fsi_cylinder_conserving.toml");

#[test]
fn a_fluid_run_resumed_from_its_checkpoint_is_bit_identical() {
    let (_, path) = interrupted_equals_whole("fluid", FLUID, 200, &["probes.csv"]);
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

/// `[numerics] storage = "f32"`: the run steps f32 populations (its state hash differs from the
/// f64 run's, the summary says so) and resumes from its checkpoint bit for bit (f32 → f64 → f32
/// is exact). How far it lies from the f64 run: `fluid::solver::tests`.
#[test]
fn a_fluid_run_with_f32_storage_resumes_bit_identical() {
    let text = FLUID.replace("[numerics]\n", "[numerics]\nstorage = \"f32\"\n");
    assert_ne!(text, FLUID);
    let (_, path) = interrupted_equals_whole("fluid-f32", &text, 200, &["probes.csv"]);
    let cut = path.parent().unwrap().to_path_buf();
    let reference = tmp("fluid-f64");
    let h64 = run(FLUID, &reference, &opts(FLUID, 200, None, None, None));
    let summary = std::fs::read_to_string(cut.join("summary.json")).unwrap();
    assert!(summary.contains("populations stored in f32"), "the summary names the storage: {summary}");
    assert!(!summary.contains(&h64), "the f32 run's state hash is the f64 run's: f32 storage did not run");
    for d in [cut, reference] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn f32_storage_is_refused_for_a_coupled_scene_naming_the_field() {
    let text = CONSERVING.replace("[numerics]\n", "[numerics]\nstorage = \"f32\"\n");
    assert_ne!(text, CONSERVING);
    let e = Scene::read(&text).expect_err("refused").to_string();
    assert!(e.contains("numerics.storage") && e.contains("fluid-only"), "{e}");
}

/// The implicit step's preconditioner (block Jacobi and the coarse space) is built from the
/// scene alone, not from the state where a run starts, so a resumed run solves as the whole run.
#[test]
fn an_implicit_solid_run_resumed_is_bit_identical() {
    let (_, path) = interrupted_equals_whole("solid-implicit", IMPLICIT, 12, &["solid.csv"]);
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

#[test]
fn a_solid_run_with_contact_anchors_resumed_is_bit_identical() {
    // the blocks collide before the checkpoint: their friction anchors must be carried over
    let (ck, path) = interrupted_equals_whole("solid", SOLID, 600, &["solid.csv"]);
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
    let state = ck.state;
    let mut s = match Scene::read(SOLID).unwrap() {
        Scene::Solid(sc) => sc.build().unwrap(),
        _ => unreachable!(),
    };
    crate::state::SaveState::load_state(&mut s, &mut crate::state::StateReader::new(&state)).unwrap();
    let anchors = s.contacts().anchors();
    assert!(anchors.0 + anchors.1 > 0, "the checkpoint holds contact anchors (pairs, walls): {anchors:?}");
}

#[test]
fn a_lattice_gas_run_resumed_continues_its_random_streams() {
    let text = crate::scene::lattice_gas::tests::SMALL;
    let (_, path) = interrupted_equals_whole("lattice_gas", text, 60, &["probe.csv"]);
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

#[test]
fn a_coupled_glottis_run_resumed_is_bit_identical() {
    let (_, ck) = interrupted_equals_whole("coupled", GLOTTIS, 40, &["coupling.csv", "probes.csv", "glottal_flow.csv"]);
    let cut = ck.parent().unwrap().to_path_buf();
    refusals(&ck, &cut);
    let _ = std::fs::remove_dir_all(&cut);
}

/// A particle probe's analysis covers the whole run when the run resumed: its checkpoint
/// carries the samples before it, so the summary's probe report (window, largest |dy|,
/// oscillation) is the whole run's, not the part after the resume.
#[test]
fn a_resumed_coupled_run_analyses_its_particle_probes_over_the_whole_run() {
    let text = CONSERVING.replace("[coupling]\n", "[coupling]\nprobes = [{ name = \"rear\", min = [0.24, 0.15], max = [0.26, 0.25] }]\n");
    assert_ne!(text, CONSERVING);
    let (whole, cut) = (tmp("probes-whole"), tmp("probes-cut"));
    let n = 40;
    run(&text, &whole, &opts(&text, n, None, None, None));
    run(&text, &cut, &opts(&text, n, Some(n / 2), Some(3 * n / 4), None));
    let ck = Checkpoint::read(&cut.join(FILE_NAME)).unwrap();
    run(&text, &cut, &opts(&text, n, None, None, Some(ck)));
    let probes = |d: &Path| -> serde_json::Value {
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.join("summary.json")).unwrap()).unwrap();
        v["particle_probes"].clone()
    };
    let (a, b) = (probes(&whole), probes(&cut));
    assert_eq!(a.as_array().map(|p| p.len()), Some(1), "{a}");
    assert!(a[0]["max_abs_dy"].as_f64().unwrap() > 0.0, "the probe moves: {a}");
    // the window is the second half of the whole run: it starts at the checkpoint's step
    assert_eq!(a, b, "the resumed run's probe report is the whole run's");
    for d in [whole, cut] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_method_2_run_resumed_is_bit_identical() {
    // the level-set walls are rebuilt from the particle positions in the checkpoint
    let (_, ck) = interrupted_equals_whole("conserving", CONSERVING, 40, &["coupling.csv"]);
    let summary = std::fs::read_to_string(ck.parent().unwrap().join("summary.json")).unwrap();
    assert!(summary.contains("\"method\": \"momentum_conserving\"") || summary.contains("\"method\":\"momentum_conserving\""), "{summary}");
    let _ = std::fs::remove_dir_all(ck.parent().unwrap());
}

/// Damaged, truncated, foreign and other-version checkpoints are refused with what is wrong,
/// and the outputs are left as they were.
fn refusals(ck_path: &Path, dir: &Path) {
    let good = std::fs::read(ck_path).unwrap();
    let before = std::fs::read(dir.join("coupling.csv")).unwrap();
    let read = |b: &[u8]| Checkpoint::from_bytes(b, Path::new("ck.bin"));
    assert!(matches!(read(&good[..good.len() - 100]), Err(CheckpointError::Truncated { .. })));
    assert!(matches!(read(&good[..20]), Err(CheckpointError::Truncated { .. })));
    let mut flipped = good.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 1;
    assert!(matches!(read(&flipped), Err(CheckpointError::Checksum { .. })));
    let mut version = good.clone();
    version[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    let e = read(&version).unwrap_err();
    assert!(matches!(e, CheckpointError::Version { found, .. } if found == FORMAT_VERSION + 1), "{e}");
    assert!(e.to_string().contains("version"));
    assert!(matches!(read(b"not a checkpoint at all"), Err(CheckpointError::NotACheckpoint { .. })));
    // another scene: refused by its hash; comments and layout do not count
    let ck = read(&good).unwrap();
    let e = ck.check_scene(FLUID).unwrap_err();
    assert!(matches!(e, CheckpointError::OtherScene { .. }) && e.to_string().contains("another scene"), "{e}");
    ck.check_scene(&format!("# a comment\n{}", GLOTTIS.replace(" = ", "="))).unwrap();
    let e = ck.check_scene(&GLOTTIS.replace("pressure = 8000.0", "pressure = 8000.5")).unwrap_err();
    assert!(matches!(e, CheckpointError::OtherScene { .. }), "a changed value is another scene: {e}");
    // a state that does not fit the scene's solver: refused before any output is touched
    let mut foreign = ck.clone();
    foreign.state.truncate(foreign.state.len() / 2);
    let mut o = opts(GLOTTIS, 40, None, None, Some(foreign));
    let sc = match Scene::read(GLOTTIS).unwrap() {
        Scene::Coupled(sc) => sc,
        _ => unreachable!(),
    };
    let e = super::coupled::run_coupled_scene(&sc, dir, &o).unwrap_err();
    assert!(e.to_string().contains("truncated"), "{e}");
    let lattice_gas = Checkpoint { state: read(&good).unwrap().state[..64].to_vec(), ..ck.clone() };
    o.checkpoint.resume = Some(lattice_gas);
    assert!(super::coupled::run_coupled_scene(&sc, dir, &o).is_err());
    assert_eq!(std::fs::read(dir.join("coupling.csv")).unwrap(), before, "a refused resume leaves the outputs alone");
    assert_eq!(std::fs::read(ck_path).unwrap(), good, "and the checkpoint");
}

/// Golden state hashes after a short CPU run of each kind of scene. When a change to the
/// numerics is intended, re-mint them: run this test, and copy the hashes it prints into
/// `GOLDEN` (say in the commit why the results changed).
#[test]
fn the_state_hash_of_each_kind_is_golden_and_independent_of_the_thread_count() {
    const GOLDEN: [(&str, &str); 4] = [
        ("fluid", "2c450a063515f3942c4db11b7d829a8bb9236be50d4680cc4da7c7c2fa8307a4"),
        ("solid", "9c6a9a1c405d1eaec5cfc1c43e54ed6d1887fe6e139be5010088d506af25d1b6"),
        ("lattice_gas", "fce54480dc8967dde4764fa9e2fdadd3f4fea84764c4f55d68bda9f025b38717"),
        ("coupled", "a6fbb48445c144538eac6574c599d401c24b672e0eabbafa7a65b37b9b210a35"),
    ];
    let cases: [(&str, &str, u64); 4] =
        [("fluid", FLUID, 30), ("solid", SOLID, 60), ("lattice_gas", crate::scene::lattice_gas::tests::SMALL, 20), ("coupled", GLOTTIS, 6)];
    let mut minted = Vec::new();
    for (kind, text, n) in cases {
        let hash_with = |threads: usize, k: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let dir = tmp(&format!("golden-{kind}-{threads}-{k}"));
            let h = pool.install(|| run(text, &dir, &opts(text, n, None, None, None)));
            let _ = std::fs::remove_dir_all(&dir);
            h
        };
        let (one, two, again) = (hash_with(1, 0), hash_with(2, 0), hash_with(2, 1));
        assert_eq!(one, two, "{kind}: 1 and 2 threads give different states");
        assert_eq!(two, again, "{kind}: the same run twice gives different states");
        minted.push(format!("(\"{kind}\", \"{one}\")"));
    }
    println!("minted: [{}]", minted.join(", "));
    for ((kind, golden), line) in GOLDEN.iter().zip(&minted) {
        assert!(
            line.contains(golden),
            "{kind}: state hash changed: {line} (golden {golden}). If the change of results is intended, re-mint: `cargo test --no-default-features --lib golden -- --nocapture` and copy the printed hashes into GOLDEN"
        );
    }
}
