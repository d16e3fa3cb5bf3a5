//! Discrete velocity sets of the thermal FDLB model (seed 000 §2.3, Figs. 2.3–2.4):
//! **D2Q21** (Watari & Tsutahara 2003) and **D3Q39** (Watari & Tsutahara 2004).
//!
//! Velocities are integer vectors in units of the lattice speed `c` (= one cell per lattice
//! time unit). Each velocity belongs to a *shell* (all vectors obtained from one prototype by
//! sign changes and axis permutations); the equilibrium weight of a velocity is its shell's
//! coefficient `F(T)`, a polynomial in the reduced temperature `T = θ / c²`, where
//! `θ = p / ρ` (velocity², the "RT" of the gas).
//!
//! **Decision on the seed's notation.** The seed writes `B = −1/(2e)` in (2.82) and (2.89).
//! Expanding the Maxwellian `exp(−(c−u)²/(2θ))` to third order gives exactly the bracket of
//! (2.78) with `B = −1/(2θ)`. In 2D the internal energy of the monatomic model is `e = θ`, so the
//! seed is right as written; in 3D `e = 3θ/2`, and the coefficients (2.90–2.95) reproduce the
//! Maxwellian moments (and reduce to Shan's D3Q39 weights at `T = 2/3`) only with `B = −1/(2θ)`.
//! We therefore write every coefficient in terms of `T = θ/c²`, and reserve `e` for the internal
//! energy (`e = Dθ/2`, plus rotational energy for the diatomic gas).
//!
//! **Decision on (2.95).** The extracted `F31 = −(1/(20B²c⁴))(7/(16Bc²) + 1)` breaks mass
//! conservation (`Σ w − 1 = 2T²(7T − 8)/5`); with the opposite sign, `F31 = T²/5 − 7T³/40`, the
//! set reproduces every Maxwellian moment through 4th order for all `T` and becomes Shan's D3Q39
//! at `T = 2/3`. The test `fluid_moments` proves both statements.

use serde::{Deserialize, Serialize};

/// Which discrete velocity set a lattice uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Hash)]
#[serde(rename_all = "snake_case")]
pub enum VelocitySetKind {
    /// 2D, 21 velocities, exact Maxwellian moments through 6th order.
    D2q21,
    /// 3D, 39 velocities, exact through 4th order (6th order exact at T = 2/3).
    D3q39,
}

/// One shell: every sign/permutation image of `prototype`, with weight `weight(T)`.
#[derive(Clone, Copy, Debug)]
pub struct Shell {
    /// Name used in the seed (`F0`, `F11`, …).
    pub name: &'static str,
    /// Prototype velocity (units of c).
    pub prototype: [i32; 3],
    /// Coefficients `[a0, a1, a2, a3]` of `F(T) = a0 + a1 T + a2 T² + a3 T³`.
    pub poly: [f64; 4],
}

impl Shell {
    /// Weight of each velocity of this shell at reduced temperature `t = θ/c²`.
    #[inline]
    pub fn weight(&self, t: f64) -> f64 {
        let [a0, a1, a2, a3] = self.poly;
        a0 + t * (a1 + t * (a2 + t * a3))
    }
}

// D2Q21 shells: (2.83)–(2.88) with B = −1/(2T), c = 1, expanded to polynomials in T.
//   F0  = 1 − 49T/18 + 175T²/48 − 85T³/48
//   F11 = 3T/4 − 71T²/48 + 13T³/16         (1,0)
//   F12 = −3T/40 + 25T²/96 − 5T³/32        (2,0)
//   F13 = T/180 − T²/48 + T³/48            (3,0)
//   F21 = T²/3 − T³/4                      (1,1)
//   F22 = −T²/192 + T³/64                  (2,2)
const D2Q21_SHELLS: [Shell; 6] = [
    Shell { name: "F0", prototype: [0, 0, 0], poly: [1.0, -49.0 / 18.0, 175.0 / 48.0, -85.0 / 48.0] },
    Shell { name: "F11", prototype: [1, 0, 0], poly: [0.0, 3.0 / 4.0, -71.0 / 48.0, 13.0 / 16.0] },
    Shell { name: "F12", prototype: [2, 0, 0], poly: [0.0, -3.0 / 40.0, 25.0 / 96.0, -5.0 / 32.0] },
    Shell { name: "F13", prototype: [3, 0, 0], poly: [0.0, 1.0 / 180.0, -1.0 / 48.0, 1.0 / 48.0] },
    Shell { name: "F21", prototype: [1, 1, 0], poly: [0.0, 0.0, 1.0 / 3.0, -1.0 / 4.0] },
    Shell { name: "F22", prototype: [2, 2, 0], poly: [0.0, 0.0, -1.0 / 192.0, 1.0 / 64.0] },
];

