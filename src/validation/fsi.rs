//! Coupled-solver validations (issue 12): the towed, oscillating and sheared cylinders;
//! Schäfer–Turek 2D-1 is in [`super::fsi_schafer_turek`], the momentum cases in
//! [`super::fsi_momentum`].

use crate::coupling::{BodySurface, CoupledBody, CoupledSolver, Method, ReferenceShape, WeakOptions};
use crate::fluid::{Boundaries, Equilibrium, FaceCondition, FluidSolver, GasModel, Grid, Macro, VelocitySet, VelocitySetKind, timestep};
use crate::solid::particles::sample_ball;
use crate::solid::{Orthotropic, Particles, SolidOptions, SolidSolver};
use crate::units::Units;
use glam::DVec3;
use std::time::Instant;

pub use super::fsi_momentum::{MomentumResult, added_mass_stability, pressure_pulse_momentum, pulse_on_a_free_disc, pulse_on_a_free_disc_by};
pub use super::fsi_schafer_turek::{
    ChannelCylinderResult, ChannelStart, CylinderBody, OUTLET_DENSITY_AIR_AT_RHO0, ST_2D1_DRAG, ST_2D1_LIFT, ST_2D1_PRESSURE_DROP, schafer_turek_2d1,
    schafer_turek_2d1_with_outlet,
};

/// D2Q21, monatomic, θ₀ = 0.6: the air of every case here; returns the equilibrium and the
/// largest L1 speed (for the time step).
pub(super) fn d2q21_air() -> (Equilibrium, i32) {
    let vs = VelocitySet::new(VelocitySetKind::D2q21);
    let l1 = vs.max_l1_speed();
    (Equilibrium::new(vs, GasModel::Monatomic), l1)
}

/// Units whose physical values are the lattice's (Δx = 1 m, ρ₀ = 1 kg/m³, c_s = √(γθ₀) m/s).
pub(super) fn lattice_units(eq: &Equilibrium, theta0: f64) -> Units {
    Units::new(1.0, 1.0, eq.sound_speed(theta0), theta0, eq.gamma())
}

/// A disc body (body 0) of particles at spacing `l0`, `clamped(x)` choosing its clamped
/// particles, and its surface polygon.
pub(super) fn disc_body(centre: DVec3, radius: f64, l0: f64, density: f64, clamped: impl Fn(DVec3) -> bool) -> (Particles, BodySurface) {
    let mut particles = Particles::new(2, l0);
    for x in sample_ball(2, centre, radius, l0) {
        particles.push(x, density, 0, 0, clamped(x));
    }
    let surface = BodySurface::build(&particles, 0, &ReferenceShape::Disc { centre, radius }).expect("disc surface");
    (particles, surface)
}

/// Result of the Galilean check: the drag of a cylinder towed through air at rest against the
/// drag of the same cylinder held fixed in air that moves, at the same time after an impulsive
/// start (both in one periodic box, so the two problems are the same in the continuum).
#[derive(Clone, Debug, serde::Serialize)]
pub struct GalileanResult {
    pub diameter_cells: f64,
    pub mach: f64,
    pub reynolds: f64,
    pub steps: u64,
    /// Drag (force per unit depth along +x, lattice units) of the towed and of
    /// the fixed cylinder, averaged over the last quarter of the run.
    pub towed_drag: f64,
    pub fixed_drag: f64,
    pub relative_difference: f64,
    /// Nodes uncovered and covered by the towed cylinder.
    pub uncovered: usize,
    pub covered: usize,
    /// Relative change of the towed run's fluid mass (fresh and covered nodes).
    pub towed_mass_drift: f64,
    /// Method 2: the part of the towed drag (same window and units) that came from nodes the
    /// cylinder covered minus fresh nodes it uncovered; the rest came through wall faces.
    pub towed_drag_from_node_changes: Option<f64>,
}

/// A rigid (fully clamped, or towed) disc of `cells_per_diameter` in a periodic box of 12 × 8
/// diameters, Reynolds number `reynolds` on the relative speed (Mach `mach`), for `distance`
/// diameters of relative travel.
pub fn towed_cylinder(method: Method, cells_per_diameter: usize, mach: f64, reynolds: f64, distance: f64) -> GalileanResult {
    towed_cylinder_at(method, cells_per_diameter, mach, reynolds, distance, [0.0, 0.0])
}

