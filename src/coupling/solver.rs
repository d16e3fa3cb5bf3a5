//! The coupled solver: fluid + solid + one of the two couplings of seed 000 §2.4, stepped by
//! the coupling's ordered stage list ([`COUPLED_WEAK_STEP`] or [`COUPLED_CONSERVING_STEP`]).
//! The stages themselves live with their method: [`super::weak`] (method 1: surface polygons,
//! tractions) and [`super::conserving`] (method 2: level sets, momentum exchange); the solid
//! sub-steps are shared.
//!
//! Units: the solid works in the scene's physical units; the fluid in lattice units; positions
//! map through [`Units::position_to_lattice`] (the same origin).

use super::conserving::{ConservingOptions, Exchange};
use super::motion::Motion;
use super::surface::{BodySurface, SurfaceError};
use super::traction::SurfaceForces;
use super::weak::WeakOptions;
use crate::fluid::{FluidSolver, GeometryChange, Obstacle, Polygon, Shape, Totals};
use crate::solid::{Integrator, SolidSolver};
use crate::stages::{COUPLED_CONSERVING_STEP, COUPLED_WEAK_STEP, CoupledStage, CoupledStageKind};
use crate::step::{Instability, Part, Site};
use crate::units::Units;
use glam::DVec3;
use std::time::{Duration, Instant};

/// A body of the solid that the air sees: its surface (the polygon of method 1; the reference
/// surface that calibrates method 2's level set), optionally a prescribed motion, and how its
/// wall exchanges heat with the air.
#[derive(Clone, Debug)]
pub struct CoupledBody {
    pub surface: BodySurface,
    pub motion: Option<Motion>,
    /// The body's wall isothermal at this reduced temperature θ (lattice units), or adiabatic
    /// (`None`: zero normal temperature gradient). The ghost nodes behind an isothermal wall
    /// take the wall temperature extrapolated through it ([`crate::fluid::boundary`]), as the
    /// domain's isothermal walls do. Vocal-fold tissue is wet and at body temperature, with a
    /// heat capacity per volume ~3000× the air's: an isothermal wall is the closer model, and
    /// it is what keeps a closing glottis's dead-end pockets from heating without bound
    /// (README, "The coupled glottis").
    pub wall_temperature: Option<f64>,
}

impl CoupledBody {
    /// A body with an adiabatic wall.
    pub fn adiabatic(surface: BodySurface, motion: Option<Motion>) -> Self {
        CoupledBody { surface, motion, wall_temperature: None }
    }
}

/// Which coupling, with its options.
#[derive(Clone, Copy, Debug)]
pub enum Method {
    /// Method 1 (weak, §2.4.1).
    Weak(WeakOptions),
    /// Method 2 (momentum-conserving, §2.4.2).
    Conserving(ConservingOptions),
}

/// Errors of the coupled set-up, naming the field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CouplingSetupError {
    #[error("coupling.method: the weak coupling uses the explicit solid step (solid.integrator = \"explicit\")")]
    NeedsExplicitSolid,
    #[error("coupling: the fluid is {fluid}D and the solid {solid}D")]
    Dimensions { fluid: usize, solid: usize },
    #[error(
        "coupling.method: the weak coupling needs the bodies' surface triangles in 3D, which are not built yet; use method = \"momentum_conserving\" (level sets need no surface mesh)"
    )]
    WeakIn3d,
    #[error("coupling.bodies: {0}")]
    Surface(#[from] SurfaceError),
}

/// Fluid + solid + the coupling between them.
#[derive(Clone)]
pub struct CoupledSolver {
    pub fluid: FluidSolver,
    pub solid: SolidSolver,
    pub units: Units,
    pub bodies: Vec<CoupledBody>,
    /// Rigid obstacles of the fluid (lattice units), unchanged by the coupling.
    pub obstacles: Vec<Obstacle>,
    pub method: Method,
    /// Solid sub-steps per fluid step.
    pub substeps: u32,
    /// The air's forces on the particles over the last step (method 1: tractions; method 2:
    /// the momentum received divided by the step).
    pub forces: SurfaceForces,
    /// Geometry changes summed over the run.
    pub geometry: GeometryChange,
    pub step_count: u64,
    /// Physical time (s).
    pub time: f64,
    /// Wall time per stage of [`Self::stages`].
    pub timings: Vec<Duration>,
    pub(super) base_load: Vec<DVec3>,
    /// Method 1: the surface polygons the fluid geometry was last built from.
    pub(super) built: Option<Vec<Polygon>>,
    /// Method 2: the level sets' calibration and the momentum on its way to the particles.
    pub(super) exchange: Option<Exchange>,
    /// The particles of each coupled body, found once (a particle never changes body).
    pub(super) members: BodyMembers,
}

/// The particles of each coupled body (indices ascending), bodies in order, one after the
/// other: the order of the points of the bodies' level sets.
#[derive(Clone, Debug, Default)]
pub struct BodyMembers {
    /// Every body's particles, body after body.
    order: Vec<usize>,
    /// Where each body's particles begin in `order` (one more entry than bodies).
    starts: Vec<usize>,
}

