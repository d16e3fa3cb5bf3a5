//! Headless run of a solid scene (CPU or GPU): `solid.csv` (energies, momenta, CG iterations,
//! contact overlap, probe displacements; flushed per row), particle VTK snapshots and
//! `summary.json`, through the one run loop ([`super::driver`]).

use super::backend::{Backend, SolidEngine};
use super::driver;
use crate::scene::solid::{SolidScene, inside, vec3};
use crate::solid::{Integrator, SolidSolver};
use crate::step::Solver;
use glam::DVec3;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Outcome of a solid run.
#[derive(Clone, Debug, Serialize)]
pub struct SolidReport {
    pub name: String,
    pub backend: String,
    pub particles: usize,
    pub bonds: usize,
    pub integrator: Integrator,
    pub dt: f64,
    pub explicit_limit: f64,
    pub steps: u64,
    pub simulated_time: f64,
    pub wall_s: f64,
    pub particle_updates_per_s: f64,
    pub stage_shares: Vec<(&'static str, f64)>,
    /// max |E(t) − E(0)| / max (kinetic + elastic): conservation for undamped, unloaded
    /// scenes; the work of damping, loads and contact otherwise.
    pub energy_drift: f64,
    /// None when the run finished; else what went wrong, where and when.
    pub instability: Option<String>,
    pub files: Vec<PathBuf>,
}

/// Legacy VTK polydata of the particles (positions, displacement, velocity, material, stress).
pub fn write_vtk(s: &SolidSolver, path: &Path) -> std::io::Result<()> {
    let p = &s.particles;
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "# vtk DataFile Version 3.0\nphonation solid particles t = {:.6e}\nASCII\nDATASET POLYDATA\nPOINTS {} double", s.time, p.len())?;
    for x in &p.position {
        writeln!(w, "{} {} {}", x.x, x.y, x.z)?;
    }
    writeln!(w, "VERTICES {} {}", p.len(), 2 * p.len())?;
    for i in 0..p.len() {
        writeln!(w, "1 {i}")?;
    }
    writeln!(w, "POINT_DATA {}\nVECTORS displacement double", p.len())?;
    for i in 0..p.len() {
        let d = p.position[i] - p.reference[i];
        writeln!(w, "{} {} {}", d.x, d.y, d.z)?;
    }
    writeln!(w, "VECTORS velocity double")?;
    for v in &p.velocity {
        writeln!(w, "{} {} {}", v.x, v.y, v.z)?;
    }
    writeln!(w, "SCALARS material int 1\nLOOKUP_TABLE default")?;
    for m in &p.material {
        writeln!(w, "{m}")?;
    }
    writeln!(w, "SCALARS fixed int 1\nLOOKUP_TABLE default")?;
    for f in &p.fixed {
        writeln!(w, "{}", *f as u8)?;
    }
    writeln!(w, "SCALARS strain_xx double 1\nLOOKUP_TABLE default")?;
    for e in &s.stress().strain {
        writeln!(w, "{}", e[0])?;
    }
    w.flush()
}

