//! The validation cases of the implicit solid at a million particles (issue 16's iteration goal).

use super::case;
use crate::validation::suite::Case;
use std::time::Instant;

/// These cases, in the order `phonation validate` runs them.
pub(super) fn cases() -> Vec<Case> {
    vec![case(
        "solid_implicit_million",
        "the implicit solid's CG on the 10⁶-particle block at 10× the explicit step: ≤ 30 iterations to 10⁻⁸ (issue 16's goal)",
        "≈ 13 min, 6.9 GB of memory",
        || {
            // the yardstick for the implicit solve: the 10⁶-particle benchmark block
            // (100³, clamped on one face, released from a shear) at 10× the explicit limit, CG to
            // 10⁻⁸ with the patch smoother and the coarse space (the default: block-sparse at this
            // size, with a third level). Measured 2026-12-04 (2 cores, 13 min, 6.9 GB): 27 and 28
            // iterations (76 and 81 before the patches lost their thin remainders and the coarse
            // space its 2000-unknown cap)
            use crate::solid::{Integrator, bench::benchmark_block};
            let mut s = benchmark_block(100, Integrator::Implicit);
            let mut out = Vec::new();
            for k in 1..=2 {
                let t = Instant::now();
                let ok = s.step().is_ok();
                let cg = s.last.cg;
                println!(
                    "solid_implicit_million: step {k}: {} CG iterations, residual {:.2e}, {:.1} s",
                    cg.iterations,
                    cg.relative_residual,
                    t.elapsed().as_secs_f64()
                );
                out.push((
                    format!("{} particles, step {k}: CG iterations", s.particles.len()),
                    cg.iterations as f64,
                    "≤ 30 (issue 16's goal), converged to 10⁻⁸".into(),
                    ok && cg.converged && cg.iterations <= 30,
                ));
                if !ok {
                    break;
                }
            }
            out
        },
    )]
}
