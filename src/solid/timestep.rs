//! Explicit stability limit of the solid. For a mode of angular frequency ω and damping rate
//! γ (= c/m), the symplectic Euler step of (2.44)–(2.45) is stable iff ω²Δt² + 2γΔt ≤ 4.
//! ω_max² is estimated by power iteration on M⁻¹K (matrix-free, the linearised force kernels
//! at the reference configuration), plus bounds for the particle rotations (pair torques on
//! I = m l₀²/6) and the contact springs; γ_max by Gershgorin on the pair damping.

use super::contact::ContactParams;
use super::forces::{Discretisation, ForceField, StressField, reference_stiffness_forces};
use super::particles::Particles;
use glam::DVec3;
use rayon::prelude::*;

/// Largest stable explicit step (no safety factor).
pub fn stable_time_step(d: &Discretisation, p: &Particles, contact: Option<&ContactParams>) -> f64 {
    let mut s = StressField::new(p.len());
    let lambda = largest_eigenvalue(p, |x, f| reference_stiffness_forces(d, x, &mut s, f));
    stable_step_from(d, p, contact, lambda)
}

/// λ_max of M⁻¹K by 60 power iterations from a deterministic pseudo-random start (Rayleigh
/// quotients in the mass inner product; clamped particles held at zero). `stiffness_forces(x,
/// out)` writes into `out.force` the linearised internal forces −K x (dyn) of the
/// displacements x (cm). The iterates live in two buffers made once (the 3D glottis's are
/// 16 MB each); the sums run in particle order.
pub(crate) fn largest_eigenvalue(p: &Particles, mut stiffness_forces: impl FnMut(&[DVec3], &mut ForceField)) -> f64 {
    let n = p.len();
    let mut f = ForceField::new(n);
    // Deterministic pseudo-random start.
    let mut x: Vec<DVec3> = (0..n)
        .map(|i| {
            let h = |k: u64| (((i as u64).wrapping_mul(6364136223846793005).wrapping_add(k * 1442695040888963407) >> 33) as f64 / (1u64 << 31) as f64) - 0.5;
            if p.fixed[i] { DVec3::ZERO } else { DVec3::new(h(1), h(2), if p.dim == 3 { h(3) } else { 0.0 }) }
        })
        .collect();
    let mut y = vec![DVec3::ZERO; n];
    let mut lambda = 0.0;
    for _ in 0..60 {
        stiffness_forces(&x, &mut f);
        y.par_iter_mut().enumerate().with_min_len(4096).for_each(|(i, y)| *y = if p.fixed[i] { DVec3::ZERO } else { -f.force[i] / p.mass[i] });
        let num: f64 = (0..n).map(|i| p.mass[i] * x[i].dot(y[i])).sum();
        let den: f64 = (0..n).map(|i| p.mass[i] * x[i].length_squared()).sum();
        if den == 0.0 {
            break;
        }
        lambda = num / den;
        let norm = (0..n).map(|i| p.mass[i] * y[i].length_squared()).sum::<f64>().sqrt();
        if norm == 0.0 {
            break;
        }
        x.par_iter_mut().zip(&y).with_min_len(4096).for_each(|(x, y)| *x = *y / norm);
    }
    lambda
}

/// The stable step from λ_max of M⁻¹K, the rotations' and contacts' bounds and the damping.
fn stable_step_from(d: &Discretisation, p: &Particles, contact: Option<&ContactParams>, lambda: f64) -> f64 {
    let n = p.len();
    let b = &d.bonds;
    // Power iteration converges from below: 15 % margin.
    let mut omega2 = 1.15 * lambda.max(0.0);
    let mut gamma: f64 = 0.0;
    for i in 0..n {
        if p.fixed[i] {
            continue;
        }
        let (mut krot, mut c, mut crot) = (0.0, 0.0, 0.0);
        for k in b.of(i) {
            let r2 = b.r0[k].length_squared();
            krot += 0.5 * b.stiffness[k] * r2;
            c += 2.0 * b.damping[k];
            crot += 0.5 * b.damping[k] * r2;
        }
        omega2 = omega2.max(krot / p.inertia[i]);
        gamma = gamma.max(c / p.mass[i]).max(crot / p.inertia[i]);
        if let Some(cp) = contact {
            // a particle may touch several others: allow 4 contacts' worth of stiffness
            omega2 = omega2.max(4.0 * cp.normal_stiffness.max(cp.tangential_stiffness) / p.mass[i]);
            gamma = gamma.max(4.0 * cp.damping / p.mass[i]);
        }
    }
    if omega2 == 0.0 {
        return if gamma > 0.0 { 2.0 / gamma } else { f64::INFINITY };
    }
    (-gamma + (gamma * gamma + 4.0 * omega2).sqrt()) / omega2
}
