//! The FDLB fluid on the GPU against its CPU twin: every kernel of the stage list, whole
//! steps, the walls' face fluxes, thin walls, the boundary fill, the gather/scatter of nodes,
//! the totals and the side ghosts' room.

use crate::support::*;

#[test]
fn every_kernel_matches_its_cpu_twin() {
    let Some(ctx) = context() else { return };
    for (dim3, gas) in [(false, GasModel::Monatomic), (false, GasModel::Diatomic), (true, GasModel::Monatomic), (true, GasModel::Diatomic)] {
        let mut cpu = scene(dim3, gas);
        // Warm up on the CPU so that non-equilibrium parts are present, then copy to the GPU.
        cpu.run(3).unwrap();
        let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
        let boundary = [NodeKind::Ghost, NodeKind::FaceHalo, NodeKind::Periodic];
        for stage in &FDLB_STEP {
            cpu.run_stage(stage).unwrap();
            gpu.run_stage(stage);
            let (f1, f2, h, mac) = cpu.stage_arrays();
            let label = format!("{} {gas:?} {}", if dim3 { "3D" } else { "2D" }, stage.name);
            let (out, out_gpu) = match stage.rk {
                phonation::stages::RkStage::First => (f1, gpu.download(GpuArray::FirstStage)),
                phonation::stages::RkStage::Second => (f2, gpu.download(GpuArray::SecondStage)),
            };
            match stage.kind {
                phonation::stages::StageKind::MomentsCollide => {
                    let d_out = compare_nodes(&out_gpu, &cpu, out, cpu.pop, &[NodeKind::Fluid]);
                    let d_h = compare_nodes(&gpu.download(GpuArray::Advected), &cpu, h, cpu.pop, &[NodeKind::Fluid]);
                    let d_mac = compare_nodes(&gpu.download(GpuArray::Macro), &cpu, mac, cpu.macro_layout, &[NodeKind::Fluid]);
                    eprintln!("{label}: out {d_out:e} h {d_h:e} mac {d_mac:e}");
                    assert!(d_out < KERNEL_TOL && d_h < KERNEL_TOL && d_mac < KERNEL_TOL, "{label}: out {d_out:e} h {d_h:e} mac {d_mac:e}");
                }
                phonation::stages::StageKind::Boundaries => {
                    let d_h = compare_nodes(&gpu.download(GpuArray::Advected), &cpu, h, cpu.pop, &boundary);
                    let d_mac = compare_nodes(&gpu.download(GpuArray::Macro), &cpu, mac, cpu.macro_layout, &boundary);
                    eprintln!("{label}: ghost/halo h {d_h:e} mac {d_mac:e}");
                    assert!(d_h < KERNEL_TOL && d_mac < KERNEL_TOL, "{label}: ghost/halo h {d_h:e} mac {d_mac:e}");
                }
                phonation::stages::StageKind::Advect => {
                    let d_out = compare_nodes(&out_gpu, &cpu, out, cpu.pop, &[NodeKind::Fluid]);
                    eprintln!("{label}: {d_out:e}");
                    assert!(d_out < KERNEL_TOL, "{label}: {d_out:e}");
                }
            }
        }
        gpu.finish_step();
        assert!(gpu.instability() == Ok(None));
    }
}

#[test]
fn whole_steps_match_the_cpu_backend() {
    let Some(ctx) = context() else { return };
    for dim3 in [false, true] {
        let mut cpu = scene(dim3, GasModel::Diatomic);
        let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
        let steps = 200;
        cpu.run(steps).unwrap();
        gpu.run(steps);
        let d = gpu.max_relative_difference(&cpu);
        eprintln!("{} whole-step parity after {steps} steps: {d:e}", if dim3 { "3D" } else { "2D" });
        // f32 round-off accumulates over 200 steps of a dissipative scheme: 1e-4 of each
        // population's scale bounds it (measured 4e-5 to 6e-5 on lavapipe).
        assert!(d < 1e-4, "{}: {d:e}", if dim3 { "3D" } else { "2D" });
        assert!(gpu.instability() == Ok(None));
        assert_eq!(gpu.step_count, steps);
    }
}

