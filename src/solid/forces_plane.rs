//! The explicit step's force kernels in the plane: [`super::forces::strain_stress`] and
//! [`super::forces::bond_forces`] at `Mode::Full` for a 2D solid, on the in-plane components
//! alone.
//!
//! In 2D every position, velocity, bond vector r⁰_ij and gradient weight g_ij has a zero z
//! component, every rotation turns about z and every spin points along it (the bonds and the
//! orthotropic stiffness, aligned with the axes, couple no in-plane strain to an out-of-plane
//! stress). The general kernels then add exact zeros (±0) to every in-plane sum, and their
//! out-of-plane force and torque components are zeros. These kernels do the same in-plane
//! operations in the same order without the zeros: about 60 instead of 150 flops a bond in
//! `bond_forces` (the 2D glottis is compute-bound there) and about 120 instead of 310 in
//! `strain_stress`'s per-particle part, the same numbers (a zero's sign aside), and the same state
//! bit for bit (test below; the state hashes of the 2D scenes).

use super::forces::{Discretisation, ForceField, StressField};
use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// r_ij = x_j − x_i (+ the periodic shift) in the plane, as [`super::bonds::Bonds::current_vector`].
#[inline(always)]
fn in_plane_vector<const PERIODIC: bool>(d: &Discretisation, x: &[DVec3], i: usize, j: usize, k: usize) -> (f64, f64) {
    if PERIODIC {
        let s = d.bonds.shift[k];
        (x[j].x + s.x - x[i].x, x[j].y + s.y - x[i].y)
    } else {
        (x[j].x - x[i].x, x[j].y - x[i].y)
    }
}

/// `strain_stress` at `Mode::Full` in the plane: F_i = Σ_j r_ij ⊗ g_ij on its x–y block (the
/// rest of F is zero, F_zz = 1), then the per-particle part in the plane.
pub(super) fn strain_stress_plane<const PERIODIC: bool>(d: &Discretisation, x: &[DVec3], rot: &[DMat3], out: &mut StressField) {
    let b = &d.bonds;
    (out.q.par_iter_mut(), out.torque.par_iter_mut(), out.energy.par_iter_mut(), out.strain.par_iter_mut()).into_par_iter().enumerate().for_each(
        |(i, (q, tq, en, st))| {
            let (mut fxx, mut fxy, mut fyx, mut fyy) = (0.0, 0.0, 0.0, 0.0);
            for k in b.of(i) {
                let j = b.neighbour[k] as usize;
                let (rx, ry) = in_plane_vector::<PERIODIC>(d, x, i, j, k);
                let g = b.grad[k];
                // outer(r, g): column a is r g_a
                fxx += rx * g.x;
                fxy += ry * g.x;
                fyx += rx * g.y;
                fyy += ry * g.y;
            }
            particle_stress_plane(d, i, [fxx, fxy, fyx, fyy], &rot[i], (q, tq, en, st));
        },
    );
}

