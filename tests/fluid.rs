//! Validation of the FDLB fluid on the CPU (issue: foundation). Every test asserts a figure
//! against an analytic or published reference (../shared/reference).

use phonation::fluid::velocity_set::{D3Q39_F31_AS_EXTRACTED, Shell};
use phonation::fluid::*;

/// Gauss–Hermite rule for the standard normal weight e^{−x²/2}/√(2π): nodes are the roots of
/// the probabilists' Hermite polynomial He_n (bisection), weights n!/(n² He_{n−1}(x)²). With
/// n = 10 it is exact for polynomials of degree ≤ 19.
fn gauss_hermite(n: usize) -> Vec<(f64, f64)> {
    let he = |k: usize, x: f64| -> f64 {
        let (mut a, mut b) = (1.0, x);
        if k == 0 {
            return a;
        }
        for j in 1..k {
            let c = x * b - j as f64 * a;
            a = b;
            b = c;
        }
        b
    };
    let fact: f64 = (1..=n).map(|k| k as f64).product();
    let mut out = Vec::new();
    let steps = 24000;
    for i in 0..steps {
        let (mut a, mut b) = (-12.0 + 24.0 * i as f64 / steps as f64, -12.0 + 24.0 * (i + 1) as f64 / steps as f64);
        if he(n, a) * he(n, b) > 0.0 {
            continue;
        }
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if he(n, a) * he(n, m) <= 0.0 { b = m } else { a = m }
        }
        let x = 0.5 * (a + b);
        if out.last().is_some_and(|(y, _): &(f64, f64)| (x - y).abs() < 1e-9) {
            continue;
        }
        out.push((x, fact / ((n * n) as f64 * he(n - 1, x).powi(2))));
    }
    assert_eq!(out.len(), n);
    out
}

/// ∫ g(c) M(c) dc for the Maxwellian of temperature θ and velocity u (density 1), via
/// tensor Gauss–Hermite quadrature (exact for polynomial g of degree ≤ 19).
fn maxwellian_moment(dim: usize, theta: f64, u: [f64; 3], g: &dyn Fn([f64; 3]) -> f64) -> f64 {
    let gh = gauss_hermite(10);
    let s = theta.sqrt();
    let mut total = 0.0;
    for &(x, wx) in &gh {
        for &(y, wy) in &gh {
            if dim == 2 {
                total += wx * wy * g([u[0] + s * x, u[1] + s * y, 0.0]);
            } else {
                for &(z, wz) in &gh {
                    total += wx * wy * wz * g([u[0] + s * x, u[1] + s * y, u[2] + s * z]);
                }
            }
        }
    }
    total
}

fn monomials(dim: usize, order: usize) -> Vec<[usize; 3]> {
    let mut out = Vec::new();
    for a in 0..=order {
        for b in 0..=(order - a) {
            let c = order - a - b;
            if dim == 2 && c != 0 {
                continue;
            }
            out.push([a, b, c]);
        }
    }
    out
}

fn mono(c: [f64; 3], p: [usize; 3]) -> f64 {
    c[0].powi(p[0] as i32) * c[1].powi(p[1] as i32) * c[2].powi(p[2] as i32)
}

