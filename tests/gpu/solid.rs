//! The MPS solid on the GPU against its CPU twin: kernels, whole explicit and implicit steps,
//! the patch smoother, the scene's CG tolerance and contact.

use crate::support::*;

#[test]
fn solid_kernels_match_their_cpu_twins() {
    let Some(ctx) = context() else { return };
    for dim in [2, 3] {
        for integrator in [Integrator::Explicit, Integrator::Implicit] {
            let mut cpu = solid(dim, integrator);
            let mut gpu = GpuSolid::from_solver(&ctx, &mut cpu).unwrap();
            gpu.cg_tolerance = 1e-6;
            let list = if integrator == Integrator::Explicit { &SOLID_EXPLICIT_STEP[..] } else { &SOLID_IMPLICIT_STEP[..] };
            let x0: Vec<DVec3> = cpu.particles.position.clone();
            let v0: Vec<DVec3> = cpu.particles.velocity.clone();
            for st in list {
                cpu.run_single_stage(st.kind);
                gpu.run_stage(st.kind);
                let (what, err, bound) = match st.kind {
                    phonation::stages::SolidStageKind::Rotations => {
                        ("rotation matrices", rel_mat(&gpu.download_matrices(SolidArray::Rotation), cpu.rotations()), 1e-5)
                    }
                    phonation::stages::SolidStageKind::StrainStress => {
                        let q: Vec<DMat3> = cpu.stress().q.clone();
                        // σ comes from ε = sym(RᵀF) − I with |ε| ~ 1e-3 here: the f32 cancellation of F − I
                        // alone is ~1e-7 / 1e-3 = 1e-4 of the largest stress
                        ("V R σ", rel_mat(&gpu.download_matrices(SolidArray::Q), &q), 2e-4)
                    }
                    phonation::stages::SolidStageKind::BondForces => {
                        // the CPU adds loads and gravity in its Contact stage: compare internal forces
                        let f = cpu.internal_force().to_vec();
                        ("forces", rel_vec(&gpu.download_vectors(SolidArray::Force), &f), 1e-4)
                    }
                    phonation::stages::SolidStageKind::Contact => continue,
                    phonation::stages::SolidStageKind::ConjugateGradient => {
                        // the CPU stage adds ΔV to v, the GPU keeps ΔV for its integrate kernel
                        let dv: Vec<DVec3> = (0..cpu.particles.len()).map(|i| cpu.particles.velocity[i] - v0[i]).collect();
                        ("ΔV (CG)", rel_vec(&gpu.download_vectors(SolidArray::DeltaV), &dv), 1e-4)
                    }
                    phonation::stages::SolidStageKind::Integrate => {
                        let u_c: Vec<DVec3> = (0..cpu.particles.len()).map(|i| cpu.particles.position[i] - x0[i]).collect();
                        let u_g: Vec<DVec3> = gpu.download_vectors(SolidArray::Position).iter().zip(&x0).map(|(a, b)| *a - *b).collect();
                        // f32 positions of size ~1 round at ~1e-7, the step moves them by ~1e-4
                        ("step displacement", rel_vec(&u_g, &u_c), 2e-3)
                    }
                };
                println!("{dim}D {integrator:?} {:20} {what:18}: max relative difference {err:.2e} (bound {bound:.0e})", st.name);
                assert!(err < bound, "{dim}D {integrator:?} {}: {err}", st.name);
            }
            if integrator == Integrator::Implicit {
                println!(
                    "{dim}D implicit: GPU CG {} iterations to {:.1e}; CPU {} to {:.1e}",
                    gpu.last_cg.0, gpu.last_cg.1, cpu.last.cg.iterations, cpu.last.cg.relative_residual
                );
            }
        }
    }
}

