//! What a solid run of a clamped–free beam reports against beam theory
//! ([`crate::analysis::beam`]): the first period of its tip's vibration and, under a tip load,
//! the tip's deflection at the end against the static one — the error the scene's speed is
//! read against (the built-in `cantilever` and `oscillating_plate`). Read from `solid.csv` once
//! the run ends, so that a resumed run analyses its whole history.

use super::columns::Columns;
use crate::analysis::beam::BeamTheory;
use crate::analysis::oscillation::{oscillation, upward_crossings};
use crate::scene::solid::{MaterialSpec, SolidScene};
use anyhow::Context;
use serde::Serialize;
use std::path::Path;

/// A beam run against beam theory (the scene's units: lengths, forces, seconds).
#[derive(Clone, Debug, Serialize)]
pub struct BeamReport {
    /// The beam as theory sees it: free length from the clamp's face, section, material.
    pub theory: BeamTheory,
    /// x of the clamp's face (the root).
    pub root_x: f64,
    /// Euler–Bernoulli's first period, 1/f₁.
    pub first_period_theory: f64,
    /// The probe that holds the tip (the box around the last particle column), whose mean y
    /// displacement is read; None when no probe does (nothing measured).
    pub tip_probe: Option<String>,
    /// The tip's vibration over the run; None with fewer than two cycles.
    pub vibration: Option<BeamVibration>,
    /// Under a transverse tip load: the static deflection against the tip's at the end.
    pub tip_load: Option<TipLoad>,
}

/// The tip's measured vibration.
#[derive(Clone, Debug, Serialize)]
pub struct BeamVibration {
    /// Mean period between the first and last upward crossings of the tip's mean deflection
    /// (free) or of its deflection at the end (under a load: while the swing exceeds 1 % of it).
    pub period: f64,
    pub cycles: usize,
    /// period / first_period_theory − 1.
    pub error_vs_theory: f64,
}

/// A transverse tip load and the deflection it gives.
#[derive(Clone, Debug, Serialize)]
pub struct TipLoad {
    /// The load's y component (force; per unit depth in 2D).
    pub load: f64,
    /// Beam theory's static tip deflection under it (signed, along y).
    pub deflection_theory: f64,
    /// The tip probe's y displacement at the run's end.
    pub deflection_end: Option<f64>,
    /// deflection_end / deflection_theory − 1.
    pub error_vs_theory: Option<f64>,
    /// The tip's peak-to-peak swing over the run's last theoretical period, as a fraction of the
    /// static deflection: how far from rest the end state still is (the error above means the
    /// static one only when this is small).
    pub last_period_swing: Option<f64>,
}

/// A scene that is one straight beam: one isotropic box along x, clamped over its whole section
/// at its low-x end, no gravity, walls, contact or layers; at most one load, on the free end,
/// along y.
struct ClampedBeam {
    theory: BeamTheory,
    root_x: f64,
    /// A point on the tip's last particle column, mid-section.
    tip: [f64; 3],
    load: Option<f64>,
}

fn clamped_beam(sc: &SolidScene) -> Option<ClampedBeam> {
    let s = &sc.file.solid;
    let dim = s.dimension;
    let [body] = s.bodies.as_slice() else { return None };
    let zero = |v: &[f64]| v.iter().all(|&c| c == 0.0);
    let box_body = body.radius.is_none() && body.fold.is_none() && body.min.len() == dim && body.max.len() == dim;
    if !box_body || !zero(&body.velocity) || !zero(&s.gravity) || !s.walls.is_empty() || s.contact.is_some() || !s.layers.is_empty() {
        return None;
    }
    let MaterialSpec::Isotropic { young, poisson, density, .. } = *s.materials.get(body.material)? else { return None };
    let (lo, hi) = (&body.min, &body.max);
    // the clamps that reach into the body hold its whole section from its low-x end on
    let across = |r_min: &[f64], r_max: &[f64]| (1..dim).all(|a| r_min[a] <= lo[a] && r_max[a] >= hi[a]);
    let mut root_x = f64::NEG_INFINITY;
    for c in &s.clamps {
        if c.max[0] < lo[0] || c.min[0] > hi[0] {
            continue;
        }
        if c.min[0] > lo[0] || c.max[0] >= hi[0] || !across(&c.min, &c.max) {
            return None;
        }
        root_x = root_x.max(c.max[0]);
    }
    if !root_x.is_finite() {
        return None;
    }
    let load = match s.loads.as_slice() {
        [] => None,
        [l] => {
            let f = |a: usize| l.total_force.get(a).copied().unwrap_or(0.0);
            let transverse_only = f(0) == 0.0 && f(2) == 0.0 && f(1) != 0.0;
            if !(transverse_only && l.min[0] >= root_x && l.max[0] >= hi[0] && across(&l.min, &l.max)) {
                return None;
            }
            Some(f(1))
        }
        _ => return None,
    };
    let width = if dim == 3 { hi[2] - lo[2] } else { 0.0 };
    let theory = BeamTheory { dim, length: hi[0] - root_x, thickness: hi[1] - lo[1], width, young, poisson, density };
    let mid = |a: usize| if a < dim { 0.5 * (lo[a] + hi[a]) } else { 0.0 };
    Some(ClampedBeam { theory, root_x, tip: [hi[0] - 0.5 * s.spacing, mid(1), mid(2)], load })
}

