//! One step of the lattice gas on the CPU, stage by stage as [`crate::stages::LATTICE_GAS_STEP`]
//! lists them: collision (seed 002 §3.3), interference (§3.4), propagation by bit shifts (§3.3)
//! and the channel boundaries (§3.5). Blocks are processed in parallel (rayon).

use super::bits::{OWN_PLANE_EXCHANGES, complementary_sides, exchange_lane, propagation_moves, replicate64, transpose64};
use super::collision::{COMPLEMENTARY_STREAM, CollisionTable, INLET_STREAM, INTERFERENCE_STREAM, keyed_random, site_random, stream_key};
use super::lattice::{Block, Diagonals, LANES, LatticeGas, probability_threshold};
use super::velocities::{Q, opposite};
use crate::stages::{LATTICE_GAS_STEP, LatticeGasStageKind};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Accumulated wall time per stage of [`LATTICE_GAS_STEP`].
#[derive(Clone, Debug, Default)]
pub struct LatticeGasTimings {
    pub total: [Duration; LATTICE_GAS_STEP.len()],
    pub steps: u64,
}

impl LatticeGasTimings {
    pub fn report(&self) -> Vec<(&'static str, f64)> {
        crate::stages::time_shares(LATTICE_GAS_STEP.iter().map(|s| s.name).zip(&self.total))
    }
}

impl LatticeGas {
    /// Collision at every site (seed 002 §3.3): a fluid site's 24 bits are replaced by a member
    /// of their class chosen by the counter-based stream of (seed, step, site = 16·cell + v); an
    /// obstacle site reverses every particle (bounce-back: no-slip on the obstacle).
    pub fn collide(&mut self, table: &CollisionTable) {
        let collision = Collision::new(table, self.seed, self.step, &self.solid);
        self.blocks.par_chunks_mut(COLLISION_CHUNK).enumerate().for_each(|(c, blocks)| collision.apply(c * COLLISION_CHUNK, blocks, None));
    }

    /// [`Self::collide`] then [`Self::interfere`], block by block in one pass over the gas (the
    /// GPU's `collide_interfere` kernel): what a whole step runs, the same bits as the two
    /// stages one after the other (each block's interference touches only its own cells).
    pub fn collide_interfere(&mut self, table: &CollisionTable) {
        let collision = Collision::new(table, self.seed, self.step, &self.solid);
        let interference = Interference::new(self.interference, self.diagonals, self.seed, self.step, &self.solid);
        self.blocks.par_chunks_mut(COLLISION_CHUNK).enumerate().for_each(|(c, blocks)| collision.apply(c * COLLISION_CHUNK, blocks, interference.as_ref()));
    }

    /// The collision of [`Self::collide`] written site by site: each site's 24 bits gathered from
    /// the velocity words one at a time and scattered back the same way, with the full three-hash
    /// stream per site and the table read through the class index. The plain statement of the operation, kept as the reference that the
    /// transposed kernel must match bit for bit (test below) and that `bench` times it against.
    pub fn collide_site_by_site(&mut self, table: &CollisionTable) {
        let (seed, step, solid) = (self.seed, self.step, &self.solid);
        self.blocks.par_iter_mut().enumerate().for_each(|(bi, block)| {
            let mut out: Block = [0; Q];
            for lane in 0..LANES {
                let cell = bi * LANES + lane;
                if solid[cell] {
                    let m = 0xFFFFu64 << (16 * lane);
                    for k in 0..Q {
                        out[opposite(k)] |= block[k] & m;
                    }
                    continue;
                }
                for v in 0..16 {
                    let bit = 16 * lane + v;
                    let s = (0..Q).fold(0u32, |s, k| s | (((block[k] >> bit) & 1) as u32) << k);
                    let t = table.collide_by_class(s, site_random(seed, step, (cell * 16 + v) as u32));
                    for (k, o) in out.iter_mut().enumerate() {
                        *o |= ((t >> k) & 1) as u64 * (1 << bit);
                    }
                }
            }
            *block = out;
        });
    }

    /// The interference operation (seed 002 §3.4, Fig. 2; see `Interference`) on every fluid
    /// cell and velocity.
    pub fn interfere(&mut self) {
        let Some(interference) = Interference::new(self.interference, self.diagonals, self.seed, self.step, &self.solid) else { return };
        self.blocks.par_iter_mut().enumerate().for_each(|(bi, block)| interference.apply(bi, block));
    }

