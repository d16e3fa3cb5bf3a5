//! Where a function changes sign between two points of a line: the walls' crossings
//! ([`super::thin_wall`]'s side ghosts, [`super::ghost_wall`]'s searches).

/// Narrows a bracket [a, b] of a sign change of `f` (f(a) = `fa` > 0 ≥ f(b) = `fb`) by regula
/// falsi with the Illinois rule (when the same end is kept twice running, the other end's value
/// is halved, so both ends move), at most `steps` evaluations, stopping after an evaluation f(t)
/// for which `done(f(t), a, b)` holds; a trial point that falls outside (a, b) (rounding) is
/// replaced by the midpoint. Returns the last bracket (a, fa, b, fb).
pub(super) fn illinois(
    f: impl Fn(f64) -> f64,
    (mut a, mut fa): (f64, f64),
    (mut b, mut fb): (f64, f64),
    steps: usize,
    done: impl Fn(f64, f64, f64) -> bool,
) -> (f64, f64, f64, f64) {
    // which end the last step kept: 1 the outer one (b), −1 the inner one (a)
    let mut kept = 0i8;
    for _ in 0..steps {
        let mut t = (a * fb - b * fa) / (fb - fa);
        if !(t > a && t < b) {
            t = 0.5 * (a + b);
        }
        let ft = f(t);
        if ft > 0.0 {
            (a, fa) = (t, ft);
            if kept == 1 {
                fb *= 0.5;
            }
            kept = 1;
        } else {
            (b, fb) = (t, ft);
            if kept == -1 {
                fa *= 0.5;
            }
            kept = -1;
        }
        if done(ft, a, b) {
            break;
        }
    }
    (a, fa, b, fb)
}

#[cfg(test)]
mod tests {
    /// A cubic with a root at 0.3: the bracket closes on it to the asked width, in fewer
    /// evaluations than bisection's 30, with each end on its side.
    #[test]
    fn the_bracket_closes_on_the_root() {
        let calls = std::cell::Cell::new(0);
        let f = |t: f64| {
            calls.set(calls.get() + 1);
            (0.3 - t) * (1.0 + t * t)
        };
        let (a, fa, b, fb) = super::illinois(f, (0.0, f(0.0)), (1.0, f(1.0)), 100, |_, a, b| b - a < 1e-9);
        assert!(b - a < 1e-9 && a <= 0.3 && b >= 0.3 - 1e-15, "[{a}, {b}]");
        assert!(fa > 0.0 && fb <= 0.0);
        assert!(calls.get() < 2 + 15, "{} evaluations", calls.get());
    }
}
