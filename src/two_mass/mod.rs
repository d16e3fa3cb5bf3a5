//! The Ishizaka–Flanagan (1972) two-mass model of the vocal folds: the yardstick the 2D/3D
//! glottis is compared with. Each fold is two masses (lower m₁, upper m₂) on nonlinear springs,
//! coupled by k_c, driven by the quasi-steady glottal flow (Bernoulli with the vena-contracta
//! entrance loss and viscous Poiseuille losses); the folds are symmetric and collide at the
//! mid-line through an extra nonlinear spring. Units cgs throughout (g, cm, s, dyn).
//!
//! Ishizaka K., Flanagan J. L., "Synthesis of voiced sounds from a two-mass model of the vocal
//! cords", Bell Syst. Tech. J. 51 (1972) 1233–1268; parameters and the 8 cmH₂O result in
//! ../shared/reference/README.md.

pub mod model;

pub use model::{TwoMass, TwoMassRun, glottal_flow, simulate, simulate_from};

use serde::{Deserialize, Serialize};

/// 1 cmH₂O in dyn/cm².
pub const CM_H2O: f64 = 980.665;

/// The model's parameters (cgs). `Default` is Ishizaka & Flanagan's standard set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TwoMassParams {
    /// Lower mass m₁ (g).
    pub m1: f64,
    /// Upper mass m₂ (g).
    pub m2: f64,
    /// Spring constants (dyn/cm).
    pub k1: f64,
    pub k2: f64,
    /// Coupling stiffness between the masses (dyn/cm).
    pub kc: f64,
    /// Damping ratios ζ₁, ζ₂ (open glottis); r = 2ζ√(mk).
    pub damping_ratio1: f64,
    pub damping_ratio2: f64,
    /// Added to the damping ratios while a mass is in collision.
    pub collision_damping_increase: f64,
    /// Collision spring h = this × k.
    pub collision_stiffness_factor: f64,
    /// Nonlinear spring coefficients (cm⁻²): s(x) = k x (1 + η_k x²), collision h y (1 + η_h y²).
    pub eta_k: f64,
    pub eta_h: f64,
    /// Thicknesses of the masses along the flow (cm).
    pub d1: f64,
    pub d2: f64,
    /// Glottal length (cm).
    pub length: f64,
    /// Rest areas of the two sections (cm²).
    pub rest_area1: f64,
    pub rest_area2: f64,
    /// Air density (g/cm³) and viscosity (poise).
    pub air_density: f64,
    pub air_viscosity: f64,
}

impl Default for TwoMassParams {
    fn default() -> Self {
        TwoMassParams {
            m1: 0.125,
            m2: 0.025,
            k1: 80_000.0,
            k2: 8_000.0,
            kc: 25_000.0,
            damping_ratio1: 0.1,
            damping_ratio2: 0.6,
            collision_damping_increase: 1.0,
            collision_stiffness_factor: 3.0,
            eta_k: 100.0,
            eta_h: 500.0,
            d1: 0.25,
            d2: 0.05,
            length: 1.4,
            rest_area1: 0.05,
            rest_area2: 0.05,
            air_density: 1.13e-3,
            air_viscosity: 1.86e-4,
        }
    }
}

impl TwoMassParams {
    /// The first parameter that is not a finite number in its physical range, named, with the
    /// reason.
    pub fn problem(&self) -> Option<(&'static str, String)> {
        let positive = [
            ("m1", self.m1),
            ("m2", self.m2),
            ("k1", self.k1),
            ("k2", self.k2),
            ("d1", self.d1),
            ("d2", self.d2),
            ("length", self.length),
            ("air_density", self.air_density),
            ("collision_stiffness_factor", self.collision_stiffness_factor),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Some((name, format!("must be a positive number (got {v})")));
            }
        }
        let non_negative = [
            ("kc", self.kc),
            ("damping_ratio1", self.damping_ratio1),
            ("damping_ratio2", self.damping_ratio2),
            ("collision_damping_increase", self.collision_damping_increase),
            ("eta_k", self.eta_k),
            ("eta_h", self.eta_h),
            ("rest_area1", self.rest_area1),
            ("rest_area2", self.rest_area2),
            ("air_viscosity", self.air_viscosity),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Some((name, format!("must be a finite number ≥ 0 (got {v})")));
            }
        }
        None
    }

    /// The highest natural angular frequency of the undamped, uncoupled-collision system
    /// (rad/s): the time step must resolve it.
    pub fn fastest_mode(&self) -> f64 {
        let h = self.collision_stiffness_factor;
        ((self.k1 * (1.0 + h) + self.kc) / self.m1).max((self.k2 * (1.0 + h) + self.kc) / self.m2).sqrt()
    }
}
