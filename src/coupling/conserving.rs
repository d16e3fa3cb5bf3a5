//! The momentum-conserving coupling (method 2, seed 000 §2.4.2) on the CPU: one coupled step
//! runs [`COUPLED_CONSERVING_STEP`].
//!
//! 1. **fluid_geometry** — every body's particles define a level set on the lattice (2.124);
//!    its zero contour is the wall the fluid sees (a [`KernelLevelSet`] obstacle: the ghost
//!    nodes take the wall position −L/|∇L| and normal −∇L/|∇L| (2.125–2.126) and the wall
//!    velocity interpolated from the particles with the kernel weights, 2.130). A node the
//!    body covers leaves the fluid with its momentum, which the body receives; a node it
//!    uncovers enters the fluid with momentum the body gives up.
//! 2. **fluid** — one FDLB step; the momentum each wall node takes out of the air through its
//!    faces with fluid nodes is recorded link by link ([`super::momentum_exchange`]: the
//!    W_in + W_out of 2.122–2.123 for the finite-difference advection).
//! 3. **momentum_exchange** — each wall node's momentum is shared among the particles within
//!    r_e of it with the kernel weights w_j normalised to sum to one (2.127–2.128; the seed
//!    normalises by |L|, which does not sum to one, and the sum must be one for the solid to
//!    receive exactly what the air lost) and becomes a load over the step.
//! 4. **solid** — the solid steps (explicit sub-steps or implicit) with those loads.
//!
//! Everything the air loses, the particles gain: fluid + solid momentum is conserved to
//! round-off (the solid's internal forces are pairwise), with no surface polygon. The exchange
//! is counted against the air at rest at the reference pressure p₀ (gauge), as method 1's
//! tractions are: a body's reference shape is its shape in air at p₀.
//!
//! Not built yet: the fluid's added mass in the implicit solve (2.129), which lets the seed take
//! larger steps with light bodies; here the wall velocity of a step is the particles' velocity
//! at its start (a staggered exchange), as in method 1.
//!
//! Units: the solid in the scene's physical units, the fluid in lattice units.

use super::momentum_exchange::step_with_exchange;
use super::weak::{CoupledBody, CouplingSetupError};
use crate::fluid::layout::NodeKind;
use crate::fluid::{FluidSolver, GeometryChange, KernelLevelSet, Obstacle, Shape};
use crate::solid::SolidSolver;
use crate::stages::{COUPLED_CONSERVING_STEP, CoupledStageKind};
use crate::step::{Instability, Part, Site};
use crate::units::Units;
use glam::DVec3;
use std::time::{Duration, Instant};

/// Options of the momentum-conserving coupling.
#[derive(Clone, Copy, Debug)]
pub struct ConservingOptions {
    /// Kernel radius r_e of the level set (lattice cells); the level set's contour is smooth
    /// to a fraction of a cell for r_e ≥ 2 cells (`level_set` tests).
    pub kernel_radius: f64,
    /// Largest particle displacement per fluid step (cells).
    pub max_cells_per_step: f64,
}

impl Default for ConservingOptions {
    fn default() -> Self {
        Self { kernel_radius: 2.0, max_cells_per_step: 1.0 }
    }
}

/// Fluid + solid + the momentum-conserving coupling between them.
pub struct ConservingCoupling {
    pub fluid: FluidSolver,
    pub solid: SolidSolver,
    pub units: Units,
    pub bodies: Vec<CoupledBody>,
    /// Rigid obstacles of the fluid (lattice units), unchanged by the coupling.
    pub obstacles: Vec<Obstacle>,
    pub options: ConservingOptions,
    /// Solid sub-steps per fluid step.
    pub substeps: u32,
    /// Surface level φ of each body (2.124), from its reference surface.
    pub phi: Vec<f64>,
    /// Momentum each particle received from the air in the last step (physical units).
    pub received: Vec<DVec3>,
    /// Momentum handed over the run to walls that are no coupled body (rigid obstacles, face
    /// walls: no particle within r_e), physical units.
    pub walls: DVec3,
    /// Geometry changes summed over the run.
    pub geometry: GeometryChange,
    pub step_count: u64,
    /// Physical time (s).
    pub time: f64,
    /// Wall time per stage of [`COUPLED_CONSERVING_STEP`].
    pub timings: [Duration; COUPLED_CONSERVING_STEP.len()],
    base_load: Vec<DVec3>,
    /// Momentum taken out of the air per padded node in the current step (lattice units).
    wall: Vec<DVec3>,
    /// Particle positions (cells) the geometry was last built from.
    built: Option<Vec<DVec3>>,
    /// Populations of the air at rest in the reference state (ρ = 1, θ₀): the exchange is
    /// counted against it (gauge momentum, [`super::momentum_exchange::add_face_fluxes`]).
    reference: Vec<f64>,
}

