//! What is drawn, made on the GPU against its CPU twin: marching cubes, the fold surface, the
//! slice and the tracers.

use crate::support::*;

/// Marching cubes on the GPU gives the CPU twin's triangles: the same count, the same cells,
/// vertices within f32 rounding, on a sphere and on the 2D glottis's folds (their level set as
/// the coupling sees it, as a slab). Bounds: a vertex is origin + h·(n₀ + s(n₁ − n₀)) evaluated
/// in f32, so it carries ~1e-7 of the largest coordinate plus h·1e-7 from s: 1e-5 of the
/// grid's extent bounds it; the normals come from f32 differences of the same f32 values: 1e-4.
#[test]
fn marching_cubes_matches_its_cpu_twin() {
    use phonation::gpu::marching_cubes::GpuMarchingCubes;
    use phonation::mesh::{ScalarGrid, extract};
    let Some(ctx) = context() else { return };
    let mc = GpuMarchingCubes::new(&ctx);
    let compare = |label: &str, grid: &ScalarGrid| {
        let cpu = extract(grid, 0.0);
        let n = cpu.triangles.len() as u32;
        let (gpu, count) = mc.extract(&ctx, grid, 0.0, n + 16);
        let extent = grid.origin.abs().max_element() + grid.spacing * *grid.dims.iter().max().unwrap() as f64;
        assert!(n > 100, "{label}: {n} triangles");
        assert_eq!(count, n, "{label}: triangle count");
        let (mut dp, mut dn) = (0f64, 0f64);
        for (t, g) in gpu.iter().enumerate() {
            assert_eq!((g.cell, g.rank), (cpu.cells[t], (t - cpu.cells.partition_point(|c| *c < g.cell)) as u32), "{label}: triangle {t}");
            let idx = cpu.triangles[t];
            for (k, &i) in idx.iter().enumerate() {
                dp = dp.max((g.positions[k] - cpu.positions[i as usize]).length());
                dn = dn.max((g.normals[k] - cpu.normals[i as usize]).length());
            }
        }
        eprintln!("{label}: {n} triangles, vertices within {:.2e} of the extent {extent}, normals within {dn:.2e}", dp / extent);
        assert!(dp < 1e-5 * extent && dn < 1e-4, "{label}: positions {dp:e}, normals {dn:e}");
        // too small a buffer: counted, not written past its end
        let (part, count) = mc.extract(&ctx, grid, 0.0, n / 2);
        assert_eq!((part.len() as u32, count), (n / 2, n), "{label}: overflow");
    };
    let c = DVec3::new(20.3, 19.6, 21.1);
    compare("sphere r = 14 at 40³", &ScalarGrid::sample([40; 3], DVec3::new(-0.5, 0.25, 0.0), 1.0, |x| 14.0 - (x - c).length()));
    let glottis = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("glottis_2d_c").unwrap()).unwrap().build().unwrap();
    for (k, set) in glottis.drawn_level_sets().iter().enumerate() {
        compare(&format!("glottis_2d_c fold {k}"), &phonation::mesh::particle_field::level_set_grid(set, 0.5, 2));
    }
}

