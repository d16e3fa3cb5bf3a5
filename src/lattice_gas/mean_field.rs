//! The interference operation (seed 002 §3.4) in the Boltzmann (mean-field) approximation: sites
//! independent, each link occupied with its mean probability. This is how far the operation, as
//! the seed defines it, can move the viscosity by itself — the reference that the measured
//! ν(p) of [`super::viscosity`] is read against.
//!
//! One application to velocity c in a cell compares the 4 departing particles of side A with
//! the 4 of side B (the ends of the square diagonals perpendicular to c, [`super::bits`]) and
//! moves every unpaired particle of the sparser side to the denser one. Side A's particles would
//! enter the neighbouring cell along c's first axis and side B's the one along its second (the
//! cell itself when that axis is R), so the operation steers c-particles towards whichever of
//! the two cells already receives more.
//! With mean occupations n_A = n − δ/2 and n_B = n + δ/2 the expected net transfer A → B is
//! F(n, δ) ≈ K(n) δ with K > 0: an anti-diffusion of each population along e = x_B − x_A,
//! perpendicular to c.
//!
//! Viscosity: each moved particle is displaced by e (|e_X| = |e_Y| = 1 for c in the X–Y plane),
//! so with probability p per cell, velocity and diagonal the particle current is
//! j_c = (p K / 16) e (e·∇n_c) (a cell holds 16 sites, one per ℓ⁴). In a shear flow u_Y(X) the
//! equilibrium n_c = d (1 + 2 c·u) has ∇n_c = 2 d c_Y ∂_X u_Y X̂, so the added flux of
//! Y-momentum along X is Σ c_Y j_c,X = (p K / 16) 2 d S ∂_X u_Y with S = Σ c_Y² e_X² over the
//! (velocity, diagonal) pairs ([`shear_weight`]); it runs up the gradient, and with ρ = 24 d per
//! site Δν = −p K S / 192 (ℓ²/step). With c_k's own plane only (the four X–Y velocities, S = 4):
//! Δν = −p K / 48. With every perpendicular diagonal ([`Diagonals::AllPerpendicular`]) the Y–Z
//! and Y–R velocities add two diagonals each in their complementary planes X–R and X–Z (S = 20):
//! Δν = −5 p K / 48.

use super::bits::{Exchange, displacement, exchange_lane, exchanges};
use super::lattice::Diagonals;
use super::velocities::{Q, VELOCITIES};

/// Pairs compared per application: one per square of the family (seed 002 Fig. 2).
pub const PAIRS: usize = 4;

/// Expected net number of particles moved from side A to side B by one application, the
/// 2 × [`PAIRS`] sites independent with occupation probabilities `n_a` (side A) and `n_b`
/// (side B). Exact: a sum over the 3^4 joint states of the pairs (only pairs holding one
/// particle can move; the sparser side's unpaired particles move to the denser side).
pub fn net_transfer(n_a: f64, n_b: f64) -> f64 {
    // per pair: (A only) a, (B only) b, (both or neither) the rest
    let (a, b) = (n_a * (1.0 - n_b), n_b * (1.0 - n_a));
    let rest = 1.0 - a - b;
    let mut total = 0.0;
    for only_a in 0..=PAIRS {
        for only_b in 0..=PAIRS - only_a {
            let ways = multinomial(PAIRS, only_a, only_b);
            let prob = ways * a.powi(only_a as i32) * b.powi(only_b as i32) * rest.powi((PAIRS - only_a - only_b) as i32);
            // B denser: A's unpaired particles move to B; A denser: B's move to A
            total += prob
                * match only_b.cmp(&only_a) {
                    std::cmp::Ordering::Greater => only_a as f64,
                    std::cmp::Ordering::Less => -(only_b as f64),
                    std::cmp::Ordering::Equal => 0.0,
                };
        }
    }
    total
}

fn multinomial(n: usize, i: usize, j: usize) -> f64 {
    let f = |m: usize| (1..=m).product::<usize>() as f64;
    f(n) / (f(i) * f(j) * f(n - i - j))
}

/// K(n) = ∂F/∂δ at δ = 0 (particles per application per unit occupation difference). F is a
/// polynomial of degree 8 in δ, so the central difference with h = 10⁻⁴ is exact to ~10⁻⁹.
pub fn transfer_response(n: f64) -> f64 {
    let h = 1e-4;
    (net_transfer(n - h / 2.0, n + h / 2.0) - net_transfer(n + h / 2.0, n - h / 2.0)) / (2.0 * h)
}

