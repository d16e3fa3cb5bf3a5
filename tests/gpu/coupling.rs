//! The coupling on the GPU against the CPU: its kernels, whole coupled steps of both methods,
//! towed bodies, changes of layout, the objects a running step makes, isothermal walls, the
//! instability diagnosis, the traction kernels and the bench's stage timings.

use crate::support::*;

/// Method 2's coupling kernels (shaders/coupling.wgsl) against their CPU twins: the level set,
/// its gradient and the wall velocity at query points (2.124–2.126, 2.130), and the hand-over of
/// the wall nodes' momentum to the particles (2.127–2.128) — on random inputs (a jittered disc of
/// particles with random velocities, random wall momenta near it; then a second disc beside it,
/// the nodes between them sharing their momentum over both bodies' sets) and on the built-in scene
/// `fsi_cylinder_conserving` after five coupled steps.
#[test]
fn coupling_kernels_match_their_cpu_twins() {
    use glam::{DVec3, DVec4};
    use phonation::fluid::KernelLevelSet;
    use phonation::gpu::coupling::CouplingKernels;
    use phonation::stages::CoupledStageKind;
    let Some(ctx) = context() else { return };
    let kernels = CouplingKernels::new(&ctx);
    let mut rand = uniform_stream(0x2545_f491_4f6c_dd1d);
    // f32 sums of up to ~60 kernel terms that partly cancel: each quantity is compared relative
    // to the sum of its terms' magnitudes (L: φ + Σw; ∇L: Σ r_e/r²; the wall velocity: the
    // fastest particle's speed). The positions go to the GPU in f32: ~30 cells from the origin
    // they carry ~2e-6 cells of rounding, so a gradient term at r ≈ 0.2 cells (r_e/r² ≈ 50) is
    // off by 3·(4e-6)/0.2 ≈ 6e-5 of itself: 1e-4 bounds ∇L; L and the wall velocity, whose
    // terms scale as 1/r, get 2e-5.
    let compare = |label: &str, set: &KernelLevelSet, queries: &[[f64; 3]]| {
        let gpu = kernels.level_set_at(&ctx, set, queries);
        let (mut dl, mut dg, mut dv) = (0f64, 0f64, 0f64);
        let mut inside = 0;
        let v_max = set.velocities().iter().map(|v| DVec3::from_array(*v).length()).fold(1e-12, f64::max);
        for (q, (l, g, v, sw)) in queries.iter().zip(&gpu) {
            let (l_cpu, g_cpu) = set.level(*q);
            let v_cpu = DVec3::from_array(set.velocity_at(*q));
            let scale = 1.0 + set.phi + sw;
            dl = dl.max((l - l_cpu).abs() / scale);
            // |d(r_e/r)/dr| = r_e/r² = (w + 1)²/r_e
            let gs: f64 = 1.0 + set.weights(*q).map(|(_, w)| (w + 1.0) * (w + 1.0) / set.re).sum::<f64>();
            dg = dg.max((*g - DVec3::from_array(g_cpu)).length() / gs);
            dv = dv.max((*v - v_cpu).length() / v_max);
            inside += (l_cpu > 0.0) as usize;
        }
        eprintln!("{label}: {} queries ({inside} inside): L {dl:.2e}, ∇L {dg:.2e}, wall velocity {dv:.2e}", queries.len());
        assert!(inside > 0 && inside < queries.len(), "{label}: the queries must straddle the surface");
        assert!(dl < 2e-5 && dg < 1e-4 && dv < 2e-5, "{label}: L {dl:e} ∇L {dg:e} v {dv:e}");
    };
    let exchange = |label: &str, set: &KernelLevelSet, grid: &phonation::fluid::Grid, wall: &[DVec4], factor: f64, cpu: &[DVec3]| {
        let gpu = kernels.momentum_to_particles(&ctx, set, grid, wall, factor);
        let scale = cpu.iter().map(|f| f.length()).fold(0.0, f64::max);
        let d = gpu.iter().zip(cpu).map(|(g, c)| (*g - *c).length()).fold(0.0, f64::max) / scale;
        let (sg, sc) = (gpu.iter().sum::<DVec3>(), cpu.iter().sum::<DVec3>());
        eprintln!("{label}: {} particles, force {d:.2e} of the largest; total {sg:?} vs {sc:?}", cpu.len());
        assert!(scale > 0.0, "{label}: no force to compare");
        assert!(d < 1e-5, "{label}: {d:e}");
    };

    // A disc of `radius` cells at `c` (2D): particles 0.5 apart jittered by ±0.1 with random
    // velocities (points, velocities).
    fn jittered_disc(rand: &mut dyn FnMut() -> f64, c: [f64; 3], radius: f64) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let m = (2.0 * radius) as i32 + 2;
        let (mut pts, mut vel) = (Vec::new(), Vec::new());
        for i in -m..=m {
            for j in -m..=m {
                let p = [c[0] + 0.5 * i as f64 + 0.2 * (rand() - 0.5), c[1] + 0.5 * j as f64 + 0.2 * (rand() - 0.5), 0.0];
                if (p[0] - c[0]).hypot(p[1] - c[1]) <= radius {
                    pts.push(p);
                    vel.push([rand() - 0.5, rand() - 0.5, 0.0]);
                }
            }
        }
        (pts, vel)
    }
    // Random inputs: a disc of radius 6 cells at (20.3, 17.6).
    let (c0, radius) = ([20.3, 17.6, 0.0], 6.0);
    let (pts, vel) = jittered_disc(&mut rand, c0, radius);
    let set = KernelLevelSet::new(pts.clone(), vel, 2.0, 0.125, 40.0);
    let queries: Vec<[f64; 3]> = (0..2000).map(|_| [c0[0] + 20.0 * (rand() - 0.5), c0[1] + 20.0 * (rand() - 0.5), 0.0]).collect();
    compare("random disc", &set, &queries);
    let grid = phonation::fluid::Grid::new(2, [40, 36, 1]);
    let mut wall = vec![DVec4::ZERO; grid.len()];
    let mut cpu = vec![DVec3::ZERO; pts.len()];
    let factor = 0.37;
    // the run sums of the exchange (walls without particles, mass, wall frame) and their scale
    let (mut walls, mut mass, mut frame, mut scale) = (DVec3::ZERO, 0.0, DVec3::ZERO, 0.0);
    for (node, w) in wall.iter_mut().enumerate() {
        let x = grid.coords(node);
        let at = [x[0] as f64, x[1] as f64, 0.0];
        let r = (at[0] - c0[0]).hypot(at[1] - c0[1]);
        if (r - radius).abs() < 2.5 && rand() < 0.8 {
            *w = DVec4::new(rand() - 0.5, rand() - 0.5, 0.0, rand() - 0.5);
            // the CPU twin's rule (coupling::conserving::momentum_exchange), written out
            let ws: Vec<(usize, f64)> = set.weights(at).collect();
            let sum: f64 = ws.iter().map(|(_, x)| x).sum();
            let uw = DVec3::from_array(set.velocity_at(at));
            if sum > 0.0 {
                for (j, wj) in ws {
                    cpu[j] += (wj / sum) * w.truncate() * factor;
                }
            } else {
                walls += w.truncate();
            }
            mass += w.w;
            frame += w.truncate() - uw * w.w;
            scale += w.length();
        }
    }
    assert!(walls != DVec3::ZERO, "some wall nodes must have no particle within r_e");
    exchange("random wall momenta", &set, &grid, &wall, factor, &cpu);
    // The same momenta with a part booked as node changes (every third wall node's in two
    // halves, one node listed twice) added on the device to a resident buffer that holds the
    // rest: the same forces, and the buffer comes back cleared for the next step.
    {
        use wgpu::util::DeviceExt;
        let mut resident = wall.clone();
        let mut changes = Vec::new();
        for (node, w) in resident.iter_mut().enumerate().filter(|(_, w)| **w != DVec4::ZERO).step_by(3) {
            changes.push((node, 0.5 * *w));
            changes.push((node, *w - 0.5 * *w));
            *w = DVec4::ZERO;
        }
        assert!(changes.len() > 20, "{} node changes", changes.len());
        let w32: Vec<[f32; 4]> = resident.iter().map(|v| v.as_vec4().to_array()).collect();
        let buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("resident wall"),
            contents: bytemuck::cast_slice(&w32),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        });
        let (gpu, diag) = kernels.hand_over(&ctx, &[&set], &grid, &buffer, &changes, factor);
        let force_scale = cpu.iter().map(|f| f.length()).fold(0.0, f64::max);
        let d = gpu.iter().zip(&cpu).map(|(g, c)| (*g - *c).length()).fold(0.0, f64::max) / force_scale;
        // the run sums: f32 sums of ~250 terms of size ≤ 1 against f64, relative to Σ|term|
        let dd = [(diag.walls - walls).length(), (diag.mass - mass).abs(), (diag.wall_frame - frame).length()].map(|x| x / scale);
        eprintln!(
            "random wall momenta, {} as node changes on the device: force {d:.2e} of the largest; run sums walls {:?} vs {walls:?}, mass {} vs {mass}, wall frame {:?} vs {frame:?}: {:?} of Σ|term| = {scale:.1}",
            changes.len(),
            diag.walls,
            diag.mass,
            diag.wall_frame,
            dd.map(|x| format!("{x:.2e}"))
        );
        assert!(d < 1e-5, "{d:e}");
        assert!(dd.iter().all(|x| *x < 1e-6), "run sums {dd:?}");
        let after: Vec<f32> = bytemuck::cast_slice(&phonation::gpu::context::read_buffer(&ctx.device, &ctx.queue, &buffer)).to_vec();
        assert!(after.iter().all(|x| *x == 0.0), "the wall buffer is cleared after the hand-over");
    }

    // Two bodies side by side (a second disc of radius 4 cells 0.6 cells from the first): a node
    // between them has particles of both within r_e, and its momentum is shared over both sets'
    // weights at once, set after set, as the CPU's stage does (conserving::momentum_exchange).
    {
        use wgpu::util::DeviceExt;
        let (c1, r1) = ([c0[0] + radius + 0.6 + 4.0, c0[1] + 0.7, 0.0], 4.0);
        let (pts1, vel1) = jittered_disc(&mut rand, c1, r1);
        let second = KernelLevelSet::new(pts1, vel1, 2.0, 0.125, 0.0);
        let grid = phonation::fluid::Grid::new(2, [48, 36, 1]);
        let sets = [&set, &second];
        let mut wall = vec![DVec4::ZERO; grid.len()];
        let mut cpu = vec![DVec3::ZERO; set.points.len() + second.points.len()];
        let mut shared = 0;
        for (node, w) in wall.iter_mut().enumerate() {
            let x = grid.coords(node);
            let at = [x[0] as f64, x[1] as f64, 0.0];
            let near = |c: [f64; 3], r: f64| ((at[0] - c[0]).hypot(at[1] - c[1]) - r).abs() < 2.5;
            if (near(c0, radius) || near(c1, r1)) && rand() < 0.8 {
                *w = DVec4::new(rand() - 0.5, rand() - 0.5, 0.0, rand() - 0.5);
                let ws: Vec<(usize, f64)> = set.weights(at).chain(second.weights(at).map(|(j, x)| (set.points.len() + j, x))).collect();
                let sum: f64 = ws.iter().map(|(_, x)| x).sum();
                shared += (set.weights(at).next().is_some() && second.weights(at).next().is_some()) as usize;
                if sum > 0.0 {
                    for (j, wj) in ws {
                        cpu[j] += (wj / sum) * w.truncate() * factor;
                    }
                }
            }
        }
        assert!(shared > 10, "{shared} nodes with particles of both bodies within r_e");
        let w32: Vec<[f32; 4]> = wall.iter().map(|v| v.as_vec4().to_array()).collect();
        let buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("two bodies' wall"),
            contents: bytemuck::cast_slice(&w32),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        });
        let (gpu, _) = kernels.hand_over(&ctx, &sets, &grid, &buffer, &[], factor);
        assert_eq!(gpu.len(), cpu.len(), "one force per point of either set");
        let scale = cpu.iter().map(|f| f.length()).fold(0.0, f64::max);
        let d = gpu.iter().zip(&cpu).map(|(g, c)| (*g - *c).length()).fold(0.0, f64::max) / scale;
        let second_total: DVec3 = gpu[set.points.len()..].iter().sum();
        eprintln!("two bodies, {shared} nodes shared: force {d:.2e} of the largest; the second body's total {second_total:?}");
        assert!(second_total.length() > 0.01 * scale, "the second body takes its share");
        assert!(d < 1e-5, "two bodies: {d:e}");
    }

    // The built-in scene: a clamped elastic cylinder in the Schäfer–Turek channel, method 2.
    let sc = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("fsi_cylinder_conserving").unwrap()).unwrap();
    let mut c = sc.build().unwrap();
    c.run(5).unwrap();
    for st in c.stages() {
        if st.kind == CoupledStageKind::MomentumExchange {
            break;
        }
        c.run_stage(st.kind).unwrap();
    }
    let ex = c.exchange().expect("method 2");
    let (set, wall) = (ex.sets()[0].clone(), ex.wall().to_vec());
    let grid = c.fluid.layout.grid.clone();
    let nodes: Vec<[f64; 3]> = (0..grid.len())
        .filter_map(|n| {
            let x = grid.coords(n);
            let p = [x[0] as f64, x[1] as f64, 0.0];
            (set.level(p).0 > -set.phi).then_some(p)
        })
        .collect();
    compare("fsi_cylinder_conserving, nodes within r_e of a particle", &set, &nodes);
    let factor = c.momentum_unit() / c.dt();
    c.run_stage(CoupledStageKind::MomentumExchange).unwrap();
    let members: Vec<usize> = (0..c.solid.particles.len()).filter(|&i| c.solid.particles.body[i] == 0).collect();
    let cpu: Vec<DVec3> = members.iter().map(|&i| c.forces.force[i]).collect();
    exchange("fsi_cylinder_conserving, one step's wall momenta", &set, &grid, &wall, factor, &cpu);
}

