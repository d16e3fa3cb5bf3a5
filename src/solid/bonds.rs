//! MPS neighbour lists with initial-configuration weights (seed 000 §2.2.1, Song et al.):
//! w(r) = r_e/r − 1 for r ≤ r_e (2.20), the particle-number density n⁰ (2.21), κ (2.19), and
//! per particle the renormalisation L_i = (Σ_j ŵ_ij r⁰_ij ⊗ r⁰_ij)⁻¹ with ŵ = w/|r⁰|² that makes
//! the gradient model (2.17) exact for linear fields also where the neighbourhood is cut by a
//! free surface (in a full neighbourhood L_i = d/n⁰ I and the model is (2.17) itself).
//!
//! Each particle stores its own bonds (CSR, both directions), so the force kernels gather
//! without atomics on the CPU and the GPU. Bonds never change (solids use the initial
//! configuration); periodic images are stored as a shift added to x_j.
//!
//! The force kernels stream the bond arrays each step, so what they read per bond weighs
//! (see `bench.rs`). In a body none of whose bonds crosses a periodic face — every glottis,
//! flap and benchmark block — every shift is zero and r_ij = x_j − x_i, so `strain_stress` and
//! `bond_forces` do not read `shift` there ([`Bonds::periodic`]: 24 of the 116 bytes
//! `bond_forces` reads per bond, 24 of `strain_stress`'s 52).

use super::grid::{Periods, SearchGrid};
use super::material::Voigt6;
use super::particles::Particles;
use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// Particles whose neighbour lists [`build`] holds at once (≈ 100 MB of lists in 3D).
const NEIGHBOUR_BLOCK: usize = 1 << 16;

#[derive(Clone, Debug, Default)]
pub struct Bonds {
    /// Influence radius r_e.
    pub radius: f64,
    /// Reference number density n⁰ and κ of a full neighbourhood (2.19, 2.21).
    pub n0: f64,
    pub kappa: f64,
    /// Bonds of particle i: `offset[i]..offset[i+1]`.
    pub offset: Vec<u32>,
    pub neighbour: Vec<u32>,
    /// r⁰_ij = X_j − X_i (minimum image).
    pub r0: Vec<DVec3>,
    /// Periodic image shift: r_ij = x_j + shift − x_i.
    pub shift: Vec<DVec3>,
    /// w(|r⁰|) of (2.20).
    pub w: Vec<f64>,
    /// ŵ = w / |r⁰|² (gradient-model weight).
    pub w_hat: Vec<f64>,
    /// Pair (Laplacian-model) stiffness k_ij and viscous coefficient c_ij (force / length,
    /// force × time / length).
    pub stiffness: Vec<f64>,
    pub damping: Vec<f64>,
    /// Gradient weight g_ij of the second-order (least-squares, LSMPS) gradient model:
    /// ∇φ_i = Σ_j (φ_j − φ_i) g_ij exactly for polynomials of degree ≤ 2.
    pub grad: Vec<DVec3>,
    /// Index of the reverse bond j → i.
    pub reverse: Vec<u32>,
    /// g_ji, the reverse bond's gradient weight, stored with bond i → j so that the force
    /// kernel reads it in order instead of through `reverse`.
    pub grad_reverse: Vec<DVec3>,
    /// Whether some bond crosses a periodic face (a nonzero `shift`); when none does, the
    /// kernels take r_ij = x_j − x_i without reading `shift` ([`Self::current_vector`]).
    pub periodic: bool,
}

impl Bonds {
    pub fn of(&self, i: usize) -> std::ops::Range<usize> {
        self.offset[i] as usize..self.offset[i + 1] as usize
    }

    pub fn len(&self) -> usize {
        self.neighbour.len()
    }

    pub fn is_empty(&self) -> bool {
        self.neighbour.is_empty()
    }

    /// r_ij = x_j + shift − x_i of bond k (i → j) at positions x, `PERIODIC` being
    /// [`Self::periodic`]; without periodic bonds x_j − x_i, the same value (adding a zero
    /// shift could change only the sign of a component of x_j that is −0, and so of an exact
    /// zero in r: the golden state hashes of `run::resume_tests` are unchanged).
    #[inline(always)]
    pub fn current_vector<const PERIODIC: bool>(&self, x: &[DVec3], i: usize, j: usize, k: usize) -> DVec3 {
        if PERIODIC { x[j] + self.shift[k] - x[i] } else { x[j] - x[i] }
    }
}

/// w(r) of (2.20).
pub fn weight(r: f64, re: f64) -> f64 {
    if r > 0.0 && r <= re { re / r - 1.0 } else { 0.0 }
}