/// Largest |Σ w_i c_i^p − ∫ M c^p| over monomials of `order` at rest (lattice isotropy).
fn isotropy_error(set: &VelocitySet, t: f64, order: usize) -> f64 {
    let w = set.weights(t);
    monomials(set.dim, order)
        .iter()
        .map(|&p| {
            let lat: f64 = set.c.iter().zip(&w).map(|(c, w)| w * mono([c[0] as f64, c[1] as f64, c[2] as f64], p)).sum();
            let cont = maxwellian_moment(set.dim, t, [0.0; 3], &|c| mono(c, p));
            (lat - cont).abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn equilibrium_weights_are_isotropic_through_the_designed_order() {
    let d2 = VelocitySet::new(VelocitySetKind::D2q21);
    let d3 = VelocitySet::new(VelocitySetKind::D3q39);
    for t in [0.4, 0.5, 0.6, 0.8, 1.0, 1.1] {
        for order in 0..=6 {
            let e = isotropy_error(&d2, t, order);
            assert!(e < 1e-12, "D2Q21 T={t} order {order}: {e}");
        }
    }
    for t in [0.45, 0.55, 2.0 / 3.0, 0.8] {
        for order in 0..=5 {
            let e = isotropy_error(&d3, t, order);
            assert!(e < 1e-12, "D3Q39 T={t} order {order}: {e}");
        }
    }
    // 6th order: exact only at T = 2/3 (Shan's D3Q39), not elsewhere.
    assert!(isotropy_error(&d3, 2.0 / 3.0, 6) < 1e-12);
    assert!(isotropy_error(&d3, 0.5, 6) > 1e-4);
    // Shan's weights at T = 2/3.
    let shan = [("F0", 1.0 / 12.0), ("F11", 1.0 / 12.0), ("F12", 2.0 / 135.0), ("F13", 1.0 / 1620.0), ("F22", 1.0 / 432.0), ("F31", 1.0 / 27.0)];
    for (name, w) in shan {
        let s = d3.shells.iter().find(|s| s.name == name).unwrap();
        assert!((s.weight(2.0 / 3.0) - w).abs() < 1e-14, "{name}");
    }
}

#[test]
fn seed_text_f31_breaks_mass_conservation() {
    // (2.95) as extracted: Σw − 1 = 2T²(7T − 8)/5 ≠ 0; the corrected sign conserves mass.
    let d3 = VelocitySet::new(VelocitySetKind::D3q39);
    let mut shells: Vec<Shell> = d3.shells.clone();
    let k = shells.iter().position(|s| s.name == "F31").unwrap();
    shells[k] = D3Q39_F31_AS_EXTRACTED;
    let literal = VelocitySet::from_shells(VelocitySetKind::D3q39, 3, &shells);
    for t in [0.5, 0.6, 0.7] {
        let sum: f64 = literal.weights(t).iter().sum();
        assert!((sum - 1.0 - 2.0 * t * t * (7.0 * t - 8.0) / 5.0).abs() < 1e-13);
        let fixed: f64 = d3.weights(t).iter().sum();
        assert!((fixed - 1.0).abs() < 1e-14);
    }
}

#[test]
fn equilibrium_moments_equal_the_maxwellian() {
    for kind in [VelocitySetKind::D2q21, VelocitySetKind::D3q39] {
        let set = VelocitySet::new(kind);
        let dim = set.dim;
        let (lo, hi) = set.positivity_window();
        let eq = Equilibrium::new(set.clone(), GasModel::Monatomic);
        let mut w = vec![0.0; 6];
        let mut f = vec![0.0; eq.q()];
        for &rho in &[0.5, 1.0, 1.7] {
            for &t in &[lo + 0.02, 0.6, 2.0 / 3.0, hi - 0.02] {
                for &u in &[[0.0, 0.0, 0.0], [0.1, -0.05, 0.02], [0.25, 0.1, -0.15]] {
                    let u = if dim == 2 { [u[0], u[1], 0.0] } else { u };
                    let m = Macro { rho, u, theta: t };
                    eq.feq_into(&m, &mut w, &mut f);
                    // Macroscopic moments (2.79–2.81) are recovered exactly.
                    let back = eq.moments(&f);
                    assert!((back.rho - rho).abs() < 1e-12 && (back.theta - t).abs() < 1e-12);
                    for a in 0..3 {
                        assert!((back.u[a] - u[a]).abs() < 1e-12);
                    }
                    // Orders 0–3 equal the Maxwellian's; order 4 up to the u⁴ term the
                    // third-order expansion leaves out. D3Q39 is 6th-order isotropic only at
                    // T = 2/3, so there its orders 3–4 are exact only at that temperature
                    // (elsewhere they err at O(u³), which the 3D heat flux inherits).
                    let shan = (t - 2.0 / 3.0).abs() < 1e-12;
                    let top = if dim == 2 || shan { 4 } else { 2 };
                    for order in 0..=top {
                        for p in monomials(dim, order) {
                            let lat: f64 = set.c.iter().zip(&f).map(|(c, fi)| fi * mono([c[0] as f64, c[1] as f64, c[2] as f64], p)).sum();
                            let maxw = rho * maxwellian_moment(dim, t, u, &|c| mono(c, p));
                            let missing = if order == 4 { rho * mono(u, p) } else { 0.0 };
                            assert!((lat - (maxw - missing)).abs() < 1e-11, "{kind:?} ρ={rho} T={t} u={u:?} moment {p:?}: {lat} vs {}", maxw - missing);
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn weights_are_positive_inside_the_window_and_refused_outside() {
    for kind in [VelocitySetKind::D2q21, VelocitySetKind::D3q39] {
        let set = VelocitySet::new(kind);
        let (lo, hi) = set.positivity_window();
        for k in 1..100 {
            let t = lo + (hi - lo) * k as f64 / 100.0;
            assert!(set.weights(t).iter().all(|w| *w > 0.0), "{kind:?} T={t}");
        }
        assert!(set.weights(lo - 0.01).iter().any(|w| *w < 0.0));
        assert!(set.weights(hi + 0.01).iter().any(|w| *w < 0.0));
    }
}