/// The per-particle part of `strain_stress` (the general kernel's at `Mode::Full`) for F with
/// its x–y block `f` (glam's column order: x_axis.x, x_axis.y, y_axis.x, y_axis.y), F_zz = 1 and
/// the rest zero, and R_i a rotation about z: the co-rotated strain ε = sym(Rᵀ F) − I (ε_zz and the
/// out-of-plane shears zero), σ = C' ε, Q_i = V R σ, τ = V axial(F σ Rᵀ) and the energy, each
/// entry the general kernel's sum of products in its order with the products by the zero
/// entries of F, R and ε left out: about 120 flops instead of 310, the same numbers (a zero's
/// sign aside). Q's and τ's out-of-plane entries are kept (σ_xz, σ_yz and σ_zz of a general C').
#[inline(always)]
fn particle_stress_plane(d: &Discretisation, i: usize, f: [f64; 4], r: &DMat3, (q, tq, en, st): (&mut DMat3, &mut DVec3, &mut f64, &mut [f64; 6])) {
    let [fxx, fxy, fyx, fyy] = f;
    let (rxx, rxy, ryx, ryy) = (r.x_axis.x, r.x_axis.y, r.y_axis.x, r.y_axis.y);
    // h = Rᵀ F − I on the x–y block (Rᵀ's columns are R's rows)
    let hxx = (rxx * fxx + rxy * fxy) - 1.0;
    let hxy = ryx * fxx + ryy * fxy;
    let hyx = rxx * fyx + rxy * fyy;
    let hyy = (ryx * fyx + ryy * fyy) - 1.0;
    // ε = ½(h + hᵀ) in Voigt form with engineering shear: the general kernel's ½(h_xx + h_xx)
    // is h_xx exactly, and its ε_xy and ε_yx are the same sum (addition commutes exactly)
    let exy = 0.5 * (hxy + hyx);
    let ev = [hxx, hyy, 0.0, 0.0, 0.0, exy + exy];
    let c = &d.grad_stiffness[i];
    let sv: [f64; 6] = std::array::from_fn(|p| (c[p][0] * ev[0] + c[p][1] * ev[1]) + c[p][5] * ev[5]);
    let v = d.volume[i];
    // Q = (V R) σ, σ's columns (s0, s5, s4), (s5, s1, s3), (s4, s3, s2)
    let (vxx, vxy, vyx, vyy) = (v * rxx, v * rxy, v * ryx, v * ryy);
    *q = DMat3::from_cols(
        DVec3::new(vxx * sv[0] + vyx * sv[5], vxy * sv[0] + vyy * sv[5], v * sv[4]),
        DVec3::new(vxx * sv[5] + vyx * sv[1], vxy * sv[5] + vyy * sv[1], v * sv[3]),
        DVec3::new(vxx * sv[4] + vyx * sv[3], vxy * sv[4] + vyy * sv[3], v * sv[2]),
    );
    // F σ (columns), then B = F σ Rᵀ: the entries the axial vector reads
    let fs_x = DVec3::new(fxx * sv[0] + fyx * sv[5], fxy * sv[0] + fyy * sv[5], sv[4]);
    let fs_y = DVec3::new(fxx * sv[5] + fyx * sv[1], fxy * sv[5] + fyy * sv[1], sv[3]);
    let (b_xy, b_yx) = (fs_x.y * rxx + fs_y.y * ryx, fs_x.x * rxy + fs_y.x * ryy);
    let (b_xz, b_yz) = (fs_x.z * rxx + fs_y.z * ryx, fs_x.z * rxy + fs_y.z * ryy);
    // B's z column is F σ's (Rᵀ's is e_z)
    let (b_zx, b_zy) = (fxx * sv[4] + fyx * sv[3], fxy * sv[4] + fyy * sv[3]);
    *tq = v * DVec3::new(b_zy - b_yz, b_xz - b_zx, b_yx - b_xy);
    *en = 0.5 * v * ((ev[0] * sv[0] + ev[1] * sv[1]) + ev[5] * sv[5]);
    *st = ev;
}