#[test]
fn solid_whole_steps_match_the_cpu_backend() {
    let Some(ctx) = context() else { return };
    for dim in [2, 3] {
        // Implicit: 50 steps here (each runs ~100 CG iterations of 13 dispatches; lavapipe spends
        // ~5 min on 200 — measured once: 2.2e-6 (2D) and 1.2e-6 (3D) displacement difference).
        for (integrator, steps) in [(Integrator::Explicit, 200u64), (Integrator::Implicit, 50)] {
            let mut cpu = solid(dim, integrator);
            let mut gpu = GpuSolid::from_solver(&ctx, &mut cpu).unwrap();
            gpu.cg_tolerance = 1e-6;
            let x0 = cpu.particles.position.clone();
            for _ in 0..steps {
                cpu.step().unwrap();
            }
            gpu.run(steps);
            let u_c: Vec<DVec3> = (0..cpu.particles.len()).map(|i| cpu.particles.position[i] - x0[i]).collect();
            let u_g: Vec<DVec3> = gpu.download_vectors(SolidArray::Position).iter().zip(&x0).map(|(a, b)| *a - *b).collect();
            let err = rel_vec(&u_g, &u_c);
            let verr = rel_vec(&gpu.download_vectors(SolidArray::Velocity), &cpu.particles.velocity);
            println!("{dim}D {integrator:?}, {steps} steps: displacement difference {err:.2e}, velocity {verr:.2e} (relative to the largest)");
            assert!(err < 1e-3 && verr < 1e-3);
            // the device's CG tally counts every solve as the CPU's does (none when explicit)
            assert_eq!(gpu.cg_tally.solves, cpu.cg_tally.solves, "{:?} vs {:?}", gpu.cg_tally, cpu.cg_tally);
            assert_eq!(cpu.cg_tally.solves, if integrator == Integrator::Implicit { steps } else { 0 });
            if integrator == Integrator::Implicit {
                assert_eq!(gpu.cg_tally.unconverged, 0, "{:?}", gpu.cg_tally);
                assert!(gpu.cg_tally.max_iterations >= gpu.last_cg.0 && gpu.cg_tally.worst_relative_residual <= 1e-6, "{:?}", gpu.cg_tally);
            }
        }
    }
}

/// The device's patch smoother (`cg_patches`, one workgroup per patch) against its CPU twin
/// `PatchJacobi::apply` on the 2D and 3D test solids (clamped particles, patches of up to 5²
/// and 4³ particles: every code path of the kernel's packed-triangle reads): z for a
/// pseudo-random r within 10⁻⁵ of the largest (f32 inverses on both sides, f32 sums on the
/// device), and exactly 0 at the clamped particles.
#[test]
fn the_patch_smoother_matches_its_cpu_twin() {
    let Some(ctx) = context() else { return };
    for dim in [2, 3] {
        let mut cpu = solid(dim, Integrator::Implicit);
        let mut gpu = GpuSolid::from_solver(&ctx, &mut cpu).unwrap();
        assert_eq!(gpu.preconditioner, phonation::solid::Preconditioner::Patches, "{:?}", gpu.preconditioner_note);
        let n = cpu.particles.len();
        let h = |i: usize, k: f64| ((i as f64 * 12.9898 + k * 78.233).sin() * 43758.5453).fract() - 0.5;
        let z_comp = if dim == 3 { 1.0 } else { 0.0 };
        let r: Vec<DVec3> = (0..n).map(|i| DVec3::new(h(i, 1.0), h(i, 2.0), z_comp * h(i, 3.0))).collect();
        let pj = cpu.patch_smoother();
        let mut z_cpu = vec![DVec3::ZERO; n];
        pj.apply(&r, &mut z_cpu);
        let z_gpu = gpu.apply_patches(&r).expect("the device applies the patches");
        let err = rel_vec(&z_gpu, &z_cpu);
        println!("{dim}D: {} patches of at most {} particles, z within {err:.2e} of the largest", pj.patches(), pj.largest_patch());
        assert!(err < 1e-5, "{dim}D: {err}");
        for i in (0..n).filter(|&i| cpu.particles.fixed[i]) {
            assert_eq!(z_gpu[i], DVec3::ZERO, "clamped particle {i}");
        }
    }
}