/// Method 2's level-set questions on the device (shaders/level_set_queries.wgsl, f64) against
/// their CPU twins: each node's side and distance (`KernelLevelSet::outside_distance`) on every
/// node of a box around the body reaching past its bins, and each ghost's wall point
/// (`KernelLevelSet::ghost_wall`), on the ghosts of thick bodies (a disc of radius 6 cells
/// and a ball of radius 4, particles 0.4 cells apart jittered by ±0.08, r_e = 1 cell: the coarse
/// 3D glottis's kernel over a body many kernels thick, where Newton's steps, the search away
/// from the body's mass and the search toward the fluid node all decide some ghosts) and of a
/// thin one (a plate 0.8 cells thick). The kernel writes the CPU's operations in the CPU's
/// order; only a driver's contraction of a product and a sum can part them, so each distance is
/// held to the CPU's own definition of it, the searches' bracket width (1e-9 cells), and each
/// normal to the same: a ghost whose wall came from another candidate (Newton's instead of a
/// search's) would be off by far more. Every node must fall on the CPU's side, and its distance
/// (one sum, −L/|∇L|) agree to 1e-12 of itself. Each ghost's wall velocity (2.130, the
/// particles' velocities — random in [−1, 1]³ here, the roughest field a body can carry —
/// averaged with their kernel weights at the wall point) is held to 1e-8: the weights are
/// continuous in the wall point (w = 0 at r = r_e, clamped at r_min) with |∂w/∂r| = r_e/r² ≤ 4
/// per cell, so over the ≲ 30 particles within r_e the mean moves by ≲ 10² per cell of wall
/// point, and the wall points agree to the 1e-9 above and by far less in practice; a velocity
/// summed over other particles, or from the wrong point, would be off by O(1).
#[test]
fn level_set_queries_on_the_device_match_the_cpu() {
    use phonation::fluid::KernelLevelSet;
    use phonation::gpu::level_set_queries::LevelSetKernels;
    let Some(ctx) = context() else { return };
    let Some(kernel) = LevelSetKernels::new(&ctx) else {
        eprintln!("{}: no f64 in shaders, the level sets' questions stay on the CPU", ctx.describe());
        return;
    };
    let mut rand = uniform_stream(0x9e37_79b9_7f4a_7c15);
    // particles 0.4 cells apart inside `inside` (relative to the centre), jittered
    let mut body = |dim: usize, centre: [f64; 3], reach: f64, inside: &dyn Fn([f64; 3]) -> bool| {
        let m = (reach / 0.4).ceil() as i64 + 1;
        let mut pts = Vec::new();
        for k in if dim == 3 { -m..=m } else { 0..=0 } {
            for j in -m..=m {
                for i in -m..=m {
                    let x = [i as f64 * 0.4, j as f64 * 0.4, k as f64 * 0.4];
                    if inside(x) {
                        let jit = |r: f64| 0.16 * (r - 0.5);
                        let z = if dim == 3 { centre[2] + x[2] + jit(rand()) } else { 0.0 };
                        pts.push([centre[0] + x[0] + jit(rand()), centre[1] + x[1] + jit(rand()), z]);
                    }
                }
            }
        }
        let vel: Vec<[f64; 3]> = (0..pts.len()).map(|_| [2.0 * rand() - 1.0, 2.0 * rand() - 1.0, 2.0 * rand() - 1.0]).collect();
        let mut s = KernelLevelSet::new(pts, vel, 1.0, 0.5, 0.0);
        s.phi = 0.5 * s.level(centre).0;
        s
    };
    let disc = body(2, [40.3, 37.6, 0.0], 6.0, &|x| x[0] * x[0] + x[1] * x[1] <= 36.0);
    let ball = body(3, [30.2, 28.7, 26.1], 4.0, &|x| x[0] * x[0] + x[1] * x[1] + x[2] * x[2] <= 16.0);
    let plate = body(2, [30.5, 20.2, 0.0], 12.0, &|x| x[0].abs() <= 12.0 && x[1].abs() <= 0.4);
    for (label, set, dim, c, reach) in
        [("disc", &disc, 2, [40.3, 37.6, 0.0], 6.0), ("ball", &ball, 3, [30.2, 28.7, 26.1], 4.0), ("plate", &plate, 2, [30.5, 20.2, 0.0], 12.0)]
    {
        // every node of the box of the ghosts' search, 2 cells wider than the body's bins
        let r = f64::ceil(reach) as i64 + 4;
        let zs = if dim == 3 { c[2] as i64 - r..=c[2] as i64 + r } else { 0..=0 };
        let nodes: Vec<[f64; 3]> = zs
            .flat_map(|z| {
                (c[1] as i64 - r..=c[1] as i64 + r).flat_map(move |y| (c[0] as i64 - r..=c[0] as i64 + r).map(move |x| [x as f64, y as f64, z as f64]))
            })
            .collect();
        let sides = kernel.try_outside_distances(0, set, &nodes).expect("the device answers");
        let (mut inside, mut dside) = (0, 0f64);
        for (p, d) in nodes.iter().zip(&sides) {
            let cpu = set.outside_distance(*p);
            assert_eq!(d.is_none(), cpu.is_none(), "{label}: the side of {p:?}");
            inside += d.is_none() as usize;
            if let (Some(a), Some(b)) = (d, cpu) {
                dside = dside.max((a - b).abs() / b.abs().max(1.0));
            }
        }
        eprintln!("{label}: {} nodes ({inside} inside): distance {dside:.2e} of itself", nodes.len());
        assert!(inside > 20 && inside < nodes.len() / 2, "{label}: {inside} of {} nodes inside", nodes.len());
        assert!(dside <= 1e-12, "{label}: outside distance {dside:e}");
        let r = f64::ceil(reach) as i64 + 2;
        let (lo, hi) = (c.map(|x| x as i64 - r), c.map(|x| x as i64 + r));
        let flat = |mut b: [i64; 3]| {
            if dim == 2 {
                b[2] = 0;
            }
            b
        };
        let queries = phonation::fluid::fixtures::level_set_ghosts(set, dim, flat(lo), flat(hi));
        let gpu = kernel.try_ghost_walls(0, set, &queries).expect("the device answers");
        let (mut dd, mut dn, mut dv, mut deep, mut moving) = (0f64, 0f64, 0f64, 0, 0);
        for (&(p, q), w) in queries.iter().zip(&gpu) {
            let (dc, nc) = set.ghost_wall(p, q);
            let vc = set.velocity_at(phonation::fluid::wall_point(p, dc, nc));
            dd = dd.max((w.distance - dc).abs());
            dn = dn.max((0..3).map(|a| (w.normal[a] - nc[a]).abs()).fold(0.0, f64::max));
            dv = dv.max((0..3).map(|a| (w.velocity[a] - vc[a]).abs()).fold(0.0, f64::max));
            deep += (dc < -1.0) as usize;
            moving += (vc.iter().map(|x| x.abs()).fold(0.0, f64::max) > 1e-3) as usize;
            assert!(w.distance.is_finite() && w.distance < 0.0, "{label}: a ghost at {p:?} is inside: {}", w.distance);
        }
        eprintln!(
            "{label}: {} ghosts ({deep} deeper than a cell, {moving} with a wall velocity): distance {dd:.2e} cells, normal {dn:.2e}, velocity {dv:.2e}",
            queries.len()
        );
        assert!(queries.len() > 20, "{label}: {} ghosts", queries.len());
        assert!(moving > queries.len() / 2, "{label}: {moving} of {} walls move", queries.len());
        assert!(dd <= 1e-9 && dn <= 1e-9, "{label}: distance {dd:e}, normal {dn:e}");
        assert!(dv <= 1e-8, "{label}: wall velocity {dv:e}");
    }
    // each body's bins sent once for its two questions
    let w = kernel.work();
    assert_eq!((w.calls, w.bins_sent, w.failed), (6, 3, 0));
}

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

