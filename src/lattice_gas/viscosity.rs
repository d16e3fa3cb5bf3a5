//! Kinematic viscosity of the lattice gas from the decay of a shear wave (issue 5: the seed made
//! no quantitative measurement). A periodic box is filled at density d per link with the
//! transverse velocity u_Y = U sin(k x_X), k = 2π / L_X; the mode's momentum decays as
//! exp(−ν k² t), and ν is the slope of ln A(t) fitted by least squares. Tables average
//! independent seeds and give the standard error, the Boltzmann-approximation line
//! ν(0) + Δν(p) of [`super::mean_field`] beside it, and the smallest velocity-family share at the
//! end of the runs ([`super::isotropy`]: where it has left 1 the gas is no longer isotropic and
//! ν is not the isotropic fluid's viscosity).
//! Units: ν in (site spacing ℓ)² per step, with integer 4D site coordinates.

use super::collision::CollisionTable;
use super::isotropy::{family_shares, smallest_share};
use super::lattice::{Diagonals, LatticeGas};
use crate::analysis::fit::slope;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
pub struct ShearWave {
    pub density: f64,
    pub interference: f64,
    /// Measured kinematic viscosity ν (ℓ²/step).
    pub viscosity: f64,
    /// Amplitude of the mode at the start and the end of the fit (momentum per site).
    pub amplitudes: (f64, f64),
    pub steps: u32,
    /// The smallest share of a velocity family at the end (1 while the populations stay
    /// isotropic; [`super::isotropy`]).
    pub smallest_share: f64,
}

/// How a shear wave is set up and fitted.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ShearWaveSetup {
    /// Cells along X (a multiple of 4): the wave's length is 2 `nx` ℓ.
    pub nx: usize,
    /// Cells along Y and Z.
    pub n: usize,
    /// Steps run; the decay is fitted from step 20 to the last.
    pub steps: u32,
    /// Amplitude U of the initial u_Y (ℓ/step).
    pub amplitude: f64,
    /// Diagonals of the interference.
    pub diagonals: Diagonals,
}

impl ShearWaveSetup {
    /// The table's box: 32 × 8 × 8 cells, 600 steps, U = 0.1, own-plane interference.
    pub const TABLE: Self = Self { nx: 32, n: 8, steps: 600, amplitude: 0.1, diagonals: Diagonals::OwnPlane };
}

/// Measures ν in a box of `nx` × `n` × `n` cells over `steps` steps (fit from step 20).
pub fn shear_wave(density: f64, interference: f64, setup: &ShearWaveSetup, seed: u32) -> ShearWave {
    let table = CollisionTable::shared();
    let &ShearWaveSetup { nx, n, steps, amplitude, diagonals } = setup;
    let lx = 2.0 * nx as f64;
    let k = 2.0 * std::f64::consts::PI / lx;
    let mut g = LatticeGas::new([nx, n, n], seed, interference);
    g.diagonals = diagonals;
    g.fill(density, |x| [0.0, amplitude * (k * x[0]).sin(), 0.0, 0.0], seed.wrapping_add(1));
    let mode = |g: &LatticeGas| {
        let prof = g.momentum_profile_x();
        2.0 / nx as f64 * prof.iter().enumerate().map(|(x, j)| j[1] * (k * 2.0 * x as f64).sin()).sum::<f64>()
    };
    let (mut ts, mut ls) = (Vec::new(), Vec::new());
    let mut first = f64::NAN;
    let mut last = f64::NAN;
    for t in 0..steps {
        if t >= 20 {
            let a = mode(&g);
            if a > 0.0 {
                ts.push(t as f64);
                ls.push(a.ln());
            }
            if t == 20 {
                first = a;
            }
            last = a;
        }
        g.advance(table);
    }
    let smallest_share = smallest_share(&family_shares(&g));
    ShearWave { density, interference, viscosity: -slope(&ts, &ls) / (k * k), amplitudes: (first, last), steps, smallest_share }
}

/// An ensemble of shear-wave measurements at one (density, p): independent seeds.
#[derive(Clone, Debug, Serialize)]
pub struct ViscosityPoint {
    pub density: f64,
    pub interference: f64,
    pub setup: ShearWaveSetup,
    /// Mean ν over the seeds (ℓ²/step).
    pub viscosity: f64,
    /// Standard error of the mean (sample standard deviation / √seeds).
    pub standard_error: f64,
    /// Mean over the seeds of [`ShearWave::smallest_share`].
    pub smallest_share: f64,
    pub seeds: usize,
    pub runs: Vec<ShearWave>,
}