    /// Propagation by bit operations (seed 002 §3.3): every particle moves by c_k; crossing a
    /// face of its cell it enters the neighbouring cell (periodic in X, Y, Z), along R it stays in
    /// the cell. Pull form: each destination block gathers, per velocity and quadrant of source
    /// vertices, the source row's word — shifted by one lane (16 bits) when the move crosses X.
    pub fn propagate(&mut self) {
        let [nx, ny, nz] = self.dims;
        let nb = nx / LANES;
        let moves: [[(u64, [i64; 3], u32); 4]; Q] = std::array::from_fn(|k| propagation_moves(k).map(|(m, o, r)| (replicate64(m), o, r)));
        let old = std::mem::take(&mut self.blocks);
        // every word of every block is written below, so the spare's old content is never read
        let mut new = std::mem::take(&mut self.spare);
        new.resize(old.len(), [0; Q]);
        new.par_iter_mut().enumerate().for_each(|(bi, out)| {
            let (xb, y, z) = (bi % nb, (bi / nb) % ny, bi / (nb * ny));
            // the source rows at (y + dy, z + dz), dy, dz ∈ {−1, 0, 1} (periodic), and the
            // neighbouring words along X, found once per block rather than once per move
            let wrap = |c: usize, d: i64, n: usize| (c + n).wrapping_add_signed(d as isize) % n;
            let rows: [[usize; 3]; 3] = std::array::from_fn(|dz| std::array::from_fn(|dy| (wrap(z, dz as i64 - 1, nz) * ny + wrap(y, dy as i64 - 1, ny)) * nb));
            let (west, east) = ((xb + nb - 1) % nb, (xb + 1) % nb);
            for k in 0..Q {
                let mut acc = 0u64;
                for &(mask, off, rotation) in &moves[k] {
                    let row = rows[(off[2] + 1) as usize][(off[1] + 1) as usize];
                    let here = old[row + xb][k];
                    let src = match off[0] {
                        0 => here,
                        // sources one cell to the −X side: lanes move up, lane 0 from the previous word
                        -1 => (here << 16) | (old[row + west][k] >> 48),
                        _ => (here >> 16) | (old[row + east][k] << 48),
                    };
                    // the quadrant's vertices flipped on both axes of c_k: one rotation
                    acc |= (src & mask).rotate_left(rotation);
                }
                out[k] = acc;
            }
        });
        self.blocks = new;
        self.spare = old;
    }

    /// Channel boundaries (seed 002 §3.5), after propagation: the last cell of every X row
    /// copies the one before it (zero-gradient outlet) or is refilled with the free stream
    /// ([`super::lattice::Outlet`]), and the first cell is refilled with the inlet's equilibrium
    /// (bits drawn from the stream of (seed ^ [`INLET_STREAM`], 24·step + k, 16·cell + v)).
    /// Nothing in periodic boxes.
    pub fn boundaries(&mut self) {
        let Some(inlet) = self.inlet else { return };
        let nb = self.dims[0] / LANES;
        let (seed, step, nx) = (self.seed ^ INLET_STREAM, self.step, self.dims[0]);
        let keys: [u32; Q] = std::array::from_fn(|k| stream_key(seed, step.wrapping_mul(Q as u32).wrapping_add(k as u32)));
        // the free-stream equilibrium of one cell, as a 16-bit lane per velocity
        let draw = |cell: usize, k: usize| {
            let mut lane = 0u64;
            for v in 0..16 {
                if keyed_random(keys[k], (cell * 16 + v) as u32) < inlet.thresholds[k] {
                    lane |= 1 << v;
                }
            }
            lane
        };
        self.blocks.par_chunks_mut(nb).enumerate().for_each(|(row, blocks)| {
            let last = row * nx + nx - 1;
            for (k, w) in blocks[nb - 1].iter_mut().enumerate() {
                let lane = match inlet.outlet {
                    super::lattice::Outlet::Copy => (*w >> 32) & 0xFFFF,
                    super::lattice::Outlet::FreeStream => draw(last, k),
                };
                *w = (*w & 0x0000_FFFF_FFFF_FFFF) | (lane << 48);
            }
            for (k, w) in blocks[0].iter_mut().enumerate() {
                *w = (*w & !0xFFFF) | draw(row * nx, k);
            }
        });
    }