/// The device's coarse-space correction (`coarse_restrict`, `coarse_solve`, `coarse_prolong`:
/// the aggregates' affine modes, A_c⁻¹ applied as one dense f32 product) against its CPU twin
/// `CoarseSpace::add_correction` (f64, Cholesky) on the 2D and 3D test solids (with clamped
/// particles, which no aggregate holds): z + P A_c⁻¹ Pᵀ r
/// for a pseudo-random r and z within 10⁻⁵ of the largest (f32 A_c⁻¹ and sums; measured
/// 1.5–1.8·10⁻⁷) — the correction alone (z = 0) and added to a z — and z unchanged at the clamped
/// particles.
#[test]
fn the_coarse_space_correction_matches_its_cpu_twin() {
    let Some(ctx) = context() else { return };
    for dim in [2, 3] {
        let mut cpu = solid(dim, Integrator::Implicit);
        let mut gpu = GpuSolid::from_solver(&ctx, &mut cpu).unwrap();
        let c = cpu.coarse_space().expect("the implicit solver built its coarse space").clone();
        assert_eq!(gpu.coarse_unknowns(), c.unknowns(), "{:?}", gpu.coarse_note);
        let n = cpu.particles.len();
        let h = |i: usize, k: f64| ((i as f64 * 12.9898 + k * 78.233).sin() * 43758.5453).fract() - 0.5;
        let z_comp = if dim == 3 { 1.0 } else { 0.0 };
        let r: Vec<DVec3> = (0..n).map(|i| DVec3::new(h(i, 1.0), h(i, 2.0), z_comp * h(i, 3.0))).collect();
        for z0 in [vec![DVec3::ZERO; n], (0..n).map(|i| DVec3::new(h(i, 4.0), h(i, 5.0), z_comp * h(i, 6.0))).collect()] {
            let mut z_cpu = z0.clone();
            c.add_correction(&r, &mut z_cpu);
            let z_gpu = gpu.add_coarse_correction(&r, &z0).expect("the device holds the coarse space");
            let err = rel_vec(&z_gpu, &z_cpu);
            let largest = z_cpu.iter().map(|v| v.length()).fold(0.0, f64::max);
            println!("{dim}D: {} coarse unknowns, z + P A_c⁻¹ Pᵀ r within {err:.2e} of the largest ({largest:.3e})", c.unknowns());
            assert!(err < 1e-5, "{dim}D: {err}");
            assert!(largest > 0.0);
            for i in (0..n).filter(|&i| cpu.particles.fixed[i]) {
                assert_eq!(z_gpu[i], z0[i].as_vec3().as_dvec3(), "clamped particle {i}");
            }
        }
    }
}

