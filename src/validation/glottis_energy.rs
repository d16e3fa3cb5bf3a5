//! What the air gives and takes from the vibrating folds, and how much of it depends on the
//! vocal-tract face: `glottis_2d_coarse` (case A) for 30 ms from rest, once with the scene's
//! zero-gradient `outlet` and once with a `pressure_outlet` at the atmosphere's pressure, the
//! air's work on the folds per cycle by part of their surface
//! ([`crate::coupling::glottis::Glottis::air_power`], the cycles from one upward crossing of the
//! glottal area's mean to the next over the last 75 % of the run).
//!
//! The claim: the folds' lowest mode moves them along the flow like a piston across the duct
//! (`glottis_modes`), so they send sound up and down it. Through the zero-gradient outlet that
//! sound leaves as into an endless duct, and the supraglottal face's work is a radiation loss of
//! a sixth of the vibration's energy per cycle; a fixed-pressure outlet reflects it, and the loss
//! goes. Measured (2026-12-05, 2 cores beside other runs): the superior face's work per cycle
//! −25.9 erg (−17.6 % of the folds' peak kinetic energy, 147 erg) with the outlet, +3.6 erg
//! (+1.7 % of 212 erg) with the pressure outlet; in all −21.7 % and −7.1 %. `validate --case
//! glottis_air_work`: 4 rows pass, 875 s (2026-12-05, beside another run).

use crate::output::voice::EnergyTransfer;
use crate::run::coupled::run_coupled_scene;
use crate::scene::coupled::CoupledScene;
use std::path::PathBuf;

/// The coarse glottis's vocal-tract face, as built in.
pub(crate) const OUTLET: &str = "y_max = { type = \"outlet\" }";
/// The same face held at the atmosphere's pressure.
pub(crate) const PRESSURE_OUTLET: &str = "y_max = { type = \"pressure_outlet\" }";

/// Simulated time (s): 3.5 cycles at ≈ 117 Hz, the last 75 % analysed (2 whole cycles).
const DURATION: f64 = 0.03;

/// Analysed fraction of the run (the voice window).
const WINDOW: f64 = 0.75;

/// `glottis_2d_coarse` with its vocal-tract face `face` and the run's duration `DURATION`.
pub fn scene(face: &str) -> anyhow::Result<CoupledScene> {
    let text = crate::scene::builtin("glottis_2d_coarse").expect("built in");
    anyhow::ensure!(text.contains(OUTLET), "glottis_2d_coarse's vocal-tract face is no longer `{OUTLET}`");
    let text = text.replace(OUTLET, face).replace("duration = 0.04 ", &format!("duration = {DURATION} "));
    anyhow::ensure!(text.contains(&format!("duration = {DURATION} ")), "glottis_2d_coarse's run.duration is no longer 0.04");
    Ok(CoupledScene::parse(&text)?)
}

/// The air's work per cycle on the folds of one run, over the last [`WINDOW`] of it.
fn run(face: &str, name: &str) -> anyhow::Result<EnergyTransfer> {
    let sc = scene(face)?;
    let dir = PathBuf::from("out/validate").join(name);
    let r = run_coupled_scene(&sc, &dir, &crate::run::RunOptions { show_progress: true, ..Default::default() })?;
    if let Some(why) = r.instability {
        anyhow::bail!("unstable: {why}");
    }
    // the run's own voice window is the measures' default (half the run): read the last 75 %
    let opts = crate::analysis::voice::VoiceOptions { window_fraction: WINDOW, ..Default::default() };
    let series = crate::output::voice::read_glottal_csv(&dir.join("glottal_flow.csv"))?;
    crate::output::voice::glottal_measures(&series, &opts)
        .energy
        .ok_or_else(|| anyhow::anyhow!("no whole cycle of the glottal area in the last {WINDOW} of the run"))
}

/// The rows of `validate --case glottis_air_work`.
pub fn rows() -> Vec<(String, f64, String, bool)> {
    let mut out = Vec::new();
    let outlet = run(OUTLET, "glottis_air_work_outlet");
    let pressure = run(PRESSURE_OUTLET, "glottis_air_work_pressure_outlet");
    let (o, p) = match (outlet, pressure) {
        (Ok(o), Ok(p)) => (o, p),
        (o, p) => {
            for (name, r) in [("outlet", o.err()), ("pressure outlet", p.err())] {
                if let Some(e) = r {
                    out.push((format!("{name}: {e}"), f64::NAN, "runs 30 ms".into(), false));
                }
            }
            return out;
        }
    };
    let superior = |w: &EnergyTransfer| w.work_per_cycle_erg[2] / w.peak_kinetic_energy_erg;
    let total = |w: &EnergyTransfer| w.work_over_peak_kinetic_energy;
    out.push(("outlet: superior face's work / peak KE".into(), superior(&o), "< −0.1 (radiated)".into(), superior(&o) < -0.1));
    out.push(("pressure outlet: superior face's work / peak KE".into(), superior(&p), "> −0.02 (reflected)".into(), superior(&p) > -0.02));
    out.push(("outlet: the air's work / peak KE".into(), total(&o), "< 0 (damps)".into(), total(&o) < 0.0));
    out.push(("pressure outlet: the air's work / peak KE".into(), total(&p), format!("> the outlet's {:.3} + 0.1", total(&o)), total(&p) > total(&o) + 0.1));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::boundary::{Face, FaceCondition};

    /// The case's two scenes are the coarse glottis for 30 ms with the two vocal-tract faces.
    #[test]
    fn the_two_scenes_differ_in_their_vocal_tract_face_only() {
        let (o, p) = (scene(OUTLET).unwrap(), scene(PRESSURE_OUTLET).unwrap());
        assert_eq!(o.fluid.boundaries.face(Face::YMax), &FaceCondition::Outlet);
        assert!(matches!(p.fluid.boundaries.face(Face::YMax), FaceCondition::PressureInlet { .. }));
        for s in [&o, &p] {
            assert_eq!(s.fluid.boundaries.face(Face::YMin), o.fluid.boundaries.face(Face::YMin));
            assert_eq!(s.fluid.file.run.duration, DURATION);
        }
    }
}