/// Runs a solid scene, writing `solid.csv` (flushed per row), VTK snapshots and
/// `summary.json` into `dir`. A non-finite state stops the run with a diagnosis; everything
/// written so far is kept (plus a final snapshot).
pub fn run_solid_scene(sc: &SolidScene, dir: &Path, steps: Option<u64>, backend: Backend) -> anyhow::Result<SolidReport> {
    std::fs::create_dir_all(dir)?;
    // GPU: the CPU solver mirrors the GPU state at every output (rows, snapshots)
    let mut engine = SolidEngine::new(backend, sc.build()?, sc.file.solid.cg_tolerance)?;
    let s = &mut engine.solver;
    let dim = sc.file.solid.dimension;
    let total = steps.unwrap_or((sc.file.run.duration / s.dt).ceil() as u64).max(1);
    let every = sc.file.run.output_every.unwrap_or(10).max(1);
    let snaps = sc.file.run.snapshots.unwrap_or(10).max(1);
    let snap_every = (total / snaps).max(1);
    let probes: Vec<(String, Vec<usize>)> = sc
        .file
        .probes
        .iter()
        .map(|pr| {
            let (lo, hi) = (vec3("", &pr.min, dim, false).unwrap(), vec3("", &pr.max, dim, false).unwrap());
            (pr.name.clone(), (0..s.particles.len()).filter(|&i| inside(s.particles.reference[i], lo, hi, dim)).collect())
        })
        .collect();
    let mut files = vec![dir.join("solid.csv")];
    let mut csv = std::io::BufWriter::new(std::fs::File::create(dir.join("solid.csv"))?);
    let mut header = "step,time,kinetic,elastic,external,total,px,py,pz,lx,ly,lz,cg_iterations,cg_residual,max_overlap".to_string();
    for (n, _) in &probes {
        header += &format!(",{n}_ux,{n}_uy,{n}_uz");
    }
    writeln!(csv, "{header}")?;
    let row = |s: &mut SolidSolver, csv: &mut std::io::BufWriter<std::fs::File>| -> anyhow::Result<crate::solid::Energies> {
        let e = s.energies();
        let (pm, am) = (s.particles.linear_momentum(), s.particles.angular_momentum());
        let mut line = format!(
            "{},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{:.9e},{},{:.3e},{:.4e}",
            s.step_count,
            s.time,
            e.kinetic,
            e.elastic,
            e.external,
            e.total(),
            pm.x,
            pm.y,
            pm.z,
            am.x,
            am.y,
            am.z,
            s.last.cg.iterations,
            s.last.cg.relative_residual,
            s.contacts().max_overlap
        );
        for (_, idx) in &probes {
            let u: DVec3 = idx.iter().map(|&i| s.particles.position[i] - s.particles.reference[i]).sum::<DVec3>() / idx.len().max(1) as f64;
            line += &format!(",{:.9e},{:.9e},{:.9e}", u.x, u.y, u.z);
        }
        writeln!(csv, "{line}")?;
        csv.flush()?;
        Ok(e)
    };
    let first = row(s, &mut csv)?;
    let e0 = first.total();
    let mut drift: f64 = 0.0;
    let mut scale_e = first.kinetic + first.elastic;
    let snap = |s: &SolidSolver, k: u64, files: &mut Vec<PathBuf>| -> std::io::Result<()> {
        let f = dir.join(format!("particles_{k:04}.vtk"));
        write_vtk(s, &f)?;
        files.push(f);
        Ok(())
    };
    snap(s, 0, &mut files)?;
    let outcome = driver::drive(&mut engine, total, &[every, snap_every], Some("steps"), |e, t| {
        let s = &mut e.solver;
        if t.hit[0] || t.last {
            let e = row(s, &mut csv)?;
            scale_e = scale_e.max(e.kinetic + e.elastic);
            if scale_e > 0.0 {
                drift = drift.max((e.total() - e0).abs() / scale_e);
            }
        }
        if t.hit[1] {
            snap(s, t.step / snap_every, &mut files)?;
        }
        Ok(())
    })?;
    let s = &engine.solver;
    if outcome.instability.is_some() {
        snap(s, 999, &mut files)?;
    }
    let wall = outcome.wall_s;
    let report = SolidReport {
        name: sc.file.name.clone(),
        backend: engine.name.clone(),
        particles: s.particles.len(),
        bonds: s.disc.bonds.len(),
        integrator: s.options.integrator,
        dt: s.dt,
        explicit_limit: s.explicit_limit,
        steps: s.step_count,
        simulated_time: s.time,
        wall_s: wall,
        particle_updates_per_s: s.particles.len() as f64 * s.step_count as f64 / wall.max(1e-9),
        stage_shares: engine.stage_shares(),
        energy_drift: drift,
        instability: outcome.instability.map(|e| e.to_string()),
        files: files.clone(),
    };
    std::fs::write(dir.join("summary.json"), serde_json::to_string_pretty(&report)?)?;
    Ok(report)
}
