//! The coupled 2D glottis against the seed (000 §3.4.1): cases A–D of the body–cover model on
//! the CPU-sized scene `glottis_2d_coarse`, 40 ms each from rest with the lung pressure switched
//! on abruptly. Outputs (glottal_flow.csv, voice.json, WAVs, snapshots) are kept in
//! `out/validate/glottis_2d_<case>/`.

use crate::run::coupled::{CoupledReport, run_coupled_scene};
use crate::scene::coupled::CoupledScene;
use crate::solid::fold::BodyCoverCase;
use std::path::PathBuf;

/// Runs `glottis_2d_coarse` with the moduli of `case` for the scene's duration.
pub fn run_case(case: BodyCoverCase) -> anyhow::Result<CoupledReport> {
    let mut sc = CoupledScene::parse(crate::scene::builtin("glottis_2d_coarse").expect("built in"))?;
    let (cover, body) = case.young();
    sc.set_fold_moduli(cover, body);
    let dir = PathBuf::from("out/validate").join(format!("glottis_2d_{case:?}").to_lowercase());
    run_coupled_scene(&sc, &dir, &crate::run::RunOptions { show_progress: true, ..Default::default() })
}

/// The suite's rows: each case's f0 against the seed's (±20 %), the ordering A < C < B < D,
/// stability, and case C's settling and vertical phase difference.
pub fn rows() -> Vec<(String, f64, String, bool)> {
    let mut out = Vec::new();
    let mut f0 = Vec::new();
    for case in [BodyCoverCase::A, BodyCoverCase::B, BodyCoverCase::C, BodyCoverCase::D] {
        let r = match run_case(case) {
            Ok(r) => r,
            Err(e) => {
                out.push((format!("case {case:?}: {e}"), f64::NAN, "runs".into(), false));
                continue;
            }
        };
        let g = r.glottis.clone().expect("a glottis scene");
        out.push((
            format!("case {case:?}: stable 40 ms (fluid mass drift)"),
            r.fluid_mass_drift,
            r.instability.clone().unwrap_or_else(|| "finite".into()),
            r.instability.is_none(),
        ));
        let seed = case.seed_f0();
        let hz = g.f0_hz.unwrap_or(f64::NAN);
        let why = g.no_voice.clone().map(|w| format!(" — no voice: {w}")).unwrap_or_default();
        out.push((format!("case {case:?}: f0 (Hz){why}"), hz, format!("seed {seed} ± 20 %"), (hz / seed - 1.0).abs() <= 0.2));
        if case == BodyCoverCase::C {
            let spread = g.amplitude_spread_last5.unwrap_or(f64::NAN);
            out.push(("case C: AC-flow spread of the last 5 pulses".into(), spread, "≤ 0.1 (settled)".into(), spread <= 0.1));
            let lead = g.lower_margin_lead_s.unwrap_or(f64::NAN);
            out.push(("case C: lower margin leads upper (s)".into(), lead, "> 0 (closure from below)".into(), lead > 0.0));
        }
        f0.push((case, hz));
    }
    let get = |c: BodyCoverCase| f0.iter().find(|(k, _)| *k == c).map_or(f64::NAN, |(_, f)| *f);
    let ordered =
        get(BodyCoverCase::A) < get(BodyCoverCase::C) && get(BodyCoverCase::C) < get(BodyCoverCase::B) && get(BodyCoverCase::B) < get(BodyCoverCase::D);
    out.push(("f0 ordering A < C < B < D (1 = yes)".into(), ordered as u8 as f64, "seed: 110 < 145 < 180 < 190 Hz".into(), ordered));
    out
}
