//! The coupled glottis's hard cases of stiffness (issue 13, "stability on hard cases": body/cover
//! stiffness ratios 100 and 1000 with the seed's in-plane Poisson ratio 0.97 and the lung
//! pressure switched on abruptly): `glottis_2d_coarse` with the cover at 1·10⁵ dyn/cm² and the
//! body at 100× (the seed's case C) and 1000× it, from rest, for the scene's 40 ms
//! (`validate --case glottis_stiffness_ratio`; outputs in
//! `out/validate/glottis_stiffness_ratio_<ratio>/`).
//!
//! Each run must stay finite for at least 10⁴ coupled steps, keep the air's mass drift within
//! what the lung pressure can put in ([`mass_bound`]), and keep the folds' energy bounded: the kinetic energy's largest value over the second half of the
//! run no larger than over the first half. The abrupt onset sets the folds ringing; stiff folds
//! that the air does not drive (neither case self-oscillates at the seed's pressure, README "What
//! the air takes from the folds") ring down, while a coupling that feeds energy into them
//! numerically makes it grow.
//!
//! Measured (2026-12-05, the two side by side on 2 cores, 620 s; every row passes): ratio 100 — stable
//! 125,366 steps, fluid mass +3.86 %, kinetic-energy peaks 11.3 / 30.9 erg/cm (0.36); ratio 1000 —
//! stable, +2.65 %, 1.26 / 4.46 erg/cm (0.28), the folds within 7.5 µm of rest, so the rest gap
//! (under one cell) stays closed in the lattice and no air passes.

use crate::output::voice::{KINETIC_ENERGY_COLUMN, read_glottal_csv};
use crate::run::coupled::{CoupledReport, run_coupled_scene};
use crate::scene::coupled::CoupledScene;
use std::path::{Path, PathBuf};

/// The cover's Young's modulus (dyn/cm²): the seed's case C.
pub const COVER: f64 = 1.0e5;
/// Body/cover stiffness ratios of the hard cases.
pub const RATIOS: [f64; 2] = [100.0, 1000.0];
/// Coupled steps a hard case must stay finite for (the 10⁴).
pub const MIN_STEPS: u64 = 10_000;

/// `glottis_2d_coarse` with the body `ratio` times as stiff as the cover ([`COVER`]).
pub fn scene(ratio: f64) -> anyhow::Result<CoupledScene> {
    let mut sc = CoupledScene::parse(crate::scene::builtin("glottis_2d_coarse").expect("built in"))?;
    sc.set_fold_moduli(COVER, ratio * COVER);
    Ok(sc)
}

/// The most the air's mass can rise by (a fraction): the whole duct filled to the lung pressure,
/// Δρ/ρ₀ = p_lung/(ρ₀ c²) with the run's sound speed c (the Mach-scaled one: 4.5 % for
/// `glottis_2d_coarse`'s 8000 dyn/cm², ρ₀ 1.184·10⁻³ g/cm³, c 12,253 cm/s). The trachea fills
/// to it and the vocal tract, downstream of the folds, less; more would be air the walls leak in.
pub fn mass_bound(sc: &CoupledScene) -> Option<f64> {
    let u = &sc.fluid.units;
    sc.lung_pressure().map(|p| p / (u.density * u.sound_speed * u.sound_speed))
}

/// The folds' largest kinetic energy over the second half of the series and over the first
/// (erg per cm of fold length), from a run's `glottal_flow.csv`.
pub fn kinetic_energy_halves(csv: &Path) -> anyhow::Result<(f64, f64)> {
    let series = read_glottal_csv(csv)?;
    let ke = series.column(KINETIC_ENERGY_COLUMN).ok_or_else(|| anyhow::anyhow!("{} has no `{KINETIC_ENERGY_COLUMN}` column", csv.display()))?;
    anyhow::ensure!(ke.len() >= 4, "{} holds {} samples, too few to halve", csv.display(), ke.len());
    let largest = |v: &[f64]| v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let (first, second) = ke.split_at(ke.len() / 2);
    Ok((largest(second), largest(first)))
}

