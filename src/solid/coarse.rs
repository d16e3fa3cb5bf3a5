//! A coarse-space correction for the implicit step's preconditioner (two-level additive
//! Schwarz): the smoother (the patches of [`super::patch_jacobi`], or block Jacobi, one 3×3
//! block per particle, [`super::implicit::BlockJacobi`]) damps what varies from particle to
//! particle, but the smooth, body-wide modes of
//! A = M − Δt D − Δt² K are what a large time step makes stiff, and block Jacobi needs many
//! iterations to move them. The particles are grouped into aggregates (cubes of a few
//! spacings); on each, the affine motions — translations, rotations and uniform strains (2D: 6
//! modes; 3D: 12) — are the coarse unknowns (the columns of P, clamped particles left out): the
//! rigid-body modes of smoothed aggregation for elasticity, with the strains that bending and
//! stretching of a body need. The coarse matrix A_c = Pᵀ A P is computed once, matrix-free,
//! by probing: aggregates whose indices agree modulo c (c − 1 aggregates between two of them,
//! more than A's reach of 3 r_e: the rotations slaved to the positions, (2.74), carry a
//! particle's influence one bond further than the gradient model's two) are pushed together,
//! one axis at a time, and each aggregate's response is read as the entry of the one pushed
//! aggregate within its reach. A_c is dense and factorised by Cholesky; the preconditioner is
//! z = S r + P A_c⁻¹ Pᵀ r (S the smoother), symmetric positive definite as conjugate gradients need.
//!
//! The aggregates grow with the body so that A_c stays small (≤ [`MAX_UNKNOWNS`] unknowns): a
//! coarse space of ≈ 10³ aggregates still carries the body's lowest modes.

use glam::DVec3;
use rayon::prelude::*;

/// Largest number of coarse unknowns (aggregates × modes): the dense factor then holds
/// ≤ 2000² f64 (32 MB) and takes ≈ 3·10⁹ flops once.
pub const MAX_UNKNOWNS: usize = 2000;

/// The coarse space and the factor of its matrix.
#[derive(Clone, Debug)]
pub struct CoarseSpace {
    /// Aggregate (dense index) of each particle; `u32::MAX` for clamped particles.
    aggregate: Vec<u32>,
    /// First coarse unknown of each aggregate (and the total at the end).
    offset: Vec<usize>,
    /// Lower Cholesky factor of A_c, row-major, unknowns².
    factor: Vec<f64>,
    /// Side of an aggregate (length).
    pub side: f64,
    /// The basis vectors at each particle (those of its aggregate's basis, in order), from
    /// `start[i]`: P's entries, evaluated once.
    vectors: Vec<DVec3>,
    start: Vec<usize>,
}

/// Mode k of an aggregate of side `side` at `rel` from its centre — the affine motions:
/// translations along the axes, rotations (about z in 2D; about x, y, z in 3D), then the uniform
/// strains (normal, then shear), the last two kinds scaled by 1/side so that every mode moves the
/// aggregate's particles by O(1).
fn mode(k: usize, dim: usize, rel: DVec3, side: f64) -> DVec3 {
    let r = rel / side;
    match (dim, k) {
        (_, k) if k < dim => DVec3::AXES[k],
        (2, 2) => DVec3::Z.cross(r),
        (2, 3) => DVec3::new(r.x, 0.0, 0.0),
        (2, 4) => DVec3::new(0.0, r.y, 0.0),
        (2, 5) => DVec3::new(r.y, r.x, 0.0),
        (3, k) if k < 6 => DVec3::AXES[k - 3].cross(r),
        (3, k) if k < 9 => DVec3::AXES[k - 6] * r[k - 6],
        (3, 9) => DVec3::new(r.y, r.x, 0.0),
        (3, 10) => DVec3::new(0.0, r.z, r.y),
        (3, 11) => DVec3::new(r.z, 0.0, r.x),
        _ => unreachable!("mode {k} of {dim}D"),
    }
}

/// Number of affine modes in `dim` dimensions.
fn mode_count(dim: usize) -> usize {
    if dim == 2 { 6 } else { 12 }
}

