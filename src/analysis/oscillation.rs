//! Frequency and amplitude of a displacement that oscillates about a mean (a flap's tip, a
//! fold's margin): upward crossings of the series' mean, located by linear interpolation between
//! samples. Robust to a slowly drifting amplitude, unlike a spectrum peak over a short window.

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
}

/// The oscillation of `x` sampled every `dt`; `None` with fewer than two full cycles.
pub fn oscillation(x: &[f64], dt: f64) -> Option<Oscillation> {
    if x.len() < 4 || !(dt > 0.0) || x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let mut up = Vec::new();
    for (k, w) in x.windows(2).enumerate() {
        let (a, b) = (w[0] - mean, w[1] - mean);
        if a < 0.0 && b >= 0.0 {
            up.push((k as f64 + a / (a - b)) * dt);
        }
    }
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
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
