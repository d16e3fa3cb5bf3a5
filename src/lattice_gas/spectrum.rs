//! The dominant frequency of a sampled signal (the shedding frequency of a wake probe): the peak
//! of the Hann-windowed, zero-padded Fourier power spectrum of the mean-removed samples, refined by a parabola
//! through the peak and its neighbours, with its prominence over the spectrum's mean power.

use serde::Serialize;

#[derive(Clone, Copy, Debug, Serialize)]
pub struct Peak {
    /// Frequency (1 / the samples' time unit).
    pub frequency: f64,
    /// Peak power over the mean power of all nonzero frequencies (≫ 1 for a periodic signal,
    /// ≈ 5–10 for the largest value of white noise of a few hundred samples).
    pub prominence: f64,
    /// Periods of the peak frequency in the window.
    pub periods: f64,
}

/// Oversampling of the frequency grid (zero padding) over the n/2 DFT bins.
const OVERSAMPLE: usize = 8;

/// Peak of the Hann-windowed spectrum of `samples` taken every `dt`, on a frequency grid
/// `OVERSAMPLE` times finer than the DFT bins; `None` for fewer than 8 samples.
pub fn dominant_frequency(samples: &[f64], dt: f64) -> Option<Peak> {
    let n = samples.len();
    if n < 8 {
        return None;
    }
    let mean = samples.iter().sum::<f64>() / n as f64;
    let windowed: Vec<f64> = samples.iter().enumerate().map(|(i, s)| (s - mean) * (std::f64::consts::PI * i as f64 / (n - 1) as f64).sin().powi(2)).collect();
    let m = OVERSAMPLE * n;
    let power: Vec<f64> = (0..=m / 2)
        .map(|j| {
            let w = 2.0 * std::f64::consts::PI * j as f64 / m as f64;
            let (re, im) = windowed.iter().enumerate().fold((0.0, 0.0), |(re, im), (i, s)| (re + s * (w * i as f64).cos(), im - s * (w * i as f64).sin()));
            re * re + im * im
        })
        .collect();
    // skip the lowest two DFT bins (the window's main lobe around zero frequency)
    let lo = 2 * OVERSAMPLE;
    let (j, &pj) = power.iter().enumerate().skip(lo).max_by(|a, b| a.1.total_cmp(b.1))?;
    let mean_power = power[lo..].iter().sum::<f64>() / (power.len() - lo) as f64;
    let shift = if j + 1 < power.len() {
        let (a, b, c) = (power[j - 1], pj, power[j + 1]);
        let d = a - 2.0 * b + c;
        if d < 0.0 { (0.5 * (a - c) / d).clamp(-0.5, 0.5) } else { 0.0 }
    } else {
        0.0
    };
    let frequency = (j as f64 + shift) / (m as f64 * dt);
    Some(Peak { frequency, prominence: pj / mean_power.max(1e-300), periods: frequency * n as f64 * dt })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_frequency_of_a_noisy_sine() {
        // 7.3 periods of a sine plus uniform noise of 0.5× its amplitude: the peak is within
        // 2 % of the true frequency (bin width 1/7.3 = 14 %), prominent; pure noise is not
        let dt = 10.0;
        let f = 7.3 / (400.0 * dt);
        let noise = |i: usize| crate::lattice_gas::collision::mix32(i as u32) as f64 / 4_294_967_296.0 - 0.5;
        let s: Vec<f64> = (0..400).map(|i| 0.2 + (2.0 * std::f64::consts::PI * f * i as f64 * dt).sin() + noise(i)).collect();
        let p = dominant_frequency(&s, dt).unwrap();
        println!("{p:?} (true {f:.3e})");
        assert!((p.frequency / f - 1.0).abs() < 0.02);
        assert!(p.prominence > 50.0);
        let white: Vec<f64> = (0..400).map(|i| noise(i + 1000)).collect();
        let q = dominant_frequency(&white, dt).unwrap();
        println!("noise: {q:?}");
        assert!(q.prominence < 12.0);
    }
}
