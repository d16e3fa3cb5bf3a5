//! State of the FCHC lattice gas on the CPU (seed 002 §3.1–3.2): 4D cells of side ℓ whose
//! centres repeat every 2ℓ in X, Y, Z (the 4th coordinate R holds one cell, periodic), 16 vertex
//! sites per cell, one bit per (site, velocity). Four cells along X share one u64 per velocity
//! (lane = cell index mod 4, see [`super::bits`]); a block is the 24 words of four cells.
//!
//! Units: positions in ℓ (integer 4D site coordinates: a site of cell (x, y, z) at vertex v sits
//! at (2x + b_X, 2y + b_Y, 2z + b_Z, b_R)), time in steps; a particle moves by c_k per step.

use super::collision::site_random;
use super::velocities::{Q, VELOCITIES};
use rayon::prelude::*;

/// Cells per u64 word along X.
pub const LANES: usize = 4;

/// The 24 words (one per velocity) of four consecutive cells along X.
pub type Block = [u64; Q];

/// The outlet of a channel (the last cell of every X row), applied after propagation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outlet {
    /// Zero gradient: a copy of the cell before it (seed 002 §3.5). Fixes no pressure level:
    /// with the inlet fixing only the incoming populations, the mean density can drift.
    #[default]
    Copy,
    /// Refilled with the inlet's free-stream equilibrium, like the inlet: pins the density (and
    /// so the pressure) at both ends, at the price of forcing the wake back to the free stream in
    /// the last cell.
    FreeStream,
}

/// The square diagonals along which the interference operation (seed 002 §3.4) exchanges a
/// velocity's departing particles. Of the 6 families of 4 parallel squares in a cell, two have
/// diagonals perpendicular to c_k: the squares of c_k's own plane (one diagonal) and those of the
/// complementary plane, where c_k is zero (both diagonals).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum Diagonals {
    /// The perpendicular diagonal of c_k's own plane only (one draw per cell and velocity).
    #[default]
    OwnPlane,
    /// Also both diagonals of the complementary plane, each with its own draw: every family
    /// with a diagonal perpendicular to c_k (three draws per cell and velocity).
    AllPerpendicular,
}

impl Diagonals {
    /// The name in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::OwnPlane => "own_plane",
            Self::AllPerpendicular => "all_perpendicular",
        }
    }
}

/// Inflow of a channel scene (seed 002 §3.5): the inlet cells (X = 0) are refilled every step
/// with the equilibrium at this density and +X velocity; the last cells follow [`Outlet`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inlet {
    /// Particles per link.
    pub density: f64,
    /// Velocity (ℓ per step) along +X.
    pub velocity: f64,
    /// Per velocity, the threshold t_k with P(bit) = t_k / 2³² = d (1 + 2 c_kX U).
    pub thresholds: [u32; Q],
    pub outlet: Outlet,
}

impl Inlet {
    pub fn new(density: f64, velocity: f64, outlet: Outlet) -> Self {
        let thresholds = std::array::from_fn(|k| probability_threshold(density * (1.0 + 2.0 * VELOCITIES[k][0] as f64 * velocity)));
        Self { density, velocity, thresholds, outlet }
    }
}

/// The u32 threshold of a probability: a uniform u32 below it has that probability (clamped to
/// [0, 1 − 2⁻³²]); integer, so that every backend draws the same bits.
pub fn probability_threshold(p: f64) -> u32 {
    (p.clamp(0.0, 1.0) * 4_294_967_296.0).min(4_294_967_295.0) as u32
}

