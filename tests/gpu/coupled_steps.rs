//! Whole coupled steps on the GPU against the CPU: both methods over 200 steps, towed bodies,
//! the layout built with the level sets' questions on the device, changes of layout, the
//! objects a running step makes, isothermal walls, the instability diagnosis and the bench's
//! stage timings. The coupling's kernels one by one are in `coupling`.

use crate::support::*;

/// The coupled step with method 2's level-set questions answered on the device builds the
/// layout the CPU's answers give, step by step: two runs on the GPU, one with the questions on
/// the device (the default where it has f64) and one with them on the CPU, over 30 steps of the
/// small flap bending and of a disc towed past a clamped flap (two bodies, nodes changing side)
/// — the same node kinds, the same ghosts with the same image stencils' nodes, the ghosts'
/// extrapolation ratios and wall velocities to the kernels' bound against their twins (1e-9,
/// `level_set_queries_on_the_device_match_the_cpu`), both questions of each body answered on the
/// device (up to two calls per body and step, its bins sent once a step) and none of the other
/// run's.
#[test]
fn a_coupled_step_with_level_sets_on_the_device_builds_the_cpus_layout() {
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::scene::coupled::CoupledScene;
    for (label, text, bodies) in [("small flap", SMALL_FLAP, 1), ("towed disc and flap", TOWED_DISC, 2)] {
        let sc = CoupledScene::parse(text).unwrap();
        let Some(ctx) = context() else { return };
        let mut dev = GpuCoupled::new(ctx, sc.build().unwrap()).unwrap();
        if !dev.level_sets_on_device() {
            eprintln!("no f64 in shaders: the level sets' questions stay on the CPU");
            return;
        }
        let mut host = GpuCoupled::new(context().unwrap(), sc.build().unwrap()).unwrap();
        host.device_level_sets = false;
        assert!(!host.level_sets_on_device());
        let steps = 30;
        let (mut ghosts, mut dr, mut dv) = (0, 0f64, 0f64);
        for step in 0..steps {
            dev.step().unwrap();
            host.step().unwrap();
            let (a, b) = (&dev.cpu.fluid.layout, &host.cpu.fluid.layout);
            assert!(a.kind == b.kind, "{label}, step {step}: node kinds");
            assert_eq!(a.ghosts.len(), b.ghosts.len(), "{label}, step {step}: ghosts");
            for (g, h) in a.ghosts.iter().zip(&b.ghosts) {
                assert_eq!(g.node, h.node, "{label}, step {step}: ghost nodes");
                let nodes = |x: &phonation::fluid::layout::Ghost| x.image.iter().map(|t| t.0).collect::<Vec<_>>();
                assert_eq!(nodes(g), nodes(h), "{label}, step {step}: the image stencil of ghost {}", g.node);
                dr = dr.max((g.ratio - h.ratio).abs());
                dv = dv.max((0..3).map(|k| (g.wall_velocity[k] - h.wall_velocity[k]).abs()).fold(0.0, f64::max));
            }
            ghosts += a.ghosts.len();
        }
        dev.check_fluid().unwrap();
        let (w, none) = (dev.level_set_work().unwrap(), host.level_set_work().unwrap());
        eprintln!(
            "{label}, {steps} steps: {} nodes and ghosts answered on the device in {} calls ({:?}), {} changes of layout; ratio {dr:.2e}, wall velocity {dv:.2e} c",
            w.queries, w.calls, w.time, dev.round_trips
        );
        // each body's bins go up once a step and serve both of its questions (a question with
        // nothing to ask — a clamped body with no ghost at some step — makes no call)
        assert_eq!((w.bins_sent, w.failed, none.calls), (bodies * steps, 0, 0), "{label}");
        assert!(w.calls > w.bins_sent && w.calls <= 2 * w.bins_sent, "{label}: {} calls", w.calls);
        assert!(w.queries as usize > ghosts, "{label}: {} queries, {ghosts} ghosts", w.queries);
        assert!(dr <= 1e-9 && dv <= 1e-9, "{label}: ratio {dr:e}, wall velocity {dv:e}");
    }
}

