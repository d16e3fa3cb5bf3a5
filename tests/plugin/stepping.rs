//! Stepping through the plugin is stepping the solver: the fluid, the solid, the coupled solver
//! (through pause and single steps), the lattice gas and the two-mass model give exactly the
//! direct solver's state; instability, the glottis's samples, the diagnostics store and the
//! schedule's order.

use crate::support::*;

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