/// ν over every (density, p) pair (rows density-major), each the mean of [`shear_wave`] over
/// `seeds` seeds (the same seeds at every point); runs in parallel.
pub fn viscosity_table(densities: &[f64], interference: &[f64], setup: &ShearWaveSetup, seeds: usize) -> Vec<ViscosityPoint> {
    use rayon::prelude::*;
    let runs: Vec<(f64, f64, u32)> =
        densities.iter().flat_map(|&d| interference.iter().flat_map(move |&p| (0..seeds as u32).map(move |s| (d, p, 11 + 7919 * s)))).collect();
    let results: Vec<ShearWave> = runs.par_iter().map(|&(d, p, seed)| shear_wave(d, p, setup, seed)).collect();
    results
        .chunks(seeds)
        .map(|c| {
            let m = c.len() as f64;
            let mean = c.iter().map(|r| r.viscosity).sum::<f64>() / m;
            let var = if c.len() > 1 { c.iter().map(|r| (r.viscosity - mean).powi(2)).sum::<f64>() / (m - 1.0) } else { 0.0 };
            ViscosityPoint {
                density: c[0].density,
                interference: c[0].interference,
                setup: *setup,
                viscosity: mean,
                standard_error: (var / m).sqrt(),
                smallest_share: c.iter().map(|r| r.smallest_share).sum::<f64>() / m,
                seeds: c.len(),
                runs: c.to_vec(),
            }
        })
        .collect()
}

/// Where ν(p) of one density first turns negative, by linear interpolation between the
/// measured points (`None` if it stays positive over the table).
pub fn zero_crossing(rows: &[ViscosityPoint], density: f64) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = rows.iter().filter(|r| r.density == density).map(|r| (r.interference, r.viscosity)).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    pts.windows(2).find(|w| w[0].1 > 0.0 && w[1].1 <= 0.0).map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].1 / (w[0].1 - w[1].1))
}

/// ν(0) measured at `density` plus the Boltzmann-approximation shift of the interference,
/// [`super::mean_field::viscosity_shift`] (`None` without a p = 0 row at that density).
pub fn mean_field_line(rows: &[ViscosityPoint], density: f64, interference: f64) -> Option<f64> {
    let base = rows.iter().find(|r| r.density == density && r.interference == 0.0)?;
    Some(base.viscosity + super::mean_field::viscosity_shift(density, interference, base.setup.diagonals))
}

