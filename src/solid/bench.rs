//! Particle updates per second of the MPS solid (explicit and implicit steps) and the fraction
//! of the measured memory bandwidth they reach.
//!
//! Bytes per particle update (explicit), a lower bound of the traffic of the two force kernels
//! and the integration: per bond the neighbour index (4), reverse index (4), r⁰ (24), shift
//! (24), ŵ (8), k (8), c (8), g (24) read twice (strain_stress and bond_forces, 2 × 104 B, the
//! neighbour's state mostly from cache), plus per particle the 6×6 stiffness (288), x, v, ω,
//! q, f, τ, Q and strain (≈ 400 B).

//! Flops per particle update (explicit), the other roof: [`FLOPS_PER_BOND`] counted in the
//! source of the two bond loops (the per-particle work — quaternion to matrix, the 6×6
//! stress, the integration — is left out, so the count is a lower bound).

use super::particles::{Particles, sample_box};
use super::{Integrator, Orthotropic, SolidOptions, SolidSolver};
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

#[derive(Clone, Debug, Serialize)]
pub struct SolidSpeed {
    pub integrator: Integrator,
    pub particles: usize,
    pub bonds: usize,
    pub particle_updates_per_s: f64,
    pub bytes_per_update: f64,
    /// Of the triad bandwidth measured in the same process; `None` when the particles' data
    /// fits in the cache ([`crate::machine::fraction_of_bandwidth`]).
    pub bandwidth_fraction: Option<f64>,
    /// Explicit steps: [`FLOPS_PER_BOND`] × bonds per particle (a lower bound); `None` for the
    /// implicit step (its CG work depends on the iterations).
    pub flops_per_update: Option<f64>,
    /// Of the f64 peak measured in the same process (the bench fills it in:
    /// `bench::fma_peak`).
    pub flop_fraction: Option<f64>,
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
    let t0 = Instant::now();
    let mut s = benchmark_block(side, integrator);
    let setup = t0.elapsed().as_secs_f64();
    s.step().expect("the benchmark block stays finite");
    let t = Instant::now();
    let mut iters = 0usize;
    for _ in 0..steps {
        s.step().expect("the benchmark block stays finite");
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
    SolidSpeed {
        integrator: s.options.integrator,
        particles: n,
        bonds,
        particle_updates_per_s: ups,
        bytes_per_update: bytes,
        bandwidth_fraction: if cpu { crate::machine::fraction_of_bandwidth(ups * bytes, footprint(s), bandwidth) } else { Some(ups * bytes / bandwidth) },
        flops_per_update: (s.options.integrator == Integrator::Explicit).then(|| FLOPS_PER_BOND * bonds as f64 / n as f64),
        flop_fraction: None,
        cg_iterations: iters as f64 / steps as f64,
        time_step_over_explicit_limit: s.dt / s.explicit_limit,
        stage_shares,
        setup_s: setup,
    }
}

/// The benchmark body: a `side`³ cube, clamped on one face, released from a small shear.
pub fn benchmark_block(side: usize, integrator: Integrator) -> SolidSolver {
    let mat = Orthotropic { young: [1.0e6, 3.0e6, 2.0e6], poisson: [0.2, 0.25, 0.3], shear: [4.0e5, 5.0e5, 6.0e5], density: 1.0, viscosity: 1.0 };
    let l0 = 0.1;
    let mut p = Particles::new(3, l0);
    for x in sample_box(3, DVec3::ZERO, DVec3::splat(side as f64 * l0), l0) {
        p.push(x, 1.0, 0, 0, x.x < l0);
    }
    for i in 0..p.len() {
        p.velocity[i] = DVec3::new(0.0, 0.1 * p.reference[i].x, 0.0);
    }
    let mut s = SolidSolver::new(p, vec![mat], SolidOptions { integrator, ..Default::default() }).expect("valid benchmark block");
    if integrator == Integrator::Implicit {
        s.dt = 10.0 * s.explicit_limit;
    }
    s
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
        }
    }
}
