//! Internal forces and torques of the MPS solid — the CPU twins of the GPU kernels
//! `strain_stress` and `bond_forces`.
//!
//! The elastic energy is split as the seed's equation of motion (2.14) is: a pair
//! (Laplacian-model, 2.16) part that acts on the rotation-free relative displacement averaged
//! over the pair (2.38), u_ij = r_ij − ½(R_i + R_j) r⁰_ij, with energy ½ k_ij |u_ij|² per bond,
//! and a gradient-model (2.17) part that carries the rest of the orthotropic stiffness,
//! C' = C − C_pair (see [`super::bonds::pair_stiffness`]), through the renormalised gradient
//! F_i = Σ_j r_ij ⊗ g_ij, the co-rotated strain ε_i = sym(R_iᵀ F_i) − I and the energy
//! V_i ½ ε_i : C'_i : ε_i. F_i uses the second-order least-squares gradient weights g_ij
//! (exact for quadratic displacement fields, so that the strain of a bent beam is right also at
//! its surfaces; see [`super::bonds`]). Forces and torques are the exact derivatives of this
//! energy:
//!
//! * gradient part: f_i = Σ_j (Q_i g_ij − Q_j g_ji) with Q = V R σ, and a torque on the
//!   particle's rotation;
//! * pair part: f_i = Σ_j k_ij u_ij and the torque ½ k_ij R_i r⁰_ij × u_ij, which is seed (2.51).
//!
//! Because the energy is invariant under a rigid rotation of all positions and all particle
//! rotations, the torques cancel the moments of the pair forces (2.46–2.50): total (orbital +
//! spin) angular momentum is conserved exactly, and a rigidly rotated body feels no force.
//!
//! Viscosity (the η Δ ∂Ψ/∂t term of 2.15) uses the relative velocity with the rigid rotation
//! removed (2.42–2.43), symmetrised over the pair: v_ij = v_j − v_i − ½(ω_i + ω_j) × r_ij,
//! force c_ij v_ij and torque ½ c_ij r_ij × v_ij (a Rayleigh dissipation function).

use super::bonds::{Bonds, outer};
use super::forces_plane::{bond_forces_plane, strain_stress_plane};
use super::material::{Voigt6, from_voigt, mul6, to_voigt};
use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// Static per-particle data of the discretisation.
#[derive(Clone, Debug, Default)]
pub struct Discretisation {
    pub dim: usize,
    pub bonds: Bonds,
    /// Gradient-model stiffness C'_i = C − C_pair,i.
    pub grad_stiffness: Vec<Voigt6>,
    pub volume: Vec<f64>,
}

/// Evaluation mode of the force kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// The forces at positions x, velocities v (with the reference terms).
    Full,
    /// The linear part with the rotations frozen: the fields passed as positions and velocities
    /// are increments, the result is K p + D q (seed 2.61: ∂f/∂x p + ∂f/∂v q).
    Linear,
}

/// Per-particle output of `strain_stress`.
#[derive(Clone, Debug, Default)]
pub struct StressField {
    /// Q_i = V_i R_i σ_i (first Piola stress times volume).
    pub q: Vec<DMat3>,
    /// Torque of the gradient part on the particle's rotation.
    pub torque: Vec<DVec3>,
    /// Gradient-part energy V ½ ε:C':ε.
    pub energy: Vec<f64>,
    /// Co-rotated strain and the total stress C ε (Voigt), for output and tests.
    pub strain: Vec<[f64; 6]>,
}

impl StressField {
    pub fn new(n: usize) -> Self {
        Self { q: vec![DMat3::ZERO; n], torque: vec![DVec3::ZERO; n], energy: vec![0.0; n], strain: vec![[0.0; 6]; n] }
    }
}

