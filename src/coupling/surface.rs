//! The surface of an MPS body as the fluid sees it (seed 000 §2.4.1: "surface particles and
//! their polygon connectivity, built beforehand"): in 2D a closed polygon of surface particles
//! per body, built once from the reference configuration.
//!
//! * A **surface particle** is one of the body's particles with an empty axis neighbour site
//!   (the bodies are lattice samples with spacing l₀).
//! * Particles are centres of cells of size l₀, so the material surface lies l₀/2 outside the
//!   outer particles. Each surface particle carries the **offset** from its reference position
//!   to the closest point of the body's reference shape (a box corner for a corner particle, the
//!   circle for a disc); the offset turns with the particle's rotation, so the vertex of the
//!   deformed surface is x_i + R_i·o_i. The polygon then has the body's true size (a disc of
//!   radius R is a polygon inscribed in the circle of radius R) instead of R − l₀/2.
//! * The connectivity: surface particles in order of their angle about the centroid of the
//!   surface points, counter-clockwise — correct for star-shaped bodies (boxes, discs, flaps,
//!   the fold section); the builder checks that the result is a simple polygon and refuses
//!   the body otherwise.
//! * In 3D the surface particles and their offsets are built the same way (six axis
//!   neighbours), without connectivity: method 2 needs only the surface points (to calibrate
//!   its level set); method 1's triangles are not built yet, and it refuses 3D bodies.

use crate::solid::Particles;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// The reference shape of a body (physical units), used to place the surface points.
#[derive(Clone, Debug, PartialEq)]
pub enum ReferenceShape {
    /// Axis-aligned box [min, max].
    Box { min: DVec3, max: DVec3 },
    /// Disc (2D; a cylinder along z in 3D) of `radius` about `centre`.
    Disc { centre: DVec3, radius: f64 },
    /// Sphere (3D) of `radius` about `centre`.
    Ball { centre: DVec3, radius: f64 },
    /// 3D: the shape of the particle sample itself — each surface particle stands for the
    /// point half a spacing out towards each of its empty axis neighbours (the faces, edges
    /// and corners of its cell), e.g. the 3D vocal fold, whose sections shift along its length.
    Sampled,
    /// A closed polygon (2D, x–y; the last vertex joins the first), e.g. the vocal-fold section
    /// of [`crate::solid::fold::FoldSection::outline`] with its arcs cut finely.
    Outline(Vec<DVec3>),
}

impl ReferenceShape {
    /// The point of the shape's boundary that the surface particle at `x` stands for; `None`
    /// when `x` is not within a spacing of the boundary (the particles are not a sample of
    /// this shape).
    fn surface_point(&self, x: DVec3, spacing: f64) -> Option<DVec3> {
        match self {
            ReferenceShape::Box { min, max } => {
                // Every coordinate within half a spacing of a face is pushed onto it (corner
                // particles go to the corner).
                let mut p = x;
                let reach = 0.5 * spacing * (1.0 + 1e-6);
                for a in 0..3 {
                    if x[a] - min[a] <= reach {
                        p[a] = min[a];
                    } else if max[a] - x[a] <= reach {
                        p[a] = max[a];
                    }
                }
                if p == x {
                    return None;
                }
                Some(p)
            }
            ReferenceShape::Disc { centre, radius } => {
                let mut d = x - *centre;
                d.z = 0.0;
                ((d.length() - radius).abs() <= spacing).then(|| *centre + d.normalize_or(DVec3::X) * *radius)
            }
            ReferenceShape::Sampled => None,
            ReferenceShape::Ball { centre, radius } => {
                let d = x - *centre;
                ((d.length() - radius).abs() <= spacing).then(|| *centre + d.normalize_or(DVec3::X) * *radius)
            }
            ReferenceShape::Outline(v) => {
                // the nearest point of the polygon's edges
                let n = v.len();
                let p = DVec3::new(x.x, x.y, 0.0);
                let nearest = (0..n)
                    .map(|i| {
                        let (a, b) = (DVec3::new(v[i].x, v[i].y, 0.0), DVec3::new(v[(i + 1) % n].x, v[(i + 1) % n].y, 0.0));
                        let ab = b - a;
                        let t = if ab.length_squared() > 0.0 { ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
                        a + t * ab
                    })
                    .min_by(|a, b| (*a - p).length_squared().total_cmp(&(*b - p).length_squared()))?;
                ((nearest - p).length() <= spacing).then_some(DVec3::new(nearest.x, nearest.y, x.z))
            }
        }
    }
}

/// Why a surface could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SurfaceError {
    #[error("body {body}: fewer than 3 surface particles")]
    TooFew { body: u16 },
    #[error(
        "body {body}: the surface particles sorted by angle about the centroid do not form a simple polygon (edges {a} and {b} cross); the body is not star-shaped about its centroid"
    )]
    NotSimple { body: u16, a: usize, b: usize },
    #[error("body {body}: a body must be at least two particles thick everywhere for a surface polygon (particle {particle} is surface on two opposite sides)")]
    TooThin { body: u16, particle: usize },
    #[error(
        "body {body}: surface particle {particle} lies more than a spacing inside the body's reference shape (the particles are not a sample of that shape)"
    )]
    NotOnShape { body: u16, particle: usize },
}

