//! The weak coupling (method 1, seed 000 §2.4.1) on the CPU: one coupled step runs
//! [`COUPLED_WEAK_STEP`] — the bodies' surfaces become moving walls of the fluid, the fluid
//! takes one step, the air's tractions load the surface particles, and the explicit solid
//! sub-steps over the fluid's time step.
//!
//! The fluid side of the moving wall: the seed adapts Mei et al.'s curved bounce-back (2.105–
//! 2.109) to the FDLB, sub-dividing the step for the speeds that cross 2 and 3 cells. This
//! solver's FDLB advects by 3rd-order upwind finite differences whose stencil reads up to two
//! nodes behind a fluid node, so its walls enter through ghost nodes (see
//! [`crate::fluid::boundary`]: image-point extrapolation of the macroscopic state, the wall
//! velocity imposed, non-equilibrium part carried over) — already validated for fixed and
//! moving walls; here each ghost takes the wall velocity of the closest point of the body's
//! surface polygon. No per-speed sub-division is needed: the ghost state serves every
//! velocity of the stencil. The moving body must not cross more than one cell per step. Where
//! two bodies close on each other the wall between two fluid regions becomes thinner than the
//! stencil; the fluid nodes there take one-sided stencils ([`crate::fluid::thin_wall`]) so that
//! no state passes through the contact.
//!
//! Units: the solid works in the scene's physical units; the fluid in lattice units; positions
//! map through [`Units::position_to_lattice`] (the same origin).

use super::motion::Motion;
use super::surface::{BodySurface, SurfaceError};
use super::traction::{SurfaceForces, TractionModel, surface_forces};
use crate::fluid::{FluidSolver, GeometryChange, Obstacle, Polygon, Shape, Totals};
use crate::solid::{Integrator, SolidSolver};
use crate::stages::{COUPLED_WEAK_STEP, CoupledStageKind};
use crate::step::{Instability, Part, Site};
use crate::units::Units;
use glam::DVec3;
use std::time::{Duration, Instant};

/// A body of the solid that the air sees: its surface polygon and, optionally, a prescribed motion.
#[derive(Clone, Debug)]
pub struct CoupledBody {
    pub surface: BodySurface,
    pub motion: Option<Motion>,
}

/// Options of the weak coupling.
#[derive(Clone, Copy, Debug)]
pub struct WeakOptions {
    pub traction: TractionModel,
    /// Longest surface piece (lattice cells) of the traction quadrature.
    pub piece_length: f64,
    /// Largest surface displacement per fluid step (cells).
    pub max_cells_per_step: f64,
}

impl Default for WeakOptions {
    fn default() -> Self {
        Self { traction: TractionModel::default(), piece_length: 1.0, max_cells_per_step: 1.0 }
    }
}

/// Errors of the coupled set-up, naming the field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CouplingSetupError {
    #[error("coupling.method: the weak coupling uses the explicit solid step (solid.integrator = \"explicit\")")]
    NeedsExplicitSolid,
    #[error("coupling: the fluid is {fluid}D and the solid {solid}D")]
    Dimensions { fluid: usize, solid: usize },
    #[error("coupling.bodies: {0}")]
    Surface(#[from] SurfaceError),
}

/// Fluid + solid + the weak coupling between them.
pub struct WeakCoupling {
    pub fluid: FluidSolver,
    pub solid: SolidSolver,
    pub units: Units,
    pub bodies: Vec<CoupledBody>,
    /// Rigid obstacles of the fluid (lattice units), unchanged by the coupling.
    pub obstacles: Vec<Obstacle>,
    pub options: WeakOptions,
    /// Solid sub-steps per fluid step.
    pub substeps: u32,
    /// The air's forces of the last step.
    pub forces: SurfaceForces,
    /// Geometry changes summed over the run.
    pub geometry: GeometryChange,
    pub step_count: u64,
    /// Physical time (s).
    pub time: f64,
    /// Wall time per stage of [`COUPLED_WEAK_STEP`].
    pub timings: [Duration; COUPLED_WEAK_STEP.len()],
    base_load: Vec<DVec3>,
    /// The surface polygons the fluid geometry was last built from.
    pub(super) built: Option<Vec<Polygon>>,
}

impl WeakCoupling {
    /// Couples `fluid` (with its rigid `obstacles`, lattice units) and `solid` (explicit) through
    /// the surfaces of `bodies`. The solid's sub-step is the largest that divides the fluid's
    /// step into equal parts and does not exceed the solid's own step.
    pub fn new(
        fluid: FluidSolver,
        mut solid: SolidSolver,
        units: Units,
        bodies: Vec<CoupledBody>,
        obstacles: Vec<Obstacle>,
        options: WeakOptions,
    ) -> Result<Self, CouplingSetupError> {
        if solid.options.integrator != Integrator::Explicit {
            return Err(CouplingSetupError::NeedsExplicitSolid);
        }
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
        let mut c = WeakCoupling {
            fluid,
            solid,
            units,
            bodies,
            obstacles,
            options,
            substeps,
            forces: SurfaceForces::default(),
            geometry: GeometryChange::default(),
            step_count: 0,
            time: 0.0,
            timings: [Duration::ZERO; COUPLED_WEAK_STEP.len()],
            base_load,
            built: None,
        };
        // The bodies' initial walls: the fluid inside them leaves the fluid now, not as a
        // "covered" change of the first step.
        c.run_stage(CoupledStageKind::FluidGeometry).expect("the first geometry has no previous one to compare with");
        c.geometry = GeometryChange::default();
        Ok(c)
    }