/// The implicit solve on the device with the patch smoother and the coarse space: the benchmark
/// block (12³, 10× the explicit step, CG to 10⁻⁶ in f32) converges in ≤ 30 iterations (the
/// issue's bound for the 10⁶ block; measured on lavapipe: 24, counted in the device's batches of
/// 8; the CPU in f64 to 10⁻⁸ takes 25–26), in fewer than the patches alone (32) and in under
/// 60 % of block Jacobi's with the coarse space (56); the three solutions agree within 10⁻⁵ of
/// the motion (measured 2.3·10⁻⁷: the same system), and all land on the CPU's step (patches
/// and the coarse space, f64, CG to 10⁻⁸) within 2·10⁻³ of the motion — measured 1.07·10⁻³
/// for each preconditioner alike, so the f32 step's own difference, not the solve's: the block
/// starts sheared (v = 0.1 x ŷ), and B = Δt (f + Δt K v) of a uniform shear is large bond terms
/// cancelling to the faces' net, which f32 keeps to ~10⁻³ (measured on the 8³ block with and
/// without viscosity, with the clamped particles at rest or not: 1.25–1.26·10⁻³ after one
/// step, 4.4–5.5·10⁻⁴ after four; started at rest under a load instead, 1.1·10⁻⁵ and 1.9·10⁻⁶).
#[test]
fn the_device_solve_with_patches_and_the_coarse_space_takes_fewest_iterations() {
    use phonation::solid::Preconditioner;
    let Some(ctx) = context() else { return };
    let cpu = phonation::solid::bench::benchmark_block(12, Integrator::Implicit);
    let x0 = cpu.particles.position.clone();
    let mut reference = cpu.clone();
    reference.step().unwrap();
    let u_ref = displacements(&reference.particles.position, &x0);
    let mut runs = Vec::new();
    for (pre, coarse) in [(Preconditioner::Patches, true), (Preconditioner::Patches, false), (Preconditioner::BlockJacobi, true)] {
        let mut s = cpu.clone();
        s.options.preconditioner = pre;
        if !coarse {
            s.drop_coarse_space();
        }
        let mut gpu = GpuSolid::from_solver(&ctx, &mut s).unwrap();
        assert_eq!(gpu.preconditioner, pre, "{:?}", gpu.preconditioner_note);
        assert_eq!(gpu.coarse_unknowns() > 0, coarse, "{:?}", gpu.coarse_note);
        gpu.cg_tolerance = 1e-6;
        gpu.run(1);
        let u = displacements(&gpu.download_vectors(SolidArray::Position), &x0);
        let err = rel_vec(&u, &u_ref);
        println!(
            "{pre:?}{} on the device ({} coarse unknowns): {:?} (iterations, residual), step within {err:.2e} of the CPU's",
            if coarse { " + coarse" } else { "" },
            gpu.coarse_unknowns(),
            gpu.last_cg
        );
        assert!(gpu.last_cg.1 <= 1e-6, "{pre:?}: {:?}", gpu.last_cg);
        runs.push((gpu.last_cg.0, err, u));
    }
    println!("the CPU (patches + coarse, f64, to 1e-8): {} iterations", reference.last.cg.iterations);
    for k in 1..3 {
        let between = rel_vec(&runs[0].2, &runs[k].2);
        println!("run {k} against run 0 on the device: {between:.2e} of the motion");
        assert!(between < 1e-5, "the preconditioners solve the same system: {between}");
    }
    assert!(runs.iter().all(|r| r.1 < 2e-3), "steps against the CPU's: {:?}", runs.iter().map(|r| r.1).collect::<Vec<_>>());
    let its: Vec<usize> = runs.iter().map(|r| r.0).collect();
    assert!(its[0] <= 30, "patches + coarse: {} iterations", its[0]);
    assert!(its[0] < its[1], "the coarse space saves iterations: {} against {} without", its[0], its[1]);
    assert!((its[0] as f64) < 0.6 * its[2] as f64, "patches {} against block Jacobi {} iterations (both with the coarse space)", its[0], its[2]);
}

/// Two elastic blocks driven into each other above a wall, with gravity and friction.
/// `solid.cg_tolerance` has its effect on the GPU too: a looser tolerance stops the f32
/// conjugate gradient earlier, each solve ends at or below its tolerance, and a tolerance below
/// what f32 reaches is refused with the field (the CPU, in f64, takes it); the engine's CPU copy,
/// which the outputs read, reports the device's solve.
#[test]
fn the_scene_cg_tolerance_drives_the_gpu_solve_or_is_refused() {
    use phonation::run::{Backend, SolidEngine};
    use phonation::scene::solid::SolidScene;
    use phonation::step::Solver;
    let Some(_ctx) = context() else { return };
    let text = phonation::scene::builtin("cantilever").unwrap();
    let with = |t: &str| SolidScene::parse(&text.replace("time_step = 0.005", &format!("time_step = 0.005\ncg_tolerance = {t}"))).unwrap();
    let sc = with("1e-9");
    let e = SolidEngine::new(Backend::Gpu, sc.build().unwrap(), sc.file.solid.cg_tolerance).err().expect("1e-9 is out of f32's reach");
    assert!(e.to_string().contains("solid.cg_tolerance"), "{e}");
    let mut cpu = SolidEngine::new(Backend::Cpu, sc.build().unwrap(), sc.file.solid.cg_tolerance).unwrap();
    cpu.advance(1).unwrap();
    assert!(cpu.solver.last.cg.relative_residual <= 1e-9, "the CPU solves to 1e-9: {:?}", cpu.solver.last.cg);
    let mut iterations = Vec::new();
    for t in [1e-2, 1e-6] {
        let sc = with(&format!("{t:e}"));
        let mut g = SolidEngine::new(Backend::Gpu, sc.build().unwrap(), sc.file.solid.cg_tolerance).unwrap();
        g.advance(1).unwrap();
        let (it, res) = g.gpu_last_cg().expect("on the GPU");
        eprintln!("GPU CG to {t:e}: {it} iterations, residual {res:e}");
        assert!(res <= t, "GPU CG stopped at {res:e} above its tolerance {t:e}");
        // the CPU copy that the outputs read (solid.csv's cg columns) carries the device's solve
        let last = g.solver.last.cg;
        assert!(last.iterations == it && last.relative_residual == res && last.converged, "{last:?} against ({it}, {res:e})");
        assert_eq!(g.solver.cg_tally.solves, 1, "{:?}", g.solver.cg_tally);
        iterations.push(it);
    }
    assert!(iterations[0] < iterations[1], "a looser tolerance takes fewer iterations: {iterations:?}");
}

