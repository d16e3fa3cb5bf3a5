//! The MPS solid (issue 4): material checks, discretisation identities, conservation,
//! cantilever / plate / wave-speed validations, implicit integration and contact.

use glam::{DMat3, DQuat, DVec3};
use phonation::solid::grid::SearchGrid;
use phonation::solid::particles::sample_box;
use phonation::solid::{Integrator, Orthotropic, Particles, SolidOptions, SolidSolver};
use phonation::validation::beam::{Cantilever, free_vibration, oscillating_plate, release_in_first_mode, static_tip_deflection};
use phonation::validation::{contact, waves};

fn block(dim: usize, n: [usize; 3], l0: f64, mat: &Orthotropic) -> Particles {
    let mut p = Particles::new(dim, l0);
    let max = DVec3::new(n[0] as f64 * l0, n[1] as f64 * l0, if dim == 3 { n[2] as f64 * l0 } else { 0.0 });
    for x in sample_box(dim, DVec3::ZERO, max, l0) {
        p.push(x, mat.density, 0, 0, false);
    }
    p
}

#[test]
fn patch_test_uniform_strain_gives_uniform_stress() {
    for dim in [2, 3] {
        let mat = Orthotropic { young: [1.0e6, 3.0e6, 2.0e6], poisson: [0.2, 0.25, 0.3], shear: [4.0e5, 5.0e5, 6.0e5], density: 1.0, viscosity: 0.0 };
        let c = mat.stiffness("m").unwrap();
        let p = block(dim, [12, 12, 10], 0.1, &mat);
        let mut s = SolidSolver::new(p, vec![mat.clone()], SolidOptions::default()).unwrap();
        let e = DMat3::from_cols(DVec3::new(1e-3, 2e-4, 0.0), DVec3::new(2e-4, -5e-4, 0.0), DVec3::new(0.0, 0.0, 0.0));
        let e = if dim == 3 { e + DMat3::from_cols(DVec3::new(0.0, 0.0, 3e-4), DVec3::new(0.0, 0.0, -1e-4), DVec3::new(3e-4, -1e-4, 4e-4)) } else { e };
        for i in 0..s.particles.len() {
            s.particles.position[i] = s.particles.reference[i] + e * s.particles.reference[i];
        }
        s.evaluate_forces();
        let ev = phonation::solid::material::to_voigt(&e);
        let mut worst: f64 = 0.0;
        let n = s.particles.len();
        // gradient strain at every particle equals ε (only the gradient part is stored; the pair part
        // carries C_pair ε exactly for an affine field)
        for i in 0..n {
            let st = s.stress().strain[i];
            for k in 0..6 {
                worst = worst.max((st[k] - ev[k]).abs());
            }
        }
        println!("dim {dim}: max |ε_i − ε| = {worst:.2e} over {n} particles, C11 = {:.3e}", c[0][0]);
        assert!(worst < 1e-12, "patch test strain error {worst}");
        // forces on interior particles vanish; the net force on the body vanishes
        let l0 = 0.1;
        let re = 2.1 * l0;
        let interior = |x: DVec3| (0..dim).all(|a| x[a] > 2.0 * re + 1e-9 && x[a] < [12.0, 12.0, 10.0][a] * l0 - 2.0 * re - 1e-9);
        let fscale = c[0][0] * 1e-3 * l0.powi(dim as i32 - 1);
        let mut fmax: f64 = 0.0;
        for i in 0..n {
            if interior(s.particles.reference[i]) {
                fmax = fmax.max(s.net_force()[i].length());
            }
        }
        let net: DVec3 = s.net_force().iter().copied().sum();
        println!("dim {dim}: interior |f| ≤ {:.2e} (scale {fscale:.2e}), |Σf| = {:.2e}", fmax, net.length());
        assert!(fmax < 1e-9 * fscale && net.length() < 1e-9 * fscale);
    }
}

