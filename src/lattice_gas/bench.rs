//! Lattice-gas speed: site updates per second, the fraction of the memory bandwidth measured in
//! the same process, and the projected time of the seed's run (seed 002 §3.5: 512 × 256 × 128
//! cells, ~39,000 steps, ~55 minutes on 32 SX-ACE nodes).

use super::collision::CollisionTable;
use super::lattice::LatticeGas;
use super::step::LatticeGasTimings;
use super::velocities::Q;
use serde::Serialize;
use std::time::Instant;

/// Sites of the seed's run (512 × 256 × 128 cells × 16 sites).
pub const SEED_RUN_SITES: f64 = 512.0 * 256.0 * 128.0 * 16.0;
/// Steps of the seed's run.
pub const SEED_RUN_STEPS: f64 = 39_000.0;

/// Bytes of memory traffic per site update of a step, on the CPU and the GPU: two passes that
/// read and write the 24 bits of every site — collision and interference fused, then
/// propagation (24 · 2 · 2 / 8 = 12 B); the boundaries touch only the X ends.
pub const BYTES_PER_SITE_UPDATE: f64 = Q as f64 * 2.0 * 2.0 / 8.0;
/// With every stage a pass of its own (the site-by-site reference): three passes (18 B).
pub const SEPARATE_STAGES_BYTES_PER_SITE_UPDATE: f64 = Q as f64 * 2.0 * 3.0 / 8.0;

#[derive(Clone, Debug, Serialize)]
pub struct LatticeGasSpeed {
    pub backend: String,
    pub cells: [usize; 3],
    pub density: f64,
    pub interference: f64,
    pub steps: u64,
    pub site_updates_per_s: f64,
    pub bytes_per_site_update: f64,
    /// Of the bandwidth measured in the same process (CPU triad, GPU copy kernel); `None` on the
    /// CPU when the gas fits in the cache ([`crate::machine::fraction_of_bandwidth`]).
    pub bandwidth_fraction: Option<f64>,
    /// Share of the step time per stage.
    pub stage_shares: Vec<(String, f64)>,
    /// The seed's 512 × 256 × 128-cell, 39,000-step run at this speed (s).
    pub projected_seed_run_s: f64,
}

/// Fill (particles per link) of the benchmark box.
pub const BENCHMARK_FILL: f64 = 0.2;

/// The periodic box the benchmarks time: fill [`BENCHMARK_FILL`] with a shear wave,
/// interference p = 0.1.
pub fn benchmark_gas(cells: [usize; 3]) -> LatticeGas {
    let mut g = LatticeGas::new(cells, 7, 0.1);
    let k = 2.0 * std::f64::consts::PI / (2.0 * cells[0] as f64);
    g.fill(BENCHMARK_FILL, |x| [0.0, 0.1 * (k * x[0]).sin(), 0.0, 0.0], 3);
    g
}

/// Bytes of the gas a step sweeps: the state (48 B per cell) and propagation's other copy.
pub fn footprint(g: &LatticeGas) -> usize {
    96 * g.cells()
}

/// Fills in the derived figures of a measurement; `cpu`: the bandwidth is the CPU triad, and no
/// fraction is given when the gas fits in the CPU's cache.
#[allow(clippy::too_many_arguments)]
pub fn speed_of(
    cpu: bool,
    backend: String,
    g: &LatticeGas,
    steps: u64,
    seconds: f64,
    bytes_per_site_update: f64,
    bandwidth: f64,
    stage_shares: Vec<(String, f64)>,
) -> LatticeGasSpeed {
    let rate = 16.0 * g.cells() as f64 * steps as f64 / seconds.max(1e-12);
    LatticeGasSpeed {
        backend,
        cells: g.dims,
        density: BENCHMARK_FILL,
        interference: g.interference,
        steps,
        site_updates_per_s: rate,
        bytes_per_site_update,
        bandwidth_fraction: if cpu {
            crate::machine::fraction_of_bandwidth(rate * bytes_per_site_update, footprint(g), bandwidth)
        } else {
            Some(rate * bytes_per_site_update / bandwidth)
        },
        stage_shares,
        projected_seed_run_s: SEED_RUN_SITES * SEED_RUN_STEPS / rate,
    }
}

/// Times `steps` CPU steps (after one warm-up step) of [`benchmark_gas`].
pub fn cpu_speed(cells: [usize; 3], steps: u64, bandwidth: f64) -> LatticeGasSpeed {
    timed_steps(cells, steps, bandwidth, false)
}

/// [`cpu_speed`] with the collision done site by site ([`LatticeGas::collide_site_by_site`],
/// the plain form the transposed kernel replaced) and the interference as a pass of its own,
/// for the method-vs-method ratio in one run.
pub fn cpu_speed_site_by_site(cells: [usize; 3], steps: u64, bandwidth: f64) -> LatticeGasSpeed {
    timed_steps(cells, steps, bandwidth, true)
}

fn timed_steps(cells: [usize; 3], steps: u64, bandwidth: f64, site_by_site: bool) -> LatticeGasSpeed {
    use crate::stages::LatticeGasStageKind;
    let table = CollisionTable::shared();
    let mut g = benchmark_gas(cells);
    g.advance(table);
    let mut t = LatticeGasTimings::default();
    let t0 = Instant::now();
    for _ in 0..steps {
        g.advance_timed_by(table, &mut t, |g, kind, table| match kind {
            // the plain form: every stage on its own, the collision site by site
            LatticeGasStageKind::Collide if site_by_site => g.collide_site_by_site(table),
            kind if site_by_site => g.run_stage(kind, table),
            kind => g.run_step_stage(kind, table),
        });
    }
    let s = t0.elapsed().as_secs_f64();
    let shares = t.report().into_iter().map(|(n, f)| (n.to_string(), f)).collect();
    let what = if site_by_site { ", site-by-site collision" } else { "" };
    let bytes = if site_by_site { SEPARATE_STAGES_BYTES_PER_SITE_UPDATE } else { BYTES_PER_SITE_UPDATE };
    speed_of(true, format!("CPU, {} threads{what}", rayon::current_num_threads()), &g, steps, s, bytes, bandwidth, shares)
}
