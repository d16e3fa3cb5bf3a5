//! Frequency and amplitude of a displacement that oscillates about a mean (a flap's tip, a
//! fold's margin), two ways: upward crossings of the series' mean, located by linear
//! interpolation between samples (robust to a slowly drifting amplitude, but a strong higher mode
//! adds crossings and reads as a higher frequency), and the highest peak of the amplitude
//! spectrum (robust to harmonics and higher modes: the frequency that carries the most motion).

use super::pitch::{F0Range, f0_spectrum};

/// What a displacement series did over the analysed window (units of the series and of `dt`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Oscillation {
    /// Full periods counted between the first and the last upward mean crossing.
    pub cycles: usize,
    /// cycles / (time between the first and last upward crossing) (1/time unit of `dt`).
    pub frequency: f64,
    /// Largest |x| over the window (x measured from its reference, not from the mean).
    pub max_abs: f64,
    /// Half the peak-to-peak excursion of the last full cycle.
    pub last_half_range: f64,
    /// Mean of x over the window.
    pub mean: f64,
    /// Frequency of the highest peak of the amplitude spectrum (Hann window, sub-bin parabolic
    /// refinement; [`f0_spectrum`]) between two cycles per window and the Nyquist frequency
    /// (1/time unit of `dt`): the mode that carries the most motion, which a higher mode's extra
    /// mean crossings do not move. `None` when the spectrum has no peak there.
    pub spectral_peak: Option<f64>,
}

/// The times (from the first sample, `dt` apart) at which `x` rises through `level`, located by
/// linear interpolation between the samples.
pub fn upward_crossings(x: &[f64], level: f64, dt: f64) -> Vec<f64> {
    let mut up = Vec::new();
    for (k, w) in x.windows(2).enumerate() {
        let (a, b) = (w[0] - level, w[1] - level);
        if a < 0.0 && b >= 0.0 {
            up.push((k as f64 + a / (a - b)) * dt);
        }
    }
    up
}

/// The oscillation of `x` sampled every `dt`; `None` with fewer than two full cycles.
pub fn oscillation(x: &[f64], dt: f64) -> Option<Oscillation> {
    if x.len() < 4 || !(dt > 0.0) || x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let up = upward_crossings(x, mean, dt);
    if up.len() < 3 {
        return None;
    }
    let cycles = up.len() - 1;
    let (t0, t1) = (up[cycles - 1], up[cycles]);
    let (i0, i1) = ((t0 / dt).floor() as usize, ((t1 / dt).ceil() as usize).min(x.len() - 1));
    let last = &x[i0..=i1];
    let hi = last.iter().cloned().fold(f64::MIN, f64::max);
    let lo = last.iter().cloned().fold(f64::MAX, f64::min);
    Some(Oscillation {
        cycles,
        frequency: cycles as f64 / (up[cycles] - up[0]),
        max_abs: x.iter().fold(0.0, |m, v| m.max(v.abs())),
        last_half_range: 0.5 * (hi - lo),
        mean,
        spectral_peak: f0_spectrum(x, dt, F0Range { min_hz: 2.0 / (x.len() as f64 * dt), max_hz: 0.5 / dt }),
    })
}

/// One cycle of a displacement: from one upward crossing of the level to the next, and its
/// peak-to-peak excursion over the samples in between (units of the series; times from the
/// first sample).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Swing {
    pub t_start: f64,
    pub t_end: f64,
    pub peak_to_peak: f64,
}

