//! Headless run of a lattice-gas scene (CPU or GPU, bit-identical) through the one run loop
//! ([`super::driver`]): `probe.csv`, coarse-grained fields (CSV, VTK, PNG) and `summary.json`.

use super::backend::LatticeGasEngine;
use super::{RunOptions, checkpoint, driver};
use crate::lattice_gas::coarse::coarse_grain;
use crate::lattice_gas::lattice::{Diagonals, LatticeGas};
use crate::lattice_gas::spectrum::{Peak, dominant_frequency};
use crate::output::coarse::{write_csv, write_pngs, write_vtk};
use crate::scene::lattice_gas::{LatticeGasScene, region_rows, region_velocity};
use crate::state::state_hash;
use crate::step::Solver;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

#[derive(Clone, Debug, Serialize)]
pub struct LatticeGasReport {
    pub name: String,
    pub backend: String,
    pub cells: [usize; 3],
    pub sites: u64,
    pub density: f64,
    pub interference: f64,
    pub diagonals: Diagonals,
    pub steps: u64,
    pub wall_s: f64,
    pub site_updates_per_s: f64,
    /// Wall-time share per stage (CPU backend only).
    pub stage_shares: Vec<(String, f64)>,
    pub particles_start: u64,
    pub particles_end: u64,
    /// Inflow velocity (ℓ/step) set at the inlet, and measured upstream of the cylinder (mean of
    /// the last half of the samples).
    pub inlet_velocity: Option<f64>,
    pub upstream_velocity: Option<f64>,
    /// Cylinder diameter (ℓ).
    pub diameter: Option<f64>,
    /// Spectral peak of the probe's transverse velocity over the last half of the run.
    pub wake_peak: Option<Peak>,
    /// Whether the wake sheds periodically: a prominent peak (≥ 50× the mean power; white noise
    /// gives 5–10) with at least three periods in the window.
    pub shedding_periodic: bool,
    /// St = f D / U (U the inlet velocity), when shedding is periodic.
    pub strouhal: Option<f64>,
    /// BLAKE3 of the final state ([`crate::state::state_hash`]): equal for bit-identical runs.
    pub state_hash: String,
    /// The step this run resumed from (a checkpoint), if it did.
    pub resumed_from_step: Option<u64>,
    /// The gas cannot go unstable; a GPU can fail (lost, out of memory): the diagnosis, the
    /// outputs written before it kept.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_failure: Option<String>,
    /// On the GPU: what came back from the device (whole states for the coarse fields,
    /// checkpoints and the end; the probes' bands of rows).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub readback: Option<super::backend::Readback>,
    pub files: Vec<String>,
}

/// Runs a lattice-gas scene into `dir`: `probe.csv` (step, u_X, u_Y at the probe, u_X
/// upstream), `coarse_NNNNNNN.{csv,vtk}` and `coarse_NNNNNNN_{speed,uy}.png` every
/// `output.every` steps, and `summary.json`. The GPU backend mirrors its state to the CPU at
/// every sample.
pub fn run_lattice_gas_scene(sc: &LatticeGasScene, dir: &Path, opts: &RunOptions) -> anyhow::Result<LatticeGasReport> {
    let ck = &opts.checkpoint;
    ck.validate()?;
    let s = &sc.file.lattice_gas;
    let mut gas = sc.build();
    std::fs::create_dir_all(dir)?;
    let record = ck.restore(&mut gas, dir)?.cloned();
    let start = match &ck.resume {
        Some(c) if record.is_some() => c.step,
        _ => 0,
    };
    let mut engine = LatticeGasEngine::new(opts.backend, gas)?.starting_at(start);
    let total = ck.total(opts.steps, s.steps).max(1);
    let o = &s.output;
    let mut files = vec!["probe.csv".to_string()];
    let mut probe = ProbeSeries::open(dir, record.as_ref(), &engine, &mut files)?;
    let upstream = s.cylinder.as_ref().map(|c| [(c.center[0] - c.radius) * 0.5, c.center[1]]);
    let half = 2.0 * o.coarse_block as f64;
    let outcome = driver::drive_until(&mut engine, total, opts.stop_at, &[o.probe_every, o.every, ck.period()], Some("steps"), |e, t| {
        let done = t.step;
        // A probe brings back the rows it reads only (on the GPU), the coarse field and a
        // checkpoint the whole state; a read that fails writes nothing (the next advance, or
        // the end, reports it).
        if t.hit[0]
            && let Some(p) = sc.probe
        {
            probe.sample(e, done, p, upstream, half)?;
        }
        if t.hit[1] || t.last {
            let Ok(g) = e.state() else { return Ok(()) };
            probe.csv.flush()?;
            files.extend(write_coarse_fields(dir, g, o.coarse_block, &sc.file.name, done)?);
        }
        if t.hit[2] {
            let Ok(g) = e.state() else { return Ok(()) };
            probe.csv.flush()?;
            ck.save(dir, done, total, g, probe.record(&files[1..]), &["probe.csv"])?;
        }
        Ok(())
    })?;
    if ck.writes() {
        files.push(checkpoint::FILE_NAME.into());
    }
    let (done, wall) = (outcome.steps, outcome.wall_s);
    let steps_here = done - start;
    // a read that failed at the last event has no advance after it to report it
    let instability = outcome.instability.clone().or_else(|| engine.read_failure().cloned());
    let readback = engine.is_gpu().then(|| engine.readback());
    let stage_shares = engine.stage_shares().into_iter().map(|(n, f)| (n.to_string(), f)).collect();
    let backend = engine.name.clone();
    let g = &engine.into_gas();
    probe.csv.flush()?;
    let wake = Wake::of(&probe.samples, o.probe_every, s);
    let sites = 16 * g.cells() as u64;
    let report = LatticeGasReport {
        name: sc.file.name.clone(),
        backend,
        cells: s.cells,
        sites,
        density: s.density,
        interference: s.interference,
        diagonals: s.diagonals,
        steps: done,
        wall_s: wall,
        site_updates_per_s: sites as f64 * steps_here as f64 / wall.max(1e-12),
        stage_shares,
        particles_start: probe.particles_start,
        particles_end: g.invariants().particles,
        inlet_velocity: wake.inlet_velocity,
        upstream_velocity: wake.upstream_velocity,
        diameter: wake.diameter,
        wake_peak: wake.peak,
        shedding_periodic: wake.shedding_periodic,
        strouhal: wake.strouhal,
        state_hash: state_hash(g),
        resumed_from_step: (start > 0).then_some(start),
        device_failure: instability.map(|e| e.to_string()),
        readback,
        files,
    };
    std::fs::write(dir.join("summary.json"), serde_json::to_string_pretty(&report)?)?;
    Ok(report)
}

