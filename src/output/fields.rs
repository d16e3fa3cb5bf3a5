//! Scalar fields of the flow on the interior nodes (a z-mid slice in 3D), in physical units.

use crate::fluid::FluidSolver;
use crate::scene::schema::Field;
use crate::units::Units;

/// A 2D scalar image: `values[x + nx*y]`, `None` inside solids.
pub struct Slice {
    pub nx: usize,
    pub ny: usize,
    pub values: Vec<Option<f64>>,
}

/// Samples `field` on the z = n_z/2 plane.
pub fn slice(s: &FluidSolver, units: &Units, field: Field) -> Slice {
    let g = &s.layout.grid;
    let (nx, ny) = (g.n[0], g.n[1]);
    let z = (g.n[2] / 2) as i64;
    let kind = &s.layout.kind;
    let m_at = |x: i64, y: i64| {
        let node = g.index([x, y, z]);
        (kind[node] == crate::fluid::layout::NodeKind::Fluid).then(|| s.macro_at(node))
    };
    let mut values = Vec::with_capacity(nx * ny);
    for y in 0..ny as i64 {
        for x in 0..nx as i64 {
            let v = match field {
                Field::Density => m_at(x, y).map(|m| units.density_to_physical(m.rho)),
                Field::Speed => m_at(x, y).map(|m| units.velocity_to_physical(m.speed2().sqrt())),
                Field::Pressure => m_at(x, y).map(|m| units.gauge_pressure_to_physical(m.pressure())),
                Field::Temperature => m_at(x, y).map(|m| m.theta / units.theta0),
                Field::Vorticity => {
                    // ω_z = ∂v/∂x − ∂u/∂y, central differences where both neighbours are fluid.
                    let c = |x: i64, y: i64| if x >= 0 && y >= 0 && x < nx as i64 && y < ny as i64 { m_at(x, y) } else { None };
                    match (m_at(x, y), c(x + 1, y), c(x - 1, y), c(x, y + 1), c(x, y - 1)) {
                        (Some(_), Some(e), Some(w), Some(n), Some(so)) => {
                            let w_lat = 0.5 * (e.u[1] - w.u[1]) - 0.5 * (n.u[0] - so.u[0]);
                            Some(w_lat / units.time())
                        }
                        (Some(_), ..) => Some(0.0),
                        _ => None,
                    }
                }
            };
            values.push(v);
        }
    }
    Slice { nx, ny, values }
}

/// What [`slice()`] computes for `field`, as the GPU slice kernel takes it
/// ([`crate::gpu::slice::PlaneMap`]): the lattice quantity, its map to scene units, and the
/// colour map (signed for pressure and vorticity, as the PNG snapshots).
pub fn plane_map(field: Field, units: &Units) -> crate::gpu::slice::PlaneMap {
    use crate::gpu::slice::{PlaneMap, Quantity};
    let (quantity, scale, offset) = match field {
        Field::Density => (Quantity::Density, units.density_to_physical(1.0), 0.0),
        Field::Speed => (Quantity::Speed, units.velocity_to_physical(1.0), 0.0),
        Field::Pressure => (Quantity::Pressure, units.pressure_unit(), units.theta0),
        Field::Temperature => (Quantity::Temperature, 1.0 / units.theta0, 0.0),
        Field::Vorticity => (Quantity::Vorticity, 1.0 / units.time(), 0.0),
    };
    PlaneMap { quantity, scale, offset, signed: matches!(field, Field::Pressure | Field::Vorticity) }
}
