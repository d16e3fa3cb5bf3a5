//! Solid geometry seen by the fluid, in lattice units (node spacing 1, interior node `x` at
//! coordinate `x`). Every solid is a signed distance function, positive in the fluid, so that
//! the wall position is known to sub-cell accuracy ([`super::layout`] builds ghost nodes from it).

pub use super::kernel_level_set::KernelLevelSet;
pub use super::polygon::Polygon;

/// Where a point lies against a shape, as [`Shape::outside_distance_below`] answers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outside {
    /// Inside the solid (`sdf < 0`).
    Inside,
    /// Outside, at this signed distance (cells; the value of [`Shape::outside_distance`], bit
    /// for bit), below the limit asked for.
    Within(f64),
    /// Outside, at the limit asked for or farther.
    Beyond,
}

impl Outside {
    /// The answer for a distance `d` from [`Shape::outside_distance`] (None inside).
    pub fn of(d: Option<f64>, limit: f64) -> Self {
        match d {
            None => Outside::Inside,
            Some(d) if d < limit => Outside::Within(d),
            Some(_) => Outside::Beyond,
        }
    }
}

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
    /// Closed polygon in the x–y plane (a prism along z in 3D) whose vertices move with a
    /// deforming body: the wall seen by the fluid in the coupled solver ([`crate::coupling`]).
    Polygon(Polygon),
    /// The level set of a body's particles (seed 2.124): the wall of the momentum-conserving
    /// coupling ([`crate::coupling::conserving`]), shared with the coupling's exchange (a body's
    /// particles and bins are built once a step, not copied into the layout).
    KernelLevelSet(std::sync::Arc<KernelLevelSet>),
}

