//! Particle updates per second of the MPS solid (explicit and implicit steps) and the fraction
//! of the measured memory bandwidth they reach.
//!
//! Bytes per particle update (explicit), the byte count the fractions have used since issue 16
//! was filed (kept so that they compare across sessions): per bond the neighbour index (4),
//! reverse index (4), r⁰ (24), shift (24), ŵ (8), k (8), c (8), g (24) counted twice
//! (strain_stress and bond_forces, 2 × 104 B, the neighbour's state mostly from cache), plus per
//! particle the 6×6 stiffness (288), x, v, ω, q, f, τ, Q and strain (≈ 400 B). What the kernels
//! read per bond is less: strain_stress the neighbour and g (28 B), bond_forces the neighbour,
//! g, g_ji, r⁰, k and c (92 B), and the shift (24 B in each) only in a body with periodic bonds
//! (`Bonds::periodic`) — 120 of the counted 208 B. Neither roof bounds the bond loops alone:
//! the 10⁶ block reads about half the triad by those 120 B and runs at about half the scalar
//! FMA rate (`scalar_flop_fraction`; glam's f64 vectors and matrices are scalar arithmetic, and
//! not every counted flop is part of an FMA). Reading 48 B fewer per bond made it 1.05–1.22×
//! faster (interleaved runs); reading r⁰ from the particles' reference positions instead of
//! `r0` (24 B less again, one more gather) made `bond_forces` slower.

//! Flops per particle update (explicit), the other roof: [`FLOPS_PER_BOND`] counted in the
//! source of the two bond loops (the per-particle work — quaternion to matrix, the 6×6
//! stress, the integration — is left out, so the count is a lower bound).

use super::particles::{Particles, sample_box};
use super::{Integrator, Orthotropic, Preconditioner, SolidOptions, SolidSolver};
use glam::DVec3;
use serde::Serialize;
use std::time::Instant;

/// Flops per bond of an explicit step with viscosity (an FMA counts 2; glam's f64 vectors are
/// scalar arithmetic), counted in `forces.rs`: `strain_stress` 24 (r = x_j + s − x_i 6, the
/// outer product r ⊗ g 9 and its sum 9); `bond_forces` 139 (Σ g 3; Q_j g_ji 15 and its
/// subtraction 3; R_i r⁰ and R_j r⁰ 30; r 6; u = r − ½(a_i + a_j) 9; f += k u 6; the torque
/// ½k a_i × u 16; the energy ¼k|u|² 8; the viscous part 43: w̄ 6, v_ij = v_j − v_i − w̄ × r 15,
/// f += c v_ij 6, ½c r × v_ij 16).
pub const FLOPS_PER_BOND: f64 = 24.0 + 139.0;

/// Flops per bond of an explicit step in the plane (`dim` 2), counted in `forces_plane.rs` the
/// same way: `strain_stress` 10 (r 2, r ⊗ g on the x–y block 4 and its sum 4); `bond_forces`
/// 65 (Σ g 2; Q_j g_ji 6 and its subtraction 2; R_i r⁰ and R_j r⁰ 12; r 2; u 6; f += k u 4; the
/// torque ½k (a_i × u)_z 6; the energy 6; the viscous part 19: w̄ 2, v_ij 7, f += c v_ij 4,
/// ½c (r × v_ij)_z 6).
pub const FLOPS_PER_BOND_PLANE: f64 = 10.0 + 65.0;