/// The rows of one finished run of scene `sc`: stability over at least [`MIN_STEPS`] steps, the
/// air's mass drift within [`mass_bound`], and the bounded energy.
pub fn rows_of(label: &str, sc: &CoupledScene, r: &CoupledReport, dir: &Path) -> Vec<(String, f64, String, bool)> {
    let stable = r.instability.is_none() && r.steps >= MIN_STEPS;
    let bound = mass_bound(sc).unwrap_or(f64::NAN);
    let mut out = vec![
        (
            format!("{label}: stable for {} steps ({:.0} ms)", r.steps, 1e3 * r.simulated_s),
            r.steps as f64,
            format!("finite for ≥ {MIN_STEPS} steps{}", r.instability.as_ref().map(|i| format!(" — {i}")).unwrap_or_default()),
            stable,
        ),
        (
            format!("{label}: fluid mass drift"),
            r.fluid_mass_drift,
            format!("|drift| ≤ p_lung/(ρ₀c²) = {bound:.4} (the duct filled to the lung pressure)"),
            r.fluid_mass_drift.abs() <= bound,
        ),
    ];
    match kinetic_energy_halves(&dir.join("glottal_flow.csv")) {
        Ok((second, first)) => out.push((
            format!("{label}: folds' peak kinetic energy, second half / first half ({second:.3e} / {first:.3e} erg/cm)"),
            second / first,
            "≤ 1 (bounded: the onset's ringing decays)".into(),
            second <= first,
        )),
        Err(e) => out.push((format!("{label}: {e}"), f64::NAN, "the run's glottal series".into(), false)),
    }
    out
}

/// The rows of `validate --case glottis_stiffness_ratio`: both ratios, run side by side.
pub fn rows() -> Vec<(String, f64, String, bool)> {
    use rayon::prelude::*;
    let runs: Vec<_> = RATIOS
        .par_iter()
        .map(|&ratio| {
            let dir = PathBuf::from(format!("out/validate/glottis_stiffness_ratio_{ratio:.0}"));
            let r = scene(ratio).and_then(|sc| Ok((run_coupled_scene(&sc, &dir, &crate::run::RunOptions::default())?, sc)));
            (ratio, dir, r)
        })
        .collect();
    let mut out = Vec::new();
    for (ratio, dir, r) in runs {
        let label = format!("body/cover {ratio:.0}");
        match r {
            Ok((r, sc)) => out.extend(rows_of(&label, &sc, &r, &dir)),
            Err(e) => out.push((format!("{label}: {e}"), f64::NAN, "runs".into(), false)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stiffest hard case for the 10⁴ coupled steps (≈ 3.2 ms of the 40 ms the
    /// validate case runs): the body at 1000× the cover, Poisson 0.97, the lung pressure switched
    /// on at the first step. The run stays finite, the air's mass rises by no more than the
    /// whole duct filled to the lung pressure would ([`mass_bound`]: 4.5 %), and the folds'
    /// kinetic energy over the second half stays below the first half's.
    #[test]
    fn the_glottis_with_a_body_a_thousand_times_the_cover_stays_finite_with_bounded_energy() {
        let sc = scene(1000.0).unwrap();
        let dir = std::env::temp_dir().join(format!("phonation_stiffness_ratio_{}", std::process::id()));
        let opts = crate::run::RunOptions { steps: Some(MIN_STEPS), backend: crate::run::Backend::Cpu, ..Default::default() };
        let r = run_coupled_scene(&sc, &dir, &opts).unwrap();
        let bound = mass_bound(&sc).unwrap();
        assert!((bound - 8000.0 / (1.184e-3 * 12_253.333f64.powi(2))).abs() < 1e-3 * bound, "{bound}");
        let rows = rows_of("body/cover 1000", &sc, &r, &dir);
        for row in &rows {
            eprintln!("{}: {} ({})", row.0, row.1, row.2);
        }
        assert_eq!(r.steps, MIN_STEPS);
        assert_eq!(rows.len(), 3);
        assert!(rows.iter().all(|row| row.3), "{rows:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
