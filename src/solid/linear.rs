//! The implicit step's linear operator, seed (2.63)–(2.66): A x = (M + M_a) x − Δt D x − Δt² K x
//! with the rotations slaved to the increments (θ(p), ω(q) from (2.74)/(2.73)), evaluated
//! matrix-free by the force kernels' linear mode at a given configuration (rotations R_i and
//! the Jacobians J_i⁻¹ of (2.74)). Units: x a velocity increment (m/s), A x a momentum (kg·m/s,
//! per unit depth in 2D).

use super::forces::{Discretisation, ForceField, Mode, StressField, bond_forces, rotation_chain, rotation_increments, strain_stress};
use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// The operator at one configuration, with its work arrays.
pub(super) struct LinearOperator<'a> {
    disc: &'a Discretisation,
    rot: &'a [DMat3],
    jinv: &'a [DMat3],
    stress: StressField,
    force: ForceField,
    th_x: Vec<DVec3>,
    th_v: Vec<DVec3>,
    q: Vec<DVec3>,
}

impl<'a> LinearOperator<'a> {
    pub(super) fn new(disc: &'a Discretisation, rot: &'a [DMat3], jinv: &'a [DMat3]) -> Self {
        let n = rot.len();
        Self {
            disc,
            rot,
            jinv,
            stress: StressField::new(n),
            force: ForceField::new(n),
            th_x: vec![DVec3::ZERO; n],
            th_v: vec![DVec3::ZERO; n],
            q: vec![DVec3::ZERO; n],
        }
    }

    /// K x + D v: the forces of position increments x and velocity increments v.
    pub(super) fn forces(&mut self, x: &[DVec3], v: &[DVec3]) -> &[DVec3] {
        self.forces_of(x, v, None)
    }

    /// [`Self::forces`]; `v_over_x = Some(s)` says that v = s·x, so that the rotations following
    /// v are s times those following x (the map (2.74) is linear in the increments) and are not
    /// computed a second time.
    fn forces_of(&mut self, x: &[DVec3], v: &[DVec3], v_over_x: Option<f64>) -> &[DVec3] {
        let (disc, rot, jinv) = (self.disc, self.rot, self.jinv);
        strain_stress(disc, x, rot, Mode::Linear, &mut self.stress);
        rotation_increments(disc, x, rot, jinv, &mut self.th_x);
        match v_over_x {
            Some(s) => self.th_v.par_iter_mut().zip(&self.th_x).for_each(|(tv, tx)| *tv = *tx * s),
            None => rotation_increments(disc, v, rot, jinv, &mut self.th_v),
        }
        bond_forces(disc, x, v, None, rot, &self.stress, Mode::Linear, Some((&self.th_x, &self.th_v)), &mut self.force);
        rotation_chain(disc, rot, jinv, &self.force.torque, &mut self.force.force);
        &self.force.force
    }

    /// out = A x for velocity increments x over a step `dt` (positions move by x·Δt):
    /// (M + M_a) x − Δt² (K x + D x/Δt), zero on clamped particles. `mass` is M + M_a.
    pub(super) fn apply(&mut self, x: &[DVec3], out: &mut [DVec3], mass: &[f64], fixed: &[bool], dt: f64) {
        let mut q = std::mem::take(&mut self.q);
        let inv_dt = 1.0 / dt;
        q.par_iter_mut().zip(x).for_each(|(qi, xi)| *qi = *xi * inv_dt);
        let f = self.forces_of(x, &q, Some(inv_dt));
        out.par_iter_mut().enumerate().for_each(|(i, o)| *o = if fixed[i] { DVec3::ZERO } else { mass[i] * x[i] - dt * dt * f[i] });
        self.q = q;
    }
}