/// Writes `viscosity.csv`, `viscosity.json` and `viscosity.svg` (ν against p, one line per
/// density with its mean-field line dashed, and the zero line) into `dir`; returns the paths.
pub fn write_table(dir: &std::path::Path, rows: &[ViscosityPoint]) -> anyhow::Result<Vec<std::path::PathBuf>> {
    use plotters::prelude::*;
    std::fs::create_dir_all(dir)?;
    let mut densities: Vec<f64> = rows.iter().map(|r| r.density).collect();
    densities.sort_by(f64::total_cmp);
    densities.dedup();
    let csv = dir.join("viscosity.csv");
    let mut text =
        String::from("density,interference,diagonals,viscosity,standard_error,mean_field_viscosity,smallest_family_share,seeds,box,steps,amplitude\n");
    for r in rows {
        let mean_field = mean_field_line(rows, r.density, r.interference).map_or(String::new(), |v| format!("{v:.6}"));
        let ShearWaveSetup { nx, n, steps, amplitude, diagonals } = r.setup;
        text += &format!(
            "{},{},{},{:.6},{:.6},{mean_field},{:.4},{},{nx}x{n}x{n},{steps},{amplitude}\n",
            r.density,
            r.interference,
            diagonals.name(),
            r.viscosity,
            r.standard_error,
            r.smallest_share,
            r.seeds
        );
    }
    std::fs::write(&csv, text)?;
    let json = dir.join("viscosity.json");
    let crossings: Vec<_> = densities.iter().map(|&d| serde_json::json!({"density": d, "p_at_zero_viscosity": zero_crossing(rows, d)})).collect();
    std::fs::write(&json, serde_json::to_string_pretty(&serde_json::json!({"rows": rows, "zero_crossings": crossings}))?)?;
    let svg = dir.join("viscosity.svg");
    {
        let root = SVGBackend::new(&svg, (720, 480)).into_drawing_area();
        root.fill(&WHITE)?;
        let p_max = rows.iter().map(|r| r.interference).fold(0.0, f64::max).max(0.05);
        let (lo, hi) = rows.iter().fold((0.0f64, 0.0f64), |(a, b), r| (a.min(r.viscosity - r.standard_error), b.max(r.viscosity + r.standard_error)));
        let pad = 0.05 * (hi - lo).max(1e-3);
        let mut chart = ChartBuilder::on(&root)
            .caption("FCHC lattice gas: shear-wave viscosity vs interference probability", ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..p_max, (lo - pad)..(hi + pad))?;
        chart.configure_mesh().x_desc("interference probability p").y_desc("ν (ℓ² / step)").draw()?;
        chart.draw_series(LineSeries::new([(0.0, 0.0), (p_max, 0.0)], BLACK.stroke_width(1)))?;
        for (i, &d) in densities.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let mut pts: Vec<(f64, f64)> = rows.iter().filter(|r| r.density == d).map(|r| (r.interference, r.viscosity)).collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
                .label(format!("fill {d}"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
            // the Boltzmann-approximation line from the measured ν(0), dashed
            let line: Vec<(f64, f64)> = pts.iter().filter_map(|&(p, _)| mean_field_line(rows, d, p).map(|v| (p, v))).collect();
            chart.draw_series(DashedLineSeries::new(line, 6, 4, color.stroke_width(1)))?;
            // error bars: ± one standard error of the mean
            chart.draw_series(rows.iter().filter(|r| r.density == d).map(|r| {
                PathElement::new(
                    vec![(r.interference, r.viscosity - r.standard_error), (r.interference, r.viscosity + r.standard_error)],
                    color.stroke_width(1),
                )
            }))?;
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
        root.present()?;
    }
    Ok(vec![csv, json, svg])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shear_wave_viscosity_matches_the_boltzmann_value_and_responds_to_interference() {
        // ../shared/reference: ν ≈ 0.20 ℓ²/step at d = 0.2 for the uniform-in-class rule
        // (Boltzmann approximation; measurements deviate by 10–15 %). One seed scatters by
        // ≈ 0.02 (0.17–0.22 over four seeds), so the mean of four seeds is compared.
        let rows = viscosity_table(&[0.2], &[0.0, 0.4], &ShearWaveSetup::TABLE, 4);
        for r in &rows {
            let each: Vec<String> = r.runs.iter().map(|w| format!("{:.4}", w.viscosity)).collect();
            println!(
                "d = 0.2, p = {}: ν = {:.4} ± {:.4} (seeds: {}); mean field {:.4}; smallest family share at the end {:.3}",
                r.interference,
                r.viscosity,
                r.standard_error,
                each.join(", "),
                mean_field_line(&rows, 0.2, r.interference).unwrap(),
                r.smallest_share
            );
        }
        let (p0, p4) = (&rows[0], &rows[1]);
        assert!((p0.viscosity / 0.20 - 1.0).abs() < 0.15, "ν = {}", p0.viscosity);
        assert!(p0.standard_error > 0.0 && p0.standard_error < 0.03);
        // The interference operation as the seed describes it (bits.rs) raises the shear-wave
        // damping instead of lowering it: 8-seed tables give ν flat within ±0.01 for p ≤ 0.1 and
        // rising beyond (0.203 → 0.347 at p = 0.4, d = 0.2), where the Boltzmann approximation
        // (mean_field.rs) predicts a fall of 0.002. The rise comes with the loss of isotropy of
        // the velocity populations (isotropy.rs): at p = 0.4 the smallest family share is far
        // below 1 by the end of the 600 steps, at p = 0 it stays at 1. Asserted with a
        // 4-standard-error margin so that the finding stays pinned.
        let se = (p0.standard_error.powi(2) + p4.standard_error.powi(2)).sqrt();
        assert!(p4.viscosity - p0.viscosity > 4.0 * se, "ν(0.4) = {} ± {}, ν(0) = {} ± {}", p4.viscosity, p4.standard_error, p0.viscosity, p0.standard_error);
        assert!(p0.smallest_share > 0.97 && p4.smallest_share < 0.8, "shares {} and {}", p0.smallest_share, p4.smallest_share);
    }

    #[test]
    fn while_the_gas_is_still_isotropic_the_interference_leaves_nu_unchanged() {
        // The same shear wave fitted over steps 20–150 only, before the populations leave
        // isotropy (48 seeds: ν = 0.2052 ± 0.0026 at p = 0 and 0.2032 ± 0.0024 at p = 0.4, the
        // smallest share still 0.95 — against 0.347 over 600 steps). So the rise is not the
        // operation's direct effect on the momentum flux but the change of state; the direct
        // effect is the mean field's −0.002 (mean_field.rs), within the error here.
        let rows = viscosity_table(&[0.2], &[0.0, 0.4], &ShearWaveSetup { steps: 150, ..ShearWaveSetup::TABLE }, 48);
        let (p0, p4) = (&rows[0], &rows[1]);
        let se = (p0.standard_error.powi(2) + p4.standard_error.powi(2)).sqrt();
        println!(
            "steps 20–150: ν = {:.4} ± {:.4} (p = 0), {:.4} ± {:.4} (p = 0.4; mean field {:.4}); smallest share {:.3}, {:.3}",
            p0.viscosity,
            p0.standard_error,
            p4.viscosity,
            p4.standard_error,
            mean_field_line(&rows, 0.2, 0.4).unwrap(),
            p0.smallest_share,
            p4.smallest_share
        );
        assert!(se < 0.005, "standard error {se}");
        assert!((p4.viscosity - p0.viscosity).abs() < 4.0 * se, "{} vs {}", p4.viscosity, p0.viscosity);
        assert!(p4.smallest_share > 0.9);
    }

    #[test]
    fn with_every_perpendicular_diagonal_nu_falls_with_p_at_the_mean_field_rate_while_isotropic() {
        // The reading of seed 002 §3.4 in which every family of squares with a diagonal
        // perpendicular to c_k exchanges (lattice::Diagonals::AllPerpendicular) moves 4.3–5 times
        // the own plane's momentum (mean_field.rs): Δν = −0.0072 at p = 0.3, d = 0.2 — large
        // enough to resolve before the isotropy goes. Shear wave of 16 × 8 × 8 cells (k = 2π /
        // 32 sites, so the mode decays by half between steps 20 and 150), U = 0.25 for a
        // stronger signal, 128 seeds per point (the same at every p): ν = 0.2039, 0.2018,
        // 0.2007, 0.1986 (± 0.0007) at p = 0, 0.1, 0.2, 0.3 against the mean-field line
        // 0.2039, 0.2014, 0.1990, 0.1967; the smallest family share stays ≥ 0.98.
        // Asserted: each point below the one before (steps of 1.5–3 standard errors); the fall
        // over the range more than 4 standard errors; the least-squares slope dν/dp within 3
        // standard errors of the mean field's.
        let setup = ShearWaveSetup { nx: 16, n: 8, steps: 150, amplitude: 0.25, diagonals: Diagonals::AllPerpendicular };
        let ps = [0.0, 0.1, 0.2, 0.3];
        let rows = viscosity_table(&[0.2], &ps, &setup, 128);
        for r in &rows {
            println!(
                "p = {}: ν = {:.4} ± {:.4}; mean field {:.4}; smallest share {:.3}",
                r.interference,
                r.viscosity,
                r.standard_error,
                mean_field_line(&rows, 0.2, r.interference).unwrap(),
                r.smallest_share
            );
            assert!(r.smallest_share > 0.95, "p = {}: share {}", r.interference, r.smallest_share);
        }
        for w in rows.windows(2) {
            assert!(w[1].viscosity < w[0].viscosity, "ν({}) = {} ≥ ν({}) = {}", w[1].interference, w[1].viscosity, w[0].interference, w[0].viscosity);
        }
        let (first, last) = (&rows[0], &rows[rows.len() - 1]);
        let se = (first.standard_error.powi(2) + last.standard_error.powi(2)).sqrt();
        assert!(first.viscosity - last.viscosity > 4.0 * se, "fall {} ± {se}", first.viscosity - last.viscosity);
        // slope of ν against p, and its standard error from the points' (p spread evenly)
        let nus: Vec<f64> = rows.iter().map(|r| r.viscosity).collect();
        let slope_measured = slope(&ps, &nus);
        let sxx: f64 = ps.iter().map(|p| (p - 0.15).powi(2)).sum();
        let slope_se = (rows.iter().map(|r| r.standard_error.powi(2) * (r.interference - 0.15).powi(2)).sum::<f64>()).sqrt() / sxx;
        let mean_field: Vec<f64> = ps.iter().map(|&p| mean_field_line(&rows, 0.2, p).unwrap()).collect();
        let slope_mean_field = slope(&ps, &mean_field);
        println!("dν/dp = {slope_measured:.4} ± {slope_se:.4}; mean field {slope_mean_field:.4}");
        assert!((slope_measured - slope_mean_field).abs() < 3.0 * slope_se, "{slope_measured} vs {slope_mean_field}");
    }
}