// D3Q39 shells: (2.90)–(2.95) with B = −1/(2T), c = 1, F31 with the corrected sign.
//   F0  = 1 − 49T/12 + 1549T²/240 − 287T³/80
//   F11 = 3T/4 − 379T²/240 + 77T³/80       (1,0,0)
//   F12 = −3T/40 + 329T²/1200 − 77T³/400   (2,0,0)
//   F13 = T/180 − 67T²/3600 + 7T³/400      (3,0,0)
//   F22 = −3T²/320 + 7T³/320               (2,2,0)
//   F31 = T²/5 − 7T³/40                    (1,1,1)
const D3Q39_SHELLS: [Shell; 6] = [
    Shell { name: "F0", prototype: [0, 0, 0], poly: [1.0, -49.0 / 12.0, 1549.0 / 240.0, -287.0 / 80.0] },
    Shell { name: "F11", prototype: [1, 0, 0], poly: [0.0, 3.0 / 4.0, -379.0 / 240.0, 77.0 / 80.0] },
    Shell { name: "F12", prototype: [2, 0, 0], poly: [0.0, -3.0 / 40.0, 329.0 / 1200.0, -77.0 / 400.0] },
    Shell { name: "F13", prototype: [3, 0, 0], poly: [0.0, 1.0 / 180.0, -67.0 / 3600.0, 7.0 / 400.0] },
    Shell { name: "F22", prototype: [2, 2, 0], poly: [0.0, 0.0, -3.0 / 320.0, 7.0 / 320.0] },
    Shell { name: "F31", prototype: [1, 1, 1], poly: [0.0, 0.0, 1.0 / 5.0, -7.0 / 40.0] },
];

/// The (2.95) coefficient exactly as the extracted seed text writes it, kept only so that a
/// test can show why it was corrected: `F31 = −T²/5 + 7T³/40`.
pub const D3Q39_F31_AS_EXTRACTED: Shell = Shell { name: "F31 (seed text)", prototype: [1, 1, 1], poly: [0.0, 0.0, -1.0 / 5.0, 7.0 / 40.0] };

/// A velocity set with its velocities enumerated shell by shell.
#[derive(Clone, Debug)]
pub struct VelocitySet {
    pub kind: VelocitySetKind,
    /// Spatial dimension (2 or 3).
    pub dim: usize,
    /// Velocities in units of c; `c[i][2] == 0` in 2D.
    pub c: Vec<[i32; 3]>,
    /// Shell index of every velocity.
    pub shell_of: Vec<usize>,
    pub shells: Vec<Shell>,
}

impl VelocitySet {
    pub fn new(kind: VelocitySetKind) -> Self {
        let (dim, shells): (usize, &[Shell]) = match kind {
            VelocitySetKind::D2q21 => (2, &D2Q21_SHELLS),
            VelocitySetKind::D3q39 => (3, &D3Q39_SHELLS),
        };
        Self::from_shells(kind, dim, shells)
    }

    /// Builds a set from arbitrary shells (used by tests to probe the seed's literal text).
    pub fn from_shells(kind: VelocitySetKind, dim: usize, shells: &[Shell]) -> Self {
        let mut c = Vec::new();
        let mut shell_of = Vec::new();
        for (s, shell) in shells.iter().enumerate() {
            for v in shell_images(shell.prototype, dim) {
                c.push(v);
                shell_of.push(s);
            }
        }
        VelocitySet { kind, dim, c, shell_of, shells: shells.to_vec() }
    }