#[test]
fn rigid_rotation_by_a_large_angle_gives_no_elastic_force() {
    for dim in [2, 3] {
        let mat = Orthotropic::isotropic(1.0e6, 0.3, 1.0, 0.0);
        let p = block(dim, [10, 6, 5], 0.1, &mat);
        let q = if dim == 2 { DQuat::from_rotation_z(2.2) } else { DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 2.2) };
        for integrator in [Integrator::Explicit, Integrator::Implicit] {
            let mut s = SolidSolver::new(p.clone(), vec![mat.clone()], SolidOptions { integrator, ..Default::default() }).unwrap();
            for i in 0..s.particles.len() {
                s.particles.position[i] = q * s.particles.reference[i] + DVec3::new(0.3, -0.2, 0.0);
                // explicit: the particles carry the rotation; implicit: Newton–Raphson must find it
                s.particles.rotation[i] = if integrator == Integrator::Explicit { q } else { DQuat::IDENTITY };
            }
            s.evaluate_forces();
            let fscale = 1.0e6 * 0.1f64.powi(dim as i32 - 1);
            let fmax = s.net_force().iter().map(|f| f.length()).fold(0.0, f64::max);
            let tmax = s.net_torque().iter().map(|f| f.length()).fold(0.0, f64::max);
            let e = s.energies();
            println!("dim {dim} {integrator:?}: max |f| = {fmax:.2e}, max |τ| = {tmax:.2e} (force scale {fscale:.1e}), elastic energy {:.2e}", e.elastic);
            assert!(fmax < 1e-9 * fscale && tmax < 1e-9 * fscale * 0.1 && e.elastic.abs() < 1e-18 * 1e6);
        }
    }
}

#[test]
fn torques_cancel_the_moments_of_the_forces() {
    // Σ x × f + Σ τ = 0 for any state (rotation invariance of the energy)
    for dim in [2, 3] {
        let mat = Orthotropic { young: [1.0e6, 3.0e6, 2.0e6], poisson: [0.2, 0.25, 0.3], shear: [4.0e5, 5.0e5, 6.0e5], density: 1.0, viscosity: 20.0 };
        let mut s = SolidSolver::new(block(dim, [7, 6, 5], 0.1, &mat), vec![mat], SolidOptions::default()).unwrap();
        let n = s.particles.len();
        for i in 0..n {
            let x = s.particles.reference[i];
            let h = |k: f64| ((x.x * 12.9898 + x.y * 78.233 + x.z * 37.719 + k).sin() * 43758.5453).fract();
            let z = if dim == 3 { 1.0 } else { 0.0 };
            s.particles.position[i] = x + 0.01 * DVec3::new(h(1.0), h(2.0), z * h(3.0));
            s.particles.velocity[i] = DVec3::new(h(4.0), h(5.0), z * h(6.0));
            s.particles.spin[i] = if dim == 3 { DVec3::new(h(7.0), h(8.0), h(9.0)) } else { DVec3::new(0.0, 0.0, h(9.0)) };
            s.particles.rotation[i] =
                if dim == 3 { DQuat::from_scaled_axis(0.05 * DVec3::new(h(10.0), h(11.0), h(12.0))) } else { DQuat::from_rotation_z(0.05 * h(10.0)) };
        }
        s.evaluate_forces();
        let m: DVec3 = (0..n).map(|i| s.particles.position[i].cross(s.net_force()[i]) + s.net_torque()[i]).sum();
        let scale: f64 = (0..n).map(|i| s.particles.position[i].cross(s.net_force()[i]).length()).sum();
        let f: DVec3 = s.net_force().iter().copied().sum();
        let fs: f64 = s.net_force().iter().map(|f| f.length()).sum();
        println!("dim {dim}: |Σ x×f + τ| = {:.2e} of {scale:.2e}; |Σ f| = {:.2e} of {fs:.2e}", m.length(), f.length());
        assert!(m.length() < 1e-12 * scale && f.length() < 1e-12 * fs);
    }
}

#[test]
fn cantilever_static_deflection_matches_beam_theory() {
    // h/l₀ = 12 in 2D, 10 in 3D (errors 1.6 % / 1.7 %; 3.3 % / 2.8 % at h/l₀ = 8, second order)
    for (dim, cells) in [(2, 12), (3, 10)] {
        let c = Cantilever::slender(dim, cells);
        let (d, theory, it) = static_tip_deflection(&c, 0.01);
        let err = (d - theory).abs() / theory;
        println!("dim {dim}, h/l0 = {cells}: tip deflection {d:.5e}, beam theory {theory:.5e}, error {:.2}% (CG {it} iterations)", 100.0 * err);
        assert!(err < 0.03);
    }
}

