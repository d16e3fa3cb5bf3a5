//! The validation cases of Schäfer–Turek 2D-1 through the couplings and as a rigid obstacle, at three resolutions and two outlet levels.

use super::case;
use crate::coupling::TractionModel;
use crate::validation::fsi;
use crate::validation::suite::Case;

/// These cases, in the order `phonation validate` runs them.
pub(super) fn cases() -> Vec<Case> {
    vec![
        case(
            "fsi_schafer_turek_2d1",
            "Schäfer–Turek 2D-1 at D = 20 cells, 6 s: C_D and Δp within 2 % of 5.5795 and 0.11752 for the rigid obstacle and the clamped elastic cylinder with both couplings",
            "≈ 10 min (three runs side by side)",
            || {
                // D = 20 cells, Mach 0.1 at U_max, 6 s, means over the last 1.5 s. Acoustic waves
                // ring between the inlet and the constant-pressure outlet (a lossless resonator): the
                // air is settled by selective frequency damping (χ = 1/s, Δ = 1 s; it leaves the
                // steady state unchanged), and the spread of C_D over the window is a row of its
                // own. The weakly compressible channel's air within one diameter of the cylinder
                // is 0.79 % above ρ₀ at Mach 0.1 (O(Ma²); `fsi_schafer_turek_2d1_outlet_level`). The rigid obstacle's drag is measured twice: by the
                // traction quadrature (method 1's measure) and by the momentum its wall nodes take
                // out of the air (method 2's); method 2's drag must be the latter (measured, damped:
                // −0.19 % at D = 20, where the two measures differ by 1.9 %; +0.06 % at D = 10,
                // undamped, where they differ by 10.4 %).
                use fsi::CylinderBody::{ConservingCoupled, RigidObstacle, WeakCoupled};
                schafer_turek_rows(20, 0.1, 6.0, &[RigidObstacle, WeakCoupled(TractionModel::PressureAndShear), ConservingCoupled], 1.0)
            },
        ),
        case(
            "fsi_schafer_turek_2d1_d40",
            "Schäfer–Turek 2D-1 at D = 40 cells, 6 s: the rigid obstacle and method 2, C_D and Δp within 2 %",
            "≈ 63 min (two runs side by side)",
            || {
                // The same channel at D = 40 cells (176,000 nodes), Mach 0.1, 6 s, damped as above:
                // the rigid obstacle and method 2, the two runs side by side (one core each). Δp was
                // +3.6 / +2.2 % above 0.11752 at D = 20 / 30 and got worse at Mach 0.05 (the lattice
                // viscosity falls with the Mach number): this case tells whether resolution closes
                // it at Mach 0.1. Measured (2026-12-03, 2 cores): Δp +1.8 / +1.9 % (pass), C_D +3.7 %
                // (quadrature), +2.6 % (exchange), +2.7 % (method 2) (fail); 35 and 63 min side by side.
                use fsi::CylinderBody::{ConservingCoupled, RigidObstacle};
                schafer_turek_rows(40, 0.1, 6.0, &[RigidObstacle, ConservingCoupled], 1.0)
            },
        ),
        case(
            "fsi_schafer_turek_2d1_d30_air_at_rho0",
            "Schäfer–Turek 2D-1 at D = 30, 6 s, the outlet set so the air at the cylinder is at ρ₀: the rigid obstacle and method 2",
            "≈ 25 min",
            || {
                // D = 30, Mach 0.1, 6 s, damped, the rigid obstacle and method 2 side by side, with
                // the outlet at the level that puts the air around the cylinder at the benchmark's
                // ρ₀ (`OUTLET_DENSITY_AIR_AT_RHO0`; the forces follow the level one for one). The
                // density near the cylinder is in the JSON line each run prints.
                use fsi::CylinderBody::{ConservingCoupled, RigidObstacle};
                schafer_turek_rows(30, 0.1, 6.0, &[RigidObstacle, ConservingCoupled], fsi::OUTLET_DENSITY_AIR_AT_RHO0)
            },
        ),
        case("fsi_schafer_turek_2d1_d30_air_at_rho0_10s", "as fsi_schafer_turek_2d1_d30_air_at_rho0, run to 10 s", "≈ 60 min", || {
            // The rigid obstacle and method 2 as above, run to 10 s like method 1's case below
            // (39 and 57 min side by side here, beside other runs).
            use fsi::CylinderBody::{ConservingCoupled, RigidObstacle};
            schafer_turek_rows(30, 0.1, 10.0, &[RigidObstacle, ConservingCoupled], fsi::OUTLET_DENSITY_AIR_AT_RHO0)
        }),
        case("fsi_schafer_turek_2d1_d30_air_at_rho0_weak", "as fsi_schafer_turek_2d1_d30_air_at_rho0, with method 1", "≈ 25 min", || {
            // The same channel with method 1 (the weak coupling), its own run (≈ 25 min on 2 cores).
            schafer_turek_rows(30, 0.1, 6.0, &[fsi::CylinderBody::WeakCoupled(TractionModel::PressureAndShear)], fsi::OUTLET_DENSITY_AIR_AT_RHO0)
        }),
        case("fsi_schafer_turek_2d1_d30_air_at_rho0_weak_10s", "as fsi_schafer_turek_2d1_d30_air_at_rho0_weak, run to 10 s", "≈ 57 min (one core)", || {
            // Method 1 as above, run to 10 s: at 6 s its C_D read +2.06 % and the drag was
            // still falling (at D = 20 the 10-s run read 0.5 % below the 6-s one). 57 min on one
            // core beside other runs.
            schafer_turek_rows(30, 0.1, 10.0, &[fsi::CylinderBody::WeakCoupled(TractionModel::PressureAndShear)], fsi::OUTLET_DENSITY_AIR_AT_RHO0)
        }),
        case(
            "fsi_schafer_turek_2d1_outlet_level",
            "what the outlet's pressure level does to C_D and Δp: the rigid obstacle at D = 20 with the outlet at ρ₀ and at ρ₀/1.017",
            "≈ 5 min (two runs side by side)",
            || {
                // The rigid obstacle at D = 20, Mach 0.1, 6 s, damped, twice side by side: the outlet
                // at ρ₀ (as every other case) and at the level that puts the air around the cylinder
                // at ρ₀ as estimated before either ran (ρ₀ / 1.017; the first run measured 1.0079
                // there, so the second overshoots to 0.9918). Rows: the density near the cylinder,
                // C_D and Δp of each; what the pressure level does to the forces.
                let start = fsi::ChannelStart::Damped { gain: 1.0, filter_width: 1.0 };
                let levels = [1.0, 1.0 / 1.017];
                let runs: Vec<_> = {
                    use rayon::prelude::*;
                    levels
                        .par_iter()
                        .with_max_len(1)
                        .map(|&rho| fsi::schafer_turek_2d1_with_outlet(20, 0.1, start, 6.0, fsi::CylinderBody::RigidObstacle, rho))
                        .collect()
                };
                let mut out = Vec::new();
                for r in &runs {
                    println!("schafer_turek_2d1: {}", serde_json::to_string(&r).unwrap_or_default());
                    let at = format!("outlet ρ = {:.4} ρ₀", r.outlet_density);
                    let cd = r.drag_coefficient / fsi::ST_2D1_DRAG - 1.0;
                    let dp = r.pressure_drop / fsi::ST_2D1_PRESSURE_DROP - 1.0;
                    out.push((
                        format!("{at}: density near the cylinder / ρ₀"),
                        r.density_near_cylinder,
                        "measured".into(),
                        r.density_near_cylinder.is_finite(),
                    ));
                    out.push((format!("{at}: C_D / 5.5795 − 1"), cd, "|Δ| ≤ 0.02".into(), cd.abs() <= 0.02));
                    out.push((format!("{at}: Δp / 0.11752 − 1"), dp, "|Δ| ≤ 0.02".into(), dp.abs() <= 0.02));
                }
                out
            },
        ),
    ]
}

