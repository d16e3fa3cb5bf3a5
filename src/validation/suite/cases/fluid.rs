//! The validation cases of the fluid alone (FDLB): decay, sound, shocks, f32 storage, channels, the cavity and the cylinder wake, against their analytic or published references.

use super::case;
use crate::fluid::{GasModel, VelocitySetKind};
use crate::validation::suite::Case;
use crate::validation::{cavity, channel, cylinder, sod, sound, taylor_green::TaylorGreenCase};

/// These cases, in the order `phonation validate` runs them.
pub(super) fn cases() -> Vec<Case> {
    vec![
        case("taylor_green_2d", "D2Q21 64²: the Taylor–Green vortex's decay rate against ν = θ(τ − A), within 2 %", "< 1 s", || {
            let r = TaylorGreenCase::new(VelocitySetKind::D2q21, 64).run();
            vec![("decay-rate error vs ν = θ(τ−A)".into(), r.relative_error, "|err| ≤ 0.02".into(), r.relative_error.abs() <= 0.02)]
        }),
        case("taylor_green_3d", "D3Q39 24³: the Taylor–Green vortex's decay rate against ν = θ(τ − A), within 2 %", "< 1 s", || {
            let mut c = TaylorGreenCase::new(VelocitySetKind::D3q39, 24);
            c.nu = 0.25;
            let r = c.run();
            vec![("decay-rate error vs ν = θ(τ−A)".into(), r.relative_error, "|err| ≤ 0.02".into(), r.relative_error.abs() <= 0.02)]
        }),
        case("sound_speed", "the speed of a sound wave against √(γθ), D2Q21 and D3Q39, γ = 5/3 and 7/5, within 1 %", "< 1 s", || {
            [
                (VelocitySetKind::D2q21, GasModel::Monatomic),
                (VelocitySetKind::D3q39, GasModel::Monatomic),
                (VelocitySetKind::D2q21, GasModel::Diatomic),
                (VelocitySetKind::D3q39, GasModel::Diatomic),
            ]
            .iter()
            .map(|&(s, g)| {
                let r = sound::sound_speed(s, g, 64);
                (format!("{s:?} γ = {:.3}: c_s error", r.gamma), r.relative_error, "|err| ≤ 0.01".into(), r.relative_error.abs() <= 0.01)
            })
            .collect()
        }),
        case(
            "sod_shock_tube",
            "Sod's shock tube (D2Q21, γ = 5/3 and 7/5): the plateaus within 2 % of the exact Riemann solution, shock and contact within 3 cells",
            "< 1 s",
            || {
                let mut out = Vec::new();
                for gas in [GasModel::Monatomic, GasModel::Diatomic] {
                    let mut c = sod::SodCase::new(VelocitySetKind::D2q21, gas);
                    c.scale = 0.7;
                    let r = c.run();
                    for (name, m, e, rel) in &r.plateaus {
                        out.push((format!("γ = {:.1}: {name}", r.gamma), *m, format!("{e:.5} ± 2%"), rel.abs() <= 0.02));
                    }
                    let ds = r.shock_position.0 - r.shock_position.1;
                    let dc = r.contact_position.0 - r.contact_position.1;
                    out.push((format!("γ = {:.1}: shock offset (cells)", r.gamma), ds, "|Δ| ≤ 3".into(), ds.abs() <= 3.0));
                    out.push((format!("γ = {:.1}: contact offset (cells)", r.gamma), dc, "|Δ| ≤ 3".into(), dc.abs() <= 3.0));
                }
                out
            },
        ),
        case(
            "f32_storage",
            "the f32 population storage on Taylor–Green (2D, 3D) and Sod, with the f64 bounds, and its distance from the f64 run",
            "≈ 2 s",
            || {
                // the CPU's f32 population storage (`[numerics] storage = "f32"`) on the cases above,
                // with their bounds, and its distance from the f64 run
                let mut out = Vec::new();
                let mut tg3 = TaylorGreenCase::new(VelocitySetKind::D3q39, 24);
                tg3.nu = 0.25;
                for (label, c) in [("2D 64²", TaylorGreenCase::new(VelocitySetKind::D2q21, 64)), ("3D 24³", tg3)] {
                    let (a, b) = (c.run_stored::<f64>(), c.run_stored::<f32>());
                    out.push((format!("TG {label} f32: decay-rate error"), b.relative_error, "|err| ≤ 0.02".into(), b.relative_error.abs() <= 0.02));
                    let moved = ((b.measured_rate - a.measured_rate) / a.measured_rate).abs();
                    let bound = 1e-4 * a.relative_error.abs();
                    out.push((format!("TG {label} f32: |rate − f64 rate| / rate"), moved, format!("≤ 10⁻⁴ × f64 error = {bound:.2e}"), moved <= bound));
                }
                for gas in [GasModel::Monatomic, GasModel::Diatomic] {
                    let mut c = sod::SodCase::new(VelocitySetKind::D2q21, gas);
                    c.scale = 0.7;
                    let r = c.run_stored::<f32>();
                    for (name, m, e, rel) in &r.plateaus {
                        out.push((format!("Sod f32 γ = {:.1}: {name}", r.gamma), *m, format!("{e:.5} ± 2%"), rel.abs() <= 0.02));
                    }
                    let ds = r.shock_position.0 - r.shock_position.1;
                    out.push((format!("Sod f32 γ = {:.1}: shock offset (cells)", r.gamma), ds, "|Δ| ≤ 3".into(), ds.abs() <= 3.0));
                }
                out
            },
        ),
        case("poiseuille", "a body-force-driven channel (32 cells) against the parabolic profile, L2 error ≤ 1 %", "≈ 7 s", || {
            let r = channel::poiseuille(32);
            vec![("profile L2 error".into(), r.l2_error, "≤ 0.01".into(), r.l2_error <= 0.01)]
        }),
        case(
            "thermal_couette",
            "the thermal Couette flow: the velocity profile (L2 ≤ 1 %) and the viscous heating's peak against Pr U²/8c_p (±3 %)",
            "≈ 4 s",
            || {
                let r = channel::thermal_couette(32);
                let (m, p) = r.peak_rise.unwrap();
                vec![
                    ("velocity profile L2 error".into(), r.l2_error, "≤ 0.01".into(), r.l2_error <= 0.01),
                    ("peak Δθ / (Pr U²/8c_p)".into(), m / p, "1 ± 0.03".into(), (m / p - 1.0).abs() <= 0.03),
                ]
            },
        ),
        case(
            "lid_cavity_re100",
            "the lid-driven cavity at Re = 100 (96²) against Ghia et al. (1982): |u − Ghia| ≤ 3 % of the lid speed",
            "≈ 2 min",
            || {
                let r = cavity::cavity(96, 0.1, 20.0);
                vec![(format!("{}²: max |u − Ghia| / U", r.n), r.max_deviation, "≤ 0.03".into(), r.max_deviation <= 0.03)]
            },
        ),
        case("cylinder_re100", "the cylinder wake at Re = 100 (D = 16 cells, Mach 0.2): the Strouhal number in [0.160, 0.170]", "≈ 9 min", || {
            // D = 16 nodes, Mach 0.2 (halves the run; the compressibility shift of St is O(Ma²)),
            // lateral periodicity 32 D (blockage 3%, as the reference range requires).
            let r = cylinder::cylinder(16, 0.2, 14.0, 20, 32);
            vec![(
                format!("D = {} cells: Strouhal ({} periods)", r.diameter, r.periods_measured),
                r.strouhal,
                "[0.160, 0.170]".into(),
                within(r.strouhal, 0.160, 0.170),
            )]
        }),
    ]
}

/// Whether `m` lies in [lo, hi].
fn within(m: f64, lo: f64, hi: f64) -> bool {
    m >= lo && m <= hi
}