impl Shape {
    /// Signed distance to the surface (cells), positive outside the solid.
    #[inline]
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
            Shape::Polygon(poly) => poly.sdf([p[0], p[1]]),
            Shape::KernelLevelSet(k) => k.sdf(p),
        }
    }

    /// `None` where `p` is inside the solid (`sdf(p) < 0`), else `Some(sdf(p))` — bit for bit,
    /// at less cost than [`Self::sdf`] for a kernel level set, whose depth inside takes Newton
    /// steps ([`KernelLevelSet::outside_distance`]), and for a polygon, whose depth inside is a
    /// search for the nearest edge ([`Polygon`]).
    #[inline]
    pub fn outside_distance(&self, p: [f64; 3]) -> Option<f64> {
        match self {
            Shape::KernelLevelSet(k) => k.outside_distance(p),
            Shape::Polygon(poly) => poly.outside_distance([p[0], p[1]]),
            _ => Some(self.sdf(p)).filter(|d| !(*d < 0.0)),
        }
    }

    /// [`Self::outside_distance`] for a caller that needs the distance only below `limit`
    /// (the layout's pinch test, [`super::layout::PINCH`]): [`Outside::Within`] with the same
    /// value bit for bit where it is below `limit`, [`Outside::Beyond`] where it is not. A
    /// polygon ([`Polygon`]) then searches its edges only within `limit` of the point instead
    /// of out to its nearest edge, however far.
    /// Inlined, as `outside_distance` and `sdf` are: the layout asks it of every obstacle at every
    /// rebuilt node, where a half-space's answer is one dot product and the calls cost more
    /// (`glottis_3d`'s owners' pass 52–55 → 32–43 ms a step on 2 threads).
    #[inline]
    pub fn outside_distance_below(&self, p: [f64; 3], limit: f64) -> Outside {
        match self {
            Shape::Polygon(poly) => poly.outside_distance_below([p[0], p[1]], limit),
            _ => Outside::of(self.outside_distance(p), limit),
        }
    }

    /// A function with the sign and the zero contour of [`Self::sdf`] (positive in the fluid),
    /// cheaper where that is dear: a kernel level set's −L (one evaluation, where the depth
    /// inside takes Newton steps), the signed distance for the other shapes. For finding where
    /// a line enters the solid.
    pub fn signed_level(&self, p: [f64; 3]) -> f64 {
        match self {
            Shape::KernelLevelSet(k) => -k.level_value(p),
            _ => self.sdf(p),
        }
    }

    /// A box (lattice coordinates, min and max corners) outside which this shape contains no
    /// point and lies at least half a cell ([`super::layout::PINCH`]) from every point, so that
    /// a node there is classified as if the shape were absent; None where the shape is
    /// unbounded or not needed (the static shapes; [`super::layout::Layout::rebuilt`] then
    /// rebuilds the whole lattice).
    pub fn influence_box(&self) -> Option<([f64; 3], [f64; 3])> {
        match self {
            // L = −φ < 0 beyond r_e of every particle; `bin_box` is the particles' box grown by r_e
            Shape::KernelLevelSet(k) => {
                let (lo, hi, _) = k.bin_box();
                Some((lo.map(|x| x - 1.0), hi.map(|x| x + 1.0)))
            }
            // a prism along z
            Shape::Polygon(p) => {
                Some(([p.bounds()[0] - 1.0, p.bounds()[1] - 1.0, f64::NEG_INFINITY], [p.bounds()[2] + 1.0, p.bounds()[3] + 1.0, f64::INFINITY]))
            }
            _ => None,
        }
    }

    /// [`Self::sdf`] and [`Self::normal`] at `p` (the same values, bit for bit), a polygon's
    /// ([`Polygon`]) from one search of its edges and one crossing number.
    pub fn sdf_and_normal(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match self {
            Shape::Polygon(poly) => poly.sdf_and_normal([p[0], p[1]]),
            _ => (self.sdf(p), self.normal(p)),
        }
    }

    /// Outward unit normal (pointing into the fluid) near `p`, by central differences of the
    /// signed distance (exact for the half-space, cylinder and sphere).
    pub fn normal(&self, p: [f64; 3]) -> [f64; 3] {
        match self {
            Shape::HalfSpace { normal, .. } => return *normal,
            Shape::Polygon(poly) => return poly.normal([p[0], p[1]]),
            Shape::KernelLevelSet(k) => return k.normal(p),
            _ => {}
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

impl Obstacle {
    /// Wall velocity (c units) at the wall point `p`: the polygon's vertex velocities
    /// interpolated along the nearest edge, else the obstacle's uniform velocity.
    pub fn velocity_at(&self, p: [f64; 3]) -> [f64; 3] {
        match &self.shape {
            Shape::Polygon(poly) => poly.velocity_at([p[0], p[1]]),
            Shape::KernelLevelSet(k) => k.velocity_at(p),
            _ => self.velocity,
        }
    }
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

    #[test]
    fn polygon_sdf_normal_and_wall_velocity() {
        // Unit square [0, 2]², counter-clockwise, the right edge moving up.
        let sq = Polygon::new(vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]], vec![[0.0; 3], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0; 3]]);
        assert!((sq.signed_area() - 4.0).abs() < 1e-12);
        let s = Shape::Polygon(sq.clone());
        assert!((s.sdf([1.0, 1.0, 0.0]) + 1.0).abs() < 1e-12);
        assert!((s.sdf([1.5, 1.0, 0.0]) + 0.5).abs() < 1e-12);
        assert!((s.sdf([3.0, 1.0, 0.0]) - 1.0).abs() < 1e-12);
        assert!((s.sdf([1.0, -0.25, 0.0]) - 0.25).abs() < 1e-12);
        let n = s.normal([1.8, 1.0, 0.0]);
        assert!((n[0] - 1.0).abs() < 1e-12 && n[1].abs() < 1e-12);
        let n = s.normal([1.0, 0.1, 0.0]);
        assert!((n[1] + 1.0).abs() < 1e-12);
        // The bottom edge's velocity goes from 0 to 1 along it.
        let o = Obstacle { shape: s, velocity: [0.0; 3], temperature: None };
        assert!((o.velocity_at([1.5, 0.0, 0.0])[1] - 0.75).abs() < 1e-12);
        assert!((o.velocity_at([2.0, 1.0, 0.0])[1] - 1.0).abs() < 1e-12);
        // A regular 64-gon of radius 5 agrees with the circle's signed distance to O(h²).
        let k = 64;
        let verts: Vec<[f64; 2]> = (0..k)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / k as f64;
                [10.0 + 5.0 * a.cos(), 10.0 + 5.0 * a.sin()]
            })
            .collect();
        let poly = Shape::Polygon(Polygon::new(verts, vec![[0.0; 3]; k]));
        let disc = Shape::Cylinder { center: [10.0, 10.0, 0.0], radius: 5.0 };
        for p in [[12.0, 11.0, 0.0], [14.9, 10.3, 0.0], [6.0, 12.5, 0.0], [5.5, 13.0, 0.0], [10.0, 16.0, 0.0]] {
            assert!((poly.sdf(p) - disc.sdf(p)).abs() < 5.0 * (1.0 - (std::f64::consts::PI / k as f64).cos()) + 1e-12, "{p:?}");
        }
        // Beyond the bounding box: the distance to the box, positive and at most the true distance.
        let far = [2.0, 3.0, 0.0];
        assert!(poly.sdf(far) > 0.0 && poly.sdf(far) <= disc.sdf(far));
    }
}
