//! Tests of the coarse space's probing and correction.
use super::*;

/// On a chain of springs (a 1D Laplacian on both axes plus a mass term, particles 0 and the
/// last clamped: the operator's reach is one spacing), probing recovers Pᵀ A P to round-off —
/// checked against the product formed column by column, rotations included — and the
/// correction inverts A on the coarse space.
#[test]
fn probing_recovers_the_coarse_matrix_of_a_spring_chain() {
    let n = 60;
    let reference: Vec<DVec3> = (0..n).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
    let fixed: Vec<bool> = (0..n).map(|i| i == 0 || i == n - 1).collect();
    let k = |i: usize| 1.0 + 0.1 * (i as f64).sin();
    let apply = |x: &[DVec3], y: &mut [DVec3]| {
        for i in 0..n {
            y[i] = if fixed[i] {
                DVec3::ZERO
            } else {
                let mut f = 0.3 * x[i];
                if i > 0 {
                    f += k(i) * (x[i] - x[i - 1]);
                }
                if i + 1 < n {
                    f += k(i + 1) * (x[i] - x[i + 1]);
                }
                f
            };
        }
    };
    // 2D: six modes; along a chain only four are independent (ε_yy moves nothing, and the
    // rotation and the shear both move y in proportion to x): each aggregate keeps four
    let c = CoarseSpace::build(&reference, &fixed, 2, 1.0, 1.0, apply).expect("positive definite");
    assert_eq!(c.side, 4.0);
    let sizes: Vec<usize> = c.offset.windows(2).map(|w| w[1] - w[0]).collect();
    assert_eq!(sizes, vec![4; 15]);
    // A_c by columns: P e_q, then Pᵀ A P e_q; compare with L Lᵀ
    let m = c.unknowns();
    assert_eq!(m, 15 * 4);
    let CoarseSolve::Dense(l) = &c.solve else { panic!("a dense coarse space") };
    let slot = |q: usize| -> (usize, usize) {
        let j = c.offset.iter().rposition(|&o| o <= q).unwrap();
        (j, q - c.offset[j])
    };
    let column = |q: usize| -> Vec<DVec3> {
        let (j, e) = slot(q);
        (0..n).map(|i| if c.aggregate[i] as usize == j { c.vectors[c.start[i] + e] } else { DVec3::ZERO }).collect()
    };
    let mut worst: f64 = 0.0;
    for q in 0..m {
        let mut y = vec![DVec3::ZERO; n];
        apply(&column(q), &mut y);
        let scale = y.iter().map(|v| v.length()).fold(0.0, f64::max);
        for p in 0..m {
            let want: f64 = column(p).iter().zip(&y).map(|(a, b)| a.dot(*b)).sum();
            let got: f64 = (0..=p.min(q)).map(|s| l[p * m + s] * l[q * m + s]).sum();
            worst = worst.max((got - want).abs() / scale);
        }
    }
    assert!(worst < 1e-12, "A_c off by {worst:e}");
    // the correction of a residual that is A P v for a coarse vector v gives back P v
    let v: Vec<f64> = (0..m).map(|q| (q as f64 * 0.7).cos()).collect();
    let mut px = vec![DVec3::ZERO; n];
    for (q, vq) in v.iter().enumerate() {
        for (x, col) in px.iter_mut().zip(column(q)) {
            *x += *vq * col;
        }
    }
    let mut apx = vec![DVec3::ZERO; n];
    apply(&px, &mut apx);
    let mut z = vec![DVec3::ZERO; n];
    c.add_correction(&apx, &mut z);
    let err = z.iter().zip(&px).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
    assert!(err < 1e-10, "P A_c⁻¹ Pᵀ A P v = P v off by {err:e}");
}