impl ConservingCoupling {
    /// Couples `fluid` (with its rigid `obstacles`, lattice units) and `solid` through the level
    /// sets of `bodies` (their surfaces calibrate φ). The solid's sub-step is the largest that
    /// divides the fluid's step into equal parts and does not exceed the solid's own step.
    pub fn new(
        fluid: FluidSolver,
        mut solid: SolidSolver,
        units: Units,
        bodies: Vec<CoupledBody>,
        obstacles: Vec<Obstacle>,
        options: ConservingOptions,
    ) -> Result<Self, CouplingSetupError> {
        if fluid.layout.grid.dim != solid.particles.dim {
            return Err(CouplingSetupError::Dimensions { fluid: fluid.layout.grid.dim, solid: solid.particles.dim });
        }
        let dt = fluid.params.dt * units.time();
        let substeps = (dt / solid.dt).ceil().max(1.0) as u32;
        solid.dt = dt / substeps as f64;
        for b in &bodies {
            if let Some(m) = &b.motion {
                let p = &mut solid.particles;
                for i in 0..p.len() {
                    if p.body[i] == b.surface.body {
                        p.fixed[i] = true;
                    }
                }
                m.apply(p, b.surface.body, 0.0);
            }
        }
        let base_load = solid.particles.load.clone();
        let n = solid.particles.len();
        let nodes = fluid.layout.grid.len();
        let mut reference = vec![0.0; fluid.eq.values_per_node()];
        let mut shell_w = vec![0.0; fluid.eq.set.shells.len()];
        fluid.eq.feq_into(&crate::fluid::Macro { rho: 1.0, u: [0.0; 3], theta: units.theta0 }, &mut shell_w, &mut reference);
        let mut c = ConservingCoupling {
            fluid,
            solid,
            units,
            bodies,
            obstacles,
            options,
            substeps,
            phi: Vec::new(),
            received: vec![DVec3::ZERO; n],
            walls: DVec3::ZERO,
            geometry: GeometryChange::default(),
            step_count: 0,
            time: 0.0,
            timings: [Duration::ZERO; COUPLED_CONSERVING_STEP.len()],
            base_load,
            wall: vec![DVec3::ZERO; nodes],
            built: None,
            reference,
        };
        c.phi = c.bodies.iter().map(|b| c.surface_level(b)).collect();
        // The bodies' initial walls: the air inside them leaves now, not as a "covered" change
        // of the first step (and its momentum is not the body's).
        c.run_stage(CoupledStageKind::FluidGeometry).expect("the first geometry has no previous one to compare with");
        c.wall.iter_mut().for_each(|w| *w = DVec3::ZERO);
        c.geometry = GeometryChange::default();
        Ok(c)
    }

    /// Physical time step of one coupled step (s).
    pub fn dt(&self) -> f64 {
        self.fluid.params.dt * self.units.time()
    }

    fn r_min(&self) -> f64 {
        0.25 * self.solid.particles.spacing / self.units.dx
    }

    /// Lattice coordinates of a physical position (z = 0 in 2D, the plane of the nodes).
    fn to_lattice(&self, x: DVec3) -> [f64; 3] {
        let u = &self.units;
        let z = if self.fluid.layout.grid.dim == 3 { u.position_to_lattice(x.z) } else { 0.0 };
        [u.position_to_lattice(x.x), u.position_to_lattice(x.y), z]
    }

