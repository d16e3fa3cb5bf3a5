//! The validation suite run by `phonation validate`: which cases a `--case` filter selects, what
//! `--list` prints, and the run of the selected cases into outcomes (figure, measured,
//! reference, pass). The cases themselves are in `cases`. The fast cases are also asserted by
//! `cargo test` (tests/fluid.rs); the slow ones (cavity, cylinder, the coupled Schäfer–Turek and
//! towed-cylinder cases) run only here.

use serde::Serialize;
use std::fmt;
use std::time::Instant;

mod cases;
pub use cases::cases;

#[derive(Clone, Debug, Serialize)]
pub struct Outcome {
    pub case: String,
    pub figure: String,
    pub measured: f64,
    pub reference: String,
    pub pass: bool,
    pub wall_s: f64,
}

impl fmt::Display for Outcome {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        // small figures (differences, offsets) in scientific notation, so that none reads 0.00000
        let m = self.measured;
        let measured = if m != 0.0 && m.abs() < 1e-3 { format!("{m:>12.3e}") } else { format!("{m:>12.5}") };
        write!(
            f,
            "[{}] {:28} {:34} = {measured}  (reference {}; {:.1} s)",
            if self.pass { "pass" } else { "FAIL" },
            self.case,
            self.figure,
            self.reference,
            self.wall_s
        )
    }
}

/// One row of a case: (figure, measured, reference text, pass).
pub type Row = (String, f64, String, bool);

/// One validation case: its name, what it checks against which reference, what it roughly
/// costs, and its runner.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    /// What `--case` names it by.
    pub name: &'static str,
    /// What the case measures and against which reference, with its bounds.
    pub checks: &'static str,
    /// Its wall time, measured (or, where it says so, estimated) on the 2-core development
    /// machine of the README's figures: the release build, nothing else running unless stated.
    pub cost: &'static str,
    /// Runs the case: its rows.
    pub run: fn() -> Vec<Row>,
}

/// Which cases `filter` names: the one case called exactly that, else every case whose name
/// contains it (`glottis_2d` is one case, `glottis` all of them; none: every case).
pub fn selects(names: &[&str], filter: Option<&str>, name: &str) -> bool {
    match filter {
        None => true,
        Some(p) if names.contains(&p) => name == p,
        Some(p) => name.contains(p),
    }
}

/// A `--case` filter that selects no case: the error lists every case's name.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("--case: '{filter}' names no validation case (a case's name or part of it: {})", .names.join(", "))]
pub struct NoSuchCase {
    pub filter: String,
    pub names: Vec<&'static str>,
}

/// The cases `filter` selects ([`selects`]), in the suite's order; a filter that selects none
/// is refused, the error listing every case.
pub fn select(filter: Option<&str>) -> Result<Vec<Case>, NoSuchCase> {
    let all = cases();
    let names: Vec<&'static str> = all.iter().map(|c| c.name).collect();
    let picked: Vec<Case> = all.iter().copied().filter(|c| selects(&names, filter, c.name)).collect();
    match filter {
        Some(f) if picked.is_empty() => Err(NoSuchCase { filter: f.to_string(), names }),
        _ => Ok(picked),
    }
}

/// What `phonation validate --list` prints for `cases`: each case's name and cost on one line,
/// what it checks on the next.
pub fn listing(cases: &[Case]) -> String {
    let width = cases.iter().map(|c| c.name.chars().count()).max().unwrap_or(0);
    let mut out = String::new();
    for c in cases {
        out.push_str(&format!("{:width$}  {}\n{:width$}  {}\n", c.name, c.cost, "", c.checks));
    }
    out
}

