//! What a coupled run of the Schäfer–Turek 2D-1 channel reports against the benchmark
//! (Schäfer & Turek 1996; ../shared/reference): the drag coefficient C_D = 2F_x/(ρŪ²D) of the
//! clamped elastic cylinder, averaged over the last quarter of the run's `coupling.csv` rows (the
//! channel rings: the force swings by a few per cent from row to row at the built-in's 1 s), and
//! the pressure drop Δp = p(0.15, 0.2) − p(0.25, 0.2) across it in the state the run ends in —
//! the error the built-in `fsi_cylinder` and
//! `fsi_cylinder_conserving` read their speed against. Any length scale: the channel
//! 2.2 × 0.41, the cylinder D = 0.1 at (0.2, 0.2) in units of a common factor, Re = ŪD/ν = 20.

use super::columns::Columns;
use crate::coupling::CoupledSolver;
use crate::scene::coupled::CoupledScene;
use crate::scene::schema::FaceSpec;
use anyhow::Context;
use serde::Serialize;
use std::path::Path;

/// The benchmark's values (FEATFLOW, high resolution): C_D, and Δp in Pa for ρ = 1 kg/m³ and
/// Ū = 0.2 m/s (Δp / ρŪ² = 2.938).
pub const DRAG_COEFFICIENT: f64 = 5.57953523384;
pub const PRESSURE_DROP: f64 = 0.11752016697;
const PRESSURE_DROP_UNIT: f64 = 1.0 * 0.2 * 0.2;

/// A run of the 2D-1 channel against the benchmark (the scene's units).
#[derive(Clone, Debug, Serialize)]
pub struct SchaferTurekReport {
    /// Ū D ρ / μ, Ū = ⅔ U_max.
    pub reynolds: f64,
    /// The forces are averaged over [from, to], the run's last quarter (s); Δp is read at its
    /// end: the benchmark's values are steady.
    pub averaged_from_s: f64,
    pub at_time_s: f64,
    /// Rows of `coupling.csv` averaged.
    pub rows_averaged: usize,
    pub drag_coefficient: f64,
    /// C_D / 5.5795 − 1.
    pub drag_error: f64,
    pub lift_coefficient: f64,
    /// Δp between the cylinder's front and back points (pressure) and the benchmark's at this
    /// ρŪ².
    pub pressure_drop: f64,
    pub pressure_drop_reference: f64,
    /// Δp / reference − 1.
    pub pressure_drop_error: f64,
}

/// The channel's length scale (the factor on the benchmark's metres), its mean inflow speed Ū
/// and the Reynolds number, when `sc` is the 2D-1 geometry with one disc and a parabolic inlet.
fn channel(sc: &CoupledScene) -> Option<(f64, f64, f64)> {
    let (f, s) = (&sc.fluid.file, &sc.solid.file.solid);
    let [lx, ly] = f.domain.size.as_slice() else { return None };
    let scale = lx / 2.2;
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-9 * scale;
    let [body] = s.bodies.as_slice() else { return None };
    let (Some(radius), [cx, cy]) = (body.radius, body.center.as_slice()) else { return None };
    let geometry = near(*ly, 0.41 * scale) && near(radius, 0.05 * scale) && near(*cx, 0.2 * scale) && near(*cy, 0.2 * scale);
    if !geometry || !f.obstacles.is_empty() {
        return None;
    }
    let FaceSpec::VelocityInlet { velocity, profile, .. } = &f.boundaries.x_min else { return None };
    let u_max = velocity.first().copied().unwrap_or(0.0);
    if *profile != crate::fluid::boundary::InletProfile::Parabolic || velocity.get(1).is_some_and(|&v| v != 0.0) || u_max <= 0.0 {
        return None;
    }
    let walls = [&f.boundaries.y_min, &f.boundaries.y_max].iter().all(|w| matches!(w, FaceSpec::Wall { velocity, .. } if velocity.iter().all(|&v| v == 0.0)));
    let u_mean = 2.0 / 3.0 * u_max;
    let reynolds = u_mean * 0.1 * scale * f.gas.density / f.gas.viscosity;
    (walls && (reynolds / 20.0 - 1.0).abs() <= 0.01).then_some((scale, u_mean, reynolds))
}