    /// Physical time step of one coupled step (s).
    pub fn dt(&self) -> f64 {
        self.fluid.params.dt * self.units.time()
    }

    /// One coupled step.
    pub fn step(&mut self) -> Result<(), Instability> {
        for (k, st) in COUPLED_WEAK_STEP.iter().enumerate() {
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
        crate::stages::time_shares(COUPLED_WEAK_STEP.iter().map(|s| s.name).zip(&self.timings))
    }

    /// The surface polygons in lattice coordinates, with wall velocities in c units.
    pub fn polygons(&self) -> Vec<Polygon> {
        let u = &self.units;
        let p = &self.solid.particles;
        self.bodies
            .iter()
            .map(|b| {
                let x = b.surface.points(p);
                let v = b.surface.velocities(p);
                Polygon::new(
                    x.iter().map(|x| [u.position_to_lattice(x.x), u.position_to_lattice(x.y)]).collect(),
                    v.iter().map(|v| (*v / u.velocity).to_array()).collect(),
                )
            })
            .collect()
    }

    fn run_stage(&mut self, kind: CoupledStageKind) -> Result<(), Instability> {
        match kind {
            CoupledStageKind::FluidGeometry => {
                let polys = self.polygons();
                if let Some(old) = &self.built {
                    let mut moved = false;
                    for (k, (a, b)) in old.iter().zip(&polys).enumerate() {
                        let d = a.vertices.iter().zip(&b.vertices).map(|(p, q)| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()).fold(0.0, f64::max);
                        if d > self.options.max_cells_per_step {
                            return Err(Instability {
                                part: Part::Coupling,
                                step: self.step_count,
                                time: self.time,
                                time_unit: "s",
                                site: Site::Body(self.bodies[k].surface.body),
                                quantity: "surface displacement in one step (cells)",
                                value: d,
                                reason: format!(
                                    "a surface may move at most {} cell per fluid step (use a smaller time step or a slower body)",
                                    self.options.max_cells_per_step
                                ),
                            });
                        }
                        // Wall velocities change even when the vertices do not (a body set moving).
                        moved |= d > 0.0 || a.velocities != b.velocities;
                    }
                    if !moved {
                        return Ok(());
                    }
                }
                let mut all = self.obstacles.clone();
                all.extend(polys.iter().cloned().map(|p| Obstacle { shape: Shape::Polygon(p), velocity: [0.0; 3], temperature: None }));
                let ch = self.fluid.set_obstacles(&all);
                self.geometry.uncovered += ch.uncovered;
                self.geometry.covered += ch.covered;
                self.geometry.isolated += ch.isolated;
                self.geometry.mass_change += ch.mass_change;
                self.built = Some(polys);
            }
            CoupledStageKind::Fluid => self.fluid.step()?,
            // Not a stage of method 1 (its fluid → solid stage is the surface traction).
            CoupledStageKind::MomentumExchange => {}
            CoupledStageKind::SurfaceTraction => {
                let surfaces = self.bodies.iter().map(|b| &b.surface);
                self.forces = surface_forces(&self.fluid, &self.units, surfaces, &self.solid.particles, self.options.traction, self.options.piece_length);
                let p = &mut self.solid.particles;
                for i in 0..p.len() {
                    p.load[i] = self.base_load[i] + self.forces.force[i];
                }
            }
            CoupledStageKind::Solid => {
                let dts = self.solid.dt;
                for k in 0..self.substeps {
                    if let Err(mut e) = self.solid.step() {
                        // stamped with the coupled step and time
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
        }
        Ok(())
    }

    /// Linear momentum of the air (Σ ρu over fluid nodes) and of the particles (Σ m v),
    /// physical units (per unit depth in 2D).
    pub fn momentum(&self) -> (DVec3, DVec3) {
        (self.fluid_momentum(&self.fluid.totals()), self.solid.particles.linear_momentum())
    }

    /// The air's momentum Σ ρu of fluid `totals` (lattice units) in physical units.
    pub fn fluid_momentum(&self, totals: &Totals) -> DVec3 {
        let u = &self.units;
        let cell = u.dx.powi(self.fluid.layout.grid.dim as i32);
        DVec3::from_array(totals.momentum) * u.density * u.velocity * cell
    }
}

impl crate::step::Solver for WeakCoupling {
    fn step(&mut self) -> Result<(), Instability> {
        WeakCoupling::step(self)
    }
    fn step_count(&self) -> u64 {
        self.step_count
    }
    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        WeakCoupling::stage_shares(self)
    }
}