/// Kernel 1, `strain_stress`: deformation gradient, co-rotated strain, gradient-model stress,
/// Q_i and the gradient-part torque of every particle. In the plane (`dim` 2) at `Mode::Full`,
/// the explicit step's case, it runs on the in-plane components alone (`solid/forces_plane.rs`:
/// the same numbers, a zero's sign aside, and the same state bits).
pub fn strain_stress(d: &Discretisation, x: &[DVec3], rot: &[DMat3], mode: Mode, out: &mut StressField) {
    match (d.dim == 2 && mode == Mode::Full, d.bonds.periodic) {
        (true, true) => strain_stress_plane::<true>(d, x, rot, out),
        (true, false) => strain_stress_plane::<false>(d, x, rot, out),
        (false, true) => strain_stress_with::<true, false>(d, x, rot, mode, out),
        (false, false) => strain_stress_with::<false, false>(d, x, rot, mode, out),
    }
}

/// [`strain_stress`] for bonds that do (`PERIODIC`) or do not cross a periodic face. With
/// `AT_REFERENCE` (see [`reference_stiffness_forces`]) every R_i is I without reading `rot`, and
/// only Q is written (the same operations, so the same bits as with identity rotations).
pub(super) fn strain_stress_with<const PERIODIC: bool, const AT_REFERENCE: bool>(
    d: &Discretisation,
    x: &[DVec3],
    rot: &[DMat3],
    mode: Mode,
    out: &mut StressField,
) {
    let b = &d.bonds;
    let plane = d.dim == 2;
    (out.q.par_iter_mut(), out.torque.par_iter_mut(), out.energy.par_iter_mut(), out.strain.par_iter_mut()).into_par_iter().enumerate().for_each(
        |(i, (q, tq, en, st))| {
            let mut f = DMat3::ZERO;
            for k in b.of(i) {
                let j = b.neighbour[k] as usize;
                let r = match mode {
                    Mode::Full => b.current_vector::<PERIODIC>(x, i, j, k),
                    Mode::Linear => x[j] - x[i],
                };
                f += outer(r, b.grad[k]);
            }
            if plane && mode == Mode::Full {
                f.z_axis.z = 1.0;
            }
            let r_i = if AT_REFERENCE { DMat3::IDENTITY } else { rot[i] };
            let mut h = r_i.transpose() * f;
            if mode == Mode::Full {
                h -= DMat3::IDENTITY;
            }
            let eps = 0.5 * (h + h.transpose());
            let ev = to_voigt(&eps);
            let sv = mul6(&d.grad_stiffness[i], &ev);
            let sigma = from_voigt(&sv);
            let v = d.volume[i];
            *q = v * r_i * sigma;
            if AT_REFERENCE {
                return;
            }
            // τ = V axial(B), B = F σ Rᵀ (derivative of the energy w.r.t. a rotation of R_i).
            let bm = f * sigma * r_i.transpose();
            // (In linear mode this torque is of second order at small strain and is dropped.)
            *tq =
                if mode == Mode::Full { v * DVec3::new(bm.z_axis.y - bm.y_axis.z, bm.x_axis.z - bm.z_axis.x, bm.y_axis.x - bm.x_axis.y) } else { DVec3::ZERO };
            *en = 0.5 * v * ev.iter().zip(&sv).map(|(a, b)| a * b).sum::<f64>();
            *st = ev;
        },
    );
}

/// Per-particle output of `bond_forces`.
#[derive(Clone, Debug, Default)]
pub struct ForceField {
    pub force: Vec<DVec3>,
    pub torque: Vec<DVec3>,
    /// Pair-part elastic energy (half of each bond's, so the sum over particles is the total).
    pub energy: Vec<f64>,
}

impl ForceField {
    pub fn new(n: usize) -> Self {
        Self { force: vec![DVec3::ZERO; n], torque: vec![DVec3::ZERO; n], energy: vec![0.0; n] }
    }
}

/// Linearised rotations that follow position (or velocity) increments in the implicit method:
/// θ_i = J_i⁻¹ Σ_j ŵ_ij (R_i r⁰_ij) × (p_j − p_i) (the derivative of the rotation defined by
/// (2.74); for velocities it is the angular velocity of (2.73) at the same geometry).
pub fn rotation_increments(d: &Discretisation, p: &[DVec3], rot: &[DMat3], jinv: &[DMat3], out: &mut [DVec3]) {
    let b = &d.bonds;
    out.par_iter_mut().enumerate().for_each(|(i, o)| {
        let mut s = DVec3::ZERO;
        for k in b.of(i) {
            let j = b.neighbour[k] as usize;
            s += b.w_hat[k] * (rot[i] * b.r0[k]).cross(p[j] - p[i]);
        }
        *o = jinv[i] * s;
    });
}

