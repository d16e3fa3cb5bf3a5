//! Patch block Jacobi: the implicit step's smoother on small cubes of particles.
//!
//! Block Jacobi with one 3×3 block per particle ([`super::implicit::BlockJacobi`]) leaves the
//! particle-scale error slow: the gradient model (seed 2.17, second order) couples a particle to
//! its neighbours' neighbours, and the off-diagonal blocks of A = (M + M_a) − Δt D − Δt² K
//! (2.63)–(2.66) weigh up to eight times the diagonal one (λ_max(D⁻¹A) ≈ 7.8 on the benchmark
//! block). Here the particles are grouped into patches — cubes of [`patch_spacings`] reference
//! spacings, 27 particles in 3D (squares of 16 in 2D) in a lattice sample — and each patch's
//! diagonal block A_PP (81 × 81) is inverted exactly: z_P = A_PP⁻¹ r_P. Measured on the 12³
//! benchmark block at 10× the explicit step (2026-12-03, one implicit system, CG to 10⁻⁸):
//! block Jacobi 109 iterations, patches of 2³ particles 52, 3³ 37; with the coarse space
//! ([`super::coarse`]) 71 → 35 → 27 (the 20³ and 30³ blocks: 77 → 34 and 88 → 29).
//!
//! A_PP is assembled from the discretisation, not probed (probing it would cost ~2,000 operator
//! products): the mass, the pair part (2.38) as Σ (Δt² k_ij + Δt c_ij) on the diagonal and
//! −(Δt² k_ij + Δt c_ij) between bonded patch members, and the gradient part
//! Σ_k V_k (∂ε_k/∂x_i)ᵀ C'_k (∂ε_k/∂x_j) Δt² over every particle k whose strain both members move
//! (∂ε_k/∂x_j = g_kj for a neighbour j, −Σ_j g_kj for k itself) — the same terms, at the reference
//! configuration with the rotations frozen, that [`super::implicit::BlockJacobi`] keeps on the
//! diagonal (a one-particle patch is exactly its block: test). The inverses are stored as the
//! lower triangle in f32 (a preconditioner needs no more: CG converges to its f64 tolerance with
//! any fixed symmetric positive definite preconditioner, and the rounding of 2⁻²⁴ keeps the
//! blocks positive definite while their condition number is far below 10⁷), 490 B per particle
//! in 3D, 294 B in 2D.

use super::bonds::outer;
use super::forces::Discretisation;
use super::material::{mul6, to_voigt};
use super::particles::Particles;
use glam::DVec3;
use rayon::prelude::*;

/// Side of a patch in reference spacings: 3 in 3D (27 particles), 4 in 2D (16). Measured on
/// the benchmark blocks at 10× the explicit step (three steps, CG to 10⁻⁸, with the coarse
/// space; block Jacobi 65–69 iterations in 3D (12³), 49–50 in 2D (40²)): 3D 25–26 iterations
/// at 3 and at 4 spacings, 31 at 5; 2D 43–44 at 3, 22–23 at 4 and at 6.
pub fn patch_spacings(dim: usize) -> f64 {
    if dim == 3 { 3.0 } else { 4.0 }
}

/// The patches and the inverses of their diagonal blocks.
#[derive(Clone, Debug)]
pub struct PatchJacobi {
    /// Particles of patch p: `members[start[p]..start[p + 1]]` (free particles only).
    members: Vec<u32>,
    start: Vec<usize>,
    /// Position of particle i in `members`; `u32::MAX` for clamped particles.
    slot: Vec<u32>,
    /// Lower triangle (row-major, packed) of A_PP⁻¹ of each patch, from `inverse_start[p]`.
    inverse: Vec<f32>,
    inverse_start: Vec<usize>,
}

/// Voigt strains of the unit displacements along x, y, z of a particle that moves particle k's
/// strain with weight `g` (ε_k changes by sym(δx ⊗ g)).
pub(super) fn unit_strains(g: DVec3) -> [[f64; 6]; 3] {
    std::array::from_fn(|a| {
        let h = outer(DVec3::AXES[a], g);
        to_voigt(&(0.5 * (h + h.transpose())))
    })
}

