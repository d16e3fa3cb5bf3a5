//! Headless run of a solid scene (CPU or GPU): `solid.csv` (energies, momenta, CG iterations,
//! contact overlap, probe displacements; flushed per row), particle VTK snapshots and
//! `summary.json`, through the one run loop ([`super::driver`]).

use super::backend::{Backend, SolidEngine};
use super::{RunOptions, checkpoint, driver};
use crate::scene::solid::{SolidScene, inside, vec3};
use crate::solid::{Integrator, SolidSolver};
use crate::state::state_hash;
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
    /// BLAKE3 of the final state ([`crate::state::state_hash`]): equal for bit-identical runs.
    pub state_hash: String,
    /// The step this run resumed from (a checkpoint), if it did.
    pub resumed_from_step: Option<u64>,
    /// One clamped–free beam: its tip's period and deflection against beam theory
    /// ([`super::beam::beam_report`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beam: Option<super::beam::BeamReport>,
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

/// The particles of each of the scene's region probes (name, particles whose reference
/// position lies in its box).
fn region_probes(sc: &SolidScene, s: &SolidSolver) -> Vec<(String, Vec<usize>)> {
    let dim = sc.file.solid.dimension;
    sc.file
        .probes
        .iter()
        .map(|pr| {
            let (lo, hi) = (vec3("", &pr.min, dim, false).unwrap(), vec3("", &pr.max, dim, false).unwrap());
            (pr.name.clone(), (0..s.particles.len()).filter(|&i| inside(s.particles.reference[i], lo, hi, dim)).collect())
        })
        .collect()
}

/// The header of `solid.csv`: the energies, momenta, the last CG solve, the contact's largest
/// overlap, then each probe's mean displacement.
fn csv_header(probes: &[(String, Vec<usize>)]) -> String {
    let mut header = "step,time,kinetic,elastic,external,total,px,py,pz,lx,ly,lz,cg_iterations,cg_residual,max_overlap".to_string();
    for (n, _) in probes {
        header += &format!(",{n}_ux,{n}_uy,{n}_uz");
    }
    header
}

/// One row of `solid.csv` for the state of `s`, written and flushed; returns its energies.
fn csv_row(s: &mut SolidSolver, probes: &[(String, Vec<usize>)], csv: &mut std::io::BufWriter<std::fs::File>) -> anyhow::Result<crate::solid::Energies> {
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
    for (_, idx) in probes {
        let u: DVec3 = idx.iter().map(|&i| s.particles.position[i] - s.particles.reference[i]).sum::<DVec3>() / idx.len().max(1) as f64;
        line += &format!(",{:.9e},{:.9e},{:.9e}", u.x, u.y, u.z);
    }
    writeln!(csv, "{line}")?;
    csv.flush()?;
    Ok(e)
}

/// Snapshot `k` into `dir`: the particles and the solid's surface (VTK).
fn write_snapshot(s: &SolidSolver, dir: &Path, k: u64, files: &mut Vec<PathBuf>) -> std::io::Result<()> {
    let f = dir.join(format!("particles_{k:04}.vtk"));
    write_vtk(s, &f)?;
    files.push(f);
    let f = dir.join(format!("surface_{k:04}.vtk"));
    crate::output::mesh::write_mesh_vtk(&f, &super::surface::solid_surface(s), &format!("phonation solid surface t = {:.6e}", s.time))?;
    files.push(f);
    Ok(())
}

