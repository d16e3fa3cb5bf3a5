//! The run layer on the GPU backend: device loss, failed and out-of-memory reads, headless runs
//! with the CPU's outputs and only the reads they need, validations, checkpoints, the adapter's
//! limits and every scene key.

use crate::support::*;

/// Issue 15 §4: a device lost in the middle of a run (here destroyed, as a driver reset would
/// lose it) stops the run with a diagnosis naming the device, not a panic; the mirror keeps
/// the last state downloaded (so the run loop keeps the outputs written so far).
#[test]
fn a_lost_device_stops_the_run_with_a_diagnosis() {
    use phonation::run::{Backend, FluidEngine};
    use phonation::step::{Part, Solver};
    if context().is_none() {
        return;
    }
    let mut e = FluidEngine::new(Backend::Gpu, scene(false, GasModel::Monatomic)).unwrap();
    e.advance(3).expect("a healthy device steps");
    let kept = phonation::state::state_hash(e.state().unwrap());
    e.lose_device();
    let err = e.advance(3).expect_err("a lost device must stop the run");
    eprintln!("{err}");
    assert_eq!(err.part, Part::Device, "{err}");
    assert!(err.reason.contains("device lost") && err.reason.contains("step 3's"), "{err}");
    assert_eq!((e.mirror().step_count, e.mirrored_step()), (3, 3), "the mirror keeps the last downloaded state");
    assert_eq!(phonation::state::state_hash(e.mirror()), kept, "the mirror keeps the last downloaded state");
}

/// A read of the state that fails (here the device is lost between an advance and the read)
/// leaves the mirror as it was — no zeros from the failed read reach it or the outputs — and
/// returns the diagnosis, which the next advance returns too.
#[test]
fn a_failed_read_leaves_the_mirror_and_stops_the_run() {
    use phonation::run::{Backend, FluidEngine};
    use phonation::step::{Part, Solver};
    if context().is_none() {
        return;
    }
    let solver = scene(false, GasModel::Monatomic);
    let initial = phonation::state::state_hash(&solver);
    let mut e = FluidEngine::new(Backend::Gpu, solver).unwrap();
    e.advance(3).expect("a healthy device steps");
    e.lose_device();
    let err = e.state().map(|_| ()).expect_err("the read must fail on a lost device");
    eprintln!("{err}");
    assert_eq!(err.part, Part::Device, "{err}");
    assert!(err.reason.contains("device lost") && err.reason.contains("reading step 3's state back") && err.reason.contains("step 0's"), "{err}");
    assert_eq!(e.mirror().step_count, 0, "the mirror keeps the uploaded state");
    assert_eq!(phonation::state::state_hash(e.mirror()), initial, "no zeros from the failed read");
    assert!(e.state_at(&[0]).is_err(), "no read after a failed one");
    // (value is NaN in every diagnosis of a device: compare the rest)
    let same = |a: &phonation::step::Instability| (a.part, a.step, a.reason.clone()) == (err.part, err.step, err.reason.clone());
    assert!(e.read_failure().is_some_and(same), "{:?}", e.read_failure());
    assert!(same(&e.advance(1).expect_err("the next advance reports the failed read")));
}

