//! The MPS solid on the CPU: explicit (seed 000 §2.2.4) and implicit (§2.2.5) steps driven by
//! the stage lists [`SOLID_EXPLICIT_STEP`] and [`SOLID_IMPLICIT_STEP`].

use super::bonds::{self, Bonds};
use super::coarse::CoarseSpace;
use super::contact::{ContactInput, ContactParams, Contacts, Wall};
use super::forces::{Discretisation, ForceField, Mode, StressField, bond_forces, rotation_chain, strain_stress};
use super::grid::Periods;
use super::implicit::{BlockJacobi, CgReport, CgTally, conjugate_gradient};
use super::linear::LinearOperator;
use super::material::{Orthotropic, Voigt6, min_mandel_eigenvalue};
use super::particles::Particles;
use super::patch_jacobi::PatchJacobi;
use super::rotation::{advance_quaternion, solve_all_rotations, solve_angular_velocity};
use super::timestep::stable_time_step;
use crate::error::SceneError;
use crate::stages::{SOLID_EXPLICIT_STEP, SOLID_IMPLICIT_STEP, SolidStage, SolidStageKind};
use crate::step::{Instability, Part, Site};
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// Symplectic Euler on translations and rotations, (2.44)–(2.56).
    Explicit,
    /// Backward Euler on velocities with linearised pair forces, (2.57)–(2.66), rotations by
    /// Newton–Raphson (2.73)–(2.76).
    Implicit,
}

/// The smoother of the implicit step's preconditioner (the coarse space [`super::coarse`] is
/// added to either, on the CPU and, where it holds it, on the GPU).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preconditioner {
    /// One 3×3 block per particle ([`BlockJacobi`]).
    BlockJacobi,
    /// The exact inverse of each patch's block (3³ particles in 3D, 4² in 2D; [`PatchJacobi`]):
    /// 2.3–3× fewer iterations than block Jacobi on the 12³–46³ benchmark blocks at 10× the
    /// explicit step (27–28 iterations at 10⁶ particles, with the block-sparse coarse space).
    #[default]
    Patches,
}

/// Numerical options of a solid.
#[derive(Clone, Debug)]
pub struct SolidOptions {
    /// r_e / l₀ (the seed's glottis uses 0.00882 / 0.0042 = 2.1).
    pub influence_ratio: f64,
    /// Fraction β of the softest stiffness eigenvalue carried by the pair model (0, 1).
    pub pair_fraction: f64,
    pub periods: Periods,
    pub integrator: Integrator,
    /// Time step; `None` picks `safety` × the estimated explicit stability limit.
    pub time_step: Option<f64>,
    pub safety: f64,
    pub gravity: DVec3,
    pub contact: Option<ContactParams>,
    pub walls: Vec<Wall>,
    /// CG stops when ‖r‖ ≤ tolerance ‖B‖.
    pub cg_tolerance: f64,
    pub cg_max_iterations: usize,
    /// Newton–Raphson tolerance of the implicit rotations (relative moment).
    pub rotation_tolerance: f64,
    /// The implicit step's smoother on the CPU.
    pub preconditioner: Preconditioner,
}

impl Default for SolidOptions {
    fn default() -> Self {
        Self {
            influence_ratio: 2.1,
            pair_fraction: 0.3,
            periods: [None; 3],
            integrator: Integrator::Explicit,
            time_step: None,
            safety: 0.5,
            gravity: DVec3::ZERO,
            contact: None,
            walls: Vec::new(),
            cg_tolerance: 1e-8,
            cg_max_iterations: 2000,
            rotation_tolerance: 1e-12,
            preconditioner: Preconditioner::default(),
        }
    }
}

/// What the last step did.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepStats {
    pub cg: CgReport,
    pub newton_iterations: u32,
}

/// Energies of the current state (consistent units of energy; per unit depth in 2D).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Energies {
    pub kinetic: f64,
    pub elastic: f64,
    /// −Σ (loads + gravity)·(x − X).
    pub external: f64,
}

impl Energies {
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.external
    }
}

