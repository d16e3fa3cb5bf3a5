//! Files of a lattice-gas run's coarse-grained field ([`crate::lattice_gas::coarse`]): CSV,
//! legacy VTK and PNG maps.

use crate::lattice_gas::coarse::CoarseField;
use crate::output::fields::Slice;
use crate::output::png_map::write_png;
use std::io::Write;
use std::path::Path;

/// `x,y,z,density,u_x,u_y,u_z` per block (block indices; empty fields for blocks without fluid).
pub fn write_csv(path: &Path, f: &CoarseField) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "x,y,z,density,u_x,u_y,u_z")?;
    for z in 0..f.dims[2] {
        for y in 0..f.dims[1] {
            for x in 0..f.dims[0] {
                let i = f.index(x, y, z);
                match (f.density[i], f.velocity[i]) {
                    (Some(d), Some(u)) => writeln!(w, "{x},{y},{z},{d:.6},{:.6},{:.6},{:.6}", u[0], u[1], u[2])?,
                    _ => writeln!(w, "{x},{y},{z},,,,")?,
                }
            }
        }
    }
    w.flush()
}

/// Legacy VTK structured points, spacing 2·B ℓ (the block pitch), blocks without fluid as 0.
pub fn write_vtk(path: &Path, f: &CoarseField, title: &str) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let h = 2.0 * f.block as f64;
    writeln!(w, "# vtk DataFile Version 3.0\n{title}\nASCII\nDATASET STRUCTURED_POINTS")?;
    writeln!(w, "DIMENSIONS {} {} {}\nORIGIN {h2} {h2} {h2}\nSPACING {h} {h} {h}", f.dims[0], f.dims[1], f.dims[2], h2 = 0.5 * h)?;
    writeln!(w, "POINT_DATA {}\nSCALARS density float 1\nLOOKUP_TABLE default", f.density.len())?;
    for d in &f.density {
        writeln!(w, "{:.6}", d.unwrap_or(0.0))?;
    }
    writeln!(w, "VECTORS velocity float")?;
    for u in &f.velocity {
        let u = u.unwrap_or([0.0; 3]);
        writeln!(w, "{:.6} {:.6} {:.6}", u[0], u[1], u[2])?;
    }
    w.flush()
}

/// PNG maps of the Z-averaged speed and transverse velocity u_Y (blocks without fluid grey).
/// Returns the value ranges of the two maps.
pub fn write_pngs(speed: &Path, transverse: &Path, f: &CoarseField) -> std::io::Result<((f64, f64), (f64, f64))> {
    let map = |axis: Option<usize>| Slice {
        nx: f.dims[0],
        ny: f.dims[1],
        values: (0..f.dims[1])
            .flat_map(|y| (0..f.dims[0]).map(move |x| (x, y)))
            .map(|(x, y)| match axis {
                Some(a) => f.z_mean(x, y, a),
                None => match (f.z_mean(x, y, 0), f.z_mean(x, y, 1)) {
                    (Some(u), Some(v)) => Some((u * u + v * v).sqrt()),
                    _ => None,
                },
            })
            .collect(),
    };
    Ok((write_png(speed, &map(None), false)?, write_png(transverse, &map(Some(1)), true)?))
}