/// Runs the cases `filter` selects ([`select`]); a filter that selects none is refused before
/// anything runs.
pub fn run(filter: Option<&str>) -> Result<Vec<Outcome>, NoSuchCase> {
    let mut out = Vec::new();
    for Case { name, run, .. } in select(filter)? {
        let t = Instant::now();
        let rows = run();
        let wall = t.elapsed().as_secs_f64();
        for (figure, measured, reference, pass) in rows {
            out.push(Outcome { case: name.to_string(), figure, measured, reference, pass, wall_s: wall });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A case's exact name runs that case alone (`glottis_2d` is not also
    /// `glottis_speed_error`, hours apart); part of a name runs every case that contains it.
    #[test]
    fn a_case_named_exactly_runs_alone_and_a_part_selects_all_that_contain_it() {
        let all = cases();
        let names: Vec<&str> = all.iter().map(|c| c.name).collect();
        let picked = |f: Option<&str>| -> Vec<&str> { names.iter().copied().filter(|n| selects(&names, f, n)).collect() };
        assert_eq!(picked(Some("glottis_2d")), ["glottis_2d"]);
        assert_eq!(
            picked(Some("glottis")),
            [
                "glottis_2d",
                "glottis_real_air_closure",
                "glottis_3d_coarse",
                "glottis_seed_layer_list",
                "glottis_fold_modes",
                "glottis_air_work",
                "glottis_self_oscillation",
                "glottis_stiffness_ratio",
                "glottis_speed_error"
            ]
        );
        assert_eq!(picked(Some("taylor_green")), ["taylor_green_2d", "taylor_green_3d"]);
        // the D = 20 channel (minutes) is not also the D = 40 one (an hour on 2 cores)
        assert_eq!(picked(Some("fsi_schafer_turek_2d1")), ["fsi_schafer_turek_2d1"]);
        assert_eq!(
            picked(Some("schafer_turek")),
            [
                "fsi_schafer_turek_2d1",
                "fsi_schafer_turek_2d1_d40",
                "fsi_schafer_turek_2d1_d30_air_at_rho0",
                "fsi_schafer_turek_2d1_d30_air_at_rho0_10s",
                "fsi_schafer_turek_2d1_d30_air_at_rho0_weak",
                "fsi_schafer_turek_2d1_d30_air_at_rho0_weak_10s",
                "fsi_schafer_turek_2d1_outlet_level"
            ]
        );
        assert!(picked(Some("fsi_")).len() >= 8);
        assert_eq!(picked(None).len(), names.len());
        assert!(picked(Some("no_such_case")).is_empty());
        // …and `run` refuses it before running anything, listing the cases.
        let e = run(Some("no_such_case")).unwrap_err();
        assert_eq!(e.names, names);
        let msg = e.to_string();
        assert!(msg.starts_with("--case: 'no_such_case' names no validation case"), "{msg}");
        assert!(msg.contains("glottis_2d, ") && msg.contains("taylor_green_2d"), "{msg}");
    }

    /// `validate --list`: every case says what it checks and what it costs, each listed once
    /// under its own name, and a filter lists what it would run.
    #[test]
    fn every_case_says_what_it_checks_and_what_it_costs() {
        let all = cases();
        let mut names: Vec<&str> = all.iter().map(|c| c.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), all.len(), "case names must be unique");
        for c in &all {
            assert!(c.checks.chars().count() >= 40, "{}: '{}' says too little", c.name, c.checks);
            let timed = [" s", " min", " h", "hours"].iter().any(|u| c.cost.contains(u));
            assert!(timed && c.cost.chars().any(|ch| ch.is_ascii_digit()), "{}: cost '{}' names no time", c.name, c.cost);
        }
        let text = listing(&all);
        assert_eq!(text.lines().count(), 2 * all.len());
        for c in &all {
            let line = text.lines().find(|l| l.split_whitespace().next() == Some(c.name)).unwrap_or_else(|| panic!("{} not listed", c.name));
            assert!(line.ends_with(c.cost), "{line}");
            assert!(text.contains(c.checks));
        }
        let glottis: Vec<&str> = select(Some("glottis_2d")).unwrap().iter().map(|c| c.name).collect();
        assert_eq!(glottis, ["glottis_2d"]);
        assert_eq!(select(None).unwrap().len(), all.len());
        assert!(select(Some("no_such_case")).is_err());
    }
}
