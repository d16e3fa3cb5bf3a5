//! What a voice scientist reads from a coupled glottis (seed 000 §3.4.1, Figs. 3.12–3.16): the
//! glottal gap and area, the glottal volume flow through the narrowest section, and the lateral
//! displacement of the lower and upper margins of the medial surface.
//!
//! The two folds are bodies of a [`CoupledSolver`] on either side of the glottal mid-line x = x₀
//! (left below, right above; the flow runs along +y from the trachea to the vocal tract).
//! Units: the scene's (cgs: cm, s); in 2D a quantity per unit fold length is turned into the
//! fold's by multiplying with its `length` (the seed's 1.4 cm), so that areas are cm² and flows
//! cm³/s as in the two-mass model and the literature.

use super::solver::CoupledSolver;
use super::surface::BodySurface;
use crate::fluid::layout::NodeKind;
use crate::solid::Particles;
use glam::DVec3;

/// The glottis of a coupled 2D scene: which bodies are the folds and where their margins are.
#[derive(Clone, Debug)]
pub struct Glottis {
    /// Indices into [`CoupledSolver::bodies`] of the left (x < x₀) and right (x > x₀) folds.
    pub left: usize,
    pub right: usize,
    /// Glottal mid-line x₀ (scene units).
    pub mid_line: f64,
    /// Fold length along the glottis (cm): 2D per-unit-length flows and gaps are multiplied by it.
    pub length: f64,
    /// Surface particles marking the lower (inferior) and upper (superior) margins of the
    /// medial surface: [left, right] each.
    pub lower_margin: [usize; 2],
    pub upper_margin: [usize; 2],
}

/// One sample of the glottis.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GlottalSample {
    /// Smallest horizontal distance between the two folds' surfaces (scene units); ≤ 0 when
    /// they touch (closed).
    pub gap: f64,
    /// Height y of the narrowest section (scene units).
    pub narrowest_y: f64,
    /// Glottal area A_g = max(gap, 0) × length (cm²).
    pub area: f64,
    /// Volume flow through the narrowest section, ∫ ρu_y dx / ρ₀ × length (cm³/s); exactly 0
    /// when that section holds no fluid node (closed at the lattice's resolution).
    pub flow: f64,
    /// Lateral (opening) displacement of the lower and upper margins, mean of both folds.
    pub lower_margin: f64,
    pub upper_margin: f64,
}

impl Glottis {
    /// The glottis between the bodies `left` and `right` of `c` about x = `mid_line`; the
    /// margins are the surface particles nearest the reference points `lower` and `upper` of
    /// the right fold's medial surface (mirrored for the left one).
    pub fn new(c: &CoupledSolver, left: usize, right: usize, mid_line: f64, length: f64, lower: DVec3, upper: DVec3) -> Self {
        let p = &c.solid.particles;
        let nearest = |s: &BodySurface, q: DVec3| {
            *s.particles
                .iter()
                .min_by(|&&a, &&b| (p.reference[a] - q).length_squared().total_cmp(&(p.reference[b] - q).length_squared()))
                .expect("a surface has particles")
        };
        let mirror = |q: DVec3| DVec3::new(2.0 * mid_line - q.x, q.y, q.z);
        let (ls, rs) = (&c.bodies[left].surface, &c.bodies[right].surface);
        Glottis {
            left,
            right,
            mid_line,
            length,
            lower_margin: [nearest(ls, mirror(lower)), nearest(rs, lower)],
            upper_margin: [nearest(ls, mirror(upper)), nearest(rs, upper)],
        }
    }

    /// Samples the glottis of `c` now.
    pub fn sample(&self, c: &CoupledSolver) -> GlottalSample {
        let p = &c.solid.particles;
        let left = c.bodies[self.left].surface.points(p);
        let right = c.bodies[self.right].surface.points(p);
        let (gap, y) = narrowest(&left, &right);
        let u = &c.units;
        // the lattice row through the narrowest section, the fluid nodes between the folds
        let row = u.position_to_lattice(y).round() as i64;
        let g = &c.fluid.layout.grid;
        let mut flux = 0.0;
        if (0..g.n[1] as i64).contains(&row) && gap > 0.0 {
            let yr = u.length_to_physical(row as f64 + 0.5);
            let (xl, xr) = (rightmost_at(&left, yr), leftmost_at(&right, yr));
            for i in 0..g.n[0] as i64 {
                let x = u.length_to_physical(i as f64 + 0.5);
                let node = g.index([i, row, 0]);
                if c.fluid.layout.kind[node] == NodeKind::Fluid && xl.is_none_or(|a| x > a) && xr.is_none_or(|b| x < b) {
                    let m = c.fluid.macro_at(node);
                    flux += m.rho * m.u[1];
                }
            }
        }
        // Σ ρu_y Δx / ρ₀ in lattice units → cm²/s per unit length
        let flow = flux * u.velocity * u.dx * self.length;
        let lateral = |k: [usize; 2], p: &Particles| {
            let d = |i: usize| p.position[i].x - p.reference[i].x;
            0.5 * (d(k[1]) - d(k[0]))
        };
        GlottalSample {
            gap,
            narrowest_y: y,
            area: gap.max(0.0) * self.length,
            flow,
            lower_margin: lateral(self.lower_margin, p),
            upper_margin: lateral(self.upper_margin, p),
        }
    }
}

/// x of the closed polygon's edges at height y: (smallest, largest), None when y misses it.
fn span_at(poly: &[DVec3], y: f64) -> Option<(f64, f64)> {
    let n = poly.len();
    let mut out: Option<(f64, f64)> = None;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        if (a.y - y) * (b.y - y) > 0.0 || a.y == b.y {
            continue;
        }
        let x = a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x);
        out = Some(out.map_or((x, x), |(lo, hi)| (lo.min(x), hi.max(x))));
    }
    out
}

fn rightmost_at(poly: &[DVec3], y: f64) -> Option<f64> {
    span_at(poly, y).map(|s| s.1)
}

fn leftmost_at(poly: &[DVec3], y: f64) -> Option<f64> {
    span_at(poly, y).map(|s| s.0)
}

/// Smallest horizontal distance between the left polygon's right side and the right polygon's
/// left side, over the heights both span, and where it is: at every vertex of either polygon
/// (the distance between two polylines is piecewise linear in y, so its minimum is at a vertex).
pub fn narrowest(left: &[DVec3], right: &[DVec3]) -> (f64, f64) {
    let mut best = (f64::INFINITY, f64::NAN);
    for y in left.iter().chain(right).map(|v| v.y) {
        if let (Some(l), Some(r)) = (rightmost_at(left, y), leftmost_at(right, y)) {
            let d = r - l;
            if d < best.0 {
                best = (d, y);
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_narrowest_section_of_two_polygons() {
        // the left fold's tip at (0.4, 1), the right one's at (0.7, 1.5)
        let left = vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.4, 1.0, 0.0), DVec3::new(0.0, 2.0, 0.0)];
        let right = vec![DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 2.0, 0.0), DVec3::new(0.7, 1.5, 0.0)];
        let (gap, y) = narrowest(&left, &right);
        // at y = 1.5: left 0.2, right 0.7 → 0.5; at y = 1: left 0.4, right 0.8 → 0.4; at 0 and 2: 1
        assert!((gap - 0.4).abs() < 1e-12 && (y - 1.0).abs() < 1e-12, "{gap} at {y}");
        // overlap reads negative (closed)
        let shifted: Vec<DVec3> = right.iter().map(|v| *v - DVec3::new(0.6, 0.0, 0.0)).collect();
        assert!(narrowest(&left, &shifted).0 < 0.0);
    }
}
