//! **Schäfer–Turek 2D-1**, the fixed-body check of the coupling (issue 12): Schäfer & Turek 1996, "Benchmark computations of laminar flow
//! around a cylinder" (../shared/reference): channel 2.2 × 0.41 m, cylinder D = 0.1 m centred at
//! (0.2, 0.2), ν = 10⁻³ m²/s, ρ = 1 kg/m³, parabolic inflow with U_max = 0.3 m/s (U_mean = 0.2,
//! Re = 20). Steady: C_D = 5.5795, C_L = 0.0106, Δp = p(0.15, 0.2) − p(0.25, 0.2) = 0.11752 Pa.
//! The cylinder is either the fluid's rigid ghost-node obstacle, with the force found by the
//! same surface quadrature the coupling uses (a cross-check of the fluid and of the
//! quadrature), or an elastic disc clamped in its inner half and coupled through
//! [`CoupledSolver`] (the coupled path: surface polygon, moving-wall geometry, tractions).

use super::fsi::{d2q21_air, disc_body};
use crate::coupling::{ConservingOptions, CoupledBody, CoupledSolver, Method, TractionModel, WeakOptions, surface_forces};
use crate::fluid::{Boundaries, Face, FaceCondition, FluidSolver, Grid, InletProfile, Macro, Obstacle, SelectiveFrequencyDamping, Shape, timestep};
use crate::solid::{Orthotropic, SolidOptions, SolidSolver};
use crate::units::Units;
use glam::DVec3;
use std::time::Instant;

/// Schäfer–Turek 2D-1 reference values.
pub const ST_2D1_DRAG: f64 = 5.5795;
pub const ST_2D1_LIFT: f64 = 0.0106;
pub const ST_2D1_PRESSURE_DROP: f64 = 0.11752;

/// How the cylinder is represented.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CylinderBody {
    /// The fluid's fixed ghost-node cylinder (no solid).
    RigidObstacle,
    /// An elastic MPS disc, clamped for r < D/4, coupled by method 1.
    WeakCoupled(TractionModel),
    /// Every particle of the disc clamped, coupled by method 1: the coupled path (polygon
    /// walls, per-step geometry, tractions) without any motion.
    WeakCoupledRigid,
    /// The elastic disc clamped for r < D/4, coupled by method 2 (level-set walls, momentum
    /// exchanged link by link); the force is the momentum the particles received per second.
    ConservingCoupled,
}

/// How the channel flow starts.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ChannelStart {
    /// The inflow's Poiseuille profile everywhere at t = 0, the cylinder present at once: the
    /// flow's sudden blockage sends a pressure wave of order ρ c U through the channel, which
    /// rings between the velocity inlet and the constant-pressure outlet (a quarter-wave
    /// resonator, period 4L/c ≈ 2.9 s at Mach 0.1) with almost no loss.
    Impulsive,
    /// Air at rest at t = 0 and the inlet's peak velocity raised as U_max sin²(π t / 2T) over
    /// `seconds` = T (the start of Schäfer–Turek 2D-3). Only a ramp much longer than the
    /// resonator's period excites the ringing less than the impulsive start: a 3 s ramp (about
    /// one period at Mach 0.1) drove it resonantly — C_D swung between 4.7 and 6.7 after it
    /// (D = 10), against ±0.2 after the impulsive start.
    Ramp { seconds: f64 },
    /// The impulsive start, with selective frequency damping of the air after every step
    /// ([`SelectiveFrequencyDamping`]: gain `gain` per second, filter width `filter_width`
    /// seconds): the ringing dies out and the flow settles on the steady state of the
    /// undamped equations.
    Damped { gain: f64, filter_width: f64 },
}