/// Method 2's record of what the walls take out of the air (`face_fluxes`, the GPU twin of
/// `coupling::momentum_exchange::step_with_exchange`): on the 2D channel and the 3D box (walls,
/// inlet, outlet and an obstacle: ghost and face-halo walls, one-sided stencils at the corners),
/// step by step for 30 steps, every wall node's momentum and mass match the CPU's, counted
/// against the air at rest.
#[test]
fn the_walls_face_fluxes_match_their_cpu_twin() {
    use glam::DVec4;
    use phonation::coupling::momentum_exchange::step_with_exchange;
    let Some(ctx) = context() else { return };
    for dim3 in [false, true] {
        let mut cpu = scene(dim3, GasModel::Diatomic);
        // the corners of the walls have one-sided stencils, whose corrections the walls take too
        let thin = cpu.layout.thin_taps.len();
        assert!(thin > 0, "the scene exercises the thin-wall part");
        let mut reference = vec![0.0; cpu.eq.values_per_node()];
        let mut shells = vec![0.0; cpu.eq.set.shells.len()];
        cpu.eq.feq_into(&Macro { rho: 1.0, u: [0.0; 3], theta: 0.6 }, &mut shells, &mut reference);
        let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
        gpu.record_face_fluxes(&cpu, &reference);
        let (mut worst, mut walls) = (0.0f64, 0);
        for step in 0..30 {
            let want = step_with_exchange(&mut cpu, Some(&reference)).unwrap();
            gpu.run(1);
            let got = gpu.take_face_fluxes();
            assert_eq!(got.len(), want.len());
            // per component, the largest |CPU| value of the step is the scale
            let scale = (0..4).map(|a| want.iter().map(|w| w[a].abs()).fold(0.0, f64::max)).collect::<Vec<_>>();
            let dims = if dim3 { [0, 1, 2, 3].as_slice() } else { [0, 1, 3].as_slice() };
            assert!(dims.iter().all(|&a| scale[a] > 0.0), "step {step}: the walls receive momentum and mass ({scale:?})");
            for (node, (g, w)) in got.iter().zip(&want).enumerate() {
                let g = DVec4::new(g[0] as f64, g[1] as f64, g[2] as f64, g[3] as f64);
                if !dim3 {
                    assert_eq!(g.z, 0.0, "2D: no momentum along z");
                }
                for &a in dims {
                    let d = (g[a] - w[a]).abs() / scale[a];
                    // f32: the GPU state differs from the CPU's by ~1e-5 of each population's
                    // scale (whole-step parity), and a face's flux is counted against the
                    // reference populations, a difference ~10× smaller than them (measured
                    // 5.7e-5 in 2D, 2.4e-5 in 3D on lavapipe)
                    assert!(d < 2e-4, "{}: step {step}, node {node}, component {a}: GPU {} vs CPU {}", if dim3 { "3D" } else { "2D" }, g[a], w[a]);
                    worst = worst.max(d);
                }
            }
            walls = want.iter().filter(|w| **w != DVec4::ZERO).count();
        }
        eprintln!(
            "{}: face fluxes of {walls} wall nodes ({thin} thin taps) over 30 steps within {worst:.2e} of each component's scale",
            if dim3 { "3D" } else { "2D" }
        );
    }
}

