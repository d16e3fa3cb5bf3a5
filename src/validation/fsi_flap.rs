//! The Wall flexible flap (Wall & Ramm 1998; seed 000 §3.2; ../shared/reference "Wall
//! flexible-flap benchmark") on the built-in scenes `wall_flap` (method 1, weak) and
//! `wall_flap_conserving` (method 2): D = 20 cells (Δx = 0.05 cm; the flap 1.2 cells thick,
//! thick enough that a row of nodes always lies inside it), three particles across the 0.06 cm
//! flap, released in its first bending mode; run at lattice Mach [`VALIDATION_MACH`] = 0.2. The tip's transverse
//! oscillation over the second half of the run against the published envelope of coupled codes:
//! frequency 2.94–3.31 Hz, largest tip displacement 1.0–1.42 cm. The frequency is the tip's
//! spectral peak (the mode carrying the most motion: a higher mode riding on the flutter adds
//! mean crossings, so the crossing count would read it as a faster flutter), the displacement the
//! largest |dy| over the same window (what the published codes report). Outputs are kept in
//! `out/validate/<scene>/`.

use crate::run::coupled::{CoupledReport, run_coupled_scene};
use crate::scene::coupled::CoupledScene;
use std::path::PathBuf;

/// Published envelope of the limit cycle (../shared/reference).
pub const FREQUENCY_HZ: (f64, f64) = (2.94, 3.31);
pub const TIP_DISPLACEMENT_CM: (f64, f64) = (1.0, 1.42);

/// The lattice Mach number of the validation runs: 0.2, twice the scenes' 0.1, which halves the
/// steps (Δt ∝ Ma at fixed Δx; 81,000 coupled steps for 3 s) — the largest at which both methods
/// are stable on the flap (`fsi_flap_time_step`: method 1 diverges at 0.3). The compressibility
/// error it adds is O(Ma²) of the air's forces, a few per cent, inside the envelope's width.
pub const VALIDATION_MACH: f64 = 0.2;

/// The built-in flap scene `scene` with its lattice Mach number set to `mach`.
pub fn scene_at_mach(scene: &str, mach: f64) -> anyhow::Result<CoupledScene> {
    let text = crate::scene::builtin(scene).ok_or_else(|| anyhow::anyhow!("no built-in scene {scene}"))?;
    let mut table: toml::Table = text.parse()?;
    let numerics = table.get_mut("numerics").and_then(|n| n.as_table_mut()).ok_or_else(|| anyhow::anyhow!("{scene}: no [numerics]"))?;
    let scaling = numerics.get_mut("mach_scaling").and_then(|m| m.as_table_mut()).ok_or_else(|| anyhow::anyhow!("{scene}: no Mach scaling"))?;
    scaling.insert("mach".into(), toml::Value::Float(mach));
    Ok(CoupledScene::parse(&toml::to_string(&table)?)?)
}

/// Runs the built-in flap scene `scene` at [`VALIDATION_MACH`] (for `duration` s instead of the
/// scene's, if given).
pub fn run(scene: &str, duration: Option<f64>) -> anyhow::Result<CoupledReport> {
    let sc = scene_at_mach(scene, VALIDATION_MACH)?;
    let steps = duration.map(|d| (d / (sc.fluid.units.time() * sc.fluid.params.dt)).ceil() as u64);
    let dir = PathBuf::from("out/validate").join(scene);
    run_coupled_scene(&sc, &dir, &crate::run::RunOptions { show_progress: true, steps, ..Default::default() })
}

/// The suite's rows for one scene: stable, tip frequency and largest tip displacement in the
/// envelope.
pub fn rows(scene: &str, label: &str) -> Vec<(String, f64, String, bool)> {
    let r = match run(scene, None) {
        Ok(r) => r,
        Err(e) => return vec![(format!("{label}: {e}"), f64::NAN, "runs".into(), false)],
    };
    let mut out = vec![(
        format!("{label}: stable (fluid mass drift)"),
        r.fluid_mass_drift,
        r.instability.clone().unwrap_or_else(|| "finite".into()),
        r.instability.is_none(),
    )];
    let tip = r.particle_probes.iter().find(|p| p.name == "tip");
    let (f, d) = match tip {
        Some(p) => (p.oscillation.as_ref().and_then(|o| o.spectral_peak).unwrap_or(f64::NAN), p.oscillation.as_ref().map_or(f64::NAN, |o| o.max_abs)),
        None => (f64::NAN, f64::NAN),
    };
    let inside = |v: f64, (lo, hi): (f64, f64)| v >= lo && v <= hi;
    out.push((format!("{label}: tip frequency, spectral peak (Hz)"), f, format!("{}–{} Hz", FREQUENCY_HZ.0, FREQUENCY_HZ.1), inside(f, FREQUENCY_HZ)));
    out.push((
        format!("{label}: largest tip displacement, second half (cm)"),
        d,
        format!("{}–{} cm", TIP_DISPLACEMENT_CM.0, TIP_DISPLACEMENT_CM.1),
        inside(d, TIP_DISPLACEMENT_CM),
    ));
    out
}

/// One rung of the time-step ladder: the flap scene at a lattice Mach number (the fluid step,
/// hence the coupling step, grows with it at fixed Δx: Δt ∝ Ma), stepped from the start.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StepRung {
    pub mach: f64,
    /// Coupled (fluid) step (s).
    pub dt: f64,
    pub solid_substeps: u32,
    pub steps: u64,
    /// None: finite after `steps`; else the diagnosis.
    pub instability: Option<String>,
}

/// The coupled time-step ladder of the built-in flap scene `scene`: for each lattice Mach
/// number in `machs`, `steps` coupled steps from the start (the flap released in its first
/// mode: every rung sees the same motion). The largest stable step of a method is the last
/// stable rung's `dt`.
pub fn time_step_ladder(scene: &str, machs: &[f64], steps: u64) -> anyhow::Result<Vec<StepRung>> {
    let mut out = Vec::new();
    for &mach in machs {
        let mut c = scene_at_mach(scene, mach)?.build()?;
        let instability = c.run(steps).err().map(|e| e.to_string());
        out.push(StepRung { mach, dt: c.dt(), solid_substeps: c.substeps, steps: c.step_count, instability });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    /// The ladder's premise: at fixed Δx the coupled step grows with the lattice Mach number
    /// (Δt = Ma c_s Δx / U in lattice units), and the explicit solid takes proportionally more
    /// sub-steps; the first rungs of both methods are stable.
    #[test]
    fn the_coupling_step_grows_with_the_lattice_mach_number() {
        for scene in ["wall_flap", "wall_flap_conserving"] {
            let rungs = super::time_step_ladder(scene, &[0.1, 0.2], 20).unwrap();
            let (a, b) = (&rungs[0], &rungs[1]);
            assert!(a.instability.is_none() && b.instability.is_none(), "{rungs:?}");
            assert!((b.dt / a.dt - 2.0).abs() < 1e-9, "{scene}: Δt {} → {}", a.dt, b.dt);
            // the solid's sub-step count is a ceiling: within one of twice the first
            assert!((b.solid_substeps as i64 - 2 * a.solid_substeps as i64).abs() <= 1, "{rungs:?}");
            assert_eq!((a.steps, b.steps), (20, 20));
        }
    }
}
