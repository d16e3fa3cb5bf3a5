//! Cantilever beam against Euler–Bernoulli theory with the shear correction
//! (../shared/reference "Cantilever beam"): static tip deflection PL³/(3EI) + PL/(κGA),
//! κ = 5/6, and the first natural frequency (1.875104²/2π)√(EI/(ρAL⁴)); plane strain uses
//! E/(1−ν²). The beam lies along x (length L from the clamp face x = 0), its thickness h along
//! y and (3D) its width along z; `clamp_layers` particle layers at x < 0 are fixed.

use crate::analysis::beam::BeamTheory;
use crate::solid::particles::sample_box;
use crate::solid::{Integrator, Orthotropic, Particles, SolidOptions, SolidSolver};
use glam::DVec3;

#[derive(Clone, Debug)]
pub struct Cantilever {
    pub dim: usize,
    pub length: f64,
    pub thickness: f64,
    /// Width along z (3D only).
    pub width: f64,
    pub spacing: f64,
    pub clamp_layers: usize,
    pub young: f64,
    pub poisson: f64,
    pub density: f64,
}

impl Cantilever {
    /// A steel-like slab in cgs with L/h = 10: h = `cells` particles thick.
    pub fn slender(dim: usize, cells: usize) -> Self {
        let h = 1.0;
        Self { dim, length: 10.0 * h, thickness: h, width: h, spacing: h / cells as f64, clamp_layers: 3, young: 1.0e7, poisson: 0.3, density: 1.0 }
    }

    pub fn material(&self) -> Orthotropic {
        Orthotropic::isotropic(self.young, self.poisson, self.density, 0.0)
    }

    pub fn particles(&self) -> Particles {
        let mut p = Particles::new(self.dim, self.spacing);
        let l0 = self.spacing;
        let z = if self.dim == 3 { self.width } else { 0.0 };
        let clamp = self.clamp_layers as f64 * l0;
        for x in sample_box(self.dim, DVec3::new(-clamp, 0.0, 0.0), DVec3::new(self.length, self.thickness, z), l0) {
            p.push(x, self.density, 0, 0, x.x < 0.0);
        }
        p
    }

    /// Indices of the particles of the last column (x > L − l₀).
    pub fn tip(&self, p: &Particles) -> Vec<usize> {
        (0..p.len()).filter(|&i| p.reference[i].x > self.length - self.spacing).collect()
    }

    /// The beam theory of this cantilever ([`crate::analysis::beam`]).
    pub fn theory(&self) -> BeamTheory {
        BeamTheory {
            dim: self.dim,
            length: self.length,
            thickness: self.thickness,
            width: self.width,
            young: self.young,
            poisson: self.poisson,
            density: self.density,
        }
    }

    /// Beam-theory tip deflection under a tip load P (per unit depth in 2D), with the shear term.
    pub fn static_deflection(&self, load: f64) -> f64 {
        self.theory().static_deflection(load)
    }

    /// First natural frequency (Hz) of Euler–Bernoulli theory.
    pub fn first_frequency(&self) -> f64 {
        self.theory().first_frequency()
    }

    pub fn solver(&self, options: SolidOptions) -> SolidSolver {
        SolidSolver::new(self.particles(), vec![self.material()], options).expect("valid cantilever")
    }
}

/// Mean y displacement of the tip particles.
pub fn tip_deflection(s: &SolidSolver, tip: &[usize]) -> f64 {
    tip.iter().map(|&i| s.particles.position[i].y - s.particles.reference[i].y).sum::<f64>() / tip.len() as f64
}

/// Static tip deflection measured by quasi-static implicit steps (backward Euler with a step
/// far beyond the first period converges to the equilibrium of the full nonlinear model).
/// Returns (measured, beam theory, CG iterations of the last step).
pub fn static_tip_deflection(c: &Cantilever, load_fraction_of_h: f64) -> (f64, f64, usize) {
    // load giving a deflection of `load_fraction_of_h` × h by beam theory
    let unit = c.static_deflection(1.0);
    let load = load_fraction_of_h * c.thickness / unit;
    let period = 1.0 / c.first_frequency();
    let mut s = c.solver(SolidOptions { integrator: Integrator::Implicit, time_step: Some(50.0 * period), cg_tolerance: 1e-10, ..Default::default() });
    let tip = c.tip(&s.particles);
    for &i in &tip {
        s.particles.load[i] = DVec3::new(0.0, -load / tip.len() as f64, 0.0);
    }
    let mut last = f64::NAN;
    for _ in 0..40 {
        s.step().expect("the loaded cantilever stays finite");
        // kill the velocity so each step is a Newton step towards equilibrium
        s.particles.velocity.iter_mut().for_each(|v| *v = DVec3::ZERO);
        let d = -tip_deflection(&s, &tip);
        if (d - last).abs() < 1e-9 * d.abs() {
            last = d;
            break;
        }
        last = d;
    }
    (last, c.static_deflection(load), s.last.cg.iterations)
}