#[derive(Clone, Debug)]
pub struct SolidSolver {
    pub particles: Particles,
    pub disc: Discretisation,
    pub materials: Vec<Orthotropic>,
    pub options: SolidOptions,
    pub dt: f64,
    /// Estimated explicit stability limit (whatever the integrator).
    pub explicit_limit: f64,
    pub time: f64,
    pub step_count: u64,
    pub last: StepStats,
    /// Every implicit solve of this solver so far (not carried by a checkpoint: a resumed run
    /// counts from its resumption).
    pub cg_tally: CgTally,
    pub timings: Vec<(SolidStage, Duration)>,
    rot: Vec<DMat3>,
    stress: StressField,
    forces: ForceField,
    pub(super) contacts: Contacts,
    total_force: Vec<DVec3>,
    total_torque: Vec<DVec3>,
    precond: Option<BlockJacobi>,
    /// Implicit only, [`Preconditioner::Patches`]: the patch smoother, built with the coarse space.
    patches: Option<PatchJacobi>,
    /// Implicit only: the preconditioner's coarse-space correction ([`super::coarse`]), built
    /// with the smoother; `None` inside when A_c could not be factorised.
    coarse: Option<Option<CoarseSpace>>,
    /// Implicit only: J_i⁻¹ of (2.74) at the current state.
    jinv: Vec<DMat3>,
}

impl SolidSolver {
    /// Checks the materials, builds the neighbour lists, the per-particle stiffness split and
    /// the time step. Errors name the field and the reason.
    pub fn new(particles: Particles, materials: Vec<Orthotropic>, options: SolidOptions) -> Result<Self, SceneError> {
        let err = |f: &str, r: String| Err(SceneError { field: f.into(), reason: r });
        if particles.is_empty() {
            return err("solid.bodies", "no particles: every body is empty at this spacing".into());
        }
        if !(options.influence_ratio > 1.0 && options.influence_ratio <= 4.0) {
            return err("solid.influence_ratio", format!("r_e/l₀ must be in (1, 4], got {}", options.influence_ratio));
        }
        if !(options.pair_fraction > 0.0 && options.pair_fraction < 1.0) {
            return err("solid.pair_fraction", format!("must be in (0, 1), got {}", options.pair_fraction));
        }
        let re = options.influence_ratio * particles.spacing;
        for (a, period) in options.periods.iter().enumerate() {
            if let Some(l) = period
                && !(l.is_finite() && *l > 2.0 * re)
            {
                return err("solid.periods", format!("the period {l} along axis {a} must exceed 2 r_e = {:.4} (each bond needs one nearest image)", 2.0 * re));
            }
        }
        let mut stiff: Vec<Voigt6> = Vec::new();
        for (k, m) in materials.iter().enumerate() {
            stiff.push(m.stiffness(&format!("solid.materials[{k}]"))?);
        }
        let n = particles.len();
        let mu_p: Vec<f64> = stiff.iter().map(|c| options.pair_fraction * min_mandel_eigenvalue(c)).collect();
        let pm: Vec<f64> = particles.material.iter().map(|&m| mu_p[m as usize]).collect();
        let eta: Vec<f64> = particles.material.iter().map(|&m| materials[m as usize].viscosity).collect();
        let bonds: Bonds = bonds::build(&particles, re, options.periods, &pm, &eta);
        let grad_stiffness: Vec<Voigt6> = (0..n)
            .into_par_iter()
            .map(|i| {
                let cp = bonds::pair_stiffness(&bonds, i, particles.volume[i]);
                let c = stiff[particles.material[i] as usize];
                std::array::from_fn(|p| std::array::from_fn(|q| c[p][q] - cp[p][q]))
            })
            .collect();
        let disc = Discretisation { dim: particles.dim, bonds, grad_stiffness, volume: particles.volume.clone() };
        let mut s = Self {
            disc,
            materials,
            dt: 0.0,
            explicit_limit: 0.0,
            time: 0.0,
            step_count: 0,
            last: StepStats::default(),
            cg_tally: CgTally::default(),
            timings: Vec::new(),
            rot: vec![DMat3::IDENTITY; n],
            stress: StressField::new(n),
            forces: ForceField::new(n),
            contacts: Contacts::default(),
            total_force: vec![DVec3::ZERO; n],
            total_torque: vec![DVec3::ZERO; n],
            precond: None,
            patches: None,
            coarse: None,
            jinv: vec![DMat3::ZERO; n],
            particles,
            options,
        };
        s.explicit_limit = stable_time_step(&s.disc, &s.particles, s.options.contact.as_ref());
        // +∞ is right for a body with no free particle (all clamped or moved as prescribed)
        let free = s.particles.fixed.iter().any(|f| !f);
        if !(s.explicit_limit > 0.0) || s.explicit_limit.is_infinite() && free {
            return err(
                "solid.materials",
                format!(
                    "the explicit stability limit {:e} is not a positive finite time: a modulus, density or viscosity is too small or too large for the spacing {}",
                    s.explicit_limit, s.particles.spacing
                ),
            );
        }
        s.dt = match s.options.time_step {
            Some(dt) => {
                if !(dt.is_finite() && dt > 0.0) {
                    return err("solid.time_step", format!("must be finite and > 0, got {dt}"));
                }
                if s.options.integrator == Integrator::Explicit && dt > s.explicit_limit {
                    return err(
                        "solid.time_step",
                        format!("{dt:.3e} exceeds the explicit stability limit {:.3e} (use a smaller step or the implicit integrator)", s.explicit_limit),
                    );
                }
                dt
            }
            None => s.options.safety * s.explicit_limit,
        };
        s.timings = s.stage_list().iter().map(|st| (*st, Duration::ZERO)).collect();
        Ok(s)
    }