/// n⁰ and κ of a complete lattice neighbourhood of spacing l₀ (the sampling's interior).
pub fn full_neighbourhood(dim: usize, spacing: f64, re: f64) -> (f64, f64) {
    let m = (re / spacing).ceil() as i64;
    let (mut n0, mut r2w) = (0.0, 0.0);
    for k in if dim == 3 { -m..=m } else { 0..=0 } {
        for j in -m..=m {
            for i in -m..=m {
                if (i, j, k) == (0, 0, 0) {
                    continue;
                }
                let r = spacing * ((i * i + j * j + k * k) as f64).sqrt();
                let w = weight(r, re);
                n0 += w;
                r2w += r * r * w;
            }
        }
    }
    (n0, r2w / n0)
}

/// Builds the bond lists of all particles from their reference positions with a uniform
/// search grid (O(N)). `pair_modulus[i]` is the modulus μ_p carried by the pair model at
/// particle i and `viscosity[i]` the η of its layer; a bond uses the smaller modulus of its two
/// ends and the mean viscosity.
pub fn build(p: &Particles, re: f64, periods: Periods, pair_modulus: &[f64], viscosity: &[f64]) -> Bonds {
    let n = p.len();
    let d = p.dim as f64;
    let (n0, kappa) = full_neighbourhood(p.dim, p.spacing, re);
    let grid = SearchGrid::build(&p.reference, re, periods);
    let lap = 2.0 * d / (kappa * n0);
    let mut b = Bonds { radius: re, n0, kappa, offset: Vec::with_capacity(n + 1), ..Default::default() };
    b.offset.push(0);
    // each particle's neighbours, sorted: found on the pool's threads a block of particles at a
    // time (the lists of one block at once, not of all), appended in particle order
    let neighbours = |i: usize| {
        let mut list: Vec<(usize, DVec3)> = Vec::new();
        grid.for_each_within(p.reference[i], re, &p.reference, |j, r| {
            // bonds join particles of the same body only (bodies interact through contact)
            if j != i && r.length_squared() > 0.0 && p.body[j] == p.body[i] {
                list.push((j, r));
            }
        });
        list.sort_by_key(|(j, _)| *j);
        list
    };
    let mut block: Vec<Vec<(usize, DVec3)>> = Vec::new();
    for i in 0..n {
        if i % NEIGHBOUR_BLOCK == 0 {
            (i..n.min(i + NEIGHBOUR_BLOCK)).into_par_iter().with_min_len(256).map(neighbours).collect_into_vec(&mut block);
        }
        for &(j, r) in &block[i % NEIGHBOUR_BLOCK] {
            let len = r.length();
            let w = weight(len, re);
            let shift = r - (p.reference[j] - p.reference[i]);
            let vbar = 0.5 * (p.volume[i] + p.volume[j]);
            b.neighbour.push(j as u32);
            b.r0.push(r);
            b.shift.push(shift);
            b.w.push(w);
            b.w_hat.push(w / (len * len));
            b.stiffness.push(pair_modulus[i].min(pair_modulus[j]) * vbar * lap * w);
            b.damping.push(0.5 * (viscosity[i] + viscosity[j]) * vbar * lap * w);
        }
        b.offset.push(b.neighbour.len() as u32);
    }
    // (on the pool's threads; rayon's collect keeps the particles' order)
    b.reverse = (0..n)
        .into_par_iter()
        .with_min_len(256)
        .flat_map_iter(|i| {
            let b = &b;
            b.of(i).map(move |k| {
                let j = b.neighbour[k] as usize;
                b.of(j).find(|&m| b.neighbour[m] as usize == i).expect("bond lists are symmetric") as u32
            })
        })
        .collect();
    b.grad = (0..n).into_par_iter().with_min_len(256).flat_map_iter(|i| second_order_weights(&b, i, p.dim)).collect();
    b.grad_reverse = b.reverse.iter().map(|&r| b.grad[r as usize]).collect();
    b.periodic = b.shift.iter().any(|s| *s != DVec3::ZERO);
    b
}

pub fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Inverse of the moment matrix; in 2D only the x–y block is inverted (z row/column zero).
/// A particle with too few neighbours to span the space gets a zero correction (it then feels
/// only the pair model).
fn invert_moment(m: DMat3, dim: usize) -> DMat3 {
    if dim == 2 {
        let (a, b, c, e) = (m.x_axis.x, m.y_axis.x, m.x_axis.y, m.y_axis.y);
        let det = a * e - b * c;
        let scale = (a + e).abs().max(1e-300);
        if det.abs() <= 1e-10 * scale * scale {
            return DMat3::ZERO;
        }
        DMat3::from_cols(DVec3::new(e / det, -c / det, 0.0), DVec3::new(-b / det, a / det, 0.0), DVec3::ZERO)
    } else {
        let det = m.determinant();
        let scale = (m.x_axis.x + m.y_axis.y + m.z_axis.z).abs().max(1e-300);
        if det.abs() <= 1e-10 * scale.powi(3) {
            return DMat3::ZERO;
        }
        m.inverse()
    }
}

