//! The time by which one signal leads another: the lag of the largest cross-correlation (means
//! removed), refined by a parabola through its neighbours. Used for the vertical phase
//! difference of the folds (the lower margin moves before the upper one: the mucosal wave,
//! seed 000 §3.4.1 and Titze's body–cover theory).

use super::spectrum::{harmonic_amplitude, harmonic_phase, parabolic_peak};

/// Time (units of `dt`) by which `a` leads `b`: the τ ∈ [−max_lag, max_lag] that maximises
/// Σ a(t) b(t + τ). Positive when `a` happens first. `None` for signals without variation or
/// shorter than three lags. Each lag sums over its overlap (n − |τ| terms), which pulls the
/// peak of periodic signals towards zero lag by ≈ 1/(ω²(n − τ)) samples (ω per sample): a few
/// per cent of the lead over a handful of periods; [`phase_lead`] reads the fundamentals
/// without that bias.
pub fn lead_time(a: &[f64], b: &[f64], dt: f64, max_lag: usize) -> Option<f64> {
    let n = a.len().min(b.len());
    if n < 3 * max_lag.max(1) {
        return None;
    }
    let mean = |x: &[f64]| x[..n].iter().sum::<f64>() / n as f64;
    let (ma, mb) = (mean(a), mean(b));
    let corr =
        |lag: i64| -> f64 { (0..n as i64).filter(|&t| (0..n as i64).contains(&(t + lag))).map(|t| (a[t as usize] - ma) * (b[(t + lag) as usize] - mb)).sum() };
    let lags: Vec<i64> = (-(max_lag as i64)..=max_lag as i64).collect();
    let c: Vec<f64> = lags.iter().map(|&l| corr(l)).collect();
    let k = (0..c.len()).max_by(|&i, &j| c[i].total_cmp(&c[j]))?;
    if c[k] <= 0.0 {
        return None;
    }
    let shift = if k > 0 && k + 1 < c.len() { parabolic_peak(c[k - 1], c[k], c[k + 1]).0 } else { 0.0 };
    Some((lags[k] as f64 + shift) * dt)
}

/// The phase difference of two signals at their fundamental `f0` (Hz): the vertical phase
/// difference of the folds' lower and upper margins, the mucosal wave's delay of the upper
/// margin behind the lower one (Titze 1988, J. Acoust. Soc. Am. 83, 1536), read as the first
/// harmonic's phase of each from a pitch-synchronous projection over the largest whole number of
/// periods at the end of the series, their means taken out ([`super::spectrum::harmonic_phase`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PhaseLead {
    /// Degrees by which `a` leads `b`, in (−180, 180]: positive when `a` moves first.
    pub degrees: f64,
    /// The same as a time (s): degrees / 360 / f0.
    pub lead_s: f64,
    /// Amplitudes of `a`'s and `b`'s fundamentals (their series' units).
    pub amplitudes: [f64; 2],
    /// Whole periods the projection spans.
    pub periods: usize,
}