impl PatchJacobi {
    /// Groups the free particles into patches of [`patch_spacings`] × l₀ (cells of the
    /// reference positions) and inverts each patch's block of A for the step `dt`.
    pub fn new(d: &Discretisation, p: &Particles, dt: f64) -> Self {
        Self::with_patch_side(d, p, dt, patch_spacings(p.dim) * p.spacing)
    }

    /// [`Self::new`] with patches of side `side` (length); a side below l₀ gives one particle
    /// per patch, which is block Jacobi.
    pub fn with_patch_side(d: &Discretisation, p: &Particles, dt: f64, side: f64) -> Self {
        let n = p.len();
        let dim = p.dim;
        // the free particles' extent along each axis, in layers of l₀, split into a whole number
        // of patches as close to `side` as that allows: a lattice sample's patches are then
        // side/l₀ ± 1 layers thick (2–4 in 3D, 3–5 in 2D), never a thin remainder of one layer at
        // a face (a body that is not a box still has thin patches where its boundary cuts the
        // cells). Measured on the benchmark blocks (patches
        // alone, 10× the explicit step, one system to 10⁻⁸), when the remainder was left thin:
        // 16³ 80 CG iterations, 24³ 40, 30³ 41, 38³ 51, 46³ 87 — the blocks whose side is not a
        // multiple of 3 took up to twice the iterations (λ_max of the preconditioned operator 3.7
        // against 2.3, from the CG coefficients); split into whole patches: 16³ 33, 30³ 42, 46³ 44.
        let free = || (0..n).filter(|&i| !p.fixed[i]).map(|i| p.reference[i]);
        let lo = free().fold(DVec3::splat(f64::INFINITY), |a, x| a.min(x));
        let hi = free().fold(DVec3::splat(f64::NEG_INFINITY), |a, x| a.max(x));
        // per axis: the layers of the extent and the patches across it
        let split: [(f64, f64); 3] = std::array::from_fn(|a| {
            if a >= dim || lo[a] > hi[a] {
                return (1.0, 1.0);
            }
            let layers = ((hi[a] - lo[a]) / p.spacing).round() + 1.0;
            (layers, (layers * p.spacing / side).round().max(1.0))
        });
        // a particle's layer coordinate t (an integer in a lattice sample) puts it in patch
        // ⌊(t + 0.499) k / n⌋ of the k across n layers: 0.499 rather than 0.5 so that no lattice
        // row sits on a patch face, where rounding would decide its patch
        let key = |x: DVec3| -> [i64; 3] {
            std::array::from_fn(|a| {
                let (layers, count) = split[a];
                if a < dim { (((x[a] - lo[a]) / p.spacing + 0.499) * count / layers).floor().clamp(0.0, count - 1.0) as i64 } else { 0 }
            })
        };
        // patches in the order of their cells (z, y, x), members in particle order
        let mut cells: std::collections::BTreeMap<[i64; 3], Vec<u32>> = std::collections::BTreeMap::new();
        for i in 0..n {
            if !p.fixed[i] {
                let k = key(p.reference[i]);
                cells.entry([k[2], k[1], k[0]]).or_default().push(i as u32);
            }
        }
        let mut members = Vec::with_capacity(n);
        let mut start = vec![0];
        let (mut slot, mut patch) = (vec![u32::MAX; n], vec![u32::MAX; n]);
        for (q, m) in cells.into_values().enumerate() {
            for i in m {
                slot[i as usize] = members.len() as u32;
                patch[i as usize] = q as u32;
                members.push(i);
            }
            start.push(members.len());
        }
        let patches = start.len() - 1;
        let layout = Layout { members: &members, start: &start, slot: &slot, patch: &patch };
        let inverses: Vec<Vec<f32>> = (0..patches)
            .into_par_iter()
            .map(|q| {
                let m = 3 * (start[q + 1] - start[q]);
                let mut a = layout.block(d, p, dt, q);
                symmetric_inverse_packed(&mut a, m)
            })
            .collect();
        let mut inverse_start = Vec::with_capacity(patches + 1);
        let mut total = 0;
        for inv in &inverses {
            inverse_start.push(total);
            total += inv.len();
        }
        inverse_start.push(total);
        Self { members, start, slot, inverse: inverses.concat(), inverse_start }
    }

