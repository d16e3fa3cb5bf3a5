//! Band-limited resampling of a uniformly sampled series to another rate (the simulation's
//! rate → 44.1 kHz audio): windowed-sinc interpolation, y(t) = Σₙ xₙ (2f_c/f_in)
//! sinc(2f_c (t − n/f_in)) w(t − n/f_in), with the cut-off f_c = 0.45 min(f_in, f_out) so that
//! nothing above the output's Nyquist frequency folds back, and a Blackman window over ±16 zero
//! crossings (stop band below −70 dB).
//!
//! Hand-written rather than a crate: the job is one fixed-ratio pass over a finished series
//! (no streaming, no chunks), ~30 lines, and it is tested below on its pass band and stop band.

use std::f64::consts::PI;

/// Zero crossings of the sinc on each side of the window.
const ZEROS: f64 = 16.0;

/// Samples of `x` (rate `f_in` Hz) at `n_out` instants k / `f_out`, k = 0..n_out. With
/// `periodic` the series repeats (`x[n + len] = x[n]`), so any length of output can be drawn
/// from whole periods; otherwise it is zero outside.
pub fn resample(x: &[f64], f_in: f64, f_out: f64, n_out: usize, periodic: bool) -> Vec<f64> {
    if x.is_empty() {
        return vec![0.0; n_out];
    }
    let fc = 0.45 * f_in.min(f_out);
    let half_width = ZEROS / (2.0 * fc); // s
    let gain = 2.0 * fc / f_in;
    let len = x.len() as i64;
    (0..n_out)
        .map(|k| {
            let t = k as f64 / f_out;
            let lo = ((t - half_width) * f_in).ceil() as i64;
            let hi = ((t + half_width) * f_in).floor() as i64;
            let mut y = 0.0;
            for n in lo..=hi {
                let v = if periodic {
                    x[n.rem_euclid(len) as usize]
                } else if n >= 0 && n < len {
                    x[n as usize]
                } else {
                    continue;
                };
                let tau = t - n as f64 / f_in;
                let u = tau / half_width;
                let window = 0.42 + 0.5 * (PI * u).cos() + 0.08 * (2.0 * PI * u).cos();
                let arg = 2.0 * fc * tau;
                let sinc = if arg.abs() < 1e-12 { 1.0 } else { (PI * arg).sin() / (PI * arg) };
                y += v * gain * sinc * window;
            }
            y
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_band_is_kept_and_the_band_above_the_output_nyquist_is_removed() {
        let (f_in, f_out) = (352_800.0 * 1.013, 44_100.0);
        let n = 35_000;
        let tone = |f: f64, t: f64| (2.0 * PI * f * t).sin();
        // 1 kHz kept, 30 kHz (above 22.05 kHz) removed
        let x: Vec<f64> = (0..n).map(|i| tone(1000.0, i as f64 / f_in) + tone(30_000.0, i as f64 / f_in)).collect();
        let y = resample(&x, f_in, f_out, 4000, false);
        let err = (500..3500).map(|k| (y[k] - tone(1000.0, k as f64 / f_out)).abs()).fold(0.0, f64::max);
        assert!(err < 2e-3, "max deviation from the 1 kHz tone {err}");
    }

    #[test]
    fn upsampling_a_band_limited_tone_is_accurate() {
        let (f_in, f_out) = (8000.0, 44_100.0);
        let x: Vec<f64> = (0..4000).map(|i| (2.0 * PI * 440.0 * i as f64 / f_in).cos()).collect();
        let y = resample(&x, f_in, f_out, 20_000, false);
        let err = (1000..19_000).map(|k| (y[k] - (2.0 * PI * 440.0 * k as f64 / f_out).cos()).abs()).fold(0.0, f64::max);
        assert!(err < 2e-3, "{err}");
    }

    #[test]
    fn periodic_extension_repeats_whole_periods_without_a_seam() {
        // exactly 5 periods of 100 Hz at 10 kHz, drawn out to 1 s at 44.1 kHz
        let x: Vec<f64> = (0..500).map(|i| (2.0 * PI * 100.0 * i as f64 / 10_000.0).sin()).collect();
        let y = resample(&x, 10_000.0, 44_100.0, 44_100, true);
        let err = (0..44_100).map(|k| (y[k] - (2.0 * PI * 100.0 * k as f64 / 44_100.0).sin()).abs()).fold(0.0, f64::max);
        assert!(err < 2e-3, "{err}");
    }
}