    /// Number of velocities Q.
    pub fn q(&self) -> usize {
        self.c.len()
    }

    /// Largest speed along one axis, max |c_iα| (cells per lattice time unit).
    pub fn max_axis_speed(&self) -> i32 {
        self.c.iter().flat_map(|v| v.iter().map(|x| x.abs())).max().unwrap_or(0)
    }

    /// max_i Σ_α |c_iα|: sets the advection stability limit of the axis-wise upwind scheme.
    pub fn max_l1_speed(&self) -> i32 {
        self.c.iter().map(|v| v.iter().map(|x| x.abs()).sum::<i32>()).max().unwrap_or(0)
    }

    /// Weights of every velocity at reduced temperature `t = θ/c²`.
    pub fn weights(&self, t: f64) -> Vec<f64> {
        let per_shell: Vec<f64> = self.shells.iter().map(|s| s.weight(t)).collect();
        self.shell_of.iter().map(|&s| per_shell[s]).collect()
    }

    /// Fills `out[s]` with each shell's weight (no allocation; hot path).
    #[inline]
    pub fn shell_weights_into(&self, t: f64, out: &mut [f64]) {
        for (o, s) in out.iter_mut().zip(&self.shells) {
            *o = s.weight(t);
        }
    }

    /// Index of the mirror image of velocity `i` across a plane normal to `axis` (c_i with its
    /// `axis` component negated).
    pub fn mirror(&self, axis: usize, i: usize) -> usize {
        let mut v = self.c[i];
        v[axis] = -v[axis];
        self.c.iter().position(|w| *w == v).expect("symmetric set")
    }

    /// Index of the velocity opposite to `i` (c_opp = −c_i).
    pub fn opposite(&self, i: usize) -> usize {
        let v = self.c[i];
        self.c.iter().position(|w| w[0] == -v[0] && w[1] == -v[1] && w[2] == -v[2]).expect("symmetric set")
    }

    /// The open interval of reduced temperatures T in which every weight is positive, found by
    /// bisection on the shell polynomials from a point known to be inside (T = 0.6).
    pub fn positivity_window(&self) -> (f64, f64) {
        let inside = |t: f64| self.shells.iter().all(|s| s.weight(t) > 0.0);
        let t_in = 0.6;
        assert!(inside(t_in), "0.6 must lie inside the positivity window");
        let edge = |mut a: f64, mut b: f64| {
            // a inside, b outside
            for _ in 0..200 {
                let m = 0.5 * (a + b);
                if inside(m) { a = m } else { b = m }
            }
            a
        };
        (edge(t_in, 0.0), edge(t_in, 3.0))
    }
}

/// All distinct vectors obtained from `p` by permuting its first `dim` components and flipping
/// signs.
fn shell_images(p: [i32; 3], dim: usize) -> Vec<[i32; 3]> {
    let mut out: Vec<[i32; 3]> = Vec::new();
    let perms: &[[usize; 3]] = if dim == 2 { &[[0, 1, 2], [1, 0, 2]] } else { &[[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]] };
    for perm in perms {
        for signs in 0..8u32 {
            let mut v = [0i32; 3];
            for a in 0..3 {
                let s = if signs & (1 << a) != 0 { -1 } else { 1 };
                v[a] = s * p[perm[a]];
            }
            if dim == 2 && v[2] != 0 {
                continue;
            }
            if !out.contains(&v) {
                out.push(v);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(VelocitySet::new(VelocitySetKind::D2q21).q(), 21);
        assert_eq!(VelocitySet::new(VelocitySetKind::D3q39).q(), 39);
    }

    #[test]
    fn windows_match_design_digest() {
        let (lo, hi) = VelocitySet::new(VelocitySetKind::D2q21).positivity_window();
        assert!((lo - 0.370).abs() < 1e-3 && (hi - 1.148).abs() < 1e-3, "{lo} {hi}");
        let (lo, hi) = VelocitySet::new(VelocitySetKind::D3q39).positivity_window();
        assert!((lo - 0.429).abs() < 1e-3 && (hi - 0.837).abs() < 1e-3, "{lo} {hi}");
    }
}