/// A real out-of-memory during a run: the device's memory is exhausted between two advances,
/// so the staging buffer of the next read of the state cannot be allocated. The read fails with
/// wgpu's own out-of-memory error in the diagnosis, the mirror keeps the last state brought
/// back, and the next advance stops with the same diagnosis — what the run loop turns into a
/// stop that keeps the outputs written so far.
///
/// lavapipe's device memory is the process's memory (malloc), so the test exhausts it for
/// real: it runs again in a child process of this test binary, whose address space is limited
/// (setrlimit) to what it uses after the first read plus 256 MiB, and fills that with buffers
/// (the filler's own failures caught by an error scope) from 256 MiB down to 1 MiB — below
/// gpu-allocator's smallest block, so that no block has room left for a staging buffer and no
/// new one can be made.
#[test]
fn an_out_of_memory_read_stops_the_run_with_a_diagnosis() {
    use phonation::run::{Backend, FluidEngine};
    use phonation::step::{Part, Solver};
    const NAME: &str = "runs::an_out_of_memory_read_stops_the_run_with_a_diagnosis";
    const CHILD: &str = "PHONATION_OUT_OF_MEMORY_CHILD";
    if std::env::var_os(CHILD).is_none() {
        if context().is_none() {
            return;
        }
        let out = std::process::Command::new(std::env::current_exe().unwrap())
            .args([NAME, "--exact", "--nocapture", "--test-threads=1"])
            .env(CHILD, "1")
            .output()
            .unwrap();
        let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        eprintln!("child process:\n{text}");
        assert!(out.status.success(), "the child process failed ({})", out.status);
        assert!(text.contains("1 passed") && text.contains("out-of-memory read checked"), "the child did not run the test");
        return;
    }
    // A 512² D2Q21 box: a whole state is 22 MB of f32 populations.
    let kind = VelocitySetKind::D2q21;
    let eq = Equilibrium::new(VelocitySet::new(kind), GasModel::Monatomic);
    let params = timestep::choose(0.01, 0.6, eq.set.max_l1_speed(), None, 0.8).unwrap();
    let solver = FluidSolver::new(eq, Grid::new(2, [512, 512, 1]), Boundaries::periodic(), &[], params, |x| Macro {
        rho: 1.0 + 0.01 * (0.05 * x[0]).sin(),
        u: [0.02, 0.01 * (0.03 * x[1]).cos(), 0.0],
        theta: 0.6,
    });
    let mut e = FluidEngine::new(Backend::Gpu, solver).expect("the box fits");
    e.advance(2).expect("a healthy device steps");
    let kept = phonation::state::state_hash(e.state().expect("the first read"));
    let device = e.gpu_device().expect("on the GPU").clone();
    let _ = device.poll(wgpu::PollType::wait_indefinitely());

    let used = std::fs::read_to_string("/proc/self/status")
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("VmSize:").map(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().unwrap() * 1024))
        .expect("VmSize");
    let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    assert_eq!(unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) }, 0);
    let unlimited = limit;
    limit.rlim_cur = used + (256 << 20);
    assert_eq!(unsafe { libc::setrlimit(libc::RLIMIT_AS, &limit) }, 0);

    let mut filler = Vec::new();
    let mut size: u64 = 256 << 20;
    while size >= 1 << 20 {
        loop {
            let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
            let b = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("filler"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            if pollster::block_on(scope.pop()).is_some() {
                break;
            }
            filler.push(b);
        }
        size /= 2;
    }
    let filled: u64 = filler.iter().map(|b: &wgpu::Buffer| b.size()).sum();
    eprintln!(
        "address space {} MiB used, limit {} MiB: {} MiB of device memory taken in {} buffers",
        used >> 20,
        limit.rlim_cur >> 20,
        filled >> 20,
        filler.len()
    );
    // At least the 256 MiB left less one block (64 MiB); more where the allocator kept free
    // blocks from earlier buffers (here, measured: 354 MiB).
    assert!(filled >= 192 << 20, "the filler took only {filled} B of the 256 MiB left");

    e.advance(2).expect("stepping allocates no device memory");
    let err = e.state().map(|_| ()).expect_err("no memory is left for the staging buffer");
    eprintln!("{err}");
    assert_eq!(err.part, Part::Device, "{err}");
    assert!(err.reason.contains("out of GPU memory"), "wgpu's out-of-memory error is the diagnosis: {err}");
    assert!(err.reason.contains("reading step 4's state back") && err.reason.contains("step 2's"), "{err}");
    assert_eq!(e.mirrored_step(), 2, "the mirror keeps the last state brought back");
    let next = e.advance(1).expect_err("the next advance reports the failed read");
    assert_eq!((next.part, next.step, next.reason.clone()), (err.part, err.step, err.reason.clone()));

    // The host's memory is as full as the device's (the same process): free it before the hash.
    drop(filler);
    assert_eq!(unsafe { libc::setrlimit(libc::RLIMIT_AS, &unlimited) }, 0);
    assert_eq!(phonation::state::state_hash(e.mirror()), kept, "no zeros from the failed read");
    eprintln!("out-of-memory read checked");
}

