//! Exact solution of the Riemann problem for an ideal gas (Toro, *Riemann Solvers and Numerical
//! Methods for Fluid Dynamics*, ch. 4): the reference for the Sod shock tube.

/// One constant state (density, velocity, pressure).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    pub rho: f64,
    pub u: f64,
    pub p: f64,
}

/// The star region and the wave speeds of the solution.
#[derive(Clone, Copy, Debug)]
pub struct Solution {
    pub gamma: f64,
    pub left: State,
    pub right: State,
    pub p_star: f64,
    pub u_star: f64,
    pub rho_star_left: f64,
    pub rho_star_right: f64,
}

fn pressure_function(p: f64, s: State, gamma: f64) -> (f64, f64) {
    let a = (gamma * s.p / s.rho).sqrt();
    if p > s.p {
        let ak = 2.0 / ((gamma + 1.0) * s.rho);
        let bk = (gamma - 1.0) / (gamma + 1.0) * s.p;
        let q = (ak / (p + bk)).sqrt();
        ((p - s.p) * q, q * (1.0 - 0.5 * (p - s.p) / (bk + p)))
    } else {
        let pr = p / s.p;
        let e = (gamma - 1.0) / (2.0 * gamma);
        (2.0 * a / (gamma - 1.0) * (pr.powf(e) - 1.0), 1.0 / (s.rho * a) * pr.powf(-(gamma + 1.0) / (2.0 * gamma)))
    }
}

impl Solution {
    pub fn new(left: State, right: State, gamma: f64) -> Self {
        let mut p = 0.5 * (left.p + right.p);
        for _ in 0..100 {
            let (fl, dl) = pressure_function(p, left, gamma);
            let (fr, dr) = pressure_function(p, right, gamma);
            let f = fl + fr + right.u - left.u;
            let np = (p - f / (dl + dr)).max(1e-12);
            if (np - p).abs() < 1e-14 * p {
                p = np;
                break;
            }
            p = np;
        }
        let (fl, _) = pressure_function(p, left, gamma);
        let (fr, _) = pressure_function(p, right, gamma);
        let u_star = 0.5 * (left.u + right.u) + 0.5 * (fr - fl);
        let g = (gamma - 1.0) / (gamma + 1.0);
        let rho_side = |s: State| {
            if p > s.p { s.rho * (p / s.p + g) / (g * p / s.p + 1.0) } else { s.rho * (p / s.p).powf(1.0 / gamma) }
        };
        Solution { gamma, left, right, p_star: p, u_star, rho_star_left: rho_side(left), rho_star_right: rho_side(right) }
    }

    /// Speed of the right-moving shock (assumes p* > p_R, as in Sod's problem).
    pub fn right_shock_speed(&self) -> f64 {
        let g = self.gamma;
        let s = self.right;
        let a = (g * s.p / s.rho).sqrt();
        s.u + a * ((g + 1.0) / (2.0 * g) * self.p_star / s.p + (g - 1.0) / (2.0 * g)).sqrt()
    }

    /// Sampled state at x/t = `xi` (Toro §4.5).
    pub fn sample(&self, xi: f64) -> State {
        let g = self.gamma;
        let (l, r) = (self.left, self.right);
        if xi <= self.u_star {
            let al = (g * l.p / l.rho).sqrt();
            if self.p_star > l.p {
                let sl = l.u - al * ((g + 1.0) / (2.0 * g) * self.p_star / l.p + (g - 1.0) / (2.0 * g)).sqrt();
                if xi < sl { l } else { State { rho: self.rho_star_left, u: self.u_star, p: self.p_star } }
            } else {
                let head = l.u - al;
                let a_star = al * (self.p_star / l.p).powf((g - 1.0) / (2.0 * g));
                let tail = self.u_star - a_star;
                if xi < head {
                    l
                } else if xi > tail {
                    State { rho: self.rho_star_left, u: self.u_star, p: self.p_star }
                } else {
                    let c = 2.0 / (g + 1.0) + (g - 1.0) / ((g + 1.0) * al) * (l.u - xi);
                    let u = 2.0 / (g + 1.0) * (al + (g - 1.0) / 2.0 * l.u + xi);
                    State { rho: l.rho * c.powf(2.0 / (g - 1.0)), u, p: l.p * c.powf(2.0 * g / (g - 1.0)) }
                }
            }
        } else if xi > self.right_shock_speed() {
            r
        } else {
            State { rho: self.rho_star_right, u: self.u_star, p: self.p_star }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn sod_gamma_14_matches_toro() {
        // Toro Table 4.3, test 1: p* = 0.30313, u* = 0.92745, ρ*L = 0.42632, ρ*R = 0.26557.
        let s = Solution::new(State { rho: 1.0, u: 0.0, p: 1.0 }, State { rho: 0.125, u: 0.0, p: 0.1 }, 1.4);
        assert!((s.p_star - 0.30313).abs() < 1e-4);
        assert!((s.u_star - 0.92745).abs() < 1e-4);
        assert!((s.rho_star_left - 0.42632).abs() < 1e-4);
        assert!((s.rho_star_right - 0.26557).abs() < 1e-4);
    }
}