/// The oscillating plate of Gray, Monaghan & Swift (2001) (../shared/reference): L = 0.2 m,
/// H = 0.02 m, ρ = 1000 kg/m³, E = 2 MPa, ν = 0.3975, plane strain, clamped at x = 0, released
/// with the first-mode velocity profile v_y = V_f c f(x)/f(L), V_f = 0.01, c = √(E/ρ).
pub fn oscillating_plate(cells: usize) -> Cantilever {
    Cantilever {
        dim: 2,
        length: 0.2,
        thickness: 0.02,
        width: 0.0,
        spacing: 0.02 / cells as f64,
        clamp_layers: 3,
        young: 2.0e6,
        poisson: 0.3975,
        density: 1000.0,
    }
}

pub use crate::analysis::beam::first_mode_shape;

/// Sets the first-mode velocity profile with tip speed `tip_speed` on the beam particles.
pub fn release_in_first_mode(s: &mut SolidSolver, c: &Cantilever, tip_speed: f64) {
    let fl = first_mode_shape(c.length, c.length);
    for i in 0..s.particles.len() {
        if !s.particles.fixed[i] {
            let x = s.particles.reference[i].x;
            s.particles.velocity[i] = DVec3::new(0.0, tip_speed * first_mode_shape(x, c.length) / fl, 0.0);
        }
    }
}

/// Result of a free-vibration run.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Vibration {
    /// Mean period from upward zero crossings of the tip deflection (interpolated), s.
    pub period: f64,
    pub periods_measured: usize,
    /// Max |E(t) − E(0)| / E(0) over the run.
    pub energy_drift: f64,
    /// Max tip amplitude in the first and in the last measured period.
    pub first_amplitude: f64,
    pub last_amplitude: f64,
    pub steps: u64,
    pub dt: f64,
    pub wall_s: f64,
}

/// Runs until `periods` upward zero crossings of the tip deflection after the first (or until
/// `max_time`), measuring the period and the energy drift (sampled every `energy_every` steps).
pub fn free_vibration(s: &mut SolidSolver, c: &Cantilever, periods: usize, max_time: f64, energy_every: u64) -> Vibration {
    let t0 = std::time::Instant::now();
    let tip = c.tip(&s.particles);
    let e0 = s.energies().total();
    let mut drift: f64 = 0.0;
    let mut prev = tip_deflection(s, &tip);
    let mut crossings: Vec<f64> = Vec::new();
    let mut amps: Vec<f64> = vec![0.0];
    while s.time < max_time && crossings.len() < periods + 1 {
        if s.step().is_err() {
            break;
        }
        let d = tip_deflection(s, &tip);
        if let Some(a) = amps.last_mut() {
            *a = a.max(d.abs());
        }
        if prev < 0.0 && d >= 0.0 {
            let frac = prev / (prev - d);
            crossings.push(s.time - s.dt + frac * s.dt);
            amps.push(0.0);
        }
        prev = d;
        if s.step_count.is_multiple_of(energy_every) {
            let e = s.energies().total();
            drift = drift.max((e - e0).abs() / e0.abs());
        }
    }
    let n = crossings.len();
    let period = if n >= 2 { (crossings[n - 1] - crossings[0]) / (n - 1) as f64 } else { f64::NAN };
    Vibration {
        period,
        periods_measured: n.saturating_sub(1),
        energy_drift: drift,
        first_amplitude: amps.get(1).copied().unwrap_or(f64::NAN),
        last_amplitude: if n >= 2 { amps[n - 1] } else { f64::NAN },
        steps: s.step_count,
        dt: s.dt,
        wall_s: t0.elapsed().as_secs_f64(),
    }
}
