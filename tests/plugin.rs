//! The Bevy plugin in a headless app (MinimalPlugins): stepping through the plugin gives exactly
//! the same fields as stepping the solver directly; pause and single-step work; an unstable run
//! is reported on the entity.
#![cfg(feature = "bevy")]

use bevy::prelude::*;
use phonation::plugin::{FluidDiagnostics, FluidSimulation, FluidStatus, PhonationPlugin, SimulationControl};
use phonation::scene;

fn scene() -> scene::FluidScene {
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap();
    scene::load(&text).unwrap()
}

/// Bevy's default plugins without the window loop (winit needs a display; these apps are
/// updated by hand).
fn headless_default_plugins(p: bevy::app::PluginGroupBuilder) -> bevy::app::PluginGroupBuilder {
    #[cfg(feature = "render")]
    let p = p.disable::<bevy::winit::WinitPlugin>();
    p
}

/// Whether a GPU adapter (lavapipe in CI) exists; without one a GPU test is skipped, except in
/// CI, where it must run.
fn has_gpu() -> bool {
    match phonation::gpu::GpuContext::new() {
        Ok(_) => true,
        Err(e) if std::env::var("CI").is_ok_and(|v| v == "true") => panic!("CI must run the GPU tests, but {e}"),
        Err(e) => {
            eprintln!("SKIPPED: no GPU adapter ({e})");
            false
        }
    }
}

/// A headless app with Bevy's renderer (no window, no camera) and the GPU plugin, ready to be
/// updated by hand; None (the test skipped) without an adapter outside CI.
fn render_world_app() -> Option<App> {
    use bevy::app::PluginsState;
    use bevy::window::{ExitCondition, WindowPlugin};
    if !has_gpu() {
        return None;
    }
    let mut app = App::new();
    app.add_plugins((
        headless_default_plugins(
            DefaultPlugins.set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() }).disable::<bevy::log::LogPlugin>(),
        ),
        PhonationPlugin,
        phonation::plugin::PhonationGpuPlugin,
    ));
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    Some(app)
}

fn app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, PhonationPlugin));
    app
}

#[test]
fn plugin_steps_give_exactly_the_direct_solver_fields() {
    let sc = scene();
    let mut app = app();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 3, single_steps: 0 });
    let e = app.world_mut().spawn(FluidSimulation::from_scene(&sc)).id();
    for _ in 0..10 {
        app.update();
    }
    let mut direct = sc.build_solver();
    direct.run(30).unwrap();
    let sim = app.world().get::<FluidSimulation>(e).unwrap();
    assert_eq!(sim.solver.step_count, 30);
    assert_eq!(sim.solver.f.len(), direct.f.len());
    assert!(sim.solver.f.iter().zip(&direct.f).all(|(a, b)| a.to_bits() == b.to_bits()), "fields differ");
    let d = app.world().get::<FluidDiagnostics>(e).unwrap();
    assert_eq!(d.steps, 30);
    assert!(d.mass_drift.abs() < 0.05);
}

#[test]
fn pause_and_single_step() {
    let sc = scene();
    let mut app = app();
    app.insert_resource(SimulationControl { paused: true, steps_per_frame: 5, single_steps: 0 });
    let e = app.world_mut().spawn(FluidSimulation::from_scene(&sc)).id();
    app.update();
    app.update();
    assert_eq!(app.world().get::<FluidSimulation>(e).unwrap().solver.step_count, 0);
    app.world_mut().resource_mut::<SimulationControl>().single_steps = 2;
    app.update();
    app.update();
    assert_eq!(app.world().get::<FluidSimulation>(e).unwrap().solver.step_count, 2);
}

#[test]
fn unstable_simulation_is_marked_and_stops() {
    let mut sc = scene();
    sc.params.dt = 1.0;
    sc.params.tau = 1.0;
    sc.params.a = 0.0;
    let mut app = app();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 50, single_steps: 0 });
    let e = app.world_mut().spawn(FluidSimulation::from_scene(&sc)).id();
    for _ in 0..40 {
        app.update();
    }
    let status = app.world().get::<FluidStatus>(e).cloned();
    let Some(FluidStatus::Unstable(err)) = status else { panic!("expected an unstable status, got {status:?}") };
    let steps = app.world().get::<FluidSimulation>(e).unwrap().solver.step_count;
    assert_eq!(steps, err.step, "stepping stopped at the failing step");
    app.update();
    assert_eq!(app.world().get::<FluidSimulation>(e).unwrap().solver.step_count, steps);
}

/// The render-world GPU path on lavapipe (or a real GPU): a headless app with Bevy's renderer,
/// no window. The probe values read back through `Readback`, tagged with their step index, must
/// equal the CPU backend's at that step (f32 tolerance).
#[test]
fn gpu_stepping_in_the_render_world_matches_the_cpu() {
    use phonation::plugin::{GpuProbes, GpuStepping};
    let Some(mut app) = render_world_app() else { return };
    let sc = scene();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 8, single_steps: 0 });
    // the panel's plot of the first probe (the panel itself needs a window)
    #[cfg(feature = "render")]
    app.add_systems(Update, phonation::render::plots::record_plots);
    let e = app.world_mut().spawn((FluidSimulation::from_scene(&sc), GpuStepping)).id();
    let mut got = None;
    // 200 steps: the inflow (an acoustic front from the inlet) has reached the probe by then.
    for _ in 0..400 {
        app.update();
        if let Some(p) = app.world().get::<GpuProbes>(e)
            && p.step >= 200
        {
            got = Some(p.clone());
            break;
        }
    }
    let probes = got.expect("probe readbacks reach step 200 within 400 frames");
    eprintln!("render-world GPU probes at step {} after {} readbacks: {:?}", probes.step, probes.readbacks, probes.values);
    assert_eq!(probes.values.len(), sc.probes.len());
    assert_eq!(probes.step % 8, 0, "steps are recorded 8 per frame");
    assert!(probes.values[0][1] > 0.01, "the flow has reached the probe: {:?}", probes.values);
    // The CPU mirror was not stepped (the entity is GPU-stepped).
    assert_eq!(app.world().get::<FluidSimulation>(e).unwrap().solver.step_count, 0);
    // What the panel shows of it comes from the device's readbacks, not from the CPU mirror's
    // initial state: the backend, the time and step, and the probe's plot (one point per
    // readback, at its step's time).
    #[cfg(feature = "render")]
    {
        use phonation::render::panel::fluid_status;
        use phonation::render::plots::{PROBE_UY_CM_S, PlotHistory, first_probe_uy};
        let sim = app.world().get::<FluidSimulation>(e).unwrap();
        let [backend, time] = fluid_status(sim, Some(&probes));
        assert!(backend.starts_with("GPU backend"), "{backend}");
        assert!(time.ends_with(&format!("(step {} read back)", probes.step)), "{time}");
        let series = app.world().get::<PlotHistory>(e).and_then(|h| h.get(PROBE_UY_CM_S)).expect("the probe's plot");
        let points: Vec<[f64; 2]> = series.points.iter().copied().collect();
        let now = first_probe_uy(sim, Some(&probes)).unwrap();
        let last = *points.last().unwrap();
        eprintln!(
            "probe plot: {} points, t {:.4} … {:.4} ms; the last readback at {:.4} ms, u_y {:.3} cm/s",
            points.len(),
            points[0][0],
            last[0],
            now[0],
            now[1]
        );
        // (the first readback may be of step 0)
        assert!(points.len() >= 5 && points.windows(2).all(|w| w[1][0] > w[0][0]) && last[0] > 0.0, "{points:?}");
        assert!(last[0] <= now[0] && (last[0] < now[0] || last[1] == now[1]), "{last:?} vs {now:?}");
    }
    let mut cpu = sc.build_solver();
    cpu.run(probes.step).unwrap();
    for (k, (_, x)) in sc.probes.iter().enumerate() {
        let m = cpu.macro_at_coords(*x);
        let g = probes.values[k];
        let cpu_vals = [m.rho, m.u[0], m.u[1], m.u[2], m.theta];
        for j in 0..5 {
            assert!(
                (g[j] as f64 - cpu_vals[j]).abs() < 1e-4 * cpu_vals[j].abs().max(0.05),
                "probe {k} value {j} at step {}: GPU {} CPU {}",
                probes.step,
                g[j],
                cpu_vals[j]
            );
        }
    }

    // GpuStepping taken off (paused): a frame later the device's state comes back into the
    // entity's solver — its step and probes those of the CPU run to that step within the same
    // f32 bound — and, unpaused, the CPU steps it on
    app.insert_resource(SimulationControl { paused: true, steps_per_frame: 8, single_steps: 0 });
    app.world_mut().entity_mut(e).remove::<GpuStepping>();
    app.update();
    assert!(app.world().get::<phonation::plugin::GpuFluidHandle>(e).is_some(), "on its way back: a frame with no steps first");
    app.update();
    assert!(app.world().get::<phonation::plugin::GpuFluidHandle>(e).is_none() && app.world().get::<GpuProbes>(e).is_none(), "the device's copy is dropped");
    let back = app.world().get::<FluidSimulation>(e).unwrap().solver.step_count;
    assert!(back >= probes.step && back % 8 == 0, "brought back at step {back} (probes of step {})", probes.step);
    cpu.run(back - probes.step).unwrap();
    let sim = &app.world().get::<FluidSimulation>(e).unwrap().solver;
    for (k, (_, x)) in sc.probes.iter().enumerate() {
        let (m, c) = (sim.macro_at_coords(*x), cpu.macro_at_coords(*x));
        for (g, w) in [m.rho, m.u[0], m.u[1], m.u[2], m.theta].into_iter().zip([c.rho, c.u[0], c.u[1], c.u[2], c.theta]) {
            assert!((g - w).abs() < 1e-4 * w.abs().max(0.05), "probe {k} at step {back}: brought back {g}, CPU {w}");
        }
    }
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 8, single_steps: 0 });
    app.update();
    assert_eq!(app.world().get::<FluidSimulation>(e).unwrap().solver.step_count, back + 8, "stepped on the CPU from the step brought back");
}