    /// Number of patches.
    pub fn patches(&self) -> usize {
        self.start.len() - 1
    }

    /// The particles of patch q.
    pub fn members(&self, q: usize) -> &[u32] {
        &self.members[self.start[q]..self.start[q + 1]]
    }

    /// The most particles in one patch.
    pub fn largest_patch(&self) -> usize {
        self.start.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0)
    }

    /// The flat arrays as the GPU's twin of [`Self::apply`] reads them: the patches' members
    /// one after the other, where each patch's members start (patches + 1 offsets), and the
    /// packed lower triangles of A_PP⁻¹ (row a holds columns 0..=a of the 3m unknowns x, y, z of
    /// each member in turn) with where each patch's starts.
    pub fn flat(&self) -> (&[u32], &[usize], &[f32], &[usize]) {
        (&self.members, &self.start, &self.inverse, &self.inverse_start)
    }

    /// z = blockdiag(A_PP⁻¹) r (zero on clamped particles).
    pub fn apply(&self, r: &[DVec3], z: &mut [DVec3]) {
        let mut zp = vec![DVec3::ZERO; self.members.len()];
        let mut slices: Vec<&mut [DVec3]> = Vec::with_capacity(self.patches());
        let mut rest = zp.as_mut_slice();
        for q in 0..self.patches() {
            let (head, tail) = rest.split_at_mut(self.start[q + 1] - self.start[q]);
            slices.push(head);
            rest = tail;
        }
        // (r_P, z_P) scratch per worker thread, not per patch: this runs every CG iteration
        slices.into_par_iter().enumerate().for_each_init(
            || (Vec::new(), Vec::new()),
            |(rl, y), (q, out)| {
                let mem = &self.members[self.start[q]..self.start[q + 1]];
                let inv = &self.inverse[self.inverse_start[q]..self.inverse_start[q + 1]];
                let m = 3 * mem.len();
                rl.clear();
                rl.extend(mem.iter().flat_map(|&i| r[i as usize].to_array()));
                y.clear();
                y.resize(m, 0.0f64);
                // packed lower triangle: row a holds columns 0..=a
                let mut at = 0;
                for a in 0..m {
                    let row = &inv[at..at + a + 1];
                    let mut s = 0.0;
                    for (c, &v) in row[..a].iter().enumerate() {
                        s += v as f64 * rl[c];
                        y[c] += v as f64 * rl[a];
                    }
                    y[a] += s + row[a] as f64 * rl[a];
                    at += a + 1;
                }
                for (l, o) in out.iter_mut().enumerate() {
                    *o = DVec3::new(y[3 * l], y[3 * l + 1], y[3 * l + 2]);
                }
            },
        );
        z.par_iter_mut().enumerate().for_each(|(i, zi)| *zi = if self.slot[i] == u32::MAX { DVec3::ZERO } else { zp[self.slot[i] as usize] });
    }
}

/// Where the patches are: members per patch, each particle's slot and patch.
struct Layout<'a> {
    members: &'a [u32],
    start: &'a [usize],
    slot: &'a [u32],
    patch: &'a [u32],
}