/// The stencils next to walls thinner than the upwind stencil (`fluid::thin_wall`), with their
/// side ghosts: a channel closed by a plate one cell thick, with a 5 % overpressure below it, and a disc
/// four cells across in the flow below. The advection stage (with its thin-wall pass) matches
/// the CPU kernel, whole steps match, and the air above the plate stays at rest on the GPU too.
#[test]
fn thin_walls_match_the_cpu() {
    let Some(ctx) = context() else { return };
    // the thin walls' leak-test channel (a plate one cell thick), a diatomic gas, and a disc
    let disc = [Obstacle { shape: Shape::Cylinder { center: [11.7, 7.4, 0.0], radius: 2.0 }, velocity: [0.0; 3], temperature: None }];
    let channel = || phonation::fluid::fixtures::closed_channel(GasModel::Diatomic, 1, &disc);
    let mut cpu = channel();
    assert!(cpu.layout.thin_taps.len() > 24, "the plate and the disc have thin taps: {}", cpu.layout.thin_taps.len());
    // the plate's row of ghosts serves one side; the other reads side ghosts (nodes past the
    // lattice on the GPU)
    let sides = phonation::fluid::thin_wall::side_ghost_count(&cpu.layout.thin_taps);
    assert!(sides >= 24, "the plate's far side has side ghosts: {sides}");
    cpu.run(20).unwrap();
    let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
    for stage in &FDLB_STEP[..3] {
        cpu.run_stage(stage).unwrap();
        gpu.run_stage(stage);
    }
    let (f1, ..) = cpu.stage_arrays();
    let d = compare_nodes(&gpu.download(GpuArray::FirstStage), &cpu, f1, cpu.pop, &[NodeKind::Fluid]);
    eprintln!("thin walls: advection stage {d:e}");
    assert!(d < KERNEL_TOL, "advection with thin-wall stencils: {d:e}");
    let mut cpu = channel();
    let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
    cpu.run(200).unwrap();
    gpu.run(200);
    let d = gpu.max_relative_difference(&cpu);
    eprintln!("thin walls: whole-step parity after 200 steps: {d:e}");
    assert!(d < 1e-4, "{d:e}");
    let mut mirror = cpu;
    gpu.download_into(&mut mirror);
    for y in 17..32 {
        for x in 0..24 {
            let rho = mirror.macro_at_coords([x, y, 0]).rho;
            // At rest to f32 round-off: the moments → equilibrium round trip in f32 moves ρ by
            // O(ε_f32 = 6e-8) per step, 200 steps ≤ 1.2e-5 (measured 4.1e-6 on lavapipe); the
            // leak without the one-sided stencils is above 1e-4 (CPU test, f64).
            assert!((rho - 1.0).abs() < 2e-5, "ρ above the plate at [{x}, {y}] on the GPU: {rho}");
        }
    }
}

#[test]
fn gpu_reports_instability() {
    let Some(ctx) = context() else { return };
    let mut cpu = scene(false, GasModel::Monatomic);
    cpu.params.dt = 1.0;
    cpu.params.tau = 1.0;
    cpu.params.a = 0.0;
    let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
    gpu.run(300);
    let (node, code) = gpu.instability().expect("the flag is read").expect("Δt = 1 must blow up");
    assert!(cpu.layout.kind[node] == NodeKind::Fluid && (1..=3).contains(&code));
}

/// Arrays larger than the adapter's binding limit are bound as several population ranges; the
/// results must not change. The limit is lowered so that a small lattice takes that path.
#[test]
fn split_bindings_give_the_same_steps() {
    let Some(ctx) = context() else { return };
    let cpu0 = scene(false, GasModel::Diatomic);
    let n = cpu0.layout.grid.len().div_ceil(64) * 64;
    // 42 values per node, 16 populations per binding: 3 bindings per array.
    let ctx = ctx.with_binding_limit((16 * n * 4) as u64);
    let mut cpu = cpu0;
    let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
    cpu.run(50).unwrap();
    gpu.run(50);
    let d = gpu.max_relative_difference(&cpu);
    eprintln!("split-binding parity after 50 steps: {d:e}");
    assert!(d < 1e-4, "{d:e}");
}

