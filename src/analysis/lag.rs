//! The time by which one signal leads another: the lag of the largest cross-correlation (means
//! removed), refined by a parabola through its neighbours. Used for the vertical phase
//! difference of the folds (the lower margin moves before the upper one: the mucosal wave,
//! seed 000 §3.4.1 and Titze's body–cover theory).

use super::spectrum::parabolic_peak;

/// Time (units of `dt`) by which `a` leads `b`: the τ ∈ [−max_lag, max_lag] that maximises
/// Σ a(t) b(t + τ). Positive when `a` happens first. `None` for signals without variation or
/// shorter than three lags.
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

#[cfg(test)]
mod tests {
    use super::*;

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
