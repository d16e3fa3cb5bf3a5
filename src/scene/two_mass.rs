//! Two-mass scene files (a `[two_mass]` table): the Ishizaka–Flanagan model
//! ([`crate::two_mass`]) under a lung pressure, its duration and integration rate, any model
//! parameter, and the voice-analysis settings. Checked field by field before anything runs.
//!
//! ```toml
//! name = "two_mass"
//! [two_mass]
//! lung_pressure = 7845.32   # dyn/cm² (8 cmH₂O), switched on at t = 0
//! duration = 0.5            # s
//! sample_rate = 176400      # Hz: RK4 steps per second, also the rate of glottal_flow.csv
//! [two_mass.params]         # optional, cgs; defaults: Ishizaka & Flanagan (1972)
//! k1 = 80000
//! [analysis]                # optional: the voice measures' window and f0 range
//! window_fraction = 0.5
//! ```

use crate::analysis::voice::VoiceOptions;
use crate::scene::SceneError;
use crate::two_mass::TwoMassParams;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TwoMassSceneFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub two_mass: TwoMassSection,
    #[serde(default)]
    pub analysis: AnalysisSection,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TwoMassSection {
    /// Sub-glottal (lung) pressure (dyn/cm²).
    pub lung_pressure: f64,
    /// Simulated time (s).
    pub duration: f64,
    /// Integration and output rate (Hz).
    #[serde(default = "default_rate")]
    pub sample_rate: f64,
    #[serde(default)]
    pub params: TwoMassParams,
}

fn default_rate() -> f64 {
    4.0 * 44_100.0
}

/// The voice measures' settings in a scene ([`VoiceOptions`]).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct AnalysisSection {
    pub window_fraction: f64,
    pub f0_min: f64,
    pub f0_max: f64,
}

impl Default for AnalysisSection {
    fn default() -> Self {
        let d = VoiceOptions::default();
        AnalysisSection { window_fraction: d.window_fraction, f0_min: d.f0_range.min_hz, f0_max: d.f0_range.max_hz }
    }
}

impl AnalysisSection {
    pub fn options(&self) -> VoiceOptions {
        VoiceOptions {
            window_fraction: self.window_fraction,
            f0_range: crate::analysis::pitch::F0Range { min_hz: self.f0_min, max_hz: self.f0_max },
            ..VoiceOptions::default()
        }
    }

    /// The first bad value, named.
    pub fn check(&self) -> Result<(), SceneError> {
        let bad = |field: &str, reason: String| Err(SceneError { field: format!("analysis.{field}"), reason });
        if !(self.window_fraction > 0.0 && self.window_fraction <= 1.0) {
            return bad("window_fraction", format!("must lie in (0, 1] (got {})", self.window_fraction));
        }
        if !(self.f0_min.is_finite() && self.f0_min > 0.0) {
            return bad("f0_min", format!("must be a positive frequency in Hz (got {})", self.f0_min));
        }
        if !(self.f0_max.is_finite() && self.f0_max > self.f0_min) {
            return bad("f0_max", format!("must exceed f0_min = {} Hz (got {})", self.f0_min, self.f0_max));
        }
        Ok(())
    }
}

/// The most steps one run may take (each recorded: 4 series of 8 bytes, 0.8 GB at this cap).
pub const MAX_STEPS: f64 = 2.5e7;

/// A checked two-mass scene.
#[derive(Clone, Debug, Serialize)]
pub struct TwoMassScene {
    pub file: TwoMassSceneFile,
    pub steps: usize,
}

impl TwoMassScene {
    pub fn parse(text: &str) -> Result<Self, SceneError> {
        let file: TwoMassSceneFile = toml::from_str(text).map_err(|e| SceneError::from_toml("two_mass", &e, text))?;
        Self::new(file)
    }

    pub fn new(file: TwoMassSceneFile) -> Result<Self, SceneError> {
        let s = &file.two_mass;
        let bad = |field: &str, reason: String| Err(SceneError { field: format!("two_mass.{field}"), reason });
        if let Some((field, reason)) = s.params.problem() {
            return bad(&format!("params.{field}"), reason);
        }
        if !s.lung_pressure.is_finite() || s.lung_pressure.abs() > 1e6 {
            return bad("lung_pressure", format!("must be a finite pressure in dyn/cm² within ±10⁶ (got {})", s.lung_pressure));
        }
        if !(s.duration.is_finite() && s.duration > 0.0) {
            return bad("duration", format!("must be a positive time in s (got {})", s.duration));
        }
        // RK4 is stable for ω Δt < 2.8 on oscillatory modes; ask for 10 steps per radian of the
        // fastest mode (collision springs included) so that the collisions are resolved.
        let needed = 10.0 * s.params.fastest_mode();
        if !(s.sample_rate.is_finite() && s.sample_rate >= needed) {
            return bad(
                "sample_rate",
                format!("must be at least {needed:.0} Hz for these masses and springs (10 steps per radian of the fastest mode; got {})", s.sample_rate),
            );
        }
        let steps = s.duration * s.sample_rate;
        if steps > MAX_STEPS {
            return bad("duration", format!("{} s at {} Hz is {steps:.3e} steps, above the {MAX_STEPS:.1e} a run records", s.duration, s.sample_rate));
        }
        file.analysis.check()?;
        Ok(TwoMassScene { steps: steps.round() as usize, file })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_builtin_two_mass_scene_parses_with_the_reference_parameters() {
        let sc = TwoMassScene::parse(crate::scene::builtin("two_mass").unwrap()).unwrap();
        assert_eq!(sc.file.two_mass.params, TwoMassParams::default());
        assert!((sc.file.two_mass.lung_pressure / crate::two_mass::CM_H2O - 8.0).abs() < 1e-3);
        use crate::scene::SceneKind;
        assert_eq!(SceneKind::of(crate::scene::builtin("two_mass").unwrap()), SceneKind::TwoMass);
        assert_ne!(SceneKind::of(crate::scene::BUILTIN[0].1), SceneKind::TwoMass);
    }

    #[test]
    fn bad_two_mass_scenes_name_the_field() {
        let base = "name = \"t\"\n[two_mass]\nlung_pressure = 7845\nduration = 0.1\n";
        let cases = [
            (base.replace("duration = 0.1", "duration = -1"), "two_mass.duration"),
            (base.replace("duration = 0.1", "duration = 1e6"), "two_mass.duration"),
            (base.replace("lung_pressure = 7845", "lung_pressure = nan"), "two_mass.lung_pressure"),
            (format!("{base}sample_rate = 1000\n"), "two_mass.sample_rate"),
            (format!("{base}[two_mass.params]\nm1 = 0\n"), "two_mass.params.m1"),
            (format!("{base}[two_mass.params]\nkc = -5\n"), "two_mass.params.kc"),
            (format!("{base}[two_mass.params]\nmass = 1\n"), "mass"),
            (format!("{base}[analysis]\nwindow_fraction = 0\n"), "analysis.window_fraction"),
            (format!("{base}[analysis]\nf0_max = 10\n"), "analysis.f0_max"),
            (base.replace("lung_pressure = 7845", "lung_pressure = \"high\""), "two_mass.lung_pressure"),
        ];
        for (text, field) in cases {
            let e = TwoMassScene::parse(&text).unwrap_err();
            assert!(e.field.contains(field), "{text}\n→ {e} (want field {field})");
        }
    }
}
