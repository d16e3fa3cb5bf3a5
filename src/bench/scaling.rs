//! Cost per update against problem size (`bench --only scaling`): the FDLB lattices from a few
//! thousand nodes to millions, the explicit MPS solid from 10⁴ to 10⁶ particles, and the lattice
//! gas, each timed on the CPU in one process. A linear-cost kernel keeps its nanoseconds per
//! update flat as the size grows, apart from the step where its data leaves the last-level cache
//! (the `data` column against [`super::last_level_cache_bytes`]); an O(N²) part would grow with N.

use super::benchmark_solver;
use crate::fluid::VelocitySetKind;
use crate::lattice_gas::bench::benchmark_gas;
use crate::lattice_gas::collision::CollisionTable;
use crate::solid::{Integrator, bench::benchmark_block};
use serde::Serialize;
use std::time::Instant;

/// One size of one kernel.
#[derive(Clone, Debug, Serialize)]
pub struct ScalingRow {
    /// "D2Q21", "D3Q39", "solid (explicit)", "lattice gas".
    pub kernel: String,
    /// Nodes, particles or sites.
    pub size: usize,
    pub steps: u64,
    pub updates_per_s: f64,
    pub ns_per_update: f64,
    /// Bytes of the kernel's state and per-step arrays.
    pub data_bytes: usize,
}

fn row(kernel: &str, size: usize, steps: u64, wall: f64, data_bytes: usize) -> ScalingRow {
    let ups = size as f64 * steps as f64 / wall;
    ScalingRow { kernel: kernel.into(), size, steps, updates_per_s: ups, ns_per_update: 1e9 / ups, data_bytes }
}

/// Steps that make about `updates` updates of `size` (at least 2).
fn steps_for(size: usize, updates: f64) -> u64 {
    ((updates / size as f64).round() as u64).max(2)
}

/// The table; `quick` stops each kernel at a size that runs in seconds.
pub fn scaling_table(quick: bool) -> Vec<ScalingRow> {
    let mut rows = Vec::new();
    let (d2, d3): (&[usize], &[usize]) = if quick { (&[64, 128, 256], &[16, 24, 32]) } else { (&[128, 256, 512, 1024, 2048], &[32, 64, 96, 128, 160]) };
    for (set, sizes) in [(VelocitySetKind::D2q21, d2), (VelocitySetKind::D3q39, d3)] {
        for &n in sizes {
            let dims = if set == VelocitySetKind::D2q21 { [n, n, 1] } else { [n, n, n] };
            let mut s = benchmark_solver(set, dims);
            s.run(1).expect("stable");
            let nodes = s.layout.fluid_count;
            let steps = steps_for(nodes, if quick { 2e6 } else { 2e7 });
            let t = Instant::now();
            s.run(steps).expect("stable");
            let data = super::fluid_footprint(&s);
            rows.push(row(if set == VelocitySetKind::D2q21 { "D2Q21" } else { "D3Q39" }, nodes, steps, t.elapsed().as_secs_f64(), data));
        }
    }
    let sides: &[usize] = if quick { &[10, 16, 22] } else { &[22, 32, 46, 68, 100] };
    for &side in sides {
        let mut s = benchmark_block(side, Integrator::Explicit);
        s.step().expect("the benchmark block stays finite");
        let n = s.particles.len();
        let steps = steps_for(n, if quick { 2e5 } else { 3e6 });
        let t = Instant::now();
        for _ in 0..steps {
            s.step().expect("the benchmark block stays finite");
        }
        rows.push(row("solid (explicit)", n, steps, t.elapsed().as_secs_f64(), crate::solid::bench::footprint(&s)));
    }
    let gases: &[[usize; 3]] = if quick { &[[16, 8, 8], [32, 16, 8]] } else { &[[32, 16, 16], [64, 32, 32], [128, 64, 32], [256, 128, 64], [256, 256, 128]] };
    let table = CollisionTable::shared();
    for &cells in gases {
        let mut g = benchmark_gas(cells);
        g.advance(table);
        let sites = 16 * g.cells();
        let steps = steps_for(sites, if quick { 2e6 } else { 1e8 });
        let t = Instant::now();
        for _ in 0..steps {
            g.advance(table);
        }
        rows.push(row("lattice gas", sites, steps, t.elapsed().as_secs_f64(), crate::lattice_gas::bench::footprint(&g)));
    }
    rows
}
