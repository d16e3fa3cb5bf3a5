//! Preconditioned conjugate gradients for the implicit system A ΔV = B of seed 000
//! (2.63)–(2.66), matrix-free (the product A p is one evaluation of the linearised force
//! kernels, as §3.1.3 multiplies only over the neighbour lists), and the block-Jacobi
//! preconditioner (one 3×3 block per particle, with `preconditioner = "block_jacobi"` on
//! either backend; the default smoother is [`super::patch_jacobi`], on the CPU with the coarse
//! space, on the GPU without it).
//! Clamped particles are constrained to ΔV = 0.

use super::forces::Discretisation;
use super::material::mul6;
use super::particles::Particles;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use serde::Serialize;

#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct CgReport {
    pub iterations: usize,
    /// Final ‖r‖ / ‖B‖.
    pub relative_residual: f64,
    pub converged: bool,
}

/// The implicit solves of a run so far: how many, their CG iterations (sum and largest) and
/// how many stopped at the iteration limit short of the tolerance — what a coupled run reports
/// in `summary.json` (`solid_cg`) beside the per-row figures of its CSV.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct CgTally {
    pub solves: u64,
    pub iterations: u64,
    pub max_iterations: usize,
    pub unconverged: u64,
    /// The largest final ‖r‖ / ‖B‖ of any solve.
    pub worst_relative_residual: f64,
}

impl CgTally {
    /// Adds one solve.
    pub fn add(&mut self, iterations: usize, relative_residual: f64, converged: bool) {
        self.solves += 1;
        self.iterations += iterations as u64;
        self.max_iterations = self.max_iterations.max(iterations);
        self.unconverged += u64::from(!converged);
        // a NaN residual (a diverged solve) is the worst of all
        if !(relative_residual <= self.worst_relative_residual) {
            self.worst_relative_residual = relative_residual;
        }
    }

    /// Mean CG iterations per solve (0 before the first).
    pub fn mean_iterations(&self) -> f64 {
        if self.solves == 0 { 0.0 } else { self.iterations as f64 / self.solves as f64 }
    }
}

/// Inverse diagonal blocks of A = (M + M_a) − Δt D − Δt² K at the reference configuration
/// (rotations = I): the mass, the pair stiffness and damping Σ_j (Δt² k_ij + Δt c_ij), and the
/// gradient-model self-stiffness Σ_k V_k (∂ε_k/∂x_i)ᵀ C'_k (∂ε_k/∂x_i).
#[derive(Clone, Debug)]
pub struct BlockJacobi {
    inv: Vec<DMat3>,
}

impl BlockJacobi {
    pub fn new(d: &Discretisation, p: &Particles, dt: f64) -> Self {
        let b = &d.bonds;
        let n = p.len();
        // Gradient weights g_ki = ∂F_k/∂x_i direction: F_k changes by δx ⊗ g.
        let blocks: Vec<DMat3> = (0..n)
            .into_par_iter()
            .map(|i| {
                let mut kb = DMat3::ZERO;
                let mut add = |k: usize, g: DVec3| {
                    let c = &d.grad_stiffness[k];
                    let e = super::patch_jacobi::unit_strains(g);
                    for a in 0..3 {
                        let s = mul6(c, &e[a]);
                        for bb in 0..3 {
                            let v: f64 = s.iter().zip(&e[bb]).map(|(x, y)| x * y).sum();
                            kb.col_mut(bb)[a] += d.volume[k] * v;
                        }
                    }
                };
                let mut self_g = DVec3::ZERO;
                let mut pair = 0.0;
                let mut damp = 0.0;
                for k in b.of(i) {
                    let j = b.neighbour[k] as usize;
                    self_g -= b.grad[k];
                    add(j, b.grad[b.reverse[k] as usize]);
                    pair += b.stiffness[k];
                    damp += b.damping[k];
                }
                add(i, self_g);
                let m = p.mass[i] + p.added_mass[i];
                let a = DMat3::from_diagonal(DVec3::splat(m + dt * damp + dt * dt * pair)) + dt * dt * kb;
                if p.dim == 2 {
                    let mut a2 = a;
                    a2.z_axis = DVec3::new(0.0, 0.0, 1.0);
                    a2.x_axis.z = 0.0;
                    a2.y_axis.z = 0.0;
                    a2.inverse()
                } else {
                    a.inverse()
                }
            })
            .collect();
        Self { inv: blocks }
    }