impl BodyMembers {
    /// The particles whose `body` id is each of `bodies`, in that order.
    pub fn of(particle_body: &[u16], bodies: &[CoupledBody]) -> Self {
        let mut m = Self { order: Vec::new(), starts: vec![0] };
        for b in bodies {
            m.order.extend((0..particle_body.len()).filter(|&i| particle_body[i] == b.surface.body));
            m.starts.push(m.order.len());
        }
        m
    }

    /// Body `k`'s particles.
    pub fn body(&self, k: usize) -> &[usize] {
        &self.order[self.starts[k]..self.starts[k + 1]]
    }

    /// Each body's particles, bodies in order.
    pub fn bodies(&self) -> impl Iterator<Item = &[usize]> {
        (0..self.starts.len() - 1).map(|k| self.body(k))
    }

    /// Every body's particles, body after body.
    pub fn order(&self) -> &[usize] {
        &self.order
    }
}

/// Solid sub-steps per coupled step of `dt` (s) for a solid whose own step is `solid_dt` (s): the
/// fewest equal parts of `dt` none longer than `solid_dt` (at least one).
pub fn solid_substeps(dt: f64, solid_dt: f64) -> u32 {
    (dt / solid_dt).ceil().max(1.0) as u32
}

impl CoupledSolver {
    /// Couples `fluid` (with its rigid `obstacles`, lattice units) and `solid` through the
    /// `bodies` by `method`. The solid's sub-step is the largest that divides the fluid's step
    /// into equal parts and does not exceed the solid's own step.
    pub fn new(
        fluid: FluidSolver,
        mut solid: SolidSolver,
        units: Units,
        bodies: Vec<CoupledBody>,
        obstacles: Vec<Obstacle>,
        method: Method,
    ) -> Result<Self, CouplingSetupError> {
        if matches!(method, Method::Weak(_)) && solid.options.integrator != Integrator::Explicit {
            return Err(CouplingSetupError::NeedsExplicitSolid);
        }
        if fluid.layout.grid.dim != solid.particles.dim {
            return Err(CouplingSetupError::Dimensions { fluid: fluid.layout.grid.dim, solid: solid.particles.dim });
        }
        if matches!(method, Method::Weak(_)) && fluid.layout.grid.dim == 3 {
            return Err(CouplingSetupError::WeakIn3d);
        }
        let dt = fluid.params.dt * units.time();
        let substeps = solid_substeps(dt, solid.dt);
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
        let members = BodyMembers::of(&solid.particles.body, &bodies);
        let n = solid.particles.len();
        let stages = Self::stages_of(&method).len();
        let mut c = CoupledSolver {
            fluid,
            solid,
            units,
            bodies,
            obstacles,
            method,
            substeps,
            forces: SurfaceForces { force: vec![DVec3::ZERO; n], ..Default::default() },
            geometry: GeometryChange::default(),
            step_count: 0,
            time: 0.0,
            timings: vec![Duration::ZERO; stages],
            base_load,
            built: None,
            exchange: None,
            members,
        };
        if let Method::Conserving(o) = method {
            c.exchange = Some(Exchange::new(&c, o));
        }
        // The bodies' initial walls: the fluid inside them leaves the fluid now, not as a
        // "covered" change of the first step (nor as momentum handed to the bodies).
        c.run_stage(CoupledStageKind::FluidGeometry).expect("the first geometry has no previous one to compare with");
        c.geometry = GeometryChange::default();
        if let Some(e) = &mut c.exchange {
            e.clear();
        }
        if let Method::Conserving(o) = method
            && o.added_mass
        {
            let m = c.fluid_added_mass();
            c.solid.set_added_mass(m);
        }
        Ok(c)
    }

    /// The bodies' walls in the fluid: `shapes[k]` is body k's (its polygon or level set), at
    /// rest until the geometry stage sets its velocities, with body k's wall temperature.
    pub(super) fn body_walls(&self, shapes: impl IntoIterator<Item = Shape>) -> impl Iterator<Item = Obstacle> {
        shapes.into_iter().zip(&self.bodies).map(|(shape, b)| Obstacle { shape, velocity: [0.0; 3], temperature: b.wall_temperature })
    }