/// The benchmark report of a run of `sc` that ended in the state `c` and wrote its forces to
/// `coupling_csv`; `None` for a scene that is not the 2D-1 channel at Re = 20 or a run with no
/// row after its start.
pub fn schafer_turek_report(sc: &CoupledScene, c: &CoupledSolver, coupling_csv: &Path) -> anyhow::Result<Option<SchaferTurekReport>> {
    let Some((scale, u_mean, reynolds)) = channel(sc) else { return Ok(None) };
    let text = std::fs::read_to_string(coupling_csv).with_context(|| format!("reading {}", coupling_csv.display()))?;
    let columns = Columns::parse(&text).with_context(|| format!("{}", coupling_csv.display()))?;
    let (time, fx, fy) = (columns.get("time_s")?, columns.get("force_x_0")?, columns.get("force_y_0")?);
    // the rows after the start (the first is the state before any step, with no force yet)
    let t_end = time.last().copied().unwrap_or(0.0);
    let from = 0.75 * t_end;
    let window: Vec<usize> = (1..time.len()).filter(|&k| time[k] >= from).collect();
    if window.is_empty() || t_end <= 0.0 {
        return Ok(None);
    }
    let mean = |v: &[f64]| window.iter().map(|&k| v[k]).sum::<f64>() / window.len() as f64;
    let rho = sc.fluid.file.gas.density;
    let dynamic = rho * u_mean * u_mean;
    let coefficient = 2.0 / (dynamic * 0.1 * scale);
    let u = &c.units;
    let p = |x: f64| {
        let at = [u.position_to_lattice(x * scale), u.position_to_lattice(0.2 * scale), 0.0];
        c.fluid.sample(at).map(|m| u.gauge_pressure_to_physical(m.pressure())).unwrap_or(f64::NAN)
    };
    let pressure_drop = p(0.15) - p(0.25);
    let pressure_drop_reference = PRESSURE_DROP / PRESSURE_DROP_UNIT * dynamic;
    let drag_coefficient = mean(&fx) * coefficient;
    Ok(Some(SchaferTurekReport {
        reynolds,
        averaged_from_s: time[window[0]],
        at_time_s: c.time,
        rows_averaged: window.len(),
        drag_coefficient,
        drag_error: drag_coefficient / DRAG_COEFFICIENT - 1.0,
        lift_coefficient: mean(&fy) * coefficient,
        pressure_drop,
        pressure_drop_reference,
        pressure_drop_error: pressure_drop / pressure_drop_reference - 1.0,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(text: &str) -> CoupledScene {
        CoupledScene::parse(text).expect("parses")
    }

    /// A coupling.csv written by hand: the state before the first step (no force), then a drag
    /// that rings about 0.011 N/m by ±3 % over 1 s, sampled every 10 ms, and a lift about 3·10⁻⁴.
    fn forces_csv(tag: &str, drag: f64) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("phonation_st_{tag}_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut csv = String::from("step,time_s,force_x_0,force_y_0\n0,0,0,0\n");
        for k in 1..=100 {
            let t = k as f64 * 0.01;
            // two whole periods of the ringing in the last quarter (25 rows, 80 ms each way)
            let ring = 0.03 * (std::f64::consts::TAU * t / 0.125).sin();
            csv.push_str(&format!("{k},{t},{},{}\n", drag * (1.0 + ring), 3e-4));
        }
        let path = dir.join("coupling.csv");
        std::fs::write(&path, csv).unwrap();
        path
    }

    /// The fsi_cylinder scene is the 2D-1 channel at Re = 20, and so is the same scene twice as
    /// large with twice the viscosity; a drag ringing about 0.011 N/m on it averages over the last
    /// quarter to C_D = 2F/(ρŪ²D) = 5.5 (−1.43 % against 5.5795), and its state at rest in a
    /// uniform stream has no pressure drop (error −1); at twice the size the same C_D is twice
    /// the force per unit depth. Another disc radius, an obstacle, or another Re is not the
    /// benchmark, and a run with no row after its start has no report.
    #[test]
    fn the_schafer_turek_report_reads_drag_and_pressure_drop_on_the_benchmarks_channel() {
        let text = crate::scene::builtin("fsi_cylinder").expect("built in");
        let sc = scene(text);
        let c = sc.build().expect("builds");
        let path = forces_csv("base", 0.011);
        let r = schafer_turek_report(&sc, &c, &path).unwrap().expect("the 2D-1 channel");
        assert!((r.reynolds - 20.0).abs() < 1e-9, "{}", r.reynolds);
        assert_eq!((r.rows_averaged, r.averaged_from_s), (26, 0.75));
        // 26 rows: the ringing's two periods (25 rows) average out, the 26th adds its sample
        let ring_26th = 0.03 * (std::f64::consts::TAU * 0.75 / 0.125).sin() / 26.0;
        assert!((r.drag_coefficient - 5.5 * (1.0 + ring_26th)).abs() < 1e-9 && (r.lift_coefficient - 0.15).abs() < 1e-12, "{r:?}");
        assert!((r.drag_error - (r.drag_coefficient / 5.57953523384 - 1.0)).abs() < 1e-12);
        assert!((r.pressure_drop_reference - 0.11752016697).abs() < 1e-12, "{r:?}");
        assert!(r.pressure_drop.abs() < 1e-9 && (r.pressure_drop_error + 1.0).abs() < 1e-6, "{r:?}");
        let twice = text
            .replace("size = [2.2, 0.41]", "size = [4.4, 0.82]")
            .replace("viscosity = 1.0e-3 ", "viscosity = 2.0e-3 ")
            .replace("spacing = 0.005 ", "spacing = 0.01 ")
            .replace("bodies = [{ center = [0.2, 0.2], radius = 0.05 }]", "bodies = [{ center = [0.4, 0.4], radius = 0.1 }]")
            .replace("clamps = [{ min = [0.175, 0.175], max = [0.225, 0.225] }]", "clamps = [{ min = [0.35, 0.35], max = [0.45, 0.45] }]")
            .replace("position = [0.35, 0.21]", "position = [0.7, 0.42]");
        let big = scene(&twice);
        let path2 = forces_csv("twice", 0.022);
        let r2 = schafer_turek_report(&big, &big.build().unwrap(), &path2).unwrap().expect("the benchmark at twice the size");
        assert!((r2.reynolds - 20.0).abs() < 1e-9 && (r2.drag_coefficient - r.drag_coefficient).abs() < 1e-9, "{r2:?}");
        for (what, other) in [
            ("radius", text.replace("radius = 0.05", "radius = 0.06")),
            ("Re", text.replace("viscosity = 1.0e-3 ", "viscosity = 2.0e-3 ")),
            ("obstacle", text.replace("[initial]", "[[obstacles]]\nshape = \"cylinder\"\ncenter = [1.0, 0.2]\nradius = 0.03\n\n[initial]")),
        ] {
            assert_ne!(other, text, "{what}");
            let o = scene(&other);
            assert!(schafer_turek_report(&o, &o.build().unwrap(), &path).unwrap().is_none(), "{what}");
        }
        std::fs::write(&path2, "step,time_s,force_x_0,force_y_0\n0,0,0,0\n").unwrap();
        assert!(schafer_turek_report(&big, &big.build().unwrap(), &path2).unwrap().is_none(), "no row after the start");
        for p in [path, path2] {
            std::fs::remove_dir_all(p.parent().unwrap()).ok();
        }
    }
}