    /// The inverse 3×3 blocks (uploaded by the GPU backend).
    pub fn blocks(&self) -> &[DMat3] {
        &self.inv
    }

    pub fn apply(&self, r: &[DVec3], z: &mut [DVec3]) {
        z.par_iter_mut().enumerate().for_each(|(i, zi)| *zi = self.inv[i] * r[i]);
    }
}

/// Σ a_i·b_i in a fixed order whatever the thread count: sequential partial sums over fixed
/// chunks, then their sum in chunk order (rayon's own `sum` splits where work is stolen, which
/// changes the last bits from run to run).
fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    const CHUNK: usize = 4096;
    let partial: Vec<f64> = a.par_chunks(CHUNK).zip(b.par_chunks(CHUNK)).map(|(x, y)| x.iter().zip(y).map(|(x, y)| x.dot(*y)).sum::<f64>()).collect();
    partial.iter().sum()
}

/// Solves A x = b (A symmetric positive definite, given as `apply(x, out)`, preconditioned by
/// the symmetric positive definite `precondition(r, z)`: z ≈ A⁻¹ r), starting from the content
/// of `x`; stops at ‖r‖ ≤ `tol` ‖b‖ or after `max_iter` iterations. `flexible` for a
/// preconditioner that varies slightly between applications (an inner iterative solve): β then
/// takes the Polak–Ribière form rᵢ₊₁·(zᵢ₊₁ − zᵢ) / rᵢ·zᵢ (Golub & Ye 1999, "Inexact
/// preconditioned conjugate gradient method with inner-outer iteration"), which equals the
/// standard rᵢ₊₁·zᵢ₊₁ / rᵢ·zᵢ for a fixed preconditioner.
#[allow(clippy::too_many_arguments)]
pub fn conjugate_gradient(
    mut apply: impl FnMut(&[DVec3], &mut [DVec3]),
    precondition: impl Fn(&[DVec3], &mut [DVec3]),
    b: &[DVec3],
    x: &mut [DVec3],
    fixed: &[bool],
    tol: f64,
    max_iter: usize,
    flexible: bool,
) -> CgReport {
    let n = b.len();
    let mut r = vec![DVec3::ZERO; n];
    let mut ap = vec![DVec3::ZERO; n];
    apply(x, &mut ap);
    r.par_iter_mut().enumerate().for_each(|(i, ri)| *ri = if fixed[i] { DVec3::ZERO } else { b[i] - ap[i] });
    let bnorm = dot(b, b).sqrt();
    if bnorm == 0.0 {
        x.iter_mut().for_each(|v| *v = DVec3::ZERO);
        return CgReport { iterations: 0, relative_residual: 0.0, converged: true };
    }
    let mut z = vec![DVec3::ZERO; n];
    precondition(&r, &mut z);
    mask(&mut z, fixed);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut rel = dot(&r, &r).sqrt() / bnorm;
    let mut it = 0;
    while rel > tol && it < max_iter {
        apply(&p, &mut ap);
        let pap = dot(&p, &ap);
        if pap <= 0.0 {
            break;
        }
        let alpha = rz / pap;
        x.par_iter_mut().zip(&p).for_each(|(xi, pi)| *xi += alpha * *pi);
        r.par_iter_mut().zip(&ap).for_each(|(ri, ai)| *ri -= alpha * *ai);
        let r_z_old = if flexible { dot(&r, &z) } else { 0.0 };
        precondition(&r, &mut z);
        mask(&mut z, fixed);
        let rz_new = dot(&r, &z);
        let beta = (rz_new - r_z_old) / rz;
        rz = rz_new;
        p.par_iter_mut().zip(&z).for_each(|(pi, zi)| *pi = *zi + beta * *pi);
        it += 1;
        rel = dot(&r, &r).sqrt() / bnorm;
    }
    CgReport { iterations: it, relative_residual: rel, converged: rel <= tol }
}

fn mask(v: &mut [DVec3], fixed: &[bool]) {
    v.par_iter_mut().enumerate().for_each(|(i, x)| {
        if fixed[i] {
            *x = DVec3::ZERO
        }
    });
}
