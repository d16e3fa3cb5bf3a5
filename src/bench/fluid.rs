//! The FDLB's speed: node updates per second of the benchmark lattices on the CPU, bytes per
//! update and the fraction of the triad, the memory hints against none, and f32 against f64
//! storage with the error it costs (Taylor–Green, Sod).

use super::*;

/// Node updates per second of one lattice on one backend.
#[derive(Clone, Debug, Serialize)]
pub struct LatticeSpeed {
    pub lattice: String,
    pub nodes: [usize; 3],
    pub steps: u64,
    /// Best of the repetitions (the machines here are shared: the best is the least disturbed).
    pub node_updates_per_s: f64,
    /// Median and worst of the repetitions, and how many (1 where only one block was timed).
    pub median_node_updates_per_s: f64,
    pub worst_node_updates_per_s: f64,
    pub repetitions: usize,
    pub bytes_per_node_update: f64,
    /// Node updates/s × bytes per update ÷ the bandwidth measured in the same process; `None`
    /// when the lattice fits in the cache ([`fraction_of_bandwidth`]).
    pub bandwidth_fraction: Option<f64>,
    /// Fraction of the step time per stage of the stage list.
    pub stage_fractions: Vec<(String, f64)>,
    /// Why the size could not run on this backend (too large for the device, …).
    pub skipped: Option<String>,
    /// CPU: the memory hints the solver chose for this size ([`crate::fluid::solver::MemoryHints`]),
    /// and, where it chose any, the best rate of blocks timed without them, interleaved with
    /// the others in the same process.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory_hints: Option<HintsSpeed>,
    /// GPU: what a probe sample costs the run loop, in seconds and in steps of this lattice —
    /// the whole state brought back into the CPU mirror against the probes' nodes gathered on
    /// the device ([`crate::run::FluidEngine::state_at`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub readback: Option<ReadbackCost>,
}

/// The FDLB's memory hints on the CPU against none, on the same solver (see
/// [`LatticeSpeed::memory_hints`]).
#[derive(Clone, Debug, Serialize)]
pub struct HintsSpeed {
    pub streaming_stores: bool,
    pub prefetch_rows: bool,
    /// Best and median node updates per second with no hint; `None` where none was chosen.
    pub without_node_updates_per_s: Option<f64>,
    pub without_median_node_updates_per_s: Option<f64>,
}

/// The cost of one probe sample of a GPU run (see [`LatticeSpeed::readback`]).
#[derive(Clone, Debug, Serialize)]
pub struct ReadbackCost {
    /// Whole state into the mirror (s): what every sample cost before the gather.
    pub whole_s: f64,
    /// The probes' [`ReadbackCost::nodes`] nodes (lattice gas: cells in bands of rows) brought back (s).
    pub gathered_s: f64,
    pub nodes: usize,
    /// The two in steps of the lattice (wall time ÷ one step's).
    pub whole_steps: f64,
    pub gathered_steps: f64,
}

/// The benchmark problem: a periodic box of `n` nodes with a smooth shear flow, A > 0.
pub fn benchmark_solver(set: VelocitySetKind, n: [usize; 3]) -> FluidSolver {
    benchmark_solver_stored(set, n)
}