/// Expected change of the number of velocity k's particles on the cell's X-layer b_X = 1 (the
/// vertices with offset +ℓ/2 along X) in one interference pass at probability p, the 16 sites
/// independent with occupation `occupation[b_X]`. Exact: a sum over the 2¹⁶ states of the lane
/// and the subsets of the pass's exchanges that run ([`exchanges`], each with probability p) —
/// the exchanges share sites, so with more than one per velocity their effects do not simply add.
pub fn expected_layer_shift(k: usize, occupation: [f64; 2], p: f64, diagonals: Diagonals) -> f64 {
    let ex = exchanges(k, diagonals);
    let subsets: Vec<(f64, Vec<Exchange>)> = (0..1u32 << ex.len())
        .map(|s| {
            let n = s.count_ones() as i32;
            (p.powi(n) * (1.0 - p).powi(ex.len() as i32 - n), ex.iter().enumerate().filter(|(i, _)| s >> i & 1 == 1).map(|(_, e)| *e).collect())
        })
        .filter(|(w, _)| *w > 0.0)
        .collect();
    let upper = |w: u16| (w & 0xAAAA).count_ones() as f64;
    let mut total = 0.0;
    for w in 0..=u16::MAX {
        let prob: f64 = (0..16).map(|v| if w >> v & 1 == 1 { occupation[v & 1] } else { 1.0 - occupation[v & 1] }).product();
        if prob == 0.0 {
            continue;
        }
        for (weight, run) in &subsets {
            let after = run.iter().fold(w, |x, &(ma, mb, a, b)| exchange_lane(x, ma, mb, a, b));
            total += prob * weight * (upper(after) - upper(w));
        }
    }
    total
}

/// M_k = ∂⟨ΔN⟩/∂g: the expected X displacement (ℓ per pass, summed over a cell's particles of
/// velocity k) per unit occupation gradient g along X (per ℓ), at density d and probability p;
/// positive: particles move up their own gradient. ⟨ΔN⟩ is a polynomial in g; the central
/// difference with h = 10⁻⁴ is exact to a relative ~10⁻⁷.
pub fn displacement_response(k: usize, density: f64, p: f64, diagonals: Diagonals) -> f64 {
    let h = 1e-4;
    let shift = |g: f64| expected_layer_shift(k, [density - g / 2.0, density + g / 2.0], p, diagonals);
    (shift(h) - shift(-h)) / (2.0 * h)
}

/// Shift of the kinematic viscosity by the interference at probability p, density d per link,
/// in the Boltzmann approximation (ℓ²/step; module documentation): Δν = −Σ_k c_kY² M_k / 192.
/// For [`Diagonals::OwnPlane`] this is −p K(d) / 48; for [`Diagonals::AllPerpendicular`] it is
/// −p K S / 192 with S = 20 to first order in p, less at larger p (the exchanges overlap).
pub fn viscosity_shift(density: f64, interference: f64, diagonals: Diagonals) -> f64 {
    if interference == 0.0 {
        return 0.0;
    }
    let sum: f64 =
        (0..Q).filter(|&k| VELOCITIES[k][1] != 0).map(|k| (VELOCITIES[k][1] as f64).powi(2) * displacement_response(k, density, interference, diagonals)).sum();
    -sum / 192.0
}

