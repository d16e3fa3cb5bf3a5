//! Vortex shedding behind a circular cylinder: the Strouhal number St = f D / U of a probe's
//! transverse velocity, and the reference it is read against.
//!
//! Williamson C. H. K., "Defining a universal and continuous Strouhal–Reynolds number
//! relationship for the laminar vortex shedding of a circular cylinder", Phys. Fluids 31 (1988)
//! 2742: for parallel shedding behind an unconfined cylinder, 49 < Re < 178,
//! St = −3.3265/Re + 0.1816 + 1.6·10⁻⁴ Re (0.1643 at Re = 100; the fit lies within about 1 % of
//! his measurements).

use super::oscillation::oscillation;
use serde::Serialize;

/// The Reynolds numbers (exclusive) between which [`williamson_strouhal`] holds: laminar
/// parallel shedding, from its onset to the wake's three-dimensional transition.
pub const WILLIAMSON_RANGE: (f64, f64) = (49.0, 178.0);

/// Williamson's (1988) Strouhal number of an unconfined circular cylinder at Reynolds number
/// `re`; `None` outside [`WILLIAMSON_RANGE`].
pub fn williamson_strouhal(re: f64) -> Option<f64> {
    (re > WILLIAMSON_RANGE.0 && re < WILLIAMSON_RANGE.1).then(|| -3.3265 / re + 0.1816 + 1.6e-4 * re)
}

/// Full shedding cycles a series must hold for its frequency to count.
pub const MIN_CYCLES: usize = 3;

/// The shedding one probe saw over the analysed window.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Shedding {
    /// Frequency of the transverse velocity (Hz, or 1/time unit of the samples): the spectrum's
    /// highest peak, else the mean-crossing rate.
    pub frequency: f64,
    /// Full periods between the first and the last upward mean crossing.
    pub cycles: usize,
    /// Half the peak-to-peak swing of the last full cycle (velocity units of the series).
    pub amplitude: f64,
    /// f D / U.
    pub strouhal: f64,
}

/// The shedding in the transverse velocity `v` sampled every `dt` (s) behind a cylinder of
/// diameter `d` in a stream of speed `u` (the same length unit): `None` with fewer than
/// [`MIN_CYCLES`] full cycles.
pub fn shedding(v: &[f64], dt: f64, d: f64, u: f64) -> Option<Shedding> {
    let o = oscillation(v, dt)?;
    if o.cycles < MIN_CYCLES || !(u > 0.0) {
        return None;
    }
    let frequency = o.spectral_peak.unwrap_or(o.frequency);
    Some(Shedding { frequency, cycles: o.cycles, amplitude: o.last_half_range, strouhal: frequency * d / u })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The coefficients: the fit gives the figures quoted from Williamson's measurements (St ≈
    /// 0.164 at Re = 100, ≈ 0.12 at the onset near 50, ≈ 0.19 at 175), rises with Re, and says
    /// nothing outside its range.
    #[test]
    fn williamsons_fit_gives_his_strouhal_numbers_inside_its_range_only() {
        let at = |re: f64| williamson_strouhal(re).expect("in range");
        assert!((at(100.0) - 0.164).abs() < 1e-3, "{}", at(100.0));
        assert!((at(50.0) - 0.122).abs() < 2e-3, "{}", at(50.0));
        assert!((at(175.0) - 0.191).abs() < 2e-3, "{}", at(175.0));
        assert!(at(60.0) < at(100.0) && at(100.0) < at(150.0), "rises with Re");
        assert_eq!(williamson_strouhal(40.0), None);
        assert_eq!(williamson_strouhal(200.0), None);
    }

    /// A transverse velocity that swings at 6.5 Hz behind a 1 cm cylinder in 15 cm/s reads
    /// St = 6.5/15 to the spectrum's sub-bin accuracy; a series with two cycles reads none.
    #[test]
    fn a_sinusoid_reads_its_strouhal_number() {
        let dt = 1e-3;
        let v: Vec<f64> = (0..2000).map(|k| 0.3 + 2.0 * (2.0 * std::f64::consts::PI * 6.5 * k as f64 * dt).sin()).collect();
        let s = shedding(&v, dt, 1.0, 15.0).expect("13 cycles");
        assert!((s.frequency / 6.5 - 1.0).abs() < 2e-3, "{s:?}");
        assert!((s.strouhal / (6.5 / 15.0) - 1.0).abs() < 2e-3, "{s:?}");
        assert!((s.amplitude - 2.0).abs() < 0.01, "{s:?}");
        assert!(s.cycles >= 12, "{s:?}");
        assert_eq!(shedding(&v[..400], dt, 1.0, 15.0), None, "2.6 periods: two full cycles");
    }
}
