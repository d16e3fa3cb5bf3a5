//! Third-order upwind differences for the advection term c_iα ∂f_i/∂r_α of (2.77), applied
//! axis by axis (Δx = 1):
//!
//! c ∂f/∂x ≈ |c| [2 f(x+s) + 3 f(x) − 6 f(x−s) + f(x−2s)] / 6,   s = sign(c),
//!
//! and the linear stability limit of this scheme with Heun's two-stage Runge–Kutta method,
//! used by the automatic time-step choice ([`super::timestep`]).

/// Stencil of one velocity: the centre coefficient and (displacement, coefficient) pairs.
#[derive(Clone, Debug, Default)]
pub struct VelocityStencil {
    pub centre: f64,
    pub taps: Vec<([i64; 3], f64)>,
}

/// Builds the stencil of every velocity: c·∇f ≈ centre·f(x) + Σ coeff·f(x + displacement).
pub fn stencils(c: &[[i32; 3]]) -> Vec<VelocityStencil> {
    c.iter()
        .map(|v| {
            let mut s = VelocityStencil::default();
            for a in 0..3 {
                if v[a] == 0 {
                    continue;
                }
                let mag = v[a].unsigned_abs() as f64;
                let sg = v[a].signum() as i64;
                let mut d = [0i64; 3];
                s.centre += 3.0 * mag / 6.0;
                d[a] = sg;
                s.taps.push((d, 2.0 * mag / 6.0));
                d[a] = -sg;
                s.taps.push((d, -6.0 * mag / 6.0));
                d[a] = -2 * sg;
                s.taps.push((d, mag / 6.0));
            }
            s
        })
        .collect()
}

/// Fourier symbol of the 1D operator ∂/∂x ≈ [2e^{ik} + 3 − 6e^{−ik} + e^{−2ik}]/6 (c > 0).
pub fn symbol(k: f64) -> (f64, f64) {
    let (c1, s1) = (k.cos(), k.sin());
    let (c2, s2) = ((2.0 * k).cos(), (2.0 * k).sin());
    let re = (2.0 * c1 + 3.0 - 6.0 * c1 + c2) / 6.0;
    let im = (2.0 * s1 + 6.0 * s1 - s2) / 6.0;
    (re, im)
}

/// |g(z)| for Heun's method, g = 1 + z + z²/2.
pub fn heun_gain(zr: f64, zi: f64) -> f64 {
    let z2r = zr * zr - zi * zi;
    let z2i = 2.0 * zr * zi;
    let gr = 1.0 + zr + 0.5 * z2r;
    let gi = zi + 0.5 * z2i;
    (gr * gr + gi * gi).sqrt()
}

/// Largest Courant number σ = |c|Δt/Δx for which Heun + 3rd-order upwind is stable for
/// every wavenumber (pure advection). ≈ 0.87.
pub fn max_courant() -> f64 {
    let stable = |sigma: f64| {
        (0..=2000).all(|j| {
            let k = std::f64::consts::PI * j as f64 / 2000.0;
            let (re, im) = symbol(k);
            heun_gain(-sigma * re, -sigma * im) <= 1.0 + 1e-12
        })
    };
    let (mut lo, mut hi) = (0.1, 2.0);
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if stable(m) { lo = m } else { hi = m }
    }
    lo
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn courant_limit_is_about_087() {
        let s = max_courant();
        assert!((s - 0.87).abs() < 0.01, "{s}");
    }
    #[test]
    fn stencil_is_exact_for_cubics() {
        // f(x) = x³ sampled on a line: derivative at 0 must be exact (0), and for x² (0).
        for p in 1..=3 {
            let f = |x: f64| x.powi(p);
            let d = (2.0 * f(1.0) + 3.0 * f(0.0) - 6.0 * f(-1.0) + f(-2.0)) / 6.0;
            let exact = if p == 1 { 1.0 } else { 0.0 };
            assert!((d - exact).abs() < 1e-14, "p={p} d={d}");
        }
    }
}
