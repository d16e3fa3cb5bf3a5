//! The oscillation of a coupled run's particle probes (a flap's tip, a fold's margin): from the
//! samples a run collects as it goes, or read back from its `coupling.csv` (columns
//! `<probe>_dx`, `<probe>_dy`), so that a finished or resumed run can be re-read over any window
//! (`phonation analyze DIR`): the dy oscillation, and the (dx, dy) path's ellipse and every
//! pair's lead.

use crate::analysis::lag::lead_time;
use crate::analysis::oscillation::{Oscillation, oscillation};
use crate::analysis::path::{PathEllipse, path_ellipse};
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
    /// Start of the analysed window (s): of the whole run's samples, a resumed run's too (its
    /// checkpoint carries those before it).
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

/// The samples of the last `fraction` of `samples`' time span (in time order), where that part
/// starts (s) and its mean sampling interval (0 with fewer than two samples).
fn last_part<T>(samples: &[(f64, T)], fraction: f64) -> (&[(f64, T)], f64, f64) {
    let (t0, t1) = (samples.first().map_or(0.0, |s| s.0), samples.last().map_or(0.0, |s| s.0));
    let start = t1 - fraction * (t1 - t0);
    let window = &samples[samples.partition_point(|s| s.0 < start)..];
    let dt = if window.len() > 1 { (window[window.len() - 1].0 - window[0].0) / (window.len() - 1) as f64 } else { 0.0 };
    (window, start, dt)
}