#[derive(Clone, Debug)]
pub struct LatticeGas {
    /// Cells along X, Y, Z (X a multiple of [`LANES`]).
    pub dims: [usize; 3],
    /// Blocks, X fastest: block (xb, y, z) at `(z · n_y + y) · n_x/4 + xb`.
    pub blocks: Vec<Block>,
    /// Obstacle cells (bounce-back), cell index x fastest.
    pub solid: Vec<bool>,
    /// Seed of the collision / interference / inlet random streams.
    pub seed: u32,
    /// Probability p of the interference operation per (cell, velocity, diagonal) and step.
    pub interference: f64,
    /// Which diagonals the interference exchanges along ([`Diagonals`]).
    pub diagonals: Diagonals,
    /// `None`: periodic in X too; `Some`: inlet at X = 0, zero-gradient outlet at the last X.
    pub inlet: Option<Inlet>,
    pub step: u32,
    /// Propagation's destination, kept between steps (its content is no state): a fresh
    /// zeroed array per step cost a page fault per 4 KiB.
    pub(super) spare: Vec<Block>,
}

/// Totals that the dynamics conserves exactly (in periodic boxes without obstacles).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Invariants {
    pub particles: u64,
    pub momentum: [i64; 4],
}

impl LatticeGas {
    /// An empty gas. `dims[0]` must be a positive multiple of 4 (four cells per u64) and the
    /// other dimensions positive (scene validation reports these before allocating).
    pub fn new(dims: [usize; 3], seed: u32, interference: f64) -> Self {
        assert!(
            dims[0] > 0 && dims[0].is_multiple_of(LANES) && dims[1] > 0 && dims[2] > 0,
            "lattice gas cells {dims:?}: X must be a positive multiple of {LANES}"
        );
        let cells = dims[0] * dims[1] * dims[2];
        Self {
            dims,
            blocks: vec![[0; Q]; cells / LANES],
            solid: vec![false; cells],
            seed,
            interference,
            diagonals: Diagonals::default(),
            inlet: None,
            step: 0,
            spare: Vec::new(),
        }
    }