impl ChannelStart {
    /// The inlet's share of U_max at time `t` (s).
    pub fn inflow_factor(self, t: f64) -> f64 {
        match self {
            ChannelStart::Impulsive | ChannelStart::Damped { .. } => 1.0,
            ChannelStart::Ramp { seconds } if t < seconds => (std::f64::consts::FRAC_PI_2 * t / seconds).sin().powi(2),
            ChannelStart::Ramp { .. } => 1.0,
        }
    }
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct ChannelCylinderResult {
    pub body: CylinderBody,
    pub start: ChannelStart,
    pub diameter_cells: f64,
    pub mach: f64,
    pub steps: u64,
    pub simulated_s: f64,
    pub wall_s: f64,
    pub drag_coefficient: f64,
    /// The rigid obstacle only: C_D from the momentum its wall nodes take out of the air
    /// through their faces ([`crate::coupling::momentum_exchange`]: the measure method 2 hands
    /// to its particles), next to `drag_coefficient` from the traction quadrature.
    pub exchange_drag_coefficient: Option<f64>,
    pub lift_coefficient: f64,
    /// Δp = p(0.15, 0.2) − p(0.25, 0.2) (Pa) with the field sampled at the two wall points
    /// ([`FluidSolver::sample`]: fluid nodes only).
    pub pressure_drop: f64,
    /// Δp with each wall pressure extrapolated from the air along the wall's normal
    /// (quadratic through the samples 1, 2 and 3 cells out).
    pub pressure_drop_extrapolated: f64,
    /// C_D, C_L and Δp are means over the last quarter of the run (the window). These are the
    /// standard deviations of C_D and of Δp (Pa) over the window, sampled every step: what is
    /// left of the acoustic ringing, of the flow's slow settling, and of any shedding.
    pub drag_spread: f64,
    pub pressure_drop_spread: f64,
    /// The outlet's density (units of ρ₀) and the mean density of the air within one diameter
    /// of the cylinder's surface (nodes 1.2–2 radii from its centre), over the window.
    pub outlet_density: f64,
    pub density_near_cylinder: f64,
    /// [`ChannelStart::Damped`]: max |f − f̄| / max |f| at the end (zero at a steady state).
    pub damping_residual: Option<f64>,
    /// Particles of the disc (0 for the rigid obstacle) and solid sub-steps per fluid step.
    pub particles: usize,
    pub substeps: u32,
    /// Largest displacement of a particle at the end (m).
    pub max_displacement: f64,
    /// Per-stage shares of the coupled step (empty for the rigid obstacle).
    pub stage_shares: Vec<(String, f64)>,
    /// C_D at 50 evenly spaced times.
    pub drag_history: Vec<f64>,
}

/// Sums over the averaging window: force (N/m), Δp both ways (Pa), and C_D² and Δp² for the
/// spreads.
#[derive(Default)]
struct Window {
    force: DVec3,
    drop: f64,
    extrapolated_drop: f64,
    drag_squares: f64,
    drop_squares: f64,
    samples: f64,
    /// Σ of the mean density around the cylinder ([`ChannelCylinderResult::density_near_cylinder`]).
    density: f64,
}

impl Window {
    /// Adds one step's force and (sampled, extrapolated) Δp; `coefficient` turns a force into C_D.
    fn add(&mut self, force: DVec3, (drop, extrapolated): (f64, f64), coefficient: f64) {
        self.force += force;
        self.drop += drop;
        self.extrapolated_drop += extrapolated;
        self.drag_squares += (force.x * coefficient).powi(2);
        self.drop_squares += drop * drop;
        self.samples += 1.0;
    }
}

/// Schäfer–Turek 2D-1 with `cells_per_diameter` (a multiple of 10, so that the channel height
/// 4.1 D is a whole number of cells), lattice Mach number `mach` at U_max, started as `start`,
/// run for `duration` s.
pub fn schafer_turek_2d1(cells_per_diameter: usize, mach: f64, start: ChannelStart, duration: f64, body: CylinderBody) -> ChannelCylinderResult {
    schafer_turek_2d1_with_outlet(cells_per_diameter, mach, start, duration, body, 1.0)
}

/// The outlet density (units of ρ₀) at which the air within one diameter of the cylinder is at
/// ρ₀ at Mach 0.1: with the outlet at ρ₀ it measured 1.0079 ρ₀ there (D = 20,
/// `validate --case fsi_schafer_turek_2d1_outlet_level`), and 1.0001–1.0005 ρ₀ with this level
/// at D = 30. The incompressible benchmark's ρ = 1 where the forces act.
pub const OUTLET_DENSITY_AIR_AT_RHO0: f64 = 1.0 / 1.0079;

/// [`schafer_turek_2d1`] with the constant-pressure outlet at density `outlet_density` (units of
/// ρ₀; 1 in [`schafer_turek_2d1`]). The incompressible benchmark fixes no pressure level; in the
/// weakly compressible channel the level sets the density of the air around the cylinder,
/// which the pressure drop to the outlet puts O(Ma²) above the outlet's (reported as
/// [`ChannelCylinderResult::density_near_cylinder`]), and the viscous forces scale with it.
pub fn schafer_turek_2d1_with_outlet(
    cells_per_diameter: usize,
    mach: f64,
    start: ChannelStart,
    duration: f64,
    body: CylinderBody,
    outlet_density: f64,
) -> ChannelCylinderResult {
    let ch = Channel::new(cells_per_diameter, mach, start, duration, outlet_density);
    let t0 = Instant::now();
    let run = match body {
        CylinderBody::RigidObstacle => ch.run_rigid(),
        CylinderBody::WeakCoupled(_) | CylinderBody::WeakCoupledRigid | CylinderBody::ConservingCoupled => ch.run_coupled(body),
    };
    let (window, n) = (&run.window, run.window.samples);
    let force = window.force / n;
    let (drag, drop) = (force.x * ch.coefficient, window.drop / n);
    let spread = |squares: f64, mean: f64| (squares / n - mean * mean).max(0.0).sqrt();
    ChannelCylinderResult {
        body,
        start,
        diameter_cells: cells_per_diameter as f64,
        mach,
        steps: ch.steps,
        simulated_s: ch.steps as f64 * ch.params.dt * ch.units.time(),
        wall_s: t0.elapsed().as_secs_f64(),
        drag_coefficient: drag,
        exchange_drag_coefficient: run.exchange_drag,
        lift_coefficient: force.y * ch.coefficient,
        pressure_drop: drop,
        pressure_drop_extrapolated: window.extrapolated_drop / n,
        drag_spread: spread(window.drag_squares, drag),
        pressure_drop_spread: spread(window.drop_squares, drop),
        outlet_density,
        density_near_cylinder: window.density / n,
        damping_residual: run.residual,
        particles: run.particles,
        substeps: run.substeps,
        max_displacement: run.max_displacement,
        stage_shares: run.stage_shares,
        drag_history: run.history,
    }
}

/// The channel at one resolution (lattice units): the air, its faces, its time step, the
/// cylinder's particles and surface, the run's length and what it samples.
struct Channel {
    start: ChannelStart,
    units: Units,
    params: timestep::StepParams,
    /// U_max (ℓ/step) and the reference temperature θ₀.
    u_lat: f64,
    theta0: f64,
    eq: crate::fluid::Equilibrium,
    grid: Grid,
    boundaries: Boundaries,
    /// The disc's particle spacing (half a cell, so that every surface edge is shorter than a
    /// cell) and material.
    l0: f64,
    material: Orthotropic,
    centre: DVec3,
    radius: f64,
    /// 2 / (ρ U_mean² D): a force per unit span (N/m) → C_D.
    coefficient: f64,
    steps: u64,
    sample_every: u64,
    /// The first step of the averaging window (the last quarter of the run).
    average_from: u64,
    /// The two wall points of Δp (lattice coordinates).
    drop_probes: [[f64; 3]; 2],
}

/// What a run leaves: the window's sums, C_D's history, and the body's figures.
struct ChannelRun {
    window: Window,
    history: Vec<f64>,
    exchange_drag: Option<f64>,
    residual: Option<f64>,
    stage_shares: Vec<(String, f64)>,
    substeps: u32,
    max_displacement: f64,
    particles: usize,
}

impl Channel {
    fn new(cells_per_diameter: usize, mach: f64, start: ChannelStart, duration: f64, outlet_density: f64) -> Self {
        assert!(cells_per_diameter.is_multiple_of(10), "the channel height 4.1 D must be a whole number of cells");
        let (d_phys, h_phys, l_phys, nu_phys, u_max) = (0.1, 0.41, 2.2, 1.0e-3, 0.3);
        let u_mean = 2.0 / 3.0 * u_max;
        let dx = d_phys / cells_per_diameter as f64;
        let (nx, ny) = ((l_phys / dx).round() as usize, (h_phys / dx).round() as usize);
        let (eq, l1) = d2q21_air();
        let theta0 = 0.6;
        let cs_lat = eq.sound_speed(theta0);
        let units = Units::new(dx, 1.0, u_max / mach, theta0, eq.gamma());
        let nu = units.kinematic_viscosity_to_lattice(nu_phys);
        let params = timestep::choose(nu, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).expect("admissible time step");
        let u_lat = units.velocity_to_lattice(u_max);
        debug_assert!((u_lat / cs_lat - mach).abs() < 1e-12);
        let mut boundaries = Boundaries::periodic();
        boundaries.faces[0] = FaceCondition::VelocityInlet { velocity: [u_lat, 0.0, 0.0], theta: theta0, profile: InletProfile::Parabolic };
        // Constant pressure at the outlet (the reference pressure; velocity and non-equilibrium part
        // from the last interior node): a zero-gradient outlet lets the density of a compressible
        // channel drift upward under a velocity inlet (C_D grew by 4 % over 6 s at D = 10 cells).
        boundaries.faces[1] = FaceCondition::PressureInlet { rho: outlet_density, theta: theta0 };
        boundaries.faces[2] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
        boundaries.faces[3] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
        boundaries.set_inlet_velocity(Face::XMin, [u_lat * start.inflow_factor(0.0), 0.0, 0.0]).expect("x_min is the velocity inlet");
        let centre = DVec3::new(0.2, 0.2, 0.0);
        let radius = 0.5 * d_phys;
        // The disc's particles: spacing half a cell, so that every surface edge is shorter than a
        // cell. E = 200 Pa keeps the deformation under 10⁻³ D (drag ≈ 0.011 N/m) at a solid step
        // close to the fluid's; viscosity 0.01 Pa·s damps its ringing.
        let material = Orthotropic::isotropic(200.0, 0.3, 1.0, 0.01);
        let steps = (duration / (params.dt * units.time())).ceil() as u64;
        Self {
            start,
            units,
            params,
            u_lat,
            theta0,
            eq,
            grid: Grid::new(2, [nx, ny, 1]),
            boundaries,
            l0: dx / 2.0,
            material,
            centre,
            radius,
            coefficient: 2.0 / (1.0 * u_mean * u_mean * d_phys),
            steps,
            sample_every: (steps / 50).max(1),
            // Acoustic waves ring between the inlet and the outlet of the compressible channel
            // (unless `ChannelStart::Damped` settles them): the figures are averages over the
            // last quarter of the run, sampled every step.
            average_from: steps - steps / 4,
            drop_probes: [lattice_point(&units, DVec3::new(0.15, 0.2, 0.0)), lattice_point(&units, DVec3::new(0.25, 0.2, 0.0))],
        }
    }

