//! Legacy VTK (binary, STRUCTURED_POINTS) snapshots for ParaView: density, gauge pressure,
//! temperature ratio and velocity at every interior node, in physical units (solids: NaN).

use crate::fluid::FluidSolver;
use crate::units::Units;
use std::io::{BufWriter, Write};
use std::path::Path;

pub fn write_vtk(path: &Path, s: &FluidSolver, units: &Units, title: &str) -> std::io::Result<()> {
    let g = &s.layout.grid;
    let macros = s.interior_macros();
    let mut w = BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "# vtk DataFile Version 3.0")?;
    writeln!(w, "{}", title.replace('\n', " "))?;
    writeln!(w, "BINARY")?;
    writeln!(w, "DATASET STRUCTURED_POINTS")?;
    writeln!(w, "DIMENSIONS {} {} {}", g.n[0], g.n[1], g.n[2])?;
    let dx = units.dx;
    writeln!(w, "ORIGIN {} {} {}", 0.5 * dx, 0.5 * dx, if g.dim == 3 { 0.5 * dx } else { 0.0 })?;
    writeln!(w, "SPACING {dx} {dx} {dx}")?;
    writeln!(w, "POINT_DATA {}", macros.len())?;
    let scalar = |w: &mut BufWriter<std::fs::File>, name: &str, f: &dyn Fn(&crate::fluid::Macro) -> f64| -> std::io::Result<()> {
        writeln!(w, "SCALARS {name} float 1")?;
        writeln!(w, "LOOKUP_TABLE default")?;
        for m in &macros {
            let v = m.as_ref().map(f).unwrap_or(f64::NAN) as f32;
            w.write_all(&v.to_be_bytes())?;
        }
        writeln!(w)
    };
    scalar(&mut w, "density", &|m| units.density_to_physical(m.rho))?;
    scalar(&mut w, "pressure", &|m| units.gauge_pressure_to_physical(m.pressure()))?;
    scalar(&mut w, "temperature_ratio", &|m| m.theta / units.theta0)?;
    writeln!(w, "VECTORS velocity float")?;
    for m in &macros {
        for a in 0..3 {
            let v = m.as_ref().map(|m| units.velocity_to_physical(m.u[a])).unwrap_or(f64::NAN) as f32;
            w.write_all(&v.to_be_bytes())?;
        }
    }
    writeln!(w)?;
    w.flush()
}