/// Chain rule of the implicit method: with the rotations slaved to the positions through
/// (2.74), the torques τ_i (= −∂E/∂θ_i) become forces f_m += Σ_i (∂θ_i/∂x_m)ᵀ τ_i, i.e. with
/// λ_i = J_i⁻ᵀ τ_i: f_m −= Σ_j ŵ_mj (λ_j × R_j r⁰_mj + λ_m × R_m r⁰_mj). This makes the
/// implicit forces the exact gradient of E(x, R(x)) and keeps their linearisation symmetric.
pub fn rotation_chain(d: &Discretisation, rot: &[DMat3], jinv: &[DMat3], torque: &[DVec3], force: &mut [DVec3]) {
    let b = &d.bonds;
    let lambda: Vec<DVec3> = torque.par_iter().zip(jinv).map(|(t, j)| j.transpose() * *t).collect();
    force.par_iter_mut().enumerate().for_each(|(m, f)| {
        let mut s = DVec3::ZERO;
        for k in b.of(m) {
            let j = b.neighbour[k] as usize;
            let r0 = b.r0[k];
            s += b.w_hat[k] * (lambda[j].cross(rot[j] * r0) + lambda[m].cross(rot[m] * r0));
        }
        *f -= s;
    });
}

/// Kernel 2, `bond_forces`: gathers, per particle, the gradient-model pair forces, the pair
/// (Laplacian) elastic force and torque and the viscous force and torque, and adds the
/// gradient-part torque from `stress`. `spin` is ω. In `Mode::Linear`, `follow` carries the
/// linearised rotations of the increments (θ for the position field, ω for the velocity
/// field) so that the rigid part of an increment is not penalised. In the plane (`dim` 2) at
/// `Mode::Full` the bond loop runs on the in-plane components alone (`solid/forces_plane.rs`:
/// the same forces, torques and energies as numbers).
#[allow(clippy::too_many_arguments)]
pub fn bond_forces(
    d: &Discretisation,
    x: &[DVec3],
    v: &[DVec3],
    spin: Option<&[DVec3]>,
    rot: &[DMat3],
    stress: &StressField,
    mode: Mode,
    follow: Option<(&[DVec3], &[DVec3])>,
    out: &mut ForceField,
) {
    match (d.dim == 2 && mode == Mode::Full, d.bonds.periodic) {
        (true, true) => bond_forces_plane::<true>(d, x, v, spin, rot, stress, out),
        (true, false) => bond_forces_plane::<false>(d, x, v, spin, rot, stress, out),
        (false, true) => bond_forces_with::<true, false>(d, x, v, spin, rot, stress, mode, follow, out),
        (false, false) => bond_forces_with::<false, false>(d, x, v, spin, rot, stress, mode, follow, out),
    }
}

/// The linearised internal forces −K x at the reference configuration for the displacement
/// increments `x` (dyn for x in cm): what [`strain_stress`] and [`bond_forces`] give in
/// [`Mode::Linear`] with every rotation the identity, no velocity, no spin and no followed
/// rotation — the same Q bits, the same forces (a zero's sign aside) and so the same stable step
/// to the bit (test `the_reference_stiffness_is_the_linear_kernels_at_identity_bit_for_bit`) —
/// without reading the rotations, the bond vectors r⁰ and the damping, and without the torques
/// and energies. The power iteration of [`super::timestep::stable_time_step`] applies it 60
/// times to every particle before a scene's first step. `stress.q` and `out.force` are written; the other
/// fields are left as they were.
pub fn reference_stiffness_forces(d: &Discretisation, x: &[DVec3], stress: &mut StressField, out: &mut ForceField) {
    let rot: &[DMat3] = &[];
    if d.bonds.periodic {
        strain_stress_with::<true, true>(d, x, rot, Mode::Linear, stress);
        bond_forces_with::<true, true>(d, x, &[], None, rot, stress, Mode::Linear, None, out)
    } else {
        strain_stress_with::<false, true>(d, x, rot, Mode::Linear, stress);
        bond_forces_with::<false, true>(d, x, &[], None, rot, stress, Mode::Linear, None, out)
    }
}

