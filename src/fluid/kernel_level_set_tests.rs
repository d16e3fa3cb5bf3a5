//! Tests of [`super::KernelLevelSet`]: the bins, the sums against brute force, the early stop,
//! the weights and the wall velocity.

use super::*;

/// [`KernelLevelSet::new`]'s loops on the pool's threads give the bins, the bin-ordered
/// points and the bins' sums of one thread bit for bit (and so the same L everywhere):
/// 50,000 scattered points, many times `PAR_POINTS`, on one thread and on four.
#[test]
fn the_bins_built_on_the_pool_are_one_threads_bit_for_bit() {
    let n = 50_000;
    let pts: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let f = i as f64;
            [(f * 0.618_034).fract() * 40.0 - 3.3, (f * 0.414_213).fract() * 25.0 + 1.1, (f * 0.732_05).fract() * 30.0]
        })
        .collect();
    let vel: Vec<[f64; 3]> = (0..n).map(|i| [i as f64 * 1e-3, 0.0, -1.0]).collect();
    let build = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| KernelLevelSet::new(pts.clone(), vel.clone(), 1.5, 0.5, 0.7))
    };
    let (one, four) = (build(1), build(4));
    let bits = |v: &[[f64; 3]]| v.iter().flat_map(|x| x.map(f64::to_bits)).collect::<Vec<u64>>();
    assert_eq!(one.bin_box(), four.bin_box());
    assert_eq!(one.bin_lists(), four.bin_lists());
    assert_eq!(bits(&one.sorted), bits(&four.sorted));
    let sums = |s: &KernelLevelSet| s.bin_sums.iter().flat_map(|x| x.map(f64::to_bits)).collect::<Vec<u64>>();
    assert_eq!(sums(&one), sums(&four));
    assert!(one.bin_lists().0.len() > 10_000, "{} bins", one.bin_lists().0.len());
    for p in [[5.0, 7.0, 3.0], [17.3, 12.2, 29.9], [-3.0, 1.5, 0.0]] {
        assert_eq!(one.level(p).0.to_bits(), four.level(p).0.to_bits(), "L at {p:?}");
    }
}

/// A single particle: L = r_e/r − 1 − φ, zero at r = r_e/(1 + φ); the distance estimate
/// −L/|∇L| is exact to first order there, the normal radial, the velocity the particle's.
#[test]
fn one_particle_gives_a_circle_of_the_expected_radius() {
    let (re, phi) = (2.0, 1.0);
    let s = KernelLevelSet::new(vec![[5.0, 5.0, 0.0]], vec![[0.1, -0.2, 0.0]], re, 0.25, phi);
    let r0 = re / (1.0 + phi);
    let (l, _) = s.level([5.0 + r0, 5.0, 0.0]);
    assert!(l.abs() < 1e-14, "{l}");
    // Slightly outside: sign and first-order distance; inside, deep or not: the distance
    // to the circle (Newton steps), where −L/|∇L| would say 0.33 at half the radius.
    let d = s.sdf([5.0 + r0 + 0.01, 5.0, 0.0]);
    assert!((d - 0.01).abs() < 2e-4, "{d}");
    for depth in [0.01, 0.3, 0.5] {
        let d = s.sdf([5.0 + r0 - depth, 5.0, 0.0]);
        assert!((d + depth).abs() < 1e-9, "{depth}: {d}");
    }
    let n = s.normal([5.0, 5.0 + 0.7, 0.0]);
    assert!((n[1] - 1.0).abs() < 1e-12 && n[0].abs() < 1e-12, "{n:?}");
    let v = s.velocity_at([5.5, 5.0, 0.0]);
    assert!((v[0] - 0.1).abs() < 1e-15 && (v[1] + 0.2).abs() < 1e-15, "{v:?}");
    // Far away: positive, no particle seen.
    assert!(s.sdf([20.0, 20.0, 0.0]) > 10.0);
    assert_eq!(s.weights([20.0, 20.0, 0.0]).count(), 0);
}

