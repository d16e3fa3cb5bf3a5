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

/// The seed's case list as it is written (body 1·10⁵ dyn/cm², cover 10·10⁵ for A and 100·10⁵
/// for C: the layers swapped against its narrative, [`BodyCoverCase`]) on `glottis_2d_coarse`,
/// 20 ms from rest, A and C side by side, in `out/validate/glottis_seed_layer_list_{a,c}/`: does
/// the list as written give the seed's f0? Measured (2026-12-03, 1729 s on 2 cores): no — the
/// soft body lets the lung pressure blow the glottis open (case A: area 0.785 cm², a gap of
/// 0.56 cm of the fold's 0.77 cm width, 5,240 cm³/s; case C: 0.395 cm², 880 cm³/s, a first cycle
/// of ≈ 17 ms). Rows: each case's largest glottal area against ten times the rest gap's
/// (G = 0.021 cm over the 1.4 cm length) and its peak flow against the largest of the narrative
/// reading's cases (case A, 228 cm³/s).
pub fn seed_layer_list_rows() -> Vec<(String, f64, String, bool)> {
    use rayon::prelude::*;
    let cases = [("A", 10.0e5), ("C", 100.0e5)];
    let reports: Vec<anyhow::Result<CoupledReport>> = cases
        .par_iter()
        .with_max_len(1)
        .map(|&(name, cover)| {
            let text = crate::run::sweep::set_key(crate::scene::builtin("glottis_2d_coarse").expect("built in"), "run.duration", 0.02)?;
            let mut sc = CoupledScene::parse(&text)?;
            sc.set_fold_moduli(cover, 1.0e5);
            let dir = PathBuf::from(format!("out/validate/glottis_seed_layer_list_{}", name.to_lowercase()));
            run_coupled_scene(&sc, &dir, &crate::run::RunOptions { show_progress: false, ..Default::default() })
        })
        .collect();
    const REST_GAP: f64 = 0.021;
    const LENGTH: f64 = 1.4;
    const NARRATIVE_PEAK_FLOW: f64 = 228.0;
    let mut out = Vec::new();
    for ((name, cover), r) in cases.iter().zip(reports) {
        let label = format!("case {name} as listed (body 1e5, cover {cover:.0e} dyn/cm²)");
        let r = match r {
            Ok(r) => r,
            Err(e) => {
                out.push((format!("{label}: {e}"), f64::NAN, "runs".into(), false));
                continue;
            }
        };
        let g = r.glottis.clone().expect("a glottis scene");
        out.push((
            format!("{label}: stable 20 ms (fluid mass drift)"),
            r.fluid_mass_drift,
            r.instability.clone().unwrap_or_else(|| "finite".into()),
            r.instability.is_none(),
        ));
        let open = 10.0 * REST_GAP * LENGTH;
        out.push((
            format!("{label}: largest glottal area (cm²)"),
            g.max_area,
            format!("> {open:.3} (ten times the rest gap's: blown open)"),
            g.max_area > open,
        ));
        out.push((
            format!("{label}: peak flow (cm³/s)"),
            g.max_flow,
            format!("> {NARRATIVE_PEAK_FLOW} (the narrative reading's largest, case A)"),
            g.max_flow > NARRATIVE_PEAK_FLOW,
        ));
    }
    out
}

/// The resolutions of the speed-against-error study: factors of the seed's 124 × 128 lattice.
pub const STUDY_RESOLUTIONS: [f64; 3] = [0.5, 0.75, 1.0];

/// The Mach scaling of the study's second sweep (that of `glottis_2d_coarse`: the Bernoulli jet
/// √(2·8000/ρ) = 3676 cm/s at lattice Mach 0.3, a time step 2.8× the real air's).
pub const STUDY_MACH: f64 = 0.3;

/// `glottis_2d_c` (case C) with the air's sound speed scaled as `glottis_2d_coarse` scales it
/// (its `numerics.mach_scaling`: the jet's reference velocity) but with the jet at `mach`
/// (`None`: real air, the scene as it is).
pub fn case_c_scene(mach: Option<f64>) -> String {
    let text = crate::scene::builtin("glottis_2d_c").expect("built in");
    let Some(mach) = mach else { return text.to_string() };
    let parse = |name: &str| -> toml::Table { crate::scene::builtin(name).expect("built in").parse().expect("a built-in scene parses") };
    let mut scaling = parse("glottis_2d_coarse")["numerics"]["mach_scaling"].as_table().expect("glottis_2d_coarse is Mach-scaled").clone();
    scaling.insert("mach".into(), toml::Value::Float(mach));
    let mut t = parse("glottis_2d_c");
    t.get_mut("numerics").and_then(|n| n.as_table_mut()).expect("glottis_2d_c has [numerics]").insert("mach_scaling".into(), toml::Value::Table(scaling));
    toml::to_string(&t).expect("a table serialises")
}

