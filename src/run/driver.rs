//! The one run loop of every kind of scene: advances a [`Solver`] to each output event of a
//! schedule (every `p` steps for each period `p`, and the last step), shows a progress bar,
//! hands each event to the caller's writer, and stops at the first instability, keeping what
//! was written so far. Wall time counts the solver's steps only, not the outputs.

use crate::step::{Instability, Solver};
use std::time::Instant;

/// One output event: the step reached (the solver's step counter) and which of the
/// schedule's periods it completes.
#[derive(Clone, Debug)]
pub struct Tick {
    pub step: u64,
    /// `hit[k]`: the step is a multiple of `periods[k]`.
    pub hit: Vec<bool>,
    /// The run's last step.
    pub last: bool,
}

/// How a [`drive`] ended.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The step reached (the solver's counter; the failed step on an instability).
    pub steps: u64,
    /// Wall time of the steps (s), outputs excluded.
    pub wall_s: f64,
    pub instability: Option<Instability>,
}

/// Advances `solver` from its step counter to step `total`, calling `at` at every multiple of
/// each of `periods` and at the last step (steps counted by the solver: a run resumed from a
/// checkpoint meets the same events as one that never stopped). A period of 0 or `u64::MAX` never fires. `at` is not called after an
/// instability; the caller writes its final diagnosis from [`Outcome::instability`].
pub fn drive<S: Solver + ?Sized>(
    solver: &mut S,
    total: u64,
    periods: &[u64],
    progress: Option<&str>,
    at: impl FnMut(&mut S, &Tick) -> anyhow::Result<()>,
) -> anyhow::Result<Outcome> {
    drive_until(solver, total, None, periods, progress, at)
}

/// [`drive`], interrupted after step `stop` (when it comes before `total`) as if the run had
/// been killed there: the events up to it fire, the schedule stays the whole run's, and no
/// `last` event fires. A checkpoint written before the stop continues the run as if it had
/// never stopped.
pub fn drive_until<S: Solver + ?Sized>(
    solver: &mut S,
    total: u64,
    stop: Option<u64>,
    periods: &[u64],
    progress: Option<&str>,
    mut at: impl FnMut(&mut S, &Tick) -> anyhow::Result<()>,
) -> anyhow::Result<Outcome> {
    let end = stop.map_or(total, |s| s.min(total));
    let bar = match progress {
        Some(what) => {
            let b = indicatif::ProgressBar::new(total);
            b.set_position(solver.step_count().min(total));
            b.set_style(indicatif::ProgressStyle::with_template(&format!("{{bar:40}} {{pos}}/{{len}} {what}  {{per_sec}}  eta {{eta}}"))?);
            b
        }
        None => indicatif::ProgressBar::hidden(),
    };
    let live = |p: u64| p > 0 && p != u64::MAX;
    let mut step = solver.step_count();
    let mut wall = 0.0;
    let mut instability = None;
    while step < end {
        let next = periods.iter().filter(|&&p| live(p)).map(|&p| (step / p + 1) * p).chain([end]).min().expect("the end is a candidate");
        let t0 = Instant::now();
        let r = solver.advance(next - step);
        wall += t0.elapsed().as_secs_f64();
        if let Err(e) = r {
            instability = Some(e);
            break;
        }
        step = next;
        bar.set_position(step);
        let tick = Tick { step, hit: periods.iter().map(|&p| live(p) && step.is_multiple_of(p)).collect(), last: step == total };
        at(solver, &tick)?;
    }
    bar.finish_and_clear();
    let steps = match &instability {
        Some(e) => e.step.max(step),
        None => step,
    };
    Ok(Outcome { steps, wall_s: wall, instability })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::step::{Part, Site};

    /// Counts steps; goes unstable at step `fail_at`.
    struct Counter {
        n: u64,
        fail_at: u64,
    }

    impl Solver for Counter {
        fn step(&mut self) -> Result<(), Instability> {
            self.n += 1;
            if self.n == self.fail_at {
                return Err(Instability {
                    part: Part::Solid,
                    step: self.n,
                    time: self.n as f64,
                    time_unit: "s",
                    site: Site::Particle(7),
                    quantity: "position",
                    value: f64::NAN,
                    reason: "test".into(),
                });
            }
            Ok(())
        }
        fn step_count(&self) -> u64 {
            self.n
        }
        fn stage_shares(&self) -> Vec<(&'static str, f64)> {
            Vec::new()
        }
    }

    #[test]
    fn events_fire_at_every_period_and_at_the_end_and_stop_at_an_instability() {
        let mut c = Counter { n: 0, fail_at: u64::MAX };
        let mut seen = Vec::new();
        let o = drive(&mut c, 25, &[10, 4, 0, u64::MAX], None, |s, t| {
            assert_eq!(s.step_count(), t.step);
            seen.push((t.step, t.hit.clone(), t.last));
            Ok(())
        })
        .unwrap();
        assert_eq!((o.steps, c.n), (25, 25));
        assert!(o.instability.is_none());
        let steps: Vec<u64> = seen.iter().map(|s| s.0).collect();
        assert_eq!(steps, [4, 8, 10, 12, 16, 20, 24, 25]);
        assert_eq!(seen[2].1, [true, false, false, false]);
        assert_eq!(seen[5].1, [true, true, false, false]);
        assert!(seen[7].2 && !seen[6].2 && seen[7].1.iter().all(|h| !h));

        let mut c = Counter { n: 0, fail_at: 13 };
        let mut calls = 0;
        let o = drive(&mut c, 25, &[5], None, |_, _| {
            calls += 1;
            Ok(())
        })
        .unwrap();
        assert_eq!((calls, o.steps), (2, 13), "events at 5 and 10, then the failure at 13");
        assert_eq!(o.instability.unwrap().site, Site::Particle(7));

        // interrupted at 17 of 25, then continued: the same events as one whole run
        let mut c = Counter { n: 0, fail_at: u64::MAX };
        let mut split = Vec::new();
        let o = drive_until(&mut c, 25, Some(17), &[10, 4], None, |_, t| {
            split.push((t.step, t.last));
            Ok(())
        })
        .unwrap();
        assert_eq!((o.steps, c.n), (17, 17));
        let o = drive(&mut c, 25, &[10, 4], None, |_, t| {
            split.push((t.step, t.last));
            Ok(())
        })
        .unwrap();
        assert_eq!(o.steps, 25);
        assert_eq!(split, [(4, false), (8, false), (10, false), (12, false), (16, false), (17, false), (20, false), (24, false), (25, true)]);
    }
}