    /// The disc's particles and surface: clamped within half its radius, or whole (`rigid`).
    fn disc(&self, rigid: bool) -> (crate::solid::Particles, crate::coupling::BodySurface) {
        let centre = self.centre;
        disc_body(centre, self.radius, self.l0, self.material.density, |x| rigid || (x - centre).length() < 0.5 * self.radius)
    }

    /// The air at the start: the inflow's Poiseuille profile across the channel (at the start's
    /// share of U_max), at rest elsewhere along it, ρ₀ and θ₀; `obstacles` as given.
    fn fluid(&self, obstacles: &[Obstacle]) -> FluidSolver {
        let (n_y, theta0) = (self.grid.n[1] as f64, self.theta0);
        let u0 = self.u_lat * self.start.inflow_factor(0.0);
        let init = move |x: [f64; 3]| {
            let s = (x[1] + 0.5) / n_y;
            Macro { rho: 1.0, u: [u0 * 4.0 * s * (1.0 - s), 0.0, 0.0], theta: theta0 }
        };
        FluidSolver::new(self.eq.clone(), self.grid.clone(), self.boundaries.clone(), obstacles, self.params, init)
    }

    /// The inlet velocity before step k (k = 1, 2, …): U_max at the step's start time.
    fn inflow(&self, k: u64) -> [f64; 3] {
        [self.u_lat * self.start.inflow_factor((k - 1) as f64 * (self.params.dt * self.units.time())), 0.0, 0.0]
    }

