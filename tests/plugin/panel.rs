//! The egui panel: rebuilding a simulation with its parameters, its live plots, and presets
//! stepped on the GPU.

use crate::support::*;

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
