//! Speed measurements (a `bench` subcommand, never a timed test): the machine's memory bandwidth
//! (a STREAM-like triad) and the FDLB node updates per second measured in the same process, the
//! bytes moved per node update and the fraction of bandwidth achieved; and speed-vs-error tables
//! (Taylor–Green at three resolutions; the coupled Schäfer–Turek cylinder at three resolutions).
//!
//! By what they measure: `roofline` the machine's own rates (triad, FMA peak), `fluid` the
//! FDLB, `coupled` the coupled, glottis and two-mass rows, [`scaling`] cost against size; this
//! module the report and the suites `phonation bench` runs.

mod coupled;
mod fluid;
mod roofline;
pub mod scaling;

pub use coupled::*;
pub use fluid::*;
pub use roofline::*;

use crate::fluid::storage::Storage;
use crate::fluid::{Boundaries, Equilibrium, FluidSolver, GasModel, Grid, Macro, VelocitySet, VelocitySetKind, timestep};
use crate::validation::taylor_green::{TaylorGreenCase, TaylorGreenResult};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

pub use crate::machine::{fraction_of_bandwidth, last_level_cache_bytes};

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

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub threads: usize,
    pub triad_bandwidth_gb_s: f64,
    /// The triad's repetitions (best, median, worst).
    pub triad: Bandwidth,
    /// The f64 peak of the roofline ([`fma_peak`]).
    pub fma_peak: FlopRate,
    /// The scalar f64 FMA rate ([`scalar_fma_peak`]; `None` off x86-64 or without FMA).
    pub scalar_fma_peak: Option<FlopRate>,
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
    /// The coupled glottis scenes' fluid_geometry stage alone, at full size ([`geometry_speed`];
    /// only with `--only geometry`: building the 3D glottis takes a minute).
    pub geometry: Vec<GeometrySpeed>,
}

/// Parts of the benchmark, for `bench --only`.
pub const SUITES: [&str; 11] = ["fdlb", "storage", "solid", "crossover", "lattice_gas", "coupled", "two_mass", "glottis", "drawing", "scaling", "geometry"];

/// The CPU benchmark (every suite of [`SUITES`], or only `only`). `quick` shrinks grids for a
/// smoke run.
pub fn run(quick: bool, only: Option<&str>) -> BenchReport {
    let wants = |suite: &str| only.is_none_or(|o| o == suite);
    let llc = last_level_cache_bytes();
    let triad = triad(if quick { 1 << 23 } else { triad_elements(llc) }, 10);
    let fma = fma_peak(5);
    let scalar_fma = scalar_fma_peak(5);
    let sizes = Sizes::of(quick, llc, triad.best);
    let (lattices, speed_vs_error) = if wants("fdlb") { fdlb_suite(&sizes) } else { (Vec::new(), Vec::new()) };
    let mut solid = if wants("solid") { solid_suite(&sizes) } else { Vec::new() };
    let solid_crossover = if wants("solid") || only == Some("crossover") { crossover_suite(quick) } else { Vec::new() };
    for v in &mut solid {
        v.flop_fraction = v.flops_per_update.map(|f| f * v.particle_updates_per_s / fma.best);
        v.scalar_flop_fraction = v.flops_per_update.zip(scalar_fma).map(|(f, peak)| f * v.particle_updates_per_s / peak.best);
    }
    let lattice_gas = if wants("lattice_gas") { lattice_gas_suite(&sizes) } else { Vec::new() };
    let coupled = if wants("coupled") { coupled_speed_vs_error(quick) } else { Vec::new() };
    let two_mass = if wants("two_mass") { two_mass_speed_vs_error() } else { Vec::new() };
    let glottis = match (wants("glottis"), quick) {
        (false, _) => Vec::new(),
        (true, true) => glottis_speed(&["glottis_2d_coarse"], 20),
        (true, false) => glottis_speed(&["glottis_2d_coarse", "glottis_2d_c"], 300),
    };
    let scaling = if only == Some("scaling") { scaling::scaling_table(quick) } else { Vec::new() };
    let geometry = match (only == Some("geometry"), quick) {
        (false, _) => Vec::new(),
        (true, true) => geometry_speed(&["glottis_2d_coarse", "glottis_3d_coarse"], 4),
        (true, false) => geometry_speed(&["glottis_2d_c", "glottis_3d_coarse", "glottis_3d"], 8),
    };
    let (storage, storage_errors) = if wants("storage") { storage_suite(&sizes) } else { (Vec::new(), Vec::new()) };
    BenchReport {
        storage,
        storage_errors,
        scaling,
        threads: rayon::current_num_threads(),
        triad_bandwidth_gb_s: triad.best / 1e9,
        triad,
        fma_peak: fma,
        scalar_fma_peak: scalar_fma,
        last_level_cache_bytes: last_level_cache_bytes(),
        lattices,
        speed_vs_error,
        solid,
        solid_crossover,
        lattice_gas,
        coupled,
        two_mass,
        glottis,
        geometry,
    }
}

