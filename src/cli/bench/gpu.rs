//! The device's tables of `phonation bench` (`--backend gpu` or `both`), each against the CPU's
//! rates measured in the same process where there are some, and the drawing kernels'.

use super::cpu::CpuRates;
use super::{lattice_gas_header, lattice_gas_row, percent, solid_row, stages};
use phonation::gpu::GpuContext;

/// What the GPU suites measure (`only`: the one suite asked for, all when `None`).
pub struct GpuRun<'a> {
    pub quick: bool,
    pub only: Option<&'a str>,
    pub cpu: &'a CpuRates,
}

impl GpuRun<'_> {
    /// Whether `suite` was asked for.
    fn wants(&self, suite: &str) -> bool {
        self.only.is_none_or(|o| o == suite)
    }
}

/// The drawing kernels (marching cubes, tracers, the glottis's fold surface): their CPU twins
/// and, with `ctx`, the device's, measured in this process.
pub fn drawing(ctx: Option<&GpuContext>, quick: bool) -> anyhow::Result<serde_json::Value> {
    let (n, tracers) = if quick { (48, 20_000) } else { (128, 100_000) };
    let mut rows = phonation::gpu::bench::drawing_speed(ctx, n, tracers);
    // the glottis's folds as the plugin draws them
    let glottis = phonation::scene::coupled::CoupledScene::parse(phonation::scene::builtin("glottis_2d_c").expect("a built-in scene"))?.build()?;
    let source = phonation::run::surface::SurfaceSource::coupled(&glottis);
    rows.push(phonation::gpu::bench::fold_surface_speed(ctx, "glottis_2d_c", &source.sets, source.spacing, source.dim));
    println!("drawing kernels (CPU twin serial{}):", ctx.map(|c| format!("; GPU {}", c.describe())).unwrap_or_default());
    println!("{:>26} {:>8} {:>14} {:>14} {:>10} {:>10}", "kernel", "size", "CPU /s", "GPU /s", "GPU/CPU", "triangles");
    for r in &rows {
        println!(
            "{:>26} {:>8} {:>14.3e} {:>14} {:>10} {:>10}",
            r.kernel,
            r.size,
            r.cpu_per_s,
            r.gpu_per_s.map(|g| format!("{g:.3e}")).unwrap_or("-".into()),
            r.gpu_per_s.map(|g| format!("{:.1}×", g / r.cpu_per_s)).unwrap_or("-".into()),
            r.triangles.map(|t| t.to_string()).unwrap_or_default()
        );
    }
    Ok(serde_json::to_value(&rows)?)
}

/// Every GPU suite `run` asks for on a fresh device context, printed; the report's "gpu" entry.
pub fn measure(run: &GpuRun) -> anyhow::Result<serde_json::Value> {
    let ctx = GpuContext::new()?;
    let bw = phonation::gpu::bench::copy_bandwidth(&ctx, if run.quick { 64 << 20 } else { 1 << 30 }, 10);
    println!("GPU: {}, copy-kernel bandwidth {:.2} GB/s", ctx.describe(), bw / 1e9);
    let lattices = fdlb(&ctx, run, bw);
    let solid = solid(&ctx, run, bw);
    let (lattice_gas, lattice_gas_readback) = lattice_gas(&ctx, run, bw);
    let coupled = coupled(run)?;
    let (scaling, scaling_skipped) = if run.only == Some("scaling") { scaling_table(&ctx, run.quick, bw) } else { (Vec::new(), Vec::new()) };
    Ok(
        serde_json::json!({ "adapter": ctx.describe(), "copy_bandwidth_gb_s": bw / 1e9, "lattices": lattices, "solid": solid, "lattice_gas": lattice_gas, "lattice_gas_readback": lattice_gas_readback, "coupled": coupled, "scaling": scaling, "scaling_skipped": scaling_skipped }),
    )
}

/// The FDLB on the device against the copy kernel's bandwidth `bw` and the CPU's rate.
fn fdlb(ctx: &GpuContext, run: &GpuRun, bw: f64) -> Vec<phonation::bench::LatticeSpeed> {
    use phonation::fluid::VelocitySetKind::{D2q21, D3q39};
    let sizes: Vec<(phonation::fluid::VelocitySetKind, [usize; 3])> = if !run.wants("fdlb") {
        vec![]
    } else if run.quick {
        vec![(D2q21, [256, 256, 1]), (D3q39, [32, 32, 32])]
    } else {
        vec![
            (D2q21, [1024, 1024, 1]),
            (D3q39, [128, 128, 128]),
            (D3q39, [64, 64, 64]),
            // issue 16 asks for 128³ and 256³ (2.6 GB per population array in f32; reported as
            // skipped where the device's buffers are smaller)
            (D3q39, [256, 256, 256]),
        ]
    };
    let mut gpu = Vec::new();
    for (set, n) in sizes {
        let l = phonation::gpu::bench::lattice_speed(ctx, set, n, if run.quick { 5 } else { 20 }, bw);
        match &l.skipped {
            Some(why) => println!("{:8} {:>16} skipped: {why}", l.lattice, format!("{:?}", l.nodes)),
            None => {
                let vs_cpu = run
                    .cpu
                    .lattices
                    .iter()
                    .find(|(n, _)| *n == l.lattice)
                    .map(|(_, c)| format!("  {:.2}× the CPU backend", l.node_updates_per_s / c))
                    .unwrap_or_default();
                println!(
                    "{:8} {:>16} {:>16.3e} {:>10.0} {:>10}{vs_cpu}",
                    l.lattice,
                    format!("{:?}", l.nodes),
                    l.node_updates_per_s,
                    l.bytes_per_node_update,
                    percent(l.bandwidth_fraction)
                );
                if !l.stage_fractions.is_empty() {
                    println!("         GPU stages (timestamps): {}", stages(&l.stage_fractions));
                }
                if let Some(r) = &l.readback {
                    println!(
                        "         a probe sample: whole state back {:.3e} s ({:.2e} steps), {} nodes gathered {:.3e} s ({:.2e} steps)",
                        r.whole_s, r.whole_steps, r.nodes, r.gathered_s, r.gathered_steps
                    );
                }
            }
        }
        gpu.push(l);
    }
    gpu
}