    /// Selective frequency damping of `f` with [`ChannelStart::Damped`]'s gain and width.
    fn damping(&self, f: &FluidSolver) -> Option<SelectiveFrequencyDamping> {
        match self.start {
            ChannelStart::Damped { gain, filter_width } => {
                Some(SelectiveFrequencyDamping::new(f, gain * self.units.time(), filter_width / self.units.time()).expect("positive damping"))
            }
            _ => None,
        }
    }

    /// Δp two ways: the field sampled at the two wall points (fluid nodes only, a linear fit
    /// where the cell around the point is cut by the wall), and the pressure extrapolated to the
    /// wall along its normal from the air, quadratically through 1, 2 and 3 cells out
    /// (p_w = 3p₁ − 3p₂ + p₃, exact for a quadratic profile; the normals are −x and +x).
    fn pressure_drop(&self, f: &FluidSolver) -> (f64, f64) {
        let p = |x: [f64; 3]| f.sample(x).map(|m| self.units.gauge_pressure_to_physical(m.pressure())).unwrap_or(f64::NAN);
        let extrapolated = |x: [f64; 3], normal: f64| {
            let out = |k: f64| p([x[0] + normal * k, x[1], x[2]]);
            3.0 * out(1.0) - 3.0 * out(2.0) + out(3.0)
        };
        let [a, b] = self.drop_probes;
        (p(a) - p(b), extrapolated(a, -1.0) - extrapolated(b, 1.0))
    }

