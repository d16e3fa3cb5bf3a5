//! The validation cases of the glottis: cases A–D, real air, the coarse 3D glottis, the seed's layer list, the fold modes, the air work, self-oscillation, the stiffness ratios and speed against error.

use super::case;
use crate::validation::suite::Case;

/// These cases, in the order `phonation validate` runs them.
pub(super) fn cases() -> Vec<Case> {
    vec![
        case(
            "soak",
            "a closed box with a vibrating clamped elastic disc, weak coupling, 10⁵ steps: the air's mass and energy drift, momentum, displacement, no instability",
            "≈ 12 min",
            || {
                // a closed box with a vibrating elastic disc, weak coupling, 10⁵ steps
                match crate::validation::soak::soak(crate::validation::soak::SOAK_STEPS) {
                    Ok(r) => {
                        println!("soak: {}", serde_json::to_string(&r).unwrap_or_default());
                        crate::validation::soak::rows(&r, crate::validation::soak::fluid_nodes())
                    }
                    Err(e) => vec![(format!("soak: {e}"), f64::NAN, "runs".into(), false)],
                }
            },
        ),
        case(
            "glottis_2d",
            "cases A–D on glottis_2d_coarse, 40 ms each: stable, f0 against the seed's (±20 %), the ordering A < C < B < D, case C's settling and closure from below",
            "≈ 35 min (2,075 s on 2026-12-05, beside builds)",
            || {
                // Cases A–D on glottis_2d_coarse (62 × 64 cells, Mach-scaled air), 40 ms each:
                // 2,075 s for the four on 2 cores (2026-12-05, beside builds).
                crate::validation::glottis::rows()
            },
        ),
        case(
            "glottis_real_air_closure",
            "the coarse glottis in real air (not Mach-scaled), 4 ms: stable, closed ≥ 20 % of the samples, flowing again at the end",
            "≈ 9 min",
            crate::validation::glottis::real_air_closure_rows,
        ),
        // the coarse 3D glottis, 1.5 ms from rest: 27 min on one core beside another run
        case(
            "glottis_3d_coarse",
            "the coarse 3D glottis (case C, method 2), 1.5 ms from rest: stable, the mirror folds' lateral forces equal and opposite, air passing, the folds pushed apart",
            "≈ 27 min (one core)",
            crate::validation::glottis_3d::rows,
        ),
        case(
            "glottis_seed_layer_list",
            "the seed's case list as written (layers swapped against its narrative), A and C 20 ms side by side: whether it gives the seed's f0",
            "≈ 29 min",
            crate::validation::glottis::seed_layer_list_rows,
        ),
        // each case's fold ringing in vacuum (both readings of the seed's list), the lateral
        // modes of cases A and C, and the coupled case C against its fold: ≈ 15 min on 2 cores
        // beside another run (the lateral modes' four runs: ≈ 3 min on one core)
        case(
            "glottis_fold_modes",
            "each case's fold ringing in vacuum (both readings of the seed's list), the lateral modes of cases A and C, and the coupled case C against its fold",
            "≈ 15 min",
            crate::validation::glottis_modes::rows,
        ),
        // case A's air work per cycle with the zero-gradient outlet and a pressure outlet, 30 ms
        // each: ≈ 6 min each on 2 cores
        case(
            "glottis_air_work",
            "case A's air work on the folds per cycle, zero-gradient outlet against a pressure outlet, 30 ms each",
            "≈ 12 min",
            crate::validation::glottis_energy::rows,
        ),
        // case A with a pressure outlet at twice the seed's lung pressure, 135 ms from rest
        // (600,000 steps): the folds self-oscillate and settle; ≈ 1 h on 2 cores
        case(
            "glottis_self_oscillation",
            "case A with a pressure outlet at twice the seed's lung pressure, 135 ms from rest: self-oscillation that settles (f0, air work > 0, swing and pulses within 10 %, closure every cycle, closure from below)",
            "≈ 45–60 min",
            crate::validation::glottis_self_oscillation::rows,
        ),
        // the hard cases of stiffness: body/cover 100 (case C) and 1000, Poisson 0.97, the lung
        // pressure switched on abruptly, 40 ms each, side by side: ≈ 20 min on 2 cores
        case(
            "glottis_stiffness_ratio",
            "body/cover stiffness 100 and 1000 with Poisson 0.97, the lung pressure switched on abruptly, 40 ms each side by side: finite ≥ 10⁴ steps, mass and energy drift bounded",
            "≈ 20 min",
            crate::validation::glottis_stiffness::rows,
        ),
        case(
            "glottis_speed_error",
            "case C's f0 against lattice resolution (×0.5, ×0.75, ×1) and Mach scaling (real air, Mach 0.3), 40 ms each, with each run's wall time per simulated ms",
            "hours (the real air at ×1 alone ≈ 1.6 h at 122 steps/s)",
            || {
                // Case C's f0 against resolution (×0.5, ×0.75, ×1 of the seed's lattice) and Mach
                // scaling (real air, Mach 0.3), 40 ms each, with each run's wall time per simulated
                // ms: hours (the real air at ×1 is ≈ 1.6 h on 2 cores); the sweeps' directories keep
                // every job, so `phonation sweep --collect` re-reads a study cut short.
                crate::validation::glottis::speed_error_rows()
            },
        ),
    ]
}