/// [`towed_cylinder`] with the disc's centre moved by `offset` (cells) from the box's centre
/// node, so that the particles sit elsewhere between the lattice nodes.
pub fn towed_cylinder_at(method: Method, cells_per_diameter: usize, mach: f64, reynolds: f64, distance: f64, offset: [f64; 2]) -> GalileanResult {
    let d = cells_per_diameter as f64;
    let (nx, ny) = (12 * cells_per_diameter, 8 * cells_per_diameter);
    let (eq, l1) = d2q21_air();
    let theta0 = 0.6;
    let u = mach * eq.sound_speed(theta0);
    let units = lattice_units(&eq, theta0);
    let params = timestep::choose(u * d / reynolds, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).expect("admissible time step");
    let steps = (distance * d / u / params.dt).ceil() as u64;
    let centre = DVec3::new(0.5 * nx as f64 + offset[0], 0.5 * ny as f64 + offset[1], 0.0);
    let radius = 0.5 * d;
    let l0 = 0.5;
    let material = Orthotropic::isotropic(1.0, 0.3, 1.0, 0.0);
    let (particles, surface) = disc_body(centre, radius, l0, material.density, |_| true);
    let run = |towed: bool| {
        let uf = if towed { 0.0 } else { u };
        let fluid = FluidSolver::new(eq.clone(), Grid::new(2, [nx, ny, 1]), Boundaries::periodic(), &[], params, move |_| Macro {
            rho: 1.0,
            u: [uf, 0.0, 0.0],
            theta: theta0,
        });
        let solid = SolidSolver::new(particles.clone(), vec![material.clone()], SolidOptions::default()).expect("valid disc");
        let motion = towed.then_some(crate::coupling::Motion::Translation { velocity: [-units.velocity_to_physical(u), 0.0, 0.0] });
        let bodies = vec![CoupledBody::adiabatic(surface.clone(), motion)];
        let mut c = CoupledSolver::new(fluid, solid, units, bodies, Vec::new(), method).expect("valid coupling");
        let m0 = c.fluid.totals().mass;
        let mut sum = 0.0;
        let mut count = 0;
        let node_changes = |c: &CoupledSolver| c.exchange().map(|e| e.node_changes.x);
        let mut changes_at_window = None;
        for k in 1..=steps {
            // the node changes booked before the averaging window opens
            if 4 * k > 3 * steps && 4 * (k - 1) <= 3 * steps {
                changes_at_window = node_changes(&c);
            }
            c.step().expect("the towed cylinder stays stable");
            if 4 * k > 3 * steps {
                sum += c.forces.total[0].x;
                count += 1;
            }
        }
        let force_unit = units.pressure_unit() * units.dx;
        let from_changes = node_changes(&c).zip(changes_at_window).map(|(b, a)| (b - a) / (count as f64 * c.dt()) / force_unit);
        (sum / count as f64 / force_unit, c.geometry, (c.fluid.totals().mass - m0) / m0, from_changes)
    };
    let (fixed, _, _, _) = run(false);
    // The towed cylinder moves along −x through air at rest: the air pushes it along +x, as
    // the moving air pushes the fixed one.
    let (towed, geometry, drift, from_changes) = run(true);
    GalileanResult {
        diameter_cells: d,
        mach,
        reynolds,
        steps,
        towed_drag: towed,
        fixed_drag: fixed,
        relative_difference: (towed - fixed) / fixed,
        uncovered: geometry.uncovered,
        covered: geometry.covered,
        towed_mass_drift: drift,
        towed_drag_from_node_changes: from_changes,
    }
}

/// A cylinder oscillating across a periodic box of air at rest, uncovering and covering nodes
/// every few steps, for a stability check over many steps.
#[derive(Clone, Debug, serde::Serialize)]
pub struct OscillatingResult {
    pub steps: u64,
    pub uncovered: usize,
    pub covered: usize,
    /// Relative change of the fluid's mass over the run (fresh nodes take their neighbours'
    /// mean state; covered nodes take their mass out of the fluid).
    pub mass_drift: f64,
    /// Largest Mach number at the end.
    pub max_mach: f64,
    pub wall_s: f64,
}