/// The closed surface polygon of one body (2D), or its surface particles (3D).
#[derive(Clone, Debug)]
pub struct BodySurface {
    pub body: u16,
    /// Surface particles, counter-clockwise in 2D; in index order in 3D.
    pub particles: Vec<usize>,
    /// Reference offsets o_i from each surface particle to its surface point.
    pub offsets: Vec<DVec3>,
}

impl BodySurface {
    /// Builds the polygon (2D) or the surface particles (3D) of `body` from the reference
    /// configuration.
    pub fn build(p: &Particles, body: u16, shape: &ReferenceShape) -> Result<Self, SurfaceError> {
        let l0 = p.spacing;
        let dim = p.dim;
        let members: Vec<usize> = (0..p.len()).filter(|&i| p.body[i] == body).collect();
        let Some(&first) = members.first() else { return Err(SurfaceError::TooFew { body }) };
        let origin = p.reference[first];
        let key = |x: DVec3| {
            let k = ((x - origin) / l0).round();
            [k.x as i64, k.y as i64, if dim == 3 { k.z as i64 } else { 0 }]
        };
        let mut sites: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for &i in &members {
            sites.entry(key(p.reference[i])).or_default().push(i);
        }
        // Whether a particle of the body lies within l₀/2 of `q`: by distance, not by key, so
        // that a sample whose rows are sheared by a fraction of l₀ (the 3D fold, whose sections
        // shift along its length) sees its true neighbours wherever the rounding of the keys
        // jumps.
        let occupied = |q: DVec3| {
            let k = key(q);
            let near =
                |d: [i64; 3]| sites.get(&[k[0] + d[0], k[1] + d[1], k[2] + d[2]]).is_some_and(|v| v.iter().any(|&j| (p.reference[j] - q).length() < 0.5 * l0));
            let zs: &[i64] = if dim == 3 { &[-1, 0, 1] } else { &[0] };
            // the site's own key first: where a particle sits, it is almost always there
            near([0, 0, 0]) || zs.iter().any(|&dz| (-1..=1).any(|dy| (-1..=1).any(|dx| near([dx, dy, dz]))))
        };
        let empty_at = |x: DVec3, a: usize, s: i64| {
            let mut q = x;
            q[a] += s as f64 * l0;
            !occupied(q)
        };
        // (the polygon's need: in 3D, which has no connectivity, a one-particle sheet is fine)
        let too_thin = |i: usize| dim == 2 && (0..dim).any(|a| empty_at(p.reference[i], a, 1) && empty_at(p.reference[i], a, -1));
        if let Some(&i) = members.par_iter().find_first(|&&i| too_thin(i)) {
            return Err(SurfaceError::TooThin { body, particle: i });
        }
        let on_surface = |i: usize| (0..dim).any(|a| empty_at(p.reference[i], a, 1) || empty_at(p.reference[i], a, -1));
        let surface: Vec<usize> = members.par_iter().copied().filter(|&i| on_surface(i)).collect();
        if surface.len() < dim + 1 {
            return Err(SurfaceError::TooFew { body });
        }
        let points: Vec<Option<DVec3>> = surface
            .par_iter()
            .map(|&i| {
                let x = p.reference[i];
                match shape {
                    ReferenceShape::Sampled => {
                        let mut o = DVec3::ZERO;
                        for a in 0..dim {
                            for s in [1i64, -1] {
                                if empty_at(x, a, s) {
                                    o[a] += 0.5 * l0 * s as f64;
                                }
                            }
                        }
                        Some(x + o)
                    }
                    _ => shape.surface_point(x, l0),
                }
            })
            .collect();
        if let Some(k) = points.iter().position(Option::is_none) {
            return Err(SurfaceError::NotOnShape { body, particle: surface[k] });
        }
        let points: Vec<DVec3> = points.into_iter().flatten().collect();
        if dim == 3 {
            let offsets = surface.iter().zip(&points).map(|(&i, x)| *x - p.reference[i]).collect();
            return Ok(BodySurface { body, particles: surface, offsets });
        }
        let centroid = points.iter().copied().sum::<DVec3>() / points.len() as f64;
        let mut order: Vec<usize> = (0..surface.len()).collect();
        let angle = |k: usize| (points[k].y - centroid.y).atan2(points[k].x - centroid.x);
        order.sort_by(|&a, &b| angle(a).total_cmp(&angle(b)).then(surface[a].cmp(&surface[b])));
        let particles: Vec<usize> = order.iter().map(|&k| surface[k]).collect();
        let offsets: Vec<DVec3> = order.iter().map(|&k| points[k] - p.reference[surface[k]]).collect();
        let s = BodySurface { body, particles, offsets };
        let verts: Vec<[f64; 2]> = order.iter().map(|&k| [points[k].x, points[k].y]).collect();
        if let Some((a, b)) = first_crossing(&verts) {
            return Err(SurfaceError::NotSimple { body, a, b });
        }
        Ok(s)
    }

