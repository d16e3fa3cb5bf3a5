//! The path of a point that oscillates in a plane — a fold's medial-surface particles, whose
//! "elliptic trajectories" the seed reads in 3D (000 §3.4.3): the ellipse of its motion from the
//! covariance of its two coordinates. For x = a cos θ, y = b sin θ with θ uniform over whole
//! periods the covariance's eigenvalues are a²/2 and b²/2, so the semi-axes are √(2λ).

use serde::Serialize;

/// The ellipse of a planar motion (units of the samples).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PathEllipse {
    pub semi_major: f64,
    pub semi_minor: f64,
    /// The major axis's angle from the first coordinate's axis (rad, in (−π/2, π/2]).
    pub angle_rad: f64,
    /// +1 when the point goes round counter-clockwise in the (first, second) plane, −1
    /// clockwise, 0 when it sweeps no area (a line).
    pub sense: i8,
}

impl PathEllipse {
    /// semi_minor / semi_major: 0 for a line, 1 for a circle.
    pub fn roundness(&self) -> f64 {
        if self.semi_major > 0.0 { self.semi_minor / self.semi_major } else { 0.0 }
    }
}

/// The ellipse of the path (x(t), y(t)) sampled at equal intervals (means removed); `None` for
/// fewer than three samples, non-finite values or no motion.
pub fn path_ellipse(x: &[f64], y: &[f64]) -> Option<PathEllipse> {
    let n = x.len().min(y.len());
    if n < 3 || x[..n].iter().chain(&y[..n]).any(|v| !v.is_finite()) {
        return None;
    }
    let mean = |v: &[f64]| v[..n].iter().sum::<f64>() / n as f64;
    let (mx, my) = (mean(x), mean(y));
    let (mut sxx, mut syy, mut sxy, mut area) = (0.0, 0.0, 0.0, 0.0);
    for k in 0..n {
        let (dx, dy) = (x[k] - mx, y[k] - my);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
        if k + 1 < n {
            // twice the signed area swept about the mean point (the shoelace sum)
            area += dx * (y[k + 1] - my) - (x[k + 1] - mx) * dy;
        }
    }
    let (sxx, syy, sxy) = (sxx / n as f64, syy / n as f64, sxy / n as f64);
    if sxx + syy == 0.0 {
        return None;
    }
    let (half_sum, half_diff) = (0.5 * (sxx + syy), 0.5 * (sxx - syy));
    let root = (half_diff * half_diff + sxy * sxy).sqrt();
    let (major, minor) = (half_sum + root, (half_sum - root).max(0.0));
    Some(PathEllipse {
        semi_major: (2.0 * major).sqrt(),
        semi_minor: (2.0 * minor).sqrt(),
        angle_rad: 0.5 * (2.0 * sxy).atan2(sxx - syy),
        sense: if area > 0.0 {
            1
        } else if area < 0.0 {
            -1
        } else {
            0
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn ellipse(a: f64, b: f64, angle: f64, turns: f64, n: usize, sense: f64) -> (Vec<f64>, Vec<f64>) {
        let (c, s) = (angle.cos(), angle.sin());
        (0..n)
            .map(|k| {
                let t = 2.0 * PI * turns * k as f64 / n as f64;
                let (u, v) = (a * t.cos(), sense * b * t.sin());
                (3.0 + c * u - s * v, -1.0 + s * u + c * v)
            })
            .unzip()
    }

    /// An ellipse of semi-axes 2 and 0.5 tilted by 30°, gone round five times either way, and a
    /// line: the semi-axes, the tilt and the sense come back.
    #[test]
    fn the_ellipse_of_a_planar_oscillation_comes_back() {
        let (x, y) = ellipse(2.0, 0.5, PI / 6.0, 5.0, 5000, 1.0);
        let e = path_ellipse(&x, &y).unwrap();
        assert!((e.semi_major - 2.0).abs() < 1e-9 && (e.semi_minor - 0.5).abs() < 1e-9, "{e:?}");
        assert!((e.angle_rad - PI / 6.0).abs() < 1e-9, "{e:?}");
        assert_eq!(e.sense, 1);
        assert!((e.roundness() - 0.25).abs() < 1e-9);
        let (x, y) = ellipse(2.0, 0.5, PI / 6.0, 5.0, 5000, -1.0);
        assert_eq!(path_ellipse(&x, &y).unwrap().sense, -1);
        let (x, y) = ellipse(1.0, 0.0, -PI / 4.0, 3.0, 999, 1.0);
        let e = path_ellipse(&x, &y).unwrap();
        assert!((e.semi_major - 1.0).abs() < 1e-9 && e.semi_minor < 1e-6 && (e.angle_rad + PI / 4.0).abs() < 1e-9, "{e:?}");
        assert!(path_ellipse(&[1.0; 10], &[2.0; 10]).is_none());
        assert!(path_ellipse(&[1.0, f64::NAN, 2.0], &[0.0; 3]).is_none());
    }
}