/// S = Σ over velocities c and their exchanges e of c_Y² e_X²: how many (velocity, diagonal)
/// pairs carry Y-momentum across X — the first-order (small p) weight of the viscosity shift,
/// Δν ≈ −p K S / 192. 4 for [`Diagonals::OwnPlane`] (the X–Y velocities), 20 for
/// [`Diagonals::AllPerpendicular`] (also the Y–Z and Y–R velocities, whose complementary planes
/// X–R and X–Z hold two diagonals each).
pub fn shear_weight(diagonals: Diagonals) -> f64 {
    (0..Q)
        .flat_map(|k| exchanges(k, diagonals).into_iter().map(move |e| (VELOCITIES[k][1] as i32, displacement(e)[0])))
        .map(|(cy, ex)| (cy * cy * ex * ex) as f64)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lattice_gas::bits::{interfere_lane, interference_sides};
    use crate::lattice_gas::collision::site_random;
    use crate::lattice_gas::lattice::probability_threshold;

    #[test]
    fn the_operation_on_random_cells_transfers_what_the_mean_field_predicts() {
        // closed-form checks of F: nothing moves without a difference, and F is odd in δ
        assert!(net_transfer(0.2, 0.2).abs() < 1e-15);
        assert!((net_transfer(0.15, 0.25) + net_transfer(0.25, 0.15)).abs() < 1e-15);
        // one pair holding one particle on each side only: with a = b = ½, F = 0; with only B
        // occupied (n_a = 0, n_b = 1) nothing is unpaired on A, F = 0
        assert_eq!(net_transfer(0.0, 1.0), 0.0);
        // Monte Carlo of bits::interfere_lane on lanes drawn independently (sides A and B at
        // n ∓ δ/2, the other 8 sites at n) for every velocity: the mean change of side B's count
        // equals F. 2·10⁵ lanes per case; the count change has standard deviation < 1.5, so the
        // standard error is < 3.4e-3.
        for &(n, delta) in &[(0.2, 0.1), (0.2, -0.1), (0.4, 0.2), (0.1, 0.05)] {
            let expected = net_transfer(n - delta / 2.0, n + delta / 2.0);
            for k in [0, 5, 11, 22] {
                let (mask_a, mask_b) = interference_sides(k);
                let (ta, tb, t) = (probability_threshold(n - delta / 2.0), probability_threshold(n + delta / 2.0), probability_threshold(n));
                let samples = 200_000u32;
                let mut moved = 0i64;
                for s in 0..samples {
                    let mut w = 0u16;
                    for v in 0..16 {
                        let threshold = if mask_a >> v & 1 == 1 {
                            ta
                        } else if mask_b >> v & 1 == 1 {
                            tb
                        } else {
                            t
                        };
                        if site_random(k as u32, s, v) < threshold {
                            w |= 1 << v;
                        }
                    }
                    let after = interfere_lane(w, k);
                    assert_eq!(after.count_ones(), w.count_ones());
                    assert_eq!(after & !(mask_a | mask_b), w & !(mask_a | mask_b), "only the diagonal ends change");
                    moved += (after & mask_b).count_ones() as i64 - (w & mask_b).count_ones() as i64;
                }
                let mean = moved as f64 / samples as f64;
                println!("n = {n}, δ = {delta}, velocity {k}: transfer A→B {mean:.4} (mean field {expected:.4})");
                assert!((mean - expected).abs() < 0.012, "velocity {k}: {mean} vs {expected}");
            }
            // the transfer runs towards the denser side
            assert!(expected * delta > 0.0);
        }
    }

    #[test]
    fn the_mean_field_viscosity_shift_is_a_few_percent_at_most() {
        // K(n) rises with n up to half filling and is symmetric about it (particle–hole)
        let k: Vec<f64> = [0.1, 0.2, 0.3, 0.5, 0.7, 0.8].iter().map(|&n| transfer_response(n)).collect();
        println!("K(n) for n = 0.1, 0.2, 0.3, 0.5, 0.7, 0.8: {k:.4?}");
        assert!(k[0] < k[1] && k[1] < k[2] && k[2] < k[3]);
        assert!((k[1] - k[5]).abs() < 1e-6 && (k[2] - k[4]).abs() < 1e-6);
        // the slope agrees with a finite difference of F over a larger δ (F is smooth)
        assert!((net_transfer(0.19, 0.21) / 0.02 - k[1]).abs() < 1e-3 * k[1].abs().max(1.0));
        // at d = 0.2 and p = 1 the operation lowers ν by ≈ 0.0052 ℓ²/step: 2.6 % of the
        // Boltzmann value 0.20 (../shared/reference)
        let shift = viscosity_shift(0.2, 1.0, Diagonals::OwnPlane);
        println!("Δν(d = 0.2, p = 1) = {shift:.5} ℓ²/step; at d = 0.5: {:.5}", viscosity_shift(0.5, 1.0, Diagonals::OwnPlane));
        assert!(shift < 0.0 && shift > -0.006 && shift < -0.004, "Δν = {shift}");
        assert!(viscosity_shift(0.5, 1.0, Diagonals::OwnPlane) > -0.012);
        // the enumeration over lane states reproduces the pair formula for the own plane
        let (enumerated, pairs) = (viscosity_shift(0.3, 0.7, Diagonals::OwnPlane), -0.7 * transfer_response(0.3) / 48.0);
        println!("Δν(0.3, 0.7): lane enumeration {enumerated:.10}, pair formula {pairs:.10}");
        assert!((enumerated / pairs - 1.0).abs() < 1e-6);
        // every perpendicular diagonal: S = 20 (own plane 4), so five times the shift at small
        // p; at larger p less (the exchanges of a pass share sites): Δν = −0.0217 at d = 0.2,
        // p = 1 (10.6 % of ν), −0.042 at d = 0.5 — still far from turning ν negative
        assert_eq!((shear_weight(Diagonals::OwnPlane), shear_weight(Diagonals::AllPerpendicular)), (4.0, 20.0));
        let small = viscosity_shift(0.2, 0.01, Diagonals::AllPerpendicular) / viscosity_shift(0.2, 0.01, Diagonals::OwnPlane);
        let all = viscosity_shift(0.2, 1.0, Diagonals::AllPerpendicular);
        println!(
            "every perpendicular diagonal: Δν(0.2, 1) = {all:.5}, Δν(0.5, 1) = {:.5}; ratio to the own plane {small:.4} at p = 0.01, {:.4} at p = 1",
            viscosity_shift(0.5, 1.0, Diagonals::AllPerpendicular),
            all / shift
        );
        assert!((small / 5.0 - 1.0).abs() < 0.01, "{small}");
        assert!(all / shift > 3.5 && all / shift < 5.0 && all > -0.03);
        // the weight is the same for every pair of distinct spatial axes (cubic symmetry): Y
        // momentum across X equals Z momentum across Y, here counted directly
        for (m, g) in [(2, 1), (0, 2), (1, 0)] {
            for diagonals in [Diagonals::OwnPlane, Diagonals::AllPerpendicular] {
                let w: i32 = (0..Q)
                    .flat_map(|q| exchanges(q, diagonals).into_iter().map(move |e| (VELOCITIES[q][m] as i32, displacement(e)[g])))
                    .map(|(c, e)| c * c * e * e)
                    .sum();
                assert_eq!(w as f64, shear_weight(diagonals), "momentum {m} across {g}, {diagonals:?}");
            }
        }
    }

    #[test]
    fn on_an_equilibrium_shear_wave_the_operation_moves_momentum_up_the_gradient_at_the_mean_field_rate() {
        // A shear wave u_Y = U sin(k x) filled as the product measure (each link independent,
        // probability d (1 + 2 c·u)); one interference pass (no propagation, so the state is the
        // mean field's). The mode of the Y-momentum, projected on the site layers x = 2X ∓ ½,
        // grows by ΔA/A = (p K S / 192) · 4 sin²(k/2) — the Δν = −p K S / 192 of
        // `viscosity_shift` with the lattice Laplacian of jumps by one site, to O(δ²): with
        // U = 0.2 and k = 2π / 8 sites the exact F, summed over the pairs, gives 2.6 % less. At
        // p = 0.5 the operation runs in half the (cell, velocity) pairs: half the growth. With
        // every perpendicular diagonal the growth is S = 20 against 4: five times the own plane's.
        use crate::lattice_gas::lattice::LatticeGas;
        let (nx, n, d, u) = (4usize, 8usize, 0.2, 0.2);
        let k = std::f64::consts::PI / nx as f64;
        let mode = |g: &LatticeGas| {
            // Σ over sites of c_Y · sin(k x) per occupied link, over the sites of a layer × layers / 2
            let mut m = 0.0;
            for cell in 0..g.cells() {
                let x0 = 2.0 * g.coords(cell)[0] as f64;
                for q in (0..Q).filter(|&q| VELOCITIES[q][1] != 0) {
                    let w = g.cell_word(q, cell);
                    let (low, high) = ((w & 0x5555).count_ones() as f64, (w & 0xAAAA).count_ones() as f64);
                    m += VELOCITIES[q][1] as f64 * (low * (k * (x0 - 0.5)).sin() + high * (k * (x0 + 0.5)).sin());
                }
            }
            m * 2.0 / (g.cells() * 16) as f64
        };
        // the mode's growth per pass at probability p over `fills` fresh fills, relative to the
        // mode: (mean, standard error, mean mode)
        let growth = |p: f64, diagonals: Diagonals, fills: u32| {
            let (mut sum, mut sum2, mut a0) = (0.0, 0.0, 0.0);
            for f in 0..fills {
                let mut g = LatticeGas::new([nx, n, n], f, p);
                g.diagonals = diagonals;
                g.fill(d, |x| [0.0, u * (k * x[0]).sin(), 0.0, 0.0], 1000 + f);
                let before = mode(&g);
                g.interfere();
                let change = mode(&g) - before;
                a0 += before;
                sum += change;
                sum2 += change * change;
            }
            let m = fills as f64;
            let (mean, a0) = (sum / m, a0 / m);
            (mean / a0, ((sum2 / m - mean * mean) / (m - 1.0)).sqrt() / a0, a0)
        };
        // the same, exact for the product measure: per cell and velocity the expected change of
        // the count on the upper X layer (expected_layer_shift, all 2¹⁶ lane states), each
        // moved particle changing the mode by c_Y (sin k x₁ − sin k x₀); the site layers are
        // x = 2X ∓ ½. For the own plane this equals the pair formula F.
        let exact = |p: f64, diagonals: Diagonals| {
            let mut sum = 0.0;
            for x in 0..nx {
                let (x0, x1) = (2.0 * x as f64 - 0.5, 2.0 * x as f64 + 0.5);
                for q in (0..Q).filter(|&q| VELOCITIES[q][1] != 0) {
                    let cy = VELOCITIES[q][1] as f64;
                    let occupation = |x: f64| d * (1.0 + 2.0 * cy * u * (k * x).sin());
                    sum += cy * ((k * x1).sin() - (k * x0).sin()) * expected_layer_shift(q, [occupation(x0), occupation(x1)], p, diagonals);
                }
            }
            // `mode` weighs a particle by 2 / (16 · cells); every one of the n² cells of a column
            // X adds the same, so the sum over X is divided by 8 nx — and by the mode, 24 d U
            sum / (8.0 * nx as f64) / (24.0 * d * u)
        };
        // the own plane's exact rate from the pair formula F: the X–Y velocities c = (s_a, s_b)
        // have side A at x = 2X + s_a/2 and side B at 2X − s_a/2 (bits::interference_sides)
        let mut pairs = 0.0;
        for x in 0..nx {
            for (sa, sb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                let (xa, xb) = (2.0 * x as f64 + sa / 2.0, 2.0 * x as f64 - sa / 2.0);
                let occupation = |x: f64| d * (1.0 + 2.0 * sb * u * (k * x).sin());
                pairs += sb * ((k * xb).sin() - (k * xa).sin()) * net_transfer(occupation(xa), occupation(xb));
            }
        }
        let pairs = pairs / (8.0 * nx as f64) / (24.0 * d * u);
        assert!((pairs / exact(1.0, Diagonals::OwnPlane) - 1.0).abs() < 1e-9, "{pairs} vs {}", exact(1.0, Diagonals::OwnPlane));
        let laplacian = 4.0 * (k / 2.0).sin().powi(2);
        let mut full_rates = Vec::new();
        for diagonals in [Diagonals::OwnPlane, Diagonals::AllPerpendicular] {
            let (full, se, a0) = growth(1.0, diagonals, 4000);
            let predicted = -viscosity_shift(d, 1.0, diagonals) * laplacian;
            let exact_full = exact(1.0, diagonals);
            // the viscosity change this growth stands for: Δν = −growth / (4 sin²(k/2))
            println!(
                "{diagonals:?}: mode {a0:.4} (24 d U = {:.4}); growth per pass at p = 1: {full:.3e} ± {se:.1e} of the mode (Δν = {:.5} ± {:.5}); mean field {exact_full:.3e} (linear in δ: {predicted:.3e})",
                24.0 * d * u,
                -full / laplacian,
                se / laplacian
            );
            assert!((a0 / (24.0 * d * u) - 1.0).abs() < 0.02, "the fill carries the wave");
            assert!((full - exact_full).abs() < 4.0 * se, "{full} vs {exact_full}");
            // the linear rate (the viscosity shift) differs from the exact one by the O(δ²) terms only
            assert!(exact_full < predicted && exact_full > 0.97 * predicted);
            // applied with probability p per cell, velocity and diagonal: half the transfer at
            // p = 0.5 for the own plane, more than half with overlapping exchanges
            let (half, se_half, _) = growth(0.5, diagonals, 4000);
            let exact_half = exact(0.5, diagonals);
            println!("  p = 0.5: {half:.3e} ± {se_half:.1e} (Δν = {:.5}); mean field {exact_half:.3e}; ratio to p = 1: {:.3}", -half / laplacian, half / full);
            assert!((half - exact_half).abs() < 4.0 * se_half, "{half} vs {exact_half}");
            full_rates.push((full, se));
        }
        // every perpendicular diagonal moves 4.3 times the own plane's momentum: less than the
        // S = 20 / 4 of independent exchanges, since the later exchanges of a pass see the
        // pairs the earlier ones correlated
        let ((own, se_own), (all, se_all)) = (full_rates[0], full_rates[1]);
        let ratio = all / own;
        let se_ratio = ratio * ((se_own / own).powi(2) + (se_all / all).powi(2)).sqrt();
        let shifts = viscosity_shift(d, 1.0, Diagonals::AllPerpendicular) / viscosity_shift(d, 1.0, Diagonals::OwnPlane);
        println!("all perpendicular / own plane: {ratio:.3} ± {se_ratio:.3} (mean-field shifts {shifts:.3}; independent exchanges 5)");
        assert!(ratio > 3.5 && ratio < 5.0 && shifts > 3.5 && shifts < 5.0);
    }
}
