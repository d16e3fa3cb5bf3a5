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
//! so with probability p per cell and velocity the particle current is j_c = (p K / 16) e (e·∇n_c)
//! (a cell holds 16 sites, one per ℓ⁴). In a shear flow u_Y(X) only the four X–Y velocities carry
//! Y-momentum along X, and their equilibrium n_c = d (1 + 2 c·u) gives Σ c_Y n_c = ρ u_Y / 3
//! (ρ = 24 d per site). The added flux Σ c_Y j_c,X = (p K / 48) ρ ∂_X u_Y runs up the gradient:
//! Δν = −p K / 48 (ℓ²/step).

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

/// Shift of the kinematic viscosity by the interference at probability p, density d per link,
/// in the Boltzmann approximation: Δν = −p K(d) / 48 (ℓ²/step; module documentation).
pub fn viscosity_shift(density: f64, interference: f64) -> f64 {
    -interference * transfer_response(density) / 48.0
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
        let shift = viscosity_shift(0.2, 1.0);
        println!("Δν(d = 0.2, p = 1) = {shift:.5} ℓ²/step; at d = 0.5: {:.5}", viscosity_shift(0.5, 1.0));
        assert!(shift < 0.0 && shift > -0.006 && shift < -0.004, "Δν = {shift}");
        assert!(viscosity_shift(0.5, 1.0) > -0.012);
    }

    #[test]
    fn on_an_equilibrium_shear_wave_the_operation_moves_momentum_up_the_gradient_at_the_mean_field_rate() {
        // A shear wave u_Y = U sin(k x) filled as the product measure (each link independent,
        // probability d (1 + 2 c·u)); one interference pass at p = 1 (no propagation, so the
        // state is the mean field's). The mode of the Y-momentum, projected on the site layers
        // x = 2X ∓ ½, grows by ΔA/A = (p K / 48) · 4 sin²(k/2) — the Δν = −p K / 48 of
        // `viscosity_shift` with the lattice Laplacian of jumps by one site, to O(δ²): with
        // U = 0.2 and k = 2π / 8 sites the exact F, summed over the pairs, gives 2.6 % less. At
        // p = 0.5 the operation runs in half the (cell, velocity) pairs: half the growth.
        use crate::lattice_gas::lattice::LatticeGas;
        use crate::lattice_gas::velocities::{Q, VELOCITIES};
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
        let growth = |p: f64, fills: u32| {
            let (mut sum, mut sum2, mut a0) = (0.0, 0.0, 0.0);
            for f in 0..fills {
                let mut g = LatticeGas::new([nx, n, n], f, p);
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
        let (full, se, a0) = growth(1.0, 4000);
        let predicted = transfer_response(d) / 48.0 * 4.0 * (k / 2.0).sin().powi(2);
        // the same with the exact F, pair by pair: the X–Y velocities c = (s_a, s_b) have side A
        // at x = 2X + s_a/2 and side B at 2X − s_a/2 (bits::interference_sides)
        let mut exact = 0.0;
        for x in 0..nx {
            for (sa, sb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                let (xa, xb) = (2.0 * x as f64 + sa / 2.0, 2.0 * x as f64 - sa / 2.0);
                let occupation = |x: f64| d * (1.0 + 2.0 * sb * u * (k * x).sin());
                exact += sb * ((k * xb).sin() - (k * xa).sin()) * net_transfer(occupation(xa), occupation(xb));
            }
        }
        // `mode` weighs a particle by 2 / (16 · cells); every one of the n² cells of a column X adds
        // the same, so the sum over X is divided by 8 nx — and by the mode, 24 d U
        let exact = exact / (8.0 * nx as f64) / (24.0 * d * u);
        // the viscosity change this growth stands for: Δν = −growth / (4 sin²(k/2))
        let laplacian = 4.0 * (k / 2.0).sin().powi(2);
        println!(
            "mode {a0:.4} (24 d U = {:.4}); growth per pass at p = 1: {full:.3e} ± {se:.1e} of the mode (Δν = {:.5} ± {:.5}); mean field {exact:.3e} (linear in δ: {predicted:.3e})",
            24.0 * d * u,
            -full / laplacian,
            se / laplacian
        );
        assert!((a0 / (24.0 * d * u) - 1.0).abs() < 0.02, "the fill carries the wave");
        assert!((full - exact).abs() < 4.0 * se, "{full} vs {exact}");
        // the linear rate (the viscosity shift) differs from the exact one by the O(δ²) terms only
        assert!(exact < predicted && exact > 0.97 * predicted);
        // applied with probability p per cell and velocity, the transfer scales with p
        let (half, se_half, _) = growth(0.5, 4000);
        println!("p = 0.5: {half:.3e} ± {se_half:.1e} (Δν = {:.5}); ratio to p = 1: {:.3}", -half / laplacian, half / full);
        assert!((half / full - 0.5).abs() < 4.0 * (se_half / full + 0.5 * se / full), "{half} vs {full}");
    }
}