#[test]
fn plugin_steps_the_solid_exactly_like_the_direct_solver() {
    use phonation::plugin::{SolidDiagnostics, SolidSimulation};
    use phonation::scene::solid::SolidScene;
    let sc = SolidScene::parse(scene::builtin("oscillating_plate").unwrap()).unwrap();
    let mut app = app();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 20, single_steps: 0 });
    let e = app.world_mut().spawn(SolidSimulation { solver: sc.build().unwrap() }).id();
    for _ in 0..10 {
        app.update();
    }
    let mut direct = sc.build().unwrap();
    for _ in 0..200 {
        direct.step().unwrap();
    }
    let sim = app.world().get::<SolidSimulation>(e).unwrap();
    assert_eq!(sim.solver.step_count, 200);
    let same = sim
        .solver
        .particles
        .position
        .iter()
        .zip(&direct.particles.position)
        .all(|(a, b)| a.to_array().iter().zip(b.to_array()).all(|(x, y)| x.to_bits() == y.to_bits()));
    assert!(same, "positions differ");
    let d = app.world().get::<SolidDiagnostics>(e).unwrap();
    println!("solid through the plugin: {} steps, energies {:?}", d.steps, d.energies);
    assert_eq!(d.steps, 200);
    assert!(d.energies.kinetic > 0.0 && d.energies.elastic > 0.0);
}

/// Issue 14 §2: a solid with [`GpuStepping`] is stepped on Bevy's render device in the render
/// world; the particles that come back each frame are bit for bit those of the run layer's GPU
/// backend stepped directly on a device of its own (the same kernels, the same steps per
/// submission), within the f32 parity bound of the CPU's, and the diagnostics read them. Taken
/// off the device, the solid comes back with the device's particles and steps on on the CPU.
#[test]
fn a_solid_stepped_in_the_render_world_matches_the_gpu_backend() {
    use phonation::plugin::{GpuSolidHandle, GpuStepping, SolidDiagnostics, SolidSimulation, SolidStatus};
    use phonation::run::{Backend, SolidEngine};
    use phonation::scene::solid::SolidScene;
    use phonation::step::Solver;
    let Some(mut app) = render_world_app() else { return };
    let sc = SolidScene::parse(scene::builtin("oscillating_plate").unwrap()).unwrap();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 20, single_steps: 0 });
    let e = app.world_mut().spawn((SolidSimulation { solver: sc.build().unwrap() }, GpuStepping)).id();
    let mut step = 0;
    for _ in 0..100 {
        app.update();
        step = app.world().get::<SolidSimulation>(e).unwrap().solver.step_count;
        if step >= 200 {
            break;
        }
    }
    assert!(step >= 200 && step % 20 == 0, "readbacks reach step 200 within 100 frames, 20 steps a frame (step {step})");
    let w = app.world();
    assert!(w.get::<GpuSolidHandle>(e).is_some(), "stepped on the render device");
    assert_eq!(w.get::<SolidStatus>(e), None, "still running");
    let sim = w.get::<SolidSimulation>(e).unwrap();
    let d = w.get::<SolidDiagnostics>(e).unwrap();
    let mut direct = SolidEngine::new(Backend::Gpu, sc.build().unwrap(), None).unwrap();
    for _ in 0..step / 20 {
        direct.advance(20).unwrap();
    }
    let bits = |s: &phonation::solid::SolidSolver| {
        s.particles.position.iter().chain(&s.particles.velocity).flat_map(|p| p.to_array()).map(f64::to_bits).collect::<Vec<_>>()
    };
    println!("solid in the render world: {} steps, energies {:?}", d.steps, d.energies);
    assert_eq!(bits(&sim.solver), bits(&direct.solver), "positions or velocities differ from the GPU backend's");
    assert_eq!(d.steps, step);
    assert!(d.energies.kinetic > 0.0 && d.energies.elastic > 0.0);
    // the CPU reference: within 1e-3 of the largest displacement, the bound of the GPU solid's
    // own parity test (tests/gpu/solid.rs `solid_whole_steps_match_the_cpu_backend`: f32 state)
    let mut cpu = sc.build().unwrap();
    cpu.advance(step).unwrap();
    let p = &sim.solver.particles;
    let largest = cpu.particles.position.iter().zip(&cpu.particles.reference).map(|(x, r)| (*x - *r).length()).fold(0.0, f64::max);
    let worst = p.position.iter().zip(&cpu.particles.position).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    println!("largest CPU displacement {largest:.3e}, the render world's positions within {worst:.2e}");
    assert!(largest > 0.0 && worst <= 1e-3 * largest, "positions off the CPU's by {worst:e} (largest displacement {largest:e})");

    // GpuStepping taken off (paused): the device's particles come back, the direct backend's
    // bits at that step; unpaused, the CPU steps on from there
    app.insert_resource(SimulationControl { paused: true, steps_per_frame: 20, single_steps: 0 });
    app.world_mut().entity_mut(e).remove::<GpuStepping>();
    app.update();
    assert!(app.world().get::<GpuSolidHandle>(e).is_none(), "the device's copy is dropped");
    let back = app.world().get::<SolidSimulation>(e).unwrap().solver.clone();
    assert!(back.step_count >= step && back.step_count % 20 == 0, "brought back at step {}", back.step_count);
    direct.advance(back.step_count - step).unwrap();
    assert_eq!(bits(&back), bits(&direct.solver), "the particles brought back differ from the GPU backend's");
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 20, single_steps: 0 });
    app.update();
    let now = &app.world().get::<SolidSimulation>(e).unwrap().solver;
    assert_eq!(now.step_count, back.step_count + 20, "stepped on the CPU from the step brought back");
    assert!(bits(now) != bits(&back));
}

#[test]
fn plugin_steps_the_coupled_solver_exactly_like_the_direct_solver_through_pause_and_single_steps() {
    use phonation::plugin::{CoupledDiagnostics, CoupledSimulation};
    use phonation::scene::coupled::CoupledScene;
    let sc = CoupledScene::parse(scene::builtin("fsi_cylinder").unwrap()).unwrap();
    let mut app = app();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 4, single_steps: 0 });
    let e = app.world_mut().spawn(CoupledSimulation { solver: sc.build().unwrap() }).id();
    for _ in 0..3 {
        app.update();
    }
    // Paused: nothing moves until a single step is asked for.
    app.world_mut().resource_mut::<SimulationControl>().paused = true;
    app.update();
    app.world_mut().resource_mut::<SimulationControl>().single_steps = 1;
    app.update();
    app.update();
    let mut direct = sc.build().unwrap();
    direct.run(13).unwrap();
    let sim = app.world().get::<CoupledSimulation>(e).unwrap();
    assert_eq!(sim.solver.step_count, 13);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&sim.solver.fluid.f), bits(&direct.fluid.f), "air populations differ");
    let pos = |s: &phonation::coupling::CoupledSolver| s.solid.particles.position.iter().flat_map(|p| p.to_array()).map(f64::to_bits).collect::<Vec<_>>();
    assert_eq!(pos(&sim.solver), pos(&direct), "particle positions differ");
    let d = app.world().get::<CoupledDiagnostics>(e).unwrap();
    assert_eq!(d.steps, 13);
    assert!(d.body_forces[0].x > 0.0, "the air pushes the cylinder downstream: {:?}", d.body_forces);
}

#[test]
fn plugin_samples_the_glottis_of_a_coupled_glottis_scene_every_step() {
    use phonation::plugin::{CoupledGlottis, CoupledSimulation, VoiceDiagnostics};
    use phonation::scene::coupled::CoupledScene;
    let sc = CoupledScene::parse(scene::builtin("glottis_2d_coarse").unwrap()).unwrap();
    let mut app = app();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 100, single_steps: 0 });
    let solver = sc.build().unwrap();
    let glottis = CoupledGlottis::of(&sc, &solver, 0.05).expect("two folds make a glottis");
    let e = app.world_mut().spawn((CoupledSimulation { solver }, glottis)).id();
    for _ in 0..3 {
        app.update();
    }
    app.world_mut().resource_mut::<SimulationControl>().paused = true;
    app.world_mut().resource_mut::<SimulationControl>().single_steps = 1;
    app.update();
    // the direct solver after the same 301 steps, sampled the same way
    let mut direct = sc.build().unwrap();
    let g = sc.glottis(&direct).unwrap();
    let mut flows = Vec::new();
    for _ in 0..301 {
        direct.step().unwrap();
        flows.push(g.sample(&direct).flow);
    }
    let want = g.sample(&direct);
    let d = app.world().get::<VoiceDiagnostics>(e).unwrap();
    assert_eq!(d.steps, 301);
    // the lung pressure has reached the folds: the area moved off the seed's 0.021 × 1.4 cm²
    assert!((want.area - 0.0294).abs() > 1e-6, "area {}", want.area);
    assert_eq!((d.area.to_bits(), d.flow.to_bits()), (want.area.to_bits(), want.flow.to_bits()));
    let kept = &app.world().get::<CoupledGlottis>(e).unwrap().flow;
    assert_eq!(kept.iter().map(|f| f.to_bits()).collect::<Vec<_>>(), flows.iter().map(|f| f.to_bits()).collect::<Vec<_>>());
    assert!(d.measures.is_none() && d.no_voice.is_some(), "0.1 ms of flow has no voice yet");
}