/// Method 2's coupled step on the GPU (`GpuCoupled`: fluid, face fluxes, momentum exchange and
/// solid on the device; the level-set geometry built on the CPU each step, the level sets'
/// questions answered on the device where it has f64) against the CPU
/// solver over 200 steps (5000 solid sub-steps) of a moving flap that uncovers and covers
/// nodes. The geometry must agree exactly: the same nodes changed side. Bounds: the fluid alone
/// carries 4e-5 to 6e-5 of f32 round-off after 200 steps and is held to 1e-4
/// (`whole_steps_match_the_cpu_backend`); the coupling adds no rounding of its own beyond the
/// exchange's f32 sums (1e-5, `coupling_kernels_match_their_cpu_twins`), so the populations and
/// the flap's displacement are held to 1e-4 of their scale (measured on lavapipe: 3.9e-5,
/// 9.0e-7; on an H200: 4.9e-5, 2.8e-6), and the force on it to 3× the populations' difference
/// of its own size ([`FORCE_OVER_POPULATIONS`]; measured 4.1e-5 and 1.1e-4). The particles' velocities carry the solid's own f32
/// noise in particle-scale modes, measured here on the same flap without air over the same
/// sub-steps (1.4e-3); the coupling may not amplify it by more than 3× (measured 1.8e-3). Before
/// the GPU solid stored displacements instead of absolute positions, these were 2.5e-2 and
/// 5.8e-2 (f32 strains of |x|/l₀ · 2⁻²⁴ ≈ 8e-6 at 2.6 cm from the origin).
#[test]
fn coupled_steps_on_the_gpu_match_the_cpu_over_200_steps() {
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::scene::coupled::CoupledScene;
    let Some(ctx) = context() else { return };
    let sc = CoupledScene::parse(SMALL_FLAP).unwrap();
    let steps = 200;
    // the solid alone, no air: the GPU solid's own f32 velocity noise on this flap
    let dv_alone = {
        let mut alone = sc.build().unwrap().solid;
        let mut gs = GpuSolid::from_solver(&ctx, &mut alone).unwrap();
        let substeps = steps * sc.build().unwrap().substeps as u64;
        (0..substeps).try_for_each(|_| alone.step()).unwrap();
        gs.run(substeps);
        rel_vec(&gs.download_vectors(SolidArray::Velocity), &alone.particles.velocity)
    };
    let mut cpu = sc.build().unwrap();
    let mut gpu = GpuCoupled::new(ctx, sc.build().unwrap()).unwrap();
    let x0 = cpu.solid.particles.position.clone();
    // the CPU stage by stage, to measure the scale of the exchange's run sums: Σ over the steps
    // and the wall nodes of |m| and |p| (the terms, before they cancel; lattice units)
    let (mut mass_terms, mut momentum_terms) = (0.0, 0.0);
    for _ in 0..steps {
        for st in cpu.stages() {
            if st.kind == phonation::stages::CoupledStageKind::MomentumExchange {
                let w = cpu.exchange().unwrap().wall();
                mass_terms += w.iter().map(|v| v.w.abs()).sum::<f64>();
                momentum_terms += w.iter().map(|v| v.truncate().length()).sum::<f64>();
            }
            cpu.run_stage(st.kind).unwrap();
        }
        cpu.step_count += 1;
        cpu.time += cpu.dt();
    }
    gpu.run(steps).unwrap();
    gpu.download_into();
    let g = &gpu.cpu;
    let p = CoupledParity::of(&cpu, &gpu, &x0);
    let dv = rel_vec(&g.solid.particles.velocity, &cpu.solid.particles.velocity);
    eprintln!(
        "coupled, {steps} steps: {}; velocity {dv:.2e} (the solid alone: {dv_alone:.2e}); {} population round trips, {} new boundary tables; shares {:?}",
        p.summary(),
        gpu.round_trips,
        gpu.fluid.geometry_rebinds,
        gpu.stage_shares()
    );
    // the boundary tables change size on many steps (nodes changing side, thin-wall taps
    // appearing or going: 73 of the 200 steps, measured when each such step made new buffers)
    // and are rewritten in their buffers, which hold half as much again as at the upload: new
    // buffers and bind groups only if one outgrew that (`a_coupled_step_makes_no_buffers_once_running`)
    assert!(gpu.fluid.geometry_rebinds <= 1, "{} rebinds", gpu.fluid.geometry_rebinds);
    p.assert_within(1e-4);
    assert!(gpu.round_trips > 0);
    assert!(dv_alone < 1e-2 && dv < 3.0 * dv_alone, "velocity {dv:e}, the solid alone {dv_alone:e}");
    assert_eq!(gpu.step_count(), steps);
    // the exchange's run sums, kept on the GPU path as on the CPU: each against the sum of its
    // terms' magnitudes, held to the populations' and forces' bound (1e-4 of their scale)
    let (ec, eg) = (cpu.exchange().unwrap(), g.exchange().unwrap());
    let p_terms = momentum_terms * cpu.momentum_unit();
    let d = [
        (eg.walls - ec.walls).length() / p_terms,
        (eg.mass_to_walls - ec.mass_to_walls).abs() / mass_terms,
        (eg.wall_frame - ec.wall_frame).length() / p_terms,
    ];
    eprintln!(
        "run sums: walls {:?} vs {:?}, mass {:e} vs {:e}, wall frame {:?} vs {:?} (GPU vs CPU); terms Σ|p| {p_terms:.3e}, Σ|m| {mass_terms:.3e}: differences {:?}",
        eg.walls,
        ec.walls,
        eg.mass_to_walls,
        ec.mass_to_walls,
        eg.wall_frame,
        ec.wall_frame,
        d.map(|x| format!("{x:.2e}"))
    );
    assert!(ec.walls != DVec3::ZERO && ec.mass_to_walls != 0.0 && ec.wall_frame != DVec3::ZERO, "the run sums must have something to compare");
    assert!(d.iter().all(|x| *x < 1e-4), "run sums {d:?}");
}