/// The probe's series: `probe.csv`, the samples the wake's measures read (the transverse
/// velocity at the probe; the streamwise velocity upstream of the cylinder, where there is
/// one) and the particle count at the run's start, which a checkpoint carries.
struct ProbeSeries {
    csv: std::io::BufWriter<std::fs::File>,
    samples: Vec<(f64, Option<f64>)>,
    particles_start: u64,
}

impl ProbeSeries {
    /// A new `probe.csv` with its header; resuming (a checkpoint's `record`), the file appended
    /// to and the samples, particle count and `files` written before it taken from the record.
    fn open(dir: &Path, record: Option<&serde_json::Value>, engine: &LatticeGasEngine, files: &mut Vec<String>) -> anyhow::Result<Self> {
        let mut csv = std::io::BufWriter::new(checkpoint::output_file(&dir.join("probe.csv"), record.is_some())?);
        let Some(r) = record else {
            writeln!(csv, "step,u_x,u_y,upstream_u_x")?;
            return Ok(Self { csv, samples: Vec::new(), particles_start: engine.mirror().invariants().particles });
        };
        files.extend(checkpoint::names(&r["files"]));
        let uy = checkpoint::from_bits(&r["samples_uy"], "samples_uy")?;
        let up = checkpoint::from_bits(&r["samples_upstream"], "samples_upstream")?;
        let up: Vec<Option<f64>> = if up.is_empty() { vec![None; uy.len()] } else { up.into_iter().map(Some).collect() };
        Ok(Self { csv, samples: uy.into_iter().zip(up).collect(), particles_start: r["particles_start"].as_u64().unwrap_or(0) })
    }

    /// The mean velocity (ℓ/step) over a square of half-width `half` ℓ around the probe `p`,
    /// and upstream of the cylinder at `upstream`, after `done` steps: one row and one sample.
    /// Only the rows it reads come back from a GPU; a read that fails writes nothing.
    fn sample(&mut self, e: &mut LatticeGasEngine, done: u64, p: [f64; 2], upstream: Option<[f64; 2]>, half: f64) -> anyhow::Result<()> {
        let (y0, y1) = region_rows(e.mirror().dims, p, half);
        let Ok(g) = e.state_rows(y0, y1) else { return Ok(()) };
        let u = region_velocity(g, p, half);
        let up = match upstream {
            Some(a) => {
                let (y0, y1) = region_rows(g.dims, a, half);
                let Ok(g) = e.state_rows(y0, y1) else { return Ok(()) };
                Some(region_velocity(g, a, half)[0])
            }
            None => None,
        };
        writeln!(self.csv, "{done},{:.6},{:.6},{}", u[0], u[1], up.map(|v| format!("{v:.6}")).unwrap_or_default())?;
        self.samples.push((u[1], up));
        Ok(())
    }