/// Issue 14 §2: a coupled glottis with [`GpuStepping`] is stepped on Bevy's render device in the
/// render world (the run layer's GPU backend, uploaded once), and what comes back to the main
/// world — the glottal flow of every step, the solid, the air's totals — is bit for bit what the
/// same backend gives stepped directly on a device of its own (the same kernels in the same
/// order; lavapipe in CI), and follows the CPU reference within the f32 bound. The main world's
/// air is not stepped on the CPU. Taken off the device, the entity gets the device's whole
/// state back, bit for bit, and steps on on the CPU.
#[test]
fn a_coupled_glottis_stepped_in_the_render_world_matches_the_gpu_backend() {
    use phonation::plugin::{CoupledGlottis, CoupledSimulation, CoupledStatus, GpuCoupledHandle, GpuCoupledReadback, GpuStepping, VoiceDiagnostics};
    use phonation::run::{Backend, CoupledEngine};
    use phonation::scene::coupled::CoupledScene;
    use phonation::step::Solver;
    let Some(mut app) = render_world_app() else { return };
    // glottis_2d_coarse's gap (0.021 cm) is narrower than a cell: no air passes until the folds
    // part (none in 1,500 steps). Opened to 0.08 cm (3.3 cells; the section's width kept, so
    // D = width + G = 0.85 cm, and the clamped strip 0.06 cm deep, so that the lateral faces
    // stay beyond the side walls and the free parts inside them), the lung pressure's jet goes
    // through from step ~150 (CPU run).
    let open = scene::builtin("glottis_2d_coarse")
        .unwrap()
        .replace("fold = { side", "fold = { section = { gap = 0.08, d = 0.85 }, side")
        .replace("fixed_depth = 0.025", "fixed_depth = 0.06");
    let sc = CoupledScene::parse(&open).unwrap();
    const STEPS: u64 = 260;
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 20, single_steps: 0 });
    let solver = sc.build().unwrap();
    let initial_f = solver.fluid.f.clone();
    let glottis = CoupledGlottis::of(&sc, &solver, 1.0).expect("two folds make a glottis");
    let e = app.world_mut().spawn((CoupledSimulation { solver }, glottis, GpuStepping)).id();
    let mut step = 0;
    for _ in 0..200 {
        app.update();
        step = app.world().get::<GpuCoupledReadback>(e).map_or(0, |r| r.step);
        if step >= STEPS {
            break;
        }
    }
    assert!(step >= STEPS, "readbacks reach step {STEPS} within 200 frames (step {step})");
    let w = app.world();
    assert_eq!(w.get::<CoupledStatus>(e), None, "still running");
    let readback = w.get::<GpuCoupledReadback>(e).unwrap().clone();
    let sim = w.get::<CoupledSimulation>(e).unwrap();
    let kept: Vec<f64> = w.get::<CoupledGlottis>(e).unwrap().flow.iter().copied().collect();
    let voice = w.get::<VoiceDiagnostics>(e).unwrap();
    assert_eq!((sim.solver.step_count, voice.steps, kept.len() as u64), (step, step, step), "one flow sample per step, as many as steps");
    assert!(sim.solver.fluid.f == initial_f, "the main world's air was not stepped on the CPU");

    // the same backend on a device of its own, sampled the same way
    let mut direct = CoupledEngine::new(Backend::Gpu, sc.build().unwrap(), None).unwrap();
    let g = sc.glottis(direct.solver()).unwrap();
    let mut flows = Vec::new();
    for _ in 0..step {
        direct.step().unwrap();
        let mut section = None;
        let c = direct
            .observe(|c| {
                let s = g.section(c);
                let nodes = s.nodes.clone();
                section = Some(s);
                nodes
            })
            .unwrap();
        flows.push(section.unwrap().sample(&c.fluid).flow);
    }
    let totals = direct.totals().unwrap();
    let c = direct.observe(|_| Vec::new()).unwrap();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let pos = |s: &phonation::coupling::CoupledSolver| s.solid.particles.position.iter().flat_map(|p| p.to_array()).map(f64::to_bits).collect::<Vec<_>>();
    eprintln!(
        "render world: step {step} after {} readbacks, flow {:.3} cm³/s, area {:.5} cm², air mass {:.6}",
        readback.readbacks,
        kept[kept.len() - 1],
        voice.area,
        readback.totals.unwrap().mass
    );
    assert_eq!(bits(&kept), bits(&flows), "glottal flows differ from the GPU backend's");
    assert_eq!(pos(&sim.solver), pos(c), "particle positions differ from the GPU backend's");
    assert_eq!(readback.totals, Some(totals), "the air's totals differ from the GPU backend's");
    assert_eq!(voice.area.to_bits(), g.sample(c).area.to_bits());

    // and the CPU reference, step by step. The populations' f32 parity bound (1e-4, tests/gpu/)
    // carries to the section's flux ρu_y as 1e-4 × c/u_jet ≈ 6e-4 (u_jet ≈ 0.17 of the lattice
    // speed): once the jet is established (flow ≥ ¼ of the largest) the flow is held to 1e-3 of
    // the largest (measured on lavapipe: 1.6e-4). While the folds part (steps ~120–220, the
    // flow changing sign) the front's arrival moves by up to a tenth of a step between f32 and
    // f64 (measured: 0.18 cm³/s at 8 cm³/s rising 1.75 per step, 1.2e-3 of the largest): every
    // step is held to 3e-3 of the largest. The lung pressure drives a jet of > 50 cm³/s by then.
    let mut cpu = sc.build().unwrap();
    let mut want = Vec::with_capacity(kept.len());
    for _ in &kept {
        cpu.step().unwrap();
        want.push(g.sample(&cpu).flow);
    }
    let largest = want.iter().fold(0.0f64, |m, w| m.max(w.abs()));
    let off =
        |jet_only: bool| kept.iter().zip(&want).filter(|(_, w)| !jet_only || w.abs() >= 0.25 * largest).map(|(f, w)| (f - w).abs()).fold(0.0f64, f64::max);
    let (worst, worst_jet) = (off(false), off(true));
    eprintln!("largest CPU flow {largest:.4} cm³/s; the render world's within {worst:.2e} over every step, {worst_jet:.2e} in the jet");
    assert!(largest > 50.0, "the jet has formed by step {step}: largest flow {largest} cm³/s");
    assert!(worst_jet <= 1e-3 * largest, "flow in the jet off the CPU's by {worst_jet:e} (largest {largest:e})");
    assert!(worst <= 3e-3 * largest, "flow off the CPU's by {worst:e} (largest {largest:e})");

    // GpuStepping taken off (paused, so that the frame steps nowhere): the device's whole state
    // comes back into the entity's solver, the same bits as the direct backend's at that step;
    // unpaused, the CPU steps it on from there
    app.insert_resource(SimulationControl { paused: true, steps_per_frame: 20, single_steps: 0 });
    app.world_mut().entity_mut(e).remove::<GpuStepping>();
    app.update();
    let w = app.world();
    assert!(w.get::<GpuCoupledHandle>(e).is_none() && w.get::<GpuCoupledReadback>(e).is_none(), "the device's copy is dropped");
    let back = w.get::<CoupledSimulation>(e).unwrap().solver.clone();
    let flows_back = w.get::<CoupledGlottis>(e).unwrap().flow.len() as u64;
    assert!(back.step_count >= step, "brought back at step {} (read back {step})", back.step_count);
    assert_eq!(flows_back, back.step_count, "the glottis's samples up to the step brought back");
    for _ in step..back.step_count {
        direct.step().unwrap();
    }
    let d = direct.state().unwrap();
    let f_bits = |s: &phonation::coupling::CoupledSolver| s.fluid.f.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(d.step_count, back.step_count);
    assert!(f_bits(d) == f_bits(&back), "the air brought back differs from the GPU backend's at step {}", back.step_count);
    assert_eq!(pos(d), pos(&back), "the solid brought back differs from the GPU backend's");
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 20, single_steps: 0 });
    app.update();
    app.update();
    let now = app.world().get::<CoupledSimulation>(e).unwrap();
    assert_eq!(now.solver.step_count, back.step_count + 40, "stepped on the CPU from the step brought back");
    assert!(f_bits(&now.solver) != f_bits(&back));
    assert_eq!(app.world().get::<CoupledGlottis>(e).unwrap().flow.len() as u64, back.step_count + 40);
}

#[test]
fn plugin_steps_the_lattice_gas_exactly_like_the_direct_gas_and_honours_pause() {
    use phonation::lattice_gas::collision::CollisionTable;
    use phonation::plugin::{LatticeGasDiagnostics, LatticeGasSimulation};
    use phonation::scene::lattice_gas::LatticeGasScene;
    let sc = LatticeGasScene::parse(
        r#"
name = "plugin_box"
[lattice_gas]
cells = [8, 6, 4]
density = 0.2
interference = 0.3
diagonals = "all_perpendicular"
steps = 100
"#,
    )
    .unwrap();
    let mut app = app();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 5, single_steps: 0 });
    let e = app.world_mut().spawn(LatticeGasSimulation::from_scene(&sc)).id();
    for _ in 0..4 {
        app.update();
    }
    // paused: nothing moves; one single step then runs exactly one
    app.world_mut().resource_mut::<SimulationControl>().paused = true;
    app.update();
    assert_eq!(app.world().get::<LatticeGasDiagnostics>(e).unwrap().steps, 20);
    app.world_mut().resource_mut::<SimulationControl>().single_steps = 1;
    app.update();
    app.update();
    let table = CollisionTable::shared();
    let mut direct = sc.build();
    let start = direct.invariants();
    for _ in 0..21 {
        direct.advance(table);
    }
    let sim = app.world().get::<LatticeGasSimulation>(e).unwrap();
    assert_eq!(sim.gas.step, 21);
    assert_eq!(sim.gas.blocks, direct.blocks, "the plugin's gas differs from the direct one");
    let d = app.world().get::<LatticeGasDiagnostics>(e).unwrap();
    println!("lattice gas through the plugin: {d:?}");
    assert_eq!(d.steps, 21);
    assert_eq!(d.invariants, start, "a periodic box keeps its particles and momentum");
    assert!(d.invariants.particles > 0 && d.smallest_family_share > 0.8 && d.smallest_family_share <= 1.0);
}