/// Case C in real air on the coarse lattice (×0.5 of the seed's, 62 × 64 cells), with the
/// folds' walls isothermal at T₀ (`coupling.wall_temperature_ratio = 1.0`, as the built-in
/// glottis scenes have them since 2026-12-03; set here too, so that the case keeps its meaning
/// whatever the scene file says): 4 ms from rest,
/// through the first closure (≈ 2.2 ms) and the reopening (≈ 3.6 ms), in
/// `out/validate/glottis_real_air_closure/`. With adiabatic walls the same run stops at the
/// closure (step 18,944, 2.16 ms): the dead-end pockets the contact leaves heat and cool until
/// θ leaves the positivity window (README). 5.6–9 min on 2 cores.
pub fn real_air_closure_rows() -> Vec<(String, f64, String, bool)> {
    let report = (|| -> anyhow::Result<CoupledReport> {
        let text = crate::scene::resolution::text_at_resolution(&case_c_scene(None), 0.5)?;
        let mut t: toml::Table = text.parse()?;
        let mut set = |table: &str, key: &str, v: f64| -> anyhow::Result<()> {
            let tbl = t.get_mut(table).and_then(|x| x.as_table_mut()).ok_or_else(|| anyhow::anyhow!("glottis_2d_c has no [{table}]"))?;
            tbl.insert(key.into(), toml::Value::Float(v));
            Ok(())
        };
        set("coupling", "wall_temperature_ratio", 1.0)?;
        set("run", "duration", 0.004)?;
        let sc = CoupledScene::parse(&toml::to_string(&t)?)?;
        let dir = PathBuf::from("out/validate/glottis_real_air_closure");
        run_coupled_scene(&sc, &dir, &crate::run::RunOptions { show_progress: true, ..Default::default() })
    })();
    let r = match report {
        Ok(r) => r,
        Err(e) => return vec![(format!("real air, isothermal folds: {e}"), f64::NAN, "runs".into(), false)],
    };
    let g = r.glottis.clone().expect("a glottis scene");
    let last_flow = std::fs::read_to_string("out/validate/glottis_real_air_closure/glottal_flow.csv")
        .ok()
        .and_then(|csv| csv.lines().last().and_then(|l| l.split(',').nth(1)).and_then(|v| v.parse::<f64>().ok()))
        .unwrap_or(f64::NAN);
    vec![
        (
            "case C, real air, ×0.5, isothermal folds: simulated s, stable".into(),
            r.simulated_s,
            r.instability.clone().unwrap_or_else(|| "≥ 0.004 s, finite".into()),
            r.instability.is_none() && r.simulated_s >= 0.004 * (1.0 - 1e-9),
        ),
        ("  no air through the glottis (fraction of samples)".into(), g.no_flow_fraction, "≥ 0.2 (it closed)".into(), g.no_flow_fraction >= 0.2),
        ("  flow at 4 ms (cm³/s)".into(), last_flow, "> 1 (it opened again)".into(), last_flow > 1.0),
    ]
}

/// One point of the study.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StudyPoint {
    pub air: String,
    pub resolution: f64,
    pub f0_hz: Option<f64>,
    pub wall_s_per_simulated_ms: Option<f64>,
    pub f0_vs_finest: Option<f64>,
}

/// Case C's f0 against the lattice resolution and the Mach scaling, with each run's cost: two
/// sweeps (`phonation sweep --key resolution`) over [`STUDY_RESOLUTIONS`] of `glottis_2d_c`,
/// real air and Mach-scaled ([`STUDY_MACH`]), 40 ms each from rest, in
/// `out/validate/glottis_speed_error/{real_air,mach_0.3}/`, and the speed-against-error table
/// and plot (`speed_error.csv`, `speed_error.svg`) beside them. Hours on a CPU: the real air at
/// the seed's lattice is ≈ 1.6 h on 2 cores (2026-12-05; ≈ 4.3 h on the AMD machine of 2026-11-30).
pub fn speed_error_study(root: &std::path::Path) -> anyhow::Result<Vec<StudyPoint>> {
    use crate::run::sweep;
    let mut points = Vec::new();
    for (air, mach) in [("real_air", None), ("mach_0.3", Some(STUDY_MACH))] {
        let dir = root.join(air);
        let m = sweep::prepare(&dir, &case_c_scene(mach), "glottis_2d_c", crate::scene::resolution::KEY, &STUDY_RESOLUTIONS)?;
        // one job at a time (not `sweep::run_local`'s parallel jobs), so that each run's wall
        // time is its own cost; a job that goes unstable keeps its outputs, its point has no f0
        for j in &m.jobs {
            eprintln!("glottis_speed_error: {air} ×{} → {}", j.value, dir.join(&j.out).display());
            if let Err(e) = sweep::run_job(&dir, j) {
                eprintln!("glottis_speed_error: {air} ×{}: {e:#}", j.value);
            }
        }
        let (rows, _) = sweep::collect(&dir)?;
        points.extend(rows.iter().map(|r| StudyPoint {
            air: air.into(),
            resolution: r.value,
            f0_hz: r.f0_hz.filter(|_| r.stable),
            wall_s_per_simulated_ms: r.wall_s_per_simulated_ms.filter(|_| r.stable),
            f0_vs_finest: r.f0_vs_finest.filter(|_| r.stable),
        }));
    }
    write_study(root, &points)?;
    Ok(points)
}

