//! Coarse-graining (seed 002 §3.5): the particles of blocks of B × B × B cells (4 × 4 × 4 in the
//! seed) are summed into a density and a momentum, whose ratio is the macroscopic velocity.
//! Obstacle cells are left out; a block with no fluid cell has no value. Written as CSV, legacy
//! VTK (ParaView) and PNG colour maps of a Z slice.
//! Units: velocity in ℓ per step (the R component averages out and is not reported), density in
//! particles per link (0..1).

use super::lattice::LatticeGas;
use super::velocities::Q;
use rayon::prelude::*;

#[derive(Clone, Debug)]
pub struct CoarseField {
    /// Cells per block edge.
    pub block: usize,
    /// Blocks along X, Y, Z (the last block of an axis may be partial).
    pub dims: [usize; 3],
    /// Particles per link of the block's fluid sites; `None` for blocks without fluid.
    pub density: Vec<Option<f64>>,
    /// Momentum over particles (ℓ/step), X, Y, Z.
    pub velocity: Vec<Option<[f64; 3]>>,
}

impl CoarseField {
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    /// The mean of a velocity component over the blocks of an X–Y position, over Z.
    pub fn z_mean(&self, x: usize, y: usize, axis: usize) -> Option<f64> {
        self.z_mean_by(x, y, |i| self.velocity[i].map(|v| v[axis]))
    }

    /// The mean over Z of `value(block index)` at an X–Y position, over the blocks that have one.
    pub fn z_mean_by(&self, x: usize, y: usize, value: impl Fn(usize) -> Option<f64>) -> Option<f64> {
        let vals: Vec<f64> = (0..self.dims[2]).filter_map(|z| value(self.index(x, y, z))).collect();
        (!vals.is_empty()).then(|| vals.iter().sum::<f64>() / vals.len() as f64)
    }
}

/// The integer sums of one block of cells: particles, momentum (X, Y, Z) and fluid cells.
#[derive(Clone, Copy, Debug, Default)]
pub struct BlockSum {
    pub particles: u64,
    pub momentum: [i64; 3],
    pub cells: u64,
}

/// The sums of the blocks of `block`³ cells (obstacle cells left out), blocks X-fastest, and the
/// blocks along X, Y, Z (the last block of an axis may be partial).
pub fn block_sums(g: &LatticeGas, block: usize) -> ([usize; 3], Vec<BlockSum>) {
    let dims = g.dims.map(|n| n.div_ceil(block));
    let sums = (0..dims[0] * dims[1] * dims[2])
        .into_par_iter()
        .map(|b| {
            let (bx, by, bz) = (b % dims[0], (b / dims[0]) % dims[1], b / (dims[0] * dims[1]));
            let mut sum = BlockSum::default();
            for z in bz * block..((bz + 1) * block).min(g.dims[2]) {
                for y in by * block..((by + 1) * block).min(g.dims[1]) {
                    for x in bx * block..((bx + 1) * block).min(g.dims[0]) {
                        let cell = g.cell_index(x, y, z);
                        if g.solid[cell] {
                            continue;
                        }
                        let (cn, cj) = g.cell_moments(cell);
                        sum.cells += 1;
                        sum.particles += cn;
                        for a in 0..3 {
                            sum.momentum[a] += cj[a];
                        }
                    }
                }
            }
            sum
        })
        .collect();
    (dims, sums)
}

/// Density and velocity of the blocks of `block`³ cells.
pub fn coarse_grain(g: &LatticeGas, block: usize) -> CoarseField {
    let (dims, sums) = block_sums(g, block);
    let density = sums.iter().map(|s| (s.cells > 0).then(|| s.particles as f64 / (s.cells * 16 * Q as u64) as f64)).collect();
    let velocity = sums.iter().map(|s| (s.cells > 0 && s.particles > 0).then(|| s.momentum.map(|v| v as f64 / s.particles as f64))).collect();
    CoarseField { block, dims, density, velocity }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coarse_graining_recovers_the_filled_density_and_velocity() {
        // a uniform fill at d = 0.25 and u = (0.1, −0.05, 0.02, 0) gives back d and u within the
        // sampling error of 4·4·4 cells × 384 links per block (σ_u ≈ 0.008 ℓ/step per block,
        // ≈ 0.0014 over the 32 blocks), an obstacle cell is left out
        let mut g = LatticeGas::new([16, 8, 16], 1, 0.0);
        g.solid[0] = true;
        let u = [0.1, -0.05, 0.02];
        g.fill(0.25, |_| [u[0], u[1], u[2], 0.0], 4);
        let f = coarse_grain(&g, 4);
        assert_eq!(f.dims, [4, 2, 4]);
        let n = f.velocity.len() as f64;
        let mean_d = f.density.iter().flatten().sum::<f64>() / n;
        let mean_u: [f64; 3] = std::array::from_fn(|a| f.velocity.iter().flatten().map(|v| v[a]).sum::<f64>() / n);
        println!("density {mean_d:.4}, velocity {mean_u:?}");
        assert!((mean_d - 0.25).abs() < 0.002);
        for a in 0..3 {
            assert!((mean_u[a] - u[a]).abs() < 0.006, "axis {a}: {} vs {}", mean_u[a], u[a]);
        }
        // the partial block of a 6-cell axis and the obstacle cell
        let g2 = LatticeGas::new([8, 6, 2], 1, 0.0);
        assert_eq!(coarse_grain(&g2, 4).dims, [2, 2, 1]);
    }
}