/// The GPU's periodic fill copies only the values of h that the advection reads at each halo
/// node (`fluid::layout::HaloReach`, as the CPU's fill): with every value of f, f¹, fⁿ⁺¹ and h
/// on the periodic halo nodes NaN on the device from the start, 40 steps of a box periodic in x
/// (and z) with walls, a lid, an obstacle at a periodic face and a diatomic gas stay finite at
/// every fluid node and match the CPU to the whole-step bound.
#[test]
fn the_periodic_fill_copies_what_the_advection_reads() {
    let Some(ctx) = context() else { return };
    for dim3 in [false, true] {
        let (kind, n) = if dim3 { (VelocitySetKind::D3q39, [10, 9, 7]) } else { (VelocitySetKind::D2q21, [16, 12, 1]) };
        let scene = || phonation::fluid::fixtures::busy_lattice::<f64>(kind, n, 0.8);
        let mut cpu = scene();
        let mut poisoned = scene();
        let nan = vec![f64::NAN; cpu.pop.nv];
        let halo: Vec<usize> = (0..cpu.layout.grid.len()).filter(|&k| cpu.layout.kind[k] == NodeKind::Periodic).collect();
        assert!(!halo.is_empty());
        for &node in &halo {
            poisoned.set_node_populations(node, &nan);
        }
        let mut gpu = GpuFluid::from_solver(&ctx, &poisoned).unwrap();
        let steps = 40;
        cpu.run(steps).unwrap();
        gpu.run(steps);
        let label = if dim3 { "3D" } else { "2D" };
        assert!(gpu.instability() == Ok(None), "{label}");
        let state = gpu.download(GpuArray::State);
        let n = cpu.layout.grid.len();
        for node in (0..n).filter(|&k| cpu.layout.kind[k] == NodeKind::Fluid) {
            assert!(
                (0..cpu.pop.nv).all(|v| state[v * n + node].is_finite()),
                "{label}: node {:?} read a value the fill left out",
                cpu.layout.grid.coords(node)
            );
        }
        let d = gpu.max_relative_difference(&cpu);
        eprintln!("{label} periodic box with NaN halos, {steps} steps: {d:e}");
        assert!(d < 1e-4, "{label}: {d:e}");
    }
}

/// The `gather` kernel brings back the populations of the listed nodes exactly as the whole
/// download does, and touches no other node of the CPU solver.
#[test]
fn gathered_populations_are_the_downloaded_ones() {
    let Some(ctx) = context() else { return };
    for dim3 in [false, true] {
        let cpu = scene(dim3, GasModel::Diatomic);
        let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
        gpu.run(3);
        let mut whole = scene(dim3, GasModel::Diatomic);
        gpu.download_into(&mut whole);
        let n = cpu.layout.grid.len();
        // every 7th node downwards, then a run that lists some of them again, and the last node
        let nodes: Vec<usize> = (0..n).step_by(7).rev().chain(40..90).chain([n - 1]).collect();
        let mut some = scene(dim3, GasModel::Diatomic);
        let before = some.f.clone();
        gpu.download_nodes_into(&nodes, &mut some);
        // twice, so that the second call reuses the kernel's buffers
        gpu.download_nodes_into(&nodes[..10], &mut some);
        for node in 0..n {
            let expected = if nodes.contains(&node) { whole.node_populations(node) } else { (0..cpu.pop.nv).map(|v| before[cpu.pop.index(node, v)]).collect() };
            assert_eq!(some.node_populations(node), expected, "{} node {node}", if dim3 { "3D" } else { "2D" });
        }
        assert_eq!((some.step_count, some.time), (whole.step_count, whole.time));
    }
}