/// The two-mass model in the schedule: its flow is bit for bit the direct model's, pause and
/// single steps are honoured, and the live voice measures read the f0 of a full run.
#[test]
fn plugin_steps_the_two_mass_model_and_measures_its_voice_live() {
    use phonation::plugin::{TwoMassSimulation, VoiceDiagnostics};
    use phonation::two_mass::{CM_H2O, TwoMass, TwoMassParams};
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, PhonationPlugin));
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 2000, single_steps: 0 });
    let sim = TwoMassSimulation::new(TwoMassParams::default(), 8.0 * CM_H2O);
    let dt = sim.dt;
    let e = app.world_mut().spawn(sim).id();
    for _ in 0..40 {
        app.update();
    }
    // paused: nothing moves; then one single step
    app.world_mut().resource_mut::<SimulationControl>().paused = true;
    app.update();
    assert_eq!(app.world().get::<TwoMassSimulation>(e).unwrap().model.steps, 80_000);
    app.world_mut().resource_mut::<SimulationControl>().single_steps = 1;
    app.update();
    app.update();
    let sim = app.world().get::<TwoMassSimulation>(e).unwrap();
    assert_eq!(sim.model.steps, 80_001);
    let mut direct = TwoMass::new(TwoMassParams::default(), 8.0 * CM_H2O);
    for _ in 0..80_001 {
        direct.step(dt);
    }
    assert_eq!(direct.state, sim.model.state, "the plugin's model is the direct model, bit for bit");
    let d = app.world().get::<VoiceDiagnostics>(e).unwrap();
    let m = d.measures.as_ref().expect("oscillating after 0.45 s");
    let full = phonation::run::two_mass::yardstick(8.0 * CM_H2O).unwrap();
    assert!(
        (m.f0_autocorrelation_hz / full.f0_autocorrelation_hz - 1.0).abs() < 0.005,
        "live f0 {} vs {}",
        m.f0_autocorrelation_hz,
        full.f0_autocorrelation_hz
    );
    assert!((m.peak_flow / full.peak_flow - 1.0).abs() < 0.01, "live peak {} vs {}", m.peak_flow, full.peak_flow);
}

/// The panel's state rebuilds the simulation when it changes, without a click: the lung
/// pressure reaches the inlet, a preset brings its own folds.
#[cfg(feature = "render")]
#[test]
fn the_panel_state_rebuilds_the_simulation_with_its_parameters() {
    use phonation::plugin::CoupledSimulation;
    use phonation::render::panel::{PanelState, PanelTarget, apply_panel, scene_of};
    use phonation::render::{DrawPlugin, DrawSystems};
    let mut app = app();
    app.add_plugins((DrawPlugin, phonation::plugin::PhonationDiagnosticsPlugin))
        .insert_resource(PanelState { preset: "glottis_2d_coarse".into(), ..default() })
        .add_systems(Update, apply_panel.in_set(DrawSystems::Panel));
    let e = app.world_mut().spawn(PanelTarget::default()).id();
    app.update();
    let inlet_rho = |app: &App| match app.world().get::<CoupledSimulation>(e).expect("built").solver.fluid.layout.boundaries.faces[2] {
        phonation::fluid::FaceCondition::PressureInlet { rho, .. } => rho,
        ref f => panic!("y_min is {f:?}"),
    };
    let rho_8000 = inlet_rho(&app);
    app.update();
    assert!(app.world().get::<CoupledSimulation>(e).unwrap().solver.step_count > 0, "it steps");
    assert!(app.world().get::<phonation::plugin::diagnostics::InitialMass>(e).is_some(), "measured");
    // halve the lung pressure through the state
    app.world_mut().resource_mut::<PanelState>().lung_pressure = Some(4000.0);
    app.update();
    let rho_4000 = inlet_rho(&app);
    let direct = scene_of(&PanelState { preset: "glottis_2d_coarse".into(), lung_pressure: Some(4000.0), ..default() }).unwrap().build().unwrap();
    assert_eq!(app.world().get::<CoupledSimulation>(e).unwrap().solver.step_count, 0, "rebuilt");
    // the old scene's figures go with it (the mass drift restarts from the new air)
    assert!(app.world().get::<phonation::plugin::diagnostics::InitialMass>(e).is_none());
    match direct.fluid.layout.boundaries.faces[2] {
        phonation::fluid::FaceCondition::PressureInlet { rho, .. } => assert_eq!(rho, rho_4000),
        ref f => panic!("{f:?}"),
    }
    // ρ_in − 1 ∝ the gauge pressure: half of it
    assert!(((rho_4000 - 1.0) / (rho_8000 - 1.0) - 0.5).abs() < 1e-9, "inlet ρ {rho_8000} → {rho_4000}");
    // the folds' moduli and a refused value
    app.world_mut().resource_mut::<PanelState>().fold_moduli = Some((2e5, 2e7));
    app.update();
    let young: Vec<f64> = app.world().get::<CoupledSimulation>(e).unwrap().solver.solid.materials.iter().map(|m| m.young[0]).collect();
    assert!(young.contains(&2e5) && young.contains(&2e7), "moduli {young:?}");
    app.world_mut().resource_mut::<PanelState>().fold_moduli = Some((-1.0, 2e7));
    app.update();
    let t = app.world().get::<PanelTarget>(e).unwrap();
    assert!(t.error.as_deref().is_some_and(|m| m.starts_with("fold_moduli")), "{:?}", t.error);
    // the resolution: twice the cells over the same domain, the particles' spacing halved
    // (four times as many particles in 2D, to within the folds' outline), the same lung pressure
    let coarse = app.world().get::<CoupledSimulation>(e).unwrap().solver.solid.particles.len();
    *app.world_mut().resource_mut::<PanelState>() = PanelState { preset: "glottis_2d_coarse".into(), resolution: Some(2.0), ..default() };
    app.update();
    assert!(app.world().get::<PanelTarget>(e).unwrap().error.is_none());
    let fine = &app.world().get::<CoupledSimulation>(e).unwrap().solver;
    let ratio = fine.solid.particles.len() as f64 / coarse as f64;
    println!(
        "resolution ×2: {:?} nodes, {} particles ({ratio:.3} × the preset's), Δx {} cm",
        fine.fluid.layout.grid.n,
        fine.solid.particles.len(),
        fine.units.dx
    );
    assert_eq!(fine.fluid.layout.grid.n, [124, 128, 1]);
    assert!((fine.units.dx - 1.5625 / 128.0).abs() < 1e-15, "Δx {}", fine.units.dx);
    assert!((ratio - 4.0).abs() < 0.2, "particles ×{ratio}");
    assert_eq!(inlet_rho(&app), rho_8000, "the same lung pressure");
    // a factor that does not give whole cells, and the lattice gas (lengths in lattice units)
    for (preset, r) in [("glottis_2d_coarse", 0.75), ("lattice_gas_wake", 2.0)] {
        let why = phonation::render::panel::build_preset(&PanelState { preset: preset.into(), resolution: Some(r), ..default() }).err().expect("refused");
        assert!(why.starts_with("resolution: "), "{why}");
    }
    // a preset
    *app.world_mut().resource_mut::<PanelState>() = PanelState { preset: "wall_flap".into(), ..default() };
    app.update();
    let flap = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("wall_flap").unwrap()).unwrap().build().unwrap();
    let sim = &app.world().get::<CoupledSimulation>(e).unwrap().solver;
    assert_eq!((sim.solid.particles.len(), sim.fluid.layout.grid.n), (flap.solid.particles.len(), flap.fluid.layout.grid.n));
    assert!(app.world().get::<PanelTarget>(e).unwrap().error.is_none());
    // a fluid preset: the coupled simulation and its figures go, the air of the scene comes
    *app.world_mut().resource_mut::<PanelState>() = PanelState { preset: "cylinder_wake".into(), ..default() };
    app.update();
    app.update();
    let wake = scene::load(scene::builtin("cylinder_wake").unwrap()).unwrap();
    assert!(app.world().get::<CoupledSimulation>(e).is_none() && app.world().get::<phonation::plugin::CoupledDiagnostics>(e).is_none());
    let air = app.world().get::<FluidSimulation>(e).expect("the cylinder wake is a fluid simulation");
    assert_eq!((air.solver.layout.grid.n, air.probes.len()), (wake.build_solver().layout.grid.n, wake.probes.len()));
    assert!(air.solver.step_count > 0, "it steps");
    // the folds' parameters do not apply to it: refused, naming the parameter, the air kept
    app.world_mut().resource_mut::<PanelState>().lung_pressure = Some(4000.0);
    app.update();
    let t = app.world().get::<PanelTarget>(e).unwrap();
    assert!(t.error.as_deref().is_some_and(|m| m.starts_with("lung_pressure: preset cylinder_wake has no folds")), "{:?}", t.error);
    assert!(app.world().get::<FluidSimulation>(e).is_some());
    // the lattice gas's wake
    *app.world_mut().resource_mut::<PanelState>() = PanelState { preset: "lattice_gas_wake".into(), ..default() };
    app.update();
    assert!(app.world().get::<FluidSimulation>(e).is_none() && app.world().get::<FluidDiagnostics>(e).is_none());
    let gas = app.world().get::<phonation::plugin::LatticeGasSimulation>(e).expect("the lattice-gas wake");
    assert_eq!((gas.gas.dims, gas.coarse_block, gas.probe.is_some()), ([192, 96, 4], 4, true));
    assert!(app.world().get::<PanelTarget>(e).unwrap().error.is_none());
}