/// The oscillation of each probe's dy samples `(t, dy per probe)` over the last `fraction`
/// (0, 1] of the samples' time span.
pub fn probe_reports(names: &[String], samples: &[(f64, Vec<f64>)], fraction: f64) -> Vec<ParticleProbeReport> {
    let (window, start, dt) = last_part(samples, fraction);
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

/// A particle probe's motion in the plane of its two displacement components over the window:
/// the oscillation of its x (for a fold: lateral, opening and closing) displacement and the
/// ellipse of its (dx, dy) path (seed 000 §3.4.3: the medial surface's particles go round
/// ellipses).
#[derive(Clone, Debug, Serialize)]
pub struct ProbePath {
    pub name: String,
    pub oscillation_dx: Option<Oscillation>,
    pub path: Option<PathEllipse>,
}

/// The time by which probe `leading`'s dx leads probe `following`'s over the window (s, positive:
/// `leading` moves first; the cross-correlation's peak within half a period of `leading`'s dx,
/// [`lead_time`]): the vertical (lower margin before upper) and anterior–posterior phase
/// differences of the seed's 3D glottis. `None` where either does not oscillate.
#[derive(Clone, Debug, Serialize)]
pub struct ProbeLead {
    pub leading: String,
    pub following: String,
    pub lead_s: Option<f64>,
    /// The phase difference of their dx at `leading`'s frequency (degrees, positive: `leading`
    /// ahead; [`crate::analysis::lag::phase_lead`], the fundamentals alone).
    pub phase_deg: Option<f64>,
}

/// What `phonation analyze` reads from a run's particle probes (`coupling.csv`'s `time_s` and
/// `<probe>_dx`, `<probe>_dy` columns; the bodies' `mean_dy_<k>` are not probes; a csv written by
/// a resumed run holds its rows once, the resume cutting those past its checkpoint): every probe's
/// [`ParticleProbeReport`] (its dy) and [`ProbePath`], and the [`ProbeLead`] of every pair (in
/// column order), over the last `fraction` of its `coupling.csv` (read once).
pub fn probe_motion_from_csv(path: &Path, fraction: f64) -> anyhow::Result<(Vec<ParticleProbeReport>, Vec<ProbePath>, Vec<ProbeLead>)> {
    let (names, samples) = read_probes(path, fraction)?;
    let dy: Vec<(f64, Vec<f64>)> = samples.iter().map(|(t, d)| (*t, d.iter().map(|d| d[1]).collect())).collect();
    let reports = probe_reports(&names, &dy, fraction);
    let (window, _, dt) = last_part(&samples, fraction);
    // each probe's (dx, dy) over the window, taken once
    let xy: Vec<(Vec<f64>, Vec<f64>)> = (0..names.len()).map(|k| window.iter().map(|s| (s.1[k][0], s.1[k][1])).unzip()).collect();
    let paths: Vec<ProbePath> = names
        .iter()
        .zip(&xy)
        .map(|(name, (x, y))| {
            // the ellipse over whole cycles of dx: a part cycle would weigh one side of it more
            let c = whole_cycles(x);
            ProbePath { name: name.clone(), oscillation_dx: oscillation(x, dt), path: path_ellipse(&x[c.clone()], &y[c]) }
        })
        .collect();
    let mut leads = Vec::new();
    for a in 0..names.len() {
        let frequency = paths[a].oscillation_dx.as_ref().map(|o| o.spectral_peak.unwrap_or(o.frequency)).filter(|f| *f > 0.0);
        for b in a + 1..names.len() {
            let both = frequency.filter(|_| paths[b].oscillation_dx.is_some());
            let lead_s = both.and_then(|f| {
                let max_lag = ((0.5 / f / dt).round() as usize).clamp(1, window.len() / 3);
                lead_time(&xy[a].0, &xy[b].0, dt, max_lag)
            });
            let phase_deg = both.and_then(|f| crate::analysis::lag::phase_lead(&xy[a].0, &xy[b].0, dt, f)).map(|p| p.degrees);
            leads.push(ProbeLead { leading: names[a].clone(), following: names[b].clone(), lead_s, phase_deg });
        }
    }
    Ok((reports, paths, leads))
}

/// The samples from `x`'s first upward mean crossing to its last (whole cycles), or all of them
/// with fewer than two crossings.
fn whole_cycles(x: &[f64]) -> std::ops::Range<usize> {
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    let up: Vec<usize> = (1..x.len()).filter(|&k| x[k - 1] < mean && x[k] >= mean).collect();
    match (up.first(), up.last()) {
        (Some(&a), Some(&b)) if b > a => a..b,
        _ => 0..x.len(),
    }
}

/// One row of a probe file: the time (s) and each probe's (dx, dy) (cm).
type ProbeRow = (f64, Vec<[f64; 2]>);

/// The probes' names and samples (time, [dx, dy] per probe) of a run's `coupling.csv`, checked:
/// `fraction` in (0, 1], a `time_s` column, at least one probe (`<probe>_dx`, `<probe>_dy`), a
/// number in every cell, at least four rows.
fn read_probes(path: &Path, fraction: f64) -> anyhow::Result<(Vec<String>, Vec<ProbeRow>)> {
    if !(fraction > 0.0 && fraction <= 1.0) {
        bail!("window: {fraction} must lie in (0, 1]");
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().with_context(|| format!("{}: empty", path.display()))?.split(',').collect();
    let time = header.iter().position(|h| *h == "time_s").with_context(|| format!("{}: no time_s column", path.display()))?;
    let probes: Vec<(Option<usize>, usize, String)> = header
        .iter()
        .enumerate()
        .filter_map(|(i, h)| h.strip_suffix("_dy").map(|n| (header.iter().position(|x| x.strip_suffix("_dx") == Some(n)), i, n.to_string())))
        .collect();
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
        let d = probes.iter().map(|(x, y, _)| Ok([x.map(value).transpose()?.unwrap_or(0.0), value(*y)?])).collect::<anyhow::Result<Vec<[f64; 2]>>>()?;
        samples.push((value(time)?, d));
    }
    if samples.len() < 4 {
        bail!("{}: {} rows, too few to analyse", path.display(), samples.len());
    }
    Ok((probes.into_iter().map(|(_, _, n)| n).collect(), samples))
}

/// Whether a run's `coupling.csv` has particle-probe columns (`<probe>_dy`).
pub fn has_probes(path: &Path) -> bool {
    use std::io::BufRead;
    let mut header = String::new();
    std::fs::File::open(path).map(|f| std::io::BufReader::new(f).read_line(&mut header)).is_ok_and(|r| r.is_ok())
        && header.trim_end().split(',').any(|c| c.ends_with("_dy"))
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
        let r = probe_motion_from_csv(&path, 0.5).unwrap().0;
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].name, "tip");
        assert!((r[0].window_start_s - 0.5 * 3.999).abs() < 1e-9, "{}", r[0].window_start_s);
        let o = r[0].oscillation.as_ref().unwrap();
        let f = o.spectral_peak.unwrap();
        assert!((f - 3.2).abs() < 0.02, "spectral peak {f}");
        let expect = (2000..4000).map(|k| dy(k as f64 * 1e-3).abs()).fold(0.0, f64::max);
        assert!((o.max_abs - expect).abs() < 1e-8, "{} vs {expect}", o.max_abs);
        let whole = probe_motion_from_csv(&path, 1.0).unwrap().0;
        assert_eq!(whole[0].window_start_s, 0.0);
        // bad input names what is wrong
        assert!(probe_motion_from_csv(&path, 0.0).unwrap_err().to_string().contains("window"));
        std::fs::write(&path, "step,time_s,tip_dy\n0,0,1\n1,1e-3,x\n").unwrap();
        let e = probe_motion_from_csv(&path, 0.5).unwrap_err().to_string();
        assert!(e.contains("row 3") && e.contains("tip_dy"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Two probes laid out as the 3D glottis writes them (`<probe>_dx`, `<probe>_dy`), going
    /// round ellipses at 360 Hz — semi-axes 3 and 1 µm, the "lower" one counter-clockwise and
    /// 0.2 ms ahead of the "upper" one, which goes clockwise — sampled every 5.7 µs: the leads,
    /// the ellipses and their senses come back.
    #[test]
    fn the_probes_paths_and_leads_come_back_from_the_csv() {
        let dir = std::env::temp_dir().join(format!("phonation_probe_paths_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("coupling.csv");
        let (f, dt, lag) = (360.0, 5.7e-6, 0.2e-3);
        let w = 2.0 * std::f64::consts::PI * f;
        let mut text = String::from("step,time_s,force_x_0,mean_dx_0,mean_dy_0,lower_dx,lower_dy,upper_dx,upper_dy,max_displacement\n");
        for k in 0..6000 {
            let t = k as f64 * dt;
            let (l, u) = (w * t, w * (t - lag));
            text += &format!("{k},{t:.9e},1,0,0,{:.9e},{:.9e},{:.9e},{:.9e},0\n", 3e-4 * l.cos(), 1e-4 * l.sin(), 3e-4 * u.cos(), -1e-4 * u.sin());
        }
        std::fs::write(&path, text).unwrap();
        assert!(has_probes(&path));
        let (reports, paths, leads) = probe_motion_from_csv(&path, 0.5).unwrap();
        assert_eq!(reports.len(), 2);
        assert!((reports[0].oscillation.as_ref().unwrap().spectral_peak.unwrap() / f - 1.0).abs() < 0.01, "dy of the lower probe");
        assert_eq!(paths.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["lower", "upper"]);
        for (p, sense) in paths.iter().zip([1, -1]) {
            let e = p.path.unwrap();
            assert!((e.semi_major / 3e-4 - 1.0).abs() < 0.01 && (e.semi_minor / 1e-4 - 1.0).abs() < 0.01, "{}: {e:?}", p.name);
            assert_eq!(e.sense, sense, "{}", p.name);
            let fx = p.oscillation_dx.as_ref().unwrap().spectral_peak.unwrap();
            assert!((fx / f - 1.0).abs() < 0.01, "{}: {fx} Hz", p.name);
        }
        assert_eq!(leads.len(), 1);
        let lead = leads[0].lead_s.unwrap();
        assert!((lead / lag - 1.0).abs() < 0.02, "lead {lead} s, expected {lag}");
        // 0.2 ms of a 360 Hz cycle: 25.92°
        let phase = leads[0].phase_deg.unwrap();
        assert!((phase / (360.0 * f * lag) - 1.0).abs() < 0.01, "phase {phase}°, expected {}", 360.0 * f * lag);
        std::fs::remove_dir_all(&dir).ok();
    }
}
