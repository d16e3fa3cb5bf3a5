//! Triangle meshes (the folds' surface from marching cubes) as legacy VTK polydata for
//! ParaView: binary big-endian float points, triangles, outward unit normals and a `body`
//! scalar per vertex.

use crate::mesh::TriangleMesh;
use std::io::{BufWriter, Write};
use std::path::Path;

pub fn write_mesh_vtk(path: &Path, m: &TriangleMesh, title: &str) -> std::io::Result<()> {
    let mut w = BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "# vtk DataFile Version 3.0\n{}\nBINARY\nDATASET POLYDATA", title.replace('\n', " "))?;
    writeln!(w, "POINTS {} float", m.positions.len())?;
    for p in &m.positions {
        for a in 0..3 {
            w.write_all(&(p[a] as f32).to_be_bytes())?;
        }
    }
    writeln!(w, "\nPOLYGONS {} {}", m.triangles.len(), 4 * m.triangles.len())?;
    for t in &m.triangles {
        w.write_all(&3i32.to_be_bytes())?;
        for i in t {
            w.write_all(&(*i as i32).to_be_bytes())?;
        }
    }
    writeln!(w, "\nPOINT_DATA {}\nNORMALS normal float", m.positions.len())?;
    for n in &m.normals {
        for a in 0..3 {
            w.write_all(&(n[a] as f32).to_be_bytes())?;
        }
    }
    if m.scalars.len() == m.positions.len() {
        writeln!(w, "\nSCALARS body float 1\nLOOKUP_TABLE default")?;
        for s in &m.scalars {
            w.write_all(&s.to_be_bytes())?;
        }
    }
    writeln!(w)?;
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{ScalarGrid, extract};
    use glam::DVec3;

    #[test]
    fn a_mesh_file_holds_its_points_triangles_and_normals() {
        let g = ScalarGrid::sample([12; 3], DVec3::ZERO, 1.0, |x| 4.0 - (x - DVec3::splat(5.5)).length());
        let mut m = extract(&g, 0.0);
        m.scalars = vec![1.0; m.positions.len()];
        let path = std::env::temp_dir().join(format!("phonation_mesh_{}.vtk", std::process::id()));
        write_mesh_vtk(&path, &m, "ball").unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains(&format!("POINTS {} float", m.positions.len())));
        assert!(text.contains(&format!("POLYGONS {} {}", m.triangles.len(), 4 * m.triangles.len())));
        // header + 12 bytes per point + 16 per triangle + 12 per normal + 4 per scalar
        let header: usize =
            ["# vtk DataFile Version 3.0\nball\nBINARY\nDATASET POLYDATA\n", &format!("POINTS {} float\n", m.positions.len())].iter().map(|s| s.len()).sum();
        let first = f32::from_be_bytes(bytes[header..header + 4].try_into().unwrap());
        assert_eq!(first, m.positions[0].x as f32);
        assert!(bytes.len() > 12 * m.positions.len() + 16 * m.triangles.len() + 16 * m.positions.len());
    }
}