/// A body with a prescribed motion on the GPU: moved by the CPU after every solid sub-step as
/// the CPU solver moves it, only its particles' kinematics written to the device. Over 160
/// steps the towed disc crosses more than a cell, so nodes change side: the geometry must agree
/// exactly (same nodes uncovered and covered), the disc's particles must be where the motion
/// puts them (to round-off), and the displacements (the flap's f32 noise), the populations and
/// the air's force on the disc are held to the coupled flap's bounds (1e-4 of their scale,
/// `coupled_steps_on_the_gpu_match_the_cpu_over_200_steps`; measured 8.4e-7, 4.2e-5, 3e-5).
/// The CPU reference holds its positions as the GPU does (f32 displacements from the reference
/// configuration, ~1e-10 cm here): method 2's walls are not a continuous function of the
/// particles' positions — the image-point stencils and thin-wall taps switch — and the CPU
/// against itself with and without that rounding differs by up to 5e-2 in the populations over
/// these steps (transients that decay within a few steps), as did the GPU against the unrounded
/// CPU.
#[test]
fn a_towed_body_on_the_gpu_matches_the_cpu() {
    use glam::DVec3;
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::scene::coupled::CoupledScene;
    let Some(ctx) = context() else { return };
    let sc = CoupledScene::parse(TOWED_DISC).unwrap();
    let steps = 160;
    let mut cpu = sc.build().unwrap();
    let mut gpu = GpuCoupled::new(ctx, sc.build().unwrap()).expect("a prescribed motion runs on the GPU");
    let x0 = cpu.solid.particles.position.clone();
    let reference = cpu.solid.particles.reference.clone();
    for _ in 0..steps {
        cpu.step().unwrap();
        // the positions as the GPU holds them (f32 displacements from the reference): the
        // level-set geometry of a moving body is not continuous in them (the doc above)
        for (x, r) in cpu.solid.particles.position.iter_mut().zip(&reference) {
            let d = *x - *r;
            *x = *r + DVec3::new(d.x as f32 as f64, d.y as f32 as f64, d.z as f32 as f64);
        }
    }
    gpu.run(steps).unwrap();
    gpu.download_into();
    let g = &gpu.cpu;
    let travelled = (cpu.solid.particles.position[0] - x0[0]).length();
    // the disc's particles: where the motion puts them, as the CPU rounds them
    let disc = (0..x0.len()).filter(|&i| cpu.solid.particles.body[i] == 0);
    let dx_disc = disc.map(|i| (g.solid.particles.position[i] - cpu.solid.particles.position[i]).length()).fold(0.0, f64::max) / travelled;
    let p = CoupledParity::of(&cpu, &gpu, &x0);
    eprintln!(
        "towed disc, {steps} steps: travelled {travelled:.3e} cm ({:.2} cells), displacement difference {:.2e} (the disc's {dx_disc:.2e}), populations {:.2e}, force {:?} (CPU) vs {:?} (GPU); nodes uncovered / covered {:?} (CPU) vs {:?} (GPU)",
        travelled / 0.05,
        p.du,
        p.df,
        p.fc,
        p.fg,
        p.cpu_nodes,
        p.gpu_nodes
    );
    assert!(travelled > 0.05, "the disc must cross a cell ({travelled} cm)");
    assert!(dx_disc < 1e-9, "the disc's particles {dx_disc:e}");
    p.assert_within(1e-4);
    assert_eq!(gpu.step_count(), steps);
}