    /// The nodes of the solver's grid `g` whose distance from the cylinder's centre (cells)
    /// passes `keep`.
    fn nodes_at(&self, g: &Grid, keep: impl Fn(f64) -> bool) -> Vec<usize> {
        let cc = DVec3::from_array(lattice_point(&self.units, self.centre));
        (0..g.len()).filter(|&n| keep((DVec3::from_array(g.coords(n).map(|x| x as f64)) - cc).length())).collect()
    }

    /// The air within one diameter of the cylinder's surface: nodes 1.2–2 radii from its
    /// centre (fluid whatever the body does), for the density the forces see.
    fn near_nodes(&self, g: &Grid) -> Vec<usize> {
        let r_lat = self.units.length_to_lattice(self.radius);
        self.nodes_at(g, |d| (1.2 * r_lat..=2.0 * r_lat).contains(&d))
    }

    /// After step `k`: the force on the cylinder (N/m, `force`, asked only when it is needed),
    /// Δp and the density near it (`near`) into the window's sums over the last quarter of the
    /// run, and C_D into the history every `sample_every` steps.
    fn record(&self, k: u64, f: &FluidSolver, near: &[usize], force: impl FnOnce() -> DVec3, window: &mut Window, history: &mut Vec<f64>) {
        let (averaged, sampled) = (k > self.average_from, k.is_multiple_of(self.sample_every));
        if !(averaged || sampled) {
            return;
        }
        let force = force();
        if averaged {
            window.add(force, self.pressure_drop(f), self.coefficient);
            window.density += near_density(f, near);
        }
        if sampled {
            history.push(force.x * self.coefficient);
        }
    }