#[test]
fn material_stiffness_is_checked_for_positive_definiteness() {
    // isotropic: C11 = λ + 2μ, C12 = λ, C44 = μ
    let (e, nu) = (1.0e6, 0.3);
    let c = Orthotropic::isotropic(e, nu, 1.0, 0.0).stiffness("m").unwrap();
    let (lam, mu) = (e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu)));
    assert!((c[0][0] - (lam + 2.0 * mu)).abs() < 1e-9 * e && (c[0][1] - lam).abs() < 1e-9 * e && (c[3][3] - mu).abs() < 1e-9 * e);
    // the seed's fold tissue: in-plane Poisson ratio 0.97 (transversely isotropic) is valid
    let fold = Orthotropic::transversely_isotropic(1.0e5, 4.0e5, 0.97, 0.05, 4.0e4, 1.043, 5.0);
    let cf = fold.stiffness("fold").unwrap();
    println!("fold C_xx = {:.3e}, C_yy = {:.3e}, min Mandel eigenvalue {:.3e}", cf[0][0], cf[1][1], phonation::solid::material::min_mandel_eigenvalue(&cf));
    assert!(phonation::solid::material::min_mandel_eigenvalue(&cf) > 0.0);
    // refused: isotropic ν = 0.6, transversely isotropic with too large a fibre ratio, E ≤ 0
    let bad = [
        (Orthotropic::isotropic(e, 0.6, 1.0, 0.0), "poisson"),
        (Orthotropic::transversely_isotropic(1.0e5, 4.0e5, 0.97, 0.4, 4.0e4, 1.0, 0.0), "poisson"),
        (Orthotropic::isotropic(-1.0, 0.3, 1.0, 0.0), "young[0]"),
        (Orthotropic { viscosity: -1.0, ..Orthotropic::isotropic(e, 0.3, 1.0, 0.0) }, "viscosity"),
    ];
    for (m, field) in bad {
        let err = m.stiffness("solid.materials[0]").unwrap_err();
        println!("{err}");
        assert_eq!(err.field, format!("solid.materials[0].{field}"));
    }
}

#[test]
fn search_grid_finds_exactly_the_brute_force_neighbours() {
    let periods = [Some(2.0), None, Some(1.5)];
    let x: Vec<DVec3> = (0..600)
        .map(|i| {
            let h = |k: f64| ((i as f64 * 12.9898 + k * 78.233).sin() * 43758.5453).fract().abs();
            DVec3::new(2.0 * h(1.0), 3.0 * h(2.0) - 1.0, 1.5 * h(3.0))
        })
        .collect();
    let r = 0.31;
    let g = SearchGrid::build(&x, r, periods);
    let mut total = 0;
    for i in 0..x.len() {
        let mut a: Vec<usize> = Vec::new();
        g.for_each_within(x[i], r, &x, |j, _| a.push(j));
        a.sort();
        let b: Vec<usize> = (0..x.len()).filter(|&j| phonation::solid::grid::minimum_image(x[j] - x[i], &periods).length() <= r).collect();
        assert_eq!(a, b, "particle {i}");
        total += a.len();
    }
    println!("{} cells, {total} neighbour pairs checked", g.cell_count());
}

#[test]
fn explicit_undamped_motion_conserves_momentum_and_angular_momentum() {
    let mat = Orthotropic { young: [1.0e6, 3.0e6, 2.0e6], poisson: [0.2, 0.25, 0.3], shear: [4.0e5, 5.0e5, 6.0e5], density: 1.0, viscosity: 0.0 };
    let mut s = SolidSolver::new(block(3, [8, 6, 5], 0.1, &mat), vec![mat], SolidOptions::default()).unwrap();
    for i in 0..s.particles.len() {
        let x = s.particles.reference[i];
        let h = |k: f64| ((x.x * 12.9898 + x.y * 78.233 + x.z * 37.719 + k).sin() * 43758.5453).fract();
        s.particles.velocity[i] = 10.0 * DVec3::new(h(1.0), h(2.0), h(3.0)) + DVec3::new(0.0, 0.0, 30.0).cross(x);
        s.particles.spin[i] = DVec3::new(h(4.0), h(5.0), h(6.0));
    }
    let (p0, l0) = (s.particles.linear_momentum(), s.particles.angular_momentum());
    let pscale: f64 = (0..s.particles.len()).map(|i| s.particles.mass[i] * s.particles.velocity[i].length()).sum();
    let lscale: f64 = (0..s.particles.len()).map(|i| s.particles.mass[i] * s.particles.position[i].cross(s.particles.velocity[i]).length()).sum();
    for _ in 0..500 {
        s.step().unwrap();
    }
    let dp = (s.particles.linear_momentum() - p0).length() / pscale;
    let dl = (s.particles.angular_momentum() - l0).length() / lscale;
    println!("after 500 steps: |ΔP|/Σ|mv| = {dp:.2e}, |ΔL|/Σ|m x×v| = {dl:.2e}");
    assert!(dp < 1e-13 && dl < 1e-12);
}