/// The explicit and implicit solid on the device (the implicit with the patches, the default,
/// and with block Jacobi: the smoother's gain on the device, method against method in one
/// process), against the CPU's default.
fn solid(ctx: &GpuContext, run: &GpuRun, bw: f64) -> Vec<phonation::solid::bench::SolidSpeed> {
    use phonation::solid::{Integrator, Preconditioner};
    let mut rows = Vec::new();
    if !run.wants("solid") {
        return rows;
    }
    println!("GPU MPS solid:");
    let quick = run.quick;
    for side in if quick { vec![20usize] } else { vec![46, 100] } {
        let implicit_steps = if quick { 2 } else { 5 };
        for (integ, pre, steps) in [
            (Integrator::Explicit, Preconditioner::Patches, if quick { 10 } else { 50 }),
            (Integrator::Implicit, Preconditioner::Patches, implicit_steps),
            (Integrator::Implicit, Preconditioner::BlockJacobi, implicit_steps),
        ] {
            match phonation::gpu::bench::solid_speed(ctx, side, integ, pre, steps, bw) {
                Ok(v) => {
                    let key = format!("{:?}/{}/{}d", v.integrator, v.particles, v.dim).to_lowercase();
                    // against the CPU's default (patches and the coarse space)
                    let vs = (pre == Preconditioner::Patches)
                        .then(|| run.cpu.solid.iter().find(|(k, _)| *k == key))
                        .flatten()
                        .map(|(_, c)| format!("  {:.2}× the CPU", v.particle_updates_per_s / c))
                        .unwrap_or_default();
                    solid_row(&v, &vs);
                    rows.push(v);
                }
                Err(e) => println!("{integ:?} ({pre:?}) {side}³ skipped: {e}"),
            }
        }
    }
    rows
}

/// The lattice gas on the device up to the seed's lattice, with what a probe sample costs.
fn lattice_gas(ctx: &GpuContext, run: &GpuRun, bw: f64) -> (Vec<phonation::lattice_gas::bench::LatticeGasSpeed>, Vec<phonation::bench::ReadbackCost>) {
    let (mut rows, mut readback) = (Vec::new(), Vec::new());
    if !run.wants("lattice_gas") {
        return (rows, readback);
    }
    lattice_gas_header();
    // (512 × 256 × 4: the lattice of lattice_gas_wake_large)
    let sizes: Vec<[usize; 3]> = if run.quick { vec![[32, 16, 8], [512, 256, 4]] } else { vec![[128, 64, 32], [512, 256, 4], [512, 256, 128]] };
    for cells in sizes {
        match phonation::gpu::lattice_gas::lattice_gas_speed(ctx, cells, if run.quick { 5 } else { 100 }, bw) {
            Ok(v) => {
                let vs = run.cpu.lattice_gas.map(|c| format!("  {:.1}× the CPU", v.site_updates_per_s / c)).unwrap_or_default();
                lattice_gas_row(&v, &vs);
                // the large wake's probe band: 2 × coarse_block = 16 ℓ either side, 9 rows
                let step_s = 16.0 * (cells[0] * cells[1] * cells[2]) as f64 / v.site_updates_per_s;
                if let Ok(r) = phonation::gpu::lattice_gas::readback_cost(ctx, cells, 9, step_s) {
                    println!(
                        "         a probe sample: whole state back {:.3e} s ({:.2e} steps), {} cells (9 rows) {:.3e} s ({:.2e} steps)",
                        r.whole_s, r.whole_steps, r.nodes, r.gathered_s, r.gathered_steps
                    );
                    readback.push(r);
                }
                rows.push(v);
            }
            Err(e) => println!("lattice gas {cells:?} skipped: {e}"),
        }
    }
    (rows, readback)
}