    /// The rigid ghost-node obstacle: C_D by the traction quadrature every sampled step, and by
    /// the momentum its wall nodes take out of the air over the window.
    fn run_rigid(&self) -> ChannelRun {
        let obstacle = Obstacle {
            shape: Shape::Cylinder { center: lattice_point(&self.units, self.centre), radius: self.units.length_to_lattice(self.radius) },
            velocity: [0.0; 3],
            temperature: None,
        };
        let (particles, surface) = self.disc(false);
        let mut f = self.fluid(&[obstacle]);
        let drag = |f: &FluidSolver| surface_forces(f, &self.units, std::slice::from_ref(&surface), &particles, TractionModel::PressureAndShear, 1.0).total[0];
        // the cylinder's wall nodes: within 3 cells of its surface (the channel walls lie
        // 15 radii away)
        let r_lat = self.units.length_to_lattice(self.radius);
        let cylinder_walls = self.nodes_at(&f.layout.grid, |d| d < r_lat + 3.0);
        // lattice momentum per step → N per m of span
        let u = &self.units;
        let force_unit = u.density * u.velocity * u.dx * u.dx / (self.params.dt * u.time());
        let mut exchanged = DVec3::ZERO;
        let near = self.near_nodes(&f.layout.grid);
        let mut sfd = self.damping(&f);
        let (mut window, mut history) = (Window::default(), Vec::new());
        for k in 1..=self.steps {
            f.layout.boundaries.set_inlet_velocity(Face::XMin, self.inflow(k)).expect("x_min is the velocity inlet");
            if k > self.average_from {
                let wall = crate::coupling::momentum_exchange::step_with_exchange(&mut f, None).expect("Schäfer–Turek stays stable");
                exchanged += cylinder_walls.iter().map(|&n| wall[n].truncate()).sum::<DVec3>() * force_unit;
            } else {
                f.step().expect("Schäfer–Turek stays stable");
            }
            if let Some(d) = sfd.as_mut() {
                d.apply(&mut f);
            }
            self.record(k, &f, &near, || drag(&f), &mut window, &mut history);
        }
        let exchange_drag = Some(exchanged.x / window.samples * self.coefficient);
        let residual = sfd.map(|d| d.residual(&f));
        ChannelRun { window, history, exchange_drag, residual, stage_shares: Vec::new(), substeps: 0, max_displacement: 0.0, particles: 0 }
    }