#[test]
fn oscillating_plate_keeps_its_period_and_energy_over_ten_periods() {
    // Gray, Monaghan & Swift (2001): plane-strain period 0.254 s; H/Δx = 8
    let c = oscillating_plate(8);
    let mut s = c.solver(SolidOptions::default());
    release_in_first_mode(&mut s, &c, 0.01 * (c.young / c.density).sqrt());
    let v = free_vibration(&mut s, &c, 10, 4.0, 500);
    let theory = 1.0 / c.first_frequency();
    let err = (v.period - 0.254) / 0.254;
    println!(
        "plate: period {:.4} s over {} periods (reference 0.254, beam theory {theory:.4}): error {:+.2}%; energy drift {:.3}%; amplitude {:.4} → {:.4} m; {} steps of {:.2e} s in {:.1} s",
        v.period,
        v.periods_measured,
        100.0 * err,
        100.0 * v.energy_drift,
        v.first_amplitude,
        v.last_amplitude,
        v.steps,
        v.dt,
        v.wall_s
    );
    assert!(v.periods_measured >= 10 && err.abs() < 0.05);
    assert!(v.energy_drift < 0.01 && (v.last_amplitude / v.first_amplitude - 1.0).abs() < 0.05);
}

#[test]
fn cantilever_3d_first_frequency_matches_beam_theory() {
    // h/l₀ = 8 (at 6 the error is −4.9 %: discretisation −2.5 %, the sampled section's second
    // moment (1 − (l₀/h)²) −1.4 %, shear and rotary inertia −0.7 %)
    let c = Cantilever::slender(3, 8);
    let mut s = c.solver(SolidOptions::default());
    release_in_first_mode(&mut s, &c, 1e-3 * (c.young / c.density).sqrt());
    let v = free_vibration(&mut s, &c, 1, 1.0, 1000);
    let f = 1.0 / v.period;
    let err = (f - c.first_frequency()) / c.first_frequency();
    println!(
        "3D cantilever h/l0 = 8: f1 = {f:.4} Hz, beam theory {:.4} Hz, error {:+.2}% ({} particles, {} steps, {:.1} s)",
        c.first_frequency(),
        100.0 * err,
        s.particles.len(),
        v.steps,
        v.wall_s
    );
    assert!(err.abs() < 0.05);
}

#[test]
fn orthotropic_block_wave_speeds_match_the_stiffness() {
    let mat = Orthotropic { young: [1.0e6, 3.0e6, 2.0e6], poisson: [0.2, 0.25, 0.3], shear: [4.0e5, 5.0e5, 6.0e5], density: 1.0, viscosity: 0.0 };
    let fold = Orthotropic::transversely_isotropic(1.0e5, 4.0e5, 0.97, 0.05, 4.0e4, 1.043, 0.0);
    for (name, m) in [("orthotropic", &mat), ("fold (ν = 0.97)", &fold)] {
        for axis in 0..3 {
            for pol in 0..3 {
                let w = waves::wave_speed(m, axis, pol, 32, 6, 0.1);
                println!("{name}: along {axis}, polarised {pol}: c = {:.2} vs {:.2} ({:+.2}%)", w.measured, w.theory, 100.0 * w.relative_error);
                assert!(w.relative_error.abs() < 0.03);
            }
        }
    }
}