impl Layout<'_> {
    /// A_PP of patch q, row-major (3m)² for its m members: the terms listed in the module doc.
    fn block(&self, d: &Discretisation, p: &Particles, dt: f64, q: usize) -> Vec<f64> {
        let (members, start, slot, patch) = (self.members, self.start, self.slot, self.patch);
        let b = &d.bonds;
        let dt2 = dt * dt;
        let mem = &members[start[q]..start[q + 1]];
        let m = 3 * mem.len();
        let local = |j: usize| -> Option<usize> { (patch[j] == q as u32).then(|| slot[j] as usize - start[q]) };
        let mut a = vec![0.0f64; m * m];
        let mut add_block = |li: usize, lj: usize, blk: &[[f64; 3]; 3]| {
            for (x, row) in blk.iter().enumerate() {
                for (y, v) in row.iter().enumerate() {
                    a[(3 * li + x) * m + 3 * lj + y] += v;
                }
            }
        };
        // mass and pair part
        for (li, &i) in mem.iter().enumerate() {
            let i = i as usize;
            let mut diag = p.mass[i] + p.added_mass[i];
            for k in b.of(i) {
                let c = dt2 * b.stiffness[k] + dt * b.damping[k];
                diag += c;
                if let Some(lj) = local(b.neighbour[k] as usize) {
                    add_block(li, lj, &[[-c, 0.0, 0.0], [0.0, -c, 0.0], [0.0, 0.0, -c]]);
                }
            }
            add_block(li, li, &[[diag, 0.0, 0.0], [0.0, diag, 0.0], [0.0, 0.0, diag]]);
        }
        // gradient part: every strain particle k that a member moves (the members themselves
        // and their neighbours)
        let mut strain_particles: Vec<usize> = mem.iter().map(|&i| i as usize).collect();
        for &i in mem {
            strain_particles.extend(b.of(i as usize).map(|k| b.neighbour[k] as usize));
        }
        strain_particles.sort_unstable();
        strain_particles.dedup();
        for k in strain_particles {
            // (local member, ∂ε_k/∂x_member) for the members that move ε_k
            let mut deps: Vec<(usize, DVec3)> = Vec::new();
            let mut self_g = DVec3::ZERO;
            for e in b.of(k) {
                self_g -= b.grad[e];
                if let Some(lj) = local(b.neighbour[e] as usize) {
                    deps.push((lj, b.grad[e]));
                }
            }
            if let Some(lk) = local(k) {
                deps.push((lk, self_g));
            }
            let c = &d.grad_stiffness[k];
            let strains: Vec<[[f64; 6]; 3]> = deps.iter().map(|(_, g)| unit_strains(*g)).collect();
            let stresses: Vec<[[f64; 6]; 3]> = strains.iter().map(|e| std::array::from_fn(|a| mul6(c, &e[a]))).collect();
            let w = dt2 * d.volume[k];
            for (u, (li, _)) in deps.iter().enumerate() {
                for (v, (lj, _)) in deps.iter().enumerate() {
                    let blk: [[f64; 3]; 3] =
                        std::array::from_fn(|x| std::array::from_fn(|y| w * (0..6).map(|s| strains[u][x][s] * stresses[v][y][s]).sum::<f64>()));
                    add_block(*li, *lj, &blk);
                }
            }
        }
        if p.dim == 2 {
            // the out-of-plane component is not solved for: identity there
            for l in 0..mem.len() {
                let z = 3 * l + 2;
                for c in 0..m {
                    a[z * m + c] = 0.0;
                    a[c * m + z] = 0.0;
                }
                a[z * m + z] = 1.0;
            }
        }
        a
    }
}