    /// Runs one stage of [`LATTICE_GAS_STEP`] on its own.
    pub fn run_stage(&mut self, kind: LatticeGasStageKind, table: &CollisionTable) {
        match kind {
            LatticeGasStageKind::Collide => self.collide(table),
            LatticeGasStageKind::Interfere => self.interfere(),
            LatticeGasStageKind::Propagate => self.propagate(),
            LatticeGasStageKind::Boundaries => self.boundaries(),
        }
    }

    /// Runs a stage of [`LATTICE_GAS_STEP`] as a whole step runs it: the collide stage also
    /// interferes ([`Self::collide_interfere`], as the GPU's step does), so the interfere stage
    /// has nothing left to do. The same bits as [`Self::run_stage`] of every stage in order.
    pub fn run_step_stage(&mut self, kind: LatticeGasStageKind, table: &CollisionTable) {
        match kind {
            LatticeGasStageKind::Collide => self.collide_interfere(table),
            LatticeGasStageKind::Interfere => {}
            kind => self.run_stage(kind, table),
        }
    }

    /// One step: the stages of [`LATTICE_GAS_STEP`] in order ([`Self::run_step_stage`]), then
    /// the step counter.
    pub fn advance(&mut self, table: &CollisionTable) {
        for s in LATTICE_GAS_STEP {
            self.run_step_stage(s.kind, table);
        }
        self.step = self.step.wrapping_add(1);
    }

    /// [`Self::advance`] with each stage's wall time added to `timings` (the interference's
    /// time falls in the collide stage's).
    pub fn advance_timed(&mut self, table: &CollisionTable, timings: &mut LatticeGasTimings) {
        self.advance_timed_by(table, timings, |g, kind, table| g.run_step_stage(kind, table));
    }

    /// [`Self::advance_timed`] with each stage run by `run` (the benchmark swaps in the
    /// site-by-site collision).
    pub fn advance_timed_by(
        &mut self,
        table: &CollisionTable,
        timings: &mut LatticeGasTimings,
        mut run: impl FnMut(&mut Self, LatticeGasStageKind, &CollisionTable),
    ) {
        for (i, s) in LATTICE_GAS_STEP.iter().enumerate() {
            let t0 = Instant::now();
            run(self, s.kind, table);
            timings.total[i] += t0.elapsed();
        }
        timings.steps += 1;
        self.step = self.step.wrapping_add(1);
    }
}

/// Blocks per parallel task of the collision (48 KiB of state): long enough that the start and
/// end of [`Collision::apply`]'s pipeline (two blocks each) cost little, short enough for rayon
/// to balance the threads.
const COLLISION_CHUNK: usize = 256;

/// The collision of one step: its stream and the obstacle cells.
struct Collision<'a> {
    table: &'a CollisionTable,
    key: u32,
    solid: &'a [bool],
}

impl<'a> Collision<'a> {
    fn new(table: &'a CollisionTable, seed: u32, step: u32, solid: &'a [bool]) -> Self {
        Self { table, key: stream_key(seed, step), solid }
    }

    /// The collision of the blocks `first..first + blocks.len()`, then `interference` on each.
    /// A block's 24 velocity words become its 64 sites' states by one bit-matrix transpose
    /// ([`transpose64`]) and go back by another, instead of 24 single-bit moves per site each
    /// way; its 64 sites collide together ([`CollisionTable::collide64`]; site i of block b is
    /// 16·cell + v = 64·b + i) and its obstacle cells bounce back. The three phases of the
    /// collision run software-pipelined over the blocks — block j's class keys while block
    /// j − 1's member indices and block j − 2's member reads — so that each phase's table reads
    /// were prefetched a block earlier instead of waiting on the memory (a step ≈ 1.2× faster
    /// than with one block's phases back to back, measured on the 2-core test machine).
    fn apply(&self, first: usize, blocks: &mut [Block], interference: Option<&Interference>) {
        let n = blocks.len();
        let mut sites = [[0u64; 64]; 3];
        let (mut keys, mut index) = ([[0u32; 64]; 2], [[0u32; 64]; 2]);
        for j in 0..n + 2 {
            if j < n {
                let s = &mut sites[j % 3];
                s[..Q].copy_from_slice(&blocks[j]);
                s[Q..].fill(0);
                transpose64(s);
                self.table.class_keys(s, &mut keys[j % 2]);
            }
            if (1..=n).contains(&j) {
                let b = j - 1;
                self.table.member_indices(&keys[b % 2], self.key, ((first + b) * 64) as u32, &mut index[b % 2]);
            }
            if j >= 2 {
                let b = j - 2;
                let s = &mut sites[b % 3];
                self.table.read_members(&index[b % 2], s);
                let (bi, block) = (first + b, &mut blocks[b]);
                let mut bounced: Block = [0; Q];
                for lane in 0..LANES {
                    if self.solid[bi * LANES + lane] {
                        let m = 0xFFFFu64 << (16 * lane);
                        for k in 0..Q {
                            bounced[opposite(k)] |= block[k] & m;
                        }
                        s[16 * lane..16 * lane + 16].fill(0);
                    }
                }
                transpose64(s);
                for k in 0..Q {
                    block[k] = s[k] | bounced[k];
                }
                if let Some(interference) = interference {
                    interference.apply(bi, block);
                }
            }
        }
    }
}

