//! What a voice scientist reads from a coupled glottis (seed 000 §3.4.1, Figs. 3.12–3.16): the
//! glottal gap and area, the glottal volume flow through the narrowest section, and the lateral
//! displacement of the lower and upper margins of the medial surface.
//!
//! The two folds are bodies of a [`CoupledSolver`] on either side of the glottal mid-line x = x₀
//! (left below, right above; the flow runs along +y from the trachea to the vocal tract).
//! Units: the scene's (cgs: cm, s); in 2D a quantity per unit fold length is turned into the
//! fold's by multiplying with its `length` (the seed's 1.4 cm), so that areas are cm² and flows
//! cm³/s as in the two-mass model and the literature. In 3D (the fold length along z) the
//! section is read from the folds' level sets as the air sees them ([`section_3d`]): the real
//! area and flow.

use super::solver::CoupledSolver;
use super::surface::BodySurface;
use crate::fluid::KernelLevelSet;
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
    /// The power the air delivers to the two folds (erg/s), by where it acts:
    /// the parts of [`AIR_POWER_PARTS`] (inferior, medial, superior; [`Glottis::air_power`]).
    pub air_power: [f64; 3],
    /// The two folds' kinetic energy, translation and rotation of their particles (erg).
    pub kinetic_energy: f64,
}

/// Where on a fold's surface the air's power is booked ([`Glottis::air_power`]).
pub const AIR_POWER_PARTS: [&str; 3] = ["inferior", "medial", "superior"];

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

    /// Samples the glottis of `c` now (2D: the folds' surface polygons; 3D: their level sets,
    /// [`section_3d`]): [`Self::section`] read on `c`'s air.
    pub fn sample(&self, c: &CoupledSolver) -> GlottalSample {
        self.section(c).sample(&c.fluid)
    }

    /// The narrowest section of the glottis of `c` from its particles alone: its geometry and
    /// the fluid nodes whose flux is the glottal flow (the air is not read, so that a backend
    /// whose air lives elsewhere brings back those nodes only).
    pub fn section(&self, c: &CoupledSolver) -> GlottalSection {
        let (lower_margin, upper_margin) = self.margins(&c.solid.particles);
        let u = &c.units;
        let g = &c.fluid.layout.grid;
        let fluid = |node: usize| c.fluid.layout.kind[node] == NodeKind::Fluid;
        let (air_power, kinetic_energy) = (self.air_power(c), self.kinetic_energy(c));
        let sample = GlottalSample { lower_margin, upper_margin, air_power, kinetic_energy, ..Default::default() };
        let mut sec = GlottalSection { sample, nodes: Vec::new(), flow_factors: [0.0; 3] };
        if g.dim == 3 {
            let sets = c.drawn_level_sets();
            let Some(s3) = section_3d(&sets[self.left], &sets[self.right], u.position_to_lattice(self.mid_line), [g.n[1], g.n[2]]) else {
                // the folds share no row: no glottis to read
                (sec.sample.gap, sec.sample.narrowest_y) = (f64::NAN, f64::NAN);
                return sec;
            };
            for l in s3.lines.iter().filter(|l| l.gap > 0.0) {
                sec.nodes.extend(((l.left.ceil() as i64)..=(l.right.floor() as i64)).map(|x| g.index([x, s3.row, l.z])).filter(|&n| fluid(n)));
            }
            let dx = u.dx;
            sec.sample.gap = s3.lines.iter().map(|l| l.gap).fold(f64::INFINITY, f64::min) * dx;
            sec.sample.narrowest_y = u.length_to_physical(s3.row as f64 + 0.5);
            sec.sample.area = s3.area * dx * dx;
            sec.flow_factors = [u.velocity, dx, dx];
            return sec;
        }
        let p = &c.solid.particles;
        let left = c.bodies[self.left].surface.points(p);
        let right = c.bodies[self.right].surface.points(p);
        let (gap, y) = narrowest(&left, &right);
        // the lattice row through the narrowest section, the fluid nodes between the folds
        let row = u.position_to_lattice(y).round() as i64;
        if (0..g.n[1] as i64).contains(&row) && gap > 0.0 {
            let yr = u.length_to_physical(row as f64 + 0.5);
            let (xl, xr) = (rightmost_at(&left, yr), leftmost_at(&right, yr));
            sec.nodes = (0..g.n[0] as i64)
                .filter(|&i| {
                    let x = u.length_to_physical(i as f64 + 0.5);
                    xl.is_none_or(|a| x > a) && xr.is_none_or(|b| x < b)
                })
                .map(|i| g.index([i, row, 0]))
                .filter(|&n| fluid(n))
                .collect();
        }
        (sec.sample.gap, sec.sample.narrowest_y, sec.sample.area) = (gap, y, gap.max(0.0) * self.length);
        // Σ ρu_y Δx / ρ₀ in lattice units → cm²/s per unit length
        sec.flow_factors = [u.velocity, u.dx, self.length];
        sec
    }

    /// The factor that turns a 2D quantity per unit depth into the fold's (its `length`; 1 in 3D).
    fn depth(&self, c: &CoupledSolver) -> f64 {
        if c.solid.particles.dim == 2 { self.length } else { 1.0 }
    }

    /// The power the air delivers to the two folds now (erg/s; 2D: for the fold length),
    /// P = Σ F_i · v_i over their surface particles, with F_i the air's force on particle i over
    /// the last step ([`CoupledSolver::forces`]) and v_i its velocity: the aerodynamic energy
    /// transfer of Thomson, Mongeau & Frankel (2005, JASA 118, 1689), whose integral over a
    /// cycle is the work the flow does on the folds — positive where the air feeds the
    /// vibration, negative where it damps it. Split by the particle's reference height against
    /// the margins ([`AIR_POWER_PARTS`]): below the lower margin (the subglottal face), the
    /// medial surface between the margins, above the upper margin (the supraglottal face).
    pub fn air_power(&self, c: &CoupledSolver) -> [f64; 3] {
        let p = &c.solid.particles;
        // the right fold's margins; the left one's lie at the same heights (mirror images)
        let (y_lower, y_upper) = (p.reference[self.lower_margin[1]].y, p.reference[self.upper_margin[1]].y);
        let mut parts = [0.0; 3];
        for body in [self.left, self.right] {
            for &i in &c.bodies[body].surface.particles {
                let y = p.reference[i].y;
                let part = if y < y_lower {
                    0
                } else if y <= y_upper {
                    1
                } else {
                    2
                };
                // no force before the first step
                parts[part] += c.forces.force.get(i).map_or(0.0, |f| f.dot(p.velocity[i]));
            }
        }
        parts.map(|w| w * self.depth(c))
    }

    /// The two folds' kinetic energy now (erg; 2D: for the fold length).
    pub fn kinetic_energy(&self, c: &CoupledSolver) -> f64 {
        let p = &c.solid.particles;
        let bodies = [c.bodies[self.left].surface.body, c.bodies[self.right].surface.body];
        p.kinetic_energy_of(|i| bodies.contains(&p.body[i])) * self.depth(c)
    }

    /// Lateral (opening) displacement of the lower and upper margins, mean of both folds.
    fn margins(&self, p: &Particles) -> (f64, f64) {
        let lateral = |k: [usize; 2]| {
            let d = |i: usize| p.position[i].x - p.reference[i].x;
            0.5 * (d(k[1]) - d(k[0]))
        };
        (lateral(self.lower_margin), lateral(self.upper_margin))
    }
}