/// `speed_error.csv` and `speed_error.svg`: f0 against the wall time per simulated ms, one line
/// per air model, the seed's 145 Hz ± 20 % as a band.
pub fn write_study(root: &std::path::Path, points: &[StudyPoint]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let fmt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6e}"));
    let mut csv = String::from("air,resolution,f0_hz,f0_vs_finest,wall_s_per_simulated_ms\n");
    for p in points {
        csv += &format!("{},{},{},{},{}\n", p.air, p.resolution, fmt(p.f0_hz), fmt(p.f0_vs_finest), fmt(p.wall_s_per_simulated_ms));
    }
    std::fs::create_dir_all(root)?;
    std::fs::write(root.join("speed_error.csv"), csv)?;
    let pts = |air: &str| -> Vec<(f64, f64, f64)> {
        points.iter().filter(|p| p.air == air).filter_map(|p| Some((p.wall_s_per_simulated_ms?, p.f0_hz?, p.resolution))).collect()
    };
    let all: Vec<(f64, f64, f64)> = points.iter().filter_map(|p| Some((p.wall_s_per_simulated_ms?, p.f0_hz?, p.resolution))).collect();
    let (x0, x1) = all.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (x0, x1) = if all.is_empty() { (0.1, 1000.0) } else { (x0 / 2.0, (x1 * 2.0).max(x0)) };
    let hi = all.iter().fold(200.0f64, |m, p| m.max(p.1)) * 1.1;
    let seed = BodyCoverCase::C.seed_f0();
    let path = root.join("speed_error.svg");
    let area = SVGBackend::new(&path, (800, 520)).into_drawing_area();
    area.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&area)
        .caption("glottis_2d_c: f0 against cost (resolution ×0.5, ×0.75, ×1 of the seed's lattice)", ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((x0..x1).log_scale(), 0.0..hi)?;
    chart.configure_mesh().x_desc("wall s per simulated ms (this machine)").y_desc("f0 (Hz)").draw()?;
    chart
        .draw_series(std::iter::once(Rectangle::new([(x0, 0.8 * seed), (x1, 1.2 * seed)], RGBColor(200, 230, 200).filled())))?
        .label(format!("seed {seed} Hz ± 20 %"));
    for (air, colour) in [("real_air", BLUE), ("mach_0.3", RED)] {
        let p = pts(air);
        chart
            .draw_series(LineSeries::new(p.iter().map(|q| (q.0, q.1)), colour.stroke_width(2)))?
            .label(air)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour));
        chart.draw_series(p.iter().map(|q| Circle::new((q.0, q.1), 4, colour.filled())))?;
        chart.draw_series(p.iter().map(|q| Text::new(format!("×{}", q.2), (q.0, q.1 + 0.03 * hi), ("sans-serif", 13))))?;
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    area.present()?;
    Ok(())
}

/// The suite's rows of the study: each run's f0 and cost, the finest real-air f0 against the
/// seed (±20 %), f0 converging with resolution (the ×0.75 run closer to the finest than the ×0.5
/// one) for each air model, and the Mach scaling's f0 change at the seed's lattice (≤ 10 %:
/// what makes the scaled air usable for case C; stated as the acceptance, not measured yet).
pub fn speed_error_rows() -> Vec<(String, f64, String, bool)> {
    let root = PathBuf::from("out/validate/glottis_speed_error");
    let points = match speed_error_study(&root) {
        Ok(p) => p,
        Err(e) => return vec![(format!("glottis_speed_error: {e:#}"), f64::NAN, "runs".into(), false)],
    };
    study_rows(&points)
}