/// The interference of one step (seed 002 §3.4, Fig. 2; see [`super::bits::interfere_lane`]):
/// on every fluid cell and velocity, with probability p drawn from the stream of
/// (seed ^ [`INTERFERENCE_STREAM`], step, 24·cell + k); with [`Diagonals::AllPerpendicular`]
/// then the two complementary-plane exchanges ([`super::bits::complementary_sides`]), each with
/// its own draw from (seed ^ [`INTERFERENCE_STREAM`] ^ [`COMPLEMENTARY_STREAM`], step,
/// 2·(24·cell + k) + diagonal).
struct Interference<'a> {
    threshold: u32,
    key: u32,
    complementary_key: u32,
    solid: &'a [bool],
    diagonals: Diagonals,
}

impl<'a> Interference<'a> {
    /// `None` when p = 0 (nothing to do).
    fn new(p: f64, diagonals: Diagonals, seed: u32, step: u32, solid: &'a [bool]) -> Option<Self> {
        if p <= 0.0 {
            return None;
        }
        let seed = seed ^ INTERFERENCE_STREAM;
        Some(Self {
            threshold: probability_threshold(p),
            key: stream_key(seed, step),
            complementary_key: stream_key(seed ^ COMPLEMENTARY_STREAM, step),
            solid,
            diagonals,
        })
    }