/// The panel's plots record, frame by frame, the f0 the live voice measures read (two-mass
/// model), the transverse velocity at a fluid scene's first probe in cm/s and the lattice gas's
/// probe velocity — each point the value the simulation holds at that frame.
#[cfg(feature = "render")]
#[test]
fn the_panel_plots_record_f0_and_the_probe_velocities() {
    use phonation::plugin::{LatticeGasSimulation, PhonationSystems, TwoMassSimulation, VoiceDiagnostics};
    use phonation::render::plots::{F0, PROBE_UY_CM_S, PROBE_UY_LATTICE, PlotHistory, record_plots};
    use phonation::two_mass::{CM_H2O, TwoMassParams};
    let with_plots = |steps: u32| {
        let mut app = app();
        app.insert_resource(SimulationControl { paused: false, steps_per_frame: steps, single_steps: 0 })
            .add_systems(Update, record_plots.after(PhonationSystems::Diagnostics));
        app
    };
    // f0 of the two-mass model: one point per frame once the window holds periods
    let mut app = with_plots(2000);
    let e = app.world_mut().spawn(TwoMassSimulation::new(TwoMassParams::default(), 8.0 * CM_H2O)).id();
    let mut with_f0 = 0;
    for _ in 0..30 {
        app.update();
        with_f0 += app.world().get::<VoiceDiagnostics>(e).is_some_and(|v| v.measures.is_some()) as usize;
    }
    let v = app.world().get::<VoiceDiagnostics>(e).unwrap().clone();
    let f0 = app.world().get::<PlotHistory>(e).and_then(|h| h.get(F0)).expect("f0 recorded").clone();
    println!("f0 series: {} points, last {:?}", f0.points.len(), f0.points.back());
    assert!(with_f0 >= 10, "{with_f0} frames with an f0");
    assert_eq!(f0.points.len(), with_f0);
    assert_eq!(*f0.points.back().unwrap(), [v.time * 1e3, v.measures.unwrap().f0_autocorrelation_hz]);
    assert!(f0.points.iter().zip(f0.points.iter().skip(1)).all(|(a, b)| b[0] > a[0]), "time increases");
    // a paused frame adds nothing
    app.world_mut().resource_mut::<SimulationControl>().paused = true;
    app.update();
    assert_eq!(app.world().get::<PlotHistory>(e).unwrap().get(F0).unwrap().points.len(), with_f0);

    // the fluid scene's first probe, u_y in cm/s
    let sc = scene();
    let mut app = with_plots(3);
    let e = app.world_mut().spawn(FluidSimulation::from_scene(&sc)).id();
    for _ in 0..4 {
        app.update();
    }
    let sim = app.world().get::<FluidSimulation>(e).unwrap();
    let (u, node) = (sim.units.unwrap(), sim.probes[0].1);
    let expected = [u.time_to_physical(sim.solver.time) * 1e3, u.velocity_to_physical(sim.solver.macro_at(node).u[1])];
    let probe = app.world().get::<PlotHistory>(e).unwrap().get(PROBE_UY_CM_S).expect("probe recorded").clone();
    println!("probe series {:?}", probe.points);
    assert_eq!((probe.points.len(), *probe.points.back().unwrap()), (4, expected));
    assert!(expected[1] != 0.0);

    // the lattice gas's probe (ℓ/step)
    let gas = phonation::scene::lattice_gas::LatticeGasScene::parse(
        r#"
name = "plot_gas"
[lattice_gas]
cells = [16, 8, 2]
density = 0.2
steps = 100
[lattice_gas.inlet]
velocity = 0.2
[lattice_gas.output]
coarse_block = 2
every = 100
probe_every = 5
probe = [12.0, 8.0]
"#,
    )
    .unwrap();
    let mut app = with_plots(5);
    let e = app.world_mut().spawn(LatticeGasSimulation::from_scene(&gas)).id();
    for _ in 0..3 {
        app.update();
    }
    let sim = app.world().get::<LatticeGasSimulation>(e).unwrap();
    let direct = phonation::scene::lattice_gas::region_velocity(&sim.gas, [12.0, 8.0], 4.0);
    let probe = app.world().get::<PlotHistory>(e).unwrap().get(PROBE_UY_LATTICE).expect("probe recorded").clone();
    println!("lattice-gas probe series {:?}", probe.points);
    assert_eq!((probe.points.len(), *probe.points.back().unwrap()), (3, [15.0, direct[1]]));
}

/// The lattice gas's slice: its coarse-grained field averaged over Z in ℓ; the inflow's speed
/// upstream of the cylinder, no value in the cylinder's blocks, vorticity of opposite signs on
/// the two sides of the cylinder, and no pressure or temperature plane.
#[cfg(feature = "render")]
#[test]
fn the_lattice_gas_slice_shows_the_inflow_and_the_cylinder() {
    use phonation::lattice_gas::collision::CollisionTable;
    use phonation::plugin::LatticeGasSimulation;
    use phonation::render::slice::gas_plane;
    use phonation::scene::schema::Field;
    let sc = phonation::scene::lattice_gas::LatticeGasScene::parse(phonation::scene::builtin("lattice_gas_wake").unwrap()).unwrap();
    let mut sim = LatticeGasSimulation::from_scene(&sc);
    let table = CollisionTable::shared();
    for _ in 0..300 {
        sim.gas.advance(table);
    }
    let speed = gas_plane(&sim, Field::Speed).expect("speed");
    let (nx, ny) = (speed.slice.nx, speed.slice.ny);
    assert_eq!((nx, ny, speed.size, speed.unit), (48, 24, (384.0, 192.0), "ℓ/step"));
    // blocks are 8ℓ; the blocks without fluid lie inside the cylinder (centre (96, 96) ℓ, radius 12 ℓ)
    let at = |p: &phonation::render::slice::Plane, x: usize, y: usize| p.slice.values[x + nx * y];
    let upstream: Vec<f64> = (1..6).flat_map(|x| (2..22).map(move |y| (x, y))).filter_map(|(x, y)| at(&speed, x, y)).collect();
    let mean = upstream.iter().sum::<f64>() / upstream.len() as f64;
    println!("upstream speed {mean:.4} ℓ/step over {} blocks", upstream.len());
    // the gas starts at rest (block noise ≈ 0.01 ℓ/step) and the inlet's 0.2 ℓ/step has not
    // yet set the whole channel moving after 300 steps (one acoustic transit of the 384 ℓ box
    // takes 543): the inflow is well above the noise and not above the inlet's speed
    assert!(mean > 0.05 && mean < 0.21, "upstream speed {mean}");
    let solid: Vec<(usize, usize)> = (0..nx).flat_map(|x| (0..ny).map(move |y| (x, y))).filter(|&(x, y)| at(&speed, x, y).is_none()).collect();
    println!("blocks without fluid: {solid:?}");
    assert!(!solid.is_empty() && solid.iter().all(|&(x, y)| (x as f64 * 8.0 + 4.0 - 96.0).hypot(y as f64 * 8.0 + 4.0 - 96.0) < 12.0));
    let w = gas_plane(&sim, Field::Vorticity).expect("vorticity");
    let side = |y: std::ops::Range<usize>| {
        let v: Vec<f64> = (10..16).flat_map(|x| y.clone().map(move |y| (x, y))).filter_map(|(x, y)| at(&w, x, y)).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (above, below) = (side(13..16), side(8..11));
    println!("vorticity above {above:.2e}, below {below:.2e} 1/step");
    assert!(above < 0.0 && below > 0.0, "above {above}, below {below}");
    assert!(gas_plane(&sim, Field::Pressure).is_none() && gas_plane(&sim, Field::Temperature).is_none());
}

/// A headless app with the renderer (lavapipe in CI), no window, the drawing plugins without the
/// panel plus `extra`, a camera rendering the first simulation into a `w` × `h` image on a dark
/// background: the app, the image and the background as sRGB bytes.
#[cfg(feature = "render")]
fn headless_render_app<M>(extra: impl bevy::app::Plugins<M>, w: u32, h: u32) -> (App, Handle<Image>, [i32; 3]) {
    use bevy::app::PluginsState;
    use bevy::asset::RenderAssetUsages;
    use bevy::camera::RenderTarget;
    use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages};
    use bevy::window::{ExitCondition, WindowPlugin};
    use phonation::render::PhonationPlugins;
    use phonation::render::panel::PanelPlugin;
    use phonation::render::view::FrameSimulation;
    let mut app = App::new();
    app.add_plugins((
        headless_default_plugins(
            DefaultPlugins
                .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
                .set(bevy::render::RenderPlugin { synchronous_pipeline_compilation: true, ..default() })
                .disable::<bevy::log::LogPlugin>(),
        ),
        PhonationPlugins.build().disable::<PanelPlugin>(),
    ))
    .add_plugins(extra);
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    let mut target = Image::new_uninit(
        Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        TextureDimension::D2,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::RENDER_WORLD,
    );
    target.texture_descriptor.usage |= TextureUsages::RENDER_ATTACHMENT;
    let handle = app.world_mut().resource_mut::<Assets<Image>>().add(target);
    let background = Color::srgb(0.08, 0.08, 0.1);
    app.insert_resource(ClearColor(background));
    app.world_mut().spawn((Camera3d::default(), RenderTarget::from(handle.clone()), FrameSimulation));
    let bg = background.to_srgba();
    (app, handle, [bg.red, bg.green, bg.blue].map(|c| (c * 255.0).round() as i32))
}

