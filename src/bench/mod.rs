//! Speed measurements (a `bench` subcommand, never a timed test): the machine's memory bandwidth
//! (a STREAM-like triad) and the FDLB node updates per second measured in the same process, the
//! bytes moved per node update and the fraction of bandwidth achieved; and speed-vs-error tables
//! (Taylor–Green at three resolutions; the coupled Schäfer–Turek cylinder at three resolutions).

pub mod scaling;

use crate::fluid::storage::Storage;
use crate::fluid::{Boundaries, Equilibrium, FluidSolver, GasModel, Grid, Macro, VelocitySet, VelocitySetKind, timestep};
use crate::validation::taylor_green::{TaylorGreenCase, TaylorGreenResult};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// The memory bandwidth the triad a\[i\] = b\[i\] + s·c\[i\] reaches (3 × 8 bytes per element, the
/// STREAM convention), over repetitions: the machines are shared, so the best is the figure the
/// fractions use and the spread says how much to trust it.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Bandwidth {
    /// Bytes/s of the fastest, median and slowest repetition.
    pub best: f64,
    pub median: f64,
    pub worst: f64,
    pub repetitions: usize,
    /// Bytes of each of the three arrays.
    pub array_bytes: usize,
}

/// The triad over `n` f64 per array, `reps` times (the arrays should be well beyond the
/// last-level cache: [`last_level_cache_bytes`]).
pub fn triad(n: usize, reps: usize) -> Bandwidth {
    let mut a = vec![0.0f64; n];
    let b: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let c: Vec<f64> = (0..n).map(|i| (n - i) as f64).collect();
    let mut times = Vec::with_capacity(reps);
    // a first, untimed pass maps a's pages (a freshly allocated zeroed vector is mapped on first
    // write, which would otherwise count against the first repetition)
    a.par_chunks_mut(1 << 16).for_each(|a| a.fill(1.0));
    for r in 0..reps.max(1) {
        let s = 1.0 + r as f64 * 1e-3;
        let t = Instant::now();
        a.par_chunks_mut(1 << 16).zip(b.par_chunks(1 << 16)).zip(c.par_chunks(1 << 16)).for_each(|((a, b), c)| {
            for i in 0..a.len() {
                a[i] = b[i] + s * c[i];
            }
        });
        times.push(t.elapsed().as_secs_f64());
    }
    std::hint::black_box(&a);
    times.sort_by(f64::total_cmp);
    let rate = |t: f64| 24.0 * n as f64 / t;
    Bandwidth { best: rate(times[0]), median: rate(times[times.len() / 2]), worst: rate(times[times.len() - 1]), repetitions: times.len(), array_bytes: 8 * n }
}

/// The f64 arithmetic rate of the CPU, all threads, over repetitions (flop/s; an FMA counts 2).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct FlopRate {
    pub best: f64,
    pub median: f64,
    pub repetitions: usize,
}

/// Independent FMA chains per thread: enough to cover the FMA latency on every FMA port (4
/// cycles × 2 ports × 8 f64 lanes with AVX-512, twice what AVX2 needs) so that the loop runs at
/// the ports' throughput.
const FMA_CHAINS: usize = 64;

/// The peak f64 rate of the roofline: every rayon thread runs `FMA_CHAINS` independent chains
/// of `a = a · b + c` (vectorised, FMA where the CPU has it — this build's own instruction
/// set), `reps` times, in registers (no memory traffic).
pub fn fma_peak(reps: usize) -> FlopRate {
    const ITERATIONS: usize = 1 << 22;
    let threads = rayon::current_num_threads();
    let mut rates: Vec<f64> = (0..reps.max(1))
        .map(|r| {
            let t = Instant::now();
            let sum: f64 = (0..threads)
                .into_par_iter()
                .map(|i| {
                    let mut a = [1.0 + (i + r) as f64 * 1e-9; FMA_CHAINS];
                    let (b, c) = (std::hint::black_box(0.999_999_9), std::hint::black_box(1e-7));
                    for _ in 0..ITERATIONS {
                        for x in a.iter_mut() {
                            *x = x.mul_add(b, c);
                        }
                    }
                    a.iter().sum::<f64>()
                })
                .sum();
            std::hint::black_box(sum);
            2.0 * (FMA_CHAINS * ITERATIONS * threads) as f64 / t.elapsed().as_secs_f64()
        })
        .collect();
    rates.sort_by(|a, b| b.total_cmp(a));
    FlopRate { best: rates[0], median: rates[rates.len() / 2], repetitions: rates.len() }
}

