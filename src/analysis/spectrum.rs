//! Spectra of uniformly sampled series (rustfft): the magnitude spectrum, the autocorrelation
//! by the Wiener–Khinchin theorem, and the amplitude of one harmonic over whole periods.

use rustfft::{FftPlanner, num_complex::Complex};

/// One-sided amplitude spectrum of `x` (mean removed, Hann window, zero-padded to at least
/// `pad`× the next power of two). Returns `(frequency Hz, amplitude)` pairs; the amplitude is
/// scaled so that a sinusoid of amplitude `a` whose frequency falls on a bin reads `a`.
pub fn amplitude_spectrum(x: &[f64], dt: f64, pad: usize) -> Vec<(f64, f64)> {
    let n = x.len();
    if n < 2 {
        return Vec::new();
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let m = (n.next_power_of_two() * pad.max(1)).max(2);
    let mut buf: Vec<Complex<f64>> = vec![Complex::new(0.0, 0.0); m];
    let mut wsum = 0.0;
    for (i, v) in x.iter().enumerate() {
        let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos();
        wsum += w;
        buf[i] = Complex::new((v - mean) * w, 0.0);
    }
    FftPlanner::new().plan_fft_forward(m).process(&mut buf);
    let df = 1.0 / (m as f64 * dt);
    (0..=m / 2).map(|k| (k as f64 * df, 2.0 * buf[k].norm() / wsum)).collect()
}

/// Autocorrelation r(k) = Σᵢ xᵢ xᵢ₊ₖ / (N − k) of `x` (mean removed) for lags 0..=max_lag, by
/// FFT of the zero-padded series (Wiener–Khinchin), normalised so that r(0) = 1.
pub fn autocorrelation(x: &[f64], max_lag: usize) -> Vec<f64> {
    let n = x.len();
    if n == 0 {
        return Vec::new();
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let m = (2 * n).next_power_of_two();
    let mut buf: Vec<Complex<f64>> = (0..m).map(|i| Complex::new(if i < n { x[i] - mean } else { 0.0 }, 0.0)).collect();
    let mut planner = FftPlanner::new();
    planner.plan_fft_forward(m).process(&mut buf);
    for c in buf.iter_mut() {
        *c = Complex::new(c.norm_sqr(), 0.0);
    }
    planner.plan_fft_inverse(m).process(&mut buf);
    let max_lag = max_lag.min(n - 1);
    let r: Vec<f64> = (0..=max_lag).map(|k| buf[k].re / (n - k) as f64).collect();
    let r0 = r[0];
    if r0 <= 0.0 {
        return vec![0.0; r.len()];
    }
    r.iter().map(|v| v / r0).collect()
}

/// Amplitude |c_k| of harmonic `k` of frequency `f0` (Hz) in `x` sampled at `dt`: the projection
/// 2/N |Σ xₙ e^{−2πi k f0 n dt}| over the N samples, which should span whole periods (a
/// pitch-synchronous DFT). Exact for a periodic signal sampled over an integer number of periods.
pub fn harmonic_amplitude(x: &[f64], dt: f64, f0: f64, k: usize) -> f64 {
    let (re, im) = projection(x, dt, f0, k);
    2.0 * (re * re + im * im).sqrt() / x.len() as f64
}

/// Phase (rad, in (−π, π]) of harmonic `k` of `f0` in `x`: φ of x ≈ A cos(2π k f0 t + φ), t from
/// the first sample, by the same projection as [`harmonic_amplitude`]; `None` where the
/// projection is zero (no such component).
pub fn harmonic_phase(x: &[f64], dt: f64, f0: f64, k: usize) -> Option<f64> {
    let (re, im) = projection(x, dt, f0, k);
    (re != 0.0 || im != 0.0).then(|| im.atan2(re))
}

/// Σ xₙ e^{−2πi k f0 n dt} as (real, imaginary).
fn projection(x: &[f64], dt: f64, f0: f64, k: usize) -> (f64, f64) {
    let w = 2.0 * std::f64::consts::PI * k as f64 * f0 * dt;
    let (mut re, mut im) = (0.0, 0.0);
    for (n, v) in x.iter().enumerate() {
        let (s, c) = (w * n as f64).sin_cos();
        re += v * c;
        im -= v * s;
    }
    (re, im)
}

/// Sub-sample position of the extremum of the parabola through (−1, a), (0, b), (1, c), in
/// (−1, 1), and its value.
pub fn parabolic_peak(a: f64, b: f64, c: f64) -> (f64, f64) {
    let den = a - 2.0 * b + c;
    if den == 0.0 {
        return (0.0, b);
    }
    let d = (0.5 * (a - c) / den).clamp(-1.0, 1.0);
    (d, b - 0.25 * (a - c) * d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn a_sinusoid_on_a_bin_reads_its_amplitude_and_frequency() {
        let dt = 1.0 / 1000.0;
        let x: Vec<f64> = (0..1000).map(|i| 3.0 + 0.7 * (2.0 * PI * 125.0 * i as f64 * dt).sin()).collect();
        let s = amplitude_spectrum(&x, dt, 4);
        let (f, a) = s.iter().cloned().fold((0.0, 0.0), |m, p| if p.1 > m.1 { p } else { m });
        assert!((f - 125.0).abs() < 0.3, "{f}");
        assert!((a - 0.7).abs() < 0.01 * 0.7, "{a}");
    }

    #[test]
    fn autocorrelation_of_a_cosine_is_a_cosine() {
        let x: Vec<f64> = (0..4000).map(|i| (2.0 * PI * i as f64 / 40.0).cos()).collect();
        let r = autocorrelation(&x, 100);
        for k in [0, 10, 20, 40, 80] {
            assert!((r[k] - (2.0 * PI * k as f64 / 40.0).cos()).abs() < 0.02, "r({k}) = {}", r[k]);
        }
    }

    #[test]
    fn harmonic_projection_is_exact_over_whole_periods() {
        let dt = 1e-4;
        let f0 = 100.0;
        let x: Vec<f64> = (0..300).map(|i| 2.0 * (2.0 * PI * f0 * i as f64 * dt).cos() + 0.5 * (4.0 * PI * f0 * i as f64 * dt + 1.0).sin()).collect();
        assert!((harmonic_amplitude(&x, dt, f0, 1) - 2.0).abs() < 1e-12);
        assert!((harmonic_amplitude(&x, dt, f0, 2) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn parabolic_peak_of_a_parabola_is_exact() {
        let f = |x: f64| 4.0 - (x - 0.3) * (x - 0.3);
        let (d, v) = parabolic_peak(f(-1.0), f(0.0), f(1.0));
        assert!((d - 0.3).abs() < 1e-12 && (v - 4.0).abs() < 1e-12);
    }
}