/// [`speed_error_rows`] from the study's points.
pub fn study_rows(points: &[StudyPoint]) -> Vec<(String, f64, String, bool)> {
    let mut out = Vec::new();
    let get = |air: &str, r: f64| points.iter().find(|p| p.air == air && p.resolution == r);
    let f0 = |air: &str, r: f64| get(air, r).and_then(|p| p.f0_hz).unwrap_or(f64::NAN);
    for p in points {
        let cost = p.wall_s_per_simulated_ms.unwrap_or(f64::NAN);
        out.push((format!("{} ×{}: wall s per simulated ms", p.air, p.resolution), cost, "finished (summary.json)".into(), cost.is_finite()));
        let hz = p.f0_hz.unwrap_or(f64::NAN);
        out.push((format!("{} ×{}: f0 (Hz)", p.air, p.resolution), hz, "an f0 (the folds vibrate)".into(), hz.is_finite()));
    }
    let seed = BodyCoverCase::C.seed_f0();
    let finest = f0("real_air", 1.0);
    out.push(("real air ×1: f0 (Hz) against the seed".into(), finest, format!("seed {seed} ± 20 %"), (finest / seed - 1.0).abs() <= 0.2));
    for air in ["real_air", "mach_0.3"] {
        let (a, b, c) = (f0(air, 0.5), f0(air, 0.75), f0(air, 1.0));
        let closer = (b - c).abs() < (a - c).abs();
        out.push((format!("{air}: |f0(×0.75) − f0(×1)| / |f0(×0.5) − f0(×1)|"), (b - c).abs() / (a - c).abs(), "< 1 (converging)".into(), closer));
    }
    let change = f0("mach_0.3", 1.0) / finest - 1.0;
    out.push(("Mach 0.3 scaling: f0 change at ×1".into(), change, "|·| ≤ 0.1".into(), change.abs() <= 0.1));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The study's Mach-scaled scene is case C with the coarse scene's scaling: the time step
    /// 2.8× the real air's at the same lattice (the real jet runs at lattice Mach 0.107).
    #[test]
    fn the_mach_scaled_case_c_takes_longer_steps_on_the_same_lattice() {
        let real = CoupledScene::parse(&case_c_scene(None)).unwrap();
        let scaled = CoupledScene::parse(&case_c_scene(Some(STUDY_MACH))).unwrap();
        assert_eq!(real.fluid.grid.n, scaled.fluid.grid.n);
        let dt = |sc: &CoupledScene| sc.fluid.units.time_to_physical(sc.fluid.params.dt);
        let ratio = dt(&scaled) / dt(&real);
        assert!((ratio - 2.8).abs() < 0.05, "Δt ratio {ratio}");
    }

    #[test]
    fn the_study_rows_read_convergence_and_the_seed_from_the_points() {
        let p = |air: &str, resolution: f64, f0: f64| StudyPoint {
            air: air.into(),
            resolution,
            f0_hz: Some(f0),
            wall_s_per_simulated_ms: Some(10.0 * resolution.powi(3)),
            f0_vs_finest: None,
        };
        let points = [
            p("real_air", 0.5, 360.0),
            p("real_air", 0.75, 200.0),
            p("real_air", 1.0, 150.0),
            p("mach_0.3", 0.5, 360.0),
            p("mach_0.3", 0.75, 120.0),
            p("mach_0.3", 1.0, 160.0),
        ];
        let rows = study_rows(&points);
        let row = |name: &str| rows.iter().find(|r| r.0.starts_with(name)).unwrap_or_else(|| panic!("{name}: {rows:?}"));
        assert!(row("real air ×1: f0 (Hz) against the seed").3);
        let conv = row("real_air: |f0(×0.75)");
        assert!(conv.3 && (conv.1 - 50.0 / 210.0).abs() < 1e-12);
        assert!(row("mach_0.3: |f0(×0.75)").3, "40 < 200");
        let mach = row("Mach 0.3 scaling");
        assert!((mach.1 - (160.0 / 150.0 - 1.0)).abs() < 1e-12 && mach.3);
        // a point without an f0 fails its row and the rows that need it
        let mut missing = points.clone();
        missing[2].f0_hz = None;
        let rows = study_rows(&missing);
        assert!(rows.iter().filter(|r| !r.3).count() >= 4, "{rows:?}");
        let dir = std::env::temp_dir().join(format!("phonation-study-{}", std::process::id()));
        write_study(&dir, &points).unwrap();
        let csv = std::fs::read_to_string(dir.join("speed_error.csv")).unwrap();
        assert_eq!(csv.lines().count(), 7);
        assert!(std::fs::read_to_string(dir.join("speed_error.svg")).unwrap().contains("<svg"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
