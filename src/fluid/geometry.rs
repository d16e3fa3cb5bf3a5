//! Solid geometry seen by the fluid, in lattice units (node spacing 1, interior node `x` at
//! coordinate `x`). Every solid is a signed distance function, positive in the fluid, so that
//! the wall position is known to sub-cell accuracy ([`super::layout`] builds ghost nodes from it).

/// A solid shape. Signed distance `sdf` > 0 in the fluid, < 0 inside the solid.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Solid where `normal·x < offset`; `normal` (unit) points into the fluid.
    HalfSpace { normal: [f64; 3], offset: f64 },
    /// Infinite cylinder along z (a disc in 2D).
    Cylinder { center: [f64; 3], radius: f64 },
    /// Sphere (3D).
    Sphere { center: [f64; 3], radius: f64 },
    /// Axis-aligned box [min, max].
    Cuboid { min: [f64; 3], max: [f64; 3] },
}

impl Shape {
    /// Signed distance to the surface (cells), positive outside the solid.
    pub fn sdf(&self, p: [f64; 3]) -> f64 {
        match self {
            Shape::HalfSpace { normal, offset } => dot(*normal, p) - offset,
            Shape::Cylinder { center, radius } => {
                let dx = p[0] - center[0];
                let dy = p[1] - center[1];
                (dx * dx + dy * dy).sqrt() - radius
            }
            Shape::Sphere { center, radius } => norm(sub(p, *center)) - radius,
            Shape::Cuboid { min, max } => {
                let mut q = [0.0; 3];
                let mut inside = f64::NEG_INFINITY;
                for a in 0..3 {
                    let c = 0.5 * (min[a] + max[a]);
                    let h = 0.5 * (max[a] - min[a]);
                    let d = (p[a] - c).abs() - h;
                    q[a] = d.max(0.0);
                    inside = inside.max(d);
                }
                norm(q) + inside.min(0.0)
            }
        }
    }

    /// Outward unit normal (pointing into the fluid) near `p`, by central differences of the
    /// signed distance (exact for the half-space, cylinder and sphere).
    pub fn normal(&self, p: [f64; 3]) -> [f64; 3] {
        if let Shape::HalfSpace { normal, .. } = self {
            return *normal;
        }
        let h = 1e-4;
        let mut g = [0.0; 3];
        for a in 0..3 {
            let mut pp = p;
            let mut pm = p;
            pp[a] += h;
            pm[a] -= h;
            g[a] = (self.sdf(pp) - self.sdf(pm)) / (2.0 * h);
        }
        if let Shape::Cylinder { .. } = self {
            g[2] = 0.0;
        }
        let n = norm(g);
        if n > 0.0 { [g[0] / n, g[1] / n, g[2] / n] } else { [0.0, 0.0, 0.0] }
    }
}

/// A solid with the wall velocity (c units) and, for an isothermal wall, its temperature θ.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    pub shape: Shape,
    pub velocity: [f64; 3],
    /// `Some(θ_w)`: isothermal wall; `None`: adiabatic (zero normal temperature gradient).
    pub temperature: Option<f64>,
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn cylinder_sdf_and_normal() {
        let s = Shape::Cylinder { center: [10.0, 10.0, 0.0], radius: 3.0 };
        assert!((s.sdf([14.0, 10.0, 5.0]) - 1.0).abs() < 1e-12);
        let n = s.normal([14.0, 10.0, 0.0]);
        assert!((n[0] - 1.0).abs() < 1e-6 && n[1].abs() < 1e-6);
        let b = Shape::Cuboid { min: [0.0; 3], max: [2.0; 3] };
        assert!((b.sdf([1.0, 1.0, 1.0]) + 1.0).abs() < 1e-12);
        assert!((b.sdf([3.0, 1.0, 1.0]) - 1.0).abs() < 1e-12);
    }
}