    /// Surface points in the reference configuration, X_i + o_i (physical units).
    pub fn reference_points(&self, p: &Particles) -> Vec<DVec3> {
        self.particles.iter().zip(&self.offsets).map(|(&i, o)| p.reference[i] + *o).collect()
    }

    /// Current surface points x_i + R_i·o_i (physical units).
    pub fn points(&self, p: &Particles) -> Vec<DVec3> {
        self.particles.iter().zip(&self.offsets).map(|(&i, o)| p.position[i] + DMat3::from_quat(p.rotation[i]) * *o).collect()
    }

    /// Current velocities of the surface points, v_i + ω_i × R_i·o_i.
    pub fn velocities(&self, p: &Particles) -> Vec<DVec3> {
        self.particles.iter().zip(&self.offsets).map(|(&i, o)| p.velocity[i] + p.spin[i].cross(DMat3::from_quat(p.rotation[i]) * *o)).collect()
    }
}

/// The first pair of non-adjacent edges of the closed polygon that intersect.
fn first_crossing(v: &[[f64; 2]]) -> Option<(usize, usize)> {
    let n = v.len();
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    for a in 0..n {
        for b in a + 2..n {
            if a == 0 && b == n - 1 {
                continue;
            }
            let (p1, p2, q1, q2) = (v[a], v[(a + 1) % n], v[b], v[(b + 1) % n]);
            let (d1, d2) = (cross(q1, q2, p1), cross(q1, q2, p2));
            let (d3, d4) = (cross(p1, p2, q1), cross(p1, p2, q2));
            if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
                return Some((a, b));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solid::particles::{sample_ball, sample_box};

    fn body(points: &[DVec3], l0: f64) -> Particles {
        let mut p = Particles::new(2, l0);
        for &x in points {
            p.push(x, 1.0, 0, 0, false);
        }
        p
    }

    fn polygon_area(v: &[DVec3]) -> f64 {
        let n = v.len();
        0.5 * (0..n).map(|k| v[k].x * v[(k + 1) % n].y - v[(k + 1) % n].x * v[k].y).sum::<f64>()
    }

    #[test]
    fn a_box_surface_has_the_box_corners_and_area() {
        let (lo, hi) = (DVec3::new(0.3, 0.1, 0.0), DVec3::new(1.3, 0.5, 0.0));
        let p = body(&sample_box(2, lo, hi, 0.05), 0.05);
        let s = BodySurface::build(&p, 0, &ReferenceShape::Box { min: lo, max: hi }).unwrap();
        // 20 × 8 particles: 2·20 + 2·8 − 4 surface particles.
        assert_eq!(s.particles.len(), 52);
        let pts = s.points(&p);
        assert!((polygon_area(&pts) - 0.4).abs() < 1e-12, "counter-clockwise, exact area: {}", polygon_area(&pts));
        for c in [lo, hi, DVec3::new(hi.x, lo.y, 0.0), DVec3::new(lo.x, hi.y, 0.0)] {
            assert!(pts.iter().any(|q| (*q - c).length() < 1e-12), "corner {c} is a vertex");
        }
    }

    /// The vocal-fold section of seed Fig. 3.9 as a coupled body: its surface particles land on
    /// the outline and the surface polygon encloses the section's area.
    #[test]
    fn a_vocal_fold_surface_lies_on_its_outline() {
        use crate::solid::fold::FoldSection;
        let f = FoldSection::default();
        let l0 = 0.0042;
        let fold = f.sample(l0, 2.0 * l0);
        let mut p = Particles::new(2, l0);
        for (q, side) in fold.position.iter().zip(&fold.side) {
            if *side > 0 {
                p.push(DVec3::new(q[0], q[1], 0.0), 1.043, 0, 0, false);
            }
        }
        let outline: Vec<DVec3> = f.outline(64).iter().map(|q| DVec3::new(q[0], q[1], 0.0)).collect();
        let s = BodySurface::build(&p, 0, &ReferenceShape::Outline(outline.clone())).unwrap();
        let pts = s.points(&p);
        let on_outline = |q: DVec3| {
            let n = outline.len();
            (0..n).any(|i| {
                let (a, b) = (outline[i], outline[(i + 1) % n]);
                let ab = b - a;
                let t = ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                (a + t * ab - q).length() < 1e-12
            })
        };
        assert!(pts.iter().all(|q| on_outline(*q)));
        let area = polygon_area(&pts);
        assert!((area / f.area() - 1.0).abs() < 0.01, "surface polygon {area} vs section {}", f.area());
    }

    #[test]
    fn a_disc_surface_is_inscribed_in_the_circle_and_follows_a_rigid_rotation() {
        let (c, r, l0) = (DVec3::new(1.0, 1.0, 0.0), 0.3, 0.02);
        let mut p = body(&sample_ball(2, c, r, l0), l0);
        let s = BodySurface::build(&p, 0, &ReferenceShape::Disc { centre: c, radius: r }).unwrap();
        let pts = s.points(&p);
        for q in &pts {
            assert!(((*q - c).length() - r).abs() < 1e-12);
        }
        let area = polygon_area(&pts);
        let exact = std::f64::consts::PI * r * r;
        assert!(area > 0.0 && (exact - area) / exact < 2e-3, "{area} vs {exact}");
        // Rotate the body rigidly by 0.7 rad about c with angular velocity ω: the surface points
        // stay on the circle and move with ω × (x − c).
        let (theta, omega) = (0.7, 2.0);
        let q = glam::DQuat::from_rotation_z(theta);
        for i in 0..p.len() {
            let d = q * (p.reference[i] - c);
            p.position[i] = c + d;
            p.rotation[i] = q;
            p.spin[i] = DVec3::new(0.0, 0.0, omega);
            p.velocity[i] = DVec3::new(0.0, 0.0, omega).cross(d);
        }
        for (x, v) in s.points(&p).iter().zip(s.velocities(&p)) {
            assert!(((*x - c).length() - r).abs() < 1e-12);
            assert!((v - DVec3::new(0.0, 0.0, omega).cross(*x - c)).length() < 1e-12);
        }
    }

    #[test]
    fn bodies_that_cannot_have_a_polygon_are_refused() {
        let l0 = 0.1;
        let line = body(&sample_box(2, DVec3::ZERO, DVec3::new(1.0, 0.1, 0.0), l0), l0);
        let e = BodySurface::build(&line, 0, &ReferenceShape::Box { min: DVec3::ZERO, max: DVec3::new(1.0, 0.1, 0.0) }).unwrap_err();
        assert!(matches!(e, SurfaceError::TooThin { .. }), "{e}");
        // An L-shaped body is not a sample of its bounding box: its inner corner's surface
        // particles lie deep inside the box.
        let mut pts = sample_box(2, DVec3::ZERO, DVec3::new(2.0, 0.3, 0.0), l0);
        pts.extend(sample_box(2, DVec3::new(0.0, 0.3, 0.0), DVec3::new(0.3, 2.0, 0.0), l0));
        let ell = body(&pts, l0);
        let e = BodySurface::build(&ell, 0, &ReferenceShape::Box { min: DVec3::ZERO, max: DVec3::new(2.0, 2.0, 0.0) }).unwrap_err();
        assert!(matches!(e, SurfaceError::NotOnShape { .. }), "{e}");
        // A bow tie (the order of a non-star-shaped body) is caught by the simplicity check.
        assert_eq!(first_crossing(&[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]), Some((0, 2)));
        assert_eq!(first_crossing(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]), None);
    }
}