    /// φ of `body`: the mean kernel sum at its surface points in the reference configuration.
    fn surface_level(&self, body: &CoupledBody) -> f64 {
        let p = &self.solid.particles;
        let members: Vec<DVec3> = (0..p.len()).filter(|&i| p.body[i] == body.surface.body).map(|i| DVec3::from_array(self.to_lattice(p.position[i]))).collect();
        let surface: Vec<DVec3> = body.surface.points(p).into_iter().map(|x| DVec3::from_array(self.to_lattice(x))).collect();
        super::level_set::surface_level(&members, &surface, self.options.kernel_radius, self.r_min())
    }

    /// The level set of every body at the particles' current positions and velocities.
    pub fn level_sets(&self) -> Vec<KernelLevelSet> {
        let p = &self.solid.particles;
        self.bodies
            .iter()
            .zip(&self.phi)
            .map(|(b, &phi)| {
                let members = (0..p.len()).filter(|&i| p.body[i] == b.surface.body);
                let (x, v) = members.map(|i| (self.to_lattice(p.position[i]), (p.velocity[i] / self.units.velocity).to_array())).unzip();
                KernelLevelSet::new(x, v, self.options.kernel_radius, self.r_min(), phi)
            })
            .collect()
    }

    /// One coupled step.
    pub fn step(&mut self) -> Result<(), Instability> {
        for (k, st) in COUPLED_CONSERVING_STEP.iter().enumerate() {
            let t0 = Instant::now();
            let r = self.run_stage(st.kind);
            self.timings[k] += t0.elapsed();
            r?;
        }
        self.step_count += 1;
        self.time += self.dt();
        Ok(())
    }

    /// Runs `n` coupled steps, stopping at the first instability.
    pub fn run(&mut self, n: u64) -> Result<(), Instability> {
        for _ in 0..n {
            self.step()?;
        }
        Ok(())
    }