    /// The interference on the four cells of block `bi`.
    #[inline]
    fn apply(&self, bi: usize, block: &mut Block) {
        for lane in 0..LANES {
            let cell = bi * LANES + lane;
            if self.solid[cell] {
                continue;
            }
            let shift = 16 * lane;
            // the cell's 24 draws first, in one loop the compiler can vectorise
            let base = (cell * Q) as u32;
            let draws: [u32; Q] = std::array::from_fn(|k| keyed_random(self.key, base.wrapping_add(k as u32)));
            // the velocities drawn (a fraction p of them), as bits: a loop over those alone
            // instead of a branch per velocity that mispredicts a fraction p of the time
            let mut drawn = draws.iter().enumerate().fold(0u32, |m, (k, &d)| m | ((d < self.threshold) as u32) << k);
            while drawn != 0 {
                let k = drawn.trailing_zeros() as usize;
                drawn &= drawn - 1;
                let (mask_a, mask_b, a, b) = OWN_PLANE_EXCHANGES[k];
                let w = &mut block[k];
                let new = exchange_lane((*w >> shift) as u16, mask_a, mask_b, a, b);
                *w = (*w & !(0xFFFF << shift)) | ((new as u64) << shift);
            }
            if self.diagonals == Diagonals::AllPerpendicular {
                for (k, w) in block.iter_mut().enumerate() {
                    for (j, (ma, mb, p, q)) in complementary_sides(k).into_iter().enumerate() {
                        if keyed_random(self.complementary_key, ((cell * Q + k) * 2 + j) as u32) >= self.threshold {
                            continue;
                        }
                        let new = exchange_lane((*w >> shift) as u16, ma, mb, p, q);
                        *w = (*w & !(0xFFFF << shift)) | ((new as u64) << shift);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::velocities::VELOCITIES;
    use super::*;

    #[test]
    fn every_operation_conserves_particles_and_momentum_exactly() {
        let table = CollisionTable::shared();
        let mut finals = Vec::new();
        for diagonals in [Diagonals::OwnPlane, Diagonals::AllPerpendicular] {
            let mut g = LatticeGas::new([8, 4, 5], 17, 0.3);
            g.diagonals = diagonals;
            g.fill(0.2, |x| [0.1 * (x[1] * 0.7).sin(), 0.05, -0.08 * (x[0] * 0.3).cos(), 0.0], 5);
            let start = g.invariants();
            println!("{diagonals:?}: {start:?}");
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
            finals.push(g.blocks);
        }
        // the complementary-plane exchanges do act
        assert_ne!(finals[0], finals[1]);
    }

    /// A gas with a sheared fill and eight obstacle cells among the fluid ones.
    fn gas_with_obstacles(dims: [usize; 3], seed: u32, p: f64, fill: f64) -> LatticeGas {
        let mut g = LatticeGas::new(dims, seed, p);
        g.fill(fill, |x| [0.1 * (x[1] * 0.5).sin(), 0.05, 0.0, 0.0], 4);
        for c in [1, 6, 7, 40, 41, 42, 43, 200] {
            g.solid[c] = true;
        }
        g
    }

    #[test]
    fn the_transposed_collision_matches_the_site_by_site_one_bit_for_bit() {
        // with obstacle cells among fluid ones, over several steps (each step its own stream);
        // 288 blocks: two tasks of the pipelined collision, the second shorter
        let table = CollisionTable::shared();
        let mut g = gas_with_obstacles([16, 9, 8], 23, 0.0, 0.3);
        assert!(g.blocks.len() > COLLISION_CHUNK && !g.blocks.len().is_multiple_of(COLLISION_CHUNK));
        let mut h = g.clone();
        for _ in 0..4 {
            g.collide(table);
            h.collide_site_by_site(table);
            assert_eq!(g.blocks, h.blocks, "step {}", g.step);
            g.propagate();
            h.propagate();
            g.step += 1;
            h.step += 1;
        }
        assert!(g.invariants().particles > 0);
    }

    #[test]
    fn a_whole_step_with_the_fused_collision_is_every_stage_in_turn_bit_for_bit() {
        // obstacles, a channel inlet and both interference variants (the fused pass must draw
        // what the separate interference stage draws)
        let table = CollisionTable::shared();
        for diagonals in [Diagonals::OwnPlane, Diagonals::AllPerpendicular] {
            let mut g = gas_with_obstacles([16, 6, 5], 29, 0.4, 0.25);
            g.diagonals = diagonals;
            g.inlet = Some(super::super::lattice::Inlet::new(0.2, 0.1, super::super::lattice::Outlet::Copy));
            let mut by_stage = g.clone();
            for _ in 0..6 {
                g.advance(table);
                for s in LATTICE_GAS_STEP {
                    by_stage.run_stage(s.kind, table);
                }
                by_stage.step += 1;
                assert_eq!(g.blocks, by_stage.blocks, "{diagonals:?}, step {}", g.step);
            }
            assert!(g.invariants().particles > 0);
        }
    }

    #[test]
    fn propagation_moves_a_particle_by_its_velocity() {
        // a lone particle returns to its site after crossing a periodic box, and passes the
        // 4D positions x + t c_k on the way (crossing u64 word boundaries along X)
        for k in 0..Q {
            let mut g = LatticeGas::new([8, 3, 5], 0, 0.0);
            let c = g.cell_index(3, 2, 1);
            g.set(k, c, 0b0110, true);
            let pos = |g: &LatticeGas| {
                let cell = (0..g.cells()).find(|&c| g.cell_word(k, c) != 0).unwrap();
                let v = g.cell_word(k, cell).trailing_zeros() as usize;
                assert_eq!(g.invariants().particles, 1);
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

    #[test]
    fn obstacle_cells_reverse_every_particle_and_channel_boundaries_inject_and_copy() {
        let table = CollisionTable::shared();
        // bounce-back: the particles of an obstacle cell reverse, count unchanged
        let mut g = LatticeGas::new([4, 2, 2], 3, 0.0);
        g.solid[1] = true;
        g.set(0, 1, 5, true);
        g.set(7, 1, 9, true);
        g.collide(table);
        assert!(g.get(opposite(0), 1, 5) && g.get(opposite(7), 1, 9));
        assert_eq!(g.invariants().particles, 2);
        // channel: the inlet cells hold the equilibrium d (1 + 2 c_kX U) per link, the last cell
        // equals the one before it
        let (d, u) = (0.2, 0.15);
        let mut g = LatticeGas::new([8, 16, 16], 9, 0.0);
        g.inlet = Some(super::super::lattice::Inlet::new(d, u, super::super::lattice::Outlet::Copy));
        g.fill(d, |_| [0.0; 4], 1);
        let (mut plus, mut minus, mut zero, mut n) = (0u64, 0u64, 0u64, 0u64);
        for _ in 0..20 {
            g.advance(table);
            for y in 0..16 {
                for z in 0..16 {
                    for k in 0..Q {
                        let c = g.cell_word(k, g.cell_index(0, y, z)).count_ones() as u64;
                        match VELOCITIES[k][0] {
                            1 => plus += c,
                            -1 => minus += c,
                            _ => zero += c,
                        }
                        assert_eq!(g.cell_word(k, g.cell_index(7, y, z)), g.cell_word(k, g.cell_index(6, y, z)));
                    }
                }
            }
            n += 16 * 16 * 16 * 6;
        }
        let (fp, fm, f0) = (plus as f64 / n as f64, minus as f64 / n as f64, zero as f64 / (2 * n) as f64);
        println!("inlet occupation: +X {fp:.4} (expected {:.4}), −X {fm:.4} ({:.4}), 0 {f0:.4} ({d})", d * (1.0 + 2.0 * u), d * (1.0 - 2.0 * u));
        // binomial standard error √(f(1−f)/n) ≈ 1.4e-3 for n = 122,880 links: 4σ bounds
        let tol = 4.0 * (0.3 * 0.7 / n as f64).sqrt();
        assert!((fp - d * (1.0 + 2.0 * u)).abs() < tol && (fm - d * (1.0 - 2.0 * u)).abs() < tol && (f0 - d).abs() < tol);
    }

    /// The state with the spatial axes a and b (< 3) exchanged: cells, velocities and vertex bits.
    fn swap_axes(g: &LatticeGas, a: usize, b: usize) -> LatticeGas {
        let mut h = LatticeGas::new(g.dims, g.seed, g.interference);
        h.step = g.step;
        h.diagonals = g.diagonals;
        let velocity = |k: usize| {
            let mut c = VELOCITIES[k];
            c.swap(a, b);
            VELOCITIES.iter().position(|x| *x == c).unwrap()
        };
        for cell in 0..g.cells() {
            let mut xyz = g.coords(cell);
            xyz.swap(a, b);
            let to = h.cell_index(xyz[0], xyz[1], xyz[2]);
            for k in 0..Q {
                for v in (0..16).filter(|&v| g.get(k, cell, v)) {
                    let (ba, bb) = ((v >> a) & 1, (v >> b) & 1);
                    h.set(velocity(k), to, (v & !(1 << a) & !(1 << b)) | (bb << a) | (ba << b), true);
                }
            }
        }
        h
    }

    #[test]
    fn interference_and_propagation_commute_with_permutations_of_x_y_z() {
        // the lattice singles out no spatial axis: exchanging two of X, Y, Z before the
        // interference (p = 1, no random draw) and the propagation gives the exchanged result, bit
        // for bit — so a preferred direction that the gas picks (isotropy.rs) is its own choice.
        // The collision is symmetric in distribution (uniform in the class).
        for diagonals in [Diagonals::OwnPlane, Diagonals::AllPerpendicular] {
            for (a, b) in [(0, 1), (0, 2), (1, 2)] {
                let mut g = LatticeGas::new([8, 8, 8], 5, 1.0);
                g.diagonals = diagonals;
                g.fill(0.3, |x| [0.05 * x[1].sin(), 0.0, 0.02, 0.0], 9);
                let mut swapped = swap_axes(&g, a, b);
                for _ in 0..3 {
                    g.interfere();
                    g.propagate();
                    swapped.interfere();
                    swapped.propagate();
                }
                assert_eq!(swap_axes(&swapped, a, b).blocks, g.blocks, "axes {a} and {b}, {diagonals:?}");
                assert!(g.invariants().particles > 0);
            }
        }
    }
}