/// Schäfer–Turek 2D-1 at `cells_per_diameter` and lattice Mach `mach` for `duration` s, the
/// outlet at `outlet_density` (units of ρ₀), damped
/// (χ = 1/s, Δ = 1 s), each of `bodies` run side by side (rayon tasks), rows in the order of
/// `bodies`: C_D and Δp against the benchmark (±2 %), the spread of C_D over the averaging window
/// (≤ 0.5 %, settled), the rigid obstacle's drag by momentum exchange, and method 2's drag
/// against it (±1 %: the same measure of the same wall, README) when both ran.
fn schafer_turek_rows(
    cells_per_diameter: usize,
    mach: f64,
    duration: f64,
    bodies: &[fsi::CylinderBody],
    outlet_density: f64,
) -> Vec<(String, f64, String, bool)> {
    use rayon::prelude::*;
    let start = fsi::ChannelStart::Damped { gain: 1.0, filter_width: 1.0 };
    let runs: Vec<_> = bodies
        .par_iter()
        .with_max_len(1)
        .map(|&body| (body, fsi::schafer_turek_2d1_with_outlet(cells_per_diameter, mach, start, duration, body, outlet_density)))
        .collect();
    let rigid_exchange = runs.iter().find_map(|(_, r)| r.exchange_drag_coefficient).unwrap_or(f64::NAN);
    let mut out = Vec::new();
    for (body, r) in &runs {
        // every figure of the run (both drag measures, Δp both ways, spreads, wall time) for the log
        println!("schafer_turek_2d1: {}", serde_json::to_string(&r).unwrap_or_default());
        if let Some(x) = r.exchange_drag_coefficient {
            let cd = x / fsi::ST_2D1_DRAG - 1.0;
            out.push(("rigid obstacle, drag by momentum exchange: C_D / 5.5795 − 1".into(), cd, "|Δ| ≤ 0.02".into(), cd.abs() <= 0.02));
        }
        if *body == fsi::CylinderBody::ConservingCoupled && rigid_exchange.is_finite() {
            let d = r.drag_coefficient / rigid_exchange - 1.0;
            out.push(("method 2's C_D / the rigid obstacle's by momentum exchange − 1".into(), d, "|Δ| ≤ 0.01".into(), d.abs() <= 0.01));
        }
        let name = match body {
            fsi::CylinderBody::RigidObstacle => "rigid obstacle",
            fsi::CylinderBody::ConservingCoupled => "clamped elastic, method 2",
            _ => "clamped elastic, method 1",
        };
        let cd = r.drag_coefficient / fsi::ST_2D1_DRAG - 1.0;
        let dp = r.pressure_drop / fsi::ST_2D1_PRESSURE_DROP - 1.0;
        out.push((format!("{name}: C_D / 5.5795 − 1"), cd, "|Δ| ≤ 0.02".into(), cd.abs() <= 0.02));
        out.push((format!("{name}: Δp / 0.11752 − 1"), dp, "|Δ| ≤ 0.02".into(), dp.abs() <= 0.02));
        let spread = r.drag_spread / r.drag_coefficient;
        out.push((format!("{name}: spread of C_D over the window / C_D"), spread, "≤ 0.005 (settled)".into(), spread <= 0.005));
    }
    out
}
