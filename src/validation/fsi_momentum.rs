//! Momentum budget and added-mass stability of the couplings (issue 12): a free elastic disc in
//! a fully periodic box of air, hit by a pressure pulse.

use super::fsi::{d2q21_air, disc_body, lattice_units};
use crate::coupling::{BodySurface, ReferenceShape};
use crate::coupling::{CoupledBody, CoupledSolver, Method, WeakOptions};
use crate::fluid::{Boundaries, FluidSolver, Grid, Macro, timestep};
use crate::fluid::{Equilibrium, GasModel, VelocitySet, VelocitySetKind};
use crate::solid::Particles;
use crate::solid::particles::sample_ball;
use crate::solid::{Orthotropic, SolidOptions, SolidSolver};
use glam::DVec3;

/// Total momentum of air + a free elastic disc in a fully periodic box after a pressure pulse.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MomentumResult {
    pub steps: u64,
    /// |Δ(P_fluid + P_solid)| / the largest |P_solid| reached (the momentum the pulse gave the body).
    pub relative_drift: f64,
    pub largest_solid_momentum: f64,
    pub final_fluid_momentum: [f64; 2],
    pub final_solid_momentum: [f64; 2],
    /// Largest |Σ m_a v| (method 2's added mass: momentum in transit, part of the total).
    pub largest_in_transit: f64,
    /// Largest |Δ(P_fluid + P_solid)| of a single step.
    pub worst_step_change: f64,
    /// The round-off of one pass over the populations: ε·Σ_nodes Σ_i |c_i| f_i at the start
    /// (physical units), the size of a step's unavoidable rounding of the air's momentum.
    pub roundoff_scale: f64,
}

/// A free, neutrally buoyant elastic disc (D = `cells_per_diameter`) in a periodic box of
/// 6 × 6 diameters, hit by a Gaussian pressure pulse (amplitude `amplitude` of the density)
/// centred 1.5 D to its left; momentum budget over `steps` weak-coupling steps.
pub fn pressure_pulse_momentum(cells_per_diameter: usize, amplitude: f64, steps: u64) -> MomentumResult {
    pulse_on_a_free_disc(cells_per_diameter, amplitude, steps, 1.0).expect("the pulse stays stable")
}

/// [`pressure_pulse_momentum`] with a disc of density `density` (the air's is 1); an
/// instability is returned, not a panic.
pub fn pulse_on_a_free_disc(cells_per_diameter: usize, amplitude: f64, steps: u64, density: f64) -> Result<MomentumResult, crate::step::Instability> {
    pulse_on_a_free_disc_by(Method::Weak(WeakOptions::default()), cells_per_diameter, amplitude, steps, density)
}

/// [`pulse_on_a_free_disc`] coupled by `method`.
pub fn pulse_on_a_free_disc_by(
    method: Method,
    cells_per_diameter: usize,
    amplitude: f64,
    steps: u64,
    density: f64,
) -> Result<MomentumResult, crate::step::Instability> {
    pulse_on_a_free_body(2, method, cells_per_diameter, amplitude, steps, density)
}

/// The pulse case in `dim` dimensions: in 3D (D3Q39) a free elastic ball in a periodic cube of
/// 6 diameters (method 2 only: method 1 has no 3D surface).
pub fn pulse_on_a_free_body(
    dim: usize,
    method: Method,
    cells_per_diameter: usize,
    amplitude: f64,
    steps: u64,
    density: f64,
) -> Result<MomentumResult, crate::step::Instability> {
    let d = cells_per_diameter as f64;
    let n = 6 * cells_per_diameter;
    let (eq, l1) = if dim == 3 {
        let vs = VelocitySet::new(VelocitySetKind::D3q39);
        let l1 = vs.max_l1_speed();
        (Equilibrium::new(vs, GasModel::Monatomic), l1)
    } else {
        d2q21_air()
    };
    let theta0 = 0.6;
    let units = lattice_units(&eq, theta0);
    let params = timestep::choose(0.05, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).expect("admissible time step");
    let mid = 0.5 * n as f64;
    let centre = DVec3::new(mid, mid, if dim == 3 { mid } else { 0.0 });
    // E = ρ c_s² · 4: a stiff-ish body whose wave speed is twice the sound speed.
    let material = Orthotropic::isotropic(4.0 * 1.2 * density, 0.3, density, 0.05 * density);
    let (particles, surface) = if dim == 3 { ball_body(centre, 0.5 * d, 0.5, density) } else { disc_body(centre, 0.5 * d, 0.5, density, |_| false) };
    let pulse = DVec3::new(centre.x - 1.5 * d, centre.y, centre.z);
    let grid = Grid::new(dim, [n, n, if dim == 3 { n } else { 1 }]);
    let fluid = FluidSolver::new(eq, grid, Boundaries::periodic(), &[], params, move |x| {
        let r2 = (x[0] - pulse.x).powi(2) + (x[1] - pulse.y).powi(2) + if dim == 3 { (x[2] - pulse.z).powi(2) } else { 0.0 };
        Macro { rho: 1.0 + amplitude * (-r2 / (0.25 * d * d)).exp(), u: [0.0; 3], theta: theta0 }
    });
    let solid = SolidSolver::new(particles, vec![material], SolidOptions::default()).expect("valid disc");
    let bodies = vec![CoupledBody::adiabatic(surface, None)];
    let mut c = CoupledSolver::new(fluid, solid, units, bodies, Vec::new(), method).expect("valid coupling");
    let (f0, s0) = c.momentum();
    let total0 = f0 + s0 + c.added_mass_momentum();
    let roundoff_scale = f64::EPSILON * population_momentum_scale(&c);
    let mut largest: f64 = 0.0;
    let mut largest_in_transit: f64 = 0.0;
    let mut worst_step_change: f64 = 0.0;
    let mut last = total0;
    for _ in 0..steps {
        c.step()?;
        let (f, s) = c.momentum();
        let transit = c.added_mass_momentum();
        largest = largest.max(s.length());
        largest_in_transit = largest_in_transit.max(transit.length());
        worst_step_change = worst_step_change.max((f + s + transit - last).length());
        last = f + s + transit;
    }
    let (f, s) = c.momentum();
    Ok(MomentumResult {
        steps,
        relative_drift: (f + s + c.added_mass_momentum() - total0).length() / largest,
        largest_in_transit,
        largest_solid_momentum: largest,
        final_fluid_momentum: [f.x, f.y],
        final_solid_momentum: [s.x, s.y],
        worst_step_change,
        roundoff_scale,
    })
}