/// Runs a solid scene, writing `solid.csv` (flushed per row), VTK snapshots and
/// `summary.json` into `dir`. A non-finite state stops the run with a diagnosis; everything
/// written so far is kept (plus a final snapshot).
pub fn run_solid_scene(sc: &SolidScene, dir: &Path, opts: &RunOptions) -> anyhow::Result<SolidReport> {
    let ck = &opts.checkpoint;
    ck.validate()?;
    let mut solver = sc.build()?;
    // The GPU solid keeps its contact anchors on the device only: checkpoints of a scene with
    // contact are written on the CPU (`auto` picks it; `gpu` is refused).
    let mut backend = opts.backend;
    if ck.writes() && solver.options.contact.is_some() {
        match backend {
            Backend::Gpu => anyhow::bail!(
                "--checkpoint-every: the GPU solid keeps its contact anchors on the device only, so its checkpoints would lose them; use --backend cpu (or auto) for this scene (it has `solid.contact`)"
            ),
            _ => backend = Backend::Cpu,
        }
    }
    std::fs::create_dir_all(dir)?;
    let record = ck.restore(&mut solver, dir)?.cloned();
    let resumed_from_step = record.is_some().then_some(solver.step_count);
    // GPU: the CPU solver mirrors the GPU state at every output (rows, snapshots)
    let mut engine = SolidEngine::new(backend, solver, sc.file.solid.cg_tolerance)?;
    let s = &mut engine.solver;
    let total = ck.total(opts.steps, (sc.file.run.duration / s.dt).ceil() as u64).max(1);
    let every = sc.file.run.output_every.unwrap_or(10).max(1);
    let snaps = sc.file.run.snapshots.unwrap_or(10).max(1);
    let snap_every = (total / snaps).max(1);
    let probes = region_probes(sc, s);
    let mut files = vec![dir.join("solid.csv")];
    let mut csv = std::io::BufWriter::new(checkpoint::output_file(&files[0], record.is_some())?);
    // (initial energy, largest drift so far, largest kinetic + elastic energy so far)
    let (e0, mut drift, mut scale_e) = match &record {
        Some(r) => {
            files.extend(checkpoint::names(&r["files"]).into_iter().map(|n| dir.join(n)));
            let v = checkpoint::from_bits(&r["energy"], "energy")?;
            anyhow::ensure!(v.len() == 3, "checkpoint run record: `energy` holds {} values, not 3", v.len());
            (v[0], v[1], v[2])
        }
        None => {
            writeln!(csv, "{}", csv_header(&probes))?;
            let first = csv_row(s, &probes, &mut csv)?;
            write_snapshot(s, dir, 0, &mut files)?;
            (first.total(), 0.0, first.kinetic + first.elastic)
        }
    };
    let outcome = driver::drive_until(&mut engine, total, opts.stop_at, &[every, snap_every, ck.period()], Some("steps"), |e, t| {
        let s = &mut e.solver;
        if t.hit[0] || t.last {
            let e = csv_row(s, &probes, &mut csv)?;
            scale_e = scale_e.max(e.kinetic + e.elastic);
            if scale_e > 0.0 {
                drift = drift.max((e.total() - e0).abs() / scale_e);
            }
        }
        if t.hit[1] {
            write_snapshot(s, dir, t.step / snap_every, &mut files)?;
        }
        if t.hit[2] {
            let record = serde_json::json!({"energy": checkpoint::bits(&[e0, drift, scale_e]), "files": checkpoint::file_names(&files[1..])});
            ck.save(dir, t.step, total, &*s, record, &["solid.csv"])?;
        }
        Ok(())
    })?;
    let s = &engine.solver;
    if outcome.instability.is_some() {
        write_snapshot(s, dir, 999, &mut files)?;
    }
    if ck.writes() {
        files.push(dir.join(checkpoint::FILE_NAME));
    }
    let wall = outcome.wall_s;
    let steps_here = s.step_count - resumed_from_step.unwrap_or(0);
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
        particle_updates_per_s: s.particles.len() as f64 * steps_here as f64 / wall.max(1e-9),
        stage_shares: engine.stage_shares(),
        energy_drift: drift,
        instability: outcome.instability.map(|e| e.to_string()),
        state_hash: state_hash(s),
        resumed_from_step,
        beam: super::beam::beam_report(sc, &dir.join("solid.csv"))?,
        files: files.clone(),
    };
    std::fs::write(dir.join("summary.json"), serde_json::to_string_pretty(&report)?)?;
    Ok(report)
}
