//! Headless run of a coupled scene (CPU): steps [`WeakCoupling`], writes `coupling.csv`
//! (forces on each body, displacements, momenta, fluid mass, uncovered/covered nodes — flushed
//! per row), fluid probes and snapshots, particle VTK snapshots and `summary.json`. A run that
//! goes unstable stops with the diagnosis and keeps everything written so far (plus a last
//! snapshot of the last finite state).

use crate::coupling::{CoupledInstability, WeakCoupling};
use crate::output::probes::ProbeWriter;
use crate::scene::coupled::CoupledScene;
use crate::scene::solid::write_vtk;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Clone, Debug, Serialize)]
pub struct CoupledReport {
    pub name: String,
    pub backend: String,
    pub method: String,
    pub nodes: [usize; 3],
    pub particles: usize,
    /// Solid sub-steps per fluid step.
    pub substeps: u32,
    /// Fluid (= coupled) step (s).
    pub dt: f64,
    pub steps: u64,
    pub simulated_s: f64,
    pub wall_s: f64,
    pub coupled_steps_per_s: f64,
    /// Each stage's share of the coupled step's wall time.
    pub stage_shares: Vec<(String, f64)>,
    /// The air's force on each body at the end (scene units; per unit depth in 2D).
    pub final_forces: Vec<[f64; 3]>,
    pub max_displacement: f64,
    pub fluid_mass_drift: f64,
    pub uncovered: usize,
    pub covered: usize,
    /// None when the run finished; else what went wrong, where and when.
    pub instability: Option<String>,
    pub files: Vec<PathBuf>,
}

fn csv_header(c: &WeakCoupling) -> String {
    let mut h = String::from("step,time_s");
    for b in &c.bodies {
        let k = b.surface.body;
        h += &format!(",force_x_{k},force_y_{k},mean_dx_{k},mean_dy_{k}");
    }
    h + ",max_displacement,fluid_px,fluid_py,solid_px,solid_py,fluid_mass,uncovered,covered"
}

fn csv_row(c: &WeakCoupling) -> String {
    let p = &c.solid.particles;
    let mut r = format!("{},{:.9e}", c.step_count, c.time);
    for (k, b) in c.bodies.iter().enumerate() {
        let f = c.forces.total.get(k).copied().unwrap_or_default();
        let (mut d, mut n) = (glam::DVec3::ZERO, 0.0);
        for i in 0..p.len() {
            if p.body[i] == b.surface.body {
                d += p.position[i] - p.reference[i];
                n += 1.0;
            }
        }
        d /= n;
        r += &format!(",{:.9e},{:.9e},{:.9e},{:.9e}", f.x, f.y, d.x, d.y);
    }
    let max_d = (0..p.len()).map(|i| (p.position[i] - p.reference[i]).length()).fold(0.0, f64::max);
    let totals = c.fluid.totals();
    let fm = c.fluid_momentum(&totals);
    let sm = p.linear_momentum();
    r + &format!(",{max_d:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.12e},{},{}", fm.x, fm.y, sm.x, sm.y, totals.mass, c.geometry.uncovered, c.geometry.covered)
}

/// Runs `sc` for its duration (or `steps`), writing into `dir`.
pub fn run_coupled_scene(sc: &CoupledScene, dir: &Path, steps: Option<u64>, show_progress: bool) -> anyhow::Result<CoupledReport> {
    std::fs::create_dir_all(dir)?;
    let mut c = sc.build()?;
    let total = steps.unwrap_or(sc.fluid.steps);
    let every = sc.coupling.output_every.unwrap_or(10);
    let fluid_scene = &sc.fluid;
    let mut files = vec![dir.join("coupling.csv"), dir.join("probes.csv")];
    let mut csv = std::io::BufWriter::new(std::fs::File::create(&files[0])?);
    writeln!(csv, "{}", csv_header(&c))?;
    writeln!(csv, "{}", csv_row(&c))?;
    csv.flush()?;
    let mut probes = ProbeWriter::create(&files[1], &c.fluid, &fluid_scene.probes)?;
    probes.sample(&c.fluid, &fluid_scene.units)?;
    let snaps = fluid_scene.file.output.snapshots;
    let snap_every = if snaps > 0 { (total / snaps).max(1) } else { u64::MAX };
    let probe_every = fluid_scene.file.output.probe_every.max(1);
    let m0 = c.fluid.totals().mass;
    let bar = if show_progress { indicatif::ProgressBar::new(total) } else { indicatif::ProgressBar::hidden() };
    bar.set_style(indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} coupled steps  {per_sec}  eta {eta}").unwrap());
    let snapshot = |c: &WeakCoupling, k: u64, files: &mut Vec<PathBuf>| -> std::io::Result<()> {
        super::snapshot(&c.fluid, fluid_scene, dir, k, files)?;
        let path = dir.join(format!("particles_{k:03}.vtk"));
        write_vtk(&c.solid, &path)?;
        files.push(path);
        Ok(())
    };
    let t0 = Instant::now();
    let mut instability: Option<CoupledInstability> = None;
    let mut k_snap = 0;
    for _ in 0..total {
        if let Err(e) = c.step() {
            instability = Some(e);
            break;
        }
        let s = c.step_count;
        if s % every == 0 || s == total {
            writeln!(csv, "{}", csv_row(&c))?;
            csv.flush()?;
        }
        if s % probe_every == 0 || s == total {
            probes.sample(&c.fluid, &fluid_scene.units)?;
        }
        if s % snap_every == 0 && k_snap < snaps {
            k_snap += 1;
            snapshot(&c, k_snap, &mut files)?;
        }
        bar.set_position(s);
    }
    bar.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();
    if instability.is_some() {
        snapshot(&c, 999, &mut files)?;
    }
    let p = &c.solid.particles;
    let report = CoupledReport {
        name: fluid_scene.file.name.clone(),
        backend: format!("cpu ({} threads)", rayon::current_num_threads()),
        method: "weak".into(),
        nodes: fluid_scene.grid.n,
        particles: p.len(),
        substeps: c.substeps,
        dt: c.dt(),
        steps: c.step_count,
        simulated_s: c.time,
        wall_s: wall,
        coupled_steps_per_s: c.step_count as f64 / wall.max(1e-9),
        stage_shares: c.stage_shares().into_iter().map(|(n, s)| (n.to_string(), s)).collect(),
        final_forces: c.forces.total.iter().map(|f| f.to_array()).collect(),
        max_displacement: (0..p.len()).map(|i| (p.position[i] - p.reference[i]).length()).fold(0.0, f64::max),
        fluid_mass_drift: (c.fluid.totals().mass - m0) / m0,
        uncovered: c.geometry.uncovered,
        covered: c.geometry.covered,
        instability: instability.map(|e| e.to_string()),
        files: files.clone(),
    };
    let mut report = report;
    report.files.push(super::write_summary(dir, &report)?);
    Ok(report)
}