/// The beam report of a run of `sc` whose rows are in `solid_csv`; `None` for a scene that is
/// not one clamped–free beam.
pub fn beam_report(sc: &SolidScene, solid_csv: &Path) -> anyhow::Result<Option<BeamReport>> {
    let Some(b) = clamped_beam(sc) else { return Ok(None) };
    let dim = sc.file.solid.dimension;
    let first_period_theory = 1.0 / b.theory.first_frequency();
    let tip_probe = sc.file.probes.iter().find(|p| (0..dim).all(|a| p.min[a] <= b.tip[a] && b.tip[a] <= p.max[a])).map(|p| p.name.clone());
    let deflection_theory = b.load.map(|f| (f, b.theory.static_deflection(f)));
    let mut report = BeamReport {
        theory: b.theory,
        root_x: b.root_x,
        first_period_theory,
        tip_probe: tip_probe.clone(),
        vibration: None,
        tip_load: deflection_theory.map(|(load, d)| TipLoad {
            load,
            deflection_theory: d,
            deflection_end: None,
            error_vs_theory: None,
            last_period_swing: None,
        }),
    };
    let Some(probe) = tip_probe else { return Ok(Some(report)) };
    let text = std::fs::read_to_string(solid_csv).with_context(|| format!("reading {}", solid_csv.display()))?;
    let columns = Columns::parse(&text).with_context(|| format!("{}", solid_csv.display()))?;
    let time = columns.get("time")?;
    let whole = columns.get(&format!("{probe}_uy"))?;
    let mut uy = whole.clone();
    let n = time.len();
    if n < 2 {
        return Ok(Some(report));
    }
    let end = uy[n - 1];
    let (t_end, dt) = (time[n - 1], time[1] - time[0]);
    // the run's last row is written at its end, which may fall between two output periods: left
    // out of the (evenly sampled) vibration when its interval is not the others'
    if n >= 3 && ((time[n - 1] - time[n - 2]) / dt - 1.0).abs() > 1e-3 {
        uy.pop();
    }
    report.vibration = match report.tip_load {
        // free: the swing about its mean
        None => oscillation(&uy, dt).map(|o| (o.frequency.recip(), o.cycles)),
        // under a load the tip swings about where it settles, and a damped swing crosses that
        // level at its true period where it would cross its (transient-biased) mean early or
        // late: the crossings of the end deflection, while the swing is above 1 % of it (the
        // solve's residual decides the crossings below)
        Some(_) => {
            let live = uy.iter().rposition(|u| (u - end).abs() > 0.01 * end.abs()).map_or(0, |k| k + 1);
            let up = upward_crossings(&uy[..live], end, dt);
            (up.len() >= 3).then(|| ((up[up.len() - 1] - up[0]) / (up.len() - 1) as f64, up.len() - 1))
        }
    }
    .map(|(period, cycles)| BeamVibration { period, cycles, error_vs_theory: period / first_period_theory - 1.0 });
    if let Some(l) = &mut report.tip_load {
        l.deflection_end = Some(end);
        l.error_vs_theory = Some(end / l.deflection_theory - 1.0);
        // the last theoretical period, when the run is at least that long
        if t_end - time[0] >= first_period_theory {
            let last: Vec<f64> = time.iter().zip(&whole).filter(|(t, _)| **t >= t_end - first_period_theory).map(|(_, u)| *u).collect();
            let (hi, lo) = last.iter().fold((f64::MIN, f64::MAX), |(h, l), &u| (h.max(u), l.min(u)));
            l.last_period_swing = Some((hi - lo) / l.deflection_theory.abs());
        }
    }
    Ok(Some(report))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(name: &str) -> SolidScene {
        SolidScene::parse(crate::scene::builtin(name).expect("built in")).expect("parses")
    }

    fn write_csv(tag: &str, rows: impl Iterator<Item = (f64, f64)>) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("phonation_beam_{tag}_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut csv = String::from("step,time,tip_ux,tip_uy,tip_uz\n");
        for (k, (t, u)) in rows.enumerate() {
            csv.push_str(&format!("{k},{t:.12e},0,{u:.12e},0\n"));
        }
        let path = dir.join("solid.csv");
        std::fs::write(&path, csv).unwrap();
        path
    }

    /// The cantilever scene (L = 10, h = 1, plane strain, 27.24 per unit depth down at the tip)
    /// with a solid.csv written by hand: a tip that settles to 1.02× beam theory's deflection by
    /// a swing of period 0.19 s damped over 0.3 s, its last row off the output period. The report
    /// takes the beam from the scene (1.0·10⁻² cm, 0.1867 s), the period from the swing, the
    /// deflection from the last row, and the swing of the last period within its envelope.
    #[test]
    fn the_beam_report_reads_the_cantilevers_period_and_settled_deflection() {
        let sc = scene("cantilever");
        let (period, tau, dt) = (0.19, 0.3, 0.025);
        let settled = -1.02e-2;
        let u = |t: f64| settled * (1.0 - (-t / tau).exp() * (std::f64::consts::TAU * t / period).cos());
        let times = (0..120).map(|k| k as f64 * dt).chain([119.4 * dt]);
        let path = write_csv("cantilever", times.map(|t| (t, u(t))));
        let r = beam_report(&sc, &path).unwrap().expect("a clamped beam under a tip load");
        std::fs::remove_dir_all(path.parent().unwrap()).ok();
        assert_eq!((r.theory.dim, r.theory.length, r.theory.thickness, r.root_x), (2, 10.0, 1.0, 0.0));
        assert!((r.first_period_theory - 0.18674).abs() < 1e-4, "{}", r.first_period_theory);
        assert_eq!(r.tip_probe.as_deref(), Some("tip"));
        let v = r.vibration.expect("≥ 2 cycles");
        // the swing falls below 1 % of the deflection after τ ln 100 = 1.38 s: seven cycles
        assert!(v.cycles >= 5 && (v.period / period - 1.0).abs() < 2e-3, "{v:?}");
        assert!((v.error_vs_theory - (v.period / r.first_period_theory - 1.0)).abs() < 1e-12);
        let l = r.tip_load.expect("a tip load");
        assert!((l.load + 27.24).abs() < 1e-12 && (l.deflection_theory + 1.0e-2).abs() < 1e-6, "{l:?}");
        let end = l.deflection_end.unwrap();
        assert!((end / u(119.4 * dt) - 1.0).abs() < 1e-10, "the last row is the end: {end}");
        assert!((l.error_vs_theory.unwrap() - (end / l.deflection_theory - 1.0)).abs() < 1e-12);
        assert!((l.error_vs_theory.unwrap() - 0.02).abs() < 1e-4, "{l:?}");
        // over the last 0.187 s the swing's envelope is 2 |settled| e^{−(t − T₁)/τ} at most
        let envelope = 2.0 * 1.02 * (-(119.4 * dt - r.first_period_theory) / tau).exp();
        let swing = l.last_period_swing.unwrap();
        assert!(swing > 0.0 && swing < envelope, "{swing} against {envelope}");
    }

    /// The oscillating plate has a period and no load; scenes that are not one clamped beam have
    /// no report; a beam whose tip no probe holds is reported with nothing measured, and a
    /// load that is not transverse makes it no beam-theory case.
    #[test]
    fn only_a_clamped_beam_has_a_beam_report() {
        let plate = scene("oscillating_plate");
        let path = write_csv("plate", (0..400).map(|k| (k as f64 * 0.01, 1e-3 * (std::f64::consts::TAU * k as f64 * 0.01 / 0.26).sin())));
        let r = beam_report(&plate, &path).unwrap().expect("the plate is a clamped beam");
        std::fs::remove_dir_all(path.parent().unwrap()).ok();
        assert!(r.tip_load.is_none() && (r.first_period_theory - 0.254).abs() < 5e-4, "{r:?}");
        assert!((r.vibration.expect("15 cycles").period / 0.26 - 1.0).abs() < 1e-3);
        for other in ["two_blocks", "orthotropic_block"] {
            assert!(beam_report(&scene(other), Path::new("/nonexistent/solid.csv")).unwrap().is_none(), "{other}");
        }
        let text = crate::scene::builtin("cantilever").unwrap();
        let mid = text.replace("name = \"tip\"\nmin = [9.9, 0.0]\nmax = [10.0, 1.0]", "name = \"mid\"\nmin = [4.9, 0.0]\nmax = [5.0, 1.0]");
        assert_ne!(mid, text);
        let no_probe = SolidScene::parse(&mid).unwrap();
        let r = beam_report(&no_probe, Path::new("/nonexistent/solid.csv")).unwrap().expect("still a beam");
        assert!(r.tip_probe.is_none() && r.vibration.is_none() && r.tip_load.unwrap().deflection_end.is_none());
        let axial = SolidScene::parse(&text.replace("total_force = [0.0, -27.24]", "total_force = [5.0, -27.24]")).unwrap();
        assert!(beam_report(&axial, Path::new("/nonexistent/solid.csv")).unwrap().is_none());
    }
}
