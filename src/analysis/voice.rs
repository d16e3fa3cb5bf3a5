//! The glottal-flow measures a voice scientist reads, from a uniformly sampled glottal volume
//! flow U_g(t) (cm³/s): f0, open / speed / closing / quasi-open quotients, MFDR, peak, mean
//! and AC flow, NAQ and H1–H2.
//!
//! Definitions (as in the common glottal-flow tools, APARAT and the inverse-filtering
//! literature, ../shared/reference/README.md "Glottal-flow measures"):
//! - the analysis window is the last `window_fraction` of the series (the start-up transient
//!   left out); f0 by autocorrelation over the window (sub-sample parabolic refinement) and,
//!   as a second estimate, by the amplitude-spectrum peak;
//! - pulses: one flow maximum per period (the largest samples at least 0.7 T0 apart, refined by
//!   a parabola); each pulse between its neighbours has a closed-phase level before (b₋) and
//!   after (b₊) it (the minimum flow between the peaks), A_ac = U_peak − min(b₋, b₊);
//! - opening instant t_o: the rising crossing of b₋ + 0.2 (U_peak − b₋) (APARAT's 20 % level);
//!   closure instant t_c: the return to the closed-phase level, the falling crossing of
//!   b₊ + 0.01 (U_peak − b₊) (both levels settable); crossings interpolated linearly;
//! - T0 of a pulse = half the time between its neighbouring peaks; OQ = (t_c − t_o)/T0,
//!   SQ = (t_peak − t_o)/(t_c − t_peak), ClQ = (t_c − t_peak)/T0, QOQ = time above the 50 %
//!   level of A_ac / T0;
//! - MFDR = −min dU_g/dt (forward differences) between a peak and the next; NAQ =
//!   A_ac / (MFDR · T0);
//! - H1–H2 (dB): the amplitudes of the first two harmonics of dU_g/dt, by projection over the
//!   whole periods from the first to the last pulse peak (a pitch-synchronous DFT);
//! - every per-pulse measure is averaged over the pulses in the window;
//!   `amplitude_spread_last5` = (max − min)/mean of A_ac over the last five pulses (≤ 0.1
//!   means a settled oscillation).
//!
//! Noise: f0, mean, peak and AC flow are robust to noise; MFDR, NAQ and the closure instant
//! (hence OQ, SQ, ClQ) use the derivative or the closed-phase level and are not — low-pass
//! filter a measured (noisy) flow before asking for them.

use super::pitch::{F0Range, f0_autocorrelation, f0_spectrum};
use super::spectrum::{harmonic_amplitude, parabolic_peak};
use serde::{Deserialize, Serialize};

/// Settings of the measures; `Default` is the documented definitions above.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct VoiceOptions {
    pub f0_range: F0Range,
    /// The last fraction (0, 1] of the series analysed.
    pub window_fraction: f64,
    /// Opening instant: this fraction of the pulse's rise (APARAT: 0.2).
    pub opening_level: f64,
    /// Closure instant: the flow falls back to within this fraction of the rise (0.01).
    pub closed_level: f64,
}

impl Default for VoiceOptions {
    fn default() -> Self {
        VoiceOptions { f0_range: F0Range::default(), window_fraction: 0.5, opening_level: 0.2, closed_level: 0.01 }
    }
}

/// One glottal pulse (times in s from the start of the series, flows in cm³/s).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Pulse {
    pub t_open: f64,
    pub t_peak: f64,
    pub t_close: f64,
    /// The local period (s): half the time between the neighbouring peaks.
    pub period: f64,
    pub peak_flow: f64,
    pub ac_flow: f64,
    /// Maximum flow declination rate after this peak (cm³/s²).
    pub mfdr: f64,
}