/// A free ball (body 0) of particles at spacing `l0` and its surface particles.
fn ball_body(centre: DVec3, radius: f64, l0: f64, density: f64) -> (Particles, BodySurface) {
    let mut particles = Particles::new(3, l0);
    for x in sample_ball(3, centre, radius, l0) {
        particles.push(x, density, 0, 0, false);
    }
    let surface = BodySurface::build(&particles, 0, &ReferenceShape::Ball { centre, radius }).expect("ball surface");
    (particles, surface)
}

/// Σ_nodes Σ_i |c_i| f_i over the fluid of `c` (physical momentum units).
fn population_momentum_scale(c: &CoupledSolver) -> f64 {
    let f = &c.fluid;
    let q = f.eq.q();
    let speed: Vec<f64> = f.eq.cf[..q].iter().map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()).collect();
    let sum: f64 = (0..f.layout.grid.len())
        .filter(|&n| f.layout.kind[n] == crate::fluid::layout::NodeKind::Fluid)
        .map(|n| f.node_populations(n)[..q].iter().zip(&speed).map(|(f, c)| f.abs() * c).sum::<f64>())
        .sum();
    sum * c.momentum_unit()
}

/// The weak coupling's added-mass limit: the lightest free disc (density relative to the air's,
/// wave speed kept at twice the sound speed) that the pulse case carries through `steps` steps,
/// from `ratios` tried heaviest first. Returns each ratio with whether it stayed stable.
pub fn added_mass_stability(method: Method, ratios: &[f64], steps: u64) -> Vec<(f64, bool)> {
    ratios.iter().map(|&r| (r, pulse_on_a_free_disc_by(method, 8, 0.01, steps, r).is_ok())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coupling::ConservingOptions;

    /// Stability (issue 12): the explicit weak coupling carries a free disc lighter than the air
    /// (ρ_s/ρ_f = 0.3) through the pulse. Measured limit: 0.2 stable, 0.15 unstable — the
    /// added-mass instability of weak coupling; `validate --case fsi_added_mass` sweeps it.
    #[test]
    fn the_weak_coupling_carries_a_disc_lighter_than_the_air() {
        let r = pulse_on_a_free_disc(8, 0.01, 1000, 0.3).expect("stable at ρ_s/ρ_f = 0.3");
        assert!(r.largest_solid_momentum > 0.0 && r.relative_drift.is_finite(), "{r:?}");
    }

    /// Momentum budget of the weak coupling (issue 12): a free neutrally buoyant elastic disc
    /// pushed by a pressure pulse in a periodic box. Method 1 does not conserve the total
    /// momentum; measured drift after 1000 steps: 2.0 % of the largest momentum the disc
    /// reached (the bound below is that figure with margin, a regression guard).
    /// Momentum (issue 12): the free elastic disc hit by the pulse, 1000 steps of each method.
    /// Method 2 hands the body exactly what the air's face fluxes lost, so the total changes
    /// only by the rounding of the populations' updates: every step's change is below ε·Σ|c_i| f_i
    /// (the worst-case rounding of one pass over the populations; a leak of a single face's
    /// flux would be ~10⁶ times that), and over 1000 steps the total drifts by ≤ 1e-12 of the
    /// momentum the body reached. Method 1's tractions are not the air's momentum loss.
    /// Measured (this machine): method 2 drift 4.5e-14 of the body's largest momentum (0.20),
    /// worst step 6.2e-15 = 0.014 of the round-off scale 4.4e-13; method 1 drift 2.1e-2, worst
    /// step 8.8e-4.
    #[test]
    fn method_2_conserves_the_total_momentum_to_round_off() {
        let conserving = pulse_on_a_free_disc_by(Method::Conserving(ConservingOptions::default()), 8, 0.05, 1000, 1.0).expect("stable");
        let weak = pulse_on_a_free_disc_by(Method::Weak(WeakOptions::default()), 8, 0.05, 1000, 1.0).expect("stable");
        eprintln!("momentum drift over 1000 steps: method 2 {:.3e}, method 1 {:.3e}\n{conserving:?}\n{weak:?}", conserving.relative_drift, weak.relative_drift);
        assert!(conserving.largest_solid_momentum > 0.05, "the pulse moves the disc: {conserving:?}");
        assert!(conserving.worst_step_change < conserving.roundoff_scale, "{conserving:?}");
        assert!(conserving.relative_drift <= 1e-12, "{conserving:?}");
        assert!(conserving.relative_drift * 100.0 <= weak.relative_drift, "method 2 {conserving:?} vs method 1 {weak:?}");
    }

    /// The added mass (2.129, issue 12): method 2 carries a free disc a thousand times lighter
    /// than the air through the pulse, still conserving air + disc + the added mass's Σ m_a v to
    /// round-off; without the added mass (the purely staggered exchange) the same coupling
    /// diverges at a hundredth. Measured sweep (1000 steps, D = 8): without added mass stable
    /// down to ρ_s/ρ_f = 0.02, diverging at 0.01; with it stable at every ratio tried down to
    /// 10⁻⁶ (the weak coupling's limit is 0.2, `validate --case fsi_added_mass`).
    #[test]
    fn method_2_with_its_added_mass_carries_a_disc_a_thousand_times_lighter_than_the_air() {
        let with = Method::Conserving(ConservingOptions::default());
        let r = pulse_on_a_free_disc_by(with, 8, 0.01, 1000, 1e-3).expect("stable with the added mass");
        eprintln!("ρ_s/ρ_f = 1e-3 with added mass: {r:?}");
        assert!(r.largest_solid_momentum > 0.0 && r.largest_in_transit > r.largest_solid_momentum, "the air's added mass dominates: {r:?}");
        // The disc's own momentum is tiny here, so the budget is checked against the rounding
        // of the populations: every step's change below one pass's worst case, and the 1000
        // steps' total below a tenth of 1000 of them (measured 4.3e-15 and 3.2e-14 against the
        // scale 4.4e-13; a leaked face flux is ~10⁶ times the scale).
        assert!(r.worst_step_change < r.roundoff_scale, "{r:?}");
        assert!(r.relative_drift * r.largest_solid_momentum <= 0.1 * 1000.0 * r.roundoff_scale, "{r:?}");
        let without = Method::Conserving(ConservingOptions { added_mass: false, ..Default::default() });
        let e = pulse_on_a_free_disc_by(without, 8, 0.01, 1000, 1e-2).expect_err("the staggered exchange diverges at ρ_s/ρ_f = 0.01");
        eprintln!("without: {e}");
    }

    /// Method 2 in 3D (issue 12): a free elastic ball (D = 6 cells, D3Q39) hit by a pressure
    /// pulse in a periodic cube keeps air + ball + Σ m_a v to round-off over 300 steps: every
    /// step's change and the whole run's drift below one pass's worst-case rounding
    /// ε·Σ|c_i| f_i (28 times the 2D disc's: 39 velocities, 46 656 nodes). Measured: drift
    /// 2.2e-13 (1.0e-12 of the ball's largest momentum 0.215), worst step 3.7e-13, scale 1.25e-11.
    #[test]
    fn method_2_conserves_the_total_momentum_in_3d() {
        let r = pulse_on_a_free_body(3, Method::Conserving(ConservingOptions::default()), 6, 0.05, 300, 1.0).expect("stable");
        eprintln!("3D: {r:?}");
        assert!(r.largest_solid_momentum > 0.05, "the pulse moves the ball: {r:?}");
        assert!(r.worst_step_change < r.roundoff_scale, "{r:?}");
        assert!(r.relative_drift * r.largest_solid_momentum < r.roundoff_scale, "{r:?}");
    }

    #[test]
    fn the_weak_coupling_keeps_the_total_momentum_within_a_few_percent() {
        let r = pressure_pulse_momentum(8, 0.01, 1000);
        assert!(r.largest_solid_momentum > 0.01, "the pulse moves the disc: {r:?}");
        assert!(r.relative_drift < 0.05, "{r:?}");
    }
}