pub use crate::machine::{fraction_of_bandwidth, last_level_cache_bytes};

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

/// The shortest wall time (s) of `repetitions` calls of `f` (the machines here are shared: the
/// shortest is the least disturbed).
pub fn best_of(repetitions: usize, f: &mut dyn FnMut()) -> f64 {
    (0..repetitions.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
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

/// f64 per array of the full benchmark's triad: 256 MiB, or the power of two at or above the
/// last-level cache `llc` (bytes) where that is larger, so that the three arrays together are
/// at least three times the cache (a machine here reports 480 MiB of L3, where three arrays of
/// 256 MiB would be read partly from the cache).
pub fn triad_elements(llc: usize) -> usize {
    (1usize << 25).max((llc / 8).next_power_of_two())
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
fn timed_block<S: Storage>(s: &mut FluidSolver<S>, steps: u64) -> f64 {
    let t = Instant::now();
    s.run(steps).expect("stable");
    steps as f64 * s.layout.fluid_count as f64 / t.elapsed().as_secs_f64()
}

/// A solver made ready for timing: two untimed steps, timings cleared.
fn warmed<S: Storage>(set: VelocitySetKind, n: [usize; 3]) -> FluidSolver<S> {
    let mut s = benchmark_solver_stored::<S>(set, n);
    s.run(2).expect("stable");
    s.timings = Default::default();
    s
}

/// The row of `s` from its blocks' rates (best, median, worst).
fn speed_row<S: Storage>(s: &FluidSolver<S>, set: VelocitySetKind, steps: u64, mut rates: Vec<f64>, bandwidth: f64) -> LatticeSpeed {
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

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub threads: usize,
    pub triad_bandwidth_gb_s: f64,
    /// The triad's repetitions (best, median, worst).
    pub triad: Bandwidth,
    /// The f64 peak of the roofline ([`fma_peak`]).
    pub fma_peak: FlopRate,
    /// The last-level cache (bytes): benchmarks whose data fits in twice this report no
    /// bandwidth fraction.
    pub last_level_cache_bytes: usize,
    pub lattices: Vec<LatticeSpeed>,
    pub speed_vs_error: Vec<TaylorGreenResult>,
    /// The f32 storage option against f64 (`--only storage`): speed, and its error on
    /// Taylor–Green and Sod.
    pub storage: Vec<StorageSpeed>,
    pub storage_errors: Vec<StorageError>,
    /// MPS solid, explicit and implicit, at 10⁵ (and 10⁶ unless quick) particles.
    pub solid: Vec<crate::solid::bench::SolidSpeed>,
    /// The implicit step against the explicit one to the same simulated time, for an
    /// elastic-limited and viscosity-limited materials ([`crate::solid::bench::crossover`]).
    pub solid_crossover: Vec<crate::solid::bench::CrossoverRow>,
    /// FCHC lattice gas (periodic box, fill 0.2, p = 0.1).
    pub lattice_gas: Vec<crate::lattice_gas::bench::LatticeGasSpeed>,
    /// Coupled (weak, CPU): the clamped elastic cylinder of Schäfer–Turek 2D-1 at three
    /// resolutions — speed against the drag's distance from the finest run.
    pub coupled: Vec<CoupledSpeed>,
    /// The two-mass model at 8 cmH₂O: RK4 rate against the f0 and peak-flow error.
    pub two_mass: Vec<TwoMassSpeed>,
    /// The coupled 2D glottis (weak, CPU): the coarse and the seed-sized scenes.
    pub glottis: Vec<GlottisSpeed>,
    /// Cost per update against size ([`scaling`]; only with `--only scaling`: it takes minutes).
    pub scaling: Vec<scaling::ScalingRow>,
}

/// Speed of a glottis scene from rest (the first steps: the pressure wave has not yet reached
/// the folds, so the fluid geometry is rebuilt only where it changes).
#[derive(Clone, Debug, Serialize)]
pub struct GlottisSpeed {
    pub scene: String,
    pub nodes: usize,
    pub particles: usize,
    /// Coupled (= fluid) step (s).
    pub dt: f64,
    pub coupled_steps_per_s: f64,
    /// Wall seconds per simulated millisecond.
    pub wall_per_simulated_ms: f64,
    pub stage_shares: Vec<(String, f64)>,
}

/// `steps` coupled steps of each built-in glottis scene of `names`.
pub fn glottis_speed(names: &[&str], steps: u64) -> Vec<GlottisSpeed> {
    names
        .iter()
        .map(|name| {
            let sc = crate::scene::coupled::CoupledScene::parse(crate::scene::builtin(name).expect("built in")).expect("valid");
            let mut c = sc.build().expect("builds");
            let t = Instant::now();
            c.run(steps).expect("stable from rest");
            let wall = t.elapsed().as_secs_f64();
            let n = c.fluid.layout.grid.n;
            GlottisSpeed {
                scene: name.to_string(),
                nodes: n[0] * n[1] * n[2],
                particles: c.solid.particles.len(),
                dt: c.dt(),
                coupled_steps_per_s: steps as f64 / wall,
                wall_per_simulated_ms: wall / (steps as f64 * c.dt() * 1e3),
                stage_shares: c.stage_shares().into_iter().map(|(n, f)| (n.to_string(), f)).collect(),
            }
        })
        .collect()
}

/// One RK4 rate of the two-mass speed-vs-error table.
#[derive(Clone, Debug, Serialize)]
pub struct TwoMassSpeed {
    /// RK4 steps per second of simulated time (Hz).
    pub rate_hz: f64,
    pub steps_per_s: f64,
    /// Wall seconds per simulated second.
    pub wall_per_simulated_s: f64,
    pub f0_hz: f64,
    /// |f0 − f0(finest)| / f0(finest) and the same for the peak flow.
    pub f0_error: f64,
    pub peak_flow_error: f64,
}

/// The two-mass rows: 0.4 s at 8 cmH₂O with RK4 at 1, 2, 4, 8 × 44.1 kHz against 32 × 44.1 kHz.
pub fn two_mass_speed_vs_error() -> Vec<TwoMassSpeed> {
    use crate::analysis::voice::{VoiceOptions, voice_measures};
    use crate::two_mass::{CM_H2O, TwoMassParams, simulate};
    let runs: Vec<(f64, f64, crate::analysis::voice::VoiceMeasures)> = [1.0, 2.0, 4.0, 8.0, 32.0]
        .iter()
        .map(|k| {
            let rate = 44_100.0 * k;
            let steps = (0.4 * rate) as usize;
            let t = Instant::now();
            let run = simulate(&TwoMassParams::default(), 8.0 * CM_H2O, 1.0 / rate, steps);
            let wall = t.elapsed().as_secs_f64();
            (rate, wall, voice_measures(&run.flow, 1.0 / rate, &VoiceOptions::default()).expect("the standard model oscillates at 8 cmH2O"))
        })
        .collect();
    let (_, _, fine) = runs.last().expect("five rates").clone();
    runs.iter()
        .map(|(rate, wall, m)| TwoMassSpeed {
            rate_hz: *rate,
            steps_per_s: 0.4 * rate / wall,
            wall_per_simulated_s: wall / 0.4,
            f0_hz: m.f0_autocorrelation_hz,
            f0_error: (m.f0_autocorrelation_hz / fine.f0_autocorrelation_hz - 1.0).abs(),
            peak_flow_error: (m.peak_flow / fine.peak_flow - 1.0).abs(),
        })
        .collect()
}

/// One resolution of the coupled speed-vs-error table.
#[derive(Clone, Debug, Serialize)]
pub struct CoupledSpeed {
    /// "method 1" (weak) or "method 2" (momentum-conserving).
    pub method: &'static str,
    pub cells_per_diameter: usize,
    pub nodes: usize,
    pub particles: usize,
    pub solid_substeps: u32,
    pub coupled_steps_per_s: f64,
    /// Wall seconds per simulated second.
    pub wall_per_simulated_s: f64,
    /// C_D averaged over the last quarter of the run.
    pub drag_coefficient: f64,
    /// |C_D − C_D(finest)| / C_D(finest) (0 for the finest).
    pub error_vs_finest: f64,
    /// |C_D − 5.5795| / 5.5795 (the steady reference; short runs are still settling).
    pub error_vs_reference: f64,
    pub stage_shares: Vec<(String, f64)>,
}

/// The coupled rows: D = 10, 20, 30 cells (quick: 10, 20) for `duration` simulated seconds,
/// method 1 then method 2 (each against its own finest run).
pub fn coupled_speed_vs_error(quick: bool) -> Vec<CoupledSpeed> {
    use crate::coupling::TractionModel;
    use crate::validation::fsi::CylinderBody;
    let (sizes, duration): (&[usize], f64) = if quick { (&[10, 20], 0.1) } else { (&[10, 20, 30], 1.0) };
    let methods = [("method 1", CylinderBody::WeakCoupled(TractionModel::PressureAndShear)), ("method 2", CylinderBody::ConservingCoupled)];
    methods.into_iter().flat_map(|(name, body)| coupled_rows(name, body, sizes, duration)).collect()
}

fn coupled_rows(method: &'static str, body: crate::validation::fsi::CylinderBody, sizes: &[usize], duration: f64) -> Vec<CoupledSpeed> {
    use crate::validation::fsi::{ChannelStart, ST_2D1_DRAG, schafer_turek_2d1};
    let runs: Vec<_> = sizes.iter().map(|&d| (d, schafer_turek_2d1(d, 0.1, ChannelStart::Impulsive, duration, body))).collect();
    let finest = runs.last().map(|(_, r)| r.drag_coefficient).unwrap_or(f64::NAN);
    runs.into_iter()
        .map(|(d, r)| CoupledSpeed {
            method,
            cells_per_diameter: d,
            nodes: (22 * d) * (41 * d / 10),
            particles: r.particles,
            solid_substeps: r.substeps,
            coupled_steps_per_s: r.steps as f64 / r.wall_s,
            wall_per_simulated_s: r.wall_s / r.simulated_s,
            drag_coefficient: r.drag_coefficient,
            error_vs_finest: (r.drag_coefficient - finest).abs() / finest,
            error_vs_reference: (r.drag_coefficient - ST_2D1_DRAG).abs() / ST_2D1_DRAG,
            stage_shares: r.stage_shares,
        })
        .collect()
}

/// Parts of the benchmark, for `bench --only`.
pub const SUITES: [&str; 10] = ["fdlb", "storage", "solid", "crossover", "lattice_gas", "coupled", "two_mass", "glottis", "drawing", "scaling"];

/// The CPU benchmark (every suite of [`SUITES`], or only `only`). `quick` shrinks grids for a
/// smoke run.
pub fn run(quick: bool, only: Option<&str>) -> BenchReport {
    let wants = |suite: &str| only.is_none_or(|o| o == suite);
    let llc = last_level_cache_bytes();
    let triad = triad(if quick { 1 << 23 } else { triad_elements(llc) }, 10);
    let bw = triad.best;
    let fma = fma_peak(5);
    let (n2, n3, st) =
        if quick { (128, 32, 3) } else { (side_beyond_cache(VelocitySetKind::D2q21, 512, llc), side_beyond_cache(VelocitySetKind::D3q39, 96, llc), 10) };
    let lattices = if wants("fdlb") {
        vec![lattice_speed(VelocitySetKind::D2q21, [n2, n2, 1], st, 5, bw), lattice_speed(VelocitySetKind::D3q39, [n3, n3, n3], st.min(5), 5, bw)]
    } else {
        Vec::new()
    };
    let speed_vs_error = if wants("fdlb") { [32usize, 64, 128].as_slice() } else { &[] }
        .iter()
        .map(|&n| {
            let mut c = TaylorGreenCase::new(VelocitySetKind::D2q21, n);
            // Fixed physical problem: Re = U L / ν = 0.02 · n / (0.002 · n) = 10 at every resolution.
            c.decay_times = if quick { 0.1 } else { 0.5 };
            c.run()
        })
        .collect();
    use crate::solid::{Integrator, Preconditioner, bench::solid_speed, bench::solid_speed_with};
    let mut solid = Vec::new();
    for side in if !wants("solid") {
        vec![]
    } else if quick {
        vec![20]
    } else {
        vec![46, 100]
    } {
        solid.push(solid_speed(side, Integrator::Explicit, if quick { 3 } else { 5 }, bw));
        solid.push(solid_speed(side, Integrator::Implicit, if quick { 2 } else { 3 }, bw));
        // the smoother against block Jacobi, in the same process (not at 10⁶ particles, where
        // block Jacobi's ~110 iterations per step would add a quarter of an hour here)
        if side < 100 {
            solid.push(solid_speed_with(side, Integrator::Implicit, Preconditioner::BlockJacobi, if quick { 2 } else { 3 }, bw));
        }
    }
    // the crossover: the benchmark material (its step limited by the elastic waves) and the same
    // block 100, 1000 and 10⁴ times as viscous (the viscous term limits the explicit step)
    let solid_crossover = match (wants("solid") || only == Some("crossover"), quick) {
        (false, _) => Vec::new(),
        (true, true) => crate::solid::bench::crossover(8, &[crate::solid::bench::BENCHMARK_VISCOSITY, 1000.0], &[2.0, 10.0], 2),
        (true, false) => {
            crate::solid::bench::crossover(12, &[crate::solid::bench::BENCHMARK_VISCOSITY, 100.0, 1000.0, 10000.0], &[10.0, 30.0, 100.0, 300.0], 2)
        }
    };
    for v in &mut solid {
        v.flop_fraction = v.flops_per_update.map(|f| f * v.particle_updates_per_s / fma.best);
    }
    let lattice_gas = if wants("lattice_gas") {
        let (cells, steps) = if quick { ([32, 16, 8], 3) } else { ([256, 128, 64], 4) };
        vec![crate::lattice_gas::bench::cpu_speed(cells, steps, bw), crate::lattice_gas::bench::cpu_speed_site_by_site(cells, steps, bw)]
    } else {
        Vec::new()
    };
    let coupled = if wants("coupled") { coupled_speed_vs_error(quick) } else { Vec::new() };
    let two_mass = if wants("two_mass") { two_mass_speed_vs_error() } else { Vec::new() };
    let glottis = if !wants("glottis") {
        Vec::new()
    } else if quick {
        glottis_speed(&["glottis_2d_coarse"], 20)
    } else {
        glottis_speed(&["glottis_2d_coarse", "glottis_2d_c"], 300)
    };
    let scaling = if only == Some("scaling") { scaling::scaling_table(quick) } else { Vec::new() };
    let (storage, storage_errors) = if wants("storage") {
        (
            vec![storage_speed(VelocitySetKind::D2q21, [n2, n2, 1], st, 5, bw), storage_speed(VelocitySetKind::D3q39, [n3, n3, n3], st.min(5), 5, bw)],
            storage_errors(),
        )
    } else {
        (Vec::new(), Vec::new())
    };
    BenchReport {
        storage,
        storage_errors,
        scaling,
        threads: rayon::current_num_threads(),
        triad_bandwidth_gb_s: bw / 1e9,
        triad,
        fma_peak: fma,
        last_level_cache_bytes: last_level_cache_bytes(),
        lattices,
        speed_vs_error,
        solid,
        solid_crossover,
        lattice_gas,
        coupled,
        two_mass,
        glottis,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The full benchmark's sizes leave the cache on a machine with a large one: the triad's
    /// three arrays are at least three times the cache, and the lattice the smallest multiple of
    /// 32 whose swept bytes are at least twice it.
    #[test]
    fn the_full_benchmark_sizes_exceed_the_last_level_cache() {
        assert_eq!(triad_elements(32 << 20), 1 << 25);
        assert_eq!(triad_elements(480 << 20), 1 << 26);
        assert!(3 * 8 * triad_elements(480 << 20) >= 3 * (480 << 20));
        let llc = 24 << 20;
        let side = side_beyond_cache(VelocitySetKind::D2q21, 64, llc);
        let footprint = |n: usize| fluid_footprint(&benchmark_solver_stored::<f64>(VelocitySetKind::D2q21, [n, n, 1]));
        assert_eq!(side % 32, 0);
        assert!(footprint(side) >= 2 * llc, "side {side}: {} B", footprint(side));
        assert!(footprint(side - 32) < 2 * llc, "side {} already beyond the cache", side - 32);
        // a floor the cache does not reach is kept
        assert_eq!(side_beyond_cache(VelocitySetKind::D2q21, 512, llc), 512);
    }
}