/// The narrowest section of a glottis ([`Glottis::section`]): its sample but for the flow, and
/// the fluid nodes the flow is summed over.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GlottalSection {
    /// Everything but `flow` (0 here).
    pub sample: GlottalSample,
    /// The fluid nodes (padded indices) of the section between the folds, in order.
    pub nodes: Vec<usize>,
    /// The physical flow (cm³/s) is Σ ρu_y over `nodes` (lattice units) times these three
    /// factors, in order (2D: U, Δx, the fold length; 3D: U, Δx, Δx).
    pub flow_factors: [f64; 3],
}

impl GlottalSection {
    /// The sample with the flow through the section read from `fluid` (at [`Self::nodes`] only).
    pub fn sample(&self, fluid: &crate::fluid::FluidSolver) -> GlottalSample {
        let flux: f64 = self.nodes.iter().map(|&n| fluid.macro_at(n)).map(|m| m.rho * m.u[1]).fold(0.0, |a, b| a + b);
        let [a, b, c] = self.flow_factors;
        GlottalSample { flow: flux * a * b * c, ..self.sample }
    }
}

/// One line of a 3D glottal section: at lattice z, the walls of the left and right folds along
/// x (lattice coordinates) and the gap between them (cells, 0 when closed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectionLine {
    pub z: i64,
    pub left: f64,
    pub right: f64,
    pub gap: f64,
}

/// The narrowest section of a 3D glottis (lattice units): its row y, area (cells²) and lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Section3d {
    pub row: i64,
    pub area: f64,
    pub lines: Vec<SectionLine>,
}