/// The inverse of the symmetric positive definite m × m matrix `a` (row-major; overwritten) by
/// Cholesky, as its packed lower triangle in f32.
fn symmetric_inverse_packed(a: &mut [f64], m: usize) -> Vec<f32> {
    // a = L Lᵀ in the lower triangle
    for j in 0..m {
        let mut d = a[j * m + j];
        for k in 0..j {
            d -= a[j * m + k] * a[j * m + k];
        }
        assert!(d > 0.0, "a patch block of the implicit operator is not positive definite (pivot {d:e})");
        let d = d.sqrt();
        a[j * m + j] = d;
        for i in j + 1..m {
            let mut s = a[i * m + j];
            for k in 0..j {
                s -= a[i * m + k] * a[j * m + k];
            }
            a[i * m + j] = s / d;
        }
    }
    // L⁻¹ (lower), then A⁻¹ = L⁻ᵀ L⁻¹
    let mut li = vec![0.0f64; m * m];
    for c in 0..m {
        li[c * m + c] = 1.0 / a[c * m + c];
        for r in c + 1..m {
            let mut s = 0.0;
            for k in c..r {
                s += a[r * m + k] * li[k * m + c];
            }
            li[r * m + c] = -s / a[r * m + r];
        }
    }
    let mut packed = Vec::with_capacity(m * (m + 1) / 2);
    for r in 0..m {
        for c in 0..=r {
            // (L⁻ᵀ L⁻¹)_rc = Σ_k L⁻¹_kr L⁻¹_kc, k ≥ max(r, c) = r
            let s: f64 = (r..m).map(|k| li[k * m + r] * li[k * m + c]).sum();
            packed.push(s as f32);
        }
    }
    packed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solid::bench::{benchmark_block, benchmark_plate};
    use crate::solid::forces::{ForceField, Mode, StressField, bond_forces, strain_stress};
    use crate::solid::implicit::BlockJacobi;
    use crate::solid::{Integrator, Preconditioner, SolidSolver};
    use glam::DMat3;

    /// A viscous `side`² (2D) or `side`³ (3D) block of the benchmark's orthotropic material,
    /// clamped on its x = 0 face, implicit at 10× the explicit limit.
    fn block(dim: usize, side: usize) -> SolidSolver {
        if dim == 3 { benchmark_block(side, Integrator::Implicit) } else { benchmark_plate(side, Integrator::Implicit) }
    }

    /// The frozen-rotation linear operator at the reference configuration, x ↦ (M + M_a) x −
    /// Δt² (K x + D x/Δt) with the rotations held (no slaved increments), through the force
    /// kernels themselves: the operator whose diagonal blocks the patches assemble.
    fn frozen_operator(s: &SolidSolver, x: &[DVec3]) -> Vec<DVec3> {
        let n = x.len();
        let rot = vec![DMat3::IDENTITY; n];
        let mut st = StressField::new(n);
        let mut ff = ForceField::new(n);
        let v: Vec<DVec3> = x.iter().map(|x| *x / s.dt).collect();
        strain_stress(&s.disc, x, &rot, Mode::Linear, &mut st);
        bond_forces(&s.disc, x, &v, None, &rot, &st, Mode::Linear, None, &mut ff);
        let p = &s.particles;
        (0..n).map(|i| (p.mass[i] + p.added_mass[i]) * x[i] - s.dt * s.dt * ff.force[i]).collect()
    }

    #[test]
    fn a_patch_block_is_the_frozen_rotation_operators_block_to_round_off() {
        for (dim, side) in [(3, 7), (2, 9)] {
            let s = block(dim, side);
            let p = &s.particles;
            let pj = PatchJacobi::new(&s.disc, p, s.dt);
            let n = p.len();
            let mut patch = vec![u32::MAX; n];
            for q in 0..pj.patches() {
                for &i in &pj.members[pj.start[q]..pj.start[q + 1]] {
                    patch[i as usize] = q as u32;
                }
            }
            let layout = Layout { members: &pj.members, start: &pj.start, slot: &pj.slot, patch: &patch };
            // an interior patch (all 3^dim members, none clamped) and one on the free corner
            let full = (patch_spacings(dim) as usize).pow(dim as u32);
            let interior = (0..pj.patches()).find(|&q| pj.start[q + 1] - pj.start[q] == full);
            for q in [interior.expect("an interior patch"), pj.patches() - 1] {
                let mem = &pj.members[pj.start[q]..pj.start[q + 1]];
                let m = 3 * mem.len();
                let a = layout.block(&s.disc, p, s.dt, q);
                let (mut diff, mut scale) = (0.0f64, 0.0f64);
                for (lj, &j) in mem.iter().enumerate() {
                    for y in 0..dim {
                        let mut e = vec![DVec3::ZERO; n];
                        e[j as usize][y] = 1.0;
                        let col = frozen_operator(&s, &e);
                        for (li, &i) in mem.iter().enumerate() {
                            for x in 0..dim {
                                let exact = col[i as usize][x];
                                scale = scale.max(exact.abs());
                                diff = diff.max((a[(3 * li + x) * m + 3 * lj + y] - exact).abs());
                            }
                        }
                    }
                }
                println!("{dim}D patch {q} ({} members): largest |A_PP − operator| {:.2e} of the largest entry", mem.len(), diff / scale);
                assert!(diff <= 1e-12 * scale, "{dim}D patch {q}: {diff:e} of {scale:e}");
            }
        }
    }

    #[test]
    fn one_particle_patches_are_block_jacobi() {
        for (dim, side) in [(3, 5), (2, 8)] {
            let s = block(dim, side);
            let p = &s.particles;
            let pj = PatchJacobi::with_patch_side(&s.disc, p, s.dt, 0.5 * p.spacing);
            let bj = BlockJacobi::new(&s.disc, p, s.dt);
            let n = p.len();
            let r: Vec<DVec3> =
                (0..n).map(|i| DVec3::new((i as f64 * 0.37).sin(), (i as f64 * 0.91).cos(), if dim == 3 { (i as f64 * 1.3).sin() } else { 0.0 })).collect();
            let (mut a, mut b) = (vec![DVec3::ZERO; n], vec![DVec3::ZERO; n]);
            pj.apply(&r, &mut a);
            bj.apply(&r, &mut b);
            let scale = b.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
            let diff = (0..n).filter(|&i| !p.fixed[i]).map(|i| (a[i] - b[i]).abs().max_element()).fold(0.0, f64::max);
            // the inverses are stored in f32: 2⁻²⁴ per entry, a few entries per row
            assert!(diff <= 1e-6 * scale, "{dim}D: {diff:e} of {scale:e}");
            assert!((0..n).filter(|&i| p.fixed[i]).all(|i| a[i] == DVec3::ZERO));
            assert_eq!(pj.patches(), (0..n).filter(|&i| !p.fixed[i]).count());
        }
    }

    #[test]
    fn patches_take_the_implicit_step_in_under_half_the_iterations_of_block_jacobi() {
        // the 12³ benchmark block (2D: 40²) at 10× the explicit limit, three implicit steps
        // each way (measured 65–69 → 25–26 in 3D, 49–50 → 22–23 in 2D); the same motion to the
        // CG tolerance
        for (dim, side) in [(3, 12), (2, 40)] {
            let run = |pre: Preconditioner| {
                let mut s = block(dim, side);
                s.options.preconditioner = pre;
                let mut its = Vec::new();
                for _ in 0..3 {
                    s.step().unwrap();
                    assert!(s.last.cg.converged, "{pre:?}: {:?}", s.last.cg);
                    its.push(s.last.cg.iterations);
                }
                (its, s.particles.position.clone(), s.particles.reference.clone(), s)
            };
            let (bj, xb, x0, _) = run(Preconditioner::BlockJacobi);
            let (pa, xp, _, mut s) = run(Preconditioner::Patches);
            // the option, not what happens to be built, picks the smoother: switched after the
            // patches were built, the next step is block Jacobi's again
            s.options.preconditioner = Preconditioner::BlockJacobi;
            s.step().unwrap();
            assert!(s.last.cg.iterations >= 2 * pa[2], "{dim}D: {:?} after switching to block Jacobi", s.last.cg);
            let moved = xb.iter().zip(&x0).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
            let diff = xb.iter().zip(&xp).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
            println!("{dim}D {side}: CG iterations block Jacobi {bj:?}, patches {pa:?}; positions differ by {:.1e} of the motion", diff / moved);
            for (b, p) in bj.iter().zip(&pa) {
                assert!(2 * p <= *b, "{dim}D: patches {pa:?} against block Jacobi {bj:?}");
            }
            if dim == 3 {
                assert!(pa.iter().all(|&p| p <= 30), "{pa:?}");
            }
            assert!(diff <= 1e-6 * moved, "{diff:e} of {moved:e}");
        }
    }
}