/// `phonation run` of a method-2 coupled scene with `--backend gpu`: the run layer's
/// `CoupledEngine` steps `GpuCoupled`, writes the same `coupling.csv` rows as the CPU (each body's
/// force and mean displacement, within the coupled parity bounds above), says which backend ran
/// it with the stage shares and carries the exchange's run sums; a method-1 scene runs on the GPU
/// backend too.
#[test]
fn a_coupled_scene_runs_on_the_gpu_backend_with_the_cpus_outputs() {
    use phonation::run::coupled::run_coupled_scene;
    use phonation::run::{Backend, LevelSets, RunOptions};
    use phonation::scene::coupled::CoupledScene;
    let Some(_ctx) = context() else { return };
    let sc = CoupledScene::parse(&SMALL_FLAP.replace(
        "[coupling]",
        "[[probes]]\nname = \"wake\"\nposition = [3.0, 1.3]\n[output]\nprobe_every = 10\nsnapshots = 1\n[coupling]\noutput_every = 20\nprobes = [{ name = \"tip\", min = [2.5, 1.15], max = [2.6, 1.25] }]",
    ))
    .unwrap();
    let read_with = |backend: Backend, level_sets: LevelSets| {
        let dir = std::env::temp_dir().join(format!("phonation-gpu-coupled-{backend:?}-{level_sets:?}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let r = run_coupled_scene(&sc, &dir, &RunOptions { steps: Some(100), backend, level_sets, ..Default::default() }).unwrap();
        let text = std::fs::read_to_string(dir.join("coupling.csv")).unwrap();
        let header: Vec<String> = text.lines().next().unwrap().split(',').map(String::from).collect();
        let rows: Vec<Vec<f64>> = text.lines().skip(1).map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
        let _ = std::fs::remove_dir_all(&dir);
        (r, header, rows)
    };
    let read = |backend: Backend| read_with(backend, LevelSets::Device);
    let (rc, header, cpu) = read(Backend::Cpu);
    let (rg, _, gpu) = read(Backend::Gpu);
    // `--level-sets host`: the same run with the level-set questions asked on the host; the
    // backend's name says where they were asked, and the rows are those of the device's answers
    // (the same layouts: `a_coupled_step_with_level_sets_on_the_device_builds_the_cpus_layout`).
    // Measured on lavapipe: 0 apart. The answers agree to ~1e-15 of a cell and reach the f32
    // kernels rounded; 1e-6 leaves room for a driver whose contraction of a product and a sum
    // moves an f32 ratio by an ulp (6e-8), which 100 steps may grow by a few times.
    let (rh, _, host) = read_with(Backend::Gpu, LevelSets::Host);
    eprintln!("{}\n{}", rg.backend, rh.backend);
    assert!(rh.backend.ends_with("; level-set questions on the host (as asked)"), "{}", rh.backend);
    assert!(rg.backend.ends_with("; level-set questions on the device (f64)") || rg.backend.ends_with("(the device has no f64 in shaders)"), "{}", rg.backend);
    let apart = host.iter().zip(&gpu).flat_map(|(h, g)| h.iter().zip(g).map(|(a, b)| (a - b).abs() / a.abs().max(b.abs()).max(1e-300))).fold(0.0, f64::max);
    eprintln!("level sets on the host against the device: rows {apart:.2e} apart (relative)");
    assert!(apart < 1e-6, "{apart:e}");
    // what came back for the outputs: one whole state (the snapshot at step 100, also the end),
    // the air's totals summed on the device for the 5 csv rows and the summary's mass drift, the
    // probe's node at the 10 samples, the solid with each (15 kB) — not the lattice at every
    // row and sample (10 advances: 10 whole states before)
    let rb = rg.readback.expect("a GPU run reports what came back");
    eprintln!("read back: {rb:?}");
    assert!(rc.readback.is_none());
    assert_eq!((rb.whole_states, rb.totals, rb.gathered), (1, 6, 10), "{rb:?}");
    assert!(rb.bytes < 3 * 4 * 21 * 80 * 48, "{rb:?}");
    eprintln!("{} / {}: stage shares {:?}", rc.backend, rg.backend, rg.stage_shares);
    assert!(rc.backend.starts_with("cpu") && rg.backend.starts_with("gpu"), "{} / {}", rc.backend, rg.backend);
    assert!(rg.instability.is_none() && rg.steps == 100 && rg.stage_shares.len() == 4);
    assert_eq!(cpu.len(), gpu.len());
    let col = |name: &str| header.iter().position(|h| h.starts_with(name)).unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    let (fx, dy) = (col("force_x_0"), col("mean_dy_0"));
    // the air's mass and momentum of the rows: summed on the device on the GPU, held to the
    // populations' parity bound (1e-4 of the scale: the mass, and the mass times the inflow)
    let (mass, px) = (col("fluid_mass"), col("fluid_px"));
    for (c, g) in cpu.iter().zip(&gpu) {
        assert!((c[mass] / g[mass] - 1.0).abs() < 1e-4, "mass {} vs {}", c[mass], g[mass]);
        assert!((c[px] - g[px]).abs() < 1e-4 * cpu[0][px].abs(), "momentum {} vs {}", c[px], g[px]);
    }
    let tip = col("tip_dy");
    assert!(gpu.iter().all(|r| r[tip].is_finite()) && gpu.last().unwrap()[tip] != 0.0, "the tip probe is read from the device's particles");
    let f_scale = cpu.iter().map(|r| r[fx].abs()).fold(0.0, f64::max);
    let d_scale = cpu.iter().map(|r| r[dy].abs()).fold(0.0, f64::max);
    let worst = cpu.iter().zip(&gpu).map(|(c, g)| (c[fx] - g[fx]).abs()).fold(0.0, f64::max);
    eprintln!("force_x rows: largest difference {:.2e} of the largest |F_x|", worst / f_scale);
    for (c, g) in cpu.iter().zip(&gpu) {
        assert_eq!(c[0], g[0], "the same steps");
        // the coupled parity bounds: the force to FORCE_OVER_POPULATIONS × the populations'
        // bound (measured: 2.7e-5 of the scale on lavapipe, 1.14e-4 on an H200)
        assert!((c[fx] - g[fx]).abs() <= FORCE_OVER_POPULATIONS * 1e-4 * f_scale, "force {} vs {}", c[fx], g[fx]);
        assert!((c[dy] - g[dy]).abs() <= 1e-4 * d_scale, "displacement {} vs {}", c[dy], g[dy]);
    }
    assert!(d_scale > 0.0 && f_scale > 0.0);
    // the summary carries the exchange's run sums on both backends (their precision is held to
    // 1e-4 of their terms by `coupled_steps_on_the_gpu_match_the_cpu_over_200_steps`; over 200
    // steps the mass differed by 5.5e-4 of its own value)
    let (ec, eg) = (rc.exchange.as_ref().expect("method 2"), rg.exchange.as_ref().expect("method 2 on the GPU"));
    eprintln!("exchange over the run: {ec:?} (CPU) vs {eg:?} (GPU)");
    assert!(ec.mass_to_walls != 0.0 && (eg.mass_to_walls / ec.mass_to_walls - 1.0).abs() < 1e-2, "{} vs {}", eg.mass_to_walls, ec.mass_to_walls);
    // method 1 runs on the GPU backend too (its parity: `weak_coupled_steps_on_the_gpu_match_the_cpu`)
    let weak = CoupledScene::parse(&small_flap_weak()).unwrap();
    let dir = std::env::temp_dir().join(format!("phonation-gpu-coupled-weak-{}", std::process::id()));
    let r = run_coupled_scene(&weak, &dir, &RunOptions { steps: Some(10), backend: Backend::Gpu, ..Default::default() }).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(r.backend.starts_with("gpu") && r.method == "weak" && r.steps == 10 && r.instability.is_none(), "{} {} {}", r.backend, r.method, r.steps);
    assert_eq!(r.stage_shares.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(), ["fluid_geometry", "fluid", "surface_traction", "solid"]);
}

/// A change of layout on the GPU brings back only the nodes it reads and sends up only the
/// fresh nodes (`LayoutChange::reads`, `fresh`; the `gather` and `scatter` kernels) instead of
/// the whole state both ways: over 80 steps of the small flap, for both methods, the device ends
/// **bit for bit** where the whole round trips take it (populations and particles), having moved
/// a small part of the nodes.
#[test]
fn a_change_of_layout_moves_only_the_nodes_it_reads_and_writes() {
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::scene::coupled::CoupledScene;
    let steps = 80;
    for text in [SMALL_FLAP.to_string(), small_flap_weak()] {
        let sc = CoupledScene::parse(&text).unwrap();
        let (Some(c1), Some(c2)) = (context(), context()) else { return };
        let mut lists = GpuCoupled::new(c1, sc.build().unwrap()).unwrap();
        let mut whole = GpuCoupled::new(c2, sc.build().unwrap()).unwrap();
        whole.whole_round_trips = true;
        lists.run(steps).unwrap();
        whole.run(steps).unwrap();
        assert!(lists.download_into() && whole.download_into());
        let (a, b) = (&lists.cpu, &whole.cpu);
        let method = sc.coupling.method.name();
        assert!(lists.round_trips > 0 && lists.round_trips == whole.round_trips, "{method}: {} vs {} round trips", lists.round_trips, whole.round_trips);
        let differ = a.fluid.f.iter().zip(&b.fluid.f).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
        assert_eq!(differ, 0, "{method}: {differ} population values differ");
        let bits = |v: &[glam::DVec3]| v.iter().flat_map(|x| x.to_array()).map(f64::to_bits).collect::<Vec<_>>();
        assert_eq!(bits(&a.solid.particles.position), bits(&b.solid.particles.position), "{method}: positions");
        assert_eq!(bits(&a.solid.particles.velocity), bits(&b.solid.particles.velocity), "{method}: velocities");
        let per_trip = lists.round_trip_nodes as f64 / lists.round_trips as f64;
        eprintln!("{method}: {} changes of layout, {per_trip:.0} nodes moved per change instead of 2 × {}", lists.round_trips, lists.fluid.n_nodes);
        assert!(per_trip < 0.1 * lists.fluid.n_nodes as f64, "{method}: {per_trip} nodes per change");
    }
}

/// A running coupled step makes nothing on the device: its tables are rewritten in their
/// buffers (which hold half as much again as at the upload), the hand-over's and the traction's
/// buffers and bind groups are kept, the particles come back through one kept staging
/// buffer, and so do the populations of the nodes that change side (the gather's and the
/// scatter's buffers and bind groups are kept too), the air's totals and method 1's piece
/// forces that output rows read. Over 100 steps of the small flap after 20 that warm it up, for
/// both methods, with the totals and the piece forces read every 10 steps, with
/// the boundary tables changing size on many of them (the steps that made new buffers and bind
/// groups before) and nodes changing side, `device_objects_made` moves only when a table
/// outgrows its room, and not at all over the last 50.
#[test]
fn a_coupled_step_makes_no_buffers_once_running() {
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::scene::coupled::CoupledScene;
    for text in [SMALL_FLAP.to_string(), small_flap_weak()] {
        let sc = CoupledScene::parse(&text).unwrap();
        let method = sc.coupling.method.name();
        let Some(ctx) = context() else { return };
        let mut gpu = GpuCoupled::new(ctx, sc.build().unwrap()).unwrap();
        gpu.run(20).unwrap();
        // what a run's output rows read: the air's totals (summed on the device) and method 1's
        // piece forces — their kernels', bind groups' and staging buffers' first ones here
        let read_outputs = |g: &mut GpuCoupled| {
            assert!(g.fluid.totals().is_some_and(|t| t.mass > 0.0), "{method}: the totals");
            assert!(g.fluid.download_piece_forces().is_some(), "{method}: the piece forces");
        };
        read_outputs(&mut gpu);
        let (made, trips) = (gpu.device_objects_made(), gpu.round_trips);
        let table_sizes = |g: &GpuCoupled| (g.cpu.fluid.layout.ghosts.len(), g.cpu.fluid.layout.thin_taps.len());
        let mut sizes = table_sizes(&gpu);
        let (mut resized, mut half) = (0, 0);
        for k in 0..100 {
            gpu.step().unwrap();
            if k % 10 == 9 {
                read_outputs(&mut gpu);
            }
            if k == 49 {
                half = gpu.device_objects_made();
            }
            let now = table_sizes(&gpu);
            resized += (now != sizes) as u32;
            sizes = now;
        }
        gpu.check_fluid().unwrap();
        let changes = gpu.round_trips - trips;
        eprintln!(
            "{method}: {made} device objects after 20 steps, {} after 120; the tables changed size on {resized} of the 100 steps, nodes changed side on {changes}",
            gpu.device_objects_made()
        );
        assert!(resized >= 10 && changes > 0, "{method}: the test must change the tables' sizes ({resized} steps) and the layout ({changes} steps)");
        // a table that outgrows its room (a bending flap makes more thin-wall taps than at rest)
        // gets a buffer with half as much again and the bind groups that hold it: at most two
        // such growths here, and none in the last 50 steps (each step made some fifteen
        // buffers and a bind group or more before, and new tables' buffers and every stage's
        // bind groups on each step the tables changed size)
        let running = gpu.device_objects_made() - made;
        assert!(running <= 4, "{method}: {running} device objects made in 100 steps");
        assert_eq!(gpu.device_objects_made(), half, "{method}: device objects made in the last 50 steps");
    }
}

/// Bodies' walls held isothermal (`coupling.wall_temperature_ratio`) on the GPU: the ghost
/// tables carry the wall temperature to the device's ghost fill, so the coupled step matches
/// the CPU's within method 2's bound — and the bound means something, because the walls at
/// 1.05 T₀ move the air far more than that from the adiabatic run's.
#[test]
fn isothermal_body_walls_on_the_gpu_match_the_cpu() {
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::scene::coupled::CoupledScene;
    let Some(ctx) = context() else { return };
    let warm = SMALL_FLAP.replace("kernel_radius = 1.0\n", "kernel_radius = 1.0\nwall_temperature_ratio = 1.05\n");
    let sc = CoupledScene::parse(&warm).unwrap();
    let steps = 200;
    let mut cpu = sc.build().unwrap();
    let mut gpu = GpuCoupled::new(ctx, sc.build().unwrap()).expect("method 2 runs on the GPU");
    let mut adiabatic = CoupledScene::parse(SMALL_FLAP).unwrap().build().unwrap();
    let x0 = cpu.solid.particles.position.clone();
    cpu.run(steps).unwrap();
    adiabatic.run(steps).unwrap();
    gpu.run(steps).unwrap();
    gpu.download_into();
    let p = CoupledParity::of(&cpu, &gpu, &x0);
    // the largest temperature difference from the adiabatic run, at nodes fluid in both, / θ₀
    let fluid = |c: &phonation::coupling::CoupledSolver, n: usize| c.fluid.layout.kind[n] == NodeKind::Fluid;
    let effect = (0..cpu.fluid.layout.grid.len())
        .filter(|&n| fluid(&cpu, n) && fluid(&adiabatic, n))
        .map(|n| (cpu.fluid.macro_at(n).theta - adiabatic.fluid.macro_at(n).theta).abs())
        .fold(0.0, f64::max)
        / cpu.units.theta0;
    eprintln!("isothermal walls, {steps} steps: {}; the walls' effect on θ/θ₀ {effect:.2e}", p.summary());
    p.assert_within(1e-4);
    assert!(effect > 100.0 * 1e-4, "the isothermal walls' effect {effect:e} must dwarf the parity bound");
}

/// Method 1 on the GPU: the fluid, the solid and the tractions (2.110–2.113, the traction
/// kernels) on the device, the surface polygons' walls and the traction's plan on the CPU. Over
/// 200 steps of the small flap the geometry agrees exactly (the same nodes uncovered and
/// covered), and the displacements and populations are held to 2e-4 of their scale (method 2's
/// bound is 1e-4, `coupled_steps_on_the_gpu_match_the_cpu_over_200_steps`; why, below), the air's
/// force on the flap to [`FORCE_OVER_POPULATIONS`] × the populations' difference.
#[test]
fn weak_coupled_steps_on_the_gpu_match_the_cpu() {
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::scene::coupled::CoupledScene;
    let Some(ctx) = context() else { return };
    let sc = CoupledScene::parse(&small_flap_weak()).unwrap();
    let steps = 200;
    let mut cpu = sc.build().unwrap();
    let mut gpu = GpuCoupled::new(ctx, sc.build().unwrap()).expect("method 1 runs on the GPU");
    let x0 = cpu.solid.particles.position.clone();
    cpu.run(steps).unwrap();
    gpu.run(steps).unwrap();
    gpu.download_into();
    let p = CoupledParity::of(&cpu, &gpu, &x0);
    eprintln!("method 1, {steps} steps: {}; {} population round trips; shares {:?}", p.summary(), gpu.round_trips, gpu.stage_shares());
    // 2e-4, twice method 2's bound: the flap is 1.2 cells thick, so the nodes under it read
    // side ghosts, which extrapolate the plate's wall (placed and moved by each backend's own
    // particles, f32 on the GPU) into the stencils of the second side too. Measured 1.2e-4 at
    // step 200, the worst node always a reader of side ghosts under the flap, in spikes (1.4e-4
    // at step 125, 6.9e-5 at 150) where a tap's geometry changes between steps; 5.4e-5 with the
    // one-sided stencils. The kernels themselves match to 3e-6 per stage with side ghosts
    // (`thin_walls_match_the_cpu`).
    p.assert_within(2e-4);
    assert_eq!(gpu.step_count(), steps);
    // the traction read its samples' nodes on the device (4 per sample, up to 16 beside a wall,
    // two samples per piece): fewer reads than the lattice has nodes, and none came back
    let per_step = gpu.traction_nodes as f64 / steps as f64;
    eprintln!("traction: {per_step:.0} stencil reads on the device per step ({} nodes)", gpu.fluid.n_nodes);
    assert!(per_step > 0.0 && per_step < 0.5 * gpu.fluid.n_nodes as f64, "{per_step}");
}

/// A coupled GPU step reads the fluid's instability flag with the next step's particles (one
/// trip) instead of after its fluid stage: a fluid made to fail in its first step (one node's
/// populations negated, a negative density) is still diagnosed as the fluid, at the node and the
/// step the CPU names — when the next step reads it (`run(3)` stops in its second step, before
/// the solid's values the bad air made) and when a run ends on the failing step (`run(1)` reads
/// the last step's flag before it returns). Both methods.
#[test]
fn a_coupled_gpu_step_diagnoses_its_fluid_one_read_later_at_the_step_it_failed() {
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::scene::coupled::CoupledScene;
    use phonation::step::{Part, Site};
    if context().is_none() {
        return;
    }
    for text in [small_flap_weak(), SMALL_FLAP.to_string()] {
        let sc = CoupledScene::parse(&text).unwrap();
        let mut cpu = sc.build().unwrap();
        let grid = cpu.fluid.layout.grid.clone();
        let node = grid.index([3, 3, 0]);
        assert_eq!(cpu.fluid.layout.kind[node], phonation::fluid::layout::NodeKind::Fluid);
        let bad: Vec<f64> = cpu.fluid.node_populations(node).iter().map(|v| -v).collect();
        cpu.fluid.set_node_populations(node, &bad);
        let cpu_err = cpu.clone().run(3).expect_err("a negative density fails the CPU's fluid");
        for n in [3, 1] {
            let mut gpu = GpuCoupled::new(context().unwrap(), cpu.clone()).unwrap();
            let e = gpu.run(n).expect_err("a negative density fails the GPU's fluid");
            eprintln!("{}: run({n}): {e}; CPU: {cpu_err}", sc.fluid.file.name);
            assert_eq!(e.part, Part::Fluid, "{e}");
            assert_eq!((e.quantity, cpu_err.quantity), ("density", "density"), "GPU {e} / CPU {cpu_err}");
            assert_eq!((e.step, cpu_err.step), (0, 0), "GPU {e} / CPU {cpu_err}");
            assert_eq!(e.time, 0.0);
            assert_eq!(e.site, cpu_err.site, "GPU {e} / CPU {cpu_err}");
            assert!(matches!(e.site, Site::Node(x) if (x[0] - 3).abs() <= 3 && (x[1] - 3).abs() <= 3), "{e}");
            assert_eq!(cpu_err.part, Part::Fluid, "{cpu_err}");
            // run(3) found it with step 1's particles (one step done); run(1) at its end
            assert_eq!(gpu.step_count(), 1, "run({n})");
        }
    }
}

/// The bench's coupled row times at least one step stage by stage, however few steps it runs:
/// a `bench --quick` of 5 steps met no multiple of `GpuCoupled::timing_every` (16) and printed
/// every stage's share as 0 %. Both methods on the small flap, 5 steps: the shares are finite,
/// non-negative, sum to 1, and the fluid's is not zero.
#[test]
fn the_bench_times_the_coupled_stages_of_a_short_run() {
    use phonation::scene::coupled::CoupledScene;
    if context().is_none() {
        return;
    }
    for text in [SMALL_FLAP.to_string(), small_flap_weak()] {
        let sc = CoupledScene::parse(&text).unwrap();
        let v = phonation::gpu::bench::coupled_speed("small flap", || sc.build().unwrap(), 5).unwrap();
        let sum: f64 = v.gpu_stage_shares.iter().map(|(_, s)| s).sum();
        eprintln!("{:?}: {:.2} steps/s", v.gpu_stage_shares, v.gpu_steps_per_s);
        assert!(v.gpu_stage_shares.iter().all(|(_, s)| s.is_finite() && *s >= 0.0), "{:?}", v.gpu_stage_shares);
        assert!((sum - 1.0).abs() < 1e-9, "shares sum to {sum}");
        let fluid = v.gpu_stage_shares.iter().find(|(n, _)| n == "fluid").map_or(0.0, |(_, s)| *s);
        assert!(fluid > 0.0, "the fluid stage was timed: {:?}", v.gpu_stage_shares);
        assert!(v.gpu_coupling_share >= 0.0 && v.gpu_coupling_share < 1.0);
        // the host's own work: the walls and the tables on every method, the traction's plan on
        // method 1's; each timed, together less than the whole step
        let weak = !text.contains("momentum_conserving");
        let names: Vec<&str> = v.gpu_host_work_s.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names.len(), if weak { 3 } else { 2 }, "{names:?}");
        assert!(v.gpu_host_work_s.iter().all(|(_, t)| *t > 0.0), "{:?}", v.gpu_host_work_s);
        let host: f64 = v.gpu_host_work_s.iter().map(|(_, t)| t).sum();
        assert!((v.gpu_host_ceiling_steps_per_s * host - 1.0).abs() < 1e-12);
        assert!(v.gpu_host_ceiling_steps_per_s > v.gpu_steps_per_s, "host {host} s a step, {} steps/s", v.gpu_steps_per_s);
    }
}
