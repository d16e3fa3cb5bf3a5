//! What a fluid run with one circular cylinder in a uniform stream reports of its wake: the
//! shedding at each probe downstream of the cylinder over the run's second half ([`crate::analysis::wake`]) as a Strouhal number,
//! against Williamson's (1988) fit at the scene's Reynolds number — the error the main job's
//! speed is read against. Read from `probes.csv` once the run ends, so that a resumed run
//! analyses its whole history.

use super::columns::Columns;
use crate::analysis::wake::{Shedding, shedding, williamson_strouhal};
use crate::scene::FluidScene;
use crate::scene::schema::{FaceSpec, ObstacleSpec};
use anyhow::Context;
use serde::Serialize;
use std::path::Path;

/// The wake of a scene's cylinder (lengths, speeds and times in the scene's units).
#[derive(Clone, Debug, Serialize)]
pub struct WakeReport {
    pub diameter: f64,
    /// The uniform inflow's speed.
    pub inflow_speed: f64,
    /// U D ρ / μ.
    pub reynolds: f64,
    /// The velocity component read at the probes: the in-plane axis across the inflow.
    pub transverse: &'static str,
    /// Williamson's St at this Re (unconfined cylinder), where his fit holds.
    pub williamson_strouhal: Option<f64>,
    /// The samples analysed: from this time (s) on, the run's second half.
    pub from_time_s: f64,
    /// The probes more than a radius downstream of the cylinder's centre, in the scene's order.
    pub probes: Vec<ProbeShedding>,
}

/// One probe's shedding, or why it shows none.
#[derive(Clone, Debug, Serialize)]
pub struct ProbeShedding {
    pub probe: String,
    /// None: fewer than three full cycles in the window.
    pub shedding: Option<Shedding>,
    /// St / Williamson's St − 1.
    pub error_vs_williamson: Option<f64>,
}

/// One circular cylinder (a disc in 2D) in a uniform stream.
struct CylinderInAStream {
    center: [f64; 2],
    diameter: f64,
    /// The stream's velocity in the x–y plane and its speed.
    velocity: [f64; 2],
    speed: f64,
}

impl CylinderInAStream {
    /// The in-plane axis across the stream (the cylinder's axis is z): the wake swings along it.
    fn transverse(&self) -> usize {
        if self.velocity[0].abs() >= self.velocity[1].abs() { 1 } else { 0 }
    }

    /// Whether a probe at `position` lies downstream of the cylinder: more than a radius past
    /// its centre along the stream.
    fn downstream(&self, position: &[f64]) -> bool {
        let along = (0..2).map(|a| (position.get(a).copied().unwrap_or(0.0) - self.center[a]) * self.velocity[a]).sum::<f64>() / self.speed;
        along > 0.5 * self.diameter
    }
}

/// `scene`'s cylinder and stream, when it is one circular cylinder in a uniform velocity
/// inlet's stream.
fn cylinder_in_a_stream(scene: &FluidScene) -> Option<CylinderInAStream> {
    let f = &scene.file;
    let [ObstacleSpec::Cylinder { radius, center }] = f.obstacles.as_slice() else { return None };
    let mut inlets = f.boundaries.named().into_iter().filter_map(|(_, face)| match face {
        Some(FaceSpec::VelocityInlet { velocity, profile, .. }) if *profile == crate::fluid::boundary::InletProfile::Uniform => Some(velocity.as_slice()),
        _ => None,
    });
    let (velocity, None) = (inlets.next()?, inlets.next()) else { return None };
    let component = |v: &[f64], a: usize| v.get(a).copied().unwrap_or(0.0);
    let (ux, uy) = (component(velocity, 0), component(velocity, 1));
    let speed = ux.hypot(uy);
    let center = [component(center, 0), component(center, 1)];
    (speed > 0.0).then_some(CylinderInAStream { center, diameter: 2.0 * radius, velocity: [ux, uy], speed })
}