impl CoarseSpace {
    /// Builds the coarse space of particles at `reference` (spacing l₀, dimension `dim`) for the
    /// operator `apply` (x ↦ A x, zero on `fixed` particles), whose reach is `reach` (length).
    /// `None` when A_c is not positive definite to round-off (the caller keeps block Jacobi).
    pub fn build(reference: &[DVec3], fixed: &[bool], dim: usize, spacing: f64, reach: f64, mut apply: impl FnMut(&[DVec3], &mut [DVec3])) -> Option<Self> {
        let n = reference.len();
        let modes = mode_count(dim);
        let lo = reference.iter().fold(DVec3::splat(f64::INFINITY), |a, x| a.min(*x));
        let hi = reference.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, x| a.max(*x));
        let cells = |side: f64| -> [usize; 3] { std::array::from_fn(|a| if a < dim { ((hi[a] - lo[a]) / side).floor() as usize + 1 } else { 1 }) };
        let mut side = 4.0 * spacing;
        while cells(side).iter().product::<usize>() * modes > MAX_UNKNOWNS {
            side *= 1.25;
        }
        let nc = cells(side);
        let coords = |x: DVec3| -> [usize; 3] { std::array::from_fn(|a| if a < dim { (((x[a] - lo[a]) / side).floor() as usize).min(nc[a] - 1) } else { 0 }) };
        let flat = |c: [usize; 3]| (c[2] * nc[1] + c[1]) * nc[0] + c[0];
        // dense ids of the aggregates that hold a free particle
        let mut id = vec![u32::MAX; nc.iter().product()];
        let mut grid_of = Vec::new();
        let mut aggregate = vec![u32::MAX; n];
        let mut members: Vec<Vec<usize>> = Vec::new();
        for i in 0..n {
            if fixed[i] {
                continue;
            }
            let c = coords(reference[i]);
            let f = flat(c);
            if id[f] == u32::MAX {
                id[f] = grid_of.len() as u32;
                grid_of.push(c);
                members.push(Vec::new());
            }
            aggregate[i] = id[f];
            members[id[f] as usize].push(i);
        }
        let count = grid_of.len();
        if count == 0 {
            return None;
        }
        let centre: Vec<DVec3> =
            grid_of.iter().map(|c| lo + DVec3::from_array(std::array::from_fn(|a| if a < dim { (c[a] as f64 + 0.5) * side } else { 0.0 }))).collect();
        // per aggregate, Gram–Schmidt of the affine modes in the inner product over its particles
        // (a mode that the others already span there — a one-particle-thick aggregate's strain
        // across its thickness — is dropped)
        let basis: Vec<Vec<[f64; 12]>> = members
            .iter()
            .zip(&centre)
            .map(|(m, c)| {
                let mut gram = [[0.0; 12]; 12];
                for &i in m {
                    let v: Vec<DVec3> = (0..modes).map(|k| mode(k, dim, reference[i] - *c, side)).collect();
                    for k in 0..modes {
                        for l in 0..modes {
                            gram[k][l] += v[k].dot(v[l]);
                        }
                    }
                }
                let dot = |a: &[f64; 12], b: &[f64; 12]| -> f64 { (0..modes).map(|k| (0..modes).map(|l| a[k] * gram[k][l] * b[l]).sum::<f64>()).sum() };
                let mut accepted: Vec<[f64; 12]> = Vec::new();
                for k in 0..modes {
                    let mut v = [0.0; 12];
                    v[k] = 1.0;
                    let norm0 = dot(&v, &v);
                    for b in &accepted {
                        let p = dot(&v, b);
                        for (x, y) in v.iter_mut().zip(b) {
                            *x -= p * y;
                        }
                    }
                    let norm = dot(&v, &v);
                    if norm > 1e-8 * norm0 {
                        let s = 1.0 / norm.sqrt();
                        accepted.push(v.map(|x| x * s));
                    }
                }
                accepted
            })
            .collect();
        let mut offset = vec![0];
        for b in &basis {
            offset.push(offset.last().unwrap() + b.len());
        }
        let m = *offset.last().unwrap();
        let value = |j: usize, b: &[f64; 12], i: usize| -> DVec3 { (0..modes).map(|k| b[k] * mode(k, dim, reference[i] - centre[j], side)).sum() };
        // aggregates within reach differ by at most r in each index; colour period 2r + 1
        let r = (reach / side).floor() as usize + 1;
        let period = 2 * r + 1;
        let mut a = vec![0.0; m * m];
        let colours: Vec<[usize; 3]> =
            (0..period.pow(dim as u32)).map(|k| std::array::from_fn(|ax| if ax < dim { (k / period.pow(ax as u32)) % period } else { 0 })).collect();
        let mut x = vec![DVec3::ZERO; n];
        let mut y = vec![DVec3::ZERO; n];
        for colour in &colours {
            let pushed = |c: &[usize; 3]| (0..dim).all(|ax| c[ax] % period == colour[ax]);
            if !grid_of.iter().any(pushed) {
                continue;
            }
            for d in 0..modes {
                let mut any = false;
                x.iter_mut().for_each(|v| *v = DVec3::ZERO);
                for (j, m) in members.iter().enumerate() {
                    if pushed(&grid_of[j]) && d < basis[j].len() {
                        any = true;
                        for &i in m {
                            x[i] = value(j, &basis[j][d], i);
                        }
                    }
                }
                if !any {
                    continue;
                }
                apply(&x, &mut y);
                for (j, cj) in grid_of.iter().enumerate() {
                    // the pushed aggregate within reach of j: index ≡ colour (mod period), |Δ| ≤ r
                    let mut ci = [0usize; 3];
                    let mut inside = true;
                    for ax in 0..dim {
                        let off = (colour[ax] + period - cj[ax] % period) % period;
                        let off = if off > r { off as isize - period as isize } else { off as isize };
                        let v = cj[ax] as isize + off;
                        inside &= v >= 0 && (v as usize) < nc[ax];
                        ci[ax] = v.max(0) as usize;
                    }
                    if !inside || id[flat(ci)] == u32::MAX {
                        continue;
                    }
                    let i = id[flat(ci)] as usize;
                    if d >= basis[i].len() {
                        continue;
                    }
                    for (e, b) in basis[j].iter().enumerate() {
                        let response: f64 = members[j].iter().map(|&p| value(j, b, p).dot(y[p])).sum();
                        a[(offset[j] + e) * m + offset[i] + d] = response;
                    }
                }
            }
        }
        // symmetric in exact arithmetic; symmetrised against round-off
        for p in 0..m {
            for q in 0..p {
                let s = 0.5 * (a[p * m + q] + a[q * m + p]);
                a[p * m + q] = s;
                a[q * m + p] = s;
            }
        }
        let mut start = Vec::with_capacity(n + 1);
        let mut vectors = Vec::new();
        for i in 0..n {
            start.push(vectors.len());
            if aggregate[i] != u32::MAX {
                let j = aggregate[i] as usize;
                vectors.extend(basis[j].iter().map(|b| value(j, b, i)));
            }
        }
        start.push(vectors.len());
        cholesky(&mut a, m).then_some(Self { aggregate, offset, factor: a, side, vectors, start })
    }

    /// Number of coarse unknowns.
    pub fn unknowns(&self) -> usize {
        *self.offset.last().expect("one offset per aggregate and the total")
    }

    /// z += P A_c⁻¹ Pᵀ r.
    pub fn add_correction(&self, r: &[DVec3], z: &mut [DVec3]) {
        let m = self.unknowns();
        let mut u = vec![0.0; m];
        for (i, ri) in r.iter().enumerate() {
            let a = self.aggregate[i];
            if a != u32::MAX {
                let o = self.offset[a as usize];
                for (e, v) in self.vectors[self.start[i]..self.start[i + 1]].iter().enumerate() {
                    u[o + e] += v.dot(*ri);
                }
            }
        }
        // L Lᵀ u = Pᵀ r: forward then backward substitution
        let l = &self.factor;
        for p in 0..m {
            let s: f64 = (0..p).map(|q| l[p * m + q] * u[q]).sum();
            u[p] = (u[p] - s) / l[p * m + p];
        }
        for p in (0..m).rev() {
            let s: f64 = (p + 1..m).map(|q| l[q * m + p] * u[q]).sum();
            u[p] = (u[p] - s) / l[p * m + p];
        }
        let u = &u;
        z.par_iter_mut().enumerate().for_each(|(i, zi)| {
            let a = self.aggregate[i];
            if a != u32::MAX {
                let o = self.offset[a as usize];
                for (e, v) in self.vectors[self.start[i]..self.start[i + 1]].iter().enumerate() {
                    *zi += u[o + e] * *v;
                }
            }
        });
    }
}