    fn stages_of(method: &Method) -> &'static [CoupledStage] {
        match method {
            Method::Weak(_) => &COUPLED_WEAK_STEP,
            Method::Conserving(_) => &COUPLED_CONSERVING_STEP,
        }
    }

    /// The ordered stages of one step of this coupling.
    pub fn stages(&self) -> &'static [CoupledStage] {
        Self::stages_of(&self.method)
    }

    /// Physical time step of one coupled step (s).
    pub fn dt(&self) -> f64 {
        self.fluid.params.dt * self.units.time()
    }

    /// One coupled step.
    pub fn step(&mut self) -> Result<(), Instability> {
        // on one of rayon's workers, so that the stages' parallel loops start inside the pool
        // (see `SolidSolver::step`)
        rayon::scope(|_| self.step_in_pool())
    }

    fn step_in_pool(&mut self) -> Result<(), Instability> {
        for (k, st) in self.stages().iter().enumerate() {
            let t0 = Instant::now();
            let r = self.run_stage(st.kind);
            self.timings[k] += t0.elapsed();
            r?;
        }
        self.step_count += 1;
        self.time += self.dt();
        Ok(())
    }

    /// The particles of each coupled body, bodies in order: the points of each body's level
    /// set, one after the other.
    pub fn body_members(&self) -> &BodyMembers {
        &self.members
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
        crate::stages::time_shares(self.stages().iter().map(|s| s.name).zip(&self.timings))
    }

    /// Runs one stage of the step (the stages of [`Self::stages`], in order, make a step; the
    /// step counter and time advance in [`Self::step`] only): for kernel parity tests.
    pub fn run_stage(&mut self, kind: CoupledStageKind) -> Result<(), Instability> {
        match (kind, self.method) {
            (CoupledStageKind::FluidGeometry, Method::Weak(o)) => self.polygon_geometry(o),
            (CoupledStageKind::FluidGeometry, Method::Conserving(_)) => self.level_set_geometry(),
            (CoupledStageKind::Fluid, Method::Weak(_)) => self.fluid.step(),
            (CoupledStageKind::Fluid, Method::Conserving(_)) => self.fluid_step_with_exchange(),
            (CoupledStageKind::SurfaceTraction, Method::Weak(o)) => {
                self.surface_traction(o);
                Ok(())
            }
            (CoupledStageKind::MomentumExchange, Method::Conserving(_)) => {
                self.momentum_exchange();
                Ok(())
            }
            (CoupledStageKind::Solid, _) => self.solid_substeps(),
            // a stage of the other method's list
            (CoupledStageKind::SurfaceTraction, Method::Conserving(_)) | (CoupledStageKind::MomentumExchange, Method::Weak(_)) => Ok(()),
        }
    }

    /// The air's forces become the particles' loads (on top of the scene's own loads).
    pub(super) fn apply_forces(&mut self) {
        let p = &mut self.solid.particles;
        for (load, (base, air)) in p.load.iter_mut().zip(self.base_load.iter().zip(&self.forces.force)) {
            *load = *base + *air;
        }
    }

    /// Solid sub-steps over the fluid step; prescribed bodies follow their motion.
    fn solid_substeps(&mut self) -> Result<(), Instability> {
        let dts = self.solid.dt;
        for k in 0..self.substeps {
            if let Err(mut e) = self.solid.step() {
                // stamped with the coupled step and time
                e.reason = format!("{} (solid sub-step {} of {})", e.reason, k + 1, self.substeps);
                (e.step, e.time) = (self.step_count, self.time);
                return Err(e);
            }
            self.apply_motions(self.time + (k + 1) as f64 * dts);
        }
        Ok(())
    }

    /// Puts every body with a prescribed motion where its motion is at time `t` (s): positions,
    /// velocities, orientations and spins of its particles.
    pub fn apply_motions(&mut self, t: f64) {
        for b in &self.bodies {
            if let Some(m) = &b.motion {
                m.apply(&mut self.solid.particles, b.surface.body, t);
            }
        }
    }

    /// The instability of a wall that moved `value` cells in one step, more than `limit`.
    pub(super) fn moved_too_far(&self, site: Site, quantity: &'static str, value: f64, limit: f64) -> Instability {
        Instability {
            part: Part::Coupling,
            step: self.step_count,
            time: self.time,
            time_unit: "s",
            site,
            quantity,
            value,
            reason: format!("a wall may move at most {limit} cell per fluid step (use a smaller time step or a slower body)"),
        }
    }

    /// Lattice coordinates of a physical position (z = 0 in 2D, the plane of the nodes).
    pub fn to_lattice(&self, x: DVec3) -> [f64; 3] {
        let u = &self.units;
        let z = if self.fluid.layout.grid.dim == 3 { u.position_to_lattice(x.z) } else { 0.0 };
        [u.position_to_lattice(x.x), u.position_to_lattice(x.y), z]
    }

    /// Linear momentum of the air (Σ ρu over fluid nodes) and of the particles (Σ m v),
    /// physical units (per unit depth in 2D).
    pub fn momentum(&self) -> (DVec3, DVec3) {
        (self.fluid_momentum(&self.fluid.totals()), self.solid.particles.linear_momentum())
    }

    /// The air's momentum Σ ρu of fluid `totals` (lattice units) in physical units.
    pub fn fluid_momentum(&self, totals: &Totals) -> DVec3 {
        DVec3::from_array(totals.momentum) * self.momentum_unit()
    }

    /// Physical momentum of one lattice unit of momentum in one cell (ρ₀ U Δx^D).
    pub fn momentum_unit(&self) -> f64 {
        let u = &self.units;
        u.density * u.velocity * u.dx.powi(self.fluid.layout.grid.dim as i32)
    }
}

impl crate::step::Solver for CoupledSolver {
    fn step(&mut self) -> Result<(), Instability> {
        CoupledSolver::step(self)
    }
    fn step_count(&self) -> u64 {
        self.step_count
    }
    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        CoupledSolver::stage_shares(self)
    }
}