/// [`benchmark_solver`] with the populations stored as `S`.
pub fn benchmark_solver_stored<S: Storage>(set: VelocitySetKind, n: [usize; 3]) -> FluidSolver<S> {
    let vs = VelocitySet::new(set);
    let dim = vs.dim;
    let l1 = vs.max_l1_speed();
    let eq = Equilibrium::new(vs, GasModel::Monatomic);
    let params = timestep::choose(0.05, 0.6, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
    let k = 2.0 * std::f64::consts::PI / n[0] as f64;
    let init = move |x: [f64; 3]| Macro { rho: 1.0, u: [0.05 * (k * x[1]).sin(), 0.05 * (k * x[0]).sin(), 0.0], theta: 0.6 };
    FluidSolver::with_storage(eq, Grid::new(dim, n), Boundaries::periodic(), &[], params, init)
}

/// Bytes of a CPU fluid's arrays that a step sweeps: f, f¹, fⁿ⁺¹, h (of `S`) and the
/// macroscopic fields (f64).
pub fn fluid_footprint<S: Storage>(s: &FluidSolver<S>) -> usize {
    s.footprint_bytes()
}

/// The lattice side (a multiple of 32, at least `min_side`) at which the benchmark problem of
/// `set` sweeps at least twice the last-level cache `llc` (bytes) — the bound below which
/// [`fraction_of_bandwidth`] reports no fraction — so that the full benchmark measures the
/// kernels against memory on any machine. The bytes per node are read from a small solver of
/// the same kind ([`fluid_footprint`]).
pub fn side_beyond_cache(set: VelocitySetKind, min_side: usize, llc: usize) -> usize {
    let small = benchmark_solver_stored::<f64>(set, [8, 8, if VelocitySet::new(set).dim == 3 { 8 } else { 1 }]);
    let per_node = fluid_footprint(&small) as f64 / small.layout.grid.len() as f64;
    let side = (2.0 * llc as f64 / per_node).powf(1.0 / small.layout.grid.dim as f64).ceil() as usize;
    side.div_ceil(32).max(min_side.div_ceil(32)) * 32
}

/// Node updates per second of one timed block of `steps` steps.
pub(super) fn timed_block<S: Storage>(s: &mut FluidSolver<S>, steps: u64) -> f64 {
    let t = Instant::now();
    s.run(steps).expect("stable");
    steps as f64 * s.layout.fluid_count as f64 / t.elapsed().as_secs_f64()
}

/// A solver made ready for timing: two untimed steps, timings cleared.
pub(super) fn warmed<S: Storage>(set: VelocitySetKind, n: [usize; 3]) -> FluidSolver<S> {
    let mut s = benchmark_solver_stored::<S>(set, n);
    s.run(2).expect("stable");
    s.timings = Default::default();
    s
}

/// The row of `s` from its blocks' rates (best, median, worst).
pub(super) fn speed_row<S: Storage>(s: &FluidSolver<S>, set: VelocitySetKind, steps: u64, mut rates: Vec<f64>, bandwidth: f64) -> LatticeSpeed {
    rates.sort_by(|a, b| b.total_cmp(a));
    let ups = rates[0];
    let bytes = s.bytes_per_node_update();
    let footprint = fluid_footprint(s);
    LatticeSpeed {
        lattice: format!("{set:?}"),
        nodes: s.layout.grid.n,
        steps,
        node_updates_per_s: ups,
        median_node_updates_per_s: rates[rates.len() / 2],
        worst_node_updates_per_s: rates[rates.len() - 1],
        repetitions: rates.len(),
        bytes_per_node_update: bytes,
        bandwidth_fraction: fraction_of_bandwidth(ups * bytes, footprint, bandwidth),
        stage_fractions: s.timings.report().into_iter().map(|(n, f)| (n.to_string(), f)).collect(),
        skipped: None,
        memory_hints: None,
        readback: None,
    }
}

/// CPU node updates per second of the benchmark problem: `repetitions` blocks of `steps` steps,
/// the best, median and worst block (as the triad: [`triad`]). Where the solver chose memory
/// hints for this size, as many blocks without them alternate with those blocks.
pub fn lattice_speed(set: VelocitySetKind, n: [usize; 3], steps: u64, repetitions: usize, bandwidth: f64) -> LatticeSpeed {
    use crate::fluid::solver::MemoryHints;
    let mut s = warmed::<f64>(set, n);
    let chosen = s.memory_hints();
    let none = MemoryHints { streaming_stores: false, prefetch_rows: false };
    let (mut rates, mut without) = (Vec::new(), Vec::new());
    for _ in 0..repetitions.max(1) {
        rates.push(timed_block(&mut s, steps));
        if chosen != none {
            // the stage shares stay those of the blocks with the chosen hints
            let kept = s.timings.clone();
            s.set_memory_hints(none);
            without.push(timed_block(&mut s, steps));
            s.set_memory_hints(chosen);
            s.timings = kept;
        }
    }
    let mut row = speed_row(&s, set, steps, rates, bandwidth);
    without.sort_by(|a, b| b.total_cmp(a));
    row.memory_hints = Some(HintsSpeed {
        streaming_stores: chosen.streaming_stores,
        prefetch_rows: chosen.prefetch_rows,
        without_node_updates_per_s: without.first().copied(),
        without_median_node_updates_per_s: without.get(without.len() / 2).copied(),
    });
    row
}

/// The f32 storage option against f64 on one lattice, blocks interleaved in one process.
#[derive(Clone, Debug, Serialize)]
pub struct StorageSpeed {
    pub f64: LatticeSpeed,
    pub f32: LatticeSpeed,
    /// f32's best rate ÷ f64's best, and the same of the medians.
    pub speedup: f64,
    pub median_speedup: f64,
}

/// [`lattice_speed`] of the f64 and the f32 solver, their blocks alternating (f64, f32, f64,
/// …) so that a disturbance of the shared machine falls on both.
pub fn storage_speed(set: VelocitySetKind, n: [usize; 3], steps: u64, repetitions: usize, bandwidth: f64) -> StorageSpeed {
    let (mut a, mut b) = (warmed::<f64>(set, n), warmed::<f32>(set, n));
    let (mut ra, mut rb) = (Vec::new(), Vec::new());
    for _ in 0..repetitions.max(1) {
        ra.push(timed_block(&mut a, steps));
        rb.push(timed_block(&mut b, steps));
    }
    let (f64_row, f32_row) = (speed_row(&a, set, steps, ra, bandwidth), speed_row(&b, set, steps, rb, bandwidth));
    StorageSpeed {
        speedup: f32_row.node_updates_per_s / f64_row.node_updates_per_s,
        median_speedup: f32_row.median_node_updates_per_s / f64_row.median_node_updates_per_s,
        f64: f64_row,
        f32: f32_row,
    }
}

/// What f32 storage costs in accuracy on a validation case: the distance from the exact
/// answer with each storage, and f32's distance from f64.
#[derive(Clone, Debug, Serialize)]
pub struct StorageError {
    pub case: String,
    /// The figure's relative error against the exact answer, f64 and f32 storage.
    pub f64_error: f64,
    pub f32_error: f64,
    /// |f32 − f64| ÷ |exact| (the largest over the case's figures).
    pub f32_minus_f64: f64,
}

/// The error rows: the Taylor–Green decay rate (D2Q21, n = 64) and the Sod plateaus (D2Q21,
/// monatomic, the largest of the four) with f64 and f32 storage.
pub fn storage_errors() -> Vec<StorageError> {
    use crate::validation::sod::SodCase;
    let tg = TaylorGreenCase::new(VelocitySetKind::D2q21, 64);
    let (a, b) = (tg.run_stored::<f64>(), tg.run_stored::<f32>());
    let mut sod = SodCase::new(VelocitySetKind::D2q21, GasModel::Monatomic);
    sod.scale = 0.7;
    let (sa, sb) = (sod.run_stored::<f64>(), sod.run_stored::<f32>());
    let worst = |r: &crate::validation::sod::SodResult| r.plateaus.iter().map(|p| p.3.abs()).fold(0.0, f64::max);
    let diff = sa.plateaus.iter().zip(&sb.plateaus).map(|(x, y)| (x.1 - y.1).abs() / x.2.abs()).fold(0.0, f64::max);
    vec![
        StorageError {
            case: "Taylor–Green decay rate (D2Q21, 64²)".into(),
            f64_error: a.relative_error.abs(),
            f32_error: b.relative_error.abs(),
            f32_minus_f64: (b.measured_rate - a.measured_rate).abs() / a.predicted_rate,
        },
        StorageError { case: "Sod plateaus (D2Q21, 800 cells, largest of 4)".into(), f64_error: worst(&sa), f32_error: worst(&sb), f32_minus_f64: diff },
    ]
}