/// A frame's pixels (RGBA8, sRGB) of the app's image `target`, after three more frames; also
/// saved as `name` (PNG) in the test's target directory.
#[cfg(feature = "render")]
fn capture(app: &mut App, target: &Handle<Image>, name: &str) -> Vec<u8> {
    use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
    use std::sync::{Arc, Mutex};
    for _ in 0..3 {
        app.update();
    }
    let got: Arc<Mutex<Option<Image>>> = Arc::default();
    let sink = got.clone();
    app.world_mut().spawn(Screenshot::image(target.clone())).observe(move |c: On<ScreenshotCaptured>| {
        *sink.lock().unwrap() = Some(c.image.clone());
    });
    for _ in 0..30 {
        app.update();
        if got.lock().unwrap().is_some() {
            break;
        }
    }
    let img = got.lock().unwrap().take().expect("a screenshot within 30 frames");
    img.clone().try_into_dynamic().expect("an RGBA image").to_rgb8().save(std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(name)).unwrap();
    img.data.expect("pixels")
}

/// A headless app with the renderer (lavapipe in CI) and no window draws the coarse glottis
/// into an image: the folds' mesh in the fold colour, the tracers, the slice; the PNGs are kept
/// in the test's target directory.
#[cfg(feature = "render")]
#[test]
fn the_glottis_renders_headless_with_folds_tracers_and_slice() {
    use phonation::plugin::CoupledSimulation;
    use phonation::render::DrawSettings;
    if !has_gpu() {
        return;
    }
    let (w, h) = (480u32, 320u32);
    let (mut app, handle, bg) = headless_render_app((), w, h);
    app.world_mut().spawn((DirectionalLight { illuminance: 8000.0, ..default() }, Transform::from_xyz(0.3, 0.5, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
    let sc = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("glottis_2d_coarse").unwrap()).unwrap();
    app.world_mut().spawn(CoupledSimulation { solver: sc.build().unwrap() });
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let capture = |app: &mut App, name: &str| capture(app, &handle, name);
    let share =
        |px: &[u8], f: &dyn Fn(i32, i32, i32) -> bool| px.chunks(4).filter(|p| f(p[0] as i32, p[1] as i32, p[2] as i32)).count() as f64 / (w * h) as f64;
    let not_background = |r: i32, g: i32, b: i32| (r - bg[0]).abs() + (g - bg[1]).abs() + (b - bg[2]).abs() > 40;
    // rose (the folds' colours lit): red well above green and blue
    let fold_colour = |r: i32, g: i32, b: i32| r > 80 && r - g > 50 && r - b > 30;
    // the folds alone
    *app.world_mut().resource_mut::<DrawSettings>() = DrawSettings { folds: true, tracers: false, slice: None, ..default() };
    let folds = capture(&mut app, "render_folds.png");
    let (fold_share, other) = (share(&folds, &fold_colour), share(&folds, &|r, g, b| not_background(r, g, b) && !fold_colour(r, g, b)));
    // the tracers alone, after a few frames of flow
    *app.world_mut().resource_mut::<DrawSettings>() = DrawSettings { folds: false, tracers: true, slice: None, ..default() };
    let tracers = capture(&mut app, "render_tracers.png");
    let tracer_share = share(&tracers, &not_background);
    // everything: the slice fills the domain
    *app.world_mut().resource_mut::<DrawSettings>() = DrawSettings::default();
    let all = capture(&mut app, "render_all.png");
    let all_share = share(&all, &not_background);
    eprintln!(
        "rendered {w}×{h}: folds {fold_share:.3} of the image (other {other:.4}), tracers {tracer_share:.4}, with the slice {all_share:.3}; PNGs in {}",
        out.display()
    );
    assert!(fold_share > 0.01 && other < 0.01, "folds {fold_share}, other {other}");
    assert!(tracer_share > 0.0005, "tracers {tracer_share}");
    assert!(all_share > 0.3, "slice {all_share}");
    // Two frames far apart differ where the folds move: 3000 steps (≈ 1 ms) between two
    // folds-only frames, in which the lung pressure pushes the folds apart by ≈ 0.012 cm
    // (`phonation run glottis_2d_coarse --steps 3000`: largest displacement 0.0124 cm), ≈ 2.5
    // pixels here; the pixels that change lie at the folds' edges (within two pixels of fold
    // colour in either frame: the edge moved, its antialiasing and shading with it) and nothing
    // else changes.
    *app.world_mut().resource_mut::<DrawSettings>() = DrawSettings { folds: true, tracers: false, slice: None, ..default() };
    let before = capture(&mut app, "render_folds_before.png");
    let step0 = app.world_mut().query::<&CoupledSimulation>().single(app.world()).unwrap().solver.step_count;
    app.world_mut().resource_mut::<SimulationControl>().steps_per_frame = 500;
    for _ in 0..6 {
        app.update();
    }
    app.world_mut().resource_mut::<SimulationControl>().steps_per_frame = 1;
    let after = capture(&mut app, "render_folds_after.png");
    let steps = app.world_mut().query::<&CoupledSimulation>().single(app.world()).unwrap().solver.step_count - step0;
    let px = |img: &[u8], k: usize| (img[4 * k] as i32, img[4 * k + 1] as i32, img[4 * k + 2] as i32);
    let is_fold = |img: &[u8], k: usize| {
        let (r, g, b) = px(img, k);
        fold_colour(r, g, b)
    };
    // within two pixels of the folds in either frame (their antialiased, shaded edges)
    let (wi, hi) = (w as i64, h as i64);
    let near_folds = |k: usize| {
        let (x, y) = ((k as i64) % wi, (k as i64) / wi);
        (-2..=2).any(|dy| {
            (-2..=2).any(|dx| {
                let (u, v) = (x + dx, y + dy);
                u >= 0 && v >= 0 && u < wi && v < hi && (is_fold(&before, (v * wi + u) as usize) || is_fold(&after, (v * wi + u) as usize))
            })
        })
    };
    let (mut at_folds, mut elsewhere) = (0usize, 0usize);
    for k in 0..(w * h) as usize {
        let (a, b) = (px(&before, k), px(&after, k));
        let changed = is_fold(&before, k) != is_fold(&after, k) || (a.0 - b.0).abs() + (a.1 - b.1).abs() + (a.2 - b.2).abs() > 40;
        if changed {
            if near_folds(k) { at_folds += 1 } else { elsewhere += 1 }
        }
    }
    let (moved, still) = (at_folds as f64 / (w * h) as f64, elsewhere as f64 / (w * h) as f64);
    eprintln!("after {steps} more steps: {moved:.4} of the image changed at the folds' edges, {still:.5} elsewhere");
    assert!(steps >= 3000 && moved > 1e-3 && still < 1e-4, "changed at the folds {moved}, elsewhere {still}");
}

/// The folds' surface made on the GPU in the render world (level set and marching cubes on the
/// device, drawn from the kernels' buffers) draws the folds the CPU mesh draws: the same
/// triangles (the count read back against the CPU twin's), the same pixels of fold colour
/// (the two are lit differently — Bevy's PBR material for the CPU mesh, a two-sided Lambert
/// term for the GPU's — so the comparison is of the fold-coloured masks, whose edges may differ
/// by antialiasing: a pixel-wide band); one drawing at a time; a surface that outgrows its
/// buffers is made again with more room.
#[cfg(feature = "render")]
#[test]
fn the_fold_mesh_made_on_the_gpu_draws_the_cpu_meshs_folds() {
    use phonation::plugin::CoupledSimulation;
    use phonation::render::DrawSettings;
    use phonation::render::fold_mesh::FoldMeshOf;
    use phonation::render::gpu_fold_mesh::{GpuFoldMesh, GpuFoldMeshOf};
    use std::sync::Arc;
    if !has_gpu() {
        return;
    }
    let (w, h) = (480u32, 320u32);
    let (mut app, handle, _) = headless_render_app((), w, h);
    app.insert_resource(SimulationControl { paused: true, steps_per_frame: 1, single_steps: 0 });
    app.world_mut().spawn((DirectionalLight { illuminance: 8000.0, ..default() }, Transform::from_xyz(0.3, 0.5, 1.0).looking_at(Vec3::ZERO, Vec3::Y)));
    let sc = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("glottis_2d_coarse").unwrap()).unwrap();
    let solver = sc.build().unwrap();
    let cpu_triangles = phonation::run::surface::coupled_surface(&solver).triangles.len() as u32;
    let e = app.world_mut().spawn(CoupledSimulation { solver }).id();
    let fold_colour = |p: &[u8]| {
        let (r, g, b) = (p[0] as i32, p[1] as i32, p[2] as i32);
        r > 80 && r - g > 50 && r - b > 30
    };
    let count = |app: &mut App| {
        let cpu = app.world_mut().query::<&FoldMeshOf>().iter(app.world()).count();
        let gpu = app.world_mut().query::<&GpuFoldMeshOf>().iter(app.world()).count();
        (cpu, gpu)
    };
    let settings = |gpu: bool| DrawSettings { folds: true, folds_on_gpu: gpu, tracers: false, slice: None, ..default() };
    *app.world_mut().resource_mut::<DrawSettings>() = settings(false);
    let cpu = capture(&mut app, &handle, "folds_cpu.png");
    assert_eq!(count(&mut app), (1, 0), "the CPU mesh alone");
    let cpu_mesh = app.world().get::<phonation::render::fold_mesh::FoldMesh>(e).expect("the CPU mesh");
    assert_eq!(
        phonation::render::panel::fold_surface_line(Some(cpu_mesh), None).unwrap(),
        format!("folds: {cpu_triangles} triangles, made on the CPU"),
        "the panel's line"
    );
    *app.world_mut().resource_mut::<DrawSettings>() = settings(true);
    let gpu = capture(&mut app, &handle, "folds_gpu.png");
    assert_eq!(count(&mut app), (0, 1), "the GPU surface alone");
    let fm = app.world().get::<GpuFoldMesh>(e).expect("a GPU surface").clone();
    let (a, b): (Vec<bool>, Vec<bool>) = (cpu.chunks(4).map(fold_colour).collect(), gpu.chunks(4).map(fold_colour).collect());
    let both = a.iter().zip(&b).filter(|(x, y)| **x && **y).count();
    let either = a.iter().zip(&b).filter(|(x, y)| **x || **y).count();
    let iou = both as f64 / either.max(1) as f64;
    eprintln!(
        "GPU surface: {:?} triangles read back (CPU twin {cpu_triangles}, room {}); fold pixels CPU {} / GPU {}, overlap {iou:.4}",
        fm.triangles,
        fm.capacity,
        a.iter().filter(|x| **x).count(),
        b.iter().filter(|x| **x).count()
    );
    // the same triangles: a node's L within f32 rounding (1e-5 measured) of 0 could change a
    // cell's case; none does on the glottis (tests/gpu/), so the counts agree to 1 %
    let t = fm.triangles.expect("the count read back");
    assert_eq!(
        phonation::render::panel::fold_surface_line(None, Some(&fm)).unwrap(),
        format!("folds: {t} triangles, made on the GPU (room for {})", fm.capacity),
        "the panel's line"
    );
    assert!((t as f64 / cpu_triangles as f64 - 1.0).abs() < 0.01, "GPU {t}, CPU {cpu_triangles}");
    assert!(either as f64 > 0.01 * (w * h) as f64, "folds drawn: {either} pixels");
    assert!(iou > 0.95, "fold pixels overlap {iou}");
    // a surface that outgrows its buffers (here: room for 100 triangles) is counted, not
    // overrun, and made again with room for twice its triangles
    {
        let mut fm = app.world_mut().get_mut::<GpuFoldMesh>(e).unwrap();
        fm.capacity = 100;
        fm.source = Arc::new((*fm.source).clone());
    }
    for _ in 0..12 {
        app.update();
    }
    let fm = app.world().get::<GpuFoldMesh>(e).expect("made again").clone();
    eprintln!("after outgrowing room for 100: room {}, {:?} triangles", fm.capacity, fm.triangles);
    assert!(fm.capacity >= 2 * cpu_triangles && fm.triangles == Some(t), "room {}, triangles {:?}", fm.capacity, fm.triangles);
    assert_eq!(count(&mut app), (0, 1));
    // the same folds drawn (the triangles' order in the buffers is the atomics', so a pixel
    // where two triangles meet may go either way)
    let again: Vec<bool> = capture(&mut app, &handle, "folds_gpu_again.png").chunks(4).map(fold_colour).collect();
    let same = again.iter().zip(&b).filter(|(x, y)| x == y).count();
    assert!(same as f64 > 0.999 * (w * h) as f64, "{} pixels differ", (w * h) as usize - same);
}

/// A GPU-stepped fluid's tracers stay on the device: advected in the render world after the
/// frame's steps and drawn from the device's buffer by the line material. The tracers move with
/// the channel's inflow (their mean x grows), stay in the lattice, and show in the rendered
/// image; with the tracers switched off the image is the background; its slice is made on the
/// device too. The PNGs are kept in the test's target directory.
#[cfg(feature = "render")]
#[test]
fn gpu_tracers_are_advected_and_drawn_on_the_device() {
    use bevy::render::renderer::{RenderDevice, RenderQueue};
    use phonation::plugin::{GpuStepping, PhonationGpuPlugin};
    use phonation::render::DrawSettings;
    use phonation::render::gpu_tracers::GpuTracerHandle;
    if !has_gpu() {
        return;
    }
    let (w, h) = (480u32, 240u32);
    let (mut app, handle, bg) = headless_render_app(PhonationGpuPlugin, w, h);
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 8, single_steps: 0 });
    *app.world_mut().resource_mut::<DrawSettings>() = DrawSettings { folds: false, tracers: true, slice: None, tracer_count: 3000, ..default() };
    let sc = scene();
    let e = app.world_mut().spawn((FluidSimulation::from_scene(&sc), GpuStepping)).id();
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let capture = |app: &mut App, name: &str| capture(app, &handle, name);
    let tracer_positions = |app: &App| {
        let t = app.world().get::<GpuTracerHandle>(e).expect("GPU tracers").tracers.clone();
        let (device, queue) = (app.world().resource::<RenderDevice>().wgpu_device().clone(), app.world().resource::<RenderQueue>().0.clone());
        let q: &wgpu::Queue = &queue;
        t.lock().unwrap().download_on(&device, q).0
    };
    app.update();
    app.update();
    let start = tracer_positions(&app);
    let drawn = capture(&mut app, "gpu_tracers.png");
    for _ in 0..20 {
        app.update();
    }
    let later = tracer_positions(&app);
    let share = |px: &[u8]| {
        px.chunks(4).filter(|p| (p[0] as i32 - bg[0]).abs() + (p[1] as i32 - bg[1]).abs() + (p[2] as i32 - bg[2]).abs() > 40).count() as f64 / (w * h) as f64
    };
    *app.world_mut().resource_mut::<DrawSettings>() = DrawSettings { folds: false, tracers: false, slice: None, tracer_count: 3000, ..default() };
    let hidden = capture(&mut app, "gpu_tracers_hidden.png");
    let n = sim_nodes(&app, e);
    let mean_x = |p: &[glam::DVec3]| p.iter().map(|v| v.x).sum::<f64>() / p.len() as f64;
    let inside = later.iter().all(|p| p.x >= -0.5 && p.y >= -0.5 && p.x <= n[0] as f64 - 0.5 && p.y <= n[1] as f64 - 0.5);
    eprintln!(
        "GPU tracers: {} of them, mean x {:.3} → {:.3} cells over 20 frames of 8 steps; drawn {:.4} of the image, hidden {:.4}; PNGs in {}",
        later.len(),
        mean_x(&start),
        mean_x(&later),
        share(&drawn),
        share(&hidden),
        out.display()
    );
    assert_eq!(later.len(), 3000);
    assert!(inside, "every tracer inside the lattice");
    assert!(mean_x(&later) > mean_x(&start) + 0.05, "the tracers move with the inflow");
    assert!(share(&drawn) > 0.03 && share(&hidden) < 1e-4, "drawn {}, hidden {}", share(&drawn), share(&hidden));
    // the CPU mirror was not stepped, and no CPU tracers were made for it
    assert_eq!(app.world().get::<FluidSimulation>(e).unwrap().solver.step_count, 0);
    assert!(app.world().get::<phonation::render::tracers::FlowTracers>(e).is_none());
    // the slice is made on the device (render::gpu_slice; its kernels' parity with the CPU slice
    // is tests/gpu/drawing.rs `the_slice_on_the_gpu_matches_its_cpu_twin`), not from the CPU mirror:
    // the speed in the channel fills the lattice's rectangle with more than a few colours, and
    // its range comes back for the legend
    use phonation::render::gpu_slice::GpuSliceOf;
    use phonation::render::slice::{SliceOf, SliceView};
    app.world_mut().resource_mut::<DrawSettings>().slice = Some(phonation::scene::schema::Field::Speed);
    let sliced = capture(&mut app, "gpu_slice.png");
    let view = app.world().get::<SliceView>(e).expect("a slice view").clone();
    let quads =
        |app: &mut App| (app.world_mut().query::<&SliceOf>().iter(app.world()).count(), app.world_mut().query::<&GpuSliceOf>().iter(app.world()).count());
    let colours: std::collections::HashSet<[u8; 3]> = sliced.chunks(4).map(|p| [p[0], p[1], p[2]]).collect();
    eprintln!("GPU slice: speed {:.4e} … {:.4e} {}, {:.3} of the image, {} colours", view.range.0, view.range.1, view.unit, share(&sliced), colours.len());
    assert_eq!(quads(&mut app), (0, 1), "the GPU slice's quad, no CPU slice");
    assert!(view.range.0 >= 0.0 && view.range.1 > view.range.0 && view.range.1.is_finite(), "range {:?}", view.range);
    // the lattice's rectangle is 0.28 of this image (the framing leaves the left part to the
    // panel): the slice fills it
    assert!(share(&sliced) > 0.25 && colours.len() > 20, "slice drawn over {} of the image, {} colours", share(&sliced), colours.len());
    // the lines and the slice go with their simulation
    let lines = |app: &mut App| app.world_mut().query::<&phonation::render::gpu_tracers::GpuTracersOf>().iter(app.world()).count();
    assert_eq!(lines(&mut app), 1);
    // taken off the device (GpuStepping removed): the CPU steps the air brought back, its own
    // tracers and slice take over from the device's
    app.world_mut().resource_mut::<DrawSettings>().tracers = true;
    app.world_mut().entity_mut(e).remove::<GpuStepping>();
    for _ in 0..4 {
        app.update();
    }
    let steps = app.world().get::<FluidSimulation>(e).unwrap().solver.step_count;
    let cpu_tracers = app.world().get::<phonation::render::tracers::FlowTracers>(e).map_or(0, |t| t.tracers.positions.len());
    eprintln!("taken off the device: step {steps} on the CPU, {cpu_tracers} CPU tracers");
    assert!(steps > 0 && app.world().get::<phonation::plugin::GpuFluidHandle>(e).is_none(), "stepped on the CPU (step {steps})");
    assert!(app.world().get::<GpuTracerHandle>(e).is_none() && lines(&mut app) == 0 && cpu_tracers > 0, "the CPU's tracers instead of the device's");
    assert_eq!(quads(&mut app), (1, 0), "the CPU's slice instead of the device's");
    app.world_mut().despawn(e);
    app.update();
    app.update();
    assert_eq!(lines(&mut app), 0);
    assert_eq!(quads(&mut app), (0, 0));
}