/// The bodies' surfaces made wholly on the GPU (level set on the grid, then marching cubes,
/// every body into one set of buffers; what the plugin draws) match their CPU twins
/// (`particle_field::level_set_grid`, `extract`), body by body: the 2D glottis's two folds as
/// the coupling sees them, and a 3D solid beam. Bounds: L is a sum of ≤ ~40 terms
/// r_e/max(r, r_min) − 1, each ≤ 1, whose r is an f32 difference of coordinates ≤ ~130 cells
/// (rounding ~130 · 6e-8 ≈ 8e-6 cells, times |d(r_e/r)/dr| ≤ r_e/r_min² = 2/r_min ≤ 2 per
/// cell): ≤ 40 · 1.6e-5 ≈ 6e-4 if every term's error had the same sign; 1e-3 bounds it. A
/// vertex sits where the field crosses 0 along an edge: it moves by ΔL / |ΔL along the edge|
/// · h, and |ΔL| along an edge of h = ½ cell near the surface is ≥ ~0.1 (L rises by ~1 over r_e):
/// 1e-3 / 0.1 · h = 5e-3 cells bounds it; the normals (differences of the same values over 2h):
/// 5e-2. A node whose L is within 1e-3 of 0 may fall on the other side and change its cells'
/// cases: the triangle counts may then differ by a few; they are asserted equal where no node
/// is that close, and within 1 % otherwise.
#[test]
fn the_fold_surface_on_the_gpu_matches_its_cpu_twin() {
    use phonation::fluid::KernelLevelSet;
    use phonation::gpu::fold_surface::GpuFoldSurface;
    use phonation::gpu::marching_cubes::OwnedSurface;
    use phonation::mesh::extract;
    use phonation::mesh::particle_field::level_set_grid;
    let Some(ctx) = context() else { return };
    let gpu = GpuFoldSurface::new(&ctx.device);
    let compare = |label: &str, sets: &[KernelLevelSet], h: f64, dim: usize| {
        let capacity: u32 = sets.iter().map(|s| extract(&level_set_grid(s, h, dim), 0.0).triangles.len() as u32).sum::<u32>() + 64;
        let out = OwnedSurface::new(&ctx.device, capacity);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        gpu.record(&ctx.device, &mut enc, sets, h, dim, &out.buffers());
        ctx.queue.submit([enc.finish()]);
        let (tris, count) = out.download(&ctx);
        assert_eq!(count as usize, tris.len(), "{label}: all written");
        let mut total = 0;
        for (k, set) in sets.iter().enumerate() {
            let cpu_grid = level_set_grid(set, h, dim);
            let gpu_grid = gpu.level_set_grid(&ctx, set, h, dim);
            assert_eq!((gpu_grid.dims, gpu_grid.origin), (cpu_grid.dims, cpu_grid.origin), "{label} body {k}: grid");
            let dl = cpu_grid.values.iter().zip(&gpu_grid.values).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
            let close = cpu_grid.values.iter().filter(|v| v.abs() < 1e-3).count();
            let cpu = extract(&cpu_grid, 0.0);
            let mine: Vec<_> = tris.iter().filter(|t| t.body == k as u32).collect();
            total += mine.len();
            eprintln!(
                "{label} body {k}: {} nodes, L within {dl:.2e} ({close} nodes within 1e-3 of 0); triangles GPU {} / CPU {}",
                cpu_grid.values.len(),
                mine.len(),
                cpu.triangles.len()
            );
            assert!(dl < 1e-3, "{label} body {k}: L differs by {dl}");
            assert!(cpu.triangles.len() > 100, "{label} body {k}: {} triangles", cpu.triangles.len());
            if close > 0 {
                assert!((mine.len() as f64 / cpu.triangles.len() as f64 - 1.0).abs() < 0.01, "{label} body {k}: triangle counts");
                continue;
            }
            assert_eq!(mine.len(), cpu.triangles.len(), "{label} body {k}: triangle count");
            let (mut dp, mut dn) = (0f64, 0f64);
            for (t, g) in mine.iter().enumerate() {
                assert_eq!(g.cell, cpu.cells[t], "{label} body {k}: triangle {t}'s cell");
                for (v, &i) in cpu.triangles[t].iter().enumerate() {
                    dp = dp.max((g.positions[v] - cpu.positions[i as usize]).length());
                    dn = dn.max((g.normals[v] - cpu.normals[i as usize]).length());
                }
            }
            eprintln!("{label} body {k}: vertices within {dp:.2e} cells, normals within {dn:.2e}");
            assert!(dp < 5e-3 && dn < 5e-2, "{label} body {k}: positions {dp:e}, normals {dn:e}");
        }
        assert_eq!(total, tris.len(), "{label}: every triangle tagged with a body");
    };
    let glottis = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("glottis_2d_c").unwrap()).unwrap().build().unwrap();
    compare("glottis_2d_c", &glottis.drawn_level_sets(), 0.5, 2);
    let mut p = phonation::solid::Particles::new(3, 1.0);
    for x in phonation::solid::particles::sample_box(3, DVec3::ZERO, DVec3::new(12.0, 5.0, 4.0), 1.0) {
        p.push(x, 1.0, 0, 0, false);
    }
    compare("a 12 × 5 × 4 beam", &phonation::coupling::level_set::body_level_sets(&p), 1.0, 3);
}