/// The narrowest section of the opening between two folds whose walls are the zero contours
/// of the level sets `left` and `right` (lattice coordinates; the left fold at x < `mid_line`,
/// the flow along +y, the fold length along z), on a lattice of `ny` × `nz` interior rows:
/// along every lattice line (y, z) that meets both folds, each wall is found from the mid-line
/// outwards (steps of a quarter cell to the first point inside, then bisection to the contour,
/// to 10⁻⁶ cells); a line whose mid-line point lies inside either fold is closed (gap 0). A
/// row's area is Σ_z gap·Δz; the section is the row of smallest area. None when no line meets
/// both folds.
pub fn section_3d(left: &KernelLevelSet, right: &KernelLevelSet, mid_line: f64, [ny, nz]: [usize; 2]) -> Option<Section3d> {
    // each fold's particles' box grown by r_e: beyond it L = −φ < 0
    let ((ll, lh, _), (rl, rh, _)) = (left.bin_box(), right.bin_box());
    let inside = |s: &KernelLevelSet, x: f64, y: f64, z: f64| s.level([x, y, z]).0 > 0.0;
    // the wall of `s` on the line (y, z), from the mid-line in direction `dir`, within `[lo, hi]` in x
    let wall = |s: &KernelLevelSet, y: f64, z: f64, dir: f64, lo: f64, hi: f64| -> Option<f64> {
        let mut a = mid_line;
        loop {
            let b = a + 0.25 * dir;
            if b < lo || b > hi {
                return None;
            }
            if inside(s, b, y, z) {
                let (mut o, mut i) = (a, b);
                while (i - o).abs() > 1e-6 {
                    let m = 0.5 * (o + i);
                    if inside(s, m, y, z) { i = m } else { o = m }
                }
                return Some(0.5 * (o + i));
            }
            a = b;
        }
    };
    let range = |lo: f64, hi: f64, n: usize| (lo.ceil().max(0.0) as i64)..=(hi.floor().min(n as f64 - 1.0) as i64);
    let mut best: Option<Section3d> = None;
    for y in range(ll[1].max(rl[1]), lh[1].min(rh[1]), ny) {
        let mut lines = Vec::new();
        for z in range(ll[2].max(rl[2]), lh[2].min(rh[2]), nz) {
            let (yf, zf) = (y as f64, z as f64);
            let closed = inside(left, mid_line, yf, zf) || inside(right, mid_line, yf, zf);
            if closed {
                lines.push(SectionLine { z, left: mid_line, right: mid_line, gap: 0.0 });
                continue;
            }
            if let (Some(l), Some(r)) = (wall(left, yf, zf, -1.0, ll[0], lh[0]), wall(right, yf, zf, 1.0, rl[0], rh[0])) {
                lines.push(SectionLine { z, left: l, right: r, gap: r - l });
            }
        }
        if lines.is_empty() {
            continue;
        }
        let area = lines.iter().map(|l| l.gap).sum::<f64>();
        if best.as_ref().is_none_or(|b| area < b.area) {
            best = Some(Section3d { row: y, area, lines });
        }
    }
    best
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

    /// Two folds as slabs of particles (spacing 0.4 cells) whose medial faces open as
    /// h(y, z) = h₀ + 0.4|y − 12| + 0.1 z cells about the mid-line x = 20.3, the level sets
    /// calibrated on the faces as the coupling calibrates them: the narrowest row is y = 12, each
    /// line's gap is h(12, z) within 0.4 cells (each wall within half a particle spacing of the
    /// face its particles sample: the outermost particle lies within one spacing of the face,
    /// and the calibration puts the contour through the faces' points on average), and where
    /// h < −0.4 (the folds overlap at the mid-line by more than that tolerance) the lines are
    /// closed.
    #[test]
    fn the_narrowest_3d_section_of_two_slab_folds() {
        use crate::coupling::level_set::surface_level;
        let x0 = 20.3;
        for h0 in [2.0, -1.25] {
            let h = |y: f64, z: f64| h0 + 0.4 * (y - 12.0).abs() + 0.1 * z;
            let (re, r_min, l0) = (2.0, 1.0, 0.4);
            let fold = |side: f64| {
                let (mut pts, mut face) = (Vec::new(), Vec::new());
                for j in 0..=40 {
                    for k in 0..=70 {
                        let (y, z) = (4.0 + l0 * j as f64, 2.0 + l0 * k as f64);
                        let inner = x0 + side * 0.5 * h(y, z);
                        face.push(DVec3::new(inner, y, z));
                        // from 8 cells out to the face
                        let outer = x0 + side * (0.5 * h(y, z) + 8.0);
                        let n = ((outer - inner).abs() / l0).floor() as i64;
                        for i in 0..=n {
                            pts.push(DVec3::new(outer - side * l0 * i as f64, y, z));
                        }
                    }
                }
                let phi = surface_level(&pts, &face, re, r_min);
                let p: Vec<[f64; 3]> = pts.iter().map(|p| p.to_array()).collect();
                KernelLevelSet::new(p.clone(), vec![[0.0; 3]; p.len()], re, r_min, phi)
            };
            let (left, right) = (fold(-1.0), fold(1.0));
            let sec = section_3d(&left, &right, x0, [40, 40]).expect("the folds share rows");
            assert_eq!(sec.row, 12, "h₀ = {h0}");
            let (mut worst, mut closed): (f64, usize) = (0.0, 0);
            for l in sec.lines.iter().filter(|l| (6..=26).contains(&l.z)) {
                let want = h(12.0, l.z as f64);
                if want < -0.4 {
                    assert_eq!(l.gap, 0.0, "h₀ = {h0}, z = {}: closed", l.z);
                    closed += 1;
                } else if want > 1.0 {
                    worst = worst.max((l.gap - want).abs());
                }
            }
            eprintln!("h₀ = {h0}: {} lines, area {:.3} cells², gaps within {worst:.3} cells", sec.lines.len(), sec.area);
            assert!(worst < 0.4, "h₀ = {h0}: {worst}");
            assert_eq!(closed, if h0 < 0.0 { 3 } else { 0 }, "h₀ = {h0}: lines overlapping by more than the tolerance");
            assert!((sec.area - sec.lines.iter().map(|l| l.gap).sum::<f64>()).abs() < 1e-12);
        }
    }
}