/// A rigid disc of `cells_per_diameter`, oscillating harmonically along x with amplitude one
/// diameter and peak speed Mach `mach`, in a periodic box of 6 × 4 diameters, for `steps` steps.
pub fn oscillating_cylinder(method: Method, cells_per_diameter: usize, mach: f64, steps: u64) -> Result<OscillatingResult, crate::step::Instability> {
    let d = cells_per_diameter as f64;
    let (nx, ny) = (6 * cells_per_diameter, 4 * cells_per_diameter);
    let (eq, l1) = d2q21_air();
    let theta0 = 0.6;
    let u = mach * eq.sound_speed(theta0);
    let units = lattice_units(&eq, theta0);
    let params = timestep::choose(u * d / 20.0, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).expect("admissible time step");
    let centre = DVec3::new(0.5 * nx as f64, 0.5 * ny as f64, 0.0);
    let material = Orthotropic::isotropic(1.0, 0.3, 1.0, 0.0);
    let (particles, surface) = disc_body(centre, 0.5 * d, 0.5, 1.0, |_| true);
    let fluid = FluidSolver::new(eq, Grid::new(2, [nx, ny, 1]), Boundaries::periodic(), &[], params, move |_| Macro { rho: 1.0, u: [0.0; 3], theta: theta0 });
    let solid = SolidSolver::new(particles, vec![material], SolidOptions::default()).expect("valid disc");
    // Amplitude d, peak speed u: frequency u / (2π d).
    let motion = crate::coupling::Motion::Harmonic { amplitude: [d, 0.0, 0.0], frequency: u / (std::f64::consts::TAU * d) };
    let bodies = vec![CoupledBody::adiabatic(surface, Some(motion))];
    let mut c = CoupledSolver::new(fluid, solid, units, bodies, Vec::new(), method).expect("valid coupling");
    let m0 = c.fluid.totals().mass;
    let t0 = Instant::now();
    c.run(steps)?;
    Ok(OscillatingResult {
        steps,
        uncovered: c.geometry.uncovered,
        covered: c.geometry.covered,
        mass_drift: (c.fluid.totals().mass - m0) / m0,
        max_mach: c.fluid.max_mach(),
        wall_s: t0.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coupling::ConservingOptions;

    /// Galilean check (issue 12): a cylinder towed at U through air at rest feels the drag of
    /// the same cylinder held in air moving at U (Re = 20, D = 10 cells, Mach 0.1, two
    /// diameters of travel after an impulsive start; mean over the last half diameter).
    /// Measured: 0.17071 vs 0.17102 (−0.18 %), 200 nodes uncovered and 200 covered, fluid mass
    /// +2.6·10⁻⁴.
    #[test]
    fn a_towed_cylinder_feels_the_drag_of_a_fixed_one_in_the_moving_frame() {
        let r = towed_cylinder(Method::Weak(WeakOptions::default()), 10, 0.1, 20.0, 2.0);
        assert!(r.relative_difference.abs() < 0.03, "{r:?}");
        assert!(r.fixed_drag > 0.1 && r.fixed_drag < 0.3, "{r:?}");
        // The disc sweeps 20 cells: about 20 diameters' worth of nodes on each side.
        assert!(r.uncovered == r.covered && (180..=220).contains(&r.uncovered), "{r:?}");
        assert!(r.towed_mass_drift.abs() < 2e-3, "{r:?}");
    }

    /// The Galilean check with method 2: the level-set walls move with the particles, covered
    /// and uncovered nodes book their momentum to the body, and the drag is the momentum the
    /// particles receive. With the kernel clamped at r_e/2 (see `CoupledSolver::r_min`):
    /// measured (D = 10) fixed 0.18425, towed 0.18383 (−0.23 %); with the disc moved by
    /// (0.5, 0.35) cells between the nodes, 0.18287 and 0.18234 (−0.29 %). Clamped at l₀/4 the
    /// fixed drag was 0.1750, 0.1852 and 0.1573 at offsets 0, 0.25 and 0.5 and the towed one
    /// +7.6 % off. Method 2's drag stands 7–8 % above method 1's quadrature (0.1710): the
    /// level set's bumps at the particle scale (open; the Schäfer–Turek case measures it).
    #[test]
    fn method_2_tows_a_cylinder_with_the_drag_of_the_fixed_one() {
        let mut fixed = Vec::new();
        for offset in [[0.0, 0.0], [0.5, 0.35]] {
            let r = towed_cylinder_at(Method::Conserving(ConservingOptions::default()), 10, 0.1, 20.0, 2.0, offset);
            eprintln!("method 2 towed cylinder at {offset:?}: {r:?}");
            assert!(r.relative_difference.abs() < 0.03, "{r:?}");
            assert!(r.fixed_drag > 0.1 && r.fixed_drag < 0.3, "{r:?}");
            assert!(r.uncovered > 100 && r.covered > 100, "{r:?}");
            assert!(r.towed_mass_drift.abs() < 2e-3, "{r:?}");
            // the covered and uncovered nodes carry a small part of the drag (measured −5.2 % at
            // offset 0); the rest comes through the wall faces
            let nodes = r.towed_drag_from_node_changes.expect("method 2 books node changes");
            assert!(nodes.abs() < 0.1 * r.towed_drag, "{r:?}");
            fixed.push(r.fixed_drag);
        }
        // the drag does not depend on where the particles sit between the nodes
        assert!((fixed[1] / fixed[0] - 1.0).abs() < 0.02, "{fixed:?}");
    }

    /// Stability with moving walls (issue 12): a disc oscillating by one diameter (D = 8,
    /// peak Mach 0.1) uncovers and covers nodes throughout 10⁴ steps and stays finite.
    /// Measured: 966 uncovered, 962 covered, fluid mass +1.45 % (the ghost-node walls and the
    /// fresh-node fill do not conserve mass; method 2 is the conservative coupling).
    #[test]
    fn an_oscillating_cylinder_stays_stable_for_ten_thousand_steps() {
        let r = oscillating_cylinder(Method::Weak(WeakOptions::default()), 8, 0.1, 10_000).expect("stays stable");
        assert!(r.uncovered > 900 && r.covered > 900, "{r:?}");
        assert!(r.max_mach.is_finite() && r.max_mach < 0.2, "{r:?}");
        assert!(r.mass_drift.abs() < 0.03, "{r:?}");
    }

    /// Stability with moving level-set walls (method 2): the oscillating disc for 2000 steps
    /// (a quarter period; `validate --case fsi_oscillating_cylinder` runs 10⁴ steps of both
    /// methods). Measured: 192 nodes uncovered and 192 covered, fluid mass −9.5·10⁻⁴, peak
    /// Mach 0.05 at the end.
    #[test]
    fn method_2_carries_an_oscillating_cylinder() {
        let r = oscillating_cylinder(Method::Conserving(ConservingOptions::default()), 8, 0.1, 2000).expect("stays stable");
        eprintln!("method 2 oscillating cylinder: {r:?}");
        assert!(r.uncovered > 50 && r.covered > 50, "{r:?}");
        assert!(r.max_mach.is_finite() && r.max_mach < 0.2, "{r:?}");
        assert!(r.mass_drift.abs() < 0.03, "{r:?}");
    }

    /// Free body (issue 12): a neutrally buoyant free disc at the centre of a Couette channel
    /// (D = 10 cells, H = 8 D, γ̇D²/ν = 0.1) turns at γ̇/2 (clockwise). Measured: Ω/γ̇ = −0.4995
    /// after 1.5 viscous times D²/ν (−0.5000 after 2; −0.479 at H = 4 D, where the walls slow
    /// it). The traction's ∂v_w/∂s term matters here: without it the disc turned at −0.73 γ̇.
    #[test]
    fn a_free_disc_in_simple_shear_turns_at_half_the_shear_rate() {
        let r = disc_in_shear(10, 8, 0.1, 1.5);
        assert!((r.rotation_rate + 0.5).abs() < 0.01, "{r:?}");
        assert!(r.centroid_drift < 0.5, "the centred disc stays put: {r:?}");
    }
}

/// A neutrally buoyant free disc in simple shear.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ShearRotationResult {
    pub reynolds: f64,
    /// Confinement D/H.
    pub confinement: f64,
    pub steps: u64,
    /// Rigid-body angular velocity of the disc (about its centroid) over γ̇, averaged over the
    /// last fifth of the run (counter-clockwise positive; simple shear u = γ̇ y turns a body
    /// clockwise, so the expected value is −1/2).
    pub rotation_rate: f64,
    /// Drift of the disc's centroid (cells).
    pub centroid_drift: f64,
}

/// A free disc (D = `cells_per_diameter`, neutrally buoyant, stiff) at the centre of a Couette
/// channel of height `height_d` diameters (walls at ±U, periodic along x, 8 D long), particle
/// Reynolds number γ̇D²/ν = `reynolds`, for `viscous_times` times D²/ν.
pub fn disc_in_shear(cells_per_diameter: usize, height_d: usize, reynolds: f64, viscous_times: f64) -> ShearRotationResult {
    let d = cells_per_diameter as f64;
    let (nx, ny) = (8 * cells_per_diameter, height_d * cells_per_diameter);
    let (eq, l1) = d2q21_air();
    let theta0 = 0.6;
    let units = lattice_units(&eq, theta0);
    // Wall speed U = 0.01 (Mach ≈ 0.01): γ̇ = 2U/H.
    let u_wall = 0.01;
    let shear = 2.0 * u_wall / ny as f64;
    let nu = shear * d * d / reynolds;
    let params = timestep::choose(nu, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).expect("admissible time step");
    let steps = (viscous_times * d * d / nu / params.dt).ceil() as u64;
    let mut b = Boundaries::periodic();
    b.faces[2] = FaceCondition::Wall { velocity: [-u_wall, 0.0, 0.0], temperature: None };
    b.faces[3] = FaceCondition::Wall { velocity: [u_wall, 0.0, 0.0], temperature: None };
    let centre = DVec3::new(0.5 * nx as f64 - 0.5, 0.5 * ny as f64 - 0.5, 0.0);
    // Stiff against the shear stress μγ̇ (strain ≈ μγ̇/E ≈ 10⁻⁴), damped.
    let material = Orthotropic::isotropic(1.0e4 * nu * shear, 0.3, 1.0, 0.5 * nu);
    let (particles, surface) = disc_body(centre, 0.5 * d, 0.5, 1.0, |_| false);
    let y_mid = 0.5 * ny as f64 - 0.5;
    let fluid =
        FluidSolver::new(eq, Grid::new(2, [nx, ny, 1]), b, &[], params, move |x| Macro { rho: 1.0, u: [shear * (x[1] - y_mid), 0.0, 0.0], theta: theta0 });
    let solid = SolidSolver::new(particles, vec![material], SolidOptions::default()).expect("valid disc");
    let bodies = vec![CoupledBody::adiabatic(surface, None)];
    let mut c = CoupledSolver::new(fluid, solid, units, bodies, Vec::new(), Method::Weak(WeakOptions::default())).expect("valid coupling");
    let spin = |c: &CoupledSolver| {
        let p = &c.solid.particles;
        let m: f64 = p.mass.iter().sum();
        let xc = (0..p.len()).map(|i| p.mass[i] * p.position[i]).sum::<DVec3>() / m;
        let vc = (0..p.len()).map(|i| p.mass[i] * p.velocity[i]).sum::<DVec3>() / m;
        let (mut l, mut j) = (0.0, 0.0);
        for i in 0..p.len() {
            let r = p.position[i] - xc;
            l += p.mass[i] * r.cross(p.velocity[i] - vc).z;
            j += p.mass[i] * r.length_squared();
        }
        (l / j, xc)
    };
    let (mut sum, mut count) = (0.0, 0);
    for k in 1..=steps {
        c.step().expect("the disc in shear stays stable");
        if 5 * k > 4 * steps {
            sum += spin(&c).0;
            count += 1;
        }
    }
    let (_, xc) = spin(&c);
    ShearRotationResult {
        reynolds,
        confinement: 1.0 / height_d as f64,
        steps,
        rotation_rate: sum / count as f64 / shear,
        centroid_drift: (xc - centre).length(),
    }
}
