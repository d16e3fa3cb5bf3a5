//! The work a force does on an oscillating body, cycle by cycle: the aerodynamic energy
//! transfer of a glottal flow to the folds (Thomson, Mongeau & Frankel 2005, JASA 118, 1689:
//! the folds self-oscillate when the flow's work over a cycle exceeds what the tissue
//! dissipates), read from a sampled power P(t).
//!
//! Units: whatever the power's are (erg/s from a glottal run) times seconds (erg).

/// The work over one cycle and the body's largest kinetic energy in it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CycleWork {
    /// Start and end of the cycle (s from the first sample).
    pub t_start: f64,
    pub t_end: f64,
    /// ∫ P dt over [t_start, t_end] for each power series, in the order given.
    pub work: [f64; 3],
    /// The largest kinetic energy sampled in the cycle.
    pub peak_kinetic_energy: f64,
}

/// ∫ P dt over each cycle \[bounds\[k\], bounds\[k + 1\]\] (s) inside the series, for the three
/// power series `power` (uniform samples `dt` s apart, the first at t = 0), with the largest
/// sample of `kinetic_energy` in each cycle. The integral is the trapezoid rule's, its running
/// sum interpolated linearly at the bounds (which need not fall on samples).
///
/// Where the body oscillates about a load that is steady (the lung pressure on the folds), the
/// steady part F̄ of the force does the work F̄ · (x(t_end) − x(t_start)) over a cycle: zero only
/// when the body is where it was. Bounds at the instants one displacement crosses its mean
/// upward ([`super::oscillation::upward_crossings`]) make that so for the motion the
/// displacement follows; what the rest of the body does between them is not constrained.
pub fn work_per_cycle(power: [&[f64]; 3], kinetic_energy: &[f64], dt: f64, bounds: &[f64]) -> Vec<CycleWork> {
    let n = power.iter().map(|p| p.len()).min().unwrap_or(0).min(kinetic_energy.len());
    if n < 2 || !(dt > 0.0) {
        return Vec::new();
    }
    // running trapezoid sums W_k(t_i), t_i = i dt
    let running = |p: &[f64]| {
        let mut w = vec![0.0; n];
        for i in 1..n {
            w[i] = w[i - 1] + 0.5 * (p[i - 1] + p[i]) * dt;
        }
        w
    };
    let sums = power.map(running);
    let at = |w: &[f64], t: f64| {
        let x = t / dt;
        let i = (x.floor() as usize).min(n - 2);
        w[i] + (x - i as f64) * (w[i + 1] - w[i])
    };
    let end = (n - 1) as f64 * dt;
    bounds
        .windows(2)
        .filter(|b| b[0] >= 0.0 && b[1] > b[0] && b[1] <= end * (1.0 + 1e-12))
        .map(|b| {
            let (t0, t1) = (b[0], b[1]);
            let work = [0, 1, 2].map(|k| at(&sums[k], t1) - at(&sums[k], t0));
            let (i0, i1) = ((t0 / dt).ceil() as usize, ((t1 / dt).floor() as usize).min(n - 1));
            let peak_kinetic_energy = kinetic_energy[i0.min(i1)..=i1].iter().copied().fold(0.0, f64::max);
            CycleWork { t_start: t0, t_end: t1, work, peak_kinetic_energy }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A constant power plus an oscillation at the period: each period's work is the constant's
    /// alone, P₀T, however the period's ends fall between the samples.
    #[test]
    fn the_work_over_whole_periods_is_the_mean_power_times_the_period() {
        let (p0, a, period, dt) = (3.0, 40.0, 0.00853, 1.0e-5);
        let p: Vec<f64> = (0..5000).map(|i| p0 + a * (2.0 * PI * i as f64 * dt / period + 0.4).cos()).collect();
        let zero = vec![0.0; p.len()];
        let bounds: Vec<f64> = (0..8).map(|k| 0.00117 + k as f64 * period).collect();
        let w = work_per_cycle([&p, &zero, &p], &zero, dt, &bounds);
        assert_eq!(w.len(), 5, "5 whole periods of 8.53 ms fit in 50 ms after 1.17 ms");
        for pw in &w {
            assert!((pw.work[0] / (p0 * period) - 1.0).abs() < 1e-4, "{:?}", pw);
            assert_eq!(pw.work[1], 0.0);
            assert_eq!(pw.work[0], pw.work[2]);
        }
    }

    /// A damped oscillator m x'' + c x' + k x = 0 (x = e^{−γt} cos ω_d t): the damper's power
    /// −c v² over a period is the oscillator's loss of energy ½mv² + ½kx² over it, and the
    /// largest kinetic energy per period falls by e^{−2γT} from one period to the next.
    #[test]
    fn a_dampers_work_per_period_is_the_oscillators_loss_of_energy() {
        let (m, k, c) = (2.0, 2.0 * (2.0 * PI * 115.0_f64).powi(2), 40.0);
        let gamma = c / (2.0 * m);
        let wd = (k / m - gamma * gamma).sqrt();
        let period = 2.0 * PI / wd;
        let dt = period / 317.3;
        let state = |t: f64| {
            let e = (-gamma * t).exp();
            let x = e * (wd * t).cos();
            let v = -gamma * x - e * wd * (wd * t).sin();
            (x, v)
        };
        let n = (6.0 * period / dt) as usize;
        let (mut damper, mut ke) = (Vec::new(), Vec::new());
        for i in 0..n {
            let (_, v) = state(i as f64 * dt);
            damper.push(-c * v * v);
            ke.push(0.5 * m * v * v);
        }
        let zero = vec![0.0; n];
        let energy = |t: f64| {
            let (x, v) = state(t);
            0.5 * m * v * v + 0.5 * k * x * x
        };
        // cycles from one upward crossing of x's mean (0) to the next
        let x: Vec<f64> = (0..n).map(|i| state(i as f64 * dt).0).collect();
        let bounds = crate::analysis::oscillation::upward_crossings(&x, 0.0, dt);
        let w = work_per_cycle([&damper, &zero, &zero], &ke, dt, &bounds);
        assert_eq!(w.len(), 5);
        for pw in &w {
            assert!(((pw.t_end - pw.t_start) / period - 1.0).abs() < 1e-3);
            let loss = energy(pw.t_end) - energy(pw.t_start);
            assert!(loss < 0.0);
            assert!((pw.work[0] / loss - 1.0).abs() < 1e-3, "work {} against the energy's change {}", pw.work[0], loss);
        }
        let decay = (-2.0 * gamma * period).exp();
        for pair in w.windows(2) {
            let r = pair[1].peak_kinetic_energy / pair[0].peak_kinetic_energy;
            assert!((r / decay - 1.0).abs() < 2e-3, "peak kinetic energy ratio {r} against e^(−2γT) = {decay}");
        }
    }

    #[test]
    fn cycles_that_leave_the_series_are_not_counted() {
        let p = vec![1.0; 10];
        assert!(work_per_cycle([&p, &p, &p], &p, 1.0, &[0.0, 20.0]).is_empty());
        assert!(work_per_cycle([&p, &p, &p], &p, 1.0, &[3.0]).is_empty());
        let w = work_per_cycle([&p, &p, &p], &p, 1.0, &[-1.0, 2.0, 5.5, 9.0, 9.5]);
        assert_eq!(w.len(), 2, "[2, 5.5] and [5.5, 9]");
        assert!((w[0].work[0] - 3.5).abs() < 1e-12 && (w[1].work[2] - 3.5).abs() < 1e-12);
    }
}