#[derive(Clone, Debug, Serialize)]
pub struct SolidSpeed {
    /// 3 for the benchmark cube, 2 for the plate ([`plane_solid_speed`]).
    pub dim: usize,
    pub integrator: Integrator,
    /// The implicit step's smoother (`None` for explicit steps).
    pub preconditioner: Option<Preconditioner>,
    pub particles: usize,
    pub bonds: usize,
    pub particle_updates_per_s: f64,
    pub bytes_per_update: f64,
    /// Of the triad bandwidth measured in the same process; `None` when the particles' data
    /// fits in the cache ([`crate::machine::fraction_of_bandwidth`]).
    pub bandwidth_fraction: Option<f64>,
    /// Explicit steps: [`FLOPS_PER_BOND`] (in the plane [`FLOPS_PER_BOND_PLANE`]) × bonds per
    /// particle (a lower bound); `None` for the implicit step (its CG work depends on the
    /// iterations).
    pub flops_per_update: Option<f64>,
    /// Of the f64 peak measured in the same process (the bench fills it in:
    /// `bench::fma_peak`).
    pub flop_fraction: Option<f64>,
    /// Of the scalar FMA rate measured in the same process (`bench::scalar_fma_peak`): the
    /// roof of the bond loops, which are scalar f64 code.
    pub scalar_flop_fraction: Option<f64>,
    /// Mean CG iterations per implicit step (0 for explicit).
    pub cg_iterations: f64,
    pub time_step_over_explicit_limit: f64,
    pub stage_shares: Vec<(&'static str, f64)>,
    pub setup_s: f64,
}

/// Bytes of the bond data (104 per bond) and the per-particle state (≈ 700) a step reads.
pub fn footprint(s: &SolidSolver) -> usize {
    104 * s.disc.bonds.len() + 700 * s.particles.len()
}

/// A cube of `side`³ particles of the orthotropic test material, clamped on one face and
/// released from a small shear (so that CG has work to do).
pub fn solid_speed(side: usize, integrator: Integrator, steps: u64, bandwidth: f64) -> SolidSpeed {
    solid_speed_with(side, integrator, Preconditioner::default(), steps, bandwidth)
}

/// [`solid_speed`] with the implicit step preconditioned by `preconditioner`'s smoother.
pub fn solid_speed_with(side: usize, integrator: Integrator, preconditioner: Preconditioner, steps: u64, bandwidth: f64) -> SolidSpeed {
    timed_steps(
        || {
            let mut s = benchmark_block(side, integrator);
            s.options.preconditioner = preconditioner;
            s
        },
        steps,
        bandwidth,
    )
}

/// [`solid_speed`]'s explicit step in the plane: a `side`² plate ([`benchmark_plate`]), what
/// the 2D glottis's folds run on (the plane kernels of `forces_plane.rs`).
pub fn plane_solid_speed(side: usize, steps: u64, bandwidth: f64) -> SolidSpeed {
    timed_steps(|| benchmark_plate(side, Integrator::Explicit), steps, bandwidth)
}

/// The body `build` makes (its setup timed), one step untimed, then `steps` timed steps.
fn timed_steps(build: impl FnOnce() -> SolidSolver, steps: u64, bandwidth: f64) -> SolidSpeed {
    let t0 = Instant::now();
    let mut s = build();
    let setup = t0.elapsed().as_secs_f64();
    s.step().expect("the benchmark body stays finite");
    let t = Instant::now();
    let mut iters = 0usize;
    for _ in 0..steps {
        s.step().expect("the benchmark body stays finite");
        iters += s.last.cg.iterations;
    }
    let wall = t.elapsed().as_secs_f64();
    speed_of(true, &s, steps, wall, iters, setup, s.stage_shares(), bandwidth)
}

/// The figures of `steps` steps that took `wall` seconds (and `iters` CG iterations in all);
/// `cpu`: the bandwidth is the CPU triad, and no fraction is given when the particles fit in the
/// CPU's cache.
#[allow(clippy::too_many_arguments)]
pub fn speed_of(
    cpu: bool,
    s: &SolidSolver,
    steps: u64,
    wall: f64,
    iters: usize,
    setup: f64,
    stage_shares: Vec<(&'static str, f64)>,
    bandwidth: f64,
) -> SolidSpeed {
    let n = s.particles.len();
    let bonds = s.disc.bonds.len();
    let ups = n as f64 * steps as f64 / wall;
    let bytes = 2.0 * 104.0 * bonds as f64 / n as f64 + 700.0;
    let per_bond = if s.disc.dim == 2 { FLOPS_PER_BOND_PLANE } else { FLOPS_PER_BOND };
    SolidSpeed {
        dim: s.disc.dim,
        integrator: s.options.integrator,
        preconditioner: (s.options.integrator == Integrator::Implicit).then_some(s.options.preconditioner),
        particles: n,
        bonds,
        particle_updates_per_s: ups,
        bytes_per_update: bytes,
        bandwidth_fraction: if cpu { crate::machine::fraction_of_bandwidth(ups * bytes, footprint(s), bandwidth) } else { Some(ups * bytes / bandwidth) },
        flops_per_update: (s.options.integrator == Integrator::Explicit).then(|| per_bond * bonds as f64 / n as f64),
        flop_fraction: None,
        scalar_flop_fraction: None,
        cg_iterations: iters as f64 / steps as f64,
        time_step_over_explicit_limit: s.dt / s.explicit_limit,
        stage_shares,
        setup_s: setup,
    }
}

/// The benchmark body: a `side`³ cube, clamped on one face, released from a small shear.
pub fn benchmark_block(side: usize, integrator: Integrator) -> SolidSolver {
    benchmark_block_with_viscosity(side, integrator, BENCHMARK_VISCOSITY)
}

/// The benchmark material's viscosity (model units: the block's E ~ 10⁶, ρ = 1, l₀ = 0.1).
pub const BENCHMARK_VISCOSITY: f64 = 1.0;

/// The benchmark body in the plane: a `side`² plate of the same material, spacing and
/// viscosity, clamped on one edge, released from the same small shear; implicit at 10× the
/// explicit limit as [`benchmark_block`].
pub fn benchmark_plate(side: usize, integrator: Integrator) -> SolidSolver {
    benchmark_body(2, side, integrator, BENCHMARK_VISCOSITY)
}

/// [`benchmark_block`] with the material's viscosity set to `viscosity`.
pub fn benchmark_block_with_viscosity(side: usize, integrator: Integrator, viscosity: f64) -> SolidSolver {
    benchmark_body(3, side, integrator, viscosity)
}

/// The benchmark body in `dim` dimensions: a `side`-particle cube (3) or square (2) of spacing
/// l₀ = 0.1, clamped on its x < l₀ face, released from the shear v_y = 0.1 x.
fn benchmark_body(dim: usize, side: usize, integrator: Integrator, viscosity: f64) -> SolidSolver {
    let mat = Orthotropic { young: [1.0e6, 3.0e6, 2.0e6], poisson: [0.2, 0.25, 0.3], shear: [4.0e5, 5.0e5, 6.0e5], density: 1.0, viscosity };
    let l0 = 0.1;
    let edge = side as f64 * l0;
    let extent = if dim == 3 { DVec3::splat(edge) } else { DVec3::new(edge, edge, 0.0) };
    let mut p = Particles::new(dim, l0);
    for x in sample_box(dim, DVec3::ZERO, extent, l0) {
        p.push(x, 1.0, 0, 0, x.x < l0);
    }
    for i in 0..p.len() {
        p.velocity[i] = DVec3::new(0.0, 0.1 * p.reference[i].x, 0.0);
    }
    let mut s = SolidSolver::new(p, vec![mat], SolidOptions { integrator, ..Default::default() }).expect("valid benchmark body");
    if integrator == Integrator::Implicit {
        s.dt = 10.0 * s.explicit_limit;
    }
    s
}

/// One row of the implicit-against-explicit crossover ([`crossover`]).
#[derive(Clone, Debug, Serialize)]
pub struct CrossoverRow {
    /// The material's viscosity (model units) and its explicit limit over the same block's
    /// limit without viscosity: 1 when the step is limited by the elastic waves, ≪ 1 when
    /// the viscous term limits it.
    pub viscosity: f64,
    pub limit_over_inviscid_limit: f64,
    pub particles: usize,
    pub integrator: Integrator,
    pub time_step_over_explicit_limit: f64,
    pub steps: u64,
    /// Mean CG iterations per step (0 for explicit), and whether every solve reached the
    /// tolerance (`cg_tolerance`, default 10⁻⁸) within `cg_max_iterations`.
    pub cg_iterations: f64,
    pub cg_converged: bool,
    /// Wall seconds per step and per simulated second (the preconditioner's one-off setup left
    /// out: [`SolidSolver::prepare_preconditioner`]).
    pub wall_per_step_s: f64,
    pub wall_per_simulated_s: f64,
    /// This row's wall per simulated second over the explicit row's (same material): < 1
    /// where the implicit step is the cheaper way to the same simulated time.
    pub cost_over_explicit: f64,
    /// ‖x − x_explicit‖ / ‖x_explicit − x⁰‖ over the particles at the common end time: what
    /// the longer step costs in accuracy (0 for the explicit row, the reference).
    pub displacement_error: f64,
}

/// The crossover of the implicit and the explicit step (issue 16: "the implicit step is faster
/// per simulated second wherever the explicit step is limited by viscosity"): for each
/// viscosity, the `side`³ benchmark block run to the same simulated time
/// T = `steps_at_largest` × max(`ratios`) × explicit limit, explicitly at the default step
/// (half the limit) and implicitly at each of `ratios` × the limit (seed 000 (2.63)–(2.66),
/// CG to the default tolerance). Rows per viscosity: the explicit one, then one per ratio.
pub fn crossover(side: usize, viscosities: &[f64], ratios: &[f64], steps_at_largest: u64) -> Vec<CrossoverRow> {
    let largest = ratios.iter().copied().fold(0.0, f64::max);
    let mut rows = Vec::new();
    for &viscosity in viscosities {
        let inviscid = benchmark_block_with_viscosity(side, Integrator::Explicit, 0.0).explicit_limit;
        let mut explicit = benchmark_block_with_viscosity(side, Integrator::Explicit, viscosity);
        let limit = explicit.explicit_limit;
        let end = steps_at_largest as f64 * largest * limit;
        let run = |s: &mut SolidSolver| {
            let steps = (end / s.dt).round().max(1.0) as u64;
            s.dt = end / steps as f64;
            if s.options.integrator == Integrator::Implicit {
                // the one-off setup (block Jacobi, the probed coarse space) is not per-step cost
                s.prepare_preconditioner();
            }
            let (t, mut iters, mut converged) = (Instant::now(), 0usize, true);
            for _ in 0..steps {
                s.step().expect("the benchmark block stays finite");
                iters += s.last.cg.iterations;
                converged &= s.options.integrator == Integrator::Explicit || s.last.cg.converged;
            }
            (steps, iters as f64 / steps as f64, t.elapsed().as_secs_f64(), converged)
        };
        let row = |s: &SolidSolver, (steps, cg, wall, converged): (u64, f64, f64, bool), reference: Option<(&[DVec3], f64)>| {
            let p = &s.particles;
            let (error, cost) = match reference {
                None => (0.0, 1.0),
                Some((x_ref, explicit_cost)) => {
                    let diff: f64 = (0..p.len()).map(|i| (p.position[i] - x_ref[i]).length_squared()).sum();
                    let moved: f64 = (0..p.len()).map(|i| (x_ref[i] - p.reference[i]).length_squared()).sum();
                    ((diff / moved).sqrt(), wall / end / explicit_cost)
                }
            };
            CrossoverRow {
                viscosity,
                limit_over_inviscid_limit: limit / inviscid,
                particles: p.len(),
                integrator: s.options.integrator,
                time_step_over_explicit_limit: s.dt / limit,
                steps,
                cg_iterations: cg,
                cg_converged: converged,
                wall_per_step_s: wall / steps as f64,
                wall_per_simulated_s: wall / end,
                cost_over_explicit: cost,
                displacement_error: error,
            }
        };
        let measured = run(&mut explicit);
        rows.push(row(&explicit, measured, None));
        let explicit_cost = measured.2 / end;
        let x_ref = explicit.particles.position.clone();
        for &ratio in ratios {
            let mut s = benchmark_block_with_viscosity(side, Integrator::Implicit, viscosity);
            s.dt = ratio * s.explicit_limit;
            let measured = run(&mut s);
            rows.push(row(&s, measured, Some((&x_ref, explicit_cost))));
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::step::{Part, Site, Solver};

    #[test]
    fn a_time_step_far_above_the_explicit_limit_stops_with_a_diagnosis() {
        let mut s = benchmark_block(4, Integrator::Explicit);
        s.dt = 20.0 * s.explicit_limit;
        let e = Solver::advance(&mut s, 5000).expect_err("twenty times the explicit limit diverges");
        assert_eq!(e.part, Part::Solid);
        assert!(matches!(e.site, Site::Particle(i) if i < s.particles.len()), "{e}");
        assert!(e.step >= 1 && e.step == s.step_count && e.step < 5000, "{e}");
        assert!(e.to_string().contains("explicit limit"), "{e}");
        // at the explicit limit's half (the scene default) the same block stays finite
        let mut s = benchmark_block(4, Integrator::Explicit);
        Solver::advance(&mut s, 200).expect("half the explicit limit is stable");
        assert_eq!(Solver::step_count(&s), 200);
    }

    #[test]
    fn the_crossover_runs_every_integrator_to_the_same_time_and_measures_the_error_against_the_explicit_run() {
        // a 5³ block, elastic-limited (viscosity 0.1) and viscosity-limited (100): the explicit
        // row is the reference; the implicit rows reach the same time in fewer steps
        let rows = crossover(5, &[0.1, 100.0], &[2.0, 8.0], 2);
        assert_eq!(rows.len(), 6);
        for m in rows.chunks(3) {
            let (e, i2, i8) = (&m[0], &m[1], &m[2]);
            assert_eq!(e.integrator, Integrator::Explicit);
            assert_eq!(e.displacement_error, 0.0);
            assert!((e.time_step_over_explicit_limit - 0.5).abs() < 0.02, "{e:?}");
            // T = 2 × 8 limits: 32 explicit steps, 8 and 2 implicit ones
            assert_eq!((e.steps, i2.steps, i8.steps), (32, 8, 2));
            for i in [i2, i8] {
                assert_eq!(i.integrator, Integrator::Implicit);
                assert!(i.cg_iterations >= 1.0 && i.cg_converged, "{i:?}");
                assert!(i.displacement_error > 0.0 && i.displacement_error < 1.0, "{i:?}");
                assert!((i.cost_over_explicit - i.wall_per_simulated_s / e.wall_per_simulated_s).abs() < 1e-9 * i.cost_over_explicit);
            }
            // the longer step departs further from the explicit reference
            assert!(i8.displacement_error > i2.displacement_error, "{i2:?} {i8:?}");
        }
        // viscosity 0.1 leaves the step to the elastic waves; 100 shortens it
        assert!(rows[0].limit_over_inviscid_limit > 0.9, "{:?}", rows[0]);
        assert!(rows[3].limit_over_inviscid_limit < 0.5, "{:?}", rows[3]);
    }

    #[test]
    fn the_flop_count_follows_the_bonds_of_an_explicit_step_only() {
        // a 6³ block: interior particles have 32 bonds, the faces fewer (r_e = 2.1 l₀)
        for integrator in [Integrator::Explicit, Integrator::Implicit] {
            let s = benchmark_block(6, integrator);
            let v = speed_of(true, &s, 1, 1.0, 0, 0.0, Vec::new(), 1e10);
            let per_particle = s.disc.bonds.len() as f64 / s.particles.len() as f64;
            assert!(per_particle > 15.0 && per_particle < 33.0, "{per_particle} bonds per particle");
            match integrator {
                Integrator::Explicit => assert_eq!(v.flops_per_update, Some(163.0 * s.disc.bonds.len() as f64 / s.particles.len() as f64)),
                Integrator::Implicit => assert_eq!(v.flops_per_update, None),
            }
            assert_eq!(v.dim, 3);
        }
        // the plate: the plane kernels' 75 flops a bond, at most 12 bonds a particle in 2D
        let s = benchmark_plate(8, Integrator::Explicit);
        let v = speed_of(true, &s, 1, 1.0, 0, 0.0, Vec::new(), 1e10);
        let per_particle = s.disc.bonds.len() as f64 / s.particles.len() as f64;
        assert!(per_particle > 6.0 && per_particle <= 12.0, "{per_particle} bonds per particle");
        assert_eq!((v.dim, v.flops_per_update), (2, Some(75.0 * s.disc.bonds.len() as f64 / s.particles.len() as f64)));
    }
}