/// The slice made on the device from a GPU fluid's macro buffer (values, range, colours) gives
/// the CPU's image (`output::fields::slice` + `png_map::rgba_top_down`: what the Bevy slice and
/// the PNG snapshots draw) for every field, on the coarse glottis after 60 coupled steps (the lung
/// pressure's front in the trachea; the folds grey), uploaded to the GPU. Bounds: the values are f32 (ρ, u, θ from the moments in f32: ~1e-7
/// relative); the gauge pressure (ρθ − θ₀) and the vorticity (differences of neighbours'
/// velocities) lose digits to cancellation, up to ~1e-7 · θ₀ / |p − θ₀| ≈ 1e-4 of the range
/// here; the colour of a value is its 8-bit truncation, so a value that close to a level's edge
/// may take the next level: every channel within 1 level, and the range within 1e-3 of its
/// width.
#[test]
fn the_slice_on_the_gpu_matches_its_cpu_twin() {
    use phonation::gpu::slice::GpuSlice;
    use phonation::output::fields::{plane_map, slice};
    use phonation::output::png_map::rgba_top_down;
    use phonation::scene::schema::Field;
    let Some(ctx) = context() else { return };
    let sc = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("glottis_2d_coarse").unwrap()).unwrap();
    let mut c = sc.build().unwrap();
    for _ in 0..60 {
        c.step().unwrap();
    }
    let gpu = GpuFluid::from_solver(&ctx, &c.fluid).unwrap();
    for field in [Field::Speed, Field::Pressure, Field::Vorticity, Field::Density, Field::Temperature] {
        let map = plane_map(field, &c.units);
        let s = GpuSlice::new(&ctx.device, &gpu, &c.fluid.layout.grid, map);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        s.record(&gpu, &mut enc);
        ctx.queue.submit([enc.finish()]);
        let (px, range) = s.download(&ctx);
        let (cpu_px, cpu_range) = rgba_top_down(&slice(&c.fluid, &c.units, field), map.signed);
        let width = cpu_range.1 - cpu_range.0;
        let dr = (range.0 - cpu_range.0).abs().max((range.1 - cpu_range.1).abs()) / width;
        let diff: Vec<i32> = px.iter().zip(&cpu_px).map(|(a, b)| (*a as i32 - *b as i32).abs()).collect();
        let off = diff.iter().filter(|d| **d > 0).count();
        let grey = cpu_px.chunks(4).filter(|p| p[..3] == [110, 110, 110]).count();
        eprintln!(
            "{field:?}: {}×{} pixels ({grey} grey), range GPU ({:.5e}, {:.5e}) CPU ({:.5e}, {:.5e}): {dr:.1e} of its width; {off} channels differ, by at most {}",
            s.size().0,
            s.size().1,
            range.0,
            range.1,
            cpu_range.0,
            cpu_range.1,
            diff.iter().max().unwrap()
        );
        assert_eq!(px.len(), cpu_px.len());
        assert!(grey > 100, "{field:?}: the folds grey");
        assert!(dr < 1e-3, "{field:?}: range {range:?} vs {cpu_range:?}");
        assert!(diff.iter().all(|d| *d <= 1), "{field:?}: a channel differs by more than one level");
    }
}

/// Tracers on the GPU follow the CPU twin over 250 steps through a real flow (the channel with
/// a cylinder after 200 steps, frozen), re-seeding included. Bounds: each step adds f32
/// rounding of ~1e-7 of the coordinates (≤ 40 cells: ~1e-5 cells per step with the
/// interpolation's rounding), which adds up over 250 steps to at most 2.5e-3 cells if every
/// step's error had the same sign and the flow did not spread them (it is smooth and mostly
/// parallel: measured 1.5e-4): 3e-3 cells for a tracer born as often on both; at most 1 % of
/// the tracers may be re-seeded at a different step (one within ~1e-5 cells of the domain's
/// edge or of the half-way point to a wall node can go either way).
#[test]
fn tracers_match_their_cpu_twin() {
    use phonation::fluid::tracers::{Tracers, VelocityField};
    use phonation::gpu::tracers::{FieldBuffers, GpuTracers};
    let Some(ctx) = context() else { return };
    let mut s = scene(false, GasModel::Monatomic);
    s.run(200).unwrap();
    let field = VelocityField::of(&s);
    let g = &s.layout.grid;
    let seed = (DVec3::new(1.0, 1.0, 0.0), DVec3::new(3.0, (g.n[1] - 2) as f64, 0.0));
    let mut cpu = Tracers::new(4000, seed);
    let buffers = FieldBuffers::upload(&ctx, &field);
    let mut gpu = GpuTracers::new(&ctx, &cpu, g, buffers.stride);
    // 250 steps of 4 units of lattice time: through the frozen field most tracers cross the
    // channel (40 cells) and are born again at the inlet
    let dt = 4.0;
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    gpu.record(&ctx, &mut enc, &buffers.mac, &buffers.kind, dt, 250);
    ctx.queue.submit([enc.finish()]);
    for _ in 0..250 {
        cpu.advect(&field, dt);
    }
    let (pos, generation, reseeded) = gpu.download(&ctx);
    let differ = generation.iter().zip(&cpu.generation).filter(|(a, b)| a != b).count();
    let same: Vec<f64> =
        pos.iter().zip(&cpu.positions).zip(generation.iter().zip(&cpu.generation)).filter(|(_, (a, b))| a == b).map(|((p, q), _)| (*p - *q).length()).collect();
    let worst = same.iter().copied().fold(0.0, f64::max);
    let moved = cpu.positions.iter().zip(Tracers::new(4000, seed).positions).map(|(a, b)| (*a - b).length()).fold(0.0, f64::max);
    eprintln!(
        "tracers: {} re-seeded on the CPU, {reseeded} on the GPU; {differ} differ in generation; others within {worst:.2e} cells (moved up to {moved:.1})",
        cpu.reseeded
    );
    assert!(moved > 2.0 && cpu.reseeded > 1000, "the tracers must move through the flow and be born again");
    assert!(differ <= 40 && worst < 3e-3, "{differ} generations differ, {worst:e} cells");
    assert_eq!(reseeded as u64, generation.iter().map(|g| *g as u64).sum::<u64>());
}