/// The coupled step on the device against the CPU in the same process: the Wall flap (method
/// 2) at D = 20 and 30, the glottis scenes (2D: method 1; 3D: method 2), with the host's own
/// work per step and the ceiling it puts on any device.
fn coupled(run: &GpuRun) -> anyhow::Result<Vec<phonation::gpu::bench::CoupledGpuSpeed>> {
    let mut scenes: Vec<(&str, String)> = Vec::new();
    if run.wants("coupled") {
        // the Wall flap (method 2) at its built-in resolution (D = 20 cells) and at D = 30
        let flap = phonation::scene::builtin("wall_flap_conserving").expect("built in");
        let finer = flap.replace("cells = [390, 240]", "cells = [585, 360]").replace("kernel_radius = 1.0 ", "kernel_radius = 1.5 ");
        scenes.extend([("wall_flap_conserving, D = 20", flap.to_string()), ("wall_flap_conserving, D = 30", finer)]);
    }
    if run.wants("glottis") {
        // the coupled 2D glottis (method 1, as the seed): the coarse scene and the seed's lattice
        scenes.push(("glottis_2d_coarse", phonation::scene::builtin("glottis_2d_coarse").expect("built in").to_string()));
        // the coarse 3D glottis (method 2): thick folds, whose ghosts' wall points the
        // geometry spends most of its time on
        scenes.push(("glottis_3d_coarse", phonation::scene::builtin("glottis_3d_coarse").expect("built in").to_string()));
        if !run.quick {
            scenes.push(("glottis_2d_c", phonation::scene::builtin("glottis_2d_c").expect("built in").to_string()));
        }
    }
    let mut rows = Vec::new();
    if scenes.is_empty() {
        return Ok(rows);
    }
    println!("GPU coupled step against the CPU in the same process (the Wall flap and the 3D glottis: method 2; the 2D glottis: method 1):");
    for (label, text) in scenes {
        let sc = phonation::scene::coupled::CoupledScene::parse(&text)?;
        let steps = if run.quick { 5 } else { 50 };
        match phonation::gpu::bench::coupled_speed(label, || sc.build().expect("a built-in scene builds"), steps) {
            Ok(v) => {
                println!(
                    "{:>30} {:>7} nodes {:>6} particles ×{} sub-steps: {:.2} steps/s ({:.2}× the CPU), {:.0} s per simulated s; coupling stages {:.0}% ({}); {} changes of layout, {:.0} nodes' populations across the bus each",
                    v.scene,
                    v.nodes,
                    v.particles,
                    v.solid_substeps,
                    v.gpu_steps_per_s,
                    v.gpu_steps_per_s / v.cpu_steps_per_s,
                    v.gpu_wall_per_simulated_s,
                    100.0 * v.gpu_coupling_share,
                    stages(&v.gpu_stage_shares),
                    v.round_trips,
                    v.nodes_per_round_trip
                );
                let parts: Vec<String> = v.gpu_geometry_parts.iter().map(|(n, f)| format!("{n} {:.1}%", 100.0 * f)).collect();
                println!(
                    "{:>30} fluid_geometry's parts: {}; {} device buffers or bind-group sets made in the timed steps",
                    "",
                    parts.join(", "),
                    v.gpu_device_objects_made
                );
                if let Some(host) = v.gpu_steps_per_s_cpu_level_sets {
                    println!(
                        "{:>30} level sets on the device: {:.2} steps/s against {host:.2} with them on the CPU ({:.2}×)",
                        "",
                        v.gpu_steps_per_s,
                        v.gpu_steps_per_s / host
                    );
                }
                let host: Vec<String> = v.gpu_host_work_s.iter().map(|(n, t)| format!("{n} {:.3} ms", 1e3 * t)).collect();
                println!(
                    "{:>30} the host's own work per step: {} — at most {:.0} steps/s on any device driven by this host",
                    "",
                    host.join(", "),
                    v.gpu_host_ceiling_steps_per_s
                );
                rows.push(v);
            }
            Err(e) => println!("{label} skipped: {e}"),
        }
    }
    Ok(rows)
}

/// The device's cost per update against size (`--only scaling --backend gpu`), printed as the
/// CPU's table is, with each row's fraction of the copy kernel's bandwidth `bw`.
fn scaling_table(ctx: &GpuContext, quick: bool, bw: f64) -> (Vec<phonation::gpu::scaling::GpuScalingRow>, Vec<String>) {
    use phonation::gpu::scaling::{ScalingSizes, scaling_table};
    let sizes = if quick { ScalingSizes::quick() } else { ScalingSizes::full() };
    println!("cost per update against size (GPU; flat ns/update once the device is filled = linear cost):");
    let (rows, skipped) = scaling_table(ctx, &sizes, if quick { 0.05 } else { 0.3 }, bw);
    println!("{:>18} {:>12} {:>8} {:>14} {:>12} {:>10} {:>12}", "kernel", "size", "steps", "updates/s", "ns/update", "B/update", "of copy b/w");
    for r in &rows {
        println!(
            "{:>18} {:>12} {:>8} {:>14.3e} {:>12.3} {:>10.0} {:>11.1}%",
            r.kernel,
            r.size,
            r.steps,
            r.updates_per_s,
            r.ns_per_update,
            r.bytes_per_update,
            100.0 * r.bandwidth_fraction
        );
    }
    for s in &skipped {
        println!("{:>18} skipped: {s}", "");
    }
    (rows, skipped)
}
