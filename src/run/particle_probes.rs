//! The oscillation of a coupled run's particle probes (a flap's tip, a fold's margin): from the
//! samples a run collects as it goes, or read back from its `coupling.csv` (columns
//! `<probe>_dy`), so that a finished or resumed run can be re-read over any window
//! (`phonation analyze DIR`).

use crate::analysis::oscillation::{Oscillation, oscillation};
use anyhow::{Context, bail};
use serde::Serialize;
use std::path::Path;

/// The oscillation of a particle probe's y displacement (scene units: frequency in Hz, lengths
/// in cm or m) over the last part of the run (by default the second half: the first is the
/// start-up).
#[derive(Clone, Debug, Serialize)]
pub struct ParticleProbeReport {
    pub name: String,
    /// Largest |dy| over all the samples.
    pub max_abs_dy: f64,
    /// None with fewer than two full cycles in the window.
    pub oscillation: Option<Oscillation>,
    /// Start of the analysed window (s); for a resumed run only the samples since the resume
    /// are analysed (`phonation analyze` reads the whole csv).
    pub window_start_s: f64,
}

impl std::fmt::Display for ParticleProbeReport {
    /// One line: the window's spectral peak and largest |dy|, the mean-crossing count, and the
    /// whole run's largest |dy|.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.oscillation {
            Some(o) => write!(
                f,
                "probe {}: from t = {:.3} s: spectral peak {} Hz, largest |dy| {:.4e}; {} mean crossings at {:.4} Hz, last half range {:.4e}, mean {:.3e} (largest |dy| of the whole run {:.4e})",
                self.name,
                self.window_start_s,
                o.spectral_peak.map_or("none".into(), |f| format!("{f:.4}")),
                o.max_abs,
                o.cycles,
                o.frequency,
                o.last_half_range,
                o.mean,
                self.max_abs_dy
            ),
            None => write!(
                f,
                "probe {}: fewer than two cycles from t = {:.3} s (largest |dy| of the whole run {:.4e})",
                self.name, self.window_start_s, self.max_abs_dy
            ),
        }
    }
}

/// The oscillation of each probe's dy samples `(t, dy per probe)` over the last `fraction`
/// (0, 1] of the samples' time span.
pub fn probe_reports(names: &[String], samples: &[(f64, Vec<f64>)], fraction: f64) -> Vec<ParticleProbeReport> {
    let (t0, t1) = (samples.first().map_or(0.0, |s| s.0), samples.last().map_or(0.0, |s| s.0));
    let start = t1 - fraction * (t1 - t0);
    let window: Vec<&(f64, Vec<f64>)> = samples.iter().filter(|s| s.0 >= start).collect();
    let dt = if window.len() > 1 { (window[window.len() - 1].0 - window[0].0) / (window.len() - 1) as f64 } else { 0.0 };
    names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let y: Vec<f64> = window.iter().map(|s| s.1[k]).collect();
            ParticleProbeReport {
                name: name.clone(),
                max_abs_dy: samples.iter().fold(0.0, |m, s| m.max(s.1[k].abs())),
                oscillation: oscillation(&y, dt),
                window_start_s: start,
            }
        })
        .collect()
}

/// The particle probes of a coupled run's `coupling.csv` (its `time_s` and `<probe>_dy` columns;
/// the bodies' `mean_dy_<k>` are not probes), over the last `fraction` of the run. A csv written
/// by a run that was resumed holds its rows once (the resume cuts the rows past its checkpoint).
pub fn probe_reports_from_csv(path: &Path, fraction: f64) -> anyhow::Result<Vec<ParticleProbeReport>> {
    if !(fraction > 0.0 && fraction <= 1.0) {
        bail!("window: {fraction} must lie in (0, 1]");
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().with_context(|| format!("{}: empty", path.display()))?.split(',').collect();
    let time = header.iter().position(|h| *h == "time_s").with_context(|| format!("{}: no time_s column", path.display()))?;
    let probes: Vec<(usize, String)> = header.iter().enumerate().filter_map(|(i, h)| h.strip_suffix("_dy").map(|n| (i, n.to_string()))).collect();
    if probes.is_empty() {
        bail!("{}: no particle probe columns (<probe>_dy)", path.display());
    }
    let mut samples = Vec::new();
    for (row, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let cells: Vec<&str> = line.split(',').collect();
        let value = |i: usize| -> anyhow::Result<f64> {
            let c = cells.get(i).with_context(|| format!("{} row {}: {} cells, column {} missing", path.display(), row + 2, cells.len(), header[i]))?;
            c.trim().parse().with_context(|| format!("{} row {}, column {}: {c:?} is not a number", path.display(), row + 2, header[i]))
        };
        samples.push((value(time)?, probes.iter().map(|(i, _)| value(*i)).collect::<anyhow::Result<Vec<f64>>>()?));
    }
    if samples.len() < 4 {
        bail!("{}: {} rows, too few to analyse", path.display(), samples.len());
    }
    let names: Vec<String> = probes.into_iter().map(|(_, n)| n).collect();
    Ok(probe_reports(&names, &samples, fraction))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A csv laid out as `coupling.csv` (a body's mean_dy_0 column that is not a probe, a probe
    /// "tip" moving as 0.9 sin(2π 3.2 t) + 0.6 sin(2π 9.6 t)): the spectral peak is 3.2 Hz, the
    /// largest |dy| over the second half is the signal's own, and the window follows `fraction`.
    #[test]
    fn a_coupling_csv_is_read_back_into_its_probes_oscillation() {
        let dir = std::env::temp_dir().join(format!("phonation_probe_csv_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("coupling.csv");
        let dy = |t: f64| 0.9 * (2.0 * std::f64::consts::PI * 3.2 * t).sin() + 0.6 * (2.0 * std::f64::consts::PI * 9.6 * t).sin();
        let mut text = String::from("step,time_s,force_x_0,force_y_0,mean_dx_0,mean_dy_0,tip_dx,tip_dy,max_displacement\n");
        for k in 0..4000 {
            let t = k as f64 * 1e-3;
            text += &format!("{k},{t:.9e},1,2,0,{:.9e},0,{:.9e},0\n", 5.0 * t, dy(t));
        }
        std::fs::write(&path, text).unwrap();
        let r = probe_reports_from_csv(&path, 0.5).unwrap();
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].name, "tip");
        assert!((r[0].window_start_s - 0.5 * 3.999).abs() < 1e-9, "{}", r[0].window_start_s);
        let o = r[0].oscillation.as_ref().unwrap();
        let f = o.spectral_peak.unwrap();
        assert!((f - 3.2).abs() < 0.02, "spectral peak {f}");
        let expect = (2000..4000).map(|k| dy(k as f64 * 1e-3).abs()).fold(0.0, f64::max);
        assert!((o.max_abs - expect).abs() < 1e-8, "{} vs {expect}", o.max_abs);
        let whole = probe_reports_from_csv(&path, 1.0).unwrap();
        assert_eq!(whole[0].window_start_s, 0.0);
        // bad input names what is wrong
        assert!(probe_reports_from_csv(&path, 0.0).unwrap_err().to_string().contains("window"));
        std::fs::write(&path, "step,time_s,tip_dy\n0,0,1\n1,1e-3,x\n").unwrap();
        let e = probe_reports_from_csv(&path, 0.5).unwrap_err().to_string();
        assert!(e.contains("row 3") && e.contains("tip_dy"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
