//! The validation cases of the couplings on moving and free bodies: the towed and oscillating cylinders, the disc in shear, the added-mass limit, the Wall flap, the thin plate, the largest stable step and the soak.

use super::case;
use crate::validation::fsi;
use crate::validation::suite::Case;

/// These cases, in the order `phonation validate` runs them.
pub(super) fn cases() -> Vec<Case> {
    vec![
        case(
            "fsi_towed_cylinder",
            "a cylinder towed through air at rest (D = 20, Re = 20) against the same cylinder fixed in moving air: drag within 3 %, both couplings (Galilean check)",
            "≈ 40 s",
            || {
                // Galilean check of the moving walls: D = 20 cells, Re = 20, Mach 0.1, 3 D of travel.
                let mut out = Vec::new();
                for (name, method) in methods() {
                    let r = fsi::towed_cylinder(method, 20, 0.1, 20.0, 3.0);
                    out.push((format!("towed / fixed drag − 1 ({name})"), r.relative_difference, "|Δ| ≤ 0.03".into(), r.relative_difference.abs() <= 0.03));
                }
                out
            },
        ),
        case(
            "fsi_oscillating_cylinder",
            "a rigid disc oscillating by one diameter, covering and uncovering nodes for 10⁴ steps: finite, the air's mass drift within 3 %, both couplings",
            "≈ 11 s",
            || {
                // A rigid disc (D = 8) oscillating by one diameter at peak Mach 0.1 for 10⁴ steps,
                // covering and uncovering nodes throughout: stays finite; the air's mass drift is
                // reported (fresh nodes take their neighbours' mean state).
                let mut out = Vec::new();
                for (name, method) in methods() {
                    match fsi::oscillating_cylinder(method, 8, 0.1, 10_000) {
                        Ok(r) => {
                            out.push((
                                format!("fluid mass drift over 10⁴ steps ({name}, {} uncovered)", r.uncovered),
                                r.mass_drift,
                                "|Δ| ≤ 0.03".into(),
                                r.mass_drift.abs() <= 0.03,
                            ));
                        }
                        Err(e) => out.push((format!("{name}: {e}"), f64::NAN, "stable".into(), false)),
                    }
                }
                out
            },
        ),
        case("fsi_disc_in_shear", "a neutrally buoyant free disc in simple shear at Re = 0.1 turns at γ̇/2, within 3 %", "≈ 9 s", || {
            // A neutrally buoyant free disc in simple shear at Re = 0.1 turns at γ̇/2.
            let r = fsi::disc_in_shear(10, 8, 0.1, 3.0);
            let e = -r.rotation_rate / 0.5 - 1.0;
            vec![("Ω / (γ̇/2) − 1 (D/H = 1/8)".into(), e, "|Δ| ≤ 0.03".into(), e.abs() <= 0.03)]
        }),
        case(
            "fsi_added_mass",
            "the lightest free disc a pressure pulse can push for 1000 steps (added-mass limit), method 1, method 2 with and without the added mass (2.129)",
            "≈ 22 s",
            || {
                // The added-mass limit: the lightest free disc a pressure pulse can push for 1000
                // steps. Measured: method 1 0.2 stable, 0.15 unstable (explicit weak coupling fails
                // for light bodies); method 2 without its added mass 0.02 stable, 0.01 unstable;
                // with it (2.129, the default) stable at every ratio down to 10⁻⁶.
                use crate::coupling::{ConservingOptions, Method};
                let ratios = [1.0, 0.5, 0.3, 0.2, 0.15, 0.1, 0.05, 0.02, 0.01, 1e-3, 1e-4];
                let staggered = ("method 2 without added mass", Method::Conserving(ConservingOptions { added_mass: false, ..Default::default() }));
                let expected = [0.2, 1e-4, 0.02];
                let mut out = Vec::new();
                for ((name, method), bound) in methods().into_iter().chain([staggered]).zip(expected) {
                    let rows = fsi::added_mass_stability(method, &ratios, 1000);
                    let lightest = rows.iter().filter(|(_, ok)| *ok).map(|(r, _)| *r).fold(f64::INFINITY, f64::min);
                    let heavy_ok = rows.iter().filter(|(r, _)| *r >= bound).all(|(_, ok)| *ok);
                    out.push((
                        format!("lightest stable ρ_s/ρ_f ({name})"),
                        lightest,
                        format!("≤ {bound}, every heavier one stable"),
                        heavy_ok && lightest <= bound,
                    ));
                }
                out
            },
        ),
        case(
            "fsi_wall_flap",
            "the Wall flexible flap (Re = 333), both couplings, 3 s at D = 20 cells: stability, the tip's frequency and largest displacement against the published envelope",
            "≈ 10 h (5 h per method on one core; GPU-sized)",
            || {
                // The Wall flap, both methods, 3 s each at D = 20 cells and lattice Mach 0.1
                // (fsi_flap::VALIDATION_MACH; 160,800 coupled steps, ~5 h each on one core here,
                // GPU-sized).
                let mut out = crate::validation::fsi_flap::rows("wall_flap", "method 1");
                out.extend(crate::validation::fsi_flap::rows("wall_flap_conserving", "method 2"));
                out
            },
        ),
        case(
            "fsi_thin_plate",
            "the flap's cross-section as a rigid plate at zero incidence moved across the node rows: the lift a wall 1.2 cells thick feels (10 runs)",
            "≈ 10 min",
            || {
                // The flap's cross-section as a rigid plate at zero incidence, moved across the node
                // rows: the lift a wall 1.2 cells thick would feel were its far side not held by
                // side ghosts (fsi_plate; 10 runs of 5,400 steps, 563–624 s on 2 cores here).
                crate::validation::fsi_plate::rows()
            },
        ),
        case(
            "fsi_flap_time_step",
            "the largest stable coupling step of each method on the Wall flap: lattice Mach 0.1 to 0.5, 1000 steps each",
            "≈ 20 min (estimated from the flap's step rate)",
            || {
                // The largest stable coupling step of each method on the Wall flap: the lattice
                // Mach number (Δt ∝ Ma at fixed Δx) raised from 0.1 to 0.5, 1000 steps each.
                let machs = [0.1, 0.2, 0.3, 0.4, 0.5];
                let mut out = Vec::new();
                for (scene, label) in [("wall_flap", "method 1"), ("wall_flap_conserving", "method 2")] {
                    match crate::validation::fsi_flap::time_step_ladder(scene, &machs, 1000) {
                        Ok(rungs) => {
                            for r in &rungs {
                                println!(
                                    "{label}: Mach {} Δt {:.3e} s ({} solid sub-steps): {}",
                                    r.mach,
                                    r.dt,
                                    r.solid_substeps,
                                    r.instability.as_deref().unwrap_or("stable")
                                );
                            }
                            let dt = rungs.iter().take_while(|r| r.instability.is_none()).last().map_or(f64::NAN, |r| r.dt);
                            out.push((format!("{label}: largest stable coupling step (s)"), dt, "measured (stable at Mach 0.1)".into(), dt.is_finite()));
                        }
                        Err(e) => out.push((format!("{label}: {e}"), f64::NAN, "runs".into(), false)),
                    }
                }
                out
            },
        ),
    ]
}

/// Both couplings, named.
fn methods() -> [(&'static str, crate::coupling::Method); 2] {
    use crate::coupling::{ConservingOptions, Method, WeakOptions};
    [("method 1", Method::Weak(WeakOptions::default())), ("method 2", Method::Conserving(ConservingOptions::default()))]
}
