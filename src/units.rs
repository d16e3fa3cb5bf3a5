//! Physical (cgs or SI) ↔ lattice units, one formula per conversion.
//!
//! Lattice units: node spacing Δx = 1, lattice speed c = 1, reference density ρ₀ = 1, reference
//! reduced temperature θ₀ = T₀ (chosen inside the velocity set's positivity window), so the
//! lattice sound speed is c_s = √(γθ₀). The physical velocity of one lattice speed unit is
//! U = c_s,phys / c_s,lat, where c_s,phys is the gas's real sound speed — or, with Mach scaling
//! (an artificial sound speed for low-Mach scenes), u_ref / (Ma · c_s,lat) so that the reference
//! velocity has lattice Mach number Ma. The lattice time unit is Δx/U.

use serde::Serialize;

/// Scale factors between a scene's physical units and lattice units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Units {
    /// Node spacing Δx (cm or m).
    pub dx: f64,
    /// Physical velocity of one lattice velocity unit (cm/s or m/s).
    pub velocity: f64,
    /// Reference density ρ₀ (g/cm³ or kg/m³).
    pub density: f64,
    /// Lattice reference temperature θ₀ (c²).
    pub theta0: f64,
    /// Ratio of specific heats of the lattice gas.
    pub gamma: f64,
    /// Effective sound speed the run uses (physical units); equals the real one unless Mach
    /// scaling is on.
    pub sound_speed: f64,
}

impl Units {
    /// `sound_speed`: the physical sound speed the lattice must reproduce (the gas's, or the
    /// artificial one of Mach scaling).
    pub fn new(dx: f64, density: f64, sound_speed: f64, theta0: f64, gamma: f64) -> Self {
        let cs_lat = (gamma * theta0).sqrt();
        Units { dx, velocity: sound_speed / cs_lat, density, theta0, gamma, sound_speed }
    }

    /// Lattice time unit Δx/U (s).
    pub fn time(&self) -> f64 {
        self.dx / self.velocity
    }
    pub fn length_to_lattice(&self, l: f64) -> f64 {
        l / self.dx
    }
    pub fn length_to_physical(&self, l: f64) -> f64 {
        l * self.dx
    }
    /// Position (physical, measured from the domain origin) → interior node coordinates.
    pub fn position_to_lattice(&self, p: f64) -> f64 {
        p / self.dx - 0.5
    }
    pub fn velocity_to_lattice(&self, u: f64) -> f64 {
        u / self.velocity
    }
    pub fn velocity_to_physical(&self, u: f64) -> f64 {
        u * self.velocity
    }
    pub fn time_to_lattice(&self, t: f64) -> f64 {
        t / self.time()
    }
    pub fn time_to_physical(&self, t: f64) -> f64 {
        t * self.time()
    }
    /// Kinematic viscosity ν (cm²/s or m²/s) → lattice (Δx·U).
    pub fn kinematic_viscosity_to_lattice(&self, nu: f64) -> f64 {
        nu / (self.dx * self.velocity)
    }
    /// Pressure unit ρ₀U².
    pub fn pressure_unit(&self) -> f64 {
        self.density * self.velocity * self.velocity
    }
    /// Absolute lattice pressure ρθ → gauge pressure relative to the reference state ρ₀θ₀ (physical).
    pub fn gauge_pressure_to_physical(&self, p_lattice: f64) -> f64 {
        (p_lattice - self.theta0) * self.pressure_unit()
    }
    /// Gauge pressure (physical) → absolute lattice pressure.
    pub fn gauge_pressure_to_lattice(&self, p: f64) -> f64 {
        self.theta0 + p / self.pressure_unit()
    }
    pub fn density_to_physical(&self, rho: f64) -> f64 {
        rho * self.density
    }
    /// Body force per unit mass (acceleration) → lattice (U²/Δx).
    pub fn acceleration_to_lattice(&self, g: f64) -> f64 {
        g * self.dx / (self.velocity * self.velocity)
    }
    /// Frequency (Hz) of a lattice frequency.
    pub fn frequency_to_physical(&self, f: f64) -> f64 {
        f / self.time()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn round_trips_and_sound_speed() {
        // Air in cgs: c = 34300 cm/s; D2Q21 γ = 2 at θ₀ = 0.6 ⇒ c_s,lat = √1.2.
        let u = Units::new(0.01, 1.184e-3, 34300.0, 0.6, 2.0);
        let cs_lat = (2.0f64 * 0.6).sqrt();
        assert!((u.velocity_to_physical(cs_lat) - 34300.0).abs() < 1e-9);
        assert!((u.time_to_physical(u.time_to_lattice(1.3e-3)) - 1.3e-3).abs() < 1e-15);
        // p₀ = ρ₀c²/γ
        let p0 = u.theta0 * u.pressure_unit();
        assert!((p0 - 1.184e-3 * 34300.0f64.powi(2) / 2.0).abs() / p0 < 1e-12);
        assert!((u.gauge_pressure_to_physical(u.gauge_pressure_to_lattice(8000.0)) - 8000.0).abs() < 1e-6);
    }
}