/// In-place dense Cholesky A = L Lᵀ (row-major m × m; the lower triangle becomes L); false when a
/// pivot is not positive (A not positive definite to round-off).
fn cholesky(a: &mut [f64], m: usize) -> bool {
    for j in 0..m {
        let d = a[j * m + j] - (0..j).map(|k| a[j * m + k] * a[j * m + k]).sum::<f64>();
        if d.is_nan() || d <= 1e-14 * a[j * m + j].abs() {
            return false;
        }
        let d = d.sqrt();
        a[j * m + j] = d;
        let (head, tail) = a.split_at_mut((j + 1) * m);
        let row_j = &head[j * m..j * m + j];
        tail.par_chunks_mut(m).for_each(|row_i| {
            let s: f64 = row_i[..j].iter().zip(row_j).map(|(x, y)| x * y).sum();
            row_i[j] = (row_i[j] - s) / d;
        });
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a chain of springs (a 1D Laplacian on both axes plus a mass term, particles 0 and the
    /// last clamped: the operator's reach is one spacing), probing recovers Pᵀ A P to round-off —
    /// checked against the product formed column by column, rotations included — and the
    /// correction inverts A on the coarse space.
    #[test]
    fn probing_recovers_the_coarse_matrix_of_a_spring_chain() {
        let n = 60;
        let reference: Vec<DVec3> = (0..n).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
        let fixed: Vec<bool> = (0..n).map(|i| i == 0 || i == n - 1).collect();
        let k = |i: usize| 1.0 + 0.1 * (i as f64).sin();
        let apply = |x: &[DVec3], y: &mut [DVec3]| {
            for i in 0..n {
                y[i] = if fixed[i] {
                    DVec3::ZERO
                } else {
                    let mut f = 0.3 * x[i];
                    if i > 0 {
                        f += k(i) * (x[i] - x[i - 1]);
                    }
                    if i + 1 < n {
                        f += k(i + 1) * (x[i] - x[i + 1]);
                    }
                    f
                };
            }
        };
        // 2D: six modes; along a chain only four are independent (ε_yy moves nothing, and the
        // rotation and the shear both move y in proportion to x): each aggregate keeps four
        let c = CoarseSpace::build(&reference, &fixed, 2, 1.0, 1.0, apply).expect("positive definite");
        assert_eq!(c.side, 4.0);
        let sizes: Vec<usize> = c.offset.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!(sizes, vec![4; 15]);
        // A_c by columns: P e_q, then Pᵀ A P e_q; compare with L Lᵀ
        let m = c.unknowns();
        assert_eq!(m, 15 * 4);
        let l = &c.factor;
        let slot = |q: usize| -> (usize, usize) {
            let j = c.offset.iter().rposition(|&o| o <= q).unwrap();
            (j, q - c.offset[j])
        };
        let column = |q: usize| -> Vec<DVec3> {
            let (j, e) = slot(q);
            (0..n).map(|i| if c.aggregate[i] as usize == j { c.vectors[c.start[i] + e] } else { DVec3::ZERO }).collect()
        };
        let mut worst: f64 = 0.0;
        for q in 0..m {
            let mut y = vec![DVec3::ZERO; n];
            apply(&column(q), &mut y);
            let scale = y.iter().map(|v| v.length()).fold(0.0, f64::max);
            for p in 0..m {
                let want: f64 = column(p).iter().zip(&y).map(|(a, b)| a.dot(*b)).sum();
                let got: f64 = (0..=p.min(q)).map(|s| l[p * m + s] * l[q * m + s]).sum();
                worst = worst.max((got - want).abs() / scale);
            }
        }
        assert!(worst < 1e-12, "A_c off by {worst:e}");
        // the correction of a residual that is A P v for a coarse vector v gives back P v
        let v: Vec<f64> = (0..m).map(|q| (q as f64 * 0.7).cos()).collect();
        let mut px = vec![DVec3::ZERO; n];
        for (q, vq) in v.iter().enumerate() {
            for (x, col) in px.iter_mut().zip(column(q)) {
                *x += *vq * col;
            }
        }
        let mut apx = vec![DVec3::ZERO; n];
        apply(&px, &mut apx);
        let mut z = vec![DVec3::ZERO; n];
        c.add_correction(&apx, &mut z);
        let err = z.iter().zip(&px).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
        assert!(err < 1e-10, "P A_c⁻¹ Pᵀ A P v = P v off by {err:e}");
    }
}