#[test]
fn headless_run_on_the_gpu_writes_the_same_probes_as_the_cpu() {
    use phonation::run::{Backend, RunOptions, run_scene};
    let Some(_ctx) = context() else { return };
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap();
    let sc = phonation::scene::load(&text).unwrap();
    let read = |backend: Backend| -> (String, Vec<Vec<f64>>) {
        let dir = std::env::temp_dir().join(format!("phonation-gpu-run-{backend:?}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let r = run_scene(&sc, &dir, &RunOptions { steps: Some(60), show_progress: false, backend, ..Default::default() }).unwrap();
        let rows =
            std::fs::read_to_string(dir.join("probes.csv")).unwrap().lines().skip(1).map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
        let _ = std::fs::remove_dir_all(&dir);
        (r.backend, rows)
    };
    let (b_cpu, cpu) = read(Backend::Cpu);
    let (b_gpu, gpu) = read(Backend::Gpu);
    assert!(b_cpu.starts_with("cpu") && b_gpu.starts_with("gpu"), "{b_cpu} / {b_gpu}");
    assert_eq!(cpu.len(), gpu.len());
    // Columns: step, time, pressure, density, ux, uy, temperature ratio.
    let last = (cpu.last().unwrap(), gpu.last().unwrap());
    assert_eq!(last.0[0], last.1[0]);
    for (c, g) in cpu.iter().zip(&gpu) {
        assert!((c[2] - g[2]).abs() < 1e-3 * 8000.0f64.max(c[2].abs()), "pressure {} vs {}", c[2], g[2]);
        assert!((c[4] - g[4]).abs() < 1e-3 * 10.0, "u {} vs {}", c[4], g[4]);
        assert!((c[5] - g[5]).abs() < 1e-3 * 10.0, "v {} vs {}", c[5], g[5]);
    }
}

/// A GPU run brings back only what its outputs read: each probe sample gathers the probes'
/// nodes on the device (not the lattice), snapshots and the end bring the whole state, once
/// per step. The probe rows are those of a run that brought the whole state back at every
/// sample, byte for byte (the same f32 populations; the moments taken on the CPU either way).
#[test]
fn a_gpu_run_brings_back_only_what_its_outputs_read() {
    use phonation::output::probes::ProbeWriter;
    use phonation::run::{Backend, FluidEngine, Readback, RunOptions, run_scene};
    use phonation::step::Solver;
    let Some(_ctx) = context() else { return };
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap()
        + "\n[output]\nprobe_every = 10\nsnapshots = 2\npng_fields = [\"speed\"]\nvtk = false\n";
    let sc = phonation::scene::load(&text).unwrap();
    let dir = std::env::temp_dir().join(format!("phonation-gpu-readback-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let r = run_scene(&sc, &dir, &RunOptions { steps: Some(60), show_progress: false, backend: Backend::Gpu, ..Default::default() }).unwrap();
    let lazy = std::fs::read_to_string(dir.join("probes.csv")).unwrap();

    // the same run, bringing back the whole state at every sample
    let mut e = FluidEngine::new(Backend::Gpu, sc.build_solver()).unwrap();
    let eager_path = dir.join("eager_probes.csv");
    let mut w = ProbeWriter::create(&eager_path, e.mirror(), &sc.probes).unwrap();
    w.sample(e.state().unwrap(), &sc.units).unwrap();
    assert_eq!(e.readback(), Readback::default(), "the uploaded state needs no readback");
    let mut whole = 0;
    for k in 1..=6 {
        e.advance(10).unwrap();
        w.sample(e.state().unwrap(), &sc.units).unwrap();
        whole = e.readback().bytes / k;
    }
    drop(w);
    let eager = std::fs::read_to_string(&eager_path).unwrap();
    assert_eq!(lazy.lines().count(), 8, "header, the start and six samples:\n{lazy}");
    assert_eq!(lazy, eager, "gathered probe nodes give the rows of whole readbacks");
    // a gathered node costs its populations only
    e.advance(1).unwrap();
    let before = e.readback().bytes;
    let nodes: Vec<usize> = sc.probes.iter().map(|(_, x)| sc.grid.index(*x)).collect();
    e.state_at(&nodes).unwrap();
    let per_node = e.readback().bytes - before;
    assert!(per_node > 0 && per_node * 100 < whole, "{per_node} B per node, {whole} B per state");

    let got = r.readback.expect("a GPU run reports its readback");
    eprintln!("readback of the GPU run: {got:?} ({whole} B per whole state, {per_node} B per probe node)");
    // two snapshots (steps 30 and 60, the second also the end's state), one probe node × 6 samples
    assert_eq!((got.whole_states, got.gathered), (2, 6), "{got:?}");
    assert_eq!(got.bytes, 2 * whole + 6 * per_node, "{got:?}");
    assert_eq!(e.step_count(), 61);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The lattice gas on the GPU brings back the probes' bands of rows only; the coarse fields and
/// the end bring the whole state. The probe rows and the final state are the CPU run's bit for
/// bit (the gas is integers).
#[test]
fn a_lattice_gas_run_on_the_gpu_brings_back_the_probes_rows_only() {
    use phonation::run::lattice_gas::run_lattice_gas_scene;
    use phonation::run::{Backend, RunOptions};
    let Some(_ctx) = context() else { return };
    let text = "name = \"small_wake\"\n[lattice_gas]\ncells = [32, 16, 2]\ndensity = 0.2\ninterference = 0.1\nsteps = 60\n\
                [lattice_gas.inlet]\nvelocity = 0.2\n[lattice_gas.cylinder]\ncenter = [16.0, 8.0]\nradius = 3.0\n\
                [lattice_gas.output]\ncoarse_block = 4\nevery = 30\nprobe_every = 5\n";
    let sc = phonation::scene::lattice_gas::LatticeGasScene::parse(text).unwrap();
    let run = |backend: Backend| {
        let dir = std::env::temp_dir().join(format!("phonation-gpu-lg-readback-{backend:?}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let r = run_lattice_gas_scene(&sc, &dir, &RunOptions { backend, show_progress: false, ..Default::default() }).unwrap();
        let probe = std::fs::read_to_string(dir.join("probe.csv")).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        (r, probe)
    };
    let (cpu, cpu_probe) = run(Backend::Cpu);
    let (gpu, gpu_probe) = run(Backend::Gpu);
    assert_eq!(gpu_probe.lines().count(), 13, "header and 12 samples:\n{gpu_probe}");
    assert_eq!(cpu_probe, gpu_probe, "the probes' rows give the CPU's samples");
    assert_eq!(cpu.state_hash, gpu.state_hash);
    assert!(cpu.readback.is_none() && gpu.device_failure.is_none());
    let got = gpu.readback.expect("a GPU run reports its readback");
    eprintln!("lattice-gas readback: {got:?}");
    // the coarse fields at 30 and 60 (the end's state too); each sample reads whole rows (32 × 2 cells)
    assert_eq!(got.whole_states, 2, "{got:?}");
    assert!(got.gathered > 0 && got.gathered % (12 * 64) == 0, "{got:?}");
    assert_eq!(got.bytes, 2 * 24 * (2 * 32 * 16 * 2 + got.gathered), "{got:?}");
}

/// The foundation issue's CI validations, on the GPU backend, with the same tolerances.
#[test]
fn validations_pass_on_the_gpu() {
    use phonation::run::Backend;
    use phonation::validation::{sod::SodCase, sound, taylor_green::TaylorGreenCase};
    let Some(_ctx) = context() else { return };
    let r = TaylorGreenCase::new(VelocitySetKind::D2q21, 64).run_on(Backend::Gpu).unwrap();
    eprintln!("GPU Taylor–Green 2D: decay-rate error {:e}", r.relative_error);
    assert!(r.relative_error.abs() < 0.02, "{r:?}");
    let mut c = TaylorGreenCase::new(VelocitySetKind::D3q39, 24);
    c.nu = 0.25;
    let r = c.run_on(Backend::Gpu).unwrap();
    eprintln!("GPU Taylor–Green 3D: decay-rate error {:e}", r.relative_error);
    assert!(r.relative_error.abs() < 0.02, "{r:?}");
    for (set, gas) in
        [(VelocitySetKind::D2q21, GasModel::Monatomic), (VelocitySetKind::D3q39, GasModel::Monatomic), (VelocitySetKind::D2q21, GasModel::Diatomic)]
    {
        let r = sound::sound_speed_on(set, gas, 64, Backend::Gpu).unwrap();
        eprintln!("GPU sound speed {set:?} γ = {}: error {:e}", r.gamma, r.relative_error);
        assert!(r.relative_error.abs() < 0.01, "{r:?}");
    }
    for gas in [GasModel::Monatomic, GasModel::Diatomic] {
        let mut c = SodCase::new(VelocitySetKind::D2q21, gas);
        c.scale = 0.7;
        let r = c.run_on(Backend::Gpu).unwrap();
        for (name, m, e, rel) in &r.plateaus {
            assert!(rel.abs() < 0.02, "GPU γ = {}: {name} {m} vs {e}", r.gamma);
        }
        assert!((r.shock_position.0 - r.shock_position.1).abs() <= 3.0 && (r.contact_position.0 - r.contact_position.1).abs() <= 3.0, "{r:?}");
    }
}

/// Checkpoint and resume on the GPU (fluid, lattice gas, solid without contact, a method-2
/// coupled flap whose walls uncover and cover nodes): a run stopped
/// after its checkpoint and resumed from it ends where the same GPU run that never stopped ends. The checkpoint holds the GPU state as
/// the CPU mirror received it (f32 values, exact in f64) and the resume uploads it back
/// unchanged, so the GPU continues bit for bit: the probes and the state hash are identical
/// (tighter than the parity bounds the issue allows).
#[test]
fn a_gpu_run_resumed_from_its_checkpoint_ends_as_the_whole_run() {
    use phonation::run::checkpoint::{Checkpoint, Checkpointing, FILE_NAME};
    use phonation::run::{Backend, RunOptions};
    use phonation::scene::Scene;
    let Some(_ctx) = context() else { return };
    let fluid = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap();
    let gas = "name = \"small_wake\"\n[lattice_gas]\ncells = [32, 16, 2]\ndensity = 0.2\ninterference = 0.1\nsteps = 60\n\
               [lattice_gas.inlet]\nvelocity = 0.2\n[lattice_gas.cylinder]\ncenter = [16.0, 8.0]\nradius = 3.0\n\
               [lattice_gas.output]\ncoarse_block = 4\nevery = 30\nprobe_every = 5\n";
    let plate = phonation::scene::builtin("oscillating_plate").unwrap();
    let flap = SMALL_FLAP.replace("[coupling]", "[output]\nprobe_every = 5\nsnapshots = 0\n[coupling]\noutput_every = 5");
    for (kind, text, csv) in
        [("fluid", fluid.as_str(), "probes.csv"), ("lattice_gas", gas, "probe.csv"), ("solid", plate, "solid.csv"), ("coupled", &flap, "coupling.csv")]
    {
        let run = |dir: &std::path::Path, every: Option<u64>, stop_at: Option<u64>, resume: Option<Checkpoint>| -> String {
            let o = RunOptions {
                steps: Some(60),
                show_progress: false,
                backend: Backend::Gpu,
                checkpoint: Checkpointing { every, resume, scene_text: text.to_string() },
                stop_at,
                ..Default::default()
            };
            match Scene::read(text).unwrap() {
                Scene::Fluid(sc) => phonation::run::run_scene(&sc, dir, &o).unwrap().state_hash,
                Scene::LatticeGas(sc) => phonation::run::lattice_gas::run_lattice_gas_scene(&sc, dir, &o).unwrap().state_hash,
                Scene::Solid(sc) => phonation::run::solid::run_solid_scene(&sc, dir, &o).unwrap().state_hash,
                Scene::Coupled(sc) => phonation::run::coupled::run_coupled_scene(&sc, dir, &o).unwrap().state_hash,
                _ => unreachable!(),
            }
        };
        let tmp = |t: &str| std::env::temp_dir().join(format!("phonation-gpu-resume-{kind}-{t}-{}", std::process::id()));
        let (whole, cut) = (tmp("whole"), tmp("cut"));
        let _ = (std::fs::remove_dir_all(&whole), std::fs::remove_dir_all(&cut));
        let h_whole = run(&whole, None, None, None);
        let h_stopped = run(&cut, Some(30), Some(45), None);
        assert_ne!(h_stopped, h_whole, "{kind}");
        let ck = Checkpoint::read(&cut.join(FILE_NAME)).unwrap();
        assert_eq!(ck.step, 30, "{kind}");
        let h_resumed = run(&cut, None, None, Some(ck));
        let (a, b) = (std::fs::read_to_string(whole.join(csv)).unwrap(), std::fs::read_to_string(cut.join(csv)).unwrap());
        assert!(a == b, "{kind}: {csv} differs after the resume on the GPU");
        assert_eq!(h_resumed, h_whole, "{kind}: the resumed GPU run's state differs");
        let _ = (std::fs::remove_dir_all(&whole), std::fs::remove_dir_all(&cut));
    }
}

/// A lattice larger than the adapter's limits is refused before anything is allocated (the
/// check is arithmetic on the node count; the run layer makes it before building the CPU
/// solver) with the figure needed, the adapter's figure and which limit it is.
#[test]
fn a_lattice_beyond_the_adapters_limits_is_refused_with_both_figures() {
    use phonation::gpu::GpuError;
    let Some(ctx) = context() else { return };
    let nv = 21;
    // the adapter's own max_buffer_size: one population array one node too many
    let max = ctx.limits.max_buffer_size;
    let nodes = (max / 4 / nv as u64) as usize + 64;
    let e = GpuFluid::fits(&ctx.limits, nodes, nv).unwrap_err();
    let GpuError::TooLarge { bytes, limit, limit_name, .. } = &e else { panic!("{e}") };
    assert!(*bytes > *limit && *limit == max && *limit_name == "max_buffer_size", "{e}");
    let msg = e.to_string();
    assert!(msg.contains(&bytes.to_string()) && msg.contains(&max.to_string()), "{msg}");
    // one population beyond a storage binding, and too many bindings for one kernel
    let small = context().unwrap().with_binding_limit(4096);
    // (the arrays hold 256 nodes past a lattice this small for the thin walls' side ghosts)
    let e = GpuFluid::fits(&small.limits, 2048, nv).unwrap_err();
    assert!(e.to_string().contains("max_storage_buffer_binding_size") && e.to_string().contains("9216"), "{e}");
    let e = GpuFluid::fits(&small.limits, 768, nv).unwrap_err();
    assert!(e.to_string().contains("storage bindings"), "{e}");
    // and one that fits is split as the kernels expect
    let split = GpuFluid::fits(&ctx.limits, 4096, nv).unwrap();
    assert_eq!(split.nv, nv);
}

/// No setting silently ignored, on the GPU backends: every number and flag of a small scene of
/// each kind the GPU runs (the fluid channel of tests/good_base.toml, the oscillating plate, a
/// lattice-gas wake, the method-2 flap), nudged as in tests/scenes.rs
/// `every_scene_key_changes_the_state_or_is_refused`, is refused (by the reader, the build or
/// the GPU backend, naming a field) or changes the state the GPU reaches in two steps.
#[test]
fn every_scene_key_changes_the_gpu_state_or_is_refused() {
    use phonation::run::{Backend, CoupledEngine, FluidEngine, LatticeGasEngine, SolidEngine};
    use phonation::scene::Scene;
    use phonation::state::state_hash;
    use phonation::step::Solver;
    let Some(_ctx) = context() else { return };
    // the state after two GPU steps, or the refusal
    fn gpu_hash(s: &Scene) -> Result<String, String> {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        Ok(match s {
            Scene::Fluid(sc) => {
                let mut g = FluidEngine::new(Backend::Gpu, sc.build_solver()).map_err(|x| e(&x))?;
                g.advance(2).map_err(|x| e(&x))?;
                state_hash(g.state().map_err(|x| e(&x))?) + &serde_json::to_string(&sc.summary()).unwrap()
            }
            Scene::Solid(sc) => {
                let mut g = SolidEngine::new(Backend::Gpu, sc.build().map_err(|x| e(&x))?, sc.file.solid.cg_tolerance).map_err(|x| e(&x))?;
                g.advance(2).map_err(|x| e(&x))?;
                state_hash(&g.solver)
            }
            Scene::LatticeGas(sc) => {
                let mut g = LatticeGasEngine::new(Backend::Gpu, sc.build()).map_err(|x| e(&x))?;
                g.advance(2).map_err(|x| e(&x))?;
                state_hash(g.state().map_err(|x| e(&x))?)
            }
            Scene::Coupled(sc) => {
                let mut g = CoupledEngine::new(Backend::Gpu, sc.build().map_err(|x| e(&x))?, sc.solid.file.solid.cg_tolerance).map_err(|x| e(&x))?;
                g.advance(2).map_err(|x| e(&x))?;
                state_hash(g.state().map_err(|x| e(&x))?) + &serde_json::to_string(&sc.fluid.summary()).unwrap()
            }
            Scene::TwoMass(_) => unreachable!("no GPU backend"),
        })
    }
    let fluid = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap();
    // a radius of 3.5 ℓ: cell centres lie on a 2 ℓ lattice, so a 25 % nudge of 3 ℓ marks the
    // same cells (the discrete cylinder changes at 2, 2.83, 4 ℓ); from 3.5 it reaches 4
    let gas = "name = \"small_wake\"\n[lattice_gas]\ncells = [32, 16, 2]\ndensity = 0.2\ninterference = 0.1\nsteps = 60\n\
               [lattice_gas.inlet]\nvelocity = 0.2\n[lattice_gas.cylinder]\ncenter = [16.0, 8.0]\nradius = 3.5\n";
    let scenes = [
        ("good_base", fluid.as_str()),
        ("oscillating_plate", phonation::scene::builtin("oscillating_plate").unwrap()),
        ("small_wake", gas),
        ("small_flap", SMALL_FLAP),
        ("towed_disc", TOWED_DISC),
    ];
    let (mut checked, mut refused) = (0, 0);
    let mut ignored = Vec::new();
    for (name, text) in scenes {
        let h0 = gpu_hash(&Scene::read(text).unwrap()).unwrap_or_else(|e| panic!("{name}: {e}"));
        for (key, nudged) in crate::common::nudged_scenes(text) {
            checked += 1;
            let Ok(s) = Scene::read(&nudged) else {
                refused += 1;
                continue;
            };
            match gpu_hash(&s) {
                Err(_) => refused += 1,
                Ok(h) if h != h0 => {}
                Ok(_) => ignored.push(format!("{name}: {key}")),
            }
        }
    }
    eprintln!("{checked} keys nudged on the GPU, {refused} refused");
    assert!(checked > 40);
    assert!(ignored.is_empty(), "keys with no effect on the GPU state after two steps and not refused: {ignored:#?}");
}

/// Issue 16's scaling table on the device (`bench --only scaling --backend gpu`): every kernel
/// at every size, each row's byte count the same as its own bench's (FDLB `lattice_speed`, the
/// solid `solid_speed`, the lattice gas's 12 B a site), its rate and fraction consistent, and a
/// size the device cannot hold left out with the reason while the rest of the table comes back.
#[test]
fn the_gpu_scaling_table_times_every_kernel_and_leaves_out_what_does_not_fit() {
    use phonation::gpu::scaling::{ScalingSizes, scaling_table};
    let Some(ctx) = context() else { return };
    let bw = phonation::gpu::bench::copy_bandwidth(&ctx, 1 << 20, 2);
    // a device whose buffers (700 KiB) hold a 32² D2Q21 lattice's populations and an 8³ D3Q39 one's, not a 96² D2Q21 one's (870,912 B)
    let small = context().unwrap().with_buffer_limit(700 << 10);
    let sizes = ScalingSizes { d2q21: vec![32, 96], d3q39: vec![8], solid_sides: vec![6, 8], gas_cells: vec![[16, 8, 8], [32, 16, 8]] };
    let (rows, skipped) = scaling_table(&small, &sizes, 0.01, bw);
    let got: Vec<(&str, usize)> = rows.iter().map(|r| (r.kernel.as_str(), r.size)).collect();
    assert_eq!(
        got,
        [
            ("D2Q21", 32 * 32),
            ("D3Q39", 8 * 8 * 8),
            ("solid (explicit)", 6 * 6 * 6),
            ("solid (explicit)", 8 * 8 * 8),
            ("lattice gas", 16 * 16 * 8 * 8),
            ("lattice gas", 16 * 32 * 16 * 8)
        ]
    );
    assert_eq!(skipped.len(), 1, "{skipped:?}");
    assert_eq!(skipped[0], "D2Q21 [96, 96, 1]: one population array needs 870912 bytes, more than the adapter's max_buffer_size of 716800");
    let fdlb = |set, n| phonation::gpu::bench::lattice_speed(&ctx, set, n, 3, bw).bytes_per_node_update;
    let solid = |side| phonation::gpu::bench::solid_speed(&ctx, side, Integrator::Explicit, Default::default(), 3, bw).unwrap().bytes_per_update;
    for r in &rows {
        let bytes = match r.kernel.as_str() {
            "D2Q21" => fdlb(VelocitySetKind::D2q21, [32, 32, 1]),
            "D3Q39" => fdlb(VelocitySetKind::D3q39, [8, 8, 8]),
            "lattice gas" => 12.0,
            _ => solid((r.size as f64).cbrt().round() as usize),
        };
        assert_eq!(r.bytes_per_update, bytes, "{r:?}");
        assert!(r.steps >= 3 && r.updates_per_s.is_finite() && r.updates_per_s > 0.0, "{r:?}");
        assert!((r.ns_per_update * r.updates_per_s / 1e9 - 1.0).abs() < 1e-12, "{r:?}");
        assert!((r.bandwidth_fraction * bw / (r.updates_per_s * r.bytes_per_update) - 1.0).abs() < 1e-12, "{r:?}");
    }
}
