//! Synthetic glottal signals with known answers, for testing the voice measures: the
//! Rosenberg (1971) pulse train, the classic trigonometric model of the glottal flow.

use std::f64::consts::PI;

/// One Rosenberg pulse per period T0 = 1/f0 (s): a raised-cosine opening of duration
/// `opening` (s) to the peak `amplitude` (cm³/s), a quarter-cosine closing of duration
/// `closing` (s) with an abrupt closure (slope −A π / (2 T_n) there), then a closed phase at
/// `baseline` (a leakage flow, cm³/s).
#[derive(Clone, Copy, Debug)]
pub struct Rosenberg {
    pub f0: f64,
    pub opening: f64,
    pub closing: f64,
    pub amplitude: f64,
    pub baseline: f64,
}

impl Rosenberg {
    /// Flow (cm³/s) at time `t` (s); the first opening starts at t = 0.
    pub fn flow(&self, t: f64) -> f64 {
        let t0 = 1.0 / self.f0;
        let s = t.rem_euclid(t0);
        let (tp, tn, a) = (self.opening, self.closing, self.amplitude);
        self.baseline
            + if s <= tp {
                0.5 * a * (1.0 - (PI * s / tp).cos())
            } else if s <= tp + tn {
                a * (PI * (s - tp) / (2.0 * tn)).cos()
            } else {
                0.0
            }
    }

    /// dU/dt (cm³/s²) at time `t`.
    pub fn derivative(&self, t: f64) -> f64 {
        let s = t.rem_euclid(1.0 / self.f0);
        let (tp, tn, a) = (self.opening, self.closing, self.amplitude);
        if s <= tp {
            0.5 * a * PI / tp * (PI * s / tp).sin()
        } else if s <= tp + tn {
            -a * PI / (2.0 * tn) * (PI * (s - tp) / (2.0 * tn)).sin()
        } else {
            0.0
        }
    }

    /// `n` samples every `dt` s.
    pub fn sample(&self, dt: f64, n: usize) -> Vec<f64> {
        (0..n).map(|i| self.flow(i as f64 * dt)).collect()
    }

    /// Maximum flow declination rate, A π / (2 T_n) (cm³/s²).
    pub fn mfdr(&self) -> f64 {
        self.amplitude * PI / (2.0 * self.closing)
    }
}

/// A deterministic uniform noise in [−1, 1) (a 64-bit linear congruential generator), so that
/// the noisy test signals are the same on every machine.
pub fn uniform_noise(seed: u64, n: usize) -> Vec<f64> {
    let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (0..n)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        })
        .collect()
}
