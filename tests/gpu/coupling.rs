//! The coupling's kernels on the GPU against their CPU twins: method 2's level set, wall
//! velocity and hand-over, the level-set questions the layout asks (f64), and method 1's
//! traction kernels. Whole coupled steps are in `coupled_steps`.

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
