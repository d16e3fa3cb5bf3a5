//! Simulations stepped on the GPU in Bevy's render world against the GPU backend or the CPU:
//! the fluid, the solid and the coupled glottis.

use crate::support::*;

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

/// Method 2's level-set questions in the render world go where the entity asks: on Bevy's render
/// device when it has f64 in shaders (Bevy opens it with the adapter's features; lavapipe has
/// them), on the host with [`GpuLevelSets`]`(LevelSets::Host)` — each readback naming where —,
/// and the two entities, stepped alike, come back with the same air and particles bit for bit
/// (the questions' answers agree to ~1e-15 cells and reach f32 kernels: `run --level-sets`).
#[test]
fn the_render_worlds_level_set_questions_go_where_the_entity_asks() {
    use bevy::render::renderer::RenderDevice;
    use phonation::plugin::{CoupledSimulation, CoupledStatus, GpuCoupledReadback, GpuLevelSets, GpuStepping};
    use phonation::run::LevelSets;
    use phonation::scene::coupled::CoupledScene;
    let Some(mut app) = render_world_app() else { return };
    let sc = CoupledScene::parse(scene::builtin("fsi_cylinder_conserving").unwrap()).unwrap();
    app.insert_resource(SimulationControl { paused: false, steps_per_frame: 5, single_steps: 0 });
    let on_device = app.world_mut().spawn((CoupledSimulation { solver: sc.build().unwrap() }, GpuStepping)).id();
    let on_host = app.world_mut().spawn((CoupledSimulation { solver: sc.build().unwrap() }, GpuStepping, GpuLevelSets(LevelSets::Host))).id();
    let step = |app: &App, e| app.world().get::<GpuCoupledReadback>(e).map_or(0, |r| r.step);
    for _ in 0..100 {
        app.update();
        if step(&app, on_device) >= 20 && step(&app, on_host) >= 20 {
            break;
        }
    }
    let w = app.world();
    assert!(step(&app, on_device) >= 20 && step(&app, on_host) >= 20, "both stepped 20 steps within 100 frames");
    assert_eq!((w.get::<CoupledStatus>(on_device), w.get::<CoupledStatus>(on_host)), (None, None), "both still running");
    let f64_shaders = w.resource::<RenderDevice>().features().contains(bevy::render::settings::WgpuFeatures::SHADER_F64);
    let backend = |e| w.get::<GpuCoupledReadback>(e).unwrap().backend.clone();
    eprintln!("{}\n{}", backend(on_device), backend(on_host));
    let device_side =
        if f64_shaders { "; level-set questions on the device (f64)" } else { "; level-set questions on the host (the device has no f64 in shaders)" };
    assert!(backend(on_device).ends_with(device_side), "{}", backend(on_device));
    assert!(backend(on_host).ends_with("; level-set questions on the host (as asked)"), "{}", backend(on_host));
    assert!(std::env::var("CI").is_err() || f64_shaders, "lavapipe's f64 reaches Bevy's render device in CI");

    // taken off the device (paused): both come back at the same step with the same state
    app.insert_resource(SimulationControl { paused: true, steps_per_frame: 5, single_steps: 0 });
    app.world_mut().entity_mut(on_device).remove::<GpuStepping>();
    app.world_mut().entity_mut(on_host).remove::<GpuStepping>();
    app.update();
    let w = app.world();
    let (a, b) = (&w.get::<CoupledSimulation>(on_device).unwrap().solver, &w.get::<CoupledSimulation>(on_host).unwrap().solver);
    assert!(a.step_count >= 20 && a.step_count == b.step_count, "steps {} and {}", a.step_count, b.step_count);
    let f_bits = |s: &phonation::coupling::CoupledSolver| s.fluid.f.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let pos = |s: &phonation::coupling::CoupledSolver| s.solid.particles.position.iter().flat_map(|p| p.to_array()).map(f64::to_bits).collect::<Vec<_>>();
    assert!(f_bits(a) == f_bits(b), "the air differs between the level sets on the device and on the host");
    assert_eq!(pos(a), pos(b), "the particles differ between the level sets on the device and on the host");
    assert!(a.solid.particles.position.iter().zip(&a.solid.particles.reference).any(|(x, r)| *x != *r), "the cylinder moved");
}