    /// Each stage's share of the wall time so far.
    pub fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        crate::stages::time_shares(COUPLED_CONSERVING_STEP.iter().map(|s| s.name).zip(&self.timings))
    }

    fn run_stage(&mut self, kind: CoupledStageKind) -> Result<(), Instability> {
        match kind {
            CoupledStageKind::FluidGeometry => self.fluid_geometry()?,
            CoupledStageKind::Fluid => {
                let flux = step_with_exchange(&mut self.fluid, Some(&self.reference))?;
                self.wall.iter_mut().zip(flux).for_each(|(w, f)| *w += f);
            }
            CoupledStageKind::MomentumExchange => self.momentum_exchange(),
            CoupledStageKind::Solid => {
                let dts = self.solid.dt;
                for k in 0..self.substeps {
                    if let Err(mut e) = self.solid.step() {
                        e.reason = format!("{} (solid sub-step {} of {})", e.reason, k + 1, self.substeps);
                        (e.step, e.time) = (self.step_count, self.time);
                        return Err(e);
                    }
                    let t = self.time + (k + 1) as f64 * dts;
                    for b in &self.bodies {
                        if let Some(m) = &b.motion {
                            m.apply(&mut self.solid.particles, b.surface.body, t);
                        }
                    }
                }
            }
            CoupledStageKind::SurfaceTraction => {} // method 1's fluid → solid stage
        }
        Ok(())
    }

    /// Stage 1: the level-set walls; covered and uncovered nodes' momentum booked to the walls.
    fn fluid_geometry(&mut self) -> Result<(), Instability> {
        let points: Vec<DVec3> = self.solid.particles.position.iter().map(|x| DVec3::from_array(self.to_lattice(*x))).collect();
        if let Some(old) = &self.built {
            let (i, d) = old.iter().zip(&points).map(|(a, b)| (*a - *b).length()).enumerate().fold((0, 0.0), |m, (i, d)| if d > m.1 { (i, d) } else { m });
            if d > self.options.max_cells_per_step {
                return Err(Instability {
                    part: Part::Coupling,
                    step: self.step_count,
                    time: self.time,
                    time_unit: "s",
                    site: Site::Particle(i),
                    quantity: "particle displacement in one step (cells)",
                    value: d,
                    reason: format!("a particle may move at most {} cell per fluid step (use a smaller time step or a slower body)", self.options.max_cells_per_step),
                });
            }
        }
        let mut all = self.obstacles.clone();
        all.extend(self.level_sets().into_iter().map(|k| Obstacle { shape: Shape::KernelLevelSet(k), velocity: [0.0; 3], temperature: None }));
        let was: Vec<bool> = self.fluid.layout.kind.iter().map(|k| *k == NodeKind::Fluid).collect();
        let ch = self.fluid.set_obstacles(&all);
        let q = self.fluid.eq.q();
        for (node, was) in was.into_iter().enumerate() {
            let is = self.fluid.layout.kind[node] == NodeKind::Fluid;
            if was == is {
                continue;
            }
            let f = self.fluid.node_populations(node);
            let m: DVec3 = self.fluid.eq.cf[..q].iter().zip(&f[..q]).map(|(c, f)| DVec3::from_array(*c) * *f).sum();
            // Covered: the air's momentum goes to the body; uncovered: the body pays for it.
            self.wall[node] += if was { m } else { -m };
        }
        self.geometry.uncovered += ch.uncovered;
        self.geometry.covered += ch.covered;
        self.geometry.isolated += ch.isolated;
        self.geometry.mass_change += ch.mass_change;
        self.built = Some(points);
        Ok(())
    }

    /// Stage 3: each wall node's momentum to the particles near it (2.127–2.128), as loads.
    fn momentum_exchange(&mut self) {
        let u = &self.units;
        let cell = u.dx.powi(self.fluid.layout.grid.dim as i32);
        let to_physical = u.density * u.velocity * cell;
        let sets = self.level_sets();
        let p = &self.solid.particles;
        // particle index of each level set's j-th point
        let members: Vec<Vec<usize>> = self.bodies.iter().map(|b| (0..p.len()).filter(|&i| p.body[i] == b.surface.body).collect()).collect();
        self.received.iter_mut().for_each(|r| *r = DVec3::ZERO);
        let grid = &self.fluid.layout.grid;
        for node in 0..grid.len() {
            let w = std::mem::take(&mut self.wall[node]);
            if w == DVec3::ZERO {
                continue;
            }
            let x = grid.coords(node);
            let at = [x[0] as f64, x[1] as f64, x[2] as f64];
            let weights: Vec<(usize, f64)> = sets.iter().zip(&members).flat_map(|(s, m)| s.weights(at).map(move |(j, wj)| (m[j], wj))).collect();
            let sum: f64 = weights.iter().map(|(_, wj)| wj).sum();
            if sum > 0.0 {
                for (i, wj) in weights {
                    self.received[i] += (wj / sum) * w * to_physical;
                }
            } else {
                self.walls += w * to_physical;
            }
        }
        let dt = self.dt();
        let p = &mut self.solid.particles;
        for i in 0..p.len() {
            p.load[i] = self.base_load[i] + self.received[i] / dt;
        }
    }

    /// Linear momentum of the air (Σ ρu over fluid nodes) and of the particles (Σ m v),
    /// physical units (per unit depth in 2D).
    pub fn momentum(&self) -> (DVec3, DVec3) {
        let u = &self.units;
        let cell = u.dx.powi(self.fluid.layout.grid.dim as i32);
        let air = DVec3::from_array(self.fluid.totals().momentum) * u.density * u.velocity * cell;
        (air, self.solid.particles.linear_momentum())
    }
}

impl crate::step::Solver for ConservingCoupling {
    fn step(&mut self) -> Result<(), Instability> {
        ConservingCoupling::step(self)
    }
    fn step_count(&self) -> u64 {
        self.step_count
    }
    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        ConservingCoupling::stage_shares(self)
    }
}
