//! The lattice's grip on a thin plate: a rigid plate at zero incidence in a uniform stream, the
//! Wall flap's cross-section at its resolution (0.06 cm thick at Δx = 0.05 cm: 1.2 cells), moved
//! across the rows of lattice nodes by a fraction of a cell. By symmetry the air lifts it only
//! where the lattice breaks the symmetry: the lift measures the error of the walls' sub-cell
//! position, which a flap bending across the rows feels as a force that depends on where it is.
//!
//! Placed symmetrically between the node rows (centre on y = 3 cm, half-way between two rows,
//! in a channel symmetric about it) the plate feels no lift to round-off. A quarter cell off,
//! a 1.2-cell plate holds a single row of nodes; that row is a ghost serving the side its
//! nearer wall faces, and the other side's fluid nodes read the side ghosts of
//! [`crate::fluid::thin_wall`] in its place. Both couplings share this fluid wall (method 2's
//! level set is a ghost-node wall too). With the one-sided stencils that came before the side
//! ghosts, which carry no wall velocity (no no-slip on the far side), the air lifted the plate
//! by L/D = 1.51 (method 1) and 12.8 (method 2) a quarter cell off; with side ghosts, 0.019 and
//! 0.005 (README, "The lattice's grip on the flap").
//!
//! Twice as thick (2.4 cells) and a quarter cell off, method 1's plate keeps a lift (L/D 0.59,
//! method 2's 0.055) that the thin wall does not make: it depends on where the plate's blunt
//! ends lie between the node columns (moved 0.3 and 0.5 cells downstream: L/D +0.48 and −0.14),
//! the sub-cell error of the ghost walls at the ends' corners.
//!
//! Units: cgs (the flap's air: ρ = 1.18·10⁻³ g/cm³, μ = 1.82·10⁻⁴ g/(cm·s), U = 51.3 cm/s,
//! Re_L ≈ 1330 on the 4 cm plate), forces per unit depth (dyn/cm).

use crate::scene::coupled::CoupledScene;

/// Lattice spacing of the flap scenes (cm).
pub const DX: f64 = 0.05;

/// One placement of the plate.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct PlateCase {
    /// `"weak"` or `"momentum_conserving"`.
    pub method: &'static str,
    /// Thickness in lattice cells (the flap: 1.2).
    pub thickness_cells: f64,
    /// Centre line above the symmetric position, in cells.
    pub offset_cells: f64,
}

/// The air's mean force on the plate over the second half of the run (dyn/cm).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct PlateForces {
    pub drag: f64,
    pub lift: f64,
    pub steps: u64,
}

/// The scene of `case`: a plate `length` cm long from x = 3 cm in a channel of `size` cm
/// (slip side walls, the plate's centre line on the channel's mid-height plus the offset), held
/// rigid by a clamp over all of it, at lattice Mach 0.1, for `duration` s.
pub fn scene(case: PlateCase, size: [f64; 2], length: f64, duration: f64) -> anyhow::Result<CoupledScene> {
    let cells = [(size[0] / DX).round() as usize, (size[1] / DX).round() as usize];
    let y0 = 0.5 * size[1] + case.offset_cells * DX;
    let h = 0.5 * case.thickness_cells * DX;
    let kernel = if case.method == "momentum_conserving" { "kernel_radius = 1.0\n" } else { "" };
    let text = format!(
        r#"name = "thin_plate"
units = "cgs"
[domain]
lattice = "d2q21"
size = [{sx}, {sy}]
cells = [{nx}, {ny}]
[gas]
model = "monatomic"
density = 1.18e-3
viscosity = 1.82e-4
sound_speed = 34300.0
[numerics]
temperature = 0.6
mach_scaling = {{ reference_velocity = 51.3, mach = 0.1 }}
[boundaries]
x_min = {{ type = "velocity_inlet", velocity = [51.3, 0.0] }}
x_max = {{ type = "outlet" }}
y_min = {{ type = "slip" }}
y_max = {{ type = "slip" }}
[initial]
velocity = [51.3, 0.0]
[run]
duration = {duration}
[output]
snapshots = 0
vtk = false
[solid]
dimension = 2
spacing = 0.02
materials = [{{ kind = "isotropic", young = 2.5e6, poisson = 0.35, density = 0.1 }}]
bodies = [{{ min = [3.0, {ylo}], max = [{x1}, {yhi}] }}]
clamps = [{{ min = [2.9, {clo}], max = [{cx1}, {chi}] }}]
[coupling]
method = "{method}"
{kernel}"#,
        sx = size[0],
        sy = size[1],
        nx = cells[0],
        ny = cells[1],
        ylo = y0 - h,
        yhi = y0 + h,
        x1 = 3.0 + length,
        clo = y0 - h - 0.1,
        chi = y0 + h + 0.1,
        cx1 = 3.1 + length,
        method = case.method,
    );
    Ok(CoupledScene::parse(&text)?)
}

