//! Cost per update against problem size on the device (`bench --only scaling --backend gpu`):
//! the GPU side of issue 16's scaling table, beside the CPU's ([`crate::bench::scaling`]). Each
//! kernel — the FDLB D2Q21 and D3Q39 steps, the explicit MPS solid, the lattice gas — is timed
//! at sizes from a few thousand updates a step to millions, with the bytes a step moves per
//! update against the copy kernel's bandwidth measured in the same process
//! ([`super::bench::copy_bandwidth`]). A device is under-filled at the small sizes (its cost per
//! update falls as the size grows); a linear-cost kernel then keeps its nanoseconds per update
//! flat, and an O(N²) part would make them grow with N.

use super::context::{GpuContext, GpuError};
use super::fdlb::GpuFluid;
use super::lattice_gas::GpuLatticeGas;
use super::solid::GpuSolid;
use crate::bench::benchmark_solver;
use crate::fluid::VelocitySetKind;
use crate::lattice_gas::bench::{BYTES_PER_SITE_UPDATE, benchmark_gas};
use crate::lattice_gas::collision::CollisionTable;
use crate::solid::{Integrator, bench::benchmark_block};
use serde::Serialize;
use std::time::Instant;

/// One size of one kernel on the device.
#[derive(Clone, Debug, Serialize)]
pub struct GpuScalingRow {
    /// "D2Q21", "D3Q39", "solid (explicit)", "lattice gas".
    pub kernel: String,
    /// Fluid nodes, particles or sites.
    pub size: usize,
    /// Steps timed (chosen to fill about the table's time per size).
    pub steps: u64,
    pub updates_per_s: f64,
    pub ns_per_update: f64,
    /// Bytes one update moves by the kernel's own count: the FDLB's f32 model of
    /// [`super::bench::lattice_speed`] (13 reads or writes of every value and 10 of the
    /// moments), the solid's of [`crate::solid::bench::speed_of`], the lattice gas's
    /// [`BYTES_PER_SITE_UPDATE`].
    pub bytes_per_update: f64,
    /// `updates_per_s × bytes_per_update` over the copy kernel's bandwidth.
    pub bandwidth_fraction: f64,
}

/// The sizes of a table: FDLB sides (2D squares, 3D cubes), the solid block's sides (side³
/// particles) and the lattice gas's cells (16 sites each).
#[derive(Clone, Debug)]
pub struct ScalingSizes {
    pub d2q21: Vec<usize>,
    pub d3q39: Vec<usize>,
    pub solid_sides: Vec<usize>,
    pub gas_cells: Vec<[usize; 3]>,
}

impl ScalingSizes {
    /// The ranges: 2D 128² … 2048², 3D 32³ … 192³, 10⁴ … 10⁶ particles, and the lattice
    /// gas from 2.6·10⁵ sites to the seed's 512 × 256 × 128 cells (2.7·10⁸ sites).
    pub fn full() -> Self {
        ScalingSizes {
            d2q21: vec![128, 256, 512, 1024, 2048],
            d3q39: vec![32, 64, 96, 128, 160, 192],
            solid_sides: vec![22, 32, 46, 68, 100],
            gas_cells: vec![[32, 16, 16], [64, 32, 32], [128, 64, 32], [256, 128, 64], [512, 256, 128]],
        }
    }

    /// Sizes that run in seconds on a software device (lavapipe): a smoke run of the table.
    pub fn quick() -> Self {
        ScalingSizes { d2q21: vec![64, 128], d3q39: vec![16, 24], solid_sides: vec![10, 16], gas_cells: vec![[16, 8, 8], [32, 16, 8]] }
    }
}

/// Runs `run(k)` (k steps, waited for): two steps to warm up, one to estimate a step's cost,
/// then as many steps as fill about `target_s` (3 at least, `max_steps` at most), timed. Returns
/// (steps, seconds).
fn timed(mut run: impl FnMut(u64), target_s: f64, max_steps: u64) -> (u64, f64) {
    run(2);
    let t = Instant::now();
    run(1);
    let one = t.elapsed().as_secs_f64().max(1e-7);
    let steps = ((target_s / one).ceil() as u64).clamp(3, max_steps.max(3));
    let t = Instant::now();
    run(steps);
    (steps, t.elapsed().as_secs_f64())
}