fn colliding_blocks() -> SolidSolver {
    let mat = Orthotropic::isotropic(1.0e6, 0.3, 1.0, 1.0);
    let l0 = 0.1;
    let mut p = Particles::new(2, l0);
    for (b, x0) in [(0u16, 0.0), (1u16, 0.85)] {
        for x in sample_box(2, DVec3::new(x0, 0.0, 0.0), DVec3::new(x0 + 0.8, 0.6, 0.0), l0) {
            p.push(x, 1.0, 0, b, false);
        }
    }
    for i in 0..p.len() {
        // oblique approach: normal and tangential relative motion
        p.velocity[i] = if p.body[i] == 0 { DVec3::new(40.0, 8.0, 0.0) } else { DVec3::new(-40.0, -3.0, 0.0) };
    }
    let contact =
        phonation::solid::ContactParams { normal_stiffness: 2.0e7, tangential_stiffness: 1.0e7, static_friction: 0.4, dynamic_friction: 0.3, damping: 50.0 };
    let walls = vec![phonation::solid::Wall { normal: DVec3::Y, offset: 0.0 }];
    SolidSolver::new(p, vec![mat], SolidOptions { contact: Some(contact), walls, gravity: DVec3::new(0.0, -981.0, 0.0), ..Default::default() }).unwrap()
}

#[test]
fn solid_contact_matches_the_cpu() {
    let Some(ctx) = context() else { return };
    // kernel by kernel: the GPU starts every step from the CPU state and keeps its own anchors
    let mut cpu = colliding_blocks();
    let mut gpu = GpuSolid::from_solver(&ctx, &mut cpu).unwrap();
    let (mut worst, mut active_steps) = (0.0f64, 0);
    for _ in 0..1500 {
        gpu.upload_state(&cpu);
        let mut before = Vec::new();
        for st in SOLID_EXPLICIT_STEP {
            cpu.run_single_stage(st.kind);
            gpu.run_stage(st.kind);
            if st.kind == phonation::stages::SolidStageKind::BondForces {
                before = cpu.internal_force().to_vec();
            }
            if st.kind == phonation::stages::SolidStageKind::Contact {
                let p = &cpu.particles;
                let c: Vec<DVec3> = (0..p.len()).map(|i| cpu.net_force()[i] - before[i] - p.load[i] - p.mass[i] * cpu.options.gravity).collect();
                if cpu.contacts().active.0 > 0 {
                    active_steps += 1;
                    let g = gpu.download_vectors(SolidArray::ContactForce);
                    worst = worst.max(rel_vec(&g, &c));
                }
            }
        }
    }
    println!("contact forces on {active_steps} steps with pair contacts: max relative difference {worst:.2e}");
    // the overlap c = l₀ − d is a difference of f32 positions of size ~1: at overlaps of ~1e-3 l₀
    // (the first steps of a contact) its rounding alone is ~1e-7 / 1e-4 = 1e-3 of the force
    assert!(active_steps > 100 && worst < 5e-3);
    // whole run on its own
    let mut cpu = colliding_blocks();
    let mut gpu = GpuSolid::from_solver(&ctx, &mut cpu).unwrap();
    let x0 = cpu.particles.position.clone();
    for _ in 0..1500 {
        cpu.step().unwrap();
    }
    gpu.run(1500);
    let u_c: Vec<DVec3> = (0..cpu.particles.len()).map(|i| cpu.particles.position[i] - x0[i]).collect();
    let u_g: Vec<DVec3> = gpu.download_vectors(SolidArray::Position).iter().zip(&x0).map(|(a, b)| *a - *b).collect();
    let err = rel_vec(&u_g, &u_c);
    println!("1500 steps through the collision: displacement difference {err:.2e} of the largest");
    assert!(err < 1e-2);
}