/// 3×6 map B with ε r = B ε_V (Voigt with engineering shear).
fn strain_to_stretch(r: DVec3) -> [[f64; 6]; 3] {
    [[r.x, 0.0, 0.0, 0.0, 0.5 * r.z, 0.5 * r.y], [0.0, r.y, 0.0, 0.5 * r.z, 0.0, 0.5 * r.x], [0.0, 0.0, r.z, 0.5 * r.y, 0.5 * r.x, 0.0]]
}

/// The stiffness that particle i's half of its pair bonds adds for a uniform strain:
/// ½ Σ_j ½ k_ij |ε r⁰_ij|² = V_i · ½ ε_V·C_pair ε_V, so C_pair = (1/2V_i) Σ_j k_ij BᵀB.
/// The gradient model then carries C − C_pair, and a uniform strain sees exactly C.
pub fn pair_stiffness(b: &Bonds, i: usize, volume: f64) -> Voigt6 {
    let mut c = [[0.0; 6]; 6];
    for k in b.of(i) {
        let m = strain_to_stretch(b.r0[k]);
        let s = b.stiffness[k] / (2.0 * volume);
        for p in 0..6 {
            for q in 0..6 {
                c[p][q] += s * (0..3).map(|a| m[a][p] * m[a][q]).sum::<f64>();
            }
        }
    }
    c
}

/// Quadratic basis in scaled coordinates s = r / r_e: (linear terms, then quadratic ones).
fn basis(s: DVec3, dim: usize, out: &mut [f64; 9]) -> usize {
    if dim == 2 {
        *out = [s.x, s.y, s.x * s.x, s.x * s.y, s.y * s.y, 0.0, 0.0, 0.0, 0.0];
        5
    } else {
        *out = [s.x, s.y, s.z, s.x * s.x, s.y * s.y, s.z * s.z, s.x * s.y, s.y * s.z, s.z * s.x];
        9
    }
}

/// Least-squares MPS gradient weights (second-order consistent) of particle i: with
/// M = Σ_j w p(s_j) p(s_j)ᵀ, g_ij = w_ij (M⁻¹ p(s_j))[0..d] / r_e. A neighbourhood too thin
/// to fit a quadratic (a corner) falls back to the first-order renormalised weights ŵ L r⁰.
fn second_order_weights(b: &Bonds, i: usize, dim: usize) -> Vec<DVec3> {
    let re = b.radius;
    let range = b.of(i);
    let mut m = [[0.0f64; 9]; 9];
    let mut pv = [0.0; 9];
    let mut nb = 0;
    for k in range.clone() {
        nb = basis(b.r0[k] / re, dim, &mut pv);
        for a in 0..nb {
            for c in 0..nb {
                m[a][c] += b.w[k] * pv[a] * pv[c];
            }
        }
    }
    if let Some(inv) = invert_spd(&m, nb) {
        range
            .map(|k| {
                basis(b.r0[k] / re, dim, &mut pv);
                let mut g = DVec3::ZERO;
                for a in 0..dim {
                    g[a] = (0..nb).map(|c| inv[a][c] * pv[c]).sum::<f64>() * b.w[k] / re;
                }
                g
            })
            .collect()
    } else {
        let mut mm = DMat3::ZERO;
        for k in range.clone() {
            mm += b.w_hat[k] * outer(b.r0[k], b.r0[k]);
        }
        let l = invert_moment(mm, dim);
        range.map(|k| b.w_hat[k] * (l * b.r0[k])).collect()
    }
}

/// Inverse of a small symmetric positive-definite matrix by Gauss–Jordan elimination with
/// partial pivoting; None when it is numerically singular (condition worse than ~1e10).
fn invert_spd(m: &[[f64; 9]; 9], n: usize) -> Option<[[f64; 9]; 9]> {
    let mut a = *m;
    let mut inv = [[0.0; 9]; 9];
    for (k, row) in inv.iter_mut().enumerate().take(n) {
        row[k] = 1.0;
    }
    let scale = (0..n).map(|k| m[k][k].abs()).fold(0.0, f64::max);
    for col in 0..n {
        let piv = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        if a[piv][col].abs() <= 1e-10 * scale {
            return None;
        }
        a.swap(col, piv);
        inv.swap(col, piv);
        let d = a[col][col];
        for c in 0..n {
            a[col][c] /= d;
            inv[col][c] /= d;
        }
        for r in 0..n {
            if r != col {
                let f = a[r][col];
                if f != 0.0 {
                    for c in 0..n {
                        a[r][c] -= f * a[col][c];
                        inv[r][c] -= f * inv[col][c];
                    }
                }
            }
        }
    }
    Some(inv)
}