    pub fn cells(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    pub fn cell_index(&self, x: usize, y: usize, z: usize) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    pub fn coords(&self, cell: usize) -> [usize; 3] {
        [cell % self.dims[0], (cell / self.dims[0]) % self.dims[1], cell / (self.dims[0] * self.dims[1])]
    }

    /// The 16-bit word of velocity k in a cell (bit v = a particle at vertex v).
    #[inline]
    pub fn cell_word(&self, k: usize, cell: usize) -> u16 {
        (self.blocks[cell / LANES][k] >> (16 * (cell % LANES))) as u16
    }

    pub fn set_cell_word(&mut self, k: usize, cell: usize, w: u16) {
        let shift = 16 * (cell % LANES);
        let word = &mut self.blocks[cell / LANES][k];
        *word = (*word & !(0xFFFF << shift)) | ((w as u64) << shift);
    }

    /// Occupation of velocity k at vertex v of a cell.
    pub fn get(&self, k: usize, cell: usize, v: usize) -> bool {
        self.cell_word(k, cell) >> v & 1 == 1
    }

    pub fn set(&mut self, k: usize, cell: usize, v: usize, on: bool) {
        let w = self.cell_word(k, cell);
        self.set_cell_word(k, cell, if on { w | 1 << v } else { w & !(1 << v) });
    }

    /// Every cell word, velocity-major (`[k · cells + cell]`): the backend-neutral form that
    /// parity tests compare and the GPU uploads.
    pub fn cell_words(&self) -> Vec<u16> {
        let n = self.cells();
        let mut out = vec![0u16; Q * n];
        for k in 0..Q {
            for cell in 0..n {
                out[k * n + cell] = self.cell_word(k, cell);
            }
        }
        out
    }

    /// Replaces the state by velocity-major cell words (the inverse of [`Self::cell_words`]).
    pub fn set_cell_words(&mut self, words: &[u16]) {
        let n = self.cells();
        assert_eq!(words.len(), Q * n);
        for k in 0..Q {
            for cell in 0..n {
                self.set_cell_word(k, cell, words[k * n + cell]);
            }
        }
    }

    /// Particle count and 4-momentum (integers, exact).
    pub fn invariants(&self) -> Invariants {
        let counts: Vec<u64> = (0..Q).map(|k| self.blocks.iter().map(|b| b[k].count_ones() as u64).sum()).collect();
        let mut momentum = [0i64; 4];
        for (k, &c) in counts.iter().enumerate() {
            for a in 0..4 {
                momentum[a] += VELOCITIES[k][a] as i64 * c as i64;
            }
        }
        Invariants { particles: counts.iter().sum(), momentum }
    }

    /// Particle count and 4-momentum of one cell (integers).
    #[inline]
    pub fn cell_moments(&self, cell: usize) -> (u64, [i64; 4]) {
        let (mut n, mut j) = (0u64, [0i64; 4]);
        for k in 0..Q {
            let c = self.cell_word(k, cell).count_ones() as i64;
            n += c as u64;
            for a in 0..4 {
                j[a] += VELOCITIES[k][a] as i64 * c;
            }
        }
        (n, j)
    }

    /// Momentum density (4D, per site) of every X column of cells, summed over the Y–Z plane and
    /// divided by its sites.
    pub fn momentum_profile_x(&self) -> Vec<[f64; 4]> {
        let mut out = vec![[0f64; 4]; self.dims[0]];
        for cell in 0..self.cells() {
            let j = self.cell_moments(cell).1;
            for a in 0..4 {
                out[cell % self.dims[0]][a] += j[a] as f64;
            }
        }
        let sites = (16 * self.dims[1] * self.dims[2]) as f64;
        out.iter_mut().for_each(|m| m.iter_mut().for_each(|x| *x /= sites));
        out
    }

    /// Fills every fluid link with probability d (1 + 2 c_k·u(x)) — the linear equilibrium of the
    /// FCHC gas (D/c² = 2) with density d per link and velocity u at the site's 4D position x (in
    /// ℓ) — drawn from the counter-based stream of `seed`; obstacle cells are left empty.
    pub fn fill(&mut self, density: f64, velocity: impl Fn([f64; 4]) -> [f64; 4] + Sync, seed: u32) {
        let dims = self.dims;
        let solid = &self.solid;
        self.blocks.par_iter_mut().enumerate().for_each(|(bi, block)| {
            *block = [0; Q];
            for lane in 0..LANES {
                let cell = bi * LANES + lane;
                if solid[cell] {
                    continue;
                }
                let c = [cell % dims[0], (cell / dims[0]) % dims[1], cell / (dims[0] * dims[1])];
                for v in 0..16 {
                    let pos = [0, 1, 2, 3].map(|a| {
                        let off = if v >> a & 1 == 1 { 0.5 } else { -0.5 };
                        if a < 3 { 2.0 * c[a] as f64 + off } else { off }
                    });
                    let u = velocity(pos);
                    for (k, word) in block.iter_mut().enumerate() {
                        let cu: f64 = (0..4).map(|a| VELOCITIES[k][a] as f64 * u[a]).sum();
                        let t = probability_threshold(density * (1.0 + 2.0 * cu));
                        if site_random(seed, (k * 16 + v) as u32, cell as u32) < t {
                            *word |= 1 << (16 * lane + v);
                        }
                    }
                }
            }
        });
    }

    /// Marks the cells whose centre (in ℓ: 2x, 2y) lies within `radius` (ℓ) of `center` (ℓ, in
    /// the X–Y plane) as obstacle, for every Z (an infinite cylinder along Z), and empties them.
    pub fn add_cylinder(&mut self, center: [f64; 2], radius: f64) {
        for cell in 0..self.cells() {
            let c = self.coords(cell);
            let (dx, dy) = (2.0 * c[0] as f64 - center[0], 2.0 * c[1] as f64 - center[1]);
            if dx * dx + dy * dy <= radius * radius {
                self.solid[cell] = true;
                for k in 0..Q {
                    self.set_cell_word(k, cell, 0);
                }
            }
        }
    }
}
