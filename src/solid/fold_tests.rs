//! Tests of the fold section: its outline, its particles and layers, the cases, its checks.
use super::*;

/// Shoelace area of the outline (fine arcs) against the closed form.
#[test]
fn outline_area_matches_the_closed_form() {
    let f = FoldSection::default();
    f.check("glottis.fold").unwrap();
    let o = f.outline(2000);
    let n = o.len();
    let shoelace = 0.5 * (0..n).map(|i| o[i][0] * o[(i + 1) % n][1] - o[(i + 1) % n][0] * o[i][1]).sum::<f64>();
    assert!((shoelace / f.area() - 1.0).abs() < 1e-6, "outline {shoelace} vs {}", f.area());
    // 0.77 × 0.475 − ½ 0.3 × 0.325 less the two roundings
    assert!((f.area() - 0.317).abs() < 0.003, "{}", f.area());
}

#[test]
fn seed_fold_particles_count_layers_symmetry_and_gap() {
    let f = FoldSection::default();
    let l0 = 0.0042; // the seed's particle spacing
    let p = f.sample(l0, 2.0 * l0);
    let per_fold = p.position.len() / 2;
    // particle count = area / l₀² within 2 %
    let expect = f.area() / (l0 * l0);
    assert!((per_fold as f64 / expect - 1.0).abs() < 0.02, "{per_fold} particles per fold, area/l₀² = {expect:.0}");
    // body : cover = 8/9 : 1/9 within 2 %
    let cover = p.layer.iter().filter(|l| **l == Layer::Cover).count() as f64 / p.layer.len() as f64;
    assert!((cover * 9.0 - 1.0).abs() < 0.02, "cover fraction {cover}");
    // the two folds mirror each other exactly
    for k in 0..per_fold {
        let (a, b) = (p.position[k], p.position[k + per_fold]);
        assert!(a[0] == -b[0] && a[1] == b[1] && p.layer[k] == p.layer[k + per_fold]);
    }
    // minimum gap: the medial particles sit l₀/2 inside each surface
    let right_min = p.position.iter().filter(|q| q[0] > 0.0).map(|q| q[0]).fold(f64::INFINITY, f64::min);
    let left_max = p.position.iter().filter(|q| q[0] < 0.0).map(|q| q[0]).fold(f64::NEG_INFINITY, f64::max);
    assert!(((right_min - left_max) - l0 - f.gap).abs() < 1e-12, "gap {}", right_min - left_max - l0);
    // the fixed particles are the lateral columns only
    let xl = f.gap / 2.0 + f.width;
    assert!(p.position.iter().zip(&p.fixed).all(|(q, &fx)| fx == (xl - q[0].abs() < 2.0 * l0)));
    assert!(p.fixed.iter().filter(|x| **x).count() >= 2 * 2 * (f.height / l0) as usize - 4);
    // the cover runs along the medial surface: the particles nearest the mid-line are cover
    assert!(p.position.iter().zip(&p.layer).filter(|(q, _)| q[0].abs() < f.gap / 2.0 + l0).all(|(_, l)| *l == Layer::Cover));
    // the particles' cover is as thick as the continuous section's, to within half a spacing
    let continuous = f.cover_thickness(l0);
    assert!((p.cover_thickness - continuous).abs() < 0.5 * l0, "cover {} vs {continuous}", p.cover_thickness);
    assert!((continuous - 0.0198).abs() < 0.001, "{continuous}");
}

/// `depth` ranks the segments by squared distance and measures only the nearest with
/// `hypot`: the same value, bit for bit, as the smallest `hypot` over every free segment, at
/// points across the fold, on its outline's vertices (where two segments tie) and at its
/// lateral face.
#[test]
fn the_depth_is_the_smallest_distance_to_every_free_segment_bit_for_bit() {
    let f = FoldSection::default();
    let o = f.outline(64);
    let n = o.len();
    let xl = f.medial() + f.width;
    let brute = |p: [f64; 2]| -> f64 {
        (0..n)
            .filter(|&i| !((o[i][0] - xl).abs() < 1e-12 && (o[(i + 1) % n][0] - xl).abs() < 1e-12))
            .map(|i| dist(p, segment_nearest(p, o[i], o[(i + 1) % n])))
            .fold(f64::INFINITY, f64::min)
    };
    let mut points: Vec<[f64; 2]> = o.clone();
    // uniform in the fold's box, those in the fold kept
    let u = crate::analysis::synthetic::uniform_noise(12345, 2 * 30_000);
    points.extend(u.chunks(2).map(|c| [f.medial() + 0.5 * (c[0] + 1.0) * f.width, 0.5 * (c[1] + 1.0) * f.height]).filter(|p| f.contains(*p)));
    assert!(points.len() > 20_000, "{}", points.len());
    points.extend((0..50).map(|k| [xl, k as f64 * f.height / 49.0]));
    for p in &points {
        assert_eq!(f.depth(*p, &o).to_bits(), brute(*p).to_bits(), "at {p:?}");
    }
    // not all on the outline: the deepest point lies well inside
    let deepest = points.iter().map(|p| f.depth(*p, &o)).fold(0.0, f64::max);
    assert!(deepest > 0.1, "{deepest}");
}