/// The fluid's totals summed on the device (`GpuFluid::totals`: f32 partial sums per 1024 nodes,
/// added in f64) against the CPU's f64 sums (`FluidSolver::totals`) of the same f32 state
/// brought back, in 2D and 3D with a diatomic gas (its extra energy values) and obstacles: the
/// difference is the partial sums' f32 round-off, held to 1e-6 of Σ|terms| (the mass; the
/// momentum's terms are bounded by the mass times the largest |c|; measured on lavapipe: mass 2–3·10⁻⁸, momentum 4·10⁻¹⁰, energy 3·10⁻⁸).
#[test]
fn gpu_totals_match_the_cpu_sums() {
    let Some(ctx) = context() else { return };
    for dim3 in [false, true] {
        let cpu = scene(dim3, GasModel::Diatomic);
        let mut gpu = GpuFluid::from_solver(&ctx, &cpu).unwrap();
        gpu.run(5);
        let mut down = scene(dim3, GasModel::Diatomic);
        gpu.download_into(&mut down);
        let (c, g) = (down.totals(), gpu.totals().expect("the read succeeds"));
        let cmax = down.eq.set.c.iter().flat_map(|c| c.iter().map(|v| v.abs())).max().unwrap() as f64;
        let scale_p = c.mass * cmax;
        let dm = (g.mass - c.mass).abs() / c.mass;
        let dp = (0..3).map(|a| (g.momentum[a] - c.momentum[a]).abs()).fold(0.0, f64::max) / scale_p;
        let de = (g.energy - c.energy).abs() / c.energy;
        eprintln!("{}: mass {dm:.1e}, momentum {dp:.1e} (of mass × |c|max), energy {de:.1e}; CPU {c:?} GPU {g:?}", if dim3 { "3D" } else { "2D" });
        assert!(dm < 1e-6 && dp < 1e-6 && de < 1e-6, "mass {dm:e} momentum {dp:e} energy {de:e}");
        // the momentum is not zero (the scene flows), so the bound on it is not empty
        assert!(c.momentum.iter().any(|v| v.abs() > 1e-3 * scale_p), "{c:?}");
    }
}

/// The GPU fluid's arrays hold the thin walls' side ghosts past the lattice, sized when the
/// fluid goes up (twice what its walls need then, at least a 32nd of the lattice or 256 nodes).
/// Walls that need more later are refused with both figures, and the fluid is left as it was.
#[test]
fn walls_that_outgrow_the_side_ghosts_room_are_refused_with_the_figures() {
    let Some(ctx) = context() else { return };
    let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
    let params = timestep::choose(0.05, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
    let mut b = Boundaries::periodic();
    b.faces[2] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
    b.faces[3] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
    let at_rest = |_: [f64; 3]| Macro { rho: 1.0, u: [0.0; 3], theta: 0.6 };
    let grid = Grid::new(2, [400, 16, 1]);
    let open = FluidSolver::new(eq.clone(), grid.clone(), b.clone(), &[], params, at_rest);
    // a plate one row thick, a quarter cell off the mid-line, across the whole channel
    let plate = Obstacle { shape: Shape::Cuboid { min: [-4.0, 7.15, -1.0], max: [404.0, 8.35, 1.0] }, velocity: [0.0; 3], temperature: None };
    let split = FluidSolver::new(eq, grid, b, &[plate], params, at_rest);
    let needed = phonation::fluid::thin_wall::side_ghost_count(&split.layout.thin_taps);
    let mut gpu = GpuFluid::from_solver(&ctx, &open).unwrap();
    let e = gpu.set_geometry(&split).unwrap_err();
    eprintln!("{e}");
    assert_eq!(e.needed, needed);
    assert!(e.room >= 256 && e.room < needed, "{e:?}");
    assert!(e.to_string().contains(&needed.to_string()) && e.to_string().contains(&e.room.to_string()), "{e}");
    // refused before anything changed: the open channel still steps as the CPU's
    let mut cpu = open;
    gpu.run(5);
    cpu.run(5).unwrap();
    assert!(gpu.max_relative_difference(&cpu) < 1e-5);
    // made with those walls, the arrays have the room
    assert!(GpuFluid::from_solver(&ctx, &split).unwrap().set_geometry(&split).is_ok());
}
