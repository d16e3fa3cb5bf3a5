//! Where the glottis closes: the shape of the medial surface at each closure, from the lateral
//! displacements of its lower and upper margins.
//!
//! In the body–cover theory a self-oscillating glottis is convergent as it opens and divergent
//! as it closes: the lower margin leads, so it meets the other fold first and the closure runs
//! from below (the mucosal wave; Titze 1988, seed 000 §3.4.1, Fig. 3.10). At rest the medial
//! surface is vertical between the margins (both at the half-gap G/2 from the mid-line), so the
//! sign of (lower − upper) lateral displacement at a closure tells the shape: negative, the
//! lower margin is the nearer to the mid-line (divergent: closing from below); positive, the
//! upper one is (convergent: closing from above). The instants are the voice measures' closing
//! instants ([`super::voice::Pulse::t_close`]): where the flow returns to its closed level, which
//! is a closure only when the glottis closes; for a glottis that stays open it is the most closed
//! instant of the cycle, and the shape read there is the narrowing glottis's.

/// The medial surface's shape at the closures of a glottal cycle.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ClosureShape {
    /// How many closures were read.
    pub closures: usize,
    /// Fraction of them at which the lower margin was nearer the mid-line than the upper one
    /// (closure from below).
    pub from_below: f64,
    /// Mean of (lower − upper) lateral displacement at the closures (units of the margins'
    /// series, cm in a glottis run): < 0 divergent, > 0 convergent. The local gap differs by
    /// twice this between the margins.
    pub lower_minus_upper: f64,
    /// The same at each closure, in time order.
    pub per_closure: Vec<f64>,
}

/// The shape at the instants `closures` (time from the first sample, `dt` apart) of the lateral
/// displacements `lower` and `upper` (both folds' mean, positive away from the mid-line), read
/// by linear interpolation between samples. Closures outside the series are skipped; `None`
/// when none is left.
pub fn shape_at_closures(lower: &[f64], upper: &[f64], dt: f64, closures: &[f64]) -> Option<ClosureShape> {
    let n = lower.len().min(upper.len());
    if n < 2 {
        return None;
    }
    let at = |x: &[f64], t: f64| -> Option<f64> {
        let s = t / dt;
        if !(s >= 0.0) || s > (n - 1) as f64 {
            return None;
        }
        let k = (s.floor() as usize).min(n - 2);
        let f = s - k as f64;
        Some(x[k] + f * (x[k + 1] - x[k]))
    };
    let per_closure: Vec<f64> = closures.iter().filter_map(|&t| Some(at(lower, t)? - at(upper, t)?)).collect();
    if per_closure.is_empty() {
        return None;
    }
    let count = per_closure.len() as f64;
    Some(ClosureShape {
        closures: per_closure.len(),
        from_below: per_closure.iter().filter(|&&d| d < 0.0).count() as f64 / count,
        lower_minus_upper: per_closure.iter().sum::<f64>() / count,
        per_closure,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// Two margins on the same sinusoid, the lower one leading by an eighth of a period. The
    /// glottis closes when the first margin comes within a closing distance of the mid-line
    /// (here: down through −0.8 of the amplitude); that is the leading one, and at that instant
    /// the other is still |sin(asin 0.8 − ωL)| = 0.141 of the amplitude out: lower − upper =
    /// (−0.8 + 0.141) amplitude.
    #[test]
    fn a_leading_lower_margin_closes_the_glottis_from_below() {
        let (f, dt, amp) = (120.0, 1e-5, 0.01);
        let lead = 1.0 / f / 8.0;
        let n = 4000;
        let lower: Vec<f64> = (0..n).map(|i| amp * (TAU * f * (i as f64 * dt + lead)).sin()).collect();
        let upper: Vec<f64> = (0..n).map(|i| amp * (TAU * f * (i as f64 * dt)).sin()).collect();
        // the lower margin falls through −0.8 amp where its phase is π + asin 0.8
        let phase = std::f64::consts::PI + 0.8f64.asin();
        let closures: Vec<f64> = (1..5).map(|k| (phase / TAU + k as f64) / f - lead).collect();
        let s = shape_at_closures(&lower, &upper, dt, &closures).unwrap();
        assert_eq!((s.closures, s.from_below), (4, 1.0));
        let want = amp * (-0.8 + (0.8f64.asin() - TAU * f * lead).sin());
        assert!(want < 0.0);
        assert!((s.lower_minus_upper / want - 1.0).abs() < 1e-4, "{} vs {want}", s.lower_minus_upper);
        // swapped, the upper margin leads: closure from above, the same difference with the other sign
        let t = shape_at_closures(&upper, &lower, dt, &closures).unwrap();
        assert_eq!(t.from_below, 0.0);
        assert!((t.lower_minus_upper / -want - 1.0).abs() < 1e-4);
        // closures outside the series are not read
        assert_eq!(shape_at_closures(&lower, &upper, dt, &[-1.0, 1.0]), None);
        let one = shape_at_closures(&lower, &upper, dt, &[closures[0], 1.0]).unwrap();
        assert_eq!(one.closures, 1);
    }
}
