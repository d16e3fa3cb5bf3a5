//! A clamped–free beam by beam theory (../shared/reference "Cantilever beam"): the static tip
//! deflection under a tip load, Euler–Bernoulli bending plus the shear correction
//! δ = PL³/(3EI) + PL/(κGA), κ = 5/6; the first natural frequency
//! f₁ = (1.875104²/2π) √(EI/(ρAL⁴)); and the first mode's shape. Plane strain (2D, per unit
//! depth) uses E/(1 − ν²); the oscillating plate of Gray, Monaghan & Swift (2001) is this beam.

/// β₁L of the clamped–free beam's first mode: the smallest root of cos βL cosh βL = −1.
pub const FIRST_MODE_BETA_L: f64 = 1.875104;

/// A straight, isotropic, clamped–free beam along x (any consistent units: cgs or SI).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct BeamTheory {
    /// 2: plane strain, per unit depth; 3: a beam of `width` along z.
    pub dim: usize,
    /// Free length from the clamp's face to the tip (length).
    pub length: f64,
    /// Along y, the direction it bends in (length).
    pub thickness: f64,
    /// Along z (3D only; length).
    pub width: f64,
    /// Young's modulus (pressure) and Poisson's ratio.
    pub young: f64,
    pub poisson: f64,
    /// Mass per volume.
    pub density: f64,
}

impl BeamTheory {
    /// Effective modulus (plane strain in 2D), second moment of area and area of the section.
    pub fn section(&self) -> (f64, f64, f64) {
        let nu = self.poisson;
        if self.dim == 2 {
            (self.young / (1.0 - nu * nu), self.thickness.powi(3) / 12.0, self.thickness)
        } else {
            (self.young, self.width * self.thickness.powi(3) / 12.0, self.width * self.thickness)
        }
    }

    /// Tip deflection (length, along the load) under a tip load `load` (force; per unit depth in
    /// 2D), bending and shear (κ = 5/6).
    pub fn static_deflection(&self, load: f64) -> f64 {
        let (e, i, a) = self.section();
        let g = self.young / (2.0 * (1.0 + self.poisson));
        load * self.length.powi(3) / (3.0 * e * i) + load * self.length / (5.0 / 6.0 * g * a)
    }

    /// First natural frequency (1/time), Euler–Bernoulli.
    pub fn first_frequency(&self) -> f64 {
        let (e, i, a) = self.section();
        FIRST_MODE_BETA_L.powi(2) / (2.0 * std::f64::consts::PI) * (e * i / (self.density * a * self.length.powi(4))).sqrt()
    }
}

/// The first mode's shape of a clamped–free beam of `length` at `x` from the clamp (0 at the
/// clamp; unnormalised: divide by its value at x = L for a unit tip).
pub fn first_mode_shape(x: f64, length: f64) -> f64 {
    let kl = FIRST_MODE_BETA_L;
    let k = kl / length;
    let a = (kl.cos() + kl.cosh()) / (kl.sin() + kl.sinh());
    ((k * x).cos() - (k * x).cosh()) - a * ((k * x).sin() - (k * x).sinh())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The oscillating plate of Gray, Monaghan & Swift (2001): L = 0.2 m, H = 0.02 m,
    /// E = 2 MPa, ν = 0.3975, ρ = 1000 kg/m³, plane strain — their period 0.254 s. The
    /// cantilever scene's load gives its 1.0·10⁻² cm (the two terms written out), and the first
    /// mode is clamped (shape and slope 0 at x = 0) and free (curvature 0 at x = L).
    #[test]
    fn beam_theory_gives_the_plates_period_and_the_cantilevers_deflection() {
        let plate = BeamTheory { dim: 2, length: 0.2, thickness: 0.02, width: 0.0, young: 2.0e6, poisson: 0.3975, density: 1000.0 };
        let period = 1.0 / plate.first_frequency();
        assert!((period - 0.254).abs() < 5e-4, "{period}");
        // the cantilever scene: L/h = 10, E = 10⁷, ν = 0.3, 27.24 per unit depth → 1.0·10⁻² cm
        let c = BeamTheory { dim: 2, length: 10.0, thickness: 1.0, width: 0.0, young: 1.0e7, poisson: 0.3, density: 1.0 };
        let bending = 27.24 * 1000.0 / (3.0 * 1.0e7 / (1.0 - 0.09) / 12.0);
        let shear = 27.24 * 10.0 / (5.0 / 6.0 * 1.0e7 / 2.6);
        assert!((c.static_deflection(27.24) - (bending + shear)).abs() < 1e-15);
        assert!((c.static_deflection(27.24) - 1.0e-2).abs() < 1e-5, "{}", c.static_deflection(27.24));
        // 3D: the width scales the load it takes, not the deflection per load per width
        let c3 = BeamTheory { dim: 3, width: 2.0, ..c };
        assert!((c3.static_deflection(2.0) / BeamTheory { dim: 3, width: 1.0, ..c }.static_deflection(1.0) - 1.0).abs() < 1e-12);
        let (l, h) = (0.2, 1e-6);
        assert!(first_mode_shape(0.0, l).abs() < 1e-12 && (first_mode_shape(h, l) / first_mode_shape(l, l)).abs() < 1e-9);
        // one-sided second-order second derivative at the tip, against the scale φ(L) β²
        let (d, f) = (1e-3, |x: f64| first_mode_shape(x, l));
        let curvature = (2.0 * f(l) - 5.0 * f(l - d) + 4.0 * f(l - 2.0 * d) - f(l - 3.0 * d)) / (d * d);
        let scale = f(l) * (FIRST_MODE_BETA_L / l).powi(2);
        assert!(curvature.abs() < 1e-3 * scale.abs(), "{curvature} against {scale}");
    }
}