/// The sizes of one benchmark run: the FDLB lattices' sides (2D, 3D; beyond the last-level
/// cache unless `quick`) and steps, and the triad bandwidth (B/s) the fractions are taken of.
struct Sizes {
    quick: bool,
    n2: usize,
    n3: usize,
    steps: u64,
    bandwidth: f64,
}

impl Sizes {
    fn of(quick: bool, llc: usize, bandwidth: f64) -> Self {
        let (n2, n3, steps) =
            if quick { (128, 32, 3) } else { (side_beyond_cache(VelocitySetKind::D2q21, 512, llc), side_beyond_cache(VelocitySetKind::D3q39, 96, llc), 10) };
        Sizes { quick, n2, n3, steps, bandwidth }
    }
}

/// The FDLB's node updates per second (D2Q21, D3Q39) and Taylor–Green's speed against error
/// at three resolutions.
fn fdlb_suite(z: &Sizes) -> (Vec<LatticeSpeed>, Vec<TaylorGreenResult>) {
    let (n2, n3, st, bw) = (z.n2, z.n3, z.steps, z.bandwidth);
    let lattices = vec![lattice_speed(VelocitySetKind::D2q21, [n2, n2, 1], st, 5, bw), lattice_speed(VelocitySetKind::D3q39, [n3, n3, n3], st.min(5), 5, bw)];
    let speed_vs_error = [32usize, 64, 128]
        .iter()
        .map(|&n| {
            let mut c = TaylorGreenCase::new(VelocitySetKind::D2q21, n);
            // Fixed physical problem: Re = U L / ν = 0.02 · n / (0.002 · n) = 10 at every resolution.
            c.decay_times = if z.quick { 0.1 } else { 0.5 };
            c.run()
        })
        .collect();
    (lattices, speed_vs_error)
}

/// The solid's particle updates per second: the explicit and implicit steps of cubes of two
/// sides (the smoother against block Jacobi on the smaller), and the explicit step in the plane.
fn solid_suite(z: &Sizes) -> Vec<crate::solid::bench::SolidSpeed> {
    use crate::solid::{Integrator, Preconditioner, bench::plane_solid_speed, bench::solid_speed, bench::solid_speed_with};
    let (quick, bw) = (z.quick, z.bandwidth);
    let mut solid = Vec::new();
    for side in if quick { vec![20] } else { vec![46, 100] } {
        solid.push(solid_speed(side, Integrator::Explicit, if quick { 3 } else { 5 }, bw));
        solid.push(solid_speed(side, Integrator::Implicit, if quick { 2 } else { 3 }, bw));
        // the smoother against block Jacobi, in the same process (not at 10⁶ particles, where
        // block Jacobi's ~110 iterations per step would add a quarter of an hour here)
        if side < 100 {
            solid.push(solid_speed_with(side, Integrator::Implicit, Preconditioner::BlockJacobi, if quick { 2 } else { 3 }, bw));
        }
    }
    // the explicit step in the plane: a plate of the 2D glottis's size (17,000 particles, in the
    // cache) and one of 10⁶ particles (out of it)
    for side in if quick { vec![40] } else { vec![130, 1000] } {
        solid.push(plane_solid_speed(side, if quick { 3 } else { 20 }, bw));
    }
    solid
}

/// The crossover: the benchmark material (its step limited by the elastic waves) and the same
/// block 100, 1000 and 10⁴ times as viscous (the viscous term limits the explicit step).
fn crossover_suite(quick: bool) -> Vec<crate::solid::bench::CrossoverRow> {
    use crate::solid::bench::{BENCHMARK_VISCOSITY, crossover};
    if quick {
        crossover(8, &[BENCHMARK_VISCOSITY, 1000.0], &[2.0, 10.0], 2)
    } else {
        crossover(12, &[BENCHMARK_VISCOSITY, 100.0, 1000.0, 10000.0], &[10.0, 30.0, 100.0, 300.0], 2)
    }
}

/// The lattice gas's site updates per second, word-parallel and site by site.
fn lattice_gas_suite(z: &Sizes) -> Vec<crate::lattice_gas::bench::LatticeGasSpeed> {
    let (cells, steps) = if z.quick { ([32, 16, 8], 3) } else { ([256, 128, 64], 4) };
    vec![crate::lattice_gas::bench::cpu_speed(cells, steps, z.bandwidth), crate::lattice_gas::bench::cpu_speed_site_by_site(cells, steps, z.bandwidth)]
}

/// The FDLB's storage options' speed (D2Q21, D3Q39) and their errors.
fn storage_suite(z: &Sizes) -> (Vec<StorageSpeed>, Vec<StorageError>) {
    let (n2, n3, st, bw) = (z.n2, z.n3, z.steps, z.bandwidth);
    (
        vec![storage_speed(VelocitySetKind::D2q21, [n2, n2, 1], st, 5, bw), storage_speed(VelocitySetKind::D3q39, [n3, n3, n3], st.min(5), 5, bw)],
        storage_errors(),
    )
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
