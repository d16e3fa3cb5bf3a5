//! Fundamental frequency f0 of a uniformly sampled series, two ways: the autocorrelation peak
//! with sub-sample (parabolic) refinement, and the amplitude-spectrum peak.

use super::spectrum::{amplitude_spectrum, autocorrelation, parabolic_peak};

/// The search range of f0 (Hz).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct F0Range {
    pub min_hz: f64,
    pub max_hz: f64,
}

impl Default for F0Range {
    /// 50–1000 Hz: the range of the human voice, speech to soprano.
    fn default() -> Self {
        F0Range { min_hz: 50.0, max_hz: 1000.0 }
    }
}

/// A local maximum of the autocorrelation this close to the highest one counts as the period:
/// the smallest such lag wins, so that a lag of 2T0 (the octave error) is not picked.
const OCTAVE_GUARD: f64 = 0.9;

/// f0 (Hz) from the autocorrelation of `x` (sampled every `dt` s): the smallest lag in
/// [1/max, 1/min] whose local maximum reaches 0.9 of the highest one, refined by a parabola
/// through the three lags around it. `None` when no local maximum exceeds 0.3 (no periodicity).
pub fn f0_autocorrelation(x: &[f64], dt: f64, range: F0Range) -> Option<f64> {
    let lo = ((1.0 / (range.max_hz * dt)).floor() as usize).max(1);
    let hi = (1.0 / (range.min_hz * dt)).ceil() as usize;
    let hi = hi.min(x.len() / 2);
    if hi < lo + 2 {
        return None;
    }
    let r = autocorrelation(x, hi + 1);
    let peaks: Vec<usize> = (lo.max(1)..=hi).filter(|&k| r[k] > r[k - 1] && r[k] >= r[k + 1]).collect();
    let best = peaks.iter().map(|&k| r[k]).fold(f64::NEG_INFINITY, f64::max);
    if best.is_nan() || best <= 0.3 {
        return None;
    }
    let k = *peaks.iter().find(|&&k| r[k] >= OCTAVE_GUARD * best)?;
    let (d, _) = parabolic_peak(r[k - 1], r[k], r[k + 1]);
    Some(1.0 / ((k as f64 + d) * dt))
}

/// f0 (Hz) from the highest peak of the amplitude spectrum in the range (Hann window, 8×
/// zero padding), refined by a parabola through the log amplitudes of the three bins around it
/// (exact for the Gaussian-like main lobe to a small fraction of a bin).
pub fn f0_spectrum(x: &[f64], dt: f64, range: F0Range) -> Option<f64> {
    let s = amplitude_spectrum(x, dt, 8);
    if s.len() < 3 {
        return None;
    }
    let k = (1..s.len() - 1).filter(|&k| s[k].0 >= range.min_hz && s[k].0 <= range.max_hz).max_by(|&a, &b| s[a].1.total_cmp(&s[b].1))?;
    if s[k].1.is_nan() || s[k].1 <= 0.0 {
        return None;
    }
    let ln = |v: f64| v.max(1e-300).ln();
    let (d, _) = parabolic_peak(ln(s[k - 1].1), ln(s[k].1), ln(s[k + 1].1));
    let df = s[1].0;
    Some((k as f64 + d) * df)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn f0_of_a_sinusoid_off_the_sample_grid() {
        let dt = 1.0 / 44100.0;
        let f = 147.3;
        let x: Vec<f64> = (0..8000).map(|i| (2.0 * PI * f * i as f64 * dt).sin()).collect();
        let a = f0_autocorrelation(&x, dt, F0Range::default()).unwrap();
        let s = f0_spectrum(&x, dt, F0Range::default()).unwrap();
        assert!((a / f - 1.0).abs() < 1e-3, "autocorrelation {a}");
        assert!((s / f - 1.0).abs() < 1e-3, "spectrum {s}");
    }

    #[test]
    fn no_f0_in_a_constant_or_in_a_too_short_series() {
        assert_eq!(f0_autocorrelation(&[1.0; 4000], 1e-4, F0Range::default()), None);
        assert_eq!(f0_autocorrelation(&[1.0, 2.0, 3.0], 1e-4, F0Range::default()), None);
    }
}