/// `bond_forces` at `Mode::Full` in the plane: the gradient-model pair forces, the pair
/// (Laplacian) force and torque on u_ij = r_ij − ½(R_i + R_j) r⁰_ij (2.38) and the viscous force
/// and torque on v_ij = v_j − v_i − ½(ω_i + ω_j) × r_ij (2.42–2.43), written as the general
/// kernel's products with the zero components left out; torques about z.
pub(super) fn bond_forces_plane<const PERIODIC: bool>(
    d: &Discretisation,
    x: &[DVec3],
    v: &[DVec3],
    spin: Option<&[DVec3]>,
    rot: &[DMat3],
    stress: &StressField,
    out: &mut ForceField,
) {
    let b = &d.bonds;
    let spin_z = |i: usize| spin.map_or(0.0, |s| s[i].z);
    (out.force.par_iter_mut(), out.torque.par_iter_mut(), out.energy.par_iter_mut()).into_par_iter().enumerate().for_each(|(i, (fo, to, en))| {
        let (mut fx, mut fy) = (0.0, 0.0);
        let t_gradient = stress.torque[i];
        let mut tz = t_gradient.z;
        let mut e = 0.0;
        let r_i = rot[i];
        let w_i = spin_z(i);
        let (mut gx, mut gy) = (0.0, 0.0);
        for k in b.of(i) {
            let j = b.neighbour[k] as usize;
            let r0 = b.r0[k];
            // gradient model: − Q_j g_ji
            let g = b.grad[k];
            gx += g.x;
            gy += g.y;
            let (q, gr) = (&stress.q[j], b.grad_reverse[k]);
            fx -= q.x_axis.x * gr.x + q.y_axis.x * gr.y;
            fy -= q.x_axis.y * gr.x + q.y_axis.y * gr.y;
            // pair (Laplacian) model (2.38): a = R r⁰
            let r_j = &rot[j];
            let (aix, aiy) = (r_i.x_axis.x * r0.x + r_i.y_axis.x * r0.y, r_i.x_axis.y * r0.x + r_i.y_axis.y * r0.y);
            let (ajx, ajy) = (r_j.x_axis.x * r0.x + r_j.y_axis.x * r0.y, r_j.x_axis.y * r0.x + r_j.y_axis.y * r0.y);
            let (rx, ry) = in_plane_vector::<PERIODIC>(d, x, i, j, k);
            let (ux, uy) = (rx - 0.5 * (aix + ajx), ry - 0.5 * (aiy + ajy));
            let kk = b.stiffness[k];
            fx += kk * ux;
            fy += kk * uy;
            tz += 0.5 * kk * (aix * uy - ux * aiy);
            e += 0.25 * kk * (ux * ux + uy * uy);
            // viscosity on the relative velocity without rigid rotation (2.42–2.43)
            let c = b.damping[k];
            if c != 0.0 {
                let w_bar = 0.5 * (w_i + spin_z(j));
                // w̄ × r = (0 − r_y w̄, w̄ r_x, 0) as the general kernel's cross product
                let vx = (v[j].x - v[i].x) - (0.0 - ry * w_bar);
                let vy = (v[j].y - v[i].y) - w_bar * rx;
                fx += c * vx;
                fy += c * vy;
                tz += 0.5 * c * (rx * vy - vx * ry);
            }
        }
        let q = &stress.q[i];
        *fo = DVec3::new(fx + (q.x_axis.x * gx + q.y_axis.x * gy), fy + (q.x_axis.y * gx + q.y_axis.y * gy), 0.0);
        *to = DVec3::new(t_gradient.x, t_gradient.y, tz);
        *en = e;
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash::mix32;
    use crate::solid::bench::benchmark_plate;
    use crate::solid::forces::{Mode, bond_forces, bond_forces_with, strain_stress, strain_stress_with};
    use crate::solid::particles::{Particles, sample_box};
    use crate::solid::{Integrator, Orthotropic, SolidOptions, SolidSolver};
    use glam::DQuat;

    /// A pseudo-random number in [−1, 1) from a counter.
    fn noise(k: u32) -> f64 {
        mix32(k) as f64 / 2f64.powi(31) - 1.0
    }

    /// The plane kernels (through the public `strain_stress` and `bond_forces`, which pick them
    /// for a 2D solid at `Mode::Full`) against the general kernels on a deformed, moving,
    /// spinning, rotated orthotropic viscous 2D plate clamped on an edge (the bench's), and on a
    /// 2D strip periodic in x: Q, the gradient torque, energy and strain, the forces, torques and pair
    /// energies equal as numbers (bits, a zero's sign aside: the general kernel adds ±0 where
    /// these leave a product out), the out-of-plane force and in-plane torque components zero.
    #[test]
    fn the_plane_kernels_give_the_general_kernels_numbers() {
        let mat = Orthotropic { young: [1.0e6, 3.0e6, 2.0e6], poisson: [0.2, 0.25, 0.3], shear: [4.0e5, 5.0e5, 6.0e5], density: 1.0, viscosity: 2.0 };
        let mut strip = Particles::new(2, 0.1);
        for x in sample_box(2, DVec3::ZERO, DVec3::new(0.8, 0.4, 0.0), 0.1) {
            strip.push(x, 1.0, 0, 0, false);
        }
        let bodies = [
            benchmark_plate(12, Integrator::Explicit),
            SolidSolver::new(strip, vec![mat], SolidOptions { periods: [Some(0.8), None, None], ..Default::default() }).unwrap(),
        ];
        assert!(!bodies[0].disc.bonds.periodic && bodies[1].disc.bonds.periodic);
        for (m, body) in bodies.iter().enumerate() {
            let (d, p) = (&body.disc, &body.particles);
            assert!(d.dim == 2 && d.bonds.damping.iter().all(|c| *c > 0.0));
            let n = p.len();
            let plane = |k: u32, scale: f64| DVec3::new(scale * noise(2 * k), scale * noise(2 * k + 1), 0.0);
            let x: Vec<DVec3> = (0..n).map(|i| p.reference[i] + plane(i as u32, 0.01)).collect();
            let v: Vec<DVec3> = (0..n).map(|i| plane(1_000_000 + i as u32, 0.3)).collect();
            let spin: Vec<DVec3> = (0..n).map(|i| DVec3::new(0.0, 0.0, 2.0 * noise(2_000_000 + i as u32))).collect();
            let rot: Vec<DMat3> = (0..n).map(|i| DMat3::from_quat(DQuat::from_rotation_z(0.05 * noise(3_000_000 + i as u32)))).collect();

            let (mut general, mut planar) = (StressField::new(n), StressField::new(n));
            if d.bonds.periodic {
                strain_stress_with::<true, false>(d, &x, &rot, Mode::Full, &mut general);
            } else {
                strain_stress_with::<false, false>(d, &x, &rot, Mode::Full, &mut general);
            }
            strain_stress(d, &x, &rot, Mode::Full, &mut planar);
            assert!(general.q.iter().zip(&planar.q).all(|(a, b)| a == b), "body {m}: Q");
            assert!(general.torque.iter().zip(&planar.torque).all(|(a, b)| a == b), "body {m}: gradient torque");
            assert!(general.energy.iter().zip(&planar.energy).all(|(a, b)| a == b), "body {m}: gradient energy");
            assert!(general.strain.iter().zip(&planar.strain).all(|(a, b)| a == b), "body {m}: strain");
            assert!(planar.torque.iter().any(|t| t.z != 0.0) && planar.q.iter().any(|q| q.z_axis.z != 0.0), "body {m}: a gradient torque and σ_zz");
            let strained = general.strain.iter().map(|e| e[0].abs().max(e[1].abs()).max(e[5].abs())).fold(0.0, f64::max);
            assert!(strained > 1e-3, "body {m} is strained: largest in-plane strain {strained}");

            let general_forces = |spin: Option<&[DVec3]>, out: &mut ForceField| {
                if d.bonds.periodic {
                    bond_forces_with::<true, false>(d, &x, &v, spin, &rot, &general, Mode::Full, None, out)
                } else {
                    bond_forces_with::<false, false>(d, &x, &v, spin, &rot, &general, Mode::Full, None, out)
                }
            };
            let (mut fg, mut fp) = (ForceField::new(n), ForceField::new(n));
            general_forces(Some(&spin), &mut fg);
            bond_forces(d, &x, &v, Some(&spin), &rot, &general, Mode::Full, None, &mut fp);
            assert!(fg.force.iter().zip(&fp.force).all(|(a, b)| a == b), "body {m}: forces");
            assert!(fg.torque.iter().zip(&fp.torque).all(|(a, b)| a == b), "body {m}: torques");
            assert!(fg.energy.iter().zip(&fp.energy).all(|(a, b)| a == b), "body {m}: pair energies");
            assert!(fp.force.iter().all(|f| f.z == 0.0) && fp.torque.iter().all(|t| t.x == 0.0 && t.y == 0.0), "body {m}: in the plane");
            let largest = fp.force.iter().map(|f| f.length()).fold(0.0, f64::max);
            let turning = fp.torque.iter().map(|t| t.z.abs()).fold(0.0, f64::max);
            assert!(largest > 10.0 && turning > 1e-3, "body {m} is loaded: largest force {largest}, torque {turning}");
            // without a spin field (ω = 0)
            general_forces(None, &mut fg);
            bond_forces(d, &x, &v, None, &rot, &general, Mode::Full, None, &mut fp);
            assert!(fg.force.iter().zip(&fp.force).all(|(a, b)| a == b) && fg.torque.iter().zip(&fp.torque).all(|(a, b)| a == b), "body {m}: no spin");
        }
    }
}