/// The binned kernel sum equals the sum over every particle (a scattered cloud, points
/// in and out of its box), and, bit for bit, the sum over the bins' particles in index order.
#[test]
fn the_binned_sum_sees_every_particle_within_reach() {
    let pts: Vec<[f64; 3]> = (0..300)
        .map(|k| {
            let t = k as f64 * 0.618_033_988_75;
            [10.0 + 6.0 * (t * 7.1).sin() * t.fract(), 9.0 + 5.0 * (t * 3.3).cos() * (1.0 - t.fract()), 0.0]
        })
        .collect();
    let s = KernelLevelSet::new(pts.clone(), vec![[0.0; 3]; pts.len()], 2.2, 0.1, 3.0);
    for k in 0..200 {
        let p = [2.0 + 0.09 * k as f64, 1.0 + 0.085 * k as f64, 0.0];
        let brute: f64 = pts
            .iter()
            .map(|x| {
                let r = ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2)).sqrt();
                if r <= 2.2 { 2.2 / r.max(0.1) - 1.0 } else { 0.0 }
            })
            .sum::<f64>()
            - 3.0;
        let (l, g) = s.level(p);
        assert!((l - brute).abs() < 1e-9 * brute.abs().max(1.0), "{p:?}: {l} vs {brute}");
        // the same sums, bit for bit, as over `candidates` (the bins' particles through `order`
        // and `points`, where `level` reads the bin-ordered copy)
        let (mut l_ref, mut g_ref) = (-s.phi, [0.0; 3]);
        for j in s.candidates(p) {
            let d = [p[0] - pts[j][0], p[1] - pts[j][1], p[2] - pts[j][2]];
            let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if r <= s.re {
                l_ref += s.re / r.max(s.r_min) - 1.0;
                if r > s.r_min {
                    (0..3).for_each(|a| g_ref[a] += -s.re / (r * r * r) * d[a]);
                }
            }
        }
        assert_eq!((l.to_bits(), g.map(f64::to_bits)), (l_ref.to_bits(), g_ref.map(f64::to_bits)), "{p:?}");
        assert_eq!(s.weights(p).count(), pts.iter().filter(|x| ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2)).sqrt() <= 2.2).count());
    }
}

/// In 3D, with particles and points on bin edges and exactly r_e apart (a lattice of
/// particles, spacing 0.4, r_e = 1, probed at the particles, at r_e from them along axes and
/// diagonals, and scattered): the binned sums equal the sums over every particle,
/// `weights` finds exactly the particles within r_e, `level_value` is `level`'s L bit for
/// bit, and `outside_distance` stops early (`sums`) exactly where L > 0.
#[test]
fn the_binned_sums_see_every_particle_within_reach_in_3d() {
    let mut pts = Vec::new();
    for k in -12..=12 {
        for j in -12..=12 {
            for i in -12..=12 {
                let x = [0.4 * i as f64, 0.4 * j as f64, 0.4 * k as f64];
                if x[0] * x[0] + x[1] * x[1] + x[2] * x[2] <= 16.0 {
                    pts.push([x[0] + 7.0, x[1] + 7.0, x[2] + 7.0]);
                }
            }
        }
    }
    let (re, r_min) = (1.0, 0.5);
    // velocities that differ from particle to particle, so that a sum over the wrong particles
    // or in another order shows
    let vel: Vec<[f64; 3]> = (0..pts.len()).map(|j| [(j as f64 * 0.37).sin(), (j as f64 * 0.11).cos(), 1e-3 * j as f64]).collect();
    let s = KernelLevelSet::new(pts.clone(), vel.clone(), re, r_min, 2.0);
    let mut probes = Vec::new();
    for (n, x) in pts.iter().enumerate().step_by(7) {
        let unit = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.6, 0.8, 0.0], [0.0, 0.6, -0.8]][n % 5];
        probes.push([x[0] + re * unit[0], x[1] + re * unit[1], x[2] + re * unit[2]]);
        probes.push(*x);
    }
    for k in 0..3000 {
        let t = k as f64;
        probes.push([7.0 + 5.0 * (t * 0.731).sin(), 7.0 + 5.0 * (t * 0.397).cos(), 7.0 + 5.0 * (t * 0.113).sin()]);
    }
    let mut inside = 0;
    for p in &probes {
        let within: Vec<&[f64; 3]> = pts.iter().filter(|x| ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2) + (x[2] - p[2]).powi(2)).sqrt() <= re).collect();
        let brute: f64 =
            within.iter().map(|x| re / ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2) + (x[2] - p[2]).powi(2)).sqrt().max(r_min) - 1.0).sum::<f64>() - s.phi;
        assert_eq!(s.weights(*p).count(), within.len(), "{p:?}");
        // the weights read from the bin-ordered positions: the candidates' own positions'
        // weights, one at a time, in the same order, bit for bit
        let one_by_one: Vec<(usize, u64)> = s
            .candidates(*p)
            .filter_map(|j| {
                let x = pts[j];
                let r = ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2) + (x[2] - p[2]).powi(2)).sqrt();
                (r <= re).then(|| (j, (re / r.max(r_min) - 1.0).to_bits()))
            })
            .collect();
        assert_eq!(s.weights(*p).map(|(j, w)| (j, w.to_bits())).collect::<Vec<_>>(), one_by_one, "{p:?}");
        // the wall velocity (2.130) from the bin-ordered velocities: the particles' own
        // velocities with those weights, in that order, bit for bit
        let (mut v, mut sum) = ([0.0; 3], 0.0);
        for (j, w) in s.weights(*p) {
            sum += w;
            (0..3).for_each(|a| v[a] += w * vel[j][a]);
        }
        let v = if sum > 0.0 { v.map(|x| x / sum) } else { v };
        assert_eq!(s.velocity_at(*p).map(f64::to_bits), v.map(f64::to_bits), "{p:?}");
        let (l, _) = s.level(*p);
        assert!((l - brute).abs() < 1e-12 * brute.abs().max(1.0), "{p:?}: {l} vs {brute}");
        assert_eq!(s.level_value(*p).to_bits(), l.to_bits(), "{p:?}");
        assert_eq!(s.outside_distance(*p).is_none(), l > 0.0, "{p:?}");
        if l > 0.0 {
            inside += 1;
        }
    }
    assert!(inside > 1000 && inside < probes.len() - 1000, "{inside} of {} inside", probes.len());
}