/// The traction kernels (`GpuFluid::surface_traction`: the moments at the samples' stencil
/// nodes, each piece's force, the spread to the particles' loads) against their CPU twin
/// `surface_forces`, both models, on the small flap after 40 CPU steps (a developed flow, the flap
/// bent) with every population perturbed by a pseudo-random factor 1 ± 10⁻³ (random inputs): the
/// loads in the solid's load buffer are the scene's plus the air's, and the pieces' forces
/// brought back give the CPU's per-particle forces and the flap's total.
///
/// The bound, 2·10⁻⁵ of the largest particle force (measured on lavapipe: 4.8·10⁻⁶ for the loads
/// and the spread forces, 2.3·10⁻⁷ for the flap's total): the wall pressure is a gauge pressure
/// 2p(1) − p(2) − p₀ of pressures ≈ p₀ = 0.6 made in f32 (ε = 6·10⁻⁸ of p₀ per rounding, a few
/// roundings per sample), against gauge pressures of ~10⁻² p₀ here: a few 10⁻⁶ of a piece's
/// force; the bound leaves 4× for another adapter's rounding (fused multiply-adds or not).
#[test]
fn the_traction_kernels_match_their_cpu_twin() {
    use phonation::coupling::Method;
    use phonation::coupling::traction::{TractionModel, surface_forces};
    use phonation::gpu::coupled::GpuCoupled;
    use phonation::gpu::solid::SolidArray;
    use phonation::scene::coupled::CoupledScene;
    let Some(ctx) = context() else { return };
    let sc = CoupledScene::parse(&small_flap_weak()).unwrap();
    let mut cpu = sc.build().unwrap();
    cpu.run(40).unwrap();
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for f in cpu.fluid.f.iter_mut() {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        *f *= 1.0 + 1e-3 * ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0;
    }
    let Method::Weak(o) = cpu.method else { panic!("the weak flap") };
    let mut gpu = GpuCoupled::new(ctx, cpu.clone()).unwrap();
    for model in [TractionModel::PressureAndShear, TractionModel::SeedPressure] {
        let o = phonation::coupling::WeakOptions { traction: model, ..o };
        let plan = cpu.traction_plan(o);
        let reference = surface_forces(&cpu.fluid, &cpu.units, cpu.bodies.iter().map(|b| &b.surface), &cpu.solid.particles, model, o.piece_length);
        gpu.fluid.surface_traction(&plan, cpu.base_loads(), gpu.solid.load_buffer());
        let loads = gpu.solid.download_vectors(SolidArray::Load);
        let scale = reference.force.iter().map(|f| f.length()).fold(0.0, f64::max);
        let load_err = (0..loads.len()).map(|i| (loads[i] - cpu.base_loads()[i] - reference.force[i]).length()).fold(0.0, f64::max) / scale;
        let forces = plan.forces(&gpu.fluid.download_piece_forces().expect("the pieces' forces come back"));
        let force_err = forces.force.iter().zip(&reference.force).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max) / scale;
        let total_err = (forces.total[0] - reference.total[0]).length() / reference.total[0].length();
        eprintln!(
            "{model:?}: {} pieces ({} without fluid), {} particles loaded; largest particle force {scale:.4e}; loads within {load_err:.2e}, \
             forces {force_err:.2e}, total {:?} vs {:?} ({total_err:.2e})",
            plan.pieces.len(),
            plan.pieces_without_fluid,
            plan.targets.len(),
            forces.total[0],
            reference.total[0]
        );
        assert!(scale > 0.0 && plan.pieces.len() > 50);
        assert_eq!((forces.pieces, forces.pieces_without_fluid), (reference.pieces, reference.pieces_without_fluid));
        assert!(load_err < 2e-5, "{model:?}: loads {load_err:e}");
        assert!(force_err < 2e-5, "{model:?}: forces {force_err:e}");
        assert!(total_err < 2e-5, "{model:?}: total {total_err:e}");
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