/// The measures of one glottal-flow series.
#[derive(Clone, Debug, Serialize)]
pub struct VoiceMeasures {
    /// Analysed window [start, end] (s).
    pub window_s: [f64; 2],
    pub f0_autocorrelation_hz: f64,
    pub f0_spectrum_hz: Option<f64>,
    /// Number of pulses averaged.
    pub pulses: usize,
    pub open_quotient: f64,
    pub speed_quotient: f64,
    pub closing_quotient: f64,
    pub quasi_open_quotient: f64,
    /// cm³/s
    pub peak_flow: f64,
    /// cm³/s
    pub min_flow: f64,
    /// cm³/s, over the whole periods from the first to the last peak
    pub mean_flow: f64,
    /// cm³/s
    pub ac_flow: f64,
    /// cm³/s²
    pub mfdr: f64,
    pub naq: f64,
    pub h1_h2_db: f64,
    /// NaN (null in JSON) when the window holds fewer than five pulses.
    pub amplitude_spread_last5: f64,
    #[serde(skip)]
    pub pulse_list: Vec<Pulse>,
}

/// Why no voice measures could be taken.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum NoVoice {
    #[error("the window holds {0} samples: too short for the f0 range (at least two periods of the lowest f0 are needed)")]
    TooShort(usize),
    #[error("no periodicity in the f0 range (the flow does not oscillate, or not steadily)")]
    NotPeriodic,
    #[error("the flow is steady: its swing over the window is {:.2e} of its mean (an oscillation needs ≥ 1 %)", .0)]
    Steady(f64),
    #[error("only {0} pulses in the window: at least 3 are needed (run longer or widen the window)")]
    TooFewPulses(usize),
}