/// The panel's "stepped on the GPU" for a fluid preset: the preset's air goes to the render
/// device (its probes come back, its CPU mirror stays at step 0, its slice is made on the
/// device); for a coupled preset its air and folds (the glottis's flow of every step and its
/// slice come back); a lattice-gas preset with it is refused naming the setting and the old
/// simulation stays; ticking it off rebuilds the preset on the CPU on a new entity (the
/// device's handles and readbacks go with the old one).
#[cfg(feature = "render")]
#[test]
fn the_panel_steps_a_fluid_or_coupled_preset_on_the_gpu() {
    use phonation::plugin::{CoupledGlottis, CoupledSimulation, GpuCoupledHandle, GpuCoupledReadback, GpuFluidHandle, GpuProbes, PhonationGpuPlugin};
    use phonation::render::DrawSystems;
    use phonation::render::panel::{PanelState, PanelTarget, apply_panel};
    use phonation::render::slice::SliceView;
    if !has_gpu() {
        return;
    }
    let (mut app, _, _) = headless_render_app(PhonationGpuPlugin, 320, 240);
    app.add_systems(Update, apply_panel.in_set(DrawSystems::Panel));
    app.insert_resource(PanelState { preset: "cylinder_wake".into(), air_on_gpu: true, ..default() });
    app.world_mut().spawn(PanelTarget::default());
    let target = |app: &mut App| app.world_mut().query_filtered::<Entity, With<PanelTarget>>().single(app.world()).unwrap();
    for _ in 0..12 {
        app.update();
    }
    let e = target(&mut app);
    let probes = app.world().get::<GpuProbes>(e).expect("probes read back from the device").clone();
    let mirror_steps = app.world().get::<FluidSimulation>(e).unwrap().solver.step_count;
    let sliced = app.world().get::<SliceView>(e).is_some_and(|v| v.range.1 > v.range.0);
    eprintln!("air on the GPU: step {} read back ({} readbacks), CPU mirror at step {mirror_steps}, slice read back: {sliced}", probes.step, probes.readbacks);
    assert!(app.world().get::<GpuFluidHandle>(e).is_some(), "stepped on the render device");
    assert!(probes.readbacks > 0 && probes.step > 0 && mirror_steps == 0, "probes {probes:?}, mirror {mirror_steps}");
    assert!(sliced, "the slice made on the device, its range read back");
    // a coupled preset: its air and folds stepped on the device (a new entity), the glottis read
    // back every step, its slice made on the device
    app.insert_resource(PanelState { preset: "glottis_2d_coarse".into(), air_on_gpu: true, ..default() });
    for _ in 0..12 {
        app.update();
    }
    let g = target(&mut app);
    let readback = app.world().get::<GpuCoupledReadback>(g).cloned().unwrap_or_default();
    let flows = app.world().get::<CoupledGlottis>(g).map_or(0, |c| c.flow.len());
    let sim_steps = app.world().get::<CoupledSimulation>(g).unwrap().solver.step_count;
    let sliced = app.world().get::<SliceView>(g).is_some_and(|v| v.range.1 > v.range.0);
    eprintln!("coupled on the GPU: step {} read back ({} readbacks), {flows} flow samples, slice read back: {sliced}", readback.step, readback.readbacks);
    assert!(g != e && app.world().get_entity(e).is_err(), "rebuilt on a new entity");
    assert!(app.world().get::<GpuCoupledHandle>(g).is_some(), "stepped on the render device");
    assert!(readback.readbacks > 0 && readback.step > 0 && sim_steps == readback.step && flows as u64 == readback.step, "{readback:?}, {flows} flows");
    assert!(sliced, "the coupled air's slice made on the device, its range read back");
    // ticked off alone: the same simulation comes back to the CPU with its state and steps on
    // there; ticked on again, it goes back to the device from where the CPU left it
    app.insert_resource(PanelState { preset: "glottis_2d_coarse".into(), air_on_gpu: false, ..default() });
    for _ in 0..3 {
        app.update();
    }
    let on_cpu = app.world().get::<CoupledSimulation>(g).unwrap().solver.step_count;
    let flows = app.world().get::<CoupledGlottis>(g).map_or(0, |c| c.flow.len()) as u64;
    eprintln!("ticked off: step {on_cpu} on the CPU (the device's last readback: step {}), {flows} flow samples", readback.step);
    assert_eq!(target(&mut app), g, "the same entity");
    assert!(app.world().get::<GpuCoupledHandle>(g).is_none(), "no longer on the device");
    assert!(on_cpu > readback.step && flows == on_cpu, "stepped on from the device's state: step {on_cpu}, {flows} flows");
    app.insert_resource(PanelState { preset: "glottis_2d_coarse".into(), air_on_gpu: true, ..default() });
    for _ in 0..4 {
        app.update();
    }
    let again = app.world().get::<GpuCoupledReadback>(g).cloned().unwrap_or_default();
    assert_eq!(target(&mut app), g, "the same entity");
    assert!(app.world().get::<GpuCoupledHandle>(g).is_some() && again.step > on_cpu, "back on the device from step {on_cpu}: {again:?}");
    // a lattice-gas preset cannot: refused, the coupled one stays
    app.insert_resource(PanelState { preset: "lattice_gas_wake".into(), air_on_gpu: true, ..default() });
    app.update();
    let why = app.world().get::<PanelTarget>(g).unwrap().error.clone().unwrap_or_default();
    assert!(why.starts_with("air_on_gpu:") && why.contains("lattice_gas_wake"), "{why}");
    assert!(app.world().get::<GpuCoupledHandle>(g).is_some());
    // off again: the preset on the CPU, on a new entity
    app.insert_resource(PanelState { preset: "cylinder_wake".into(), ..default() });
    for _ in 0..4 {
        app.update();
    }
    let cpu = target(&mut app);
    assert!(cpu != g && app.world().get_entity(g).is_err(), "rebuilt on a new entity");
    assert!(app.world().get::<GpuFluidHandle>(cpu).is_none());
    assert!(app.world().get::<FluidSimulation>(cpu).unwrap().solver.step_count > 0, "stepped on the CPU");
}

