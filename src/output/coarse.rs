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

/// A Z-averaged map of a coarse-grained field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoarseMap {
    /// |(u_X, u_Y)| (ℓ/step).
    Speed,
    /// One velocity component (0 = X, 1 = Y; ℓ/step).
    Velocity(usize),
    /// Particles per link.
    Density,
    /// ∂u_Y/∂X − ∂u_X/∂Y by central differences over the block pitch 2B ℓ (1/step); blocks
    /// on the edge or next to a block without fluid have none.
    Vorticity,
}

/// The blocks' Z-mean of `what`, X fastest, rows from Y = 0 (blocks without fluid: `None`).
pub fn z_mean_slice(f: &CoarseField, what: CoarseMap) -> Slice {
    let (nx, ny) = (f.dims[0], f.dims[1]);
    let pitch = 2.0 * f.block as f64;
    let value = |x: usize, y: usize| match what {
        CoarseMap::Velocity(a) => f.z_mean(x, y, a),
        CoarseMap::Density => f.z_mean_by(x, y, |i| f.density[i]),
        CoarseMap::Speed => match (f.z_mean(x, y, 0), f.z_mean(x, y, 1)) {
            (Some(u), Some(v)) => Some((u * u + v * v).sqrt()),
            _ => None,
        },
        CoarseMap::Vorticity => {
            if x == 0 || y == 0 || x + 1 >= nx || y + 1 >= ny {
                return None;
            }
            let dv = f.z_mean(x + 1, y, 1)? - f.z_mean(x - 1, y, 1)?;
            let du = f.z_mean(x, y + 1, 0)? - f.z_mean(x, y - 1, 0)?;
            f.z_mean(x, y, 0)?;
            Some((dv - du) / (2.0 * pitch))
        }
    };
    Slice { nx, ny, values: (0..ny).flat_map(|y| (0..nx).map(move |x| (x, y))).map(|(x, y)| value(x, y)).collect() }
}

/// PNG maps of the Z-averaged speed and transverse velocity u_Y (blocks without fluid grey).
/// Returns the value ranges of the two maps.
pub fn write_pngs(speed: &Path, transverse: &Path, f: &CoarseField) -> std::io::Result<((f64, f64), (f64, f64))> {
    Ok((write_png(speed, &z_mean_slice(f, CoarseMap::Speed), false)?, write_png(transverse, &z_mean_slice(f, CoarseMap::Velocity(1)), true)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block field with u = (a·y, b·x) has vorticity b − a everywhere inside; the speed and
    /// density maps are the Z means; an empty block and the edges have no vorticity.
    #[test]
    fn the_z_mean_maps_of_a_linear_shear_field() {
        let (nx, ny, nz, block) = (6, 5, 2, 2);
        let (a, b) = (0.003, -0.001);
        let pitch = 2.0 * block as f64;
        let mut velocity = Vec::new();
        let mut density = Vec::new();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    // Z alternates ±0.01 in u_X around the mean, which the map averages out
                    let wobble = if z == 0 { 0.01 } else { -0.01 };
                    velocity.push(Some([a * pitch * y as f64 + wobble, b * pitch * x as f64, 0.0]));
                    density.push(Some(0.2 + 0.1 * z as f64));
                }
            }
        }
        let mut f = CoarseField { block, dims: [nx, ny, nz], density, velocity };
        let empty = f.index(4, 3, 0);
        let empty_top = f.index(4, 3, 1);
        (f.velocity[empty], f.density[empty], f.velocity[empty_top], f.density[empty_top]) = (None, None, None, None);
        let w = z_mean_slice(&f, CoarseMap::Vorticity);
        assert!((w.values[2 + nx * 2].unwrap() - (b - a)).abs() < 1e-15, "{:?}", w.values[2 + nx * 2]);
        assert_eq!(w.values[0], None);
        assert_eq!(w.values[3 + nx * 3], None, "next to the empty block");
        assert_eq!(w.values[4 + nx * 3], None, "the empty block");
        let d = z_mean_slice(&f, CoarseMap::Density);
        assert!((d.values[1].unwrap() - 0.25).abs() < 1e-15);
        let s = z_mean_slice(&f, CoarseMap::Speed);
        let (u, v) = (a * pitch * 2.0, b * pitch * 3.0);
        assert!((s.values[3 + nx * 2].unwrap() - (u * u + v * v).sqrt()).abs() < 1e-15);
    }
}