fn row(kernel: &str, size: usize, (steps, wall): (u64, f64), bytes_per_update: f64, bandwidth: f64) -> GpuScalingRow {
    let ups = size as f64 * steps as f64 / wall;
    GpuScalingRow {
        kernel: kernel.into(),
        size,
        steps,
        updates_per_s: ups,
        ns_per_update: 1e9 / ups,
        bytes_per_update,
        bandwidth_fraction: ups * bytes_per_update / bandwidth,
    }
}

/// Most steps timed at one size.
const MAX_STEPS: u64 = 100_000;

/// The rows, and the sizes left out, as a table is filled.
struct Table {
    rows: Vec<GpuScalingRow>,
    skipped: Vec<String>,
    target_s: f64,
    bandwidth: f64,
}

impl Table {
    /// Times the kernel `made` (`step(g, k)`: k steps of it, waited for) as `kernel` at `size`
    /// updates a step and `bytes` per update; one the device cannot hold (`what`) is left out
    /// with the reason.
    fn time<G>(&mut self, what: String, made: Result<G, GpuError>, mut step: impl FnMut(&mut G, u64), kernel: &str, size: usize, bytes: f64) {
        match made {
            Ok(mut g) => {
                let t = timed(|k| step(&mut g, k), self.target_s, MAX_STEPS);
                self.rows.push(row(kernel, size, t, bytes, self.bandwidth));
            }
            Err(e @ GpuError::TooLarge { .. }) => self.skipped.push(format!("{what}: {e}")),
            Err(e) => panic!("{what}: {e}"),
        }
    }
}

/// The table at `sizes`, about `target_s` of timed steps per size, against the copy kernel's
/// `bandwidth` (bytes/s). A size the device cannot hold is left out and said in the second
/// list ("kernel size: why"), so that the rest of the table still comes back.
pub fn scaling_table(ctx: &GpuContext, sizes: &ScalingSizes, target_s: f64, bandwidth: f64) -> (Vec<GpuScalingRow>, Vec<String>) {
    let mut t = Table { rows: Vec::new(), skipped: Vec::new(), target_s, bandwidth };
    for (set, sides, name) in [(VelocitySetKind::D2q21, &sizes.d2q21, "D2Q21"), (VelocitySetKind::D3q39, &sizes.d3q39, "D3Q39")] {
        for &n in sides {
            let dims = if set == VelocitySetKind::D2q21 { [n, n, 1] } else { [n, n, n] };
            let cpu = benchmark_solver(set, dims);
            let bytes = 4.0 * (13.0 * cpu.eq.values_per_node() as f64 + 10.0);
            let run = |g: &mut GpuFluid, k| {
                g.run(k);
                g.wait();
            };
            t.time(format!("{name} {dims:?}"), GpuFluid::from_solver(ctx, &cpu), run, name, cpu.layout.fluid_count, bytes);
        }
    }
    for &side in &sizes.solid_sides {
        let mut s = benchmark_block(side, Integrator::Explicit);
        let n = s.particles.len();
        // the byte count of the CPU's table (bonds both ways, the particles' state)
        let bytes = crate::solid::bench::speed_of(false, &s, 1, 1.0, 0, 0.0, Vec::new(), bandwidth).bytes_per_update;
        let run = |g: &mut GpuSolid, k| {
            g.run(k);
            g.wait();
        };
        t.time(format!("solid {side}³"), GpuSolid::from_solver(ctx, &mut s), run, "solid (explicit)", n, bytes);
    }
    let table = CollisionTable::shared();
    for &cells in &sizes.gas_cells {
        let g = benchmark_gas(cells);
        let run = |gpu: &mut GpuLatticeGas, k| {
            gpu.advance(k);
            gpu.wait();
        };
        t.time(format!("lattice gas {cells:?}"), GpuLatticeGas::new(ctx, &g, table), run, "lattice gas", 16 * g.cells(), BYTES_PER_SITE_UPDATE);
    }
    (t.rows, t.skipped)
}