/// The wake report of a run of `scene` whose probes are in `probes_csv`; `None` for a scene that
/// is not one cylinder in a uniform stream.
pub fn wake_report(scene: &FluidScene, probes_csv: &Path) -> anyhow::Result<Option<WakeReport>> {
    let Some(c) = cylinder_in_a_stream(scene) else { return Ok(None) };
    let (diameter, inflow_speed) = (c.diameter, c.speed);
    let reynolds = inflow_speed * diameter * scene.file.gas.density / scene.file.gas.viscosity;
    let reference = williamson_strouhal(reynolds);
    let component = ["ux", "uy"][c.transverse()];
    let text = std::fs::read_to_string(probes_csv).with_context(|| format!("reading {}", probes_csv.display()))?;
    let columns = Columns::parse(&text).with_context(|| format!("{}", probes_csv.display()))?;
    let time = columns.get("time_s")?;
    let half = time.len() / 2;
    let dt = time.get(half + 1).zip(time.get(half)).map_or(f64::NAN, |(b, a)| b - a);
    // the run's last sample is taken at its end, which may fall between two probe periods: left
    // out when its interval is not the others'
    let n = time.len();
    let end = if n >= half + 3 && ((time[n - 1] - time[n - 2]) / dt - 1.0).abs() > 1e-3 { n - 1 } else { n };
    let mut probes = Vec::new();
    for p in scene.file.probes.iter().filter(|p| c.downstream(&p.position)) {
        let v = columns.get(&format!("{}_{component}", p.name))?;
        let s = shedding(&v[half..end], dt, diameter, inflow_speed);
        let error_vs_williamson = s.as_ref().zip(reference).map(|(s, r)| s.strouhal / r - 1.0);
        probes.push(ProbeShedding { probe: p.name.clone(), shedding: s, error_vs_williamson });
    }
    let from_time_s = time.get(half).copied().unwrap_or(f64::NAN);
    Ok(Some(WakeReport { diameter, inflow_speed, reynolds, transverse: component, williamson_strouhal: reference, from_time_s, probes }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// cylinder_wake's own scene with a probes.csv written by hand: the wake probe swings at
    /// 6.3 Hz after a transient at another frequency, the last sample off the probe period. The
    /// report reads its St from the second half only (6.3 · 1 cm / 15.37 cm/s), Re = 100 from
    /// the scene, Williamson's 0.1643 beside it, and leaves out the probe upstream of the
    /// cylinder.
    #[test]
    fn the_wake_report_reads_the_strouhal_number_of_the_second_half() {
        let scene = crate::scene::load(crate::scene::builtin("cylinder_wake").expect("built in")).expect("parses");
        let dir = std::env::temp_dir().join(format!("phonation_wake_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("probes.csv");
        let mut csv = String::from("step,time_s,wake_pressure,wake_ux,wake_uy,upstream_pressure,upstream_ux,upstream_uy\n");
        let dt = 2e-3;
        // the last sample at the run's end, a third of a probe period after the one before
        let times = (0..1200).map(|k| k as f64 * dt).chain([1199.34 * dt]);
        for (k, t) in times.enumerate() {
            let f = if t < 1.2 { 11.0 } else { 6.3 };
            let wake = 4.0 * (2.0 * std::f64::consts::PI * f * t).sin();
            csv.push_str(&format!("{k},{t},0,15,{wake},0,15,{}\n", 1e-3 * (k % 2) as f64));
        }
        std::fs::write(&path, csv).unwrap();
        let r = wake_report(&scene, &path).unwrap().expect("one cylinder in a uniform stream");
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!((r.diameter, r.inflow_speed, r.transverse), (1.0, 15.37, "uy"));
        assert!((r.reynolds / 100.0 - 1.0).abs() < 1e-3, "{}", r.reynolds);
        let st_ref = r.williamson_strouhal.expect("Re = 100 is in range");
        assert!((st_ref - 0.1643).abs() < 1e-4, "{st_ref}");
        assert!((r.from_time_s - 1.2).abs() < 1e-9, "{}", r.from_time_s);
        let wake = r.probes[0].shedding.as_ref().expect("the wake sheds");
        assert!((wake.frequency / 6.3 - 1.0).abs() < 3e-3, "{wake:?}");
        assert!((wake.strouhal / (6.3 / 15.37) - 1.0).abs() < 3e-3, "{wake:?}");
        let err = r.probes[0].error_vs_williamson.expect("a reference");
        assert!((err - (wake.strouhal / st_ref - 1.0)).abs() < 1e-12);
        assert_eq!(r.probes.iter().map(|p| p.probe.as_str()).collect::<Vec<_>>(), ["wake"], "the upstream probe is not the wake's");
    }

    /// A scene that is not one cylinder in a uniform stream has no wake report; a probes.csv
    /// without the probe's column is an error that names it.
    #[test]
    fn only_one_cylinder_in_a_uniform_stream_has_a_wake_report() {
        let cavity = crate::scene::load(crate::scene::builtin("lid_cavity").expect("built in")).expect("parses");
        assert!(wake_report(&cavity, Path::new("/nonexistent/probes.csv")).unwrap().is_none());
        let scene = crate::scene::load(crate::scene::builtin("cylinder_wake").expect("built in")).expect("parses");
        let dir = std::env::temp_dir().join(format!("phonation_wake_bad_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("probes.csv");
        std::fs::write(&path, "step,time_s,wake_ux\n0,0,1\n1,0.1,1\n").unwrap();
        let e = wake_report(&scene, &path).unwrap_err();
        std::fs::remove_dir_all(&dir).ok();
        assert!(format!("{e:#}").contains("no column wake_uy"), "{e:#}");
    }
}