/// The cycles of `x` between its successive upward crossings of its own mean, each with its
/// peak-to-peak swing: how a vibration grows, holds or decays cycle by cycle (a fold's margin
/// from rest to its limit cycle).
pub fn swing_per_cycle(x: &[f64], dt: f64) -> Vec<Swing> {
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    let up = upward_crossings(x, mean, dt);
    up.windows(2)
        .map(|w| {
            // the samples from the first at or after the cycle's start to the last at or before its end
            let (i0, i1) = ((w[0] / dt).ceil() as usize, ((w[1] / dt).floor() as usize).min(x.len() - 1));
            let seg = &x[i0..=i1.max(i0)];
            let hi = seg.iter().cloned().fold(f64::MIN, f64::max);
            let lo = seg.iter().cloned().fold(f64::MAX, f64::min);
            Swing { t_start: w[0], t_end: w[1], peak_to_peak: hi - lo }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vibration that grows from rest and settles, A(t) = A∞ (1 − e^{−t/τ}) sin(2π f t): each
    /// cycle's swing is 2 A(t) at its extrema to the sampling's accuracy, growing, then held.
    #[test]
    fn the_swing_per_cycle_follows_a_growing_then_settled_amplitude() {
        let (f, dt, a_inf, tau) = (118.0, 2.0e-6, 0.05, 0.01);
        let amp = |t: f64| a_inf * (1.0 - (-t / tau).exp());
        let x: Vec<f64> = (0..60_000).map(|k| k as f64 * dt).map(|t| 0.04 + amp(t) * (std::f64::consts::TAU * f * t).sin()).collect();
        let s = swing_per_cycle(&x, dt);
        // 0.12 s at 118 Hz: 14 whole cycles between the first and last upward crossings
        assert!((13..=14).contains(&s.len()), "{}", s.len());
        for c in &s {
            assert!(((c.t_end - c.t_start) * f - 1.0).abs() < 0.05, "{c:?}");
            // the maximum at a quarter period past the crossing, the minimum at three quarters
            let want = amp(c.t_start + 0.25 / f) + amp(c.t_start + 0.75 / f);
            assert!((c.peak_to_peak / want - 1.0).abs() < 0.02, "{c:?} vs {want}");
        }
        assert!(s[1].peak_to_peak > 1.1 * s[0].peak_to_peak);
        let last: Vec<f64> = s[s.len() - 5..].iter().map(|c| c.peak_to_peak).collect();
        assert!(last.iter().all(|p| (p / (2.0 * a_inf) - 1.0).abs() < 0.01), "{last:?}");
        assert!(swing_per_cycle(&[1.0; 100], dt).is_empty());
    }

    #[test]
    fn a_sine_about_an_offset_gives_its_frequency_and_amplitude() {
        // 3.1 Hz, amplitude 1.2 about 0.3, sampled at 1 kHz for 2.5 s, with a slow third harmonic.
        let (f, dt) = (3.1, 1e-3);
        let x: Vec<f64> = (0..2500)
            .map(|k| {
                let t = k as f64 * dt;
                0.3 + 1.2 * (2.0 * std::f64::consts::PI * f * t).sin() + 0.1 * (6.0 * std::f64::consts::PI * f * t).sin()
            })
            .collect();
        let o = oscillation(&x, dt).unwrap();
        // upward crossings near t = k/3.1 s, k = 0..7
        assert_eq!(o.cycles, 7);
        assert!((o.frequency - f).abs() < 1e-3 * f, "{o:?}");
        let peak = (0..2500).map(|k| x[k].abs()).fold(0.0, f64::max);
        assert_eq!(o.max_abs, peak);
        // Half the range of 1.2 sin θ + 0.1 sin 3θ, found on a fine grid.
        let half = {
            let s: Vec<f64> = (0..100_000)
                .map(|k| {
                    let th = k as f64 * 2.0 * std::f64::consts::PI / 1e5;
                    1.2 * th.sin() + 0.1 * (3.0 * th).sin()
                })
                .collect();
            0.5 * (s.iter().cloned().fold(f64::MIN, f64::max) - s.iter().cloned().fold(f64::MAX, f64::min))
        };
        assert!((o.last_half_range - half).abs() < 2e-3, "{} vs {half}", o.last_half_range);
        // the window holds 7.75 cycles: the unfinished one moves the mean by at most
        // A/(π · 7.75) = 0.049
        assert!((o.mean - 0.3).abs() < 0.05, "{o:?}");
        // Fewer than two cycles: no answer.
        assert!(oscillation(&x[..500], dt).is_none());
        // the spectral peak is the fundamental's
        let p = o.spectral_peak.unwrap();
        assert!((p - f).abs() < 5e-3 * f, "{p}");
    }

    /// A strong third harmonic (0.8 of the fundamental, in opposite phase: sin θ − 0.8 sin 3θ =
    /// sin θ (3.2 sin²θ − 1.4) has four more zeros per period, at sin²θ = 0.4375 — the shape of
    /// the flap's tip with method 1) triples the crossing count's frequency; the spectral peak
    /// stays on the fundamental.
    #[test]
    fn a_strong_higher_mode_moves_the_crossing_count_but_not_the_spectral_peak() {
        let (f, dt) = (3.1, 1e-3);
        let x: Vec<f64> = (0..3000)
            .map(|k| {
                let th = 2.0 * std::f64::consts::PI * f * k as f64 * dt;
                th.sin() - 0.8 * (3.0 * th).sin()
            })
            .collect();
        let o = oscillation(&x, dt).unwrap();
        assert!((o.frequency / f - 3.0).abs() < 0.05, "crossings read {} Hz", o.frequency);
        let p = o.spectral_peak.unwrap();
        assert!((p - f).abs() < 5e-3 * f, "spectral peak {p} Hz");
    }
}