    pub fn stage_list(&self) -> &'static [SolidStage] {
        match self.options.integrator {
            Integrator::Explicit => &SOLID_EXPLICIT_STEP,
            Integrator::Implicit => &SOLID_IMPLICIT_STEP,
        }
    }

    /// Rotation matrices of the particles (as of the last `Rotations` stage).
    pub fn rotations(&self) -> &[DMat3] {
        &self.rot
    }

    pub fn stress(&self) -> &StressField {
        &self.stress
    }

    /// The bonds' forces on each particle (with the implicit step's rotation chain) of the
    /// last `BondForces` stage: what the `Contact` stage adds the loads, gravity and contact to.
    pub fn internal_force(&self) -> &[DVec3] {
        &self.forces.force
    }

    /// Net force (internal + contact + external) of the last evaluation (after its `Contact`
    /// stage).
    pub fn net_force(&self) -> &[DVec3] {
        &self.total_force
    }

    pub fn net_torque(&self) -> &[DVec3] {
        &self.total_torque
    }

    /// Sets the added mass M_a of every particle (kg, or kg/m in 2D; seed 2.129: the fluid's
    /// share of the inertia in the velocity update, [`crate::coupling`] method 2). The implicit
    /// preconditioner, whose diagonal holds M + M_a, is rebuilt on its next use.
    pub fn set_added_mass(&mut self, added_mass: Vec<f64>) {
        assert_eq!(added_mass.len(), self.particles.len(), "one added mass per particle");
        self.particles.added_mass = added_mass;
        self.precond = None;
        self.patches = None;
        self.coarse = None;
    }

    /// The implicit method's preconditioner (built on first use).
    pub fn preconditioner(&mut self) -> &BlockJacobi {
        if self.precond.is_none() {
            self.precond = Some(BlockJacobi::new(&self.disc, &self.particles, self.dt));
        }
        self.precond.as_ref().unwrap()
    }

    /// The patch smoother for the current Δt (built on first use, without the coarse space:
    /// [`crate::solid::Preconditioner::Patches`], which the GPU's implicit solve applies too).
    pub fn patch_smoother(&mut self) -> &PatchJacobi {
        if self.patches.is_none() {
            self.patches = Some(PatchJacobi::new(&self.disc, &self.particles, self.dt));
        }
        self.patches.as_ref().unwrap()
    }

    /// The patch smoother if it is built ([`Self::patch_smoother`] builds it), borrowed
    /// without borrowing the solver mutably.
    pub fn built_patch_smoother(&self) -> Option<&PatchJacobi> {
        self.patches.as_ref()
    }

    /// J_i⁻¹ of (2.74) from the last implicit `Rotations` stage.
    pub fn rotation_jacobian_inverses(&self) -> &[DMat3] {
        &self.jinv
    }

    /// Runs one stage alone (for kernel-by-kernel parity tests).
    pub fn run_single_stage(&mut self, kind: SolidStageKind) {
        self.run_stage(kind);
    }

    pub fn contacts(&self) -> &Contacts {
        &self.contacts
    }

    /// Evaluates the forces of the current state without advancing (for diagnostics/tests).
    pub fn evaluate_forces(&mut self) {
        for st in self.stage_list().iter().filter(|s| s.kind != SolidStageKind::Integrate && s.kind != SolidStageKind::ConjugateGradient) {
            self.run_stage(st.kind);
        }
    }

    /// Advances one step; stops with the diagnosis when a particle's position or velocity is
    /// no longer finite (the usual cause: a time step above the explicit limit).
    pub fn step(&mut self) -> Result<(), Instability> {
        // The whole step on one of rayon's workers: each kernel's parallel loop then starts from
        // inside the pool instead of being injected into it from outside and waited for (tens
        // of µs each, which dominated the steps of bodies of a few hundred particles).
        rayon::scope(|_| self.step_in_pool())
    }

    fn step_in_pool(&mut self) -> Result<(), Instability> {
        for k in 0..self.timings.len() {
            let st = self.timings[k].0;
            let t0 = Instant::now();
            self.run_stage(st.kind);
            self.timings[k].1 += t0.elapsed();
        }
        self.time += self.dt;
        self.step_count += 1;
        match self.non_finite() {
            None => Ok(()),
            Some(i) => Err(self.instability_at(i)),
        }
    }

    /// The diagnosis of a particle whose state is not finite.
    pub fn instability_at(&self, i: usize) -> Instability {
        let x = self.particles.reference[i];
        let v = self.particles.velocity[i];
        Instability {
            part: Part::Solid,
            step: self.step_count,
            time: self.time,
            time_unit: "s",
            site: Site::Particle(i),
            quantity: if v.is_finite() { "position" } else { "velocity" },
            value: if v.is_finite() { self.particles.position[i].length() } else { v.length() },
            reason: format!(
                "not finite; the particle's reference position is [{:.4e}, {:.4e}, {:.4e}]; Δt = {:.3e} against the explicit limit {:.3e}",
                x.x, x.y, x.z, self.dt, self.explicit_limit
            ),
        }
    }

    fn run_stage(&mut self, kind: SolidStageKind) {
        let implicit = self.options.integrator == Integrator::Implicit;
        let p = &mut self.particles;
        match kind {
            SolidStageKind::Rotations => {
                if implicit {
                    let (b, dim) = (&self.disc.bonds, p.dim);
                    self.last.newton_iterations =
                        solve_all_rotations(b, &p.position, &mut p.rotation, &mut self.jinv, &p.fixed, dim, self.options.rotation_tolerance);
                    let (x, v) = (&p.position, &p.velocity);
                    p.spin.par_iter_mut().enumerate().for_each(|(i, w)| *w = solve_angular_velocity(b, i, x, v, dim));
                }
                self.rot.par_iter_mut().zip(&p.rotation).for_each(|(r, q)| *r = DMat3::from_quat(*q));
            }
            SolidStageKind::StrainStress => strain_stress(&self.disc, &p.position, &self.rot, Mode::Full, &mut self.stress),
            SolidStageKind::BondForces => {
                bond_forces(&self.disc, &p.position, &p.velocity, Some(&p.spin), &self.rot, &self.stress, Mode::Full, None, &mut self.forces);
                if implicit {
                    // rotations slaved to positions (2.74): torques become forces
                    rotation_chain(&self.disc, &self.rot, &self.jinv, &self.forces.torque, &mut self.forces.force);
                }
            }
            SolidStageKind::Contact => {
                // the totals start from the bond forces and torques (the same sums as copying
                // them and adding the loads: f + (load + m g))
                let g = self.options.gravity;
                let (load, mass, internal) = (&p.load, &p.mass, &self.forces);
                (self.total_force.par_iter_mut(), self.total_torque.par_iter_mut()).into_par_iter().enumerate().for_each(|(i, (f, t))| {
                    *f = internal.force[i] + (load[i] + mass[i] * g);
                    *t = internal.torque[i];
                });
                if let Some(cp) = &self.options.contact {
                    let inp = ContactInput { x: &p.position, v: &p.velocity, rot: &self.rot, body: &p.body, fixed: &p.fixed, diameter: p.spacing };
                    self.contacts.apply(cp, &self.options.walls, &inp, &mut self.total_force, &mut self.total_torque);
                }
            }
            SolidStageKind::ConjugateGradient => self.implicit_solve(),
            SolidStageKind::Integrate => {
                let dt = self.dt;
                let (f, t) = (&self.total_force, &self.total_torque);
                let p = &mut self.particles;
                let Particles { position, velocity, rotation, spin, mass, added_mass, inertia, fixed, .. } = p;
                (position.par_iter_mut(), velocity.par_iter_mut(), rotation.par_iter_mut(), spin.par_iter_mut()).into_par_iter().enumerate().for_each(
                    |(i, (x, v, q, w))| {
                        if fixed[i] {
                            *v = DVec3::ZERO;
                            *w = DVec3::ZERO;
                            return;
                        }
                        if !implicit {
                            // (2.44)–(2.45), (2.52)–(2.56); with the fluid's added mass M_a of a
                            // momentum-conserving coupling, (M + M_a) ΔV = Δt f is (2.129)
                            // written for an explicit step (zero otherwise)
                            *v += dt * f[i] / (mass[i] + added_mass[i]);
                            *w += dt * t[i] / inertia[i];
                            *q = advance_quaternion(*q, *w, dt);
                        }
                        // implicit: v already holds vⁿ + ΔV (2.57)
                        *x += dt * *v;
                    },
                );
            }
        }
    }

    /// A ΔV = B with A = (M + M_a) − Δt ∂f/∂v − Δt² ∂f/∂x and B = Δt (f + Δt ∂f/∂x v),
    /// seed (2.63)–(2.66), matrix-free with the linear mode of the force kernels; the added mass
    /// M_a is the hook for the momentum-conserving coupling (2.129). Contact, loads and gravity
    /// enter B explicitly.
    fn implicit_solve(&mut self) {
        let n = self.particles.len();
        let dt = self.dt;
        self.prepare_preconditioner();
        let p = &self.particles;
        let mut op = LinearOperator::new(&self.disc, &self.rot, &self.jinv);
        // B = Δt (f + Δt K v)
        let zero = vec![DVec3::ZERO; n];
        let kv = op.forces(&p.velocity, &zero);
        let rhs: Vec<DVec3> = (0..n).map(|i| if p.fixed[i] { DVec3::ZERO } else { dt * (self.total_force[i] + dt * kv[i]) }).collect();
        let mass: Vec<f64> = (0..n).map(|i| p.mass[i] + p.added_mass[i]).collect();
        let fixed = &p.fixed;
        // the smoother the options name (both may be built: the GPU backend asks for block
        // Jacobi's blocks whatever the CPU uses)
        let (preconditioner, bj, patches, coarse) =
            (self.options.preconditioner, self.precond.as_ref(), self.patches.as_ref(), self.coarse.as_ref().and_then(|c| c.as_ref()));
        let precondition = |r: &[DVec3], z: &mut [DVec3]| {
            match preconditioner {
                Preconditioner::Patches => patches.expect("prepare_preconditioner builds the patches").apply(r, z),
                Preconditioner::BlockJacobi => bj.expect("prepare_preconditioner builds block Jacobi").apply(r, z),
            }
            if let Some(c) = coarse {
                c.add_correction(r, z);
            }
        };
        let mut dv = vec![DVec3::ZERO; n];
        let report = conjugate_gradient(
            |x, out| op.apply(x, out, &mass, fixed, dt),
            precondition,
            &rhs,
            &mut dv,
            fixed,
            self.options.cg_tolerance,
            self.options.cg_max_iterations,
            coarse.is_some_and(CoarseSpace::is_inexact),
        );
        self.last.cg = report;
        self.cg_tally.add(report.iterations, report.relative_residual, report.converged);
        let p = &mut self.particles;
        p.velocity.par_iter_mut().zip(&dv).for_each(|(v, d)| *v += *d);
    }

    /// Builds the implicit step's preconditioner (the smoother of
    /// [`SolidOptions::preconditioner`] and the coarse space) for the current Δt if it is not
    /// built yet; the first implicit step does it otherwise. A benchmark calls it to keep the
    /// one-off setup out of the per-step cost.
    pub fn prepare_preconditioner(&mut self) {
        match self.options.preconditioner {
            Preconditioner::Patches if self.patches.is_none() => self.patches = Some(PatchJacobi::new(&self.disc, &self.particles, self.dt)),
            Preconditioner::BlockJacobi if self.precond.is_none() => self.precond = Some(BlockJacobi::new(&self.disc, &self.particles, self.dt)),
            _ => {}
        }
        if self.coarse.is_none() {
            self.coarse = Some(self.reference_coarse_space());
        }
    }

    /// The preconditioner's coarse space ([`super::coarse`]), probed on the operator at the
    /// reference configuration (rotations I), like the block-Jacobi part: it depends on the scene
    /// only, so a run resumed from a checkpoint builds the same one. `None` for periodic solids
    /// (the probing assumes no aggregate reaches around a period) and when A_c cannot be
    /// factorised; block Jacobi alone then.
    fn reference_coarse_space(&self) -> Option<CoarseSpace> {
        self.probe_coarse_space(None)
    }

    /// [`Self::reference_coarse_space`] with the aggregates' side (length) and A_c's storage
    /// (sparse or dense) given instead of chosen by [`CoarseSpace::build`].
    fn probe_coarse_space(&self, layout: Option<(f64, bool)>) -> Option<CoarseSpace> {
        if self.options.periods.iter().any(Option::is_some) {
            return None;
        }
        let p = &self.particles;
        let n = p.len();
        let rot = vec![DMat3::IDENTITY; n];
        let mut q = vec![glam::DQuat::IDENTITY; n];
        let mut jinv = vec![DMat3::ZERO; n];
        solve_all_rotations(&self.disc.bonds, &p.reference, &mut q, &mut jinv, &p.fixed, p.dim, self.options.rotation_tolerance);
        let mass: Vec<f64> = (0..n).map(|i| p.mass[i] + p.added_mass[i]).collect();
        let mut op = LinearOperator::new(&self.disc, &rot, &jinv);
        // A reaches 3 r_e: the slaved rotations (2.74) carry a particle's push one bond beyond
        // the gradient model's two
        let reach = 3.0 * self.disc.bonds.radius * (1.0 + 1e-9);
        let apply = |x: &[DVec3], out: &mut [DVec3]| op.apply(x, out, &mass, &p.fixed, self.dt);
        match layout {
            None => CoarseSpace::build(&p.reference, &p.fixed, p.dim, p.spacing, reach, apply),
            Some((side, sparse)) => CoarseSpace::build_with(&p.reference, &p.fixed, p.dim, side, reach, sparse, apply),
        }
    }

    /// Builds the implicit preconditioner's coarse space with aggregates of side `side` (length)
    /// and A_c `sparse` (block-sparse with an inner solve) or dense, in place of the one
    /// [`CoarseSpace::build`] would choose: for studies of the preconditioner. False (and the
    /// smoother alone) when A_c is not positive definite or the solid is periodic.
    pub fn use_coarse_space(&mut self, side: f64, sparse: bool) -> bool {
        let c = self.probe_coarse_space(Some((side, sparse)));
        let built = c.is_some();
        self.coarse = Some(c);
        built
    }

    /// Leaves the implicit preconditioner's coarse space out (the smoother alone, on the CPU
    /// and on a device built from this solver) until the added mass changes: for studies of
    /// the preconditioner.
    pub fn drop_coarse_space(&mut self) {
        self.coarse = Some(None);
    }

    /// The implicit preconditioner's coarse space, once built.
    pub fn coarse_space(&self) -> Option<&CoarseSpace> {
        self.coarse.as_ref().and_then(|c| c.as_ref())
    }

    /// Energies of the current state (runs the force kernels on it).
    pub fn energies(&mut self) -> Energies {
        self.evaluate_forces();
        let p = &self.particles;
        let elastic: f64 = self.stress.energy.iter().sum::<f64>() + self.forces.energy.iter().sum::<f64>();
        let external: f64 = -(0..p.len()).map(|i| (p.load[i] + p.mass[i] * self.options.gravity).dot(p.position[i] - p.reference[i])).sum::<f64>();
        Energies { kinetic: p.kinetic_energy(), elastic, external }
    }

    /// Mean stage shares of the wall time so far.
    pub fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        crate::stages::time_shares(self.timings.iter().map(|(s, d)| (s.name, d)))
    }

    /// First particle whose state is not finite, if any.
    pub fn non_finite(&self) -> Option<usize> {
        let p = &self.particles;
        (0..p.len()).find(|&i| !(p.position[i].is_finite() && p.velocity[i].is_finite()))
    }
}

impl crate::step::Solver for SolidSolver {
    fn step(&mut self) -> Result<(), Instability> {
        SolidSolver::step(self)
    }
    fn step_count(&self) -> u64 {
        self.step_count
    }
    fn stage_shares(&self) -> Vec<(&'static str, f64)> {
        SolidSolver::stage_shares(self)
    }
}

#[cfg(test)]
#[path = "solver_tests.rs"]
mod tests;