fn sim_nodes(app: &App, e: Entity) -> [usize; 3] {
    app.world().get::<FluidSimulation>(e).unwrap().solver.layout.grid.n
}

/// The diagnostics plugin puts the simulations' figures in Bevy's store: particles and node
/// updates counted from the entities, the Mach number and mass drift of the air.
#[test]
fn the_diagnostics_store_carries_the_simulation_figures() {
    use bevy::diagnostic::DiagnosticsStore;
    use phonation::plugin::diagnostics::{MASS_DRIFT, MAX_MACH, NODE_UPDATES_PER_SECOND, PARTICLES, STEPS_PER_SECOND};
    use phonation::plugin::{CoupledSimulation, PhonationDiagnosticsPlugin};
    let mut app = app();
    app.add_plugins(PhonationDiagnosticsPlugin).insert_resource(SimulationControl { paused: false, steps_per_frame: 2, single_steps: 0 });
    let sc = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("glottis_2d_coarse").unwrap()).unwrap();
    let solver = sc.build().unwrap();
    let (particles, nodes) = (solver.solid.particles.len(), solver.fluid.layout.grid.interior_len());
    let e = app.world_mut().spawn(CoupledSimulation { solver }).id();
    for _ in 0..4 {
        app.update();
    }
    let store = app.world().resource::<DiagnosticsStore>();
    let value = |p: &bevy::diagnostic::DiagnosticPath| store.get(p).and_then(|d| d.value()).unwrap_or_else(|| panic!("{p:?} measured"));
    assert_eq!(value(&PARTICLES), particles as f64);
    let (steps_s, nodes_s) = (value(&STEPS_PER_SECOND), value(&NODE_UPDATES_PER_SECOND));
    assert!(steps_s > 0.0 && ((nodes_s / steps_s) / nodes as f64 - 1.0).abs() < 1e-12, "{steps_s} steps/s, {nodes_s} nodes/s");
    let sim = &app.world().get::<CoupledSimulation>(e).unwrap().solver;
    assert_eq!(value(&MAX_MACH), sim.fluid.max_mach());
    let drift = value(&MASS_DRIFT);
    assert!(drift != 0.0 && drift.abs() < 0.05, "mass drift {drift}");
}

/// The simulation plugins, the diagnostics, the drawing's order and the panel's rebuild have no
/// ambiguous system order in `Update` (Bevy's ambiguity detection set to error): two runs of
/// the same app step their systems in the same order.
#[cfg(feature = "render")]
#[test]
fn the_plugin_group_has_no_ambiguous_system_order() {
    use bevy::ecs::schedule::{LogLevel, ScheduleBuildSettings};
    use phonation::plugin::PhonationDiagnosticsPlugin;
    use phonation::render::panel::{PanelState, PanelTarget, apply_panel};
    use phonation::render::{DrawPlugin, DrawSystems};
    let mut app = app();
    // with the GPU stepping's systems too (they run in the main world whether or not a render
    // device is there)
    app.add_plugins((PhonationDiagnosticsPlugin, DrawPlugin, phonation::plugin::PhonationGpuPlugin))
        .insert_resource(PanelState { preset: "glottis_2d_coarse".into(), ..default() })
        .add_systems(Update, apply_panel.in_set(DrawSystems::Panel))
        .edit_schedule(Update, |s| {
            s.set_build_settings(ScheduleBuildSettings { ambiguity_detection: LogLevel::Error, ..default() });
        });
    app.world_mut().spawn(PanelTarget::default());
    app.world_mut().spawn(FluidSimulation::from_scene(&scene()));
    // building the schedule fails (panics) on an ambiguity
    app.update();
    app.update();
    // and the check can fail: two unordered systems that write the same resource
    let mut bad = App::new();
    bad.add_plugins(MinimalPlugins)
        .init_resource::<SimulationControl>()
        .add_systems(Update, (|mut c: ResMut<SimulationControl>| c.single_steps += 1, |mut c: ResMut<SimulationControl>| c.paused = true))
        .edit_schedule(Update, |s| {
            s.set_build_settings(ScheduleBuildSettings { ambiguity_detection: LogLevel::Error, ..default() });
        });
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| bad.update()));
    assert!(r.is_err(), "an ambiguity must be reported");
}