/// The voice measures of the flow `flow` (cm³/s) sampled every `dt` s.
pub fn voice_measures(flow: &[f64], dt: f64, opts: &VoiceOptions) -> Result<VoiceMeasures, NoVoice> {
    let start = ((1.0 - opts.window_fraction.clamp(1e-6, 1.0)) * flow.len() as f64) as usize;
    let x = &flow[start..];
    let t_of = |i: f64| (start as f64 + i) * dt;
    if (x.len() as f64) * dt < 2.0 / opts.f0_range.max_hz || x.len() < 8 {
        return Err(NoVoice::TooShort(x.len()));
    }
    // A ringing that has died away is not a voice, however periodic its remains.
    let (lo, hi) = x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
    let level = x.iter().map(|v| v.abs()).sum::<f64>() / x.len() as f64;
    if hi - lo < 0.01 * level {
        return Err(NoVoice::Steady((hi - lo) / level));
    }
    let f0 = f0_autocorrelation(x, dt, opts.f0_range).ok_or(NoVoice::NotPeriodic)?;
    let period_samples = 1.0 / (f0 * dt);
    let peaks = pulse_peaks(x, 0.7 * period_samples);
    if peaks.len() < 3 {
        return Err(NoVoice::TooFewPulses(peaks.len().saturating_sub(2)));
    }
    let derivative: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
    let refined = |i: usize| -> (f64, f64) {
        if i == 0 || i + 1 >= x.len() {
            return (i as f64, x[i]);
        }
        let (d, v) = parabolic_peak(x[i - 1], x[i], x[i + 1]);
        (i as f64 + d, v)
    };
    let mut pulses = Vec::new();
    let mut qoq = Vec::new();
    for w in peaks.windows(3) {
        let (prev, p, next) = (w[0], w[1], w[2]);
        let (tp, peak) = refined(p);
        let before = x[prev..=p].iter().cloned().fold(f64::INFINITY, f64::min);
        let after = x[p..=next].iter().cloned().fold(f64::INFINITY, f64::min);
        let ac = peak - before.min(after);
        let open_level = before + opts.opening_level * (peak - before);
        let closed_level = after + opts.closed_level * (peak - after);
        let Some(t_open) = rising_crossing(x, prev, p, open_level) else { continue };
        let Some(t_close) = falling_crossing(x, p, next, closed_level) else { continue };
        let half = before.min(after) + 0.5 * ac;
        if let (Some(a), Some(b)) = (rising_crossing(x, prev, p, half), falling_crossing(x, p, next, half)) {
            qoq.push((b - a) * dt);
        }
        let mfdr = -derivative[p..next].iter().cloned().fold(f64::INFINITY, f64::min);
        pulses.push(Pulse {
            t_open: t_of(t_open),
            t_peak: t_of(tp),
            t_close: t_of(t_close),
            period: 0.5 * (refined(next).0 - refined(prev).0) * dt,
            peak_flow: peak,
            ac_flow: ac,
            mfdr,
        });
    }
    if pulses.is_empty() {
        return Err(NoVoice::TooFewPulses(0));
    }
    let mean = |f: &dyn Fn(&Pulse) -> f64| pulses.iter().map(f).sum::<f64>() / pulses.len() as f64;
    let (first, last) = (peaks[0], *peaks.last().unwrap());
    let span = &x[first..last];
    let periods = (peaks.len() - 1) as f64;
    let f_span = periods / ((last - first) as f64 * dt);
    let d_span = &derivative[first..last];
    let h1 = harmonic_amplitude(d_span, dt, f_span, 1);
    let h2 = harmonic_amplitude(d_span, dt, f_span, 2);
    let tail: Vec<f64> = pulses.iter().rev().take(5).map(|p| p.ac_flow).collect();
    let tail_mean = tail.iter().sum::<f64>() / tail.len() as f64;
    // undefined (NaN, null in JSON) with fewer than five pulses: one pulse's spread is no evidence of settling
    let tail_spread = if tail.len() < 5 {
        f64::NAN
    } else {
        (tail.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - tail.iter().cloned().fold(f64::INFINITY, f64::min)) / tail_mean
    };
    let min_flow = peaks.windows(2).map(|w| x[w[0]..=w[1]].iter().cloned().fold(f64::INFINITY, f64::min)).sum::<f64>() / periods;
    Ok(VoiceMeasures {
        window_s: [t_of(0.0), t_of((x.len() - 1) as f64)],
        f0_autocorrelation_hz: f0,
        f0_spectrum_hz: f0_spectrum(x, dt, opts.f0_range),
        pulses: pulses.len(),
        open_quotient: mean(&|p| (p.t_close - p.t_open) / p.period),
        speed_quotient: mean(&|p| (p.t_peak - p.t_open) / (p.t_close - p.t_peak)),
        closing_quotient: mean(&|p| (p.t_close - p.t_peak) / p.period),
        quasi_open_quotient: if qoq.is_empty() { f64::NAN } else { qoq.iter().sum::<f64>() / qoq.len() as f64 * f0 },
        peak_flow: mean(&|p| p.peak_flow),
        min_flow,
        mean_flow: span.iter().sum::<f64>() / span.len() as f64,
        ac_flow: mean(&|p| p.ac_flow),
        mfdr: mean(&|p| p.mfdr),
        naq: mean(&|p| p.ac_flow / (p.mfdr * p.period)),
        h1_h2_db: 20.0 * (h1 / h2).log10(),
        amplitude_spread_last5: tail_spread,
        pulse_list: pulses,
    })
}

/// Indices of the pulse maxima: the largest local maxima at least `min_distance` samples apart,
/// in time order.
fn pulse_peaks(x: &[f64], min_distance: f64) -> Vec<usize> {
    let mut candidates: Vec<usize> = (1..x.len().saturating_sub(1)).filter(|&i| x[i] >= x[i - 1] && x[i] > x[i + 1]).collect();
    candidates.sort_by(|&a, &b| x[b].total_cmp(&x[a]).then(a.cmp(&b)));
    let mut taken = std::collections::BTreeSet::new();
    for i in candidates {
        let lo = (i as f64 - min_distance).ceil().max(0.0) as usize;
        let hi = (i as f64 + min_distance).floor() as usize;
        if taken.range(lo..=hi).next().is_none() {
            taken.insert(i);
        }
    }
    taken.into_iter().collect()
}