    /// A checkpoint's record: the samples (bit-exact), the particle count at the start and the
    /// outputs written so far (`files`, `probe.csv` left out).
    fn record(&self, files: &[String]) -> serde_json::Value {
        let uy: Vec<f64> = self.samples.iter().map(|s| s.0).collect();
        let up: Vec<f64> = self.samples.iter().filter_map(|s| s.1).collect();
        serde_json::json!({
            "particles_start": self.particles_start,
            "samples_uy": checkpoint::bits(&uy),
            "samples_upstream": checkpoint::bits(&up),
            "files": files,
        })
    }
}

/// The coarse-grained field of `g` (blocks of `block` cells) after `done` steps as
/// `coarse_NNNNNNN.{csv,vtk}` and `coarse_NNNNNNN_{speed,uy}.png` in `dir`: their names.
fn write_coarse_fields(dir: &Path, g: &LatticeGas, block: usize, scene: &str, done: u64) -> anyhow::Result<[String; 4]> {
    let f = coarse_grain(g, block);
    let stem = format!("coarse_{done:07}");
    write_csv(&dir.join(format!("{stem}.csv")), &f)?;
    write_vtk(&dir.join(format!("{stem}.vtk")), &f, &format!("{scene} step {done}"))?;
    write_pngs(&dir.join(format!("{stem}_speed.png")), &dir.join(format!("{stem}_uy.png")), &f)?;
    Ok([format!("{stem}.csv"), format!("{stem}.vtk"), format!("{stem}_speed.png"), format!("{stem}_uy.png")])
}

/// The wake's measures over the last half of the probe's samples (see [`LatticeGasReport`]).
struct Wake {
    inlet_velocity: Option<f64>,
    upstream_velocity: Option<f64>,
    diameter: Option<f64>,
    peak: Option<Peak>,
    shedding_periodic: bool,
    strouhal: Option<f64>,
}

impl Wake {
    /// From `samples` taken every `probe_every` steps, the scene's inlet and cylinder `s`.
    fn of(samples: &[(f64, Option<f64>)], probe_every: u64, s: &crate::scene::lattice_gas::LatticeGasSection) -> Self {
        let last_half = &samples[samples.len() / 2..];
        let peak = dominant_frequency(&last_half.iter().map(|s| s.0).collect::<Vec<_>>(), probe_every as f64);
        let upstream_velocity = {
            let v: Vec<f64> = last_half.iter().filter_map(|s| s.1).collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        let diameter = s.cylinder.as_ref().map(|c| 2.0 * c.radius);
        let inlet_velocity = s.inlet.as_ref().map(|i| i.velocity);
        let shedding_periodic = peak.is_some_and(|p| p.prominence >= 50.0 && p.periods >= 3.0);
        let strouhal = match (shedding_periodic, peak, diameter, inlet_velocity) {
            (true, Some(p), Some(d), Some(u)) if u > 0.0 => Some(p.frequency * d / u),
            _ => None,
        };
        Self { inlet_velocity, upstream_velocity, diameter, peak, shedding_periodic, strouhal }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::lattice_gas::tests::SMALL;

    #[test]
    fn a_small_wake_runs_and_writes_its_outputs() {
        let sc = LatticeGasScene::parse(SMALL).unwrap();
        let dir = std::env::temp_dir().join(format!("phonation_lg_{}", std::process::id()));
        let r = run_lattice_gas_scene(&sc, &dir, &RunOptions { backend: crate::run::Backend::Cpu, ..Default::default() }).unwrap();
        println!("{}", serde_json::to_string(&r).unwrap());
        assert_eq!(r.steps, 60);
        assert_eq!(r.sites, 32 * 16 * 2 * 16);
        for f in ["probe.csv", "summary.json", "coarse_0000030.csv", "coarse_0000060.vtk", "coarse_0000060_speed.png", "coarse_0000060_uy.png"] {
            assert!(dir.join(f).is_file(), "{f}");
        }
        let probe = std::fs::read_to_string(dir.join("probe.csv")).unwrap();
        assert_eq!(probe.lines().count(), 1 + 12);
        // after 60 steps the injected flow has reached the upstream probe (inlet at 0.2 ℓ/step)
        let last: Vec<f64> = probe.lines().last().unwrap().split(',').map(|v| v.parse().unwrap()).collect();
        assert!(last[3] > 0.05 && last[3] < 0.3, "upstream u_x {}", last[3]);
        // the coarse CSV holds 8 × 4 × 1 blocks
        let csv = std::fs::read_to_string(dir.join("coarse_0000060.csv")).unwrap();
        assert_eq!(csv.lines().count(), 1 + 32);
        std::fs::remove_dir_all(&dir).ok();
    }
}