/// Runs `case` (see [`scene`]) and averages the air's force on the plate over the second half.
pub fn plate_forces(case: PlateCase, size: [f64; 2], length: f64, duration: f64) -> anyhow::Result<PlateForces> {
    let sc = scene(case, size, length, duration)?;
    let mut c = sc.build()?;
    let steps = sc.fluid.steps;
    let (mut drag, mut lift, mut n) = (0.0, 0.0, 0.0);
    for k in 0..steps {
        c.step()?;
        if 2 * k >= steps {
            let f = c.forces.total[0];
            drag += f.x;
            lift += f.y;
            n += 1.0;
        }
    }
    Ok(PlateForces { drag: drag / n, lift: lift / n, steps })
}

/// The validation's cases: both methods, the flap's 1.2 cells and twice that, on the symmetric
/// position and a quarter cell off; method 1 also half a cell off (a single node row on the
/// centre line, equally far from both walls).
pub fn cases() -> Vec<PlateCase> {
    let mut out = Vec::new();
    for method in ["weak", "momentum_conserving"] {
        for thickness_cells in [1.2, 2.4] {
            let offsets: &[f64] = if method == "weak" { &[0.0, 0.25, 0.5] } else { &[0.0, 0.25] };
            for &offset_cells in offsets {
                out.push(PlateCase { method, thickness_cells, offset_cells });
            }
        }
    }
    out
}

/// The suite's rows (a 4 cm plate in a 12 × 6 cm channel for 0.1 s, 5,400 steps each):
/// - the symmetric placements feel no lift (|L/D| ≤ 10⁻⁶, mirror symmetry);
/// - the flap's 1.2 cells off the symmetric position, and 2.4 cells half a cell off:
///   |L/D| ≤ 0.05, the thin wall held on both sides (measured ≤ 0.019; 1.2–12.8 with the
///   one-sided stencils);
/// - 2.4 cells a quarter cell off: |L/D| ≤ 1, the blunt ends' sub-cell error (module docs;
///   measured 0.59 and 0.055), a row that watches it rather than a claim that it is small.
pub fn rows() -> Vec<(String, f64, String, bool)> {
    let mut runs = Vec::new();
    for case in cases() {
        let r = plate_forces(case, [12.0, 6.0], 4.0, 0.1);
        if let Ok(f) = &r {
            println!(
                "{:20} {:.1} cells, offset {:.2} cells: drag {:.4} dyn/cm, lift {:+.4} dyn/cm, L/D {:+.3}",
                case.method,
                case.thickness_cells,
                case.offset_cells,
                f.drag,
                f.lift,
                f.lift / f.drag
            );
        }
        runs.push((case, r));
    }
    let mut out = Vec::new();
    for (case, r) in &runs {
        let label = format!("{} {:.1} cells, offset {:.2}: L/D", case.method, case.thickness_cells, case.offset_cells);
        let f = match r {
            Ok(f) => f,
            Err(e) => {
                out.push((format!("{label}: {e}"), f64::NAN, "runs".into(), false));
                continue;
            }
        };
        let ratio = f.lift / f.drag;
        if case.offset_cells == 0.0 {
            out.push((label, ratio, "|L/D| ≤ 1e-6 (mirror symmetry)".into(), ratio.abs() <= 1e-6));
        } else if case.thickness_cells > 1.2 && case.offset_cells == 0.25 {
            out.push((label, ratio, "|L/D| ≤ 1 (the blunt ends' sub-cell error)".into(), ratio.abs() <= 1.0));
        } else {
            out.push((label, ratio, "|L/D| ≤ 0.05 (the thin wall held on both sides)".into(), ratio.abs() <= 0.05));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mirror symmetry of both couplings: a 1 cm plate of the flap's thickness centred between
    /// two node rows of a channel symmetric about it feels no lift (to round-off) while the
    /// stream drags it.
    #[test]
    fn a_plate_placed_symmetrically_between_the_node_rows_feels_no_lift() {
        for method in ["weak", "momentum_conserving"] {
            let case = PlateCase { method, thickness_cells: 1.2, offset_cells: 0.0 };
            let f = plate_forces(case, [4.0, 2.0], 1.0, 0.006).unwrap();
            assert!(f.steps >= 300, "{method}: {} steps", f.steps);
            assert!(f.drag > 0.05, "{method}: drag {} dyn/cm", f.drag);
            assert!(f.lift.abs() <= 1e-6 * f.drag, "{method}: lift {:e} against drag {}", f.lift, f.drag);
        }
    }
}