/// The last upward crossing of `level` in x[from..=to] (searching back from `to`), as a
/// fractional index.
fn rising_crossing(x: &[f64], from: usize, to: usize, level: f64) -> Option<f64> {
    (from..to).rev().find(|&i| x[i] < level && x[i + 1] >= level).map(|i| i as f64 + (level - x[i]) / (x[i + 1] - x[i]))
}

/// The first downward crossing of `level` in x[from..=to], as a fractional index.
fn falling_crossing(x: &[f64], from: usize, to: usize, level: f64) -> Option<f64> {
    (from..to).find(|&i| x[i] > level && x[i + 1] <= level).map(|i| i as f64 + (x[i] - level) / (x[i] - x[i + 1]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::synthetic::{Rosenberg, uniform_noise};
    use std::f64::consts::PI;

    fn within(name: &str, got: f64, want: f64, rel: f64) {
        assert!((got / want - 1.0).abs() < rel, "{name}: got {got}, want {want} (±{}%)", 100.0 * rel);
    }

    /// A Rosenberg train with set f0, opening and closing times and amplitude; the expected
    /// values follow from the documented definitions in closed form.
    #[test]
    fn rosenberg_pulse_train_measures_match_their_closed_forms() {
        let r = Rosenberg { f0: 123.4, opening: 0.40 / 123.4, closing: 0.18 / 123.4, amplitude: 400.0, baseline: 30.0 };
        let dt = 1.0 / 88200.0;
        let x = r.sample(dt, 88200 / 5);
        let m = voice_measures(&x, dt, &VoiceOptions::default()).unwrap();
        let t0 = 1.0 / r.f0;
        let (tp, tn) = (r.opening, r.closing);
        // rising 20 % crossing: (1 − cos(π t/Tp))/2 = 0.2; closure at 1 %: cos(π s/(2Tn)) = 0.01
        let t_open = tp * (0.6f64).acos() / PI;
        let t_close = tp + tn * 2.0 / PI * (0.01f64).acos();
        within("f0 autocorrelation", m.f0_autocorrelation_hz, r.f0, 0.01);
        within("f0 spectrum", m.f0_spectrum_hz.unwrap(), r.f0, 0.01);
        within("open quotient", m.open_quotient, (t_close - t_open) / t0, 0.01);
        within("speed quotient", m.speed_quotient, (tp - t_open) / (t_close - tp), 0.01);
        within("closing quotient", m.closing_quotient, (t_close - tp) / t0, 0.01);
        within("quasi-open quotient", m.quasi_open_quotient, (tp / 2.0 + 2.0 * tn / 3.0) / t0, 0.01);
        within("MFDR", m.mfdr, r.mfdr(), 0.01);
        within("peak flow", m.peak_flow, 430.0, 0.01);
        within("min flow", m.min_flow, 30.0, 0.01);
        within("AC flow", m.ac_flow, 400.0, 0.01);
        within("NAQ", m.naq, 400.0 / (r.mfdr() * t0), 0.01);
        // mean flow: baseline + A (Tp/2 + 2Tn/π)/T0
        within("mean flow", m.mean_flow, 30.0 + 400.0 * (tp / 2.0 + 2.0 * tn / PI) / t0, 0.01);
        // H1–H2 of dU/dt from the analytic derivative's Fourier coefficients (fine quadrature)
        let n = 200_000;
        let coef = |k: f64| {
            let (mut re, mut im) = (0.0, 0.0);
            for i in 0..n {
                let t = (i as f64 + 0.5) / n as f64 * t0;
                let d = r.derivative(t);
                re += d * (2.0 * PI * k * t / t0).cos();
                im += d * (2.0 * PI * k * t / t0).sin();
            }
            (re * re + im * im).sqrt()
        };
        let h1_h2 = 20.0 * (coef(1.0) / coef(2.0)).log10();
        assert!((m.h1_h2_db - h1_h2).abs() < 0.01 * h1_h2.abs().max(1.0), "H1–H2 {} dB, want {h1_h2} dB", m.h1_h2_db);
        // the pulses differ only by where the samples fall on them (T0 = 714.75 samples)
        assert!(m.amplitude_spread_last5 < 1e-3, "spread {}", m.amplitude_spread_last5);
        assert!(m.pulses >= 8, "{} pulses", m.pulses);
    }

    #[test]
    fn sinusoid_measures() {
        let (f, a, b) = (211.0, 250.0, 100.0);
        let dt = 1.0 / 44100.0;
        let x: Vec<f64> = (0..44100 / 4).map(|i| a + b * (2.0 * PI * f * i as f64 * dt).sin()).collect();
        let m = voice_measures(&x, dt, &VoiceOptions::default()).unwrap();
        within("f0", m.f0_autocorrelation_hz, f, 0.01);
        within("f0 spectrum", m.f0_spectrum_hz.unwrap(), f, 0.01);
        within("peak", m.peak_flow, a + b, 0.01);
        within("min", m.min_flow, a - b, 0.01);
        within("mean", m.mean_flow, a, 0.01);
        within("AC", m.ac_flow, 2.0 * b, 0.01);
        within("MFDR", m.mfdr, 2.0 * PI * f * b, 0.01);
        within("NAQ", m.naq, 1.0 / PI, 0.01);
        within("QOQ", m.quasi_open_quotient, 0.5, 0.01);
        // sin rises through 20 % of its swing at asin(−0.6) and falls to 1 % at π − asin(−0.98)
        let open = (-0.6f64).asin();
        let close = PI - (-0.98f64).asin();
        within("OQ", m.open_quotient, (close - open) / (2.0 * PI), 0.01);
        within("SQ", m.speed_quotient, (PI / 2.0 - open) / (close - PI / 2.0), 0.01);
    }

    /// White noise of ±0.5 % of the pulse amplitude: the robust measures stay within 1 %.
    #[test]
    fn noisy_pulse_train_keeps_f0_and_flow_levels() {
        let r = Rosenberg { f0: 97.0, opening: 0.35 / 97.0, closing: 0.2 / 97.0, amplitude: 300.0, baseline: 20.0 };
        let dt = 1.0 / 44100.0;
        let noise = uniform_noise(7, 44100 / 2);
        let x: Vec<f64> = r.sample(dt, noise.len()).iter().zip(&noise).map(|(u, n)| u + 1.5 * n).collect();
        let m = voice_measures(&x, dt, &VoiceOptions::default()).unwrap();
        within("f0 autocorrelation", m.f0_autocorrelation_hz, 97.0, 0.01);
        within("f0 spectrum", m.f0_spectrum_hz.unwrap(), 97.0, 0.01);
        within("peak flow", m.peak_flow, 320.0, 0.01);
        within("AC flow", m.ac_flow, 300.0, 0.01);
        let t0 = 1.0 / 97.0;
        within("mean flow", m.mean_flow, 20.0 + 300.0 * (r.opening / 2.0 + 2.0 * r.closing / PI) / t0, 0.01);
    }

    #[test]
    fn a_steady_flow_has_no_voice() {
        let x = vec![120.0; 20_000];
        assert_eq!(voice_measures(&x, 1e-5, &VoiceOptions::default()).unwrap_err(), NoVoice::Steady(0.0));
        // white noise swings but has no period
        let noise = uniform_noise(3, 20_000);
        assert_eq!(voice_measures(&noise, 1e-4, &VoiceOptions::default()).unwrap_err(), NoVoice::NotPeriodic);
        assert!(matches!(voice_measures(&x[..10], 1e-5, &VoiceOptions::default()), Err(NoVoice::TooShort(_))));
    }
}
