//! Bit storage, propagation and interference of the FCHC lattice gas (seed 002 §3.1–3.4).
//!
//! Sites are the 16 vertices of 4D cells of side ℓ whose centres repeat every 2ℓ in X, Y, Z (the
//! 4th coordinate R holds one cell, periodic). Vertex index v = b_X | b_Y << 1 | b_Z << 2 |
//! b_R << 3 with b = 1 for the offset +ℓ/2. Per velocity, the 16 sites of a cell are one 16-bit
//! word (bit v = a particle at vertex v), stored velocity-major: `words[k · cells + cell]`.
//! All three spatial axes are periodic here (inlet, outlet and obstacles are the scene's).
//!
//! Units: positions in ℓ, time in steps; a particle moves by c_k (components ±1, 0) per step.

use super::collision::{CollisionTable, site_random};
use super::velocities::{Q, VELOCITIES};
use rayon::prelude::*;

/// Positions (in the 16-bit word) of the vertices whose bit `axis` is 0.
const LOW: [u16; 4] = [0x5555, 0x3333, 0x0F0F, 0x00FF];

/// The word with every vertex v moved to v ^ (1 << axis).
#[inline]
fn flip(w: u16, axis: usize) -> u16 {
    let s = 1 << axis;
    ((w & LOW[axis]) << s) | ((w >> s) & LOW[axis])
}

/// Vertices whose bits (a, b) equal (ba, bb).
#[inline]
fn vertex_mask(a: usize, ba: bool, b: usize, bb: bool) -> u16 {
    let sel = |axis: usize, bit: bool| if bit { !LOW[axis] } else { LOW[axis] };
    sel(a, ba) & sel(b, bb)
}

/// The two nonzero axes and signs of velocity k.
fn axes(k: usize) -> ((usize, i8), (usize, i8)) {
    let c = VELOCITIES[k];
    let nz: Vec<usize> = (0..4).filter(|&a| c[a] != 0).collect();
    ((nz[0], c[nz[0]]), (nz[1], c[nz[1]]))
}

#[derive(Clone, Debug)]
pub struct LatticeGas {
    /// Cells along X, Y, Z.
    pub dims: [usize; 3],
    pub words: Vec<u16>,
    /// Seed of the collision / interference random stream.
    pub seed: u32,
    /// Probability p of the interference operation per (cell, velocity) and step.
    pub interference: f64,
    pub step: u32,
}

/// Totals that the dynamics conserves exactly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Invariants {
    pub particles: u64,
    pub momentum: [i64; 4],
}

impl LatticeGas {
    pub fn new(dims: [usize; 3], seed: u32, interference: f64) -> Self {
        let cells = dims[0] * dims[1] * dims[2];
        Self { dims, words: vec![0; Q * cells], seed, interference, step: 0 }
    }