/// The layout classifies nodes by `outside_distance` and must find the same side and, outside,
/// the same distance as `sdf`, bit for bit: checked at 24 000 points on and around a ball of
/// particles (3D, r_e = 2 cells, clamp r_e/2, φ its surface level) — including points on
/// its contour, where L changes sign — and at a point exactly on a one-particle circle.
#[test]
fn outside_distance_agrees_with_sdf_bit_for_bit() {
    let mut pts = Vec::new();
    for k in -8..8 {
        for j in -8..8 {
            for i in -8..8 {
                let x = [(i as f64 + 0.5) * 0.5, (j as f64 + 0.5) * 0.5, (k as f64 + 0.5) * 0.5];
                if x[0] * x[0] + x[1] * x[1] + x[2] * x[2] < 9.0 {
                    pts.push([x[0] + 10.2, x[1] + 9.7, x[2] + 10.0]);
                }
            }
        }
    }
    let mut s = KernelLevelSet::new(pts.clone(), vec![[0.0; 3]; pts.len()], 2.0, 1.0, 0.0);
    s.phi = s.level([13.2, 9.7, 10.0]).0;
    let (mut inside, mut outside, mut on) = (0, 0, 0);
    for k in 0..24_000 {
        let t = k as f64;
        let p = [10.2 + 4.5 * (t * 0.731).sin(), 9.7 + 4.5 * (t * 0.397).cos(), 10.0 + 4.5 * (t * 0.113).sin()];
        // every tenth point moved onto the contour along its ray from the centre
        let p = if k % 10 == 0 {
            let c = [10.2, 9.7, 10.0];
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let (mut lo, mut hi) = (0.0, 1.5);
            for _ in 0..80 {
                let m = 0.5 * (lo + hi);
                if s.level([c[0] + m * d[0], c[1] + m * d[1], c[2] + m * d[2]]).0 > 0.0 { lo = m } else { hi = m }
            }
            on += 1;
            [c[0] + lo * d[0], c[1] + lo * d[1], c[2] + lo * d[2]]
        } else {
            p
        };
        let d = s.sdf(p);
        match s.outside_distance(p) {
            None => {
                assert!(d < 0.0, "{p:?}: sdf {d} but classified inside");
                inside += 1;
            }
            Some(o) => {
                assert_eq!(o.to_bits(), d.to_bits(), "{p:?}");
                outside += 1;
            }
        }
    }
    assert!(inside > 2000 && outside > 2000 && on == 2400, "{inside} {outside} {on}");
    // on the contour of one particle: L = 0 exactly is outside, with distance 0
    let one = KernelLevelSet::new(vec![[5.0, 5.0, 0.0]], vec![[0.0; 3]], 2.0, 0.25, 1.0);
    assert_eq!(one.level([6.0, 5.0, 0.0]).0, 0.0);
    assert_eq!(one.outside_distance([6.0, 5.0, 0.0]).map(f64::to_bits), Some(one.sdf([6.0, 5.0, 0.0]).to_bits()));
    assert!(one.sdf([5.999, 5.0, 0.0]) < 0.0 && one.outside_distance([5.999, 5.0, 0.0]).is_none());
}

/// (2.130): two particles' velocities mix in the ratio of their kernel weights.
#[test]
fn the_wall_velocity_is_the_normalised_kernel_mean() {
    let s = KernelLevelSet::new(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 2.0, 0.1, 0.5);
    // At x = 0.25: r = 0.25 and 0.75, weights 7 and 5/3.
    let v = s.velocity_at([0.25, 0.0, 0.0]);
    let (a, b) = (7.0, 5.0 / 3.0);
    assert!((v[0] - a / (a + b)).abs() < 1e-14 && (v[1] - b / (a + b)).abs() < 1e-14, "{v:?}");
}