/// [`PhaseLead`] of `a` over `b` (sampled `dt` apart) at `f0`; `None` with less than one whole
/// period or where either signal has no component at f0. Unlike [`lead_time`] (the lag of the
/// whole waveforms' best match) it reads the fundamentals only: clipping at a closure, which
/// flattens both margins' minima, does not move it.
pub fn phase_lead(a: &[f64], b: &[f64], dt: f64, f0: f64) -> Option<PhaseLead> {
    let n = a.len().min(b.len());
    if !(f0 > 0.0 && dt > 0.0) {
        return None;
    }
    let per_period = 1.0 / (f0 * dt);
    let periods = (n as f64 / per_period).floor() as usize;
    let len = (periods as f64 * per_period).round() as usize;
    if periods == 0 || len < 2 || len > n {
        return None;
    }
    // the window's means taken out, so that a constant (or the part of one beyond whole periods
    // when f0 is read with round-off) leaks nothing into the fundamental
    let ac = |x: &[f64]| -> Vec<f64> {
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        x.iter().map(|v| v - mean).collect()
    };
    let (raw_a, raw_b) = (&a[a.len() - len..], &b[b.len() - len..]);
    let (a, b) = (&ac(raw_a)[..], &ac(raw_b)[..]);
    let amplitudes = [harmonic_amplitude(a, dt, f0, 1), harmonic_amplitude(b, dt, f0, 1)];
    // a fundamental at the round-off of the signal's values (a constant) is none
    let largest = |x: &[f64]| x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if amplitudes[0] <= 1e-9 * largest(raw_a) || amplitudes[1] <= 1e-9 * largest(raw_b) {
        return None;
    }
    let (pa, pb) = (harmonic_phase(a, dt, f0, 1)?, harmonic_phase(b, dt, f0, 1)?);
    let mut d = (pa - pb).to_degrees();
    while d > 180.0 {
        d -= 360.0;
    }
    while d <= -180.0 {
        d += 360.0;
    }
    Some(PhaseLead { degrees: d, lead_s: d / 360.0 / f0, amplitudes, periods })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Margins with a known vertical phase difference: the lower one 40° ahead of the upper,
    /// as sinusoids with a second harmonic, as the same clipped at the closure (both flattened at
    /// the mid-line for a third of the cycle), and with noise: the phase within 1 % of 40°, the
    /// lead 40/360 of a period, the amplitudes of the fundamentals; an f0 20 % off is read at
    /// that frequency (the caller's f0 sets the projection) and a constant signal has none.
    #[test]
    fn the_fundamentals_phase_difference_is_the_margins_lead() {
        let (f0, dt) = (118.65, 3.2e-6);
        let n = (0.05 / dt) as usize;
        let w = 2.0 * std::f64::consts::PI * f0;
        let lead = 40f64.to_radians();
        let margin = |t: f64, phase: f64, amp: f64| amp * ((w * t + phase).cos() + 0.3 * (2.0 * w * t + 2.0 * phase + 0.4).cos());
        let mut seed = 12345u64;
        let mut noise = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed as f64 / u64::MAX as f64) - 0.5
        };
        let lower: Vec<f64> = (0..n).map(|i| margin(i as f64 * dt, lead, 0.03)).collect();
        let upper: Vec<f64> = (0..n).map(|i| margin(i as f64 * dt, 0.0, 0.05)).collect();
        let clip = |x: &[f64], floor: f64| -> Vec<f64> { x.iter().map(|v| v.max(floor)).collect() };
        let mut noisy = |x: &[f64], a: f64| -> Vec<f64> { x.iter().map(|v| v + a * noise()).collect() };
        let cases = [
            ("sinusoids", lower.clone(), upper.clone()),
            ("clipped at closure", clip(&lower, -0.015), clip(&upper, -0.025)),
            ("with noise", noisy(&lower, 0.01), noisy(&upper, 0.01)),
        ];
        for (label, lo, up) in &cases {
            let p = phase_lead(lo, up, dt, f0).unwrap();
            assert!((p.degrees - 40.0).abs() < 0.4, "{label}: {} degrees", p.degrees);
            assert!((p.lead_s - 40.0 / 360.0 / f0).abs() < 0.01 * 40.0 / 360.0 / f0, "{label}: {} s", p.lead_s);
            assert!(p.periods == 5, "{label}: {} periods", p.periods);
            let back = phase_lead(up, lo, dt, f0).unwrap();
            assert!((back.degrees + p.degrees).abs() < 1e-9, "{label}: antisymmetric");
        }
        let p = phase_lead(&lower, &upper, dt, f0).unwrap();
        assert!((p.amplitudes[0] - 0.03).abs() < 1e-3 * 0.03 && (p.amplitudes[1] - 0.05).abs() < 1e-3 * 0.05, "{:?}", p.amplitudes);
        // the lag of the whole waveforms' best match reads nearly the same lead on these clean
        // delayed copies, pulled a little towards zero lag: its sum over each lag's overlap
        // weighs lags by (n − |τ|), which moves the peak by ≈ 1/(ω²(n − τ)) samples (11.5 of the
        // lead's 293 here, 4 %) — one reason the fundamentals' phase is the measure reported
        let xc = lead_time(&lower, &upper, dt, (0.5 / f0 / dt) as usize).unwrap();
        assert!(xc < p.lead_s && xc > 0.92 * p.lead_s, "cross-correlation {xc} against {}", p.lead_s);
        assert!(phase_lead(&vec![0.01; n], &upper, dt, f0).is_none());
        assert!(phase_lead(&lower[..100], &upper[..100], dt, f0).is_none(), "less than one period");
    }

    #[test]
    fn a_sinusoid_leads_its_delayed_copy_by_the_delay() {
        let (f, dt) = (125.0, 1e-5);
        let delay = 0.37e-3; // 37 samples
        let a: Vec<f64> = (0..4000).map(|i| (2.0 * std::f64::consts::PI * f * i as f64 * dt).sin()).collect();
        let b: Vec<f64> = (0..4000).map(|i| (2.0 * std::f64::consts::PI * f * (i as f64 * dt - delay)).sin() + 0.3).collect();
        let lead = lead_time(&a, &b, dt, 200).unwrap();
        assert!((lead - delay).abs() < 0.01 * delay, "lead {lead} vs {delay}");
        let lag = lead_time(&b, &a, dt, 200).unwrap();
        assert!((lag + delay).abs() < 0.01 * delay, "{lag}");
        assert!(lead_time(&vec![1.0; 4000], &a, dt, 200).is_none());
    }
}