/// [`bond_forces`] for bonds that do (`PERIODIC`) or do not cross a periodic face; with
/// `AT_REFERENCE`, the force of [`Mode::Linear`] at identity rotations and rest alone (see
/// [`reference_stiffness_forces`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn bond_forces_with<const PERIODIC: bool, const AT_REFERENCE: bool>(
    d: &Discretisation,
    x: &[DVec3],
    v: &[DVec3],
    spin: Option<&[DVec3]>,
    rot: &[DMat3],
    stress: &StressField,
    mode: Mode,
    follow: Option<(&[DVec3], &[DVec3])>,
    out: &mut ForceField,
) {
    let b = &d.bonds;
    if AT_REFERENCE {
        // u_ij = x_j − x_i (R = I, no followed rotation); the torque, energy and damping
        // (zero velocity) terms of the loop below are left out
        out.force.par_iter_mut().enumerate().for_each(|(i, fo)| {
            let mut f = DVec3::ZERO;
            let mut g_sum = DVec3::ZERO;
            for k in b.of(i) {
                let j = b.neighbour[k] as usize;
                g_sum += b.grad[k];
                f -= stress.q[j] * b.grad_reverse[k];
                f += b.stiffness[k] * (x[j] - x[i]);
            }
            *fo = f + stress.q[i] * g_sum;
        });
        return;
    }
    (out.force.par_iter_mut(), out.torque.par_iter_mut(), out.energy.par_iter_mut()).into_par_iter().enumerate().for_each(|(i, (fo, to, en))| {
        let mut f = DVec3::ZERO;
        let mut t = stress.torque[i];
        let mut e = 0.0;
        let r_i = rot[i];
        let w_i = spin.map_or(DVec3::ZERO, |s| s[i]);
        // Σ_j g_ij: Q_i's part of the gradient-model force is Q_i Σ_j g_ij, one product
        let mut g_sum = DVec3::ZERO;
        for k in b.of(i) {
            let j = b.neighbour[k] as usize;
            let r0 = b.r0[k];
            // gradient model: −∂/∂x_i of Σ V ψ(F) through F_i (g_ij) and F_j (g_ji)
            g_sum += b.grad[k];
            f -= stress.q[j] * b.grad_reverse[k];
            // pair (Laplacian) model on the rotation-free relative displacement (2.38)
            let (a_i, a_j) = (r_i * r0, rot[j] * r0);
            let (r, u) = match mode {
                Mode::Full => {
                    let r = b.current_vector::<PERIODIC>(x, i, j, k);
                    (r, r - 0.5 * (a_i + a_j))
                }
                Mode::Linear => {
                    let p = x[j] - x[i];
                    let u = match follow {
                        Some((th, _)) => p - 0.5 * (th[i].cross(a_i) + th[j].cross(a_j)),
                        None => p,
                    };
                    (0.5 * (a_i + a_j), u)
                }
            };
            let kk = b.stiffness[k];
            f += kk * u;
            t += 0.5 * kk * a_i.cross(u);
            e += 0.25 * kk * u.length_squared();
            // viscosity on the relative velocity without rigid rotation (2.42–2.43)
            let c = b.damping[k];
            if c != 0.0 {
                let w_bar = match (mode, follow) {
                    (Mode::Linear, Some((_, om))) => 0.5 * (om[i] + om[j]),
                    _ => 0.5 * (w_i + spin.map_or(DVec3::ZERO, |s| s[j])),
                };
                let vij = v[j] - v[i] - w_bar.cross(r);
                f += c * vij;
                t += 0.5 * c * r.cross(vij);
            }
        }
        *fo = f + stress.q[i] * g_sum;
        *to = t;
        *en = e;
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash::mix32;
    use crate::solid::bench::benchmark_block;
    use crate::solid::particles::{Particles, sample_box};
    use crate::solid::{Integrator, Orthotropic, SolidOptions, SolidSolver};
    use glam::DQuat;

    /// A pseudo-random number in [−1, 1) from a counter.
    fn noise(k: u32) -> f64 {
        mix32(k) as f64 / 2f64.powi(31) - 1.0
    }

    fn noisy(k: u32, scale: f64) -> DVec3 {
        scale * DVec3::new(noise(3 * k), noise(3 * k + 1), noise(3 * k + 2))
    }

    /// Without periodic bonds the kernels take r_ij = x_j − x_i instead of x_j + shift − x_i
    /// (`Bonds::current_vector`): on a deformed, moving, rotated block both ways give every
    /// output bit for bit; and a body whose bonds wrap a periodic face is marked periodic, so
    /// that it reads its shifts.
    #[test]
    fn the_force_kernels_read_no_zero_shift_and_change_no_bit() {
        let s = benchmark_block(6, Integrator::Explicit);
        let d = &s.disc;
        assert!(!d.bonds.periodic && d.bonds.shift.iter().all(|s| *s == DVec3::ZERO));
        let n = s.particles.len();
        let x: Vec<DVec3> = (0..n).map(|i| s.particles.reference[i] + noisy(i as u32, 0.01)).collect();
        let v: Vec<DVec3> = (0..n).map(|i| noisy(1_000_000 + i as u32, 0.3)).collect();
        let spin: Vec<DVec3> = (0..n).map(|i| noisy(2_000_000 + i as u32, 2.0)).collect();
        let rot: Vec<DMat3> = (0..n).map(|i| DMat3::from_quat(DQuat::from_scaled_axis(noisy(3_000_000 + i as u32, 0.05)))).collect();
        let bits = |v: &[DVec3]| v.iter().flat_map(|p| p.to_array()).map(f64::to_bits).collect::<Vec<_>>();
        let mat_bits = |m: &[DMat3]| m.iter().flat_map(|m| m.to_cols_array()).map(f64::to_bits).collect::<Vec<_>>();
        let (mut a, mut b) = (StressField::new(n), StressField::new(n));
        strain_stress_with::<false, false>(d, &x, &rot, Mode::Full, &mut a);
        strain_stress_with::<true, false>(d, &x, &rot, Mode::Full, &mut b);
        assert_eq!(mat_bits(&a.q), mat_bits(&b.q));
        assert_eq!(bits(&a.torque), bits(&b.torque));
        assert!(a.energy.iter().zip(&b.energy).all(|(p, q)| p.to_bits() == q.to_bits()));
        let stressed = a.q.iter().map(|q| q.to_cols_array().iter().fold(0.0f64, |m, e| m.max(e.abs()))).fold(0.0, f64::max);
        assert!(stressed > 1.0, "the block is strained: largest |Q| {stressed}");
        let (mut fa, mut fb) = (ForceField::new(n), ForceField::new(n));
        bond_forces_with::<false, false>(d, &x, &v, Some(&spin), &rot, &a, Mode::Full, None, &mut fa);
        bond_forces_with::<true, false>(d, &x, &v, Some(&spin), &rot, &a, Mode::Full, None, &mut fb);
        assert_eq!(bits(&fa.force), bits(&fb.force));
        assert_eq!(bits(&fa.torque), bits(&fb.torque));
        assert!(fa.energy.iter().zip(&fb.energy).all(|(p, q)| p.to_bits() == q.to_bits()));
        let largest = fa.force.iter().map(|f| f.length()).fold(0.0, f64::max);
        assert!(largest > 1.0, "the block is loaded: largest force {largest}");

        // a slab periodic in x: the bonds across the face carry the period as their shift
        let m = Orthotropic::isotropic(1.0e6, 0.3, 1.0, 0.0);
        let mut p = Particles::new(3, 0.1);
        for x in sample_box(3, DVec3::ZERO, DVec3::new(0.8, 0.4, 0.4), 0.1) {
            p.push(x, 1.0, 0, 0, false);
        }
        let periodic = SolidSolver::new(p, vec![m], SolidOptions { periods: [Some(0.8), None, None], ..Default::default() }).unwrap();
        let wrapping = periodic.disc.bonds.shift.iter().filter(|s| s.x.abs() > 0.7).count();
        assert!(periodic.disc.bonds.periodic && wrapping > 0, "{wrapping} bonds wrap the face");
    }

    /// [`reference_stiffness_forces`] is what the general kernels give in `Mode::Linear` at
    /// identity rotations with no velocity: the same Q bit for bit and the same forces (as
    /// numbers: a zero may differ in sign, since the general kernel adds the damping's
    /// c·(0 − 0 − 0 × r) = ±0), on an orthotropic viscous 3D block with a clamped face, a 2D
    /// block and a periodic slab; and the power iteration of the stable step gives the same λ
    /// to the bit through either.
    #[test]
    fn the_reference_stiffness_is_the_linear_kernels_at_identity_bit_for_bit() {
        use crate::solid::timestep::largest_eigenvalue;
        let general = |d: &Discretisation, x: &[DVec3], s: &mut StressField, f: &mut ForceField| {
            let n = x.len();
            let rot = vec![DMat3::IDENTITY; n];
            strain_stress(d, x, &rot, Mode::Linear, s);
            bond_forces(d, x, &vec![DVec3::ZERO; n], None, &rot, s, Mode::Linear, None, f);
        };
        let mat = Orthotropic { young: [1.0e6, 3.0e6, 2.0e6], poisson: [0.2, 0.25, 0.3], shear: [4.0e5, 5.0e5, 6.0e5], density: 1.0, viscosity: 2.0 };
        let mut plane = Particles::new(2, 0.1);
        for x in sample_box(2, DVec3::ZERO, DVec3::new(1.2, 0.7, 0.0), 0.1) {
            plane.push(x, 1.0, 0, 0, x.y < 0.1);
        }
        let mut slab = Particles::new(3, 0.1);
        for x in sample_box(3, DVec3::ZERO, DVec3::new(0.8, 0.4, 0.4), 0.1) {
            slab.push(x, 1.0, 0, 0, false);
        }
        let bodies = [
            benchmark_block(6, Integrator::Explicit),
            SolidSolver::new(plane, vec![mat.clone()], SolidOptions::default()).unwrap(),
            SolidSolver::new(slab, vec![mat], SolidOptions { periods: [Some(0.8), None, None], ..Default::default() }).unwrap(),
        ];
        assert!(bodies[0].disc.bonds.damping.iter().all(|c| *c > 0.0) && bodies[2].disc.bonds.periodic);
        for (m, body) in bodies.iter().enumerate() {
            let (d, p) = (&body.disc, &body.particles);
            let n = p.len();
            let x: Vec<DVec3> =
                (0..n).map(|i| noisy(7 * n as u32 + i as u32, 0.01) * if p.dim == 2 { DVec3::new(1.0, 1.0, 0.0) } else { DVec3::ONE }).collect();
            let (mut sa, mut fa) = (StressField::new(n), ForceField::new(n));
            let (mut sb, mut fb) = (StressField::new(n), ForceField::new(n));
            general(d, &x, &mut sa, &mut fa);
            reference_stiffness_forces(d, &x, &mut sb, &mut fb);
            let q_bits = |s: &StressField| s.q.iter().flat_map(|q| q.to_cols_array()).map(f64::to_bits).collect::<Vec<_>>();
            assert_eq!(q_bits(&sa), q_bits(&sb), "body {m}: Q");
            assert!(fa.force.iter().zip(&fb.force).all(|(a, b)| a == b), "body {m}: forces");
            let largest = fa.force.iter().map(|f| f.length()).fold(0.0, f64::max);
            assert!(largest > 10.0, "body {m} is loaded: largest force {largest}");
            let lambda_general = largest_eigenvalue(p, |x, f| general(d, x, &mut sa, f));
            let lambda_reference = largest_eigenvalue(p, |x, f| reference_stiffness_forces(d, x, &mut sb, f));
            assert!(lambda_general > 0.0 && lambda_general.to_bits() == lambda_reference.to_bits(), "body {m}: λ {lambda_general:e} vs {lambda_reference:e}");
        }
    }
}