    pub fn cells(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    pub fn cell_index(&self, x: usize, y: usize, z: usize) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    fn coords(&self, cell: usize) -> [usize; 3] {
        [cell % self.dims[0], (cell / self.dims[0]) % self.dims[1], cell / (self.dims[0] * self.dims[1])]
    }

    /// Occupation of velocity k at vertex v of a cell.
    pub fn get(&self, k: usize, cell: usize, v: usize) -> bool {
        self.words[k * self.cells() + cell] >> v & 1 == 1
    }

    pub fn set(&mut self, k: usize, cell: usize, v: usize, on: bool) {
        let n = self.cells();
        let w = &mut self.words[k * n + cell];
        if on { *w |= 1 << v } else { *w &= !(1 << v) }
    }

    /// Particle count and 4-momentum (integers, exact).
    pub fn invariants(&self) -> Invariants {
        let n = self.cells();
        let mut particles = 0u64;
        let mut momentum = [0i64; 4];
        for k in 0..Q {
            let count: u64 = self.words[k * n..(k + 1) * n].iter().map(|w| w.count_ones() as u64).sum();
            particles += count;
            for a in 0..4 {
                momentum[a] += VELOCITIES[k][a] as i64 * count as i64;
            }
        }
        Invariants { particles, momentum }
    }

    /// Collision at every site (seed 002 §3.3): the 24 bits of each site are replaced by a
    /// member of their class chosen by the counter-based stream of (seed, step, site).
    pub fn collide(&mut self, table: &CollisionTable) {
        let n = self.cells();
        let (seed, step) = (self.seed, self.step);
        let mut out = vec![[0u16; Q]; n];
        out.par_iter_mut().enumerate().for_each(|(cell, o)| {
            let mut w = [0u16; Q];
            for k in 0..Q {
                w[k] = self.words[k * n + cell];
            }
            for v in 0..16 {
                let mut s = 0u32;
                for k in 0..Q {
                    s |= ((w[k] >> v & 1) as u32) << k;
                }
                let t = table.collide(s, site_random(seed, step, (cell * 16 + v) as u32));
                for k in 0..Q {
                    o[k] |= ((t >> k & 1) as u16) << v;
                }
            }
        });
        for (cell, o) in out.iter().enumerate() {
            for k in 0..Q {
                self.words[k * n + cell] = o[k];
            }
        }
    }

    /// The interference operation (seed 002 §3.4, Fig. 2) on the departing particles: for
    /// velocity k (nonzero on axes a, b), the cell's 4 squares parallel to the (a, b) plane each
    /// have a diagonal perpendicular to c_k; its two ends form the sides A and B (4 vertices
    /// each). With probability p per (cell, velocity), the sparser side gets the AND and the
    /// denser side the OR of each pair (equal counts: unchanged) — particle number and momentum
    /// are conserved pair by pair.
    pub fn interfere(&mut self) {
        if self.interference <= 0.0 {
            return;
        }
        let n = self.cells();
        let threshold = (self.interference.min(1.0) * 4_294_967_296.0).min(4_294_967_295.0) as u64;
        let (seed, step) = (self.seed ^ 0x9e37_79b9, self.step);
        self.words.par_chunks_mut(n).enumerate().for_each(|(k, words)| {
            let ((a, sa), (b, sb)) = axes(k);
            // side A at offsets (s_a/2, −s_b/2), side B at (−s_a/2, s_b/2)
            let mask_a = vertex_mask(a, sa > 0, b, sb < 0);
            let mask_b = vertex_mask(a, sa < 0, b, sb > 0);
            for (cell, w) in words.iter_mut().enumerate() {
                if (site_random(seed, step, (cell * Q + k) as u32) as u64) >= threshold {
                    continue;
                }
                let u = *w & mask_a;
                let v = flip(flip(*w & mask_b, a), b); // B moved onto A's positions
                let (na, nb) = (u.count_ones(), v.count_ones());
                if na == nb {
                    continue;
                }
                let (and, or) = (u & v, u | v);
                let (new_a, new_b) = if na < nb { (and, or) } else { (or, and) };
                *w = (*w & !(mask_a | mask_b)) | new_a | flip(flip(new_b, a), b);
            }
        });
    }

    /// Propagation by bit operations: every particle moves by c_k; crossing a face of its cell
    /// it enters the neighbouring cell (periodic), along R it stays in the cell.
    pub fn propagate(&mut self) {
        let n = self.cells();
        let dims = self.dims;
        let old = std::mem::take(&mut self.words);
        let mut new = vec![0u16; Q * n];
        new.par_chunks_mut(n).enumerate().for_each(|(k, out)| {
            let ((a, sa), (b, sb)) = axes(k);
            let src = &old[k * n..(k + 1) * n];
            for (cell, o) in out.iter_mut().enumerate() {
                let c = [cell % dims[0], (cell / dims[0]) % dims[1], cell / (dims[0] * dims[1])];
                let mut acc = 0u16;
                for (ba, bb) in [(false, false), (false, true), (true, false), (true, true)] {
                    // source cell of the particles that start at vertices with bits (ba, bb)
                    let mut sc = [c[0] as i64, c[1] as i64, c[2] as i64];
                    for (axis, sign, bit) in [(a, sa, ba), (b, sb, bb)] {
                        if axis < 3 {
                            let shift = if sign > 0 && bit {
                                1
                            } else if sign < 0 && !bit {
                                -1
                            } else {
                                0
                            };
                            sc[axis] = (sc[axis] - shift).rem_euclid(dims[axis] as i64);
                        }
                    }
                    let s = ((sc[2] as usize * dims[1]) + sc[1] as usize) * dims[0] + sc[0] as usize;
                    acc |= flip(flip(src[s] & vertex_mask(a, ba, b, bb), a), b);
                }
                *o = acc;
            }
        });
        self.words = new;
    }

    /// One step: collision, interference, propagation.
    pub fn advance(&mut self, table: &CollisionTable) {
        self.collide(table);
        self.interfere();
        self.propagate();
        self.step = self.step.wrapping_add(1);
    }

    /// Momentum density (4D, per site) summed over the cells of each X column, as a function of
    /// the cell X index: Σ_k c_k popcount over the Y–Z plane, divided by the sites in the plane.
    pub fn momentum_profile_x(&self) -> Vec<[f64; 4]> {
        let n = self.cells();
        let mut out = vec![[0f64; 4]; self.dims[0]];
        for k in 0..Q {
            for cell in 0..n {
                let cnt = self.words[k * n + cell].count_ones() as f64;
                let x = self.coords(cell)[0];
                for a in 0..4 {
                    out[x][a] += VELOCITIES[k][a] as f64 * cnt;
                }
            }
        }
        let sites = (16 * self.dims[1] * self.dims[2]) as f64;
        out.iter_mut().for_each(|m| m.iter_mut().for_each(|x| *x /= sites));
        out
    }
}

impl LatticeGas {
    /// Fills every link with probability d (1 + 2 c_k·u(x)) — the linear equilibrium of the
    /// FCHC gas (D/c² = 2) with density d per link and velocity u at the site's 4D position
    /// x (in ℓ, cell centres at 2·index) — drawn from the counter-based stream of `seed`.
    pub fn fill(&mut self, density: f64, velocity: impl Fn([f64; 4]) -> [f64; 4] + Sync, seed: u32) {
        let n = self.cells();
        let dims = self.dims;
        let words: Vec<[u16; Q]> = (0..n)
            .into_par_iter()
            .map(|cell| {
                let c = [cell % dims[0], (cell / dims[0]) % dims[1], cell / (dims[0] * dims[1])];
                let mut w = [0u16; Q];
                for v in 0..16 {
                    let pos = [0, 1, 2, 3].map(|a| {
                        let off = if v >> a & 1 == 1 { 0.5 } else { -0.5 };
                        if a < 3 { 2.0 * c[a] as f64 + off } else { off }
                    });
                    let u = velocity(pos);
                    for k in 0..Q {
                        let cu: f64 = (0..4).map(|a| VELOCITIES[k][a] as f64 * u[a]).sum();
                        let f = (density * (1.0 + 2.0 * cu)).clamp(0.0, 1.0);
                        let r = site_random(seed, (k * 16 + v) as u32, cell as u32) as f64 / 4_294_967_296.0;
                        if r < f {
                            w[k] |= 1 << v;
                        }
                    }
                }
                w
            })
            .collect();
        for (cell, w) in words.iter().enumerate() {
            for k in 0..Q {
                self.words[k * n + cell] = w[k];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_operation_conserves_particles_and_momentum_exactly() {
        let table = CollisionTable::shared();
        let mut g = LatticeGas::new([6, 4, 5], 17, 0.3);
        g.fill(0.2, |x| [0.1 * (x[1] * 0.7).sin(), 0.05, -0.08 * (x[0] * 0.3).cos(), 0.0], 5);
        let start = g.invariants();
        println!("{start:?}");
        assert!(start.particles > 0 && start.momentum.iter().any(|&m| m != 0));
        for _ in 0..1000 {
            g.collide(table);
            assert_eq!(g.invariants(), start, "collision");
            g.interfere();
            assert_eq!(g.invariants(), start, "interference");
            g.propagate();
            assert_eq!(g.invariants(), start, "propagation");
            g.step += 1;
        }
    }

    #[test]
    fn propagation_moves_a_particle_by_its_velocity() {
        // a lone particle returns to its site after crossing a periodic box, and passes the
        // 4D positions x + t c_k on the way
        for k in 0..Q {
            let mut g = LatticeGas::new([3, 4, 5], 0, 0.0);
            g.set(k, g.cell_index(1, 2, 3), 0b0110, true);
            let pos = |g: &LatticeGas| {
                let n = g.cells();
                let (cell, w) = g.words[k * n..(k + 1) * n].iter().enumerate().find(|(_, w)| **w != 0).unwrap();
                let v = w.trailing_zeros() as usize;
                let c = g.coords(cell);
                [0, 1, 2, 3].map(|a| (if a < 3 { 2 * c[a] as i64 } else { 0 }) + if v >> a & 1 == 1 { 1 } else { 0 })
            };
            let p0 = pos(&g);
            for t in 1..=60i64 {
                g.propagate();
                let p = pos(&g);
                for a in 0..4 {
                    let period = if a < 3 { 2 * g.dims[a] as i64 } else { 2 };
                    assert_eq!((p[a] - p0[a] - t * VELOCITIES[k][a] as i64).rem_euclid(period), 0, "velocity {k} axis {a} step {t}");
                }
            }
        }
    }
}
