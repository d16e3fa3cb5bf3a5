//! Particle rotations (seed 000 §2.2.3–2.2.5).

use super::bonds::Bonds;
use glam::{DMat3, DQuat, DVec3};
use rayon::prelude::*;

/// Explicit quaternion update, seed (2.53)–(2.56): the rotation by the angle Δt|ω| about
/// ω/|ω| composed (in the space frame) with the current rotation, then renormalised.
pub fn advance_quaternion(q: DQuat, omega: DVec3, dt: f64) -> DQuat {
    let angle = omega.length() * dt;
    if angle == 0.0 {
        return q;
    }
    let axis = omega / omega.length();
    let dq = DQuat::from_axis_angle(axis, angle);
    (dq * q).normalize()
}

/// Implicit rotation, seed (2.74)–(2.76): the rotation R_i that makes the weighted moment
/// Σ_j ŵ_ij r_ij × R_i r⁰_ij vanish (the rotation that best aligns the reference bonds with the
/// current ones), found by Newton–Raphson on a rotation-vector increment from the warm start
/// `q` (the previous step's rotation). Returns the rotation, the iterations used and J⁻¹ of
/// (2.74) at the solution, J = Σ_j ŵ [(r·a) I − a rᵀ] with a = R r⁰ (only zz in 2D): the
/// linearised rotation under position increments p is θ = J⁻¹ Σ_j ŵ a × (p_j − p_i).
pub fn solve_rotation(b: &Bonds, i: usize, x: &[DVec3], q: DQuat, dim: usize, tol: f64) -> (DQuat, u32, DMat3) {
    let mut q = q;
    let scale: f64 = b.of(i).map(|k| b.w_hat[k] * b.r0[k].length_squared()).sum::<f64>().max(1e-300);
    let mut last_jac = DMat3::ZERO;
    for it in 1..=60 {
        let r_m = DMat3::from_quat(q);
        let mut g = DVec3::ZERO;
        let mut jac = DMat3::ZERO;
        let mut align = 0.0;
        for k in b.of(i) {
            let j = b.neighbour[k] as usize;
            let r = x[j] + b.shift[k] - x[i];
            let a = r_m * b.r0[k];
            let w = b.w_hat[k];
            g += w * r.cross(a);
            align += w * r.dot(a);
            // d/dθ [r × (θ × a)] = (r·a) I − a rᵀ
            jac += w * (DMat3::from_diagonal(DVec3::splat(r.dot(a))) - super::bonds::outer(a, r));
        }
        if g.length() <= tol * scale {
            return (q, it, invert_jacobian(jac, dim));
        }
        // Far from the solution (the Jacobian is not that of a maximum) take the robust
        // fixed-point step of Müller et al. (2016), θ = −g / |Σ ŵ r·R r⁰|; near it, Newton.
        let newton = if dim == 2 {
            let jz = jac.z_axis.z;
            (jz > 0.5 * align.abs() && align > 0.0).then(|| DVec3::new(0.0, 0.0, -g.z / jz))
        } else {
            let sym = 0.5 * (jac + jac.transpose());
            let pd = sym.x_axis.x > 0.0
                && sym.x_axis.x * sym.y_axis.y - sym.x_axis.y * sym.y_axis.x > 0.0
                && sym.determinant() > 0.0
                && align > 0.0
                && g.length() < 0.1 * align;
            (pd && jac.determinant().abs() > 1e-14 * scale.powi(3)).then(|| -(jac.inverse() * g))
        };
        let delta = newton.unwrap_or_else(|| {
            let d = -g / (align.abs() + 1e-12 * scale);
            if dim == 2 { DVec3::new(0.0, 0.0, d.z) } else { d }
        });
        let ang = delta.length();
        if ang < 1e-15 {
            return (q, it, invert_jacobian(jac, dim));
        }
        q = (DQuat::from_axis_angle(delta / ang, ang.min(0.5)) * q).normalize();
        last_jac = jac;
    }
    (q, 60, invert_jacobian(last_jac, dim))
}

fn invert_jacobian(jac: DMat3, dim: usize) -> DMat3 {
    if dim == 2 {
        let mut m = DMat3::ZERO;
        if jac.z_axis.z.abs() > 0.0 {
            m.z_axis.z = 1.0 / jac.z_axis.z;
        }
        m
    } else if jac.determinant().abs() > 0.0 {
        jac.inverse()
    } else {
        DMat3::ZERO
    }
}

/// Angular velocity of the implicit method, seed (2.73): Σ_j ŵ r_ij × (v_j − v_i − ω × r_ij) = 0,
/// a 3×3 linear system per particle (only ω_z in 2D).
pub fn solve_angular_velocity(b: &Bonds, i: usize, x: &[DVec3], v: &[DVec3], dim: usize) -> DVec3 {
    let mut rhs = DVec3::ZERO;
    let mut a = DMat3::ZERO;
    for k in b.of(i) {
        let j = b.neighbour[k] as usize;
        let r = x[j] + b.shift[k] - x[i];
        let w = b.w_hat[k];
        rhs += w * r.cross(v[j] - v[i]);
        // r × (ω × r) = (r·r) ω − (r·ω) r
        a += w * (DMat3::from_diagonal(DVec3::splat(r.length_squared())) - super::bonds::outer(r, r));
    }
    if dim == 2 {
        if a.z_axis.z.abs() < 1e-300 {
            return DVec3::ZERO;
        }
        return DVec3::new(0.0, 0.0, rhs.z / a.z_axis.z);
    }
    if a.determinant().abs() < 1e-300 {
        return DVec3::ZERO;
    }
    a.inverse() * rhs
}

/// All rotations of the implicit method at once, with J⁻¹ of each (zero for clamped
/// particles); returns the largest Newton iteration count.
pub fn solve_all_rotations(b: &Bonds, x: &[DVec3], q: &mut [DQuat], jinv: &mut [DMat3], fixed: &[bool], dim: usize, tol: f64) -> u32 {
    q.par_iter_mut()
        .zip(jinv.par_iter_mut())
        .enumerate()
        .map(|(i, (qi, ji))| {
            if fixed[i] {
                *ji = DMat3::ZERO;
                return 0;
            }
            let (n, it, inv) = solve_rotation(b, i, x, *qi, dim, tol);
            *qi = n;
            *ji = inv;
            it
        })
        .max()
        .unwrap_or(0)
}