#[test]
fn implicit_steps_are_stable_far_beyond_the_explicit_limit() {
    let c = oscillating_plate(8);
    let probe = c.solver(SolidOptions::default());
    let limit = probe.explicit_limit;
    let mut periods = Vec::new();
    for (factor, added) in [(20.0, 0.0), (20.0, 1.0)] {
        let mut s = c.solver(SolidOptions { integrator: Integrator::Implicit, time_step: Some(factor * limit), cg_tolerance: 1e-8, ..Default::default() });
        for i in 0..s.particles.len() {
            s.particles.added_mass[i] = added * s.particles.mass[i];
        }
        release_in_first_mode(&mut s, &c, 0.01 * (c.young / c.density).sqrt());
        let tip = c.tip(&s.particles);
        let mut prev = 0.0;
        let mut crossings = Vec::new();
        let (mut worst_res, mut max_it, mut amp) = (0.0f64, 0usize, 0.0f64);
        while crossings.len() < 3 && s.time < 2.0 {
            s.step().unwrap();
            worst_res = worst_res.max(s.last.cg.relative_residual);
            max_it = max_it.max(s.last.cg.iterations);
            let d = phonation::validation::beam::tip_deflection(&s, &tip);
            amp = amp.max(d.abs());
            if prev < 0.0 && d >= 0.0 {
                crossings.push(s.time - s.dt + prev / (prev - d) * s.dt);
            }
            prev = d;
        }
        let t = (crossings[2] - crossings[0]) / 2.0;
        println!(
            "implicit Δt = {factor} × explicit limit ({:.2e} s), added mass {added} m: period {t:.4} s ({:+.2}% vs 0.254), max amplitude {amp:.4} m, CG ≤ {max_it} iterations, worst residual {worst_res:.1e}",
            s.dt,
            100.0 * (t - 0.254) / 0.254
        );
        // no blow-up (amplitude stays that of the release), CG converged at every step, period
        // within 5 % of the reference (scaled by √((m + m_a)/m) with added mass)
        let expected = 0.254 * (1.0 + added).sqrt();
        assert!(worst_res <= 1e-8 && amp < 0.05 && ((t - expected) / expected).abs() < 0.05);
        periods.push(t);
    }
    let ratio = periods[1] / periods[0];
    println!("added mass m_a = m: period ratio {ratio:.4} vs √((m + m_a)/m) = {:.4}", 2.0f64.sqrt());
    assert!((ratio / 2.0f64.sqrt() - 1.0).abs() < 0.01);
}

#[test]
fn blocks_in_contact_do_not_interpenetrate() {
    let c = contact::two_blocks(0.05, 3000);
    println!(
        "two blocks at ±0.05 c: max overlap {:.4} l0, momentum change {:.1e}, rebound velocities {:?}",
        c.max_overlap, c.momentum_change, c.final_velocities
    );
    assert!(c.max_overlap < 0.1 && c.momentum_change < 1e-12);
    assert!(c.final_velocities[0] < 0.0 && c.final_velocities[1] > 0.0);
}

#[test]
fn block_on_a_slope_sticks_below_and_slides_above_the_friction_angle() {
    let stick = contact::block_on_slope(20.0, 0.1, 0.1);
    let slide = contact::block_on_slope(35.0, 0.1, 0.1);
    println!(
        "20° (tan 0.36 < μs 0.5): displacement {:.2e} ({:.3} l0), acceleration {:.3}",
        stick.displacement,
        stick.displacement / stick.spacing,
        stick.acceleration
    );
    println!(
        "35° (tan 0.70 > μs): acceleration {:.2} vs g(sin α − μd cos α) = {:.2} ({:+.2}%)",
        slide.acceleration,
        slide.expected_acceleration,
        100.0 * (slide.acceleration / slide.expected_acceleration - 1.0)
    );
    assert!(stick.displacement.abs() < 0.01 * stick.spacing);
    assert!((slide.acceleration / slide.expected_acceleration - 1.0).abs() < 0.03);
}