#[test]
fn the_cases_keep_the_body_stiffer_and_b_d_double_a_c() {
    use BodyCoverCase::*;
    for c in [A, B, C, D] {
        let (cover, body) = c.young();
        assert!(body > cover, "{c:?}");
    }
    assert_eq!((B.young().0, B.young().1), (2.0 * A.young().0, 2.0 * A.young().1));
    assert_eq!((D.young().0, D.young().1), (2.0 * C.young().0, 2.0 * C.young().1));
    // the seed's ordering of f0: A < C < B < D
    assert!(A.seed_f0() < C.seed_f0() && C.seed_f0() < B.seed_f0() && B.seed_f0() < D.seed_f0());
}

/// The 3D fold at the seed's 0.01 cm spacing holds ≈ 8·10⁵ particles (seed §3.4.3: "about
/// 800000"); at 0.02 cm (fast) the count is the volume over l₀³, the layers and the opening
/// are as read from the seed.
#[test]
fn three_d_fold_count_layers_and_opening() {
    let f = FoldSection::default();
    let seed_count = 2.0 * f.area() * f.length / 0.01f64.powi(3);
    assert!((seed_count / 8.0e5 - 1.0).abs() < 0.15, "{seed_count:.0}");
    let l0 = 0.02;
    let p = f.sample_3d(l0, 1.5 * l0, 0.06);
    let expect = 2.0 * f.area() * f.length / l0.powi(3);
    assert!((p.position.len() as f64 / expect - 1.0).abs() < 0.04, "{} vs {expect:.0}", p.position.len());
    let share = |l: Layer| p.layer.iter().filter(|x| **x == l).count() as f64 / p.layer.len() as f64;
    assert!((share(Layer::Cover) * 9.0 - 1.0).abs() < 0.02, "cover {}", share(Layer::Cover));
    // the quarter ellipse leaves 1 − π/4 of the width × length rectangle outside it
    let ta = share(Layer::Thyroarytenoid) / (1.0 - share(Layer::Cover));
    assert!(ta > 0.1 && ta < 0.3, "thyroarytenoid share of the non-cover {ta}");
    // gap: G at the anterior end, G + 0.06 at the posterior end (medial particles l₀/2 in)
    let gap_at = |y_lo: f64, y_hi: f64| {
        let right = p.position.iter().filter(|q| q[0] > 0.0 && q[1] > y_lo && q[1] < y_hi).map(|q| q[0]).fold(f64::INFINITY, f64::min);
        2.0 * right - l0
    };
    assert!((gap_at(0.0, l0) - (f.gap + 0.06 * 0.5 * l0 / f.length)).abs() < 1e-9, "{}", gap_at(0.0, l0));
    assert!((gap_at(f.length - l0, f.length) - (f.gap + 0.06 * (1.0 - 0.5 * l0 / f.length))).abs() < 1e-9);
    // the posterior end holds the cover free, the body fixed
    let lateral_face = |q: [f64; 3]| f.gap / 2.0 + f.width + 0.5 * 0.06 * q[1] / f.length - q[0].abs() < 1.5 * l0;
    let post: Vec<usize> = (0..p.position.len()).filter(|&i| p.position[i][1] > f.length - l0 && !lateral_face(p.position[i])).collect();
    assert!(post.len() > 100);
    assert!(post.iter().all(|&i| p.fixed[i] == (p.layer[i] != Layer::Cover)));
}

#[test]
fn impossible_folds_are_refused_with_the_field() {
    let cases = [
        (FoldSection { d: Some(0.8), ..Default::default() }, "fold.d"),
        (FoldSection { gap: 0.0, ..Default::default() }, "fold.gap"),
        (FoldSection { t1: 0.9, ..Default::default() }, "fold.t1"),
        (FoldSection { t2: 0.5, ..Default::default() }, "fold.t2"),
        (FoldSection { r1: 0.4, ..Default::default() }, "fold.r1"),
        (FoldSection { width: f64::NAN, ..Default::default() }, "fold.width"),
    ];
    for (f, field) in cases {
        let e = f.check("fold").unwrap_err();
        assert_eq!(e.field, field, "{e}");
    }
}
