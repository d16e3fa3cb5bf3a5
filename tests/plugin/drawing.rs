//! What a person sees, rendered headless: the lattice gas's slice, the glottis with folds,
//! tracers and slice, the fold mesh made on the GPU and the GPU tracers.

use crate::support::*;

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