#[test]
fn solid_scenes_validate_and_bad_input_names_the_field() {
    use phonation::run::solid::run_solid_scene;
    use phonation::scene::solid::SolidScene;
    for (name, text) in phonation::scene::SOLID_BUILTIN {
        assert_eq!(phonation::scene::SceneKind::of(text), phonation::scene::SceneKind::Solid, "{name}");
        let sc = SolidScene::parse(text).unwrap_or_else(|e| panic!("{name}: {e}"));
        let s = sc.build().unwrap_or_else(|e| panic!("{name}: {e}"));
        println!("{name}: {} particles (estimated {}), Δt {:.3e}, explicit limit {:.3e}", s.particles.len(), sc.estimated_particles, s.dt, s.explicit_limit);
        assert!(s.particles.len() >= sc.estimated_particles);
    }
    let base = phonation::scene::builtin("two_blocks").unwrap();
    let cases = [
        ("dimension = 2", "dimension = 4", "solid.dimension"),
        ("spacing = 0.1", "spacing = -0.1", "solid.spacing"),
        ("spacing = 0.1", "spacing = 0.00001", "solid.spacing"),
        ("poisson = 0.3", "poisson = 0.7", "solid.materials[0].poisson"),
        ("young = 1.0e6", "young = 0.0", "solid.materials[0].young[0]"),
        ("velocity = [50.0, 0.0]", "velocity = [50.0, 0.0, 1.0]", "solid.bodies[0].velocity"),
        ("static_friction = 0.5", "static_friction = 0.3", "solid.contact.dynamic_friction"),
        ("duration = 0.05", "duration = 0.0", "run.duration"),
        ("normal = [0.0, 1.0]", "normal = [0.0, 0.0]", "solid.walls[0].normal"),
        ("max = [1.0, 1.0]\nvelocity", "max = [0.05, 1.0]\nvelocity", "solid.bodies[0].max"),
        ("[run]", "[run]\nbogus = 1", "run.bogus"),
        ("gravity = ", "preconditioner = \"jacobi\"\ngravity = ", "solid.preconditioner"),
    ];
    for (from, to, field) in cases {
        assert!(base.contains(from), "{from}");
        let e = SolidScene::parse(&base.replacen(from, to, 1)).unwrap_err();
        println!("{e}");
        assert_eq!(e.field, field);
    }
    // the implicit solve's smoother is a scene option
    for (text, pre) in [("block_jacobi", phonation::solid::Preconditioner::BlockJacobi), ("patches", phonation::solid::Preconditioner::Patches)] {
        let s = SolidScene::parse(&base.replacen("gravity = ", &format!("preconditioner = \"{text}\"\ngravity = "), 1)).unwrap().build().unwrap();
        assert_eq!(s.options.preconditioner, pre);
    }
    assert_eq!(SolidScene::parse(base).unwrap().build().unwrap().options.preconditioner, phonation::solid::Preconditioner::Patches);
    // an explicit step beyond the stability limit is refused with the limit in the reason
    let e = SolidScene::parse(&base.replacen("gravity = ", "time_step = 1.0e-3\ngravity = ", 1)).unwrap().build().unwrap_err();
    println!("{e}");
    assert_eq!(e.field, "solid.time_step");
    // a periodic box shorter than two influence radii is refused
    let m = Orthotropic::isotropic(1.0e6, 0.3, 1.0, 0.0);
    let e = SolidSolver::new(block(3, [4, 4, 4], 0.1, &m), vec![m], SolidOptions { periods: [Some(0.4), None, None], ..Default::default() }).unwrap_err();
    println!("{e}");
    assert_eq!(e.field, "solid.periods");
    // a short run writes the CSV (one row per output, probes), snapshots and the summary
    let dir = std::env::temp_dir().join("phonation_solid_scene_test");
    let _ = std::fs::remove_dir_all(&dir);
    let sc = SolidScene::parse(base).unwrap();
    let r = run_solid_scene(&sc, &dir, &phonation::run::RunOptions { steps: Some(400), backend: phonation::run::Backend::Cpu, ..Default::default() }).unwrap();
    let csv = std::fs::read_to_string(dir.join("solid.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert!(rows[0].contains("left_ux") && rows[0].contains("right_ux"));
    assert_eq!(rows.len(), 1 + 1 + 400 / 20);
    let last: Vec<f64> = rows.last().unwrap().split(',').map(|x| x.parse().unwrap()).collect();
    // by t = 3.6 ms the blocks (gap 0.1 cm closing at 100 cm/s) have met and rebounded: the run
    // is mirror-symmetric (P_x = 0, u_left = −u_right), the overlap stayed small, and the kinetic
    // energy (initially 2500 erg per unit depth) went partly into vibration
    println!("last row: {last:?}");
    assert!(last[6].abs() < 1e-9 && (last[15] + last[18]).abs() < 1e-12 && last[14] < 0.1 && last[2] < 2500.0, "{last:?}");
    assert!(r.instability.is_none() && dir.join("summary.json").exists() && r.files.iter().filter(|f| f.extension().is_some_and(|e| e == "vtk")).count() >= 10);
}