    /// The disc through the coupling (`body`: method 1, elastic or every particle clamped, or
    /// method 2): the force is method 1's traction quadrature or the momentum method 2's
    /// particles received.
    fn run_coupled(&self, body: CylinderBody) -> ChannelRun {
        let method = match body {
            CylinderBody::WeakCoupled(traction) => Method::Weak(WeakOptions { traction, ..Default::default() }),
            CylinderBody::WeakCoupledRigid => Method::Weak(WeakOptions { traction: TractionModel::PressureAndShear, ..Default::default() }),
            _ => Method::Conserving(ConservingOptions::default()),
        };
        let (particles, surface) = self.disc(body == CylinderBody::WeakCoupledRigid);
        let solid = SolidSolver::new(particles, vec![self.material.clone()], SolidOptions::default()).expect("valid disc");
        let bodies = vec![CoupledBody::adiabatic(surface, None)];
        let mut c = CoupledSolver::new(self.fluid(&[]), solid, self.units, bodies, Vec::new(), method).expect("valid coupling");
        let near = self.near_nodes(&c.fluid.layout.grid);
        let mut sfd = self.damping(&c.fluid);
        let (mut window, mut history) = (Window::default(), Vec::new());
        for k in 1..=self.steps {
            c.fluid.layout.boundaries.set_inlet_velocity(Face::XMin, self.inflow(k)).expect("x_min is the velocity inlet");
            c.step().expect("Schäfer–Turek stays stable");
            if let Some(d) = sfd.as_mut() {
                d.apply(&mut c.fluid);
            }
            // method 1: the traction quadrature; method 2: the momentum the particles received
            self.record(k, &c.fluid, &near, || c.forces.total[0], &mut window, &mut history);
        }
        let residual = sfd.map(|d| d.residual(&c.fluid));
        let p = &c.solid.particles;
        let max_displacement = (0..p.len()).map(|i| (p.position[i] - p.reference[i]).length()).fold(0.0, f64::max);
        let stage_shares = c.stage_shares().into_iter().map(|(n, s)| (n.to_string(), s)).collect();
        ChannelRun { window, history, exchange_drag: None, residual, stage_shares, substeps: c.substeps, max_displacement, particles: p.len() }
    }
}

/// A point `p` (m) of the channel in lattice coordinates.
fn lattice_point(units: &Units, p: DVec3) -> [f64; 3] {
    [units.position_to_lattice(p.x), units.position_to_lattice(p.y), 0.0]
}

/// The mean density over `nodes` of `f`.
fn near_density(f: &FluidSolver, nodes: &[usize]) -> f64 {
    nodes.iter().map(|&n| f.macro_at(n).rho).sum::<f64>() / nodes.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The outlet's pressure level sets the density of the air the cylinder sees, and C_D and Δp
    /// follow it one for one (`validate --case fsi_schafer_turek_2d1_outlet_level`, D = 20, 6 s:
    /// the outlet at 0.9833 ρ₀ moved the density near the cylinder by ×0.9841, C_D by ×0.9830
    /// and Δp by ×0.9830). Here D = 10, 4 s, damped, the outlet at ρ₀ and at 0.98 ρ₀. Both
    /// runs start at ρ₀, so the second drains 2 % of the channel's air through its outlet
    /// first: after 1 s the density near the cylinder had moved by ×0.9940 only and the forces
    /// by ×1.037 (the drain's acoustic transient); the damping (χ = 1/s) settles it. Measured
    /// at 4 s: the density ×0.9796, C_D ×0.9721, Δp ×0.9719 — the forces still 0.8 % beyond the
    /// level (the D = 10 channel rings longer than D = 20's: C_D ± 5 % undamped at 5 s, README),
    /// hence their bound of 1 % against the density's 0.3 %.
    #[test]
    fn the_outlet_level_sets_the_density_at_the_cylinder_and_the_forces_follow_it() {
        let run = |rho| schafer_turek_2d1_with_outlet(10, 0.1, ChannelStart::Damped { gain: 1.0, filter_width: 1.0 }, 4.0, CylinderBody::RigidObstacle, rho);
        let (a, b) = (run(1.0), run(0.98));
        let density = b.density_near_cylinder / a.density_near_cylinder;
        let (drag, drop) = (b.drag_coefficient / a.drag_coefficient, b.pressure_drop / a.pressure_drop);
        println!("ρ near the cylinder {:.5} → {:.5} (×{density:.5}); C_D ×{drag:.5}; Δp ×{drop:.5}", a.density_near_cylinder, b.density_near_cylinder);
        assert_eq!((a.outlet_density, b.outlet_density), (1.0, 0.98));
        assert!(a.density_near_cylinder > 1.0 && a.density_near_cylinder < 1.03, "{}", a.density_near_cylinder);
        assert!((density - 0.98).abs() < 0.003, "density ×{density}");
        for (what, x) in [("C_D", drag), ("Δp", drop)] {
            assert!((x - 0.98).abs() < 0.01, "{what} ×{x}");
        }
    }

    /// Why method 2's drag stands above method 1's (issue 12): method 2 hands its particles the
    /// momentum the air loses through the wall faces — the discrete flow's own force — while
    /// method 1 and the rigid obstacle's figure integrate the traction at the true surface from
    /// interpolated fields. Measured both ways on the rigid obstacle in the same run, the two
    /// differ by as much as method 2 differs from the quadrature, and method 2 matches the
    /// rigid obstacle's exchange drag (Schäfer–Turek 2D-1 at D = 10, Mach 0.1, 2 s, means over
    /// the last 0.5 s — not yet steady: an acoustic wave still rings through the channel, the
    /// same in both runs, so the comparison of the two measures stands). Measured: rigid quadrature 5.410, rigid exchange 5.975 (+10.4 %),
    /// method 2 5.979 (+0.06 % from the rigid exchange). The gap closes with resolution
    /// (`validate --case fsi_schafer_turek_2d1`).
    #[test]
    fn method_2_feels_the_drag_the_rigid_obstacle_gives_by_momentum_exchange() {
        let rigid = schafer_turek_2d1(10, 0.1, ChannelStart::Impulsive, 2.0, CylinderBody::RigidObstacle);
        let conserving = schafer_turek_2d1(10, 0.1, ChannelStart::Impulsive, 2.0, CylinderBody::ConservingCoupled);
        let exchange = rigid.exchange_drag_coefficient.expect("the rigid obstacle measures both");
        eprintln!("rigid: quadrature {} exchange {exchange}; method 2 {}", rigid.drag_coefficient, conserving.drag_coefficient);
        let gap = exchange / rigid.drag_coefficient - 1.0;
        let method_2 = conserving.drag_coefficient / exchange - 1.0;
        // the two measures of one flow differ at this resolution …
        assert!(gap > 0.05, "{rigid:?}");
        // … and method 2's drag is the exchange one: the level-set walls and the particles
        // change it by 1 % at most, a tenth of the gap
        assert!(method_2.abs() < 0.01, "{conserving:?} vs {exchange}");
    }

    /// The Schäfer–Turek channel rings after its start (a lossless quarter-wave resonator
    /// between the velocity inlet and the constant-pressure outlet); selective frequency damping
    /// ([`SelectiveFrequencyDamping`], χ = 1/s, Δ = 1 s: the fastest decay of the fundamental at
    /// ω₀ ≈ 2.1/s, rate ≈ 1/s) settles it. Rigid obstacle, D = 10, Mach 0.1, 5 s, means over the
    /// last 1.25 s: the spread of C_D in that window falls tenfold and more, and the damped
    /// run's C_D is within 2 % of the benchmark (at 3 s it is not yet: +3.7 %, still coming
    /// down — the damping slows the flow's own slow relaxation by 1 + χΔ = 2). Measured: free
    /// 5.544 ± 0.285, damped 5.592 ± 0.019 (+0.22 %), residual 3.7·10⁻³.
    #[test]
    fn selective_frequency_damping_settles_the_ringing_channel() {
        let free = schafer_turek_2d1(10, 0.1, ChannelStart::Impulsive, 5.0, CylinderBody::RigidObstacle);
        let damped = schafer_turek_2d1(10, 0.1, ChannelStart::Damped { gain: 1.0, filter_width: 1.0 }, 5.0, CylinderBody::RigidObstacle);
        eprintln!(
            "C_D free {} ± {}, damped {} ± {}; residual {:?}",
            free.drag_coefficient, free.drag_spread, damped.drag_coefficient, damped.drag_spread, damped.damping_residual
        );
        assert!(damped.drag_spread < 0.1 * free.drag_spread, "{} vs {}", damped.drag_spread, free.drag_spread);
        assert!((damped.drag_coefficient / ST_2D1_DRAG - 1.0).abs() < 0.02, "{damped:?}");
        assert!(damped.damping_residual.is_some_and(|r| r < 1e-2), "{damped:?}");
    }
}
