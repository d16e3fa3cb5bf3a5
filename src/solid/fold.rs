//! The vocal-fold section of seed 000 Fig. 3.9 (§3.4.1) as a parametric shape, sampled
//! uniformly with MPS particles, mirrored about the glottal mid-line, with the body (inner 8/9)
//! and cover (outer 1/9) layers and the fixed lateral face.
//!
//! Coordinates (cm): `lateral` from the glottal mid-line (the right fold at lateral > 0),
//! `vertical` from the tracheal (lung) side, z = 0, up to the vocal-tract side, z = height.
//!
//! The figure itself is not in the seed's text, only its dimensions; this is how they are
//! read (a decision, written here and in the docs):
//! - the fold is the rectangle [G/2, G/2 + width] × [0, height] whose inferior-medial part is
//!   cut by the sloping subglottal surface, from (G/2 + T1, 0) on the tracheal side up to the
//!   medial surface at height − T2; the medial surface is vertical over the top T2;
//! - G is the minimum gap between the two folds (the seed's "initial distance between the
//!   folds", also 0.021 cm), so each medial surface is G/2 from the mid-line;
//! - R1 rounds the corner where the subglottal slope meets the medial surface, R2 the corner
//!   between the medial surface and the superior (vocal-tract) surface: "two circles give the
//!   corners their curvature";
//! - D = 0.791 = width + G is not an independent length: it is checked to equal width + G;
//! - the lateral face (attached to the thyroid cartilage) is fixed; every other face is free.
//!
//! Body and cover (Fig. 3.11): the cover is the layer of uniform thickness under the free
//! surface that holds 1/9 of the section's area, the body the inner 8/9.

use crate::error::SceneError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Fig. 3.9 dimensions (cm). `Default` is the seed's list.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FoldSection {
    pub width: f64,
    pub height: f64,
    /// Along the fold (the 3D extrusion; 2D runs are per unit length).
    pub length: f64,
    /// The seed's D; read as width + gap and checked when given.
    pub d: Option<f64>,
    /// Minimum gap between the two folds.
    pub gap: f64,
    /// Horizontal reach of the subglottal slope at the tracheal side.
    pub t1: f64,
    /// Height of the vertical medial surface.
    pub t2: f64,
    /// Radii of the inferior-medial and superior-medial corners.
    pub r1: f64,
    pub r2: f64,
    /// Area fraction of the cover layer.
    pub cover_fraction: f64,
}

impl Default for FoldSection {
    fn default() -> Self {
        FoldSection { width: 0.77, height: 0.475, length: 1.4, d: Some(0.791), gap: 0.021, t1: 0.3, t2: 0.15, r1: 0.125, r2: 0.025, cover_fraction: 1.0 / 9.0 }
    }
}

/// Which layer a particle belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Layer {
    Body,
    Cover,
    /// 3D only: the thyroid cartilage and thyroarytenoid muscle on the lateral–anterior side
    /// (seed §3.4.3, Fig. 3.34).
    Thyroarytenoid,
}

/// Both folds of the 3D glottis: (lateral, along the fold from the anterior end, vertical)
/// positions (cm), layers, fixed flags, side.
#[derive(Clone, Debug, Default)]
pub struct FoldParticles3 {
    pub position: Vec<[f64; 3]>,
    pub layer: Vec<Layer>,
    pub fixed: Vec<bool>,
    pub side: Vec<i8>,
}

/// Both folds' particles: (lateral, vertical) positions (cm), layers, fixed flags and which
/// fold (−1 left, +1 right).
#[derive(Clone, Debug, Default)]
pub struct FoldParticles {
    pub position: Vec<[f64; 2]>,
    pub layer: Vec<Layer>,
    pub fixed: Vec<bool>,
    pub side: Vec<i8>,
    /// Cover thickness on the particles (cm): the depth of the deepest cover particle (the
    /// continuous section's is [`FoldSection::cover_thickness`]).
    pub cover_thickness: f64,
}

/// A rounded corner: centre, radius, start and end angles of its arc.
struct Fillet {
    corner: [f64; 2],
    centre: [f64; 2],
    radius: f64,
    from: f64,
    to: f64,
    /// Tangent points on the incoming and outgoing edges.
    tangent_in: [f64; 2],
    tangent_out: [f64; 2],
    /// Area the rounding removes from the sharp corner.
    removed_area: f64,
}

impl FoldSection {
    /// The first dimension that does not make a fold, named `{prefix}.{field}`.
    pub fn check(&self, prefix: &str) -> Result<(), SceneError> {
        let bad = |f: &str, reason: String| Err(SceneError { field: format!("{prefix}.{f}"), reason });
        for (f, v) in [("width", self.width), ("height", self.height), ("length", self.length), ("gap", self.gap), ("t1", self.t1), ("t2", self.t2)] {
            if !(v.is_finite() && v > 0.0) {
                return bad(f, format!("must be a positive length in cm (got {v})"));
            }
        }
        for (f, v) in [("r1", self.r1), ("r2", self.r2)] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(f, format!("must be a radius ≥ 0 in cm (got {v})"));
            }
        }
        if let Some(d) = self.d
            && (d - (self.width + self.gap)).abs() > 1e-9 * d.abs().max(1.0)
        {
            return bad("d", format!("D is read as width + gap = {} cm (Fig. 3.9); got {d} (leave it out to derive it)", self.width + self.gap));
        }
        if self.t1 >= self.width {
            return bad("t1", format!("the subglottal slope's reach {} must be shorter than the width {}", self.t1, self.width));
        }
        if self.t2 >= self.height {
            return bad("t2", format!("the medial surface {} must be lower than the height {}", self.t2, self.height));
        }
        if !(self.cover_fraction > 0.0 && self.cover_fraction < 0.5) {
            return bad("cover_fraction", format!("must lie in (0, 0.5) (got {})", self.cover_fraction));
        }
        let (f1, f2) = self.fillets();
        let slope_len = self.t1.hypot(self.height - self.t2);
        if dist(f1.tangent_in, [self.gap / 2.0 + self.t1, 0.0]) > slope_len || f1.tangent_out[1] > f2.tangent_in[1] {
            return bad("r1", format!("R1 = {} and R2 = {} do not fit on the slope and the medial surface (T2 = {})", self.r1, self.r2, self.t2));
        }
        if self.r2 > self.width - self.t1 {
            return bad("r2", format!("R2 = {} is wider than the superior surface", self.r2));
        }
        Ok(())
    }

    fn medial(&self) -> f64 {
        0.5 * self.gap
    }

    /// The two rounded corners of the right fold.
    fn fillets(&self) -> (Fillet, Fillet) {
        let m = self.medial();
        let corner1 = [m, self.height - self.t2];
        let foot = [m + self.t1, 0.0];
        let top = [m, self.height];
        let along = [m + 1.0, self.height]; // superior surface heads laterally
        (fillet(foot, corner1, top, self.r1), fillet(corner1, top, along, self.r2))
    }

    /// Closed outline of the right fold, counter-clockwise, arcs cut into `per_arc` segments:
    /// bottom (tracheal) face, lateral face, superior face, R2, medial surface, R1, slope.
    pub fn outline(&self, per_arc: usize) -> Vec<[f64; 2]> {
        let m = self.medial();
        let xl = m + self.width;
        let (f1, f2) = self.fillets();
        let mut pts = vec![[m + self.t1, 0.0], [xl, 0.0], [xl, self.height]];
        pts.push(f2.tangent_out);
        pts.extend(arc(&f2, per_arc));
        pts.push(f2.tangent_in);
        pts.push(f1.tangent_out);
        pts.extend(arc(&f1, per_arc));
        pts.push(f1.tangent_in);
        pts.dedup_by(|a, b| dist(*a, *b) < 1e-15);
        pts
    }

    /// Exact area of one fold's section (cm²): the rectangle less the subglottal cut, less what
    /// the two roundings remove.
    pub fn area(&self) -> f64 {
        let (f1, f2) = self.fillets();
        self.width * self.height - 0.5 * self.t1 * (self.height - self.t2) - f1.removed_area - f2.removed_area
    }

    /// Whether (lateral, vertical) lies in the right fold.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        self.contains_with(&self.fillets(), p)
    }

    /// [`Self::contains`] with the corners' fillets computed once by the caller (the samplers
    /// test every lattice point).
    fn contains_with(&self, (f1, f2): &(Fillet, Fillet), p: [f64; 2]) -> bool {
        let m = self.medial();
        if p[0] < m || p[0] > m + self.width || p[1] < 0.0 || p[1] > self.height {
            return false;
        }
        // below the slope line from (m + T1, 0) to (m, height − T2): outside
        let (x0, y0, x1, y1) = (m + self.t1, 0.0, m, self.height - self.t2);
        if (x1 - x0) * (p[1] - y0) - (y1 - y0) * (p[0] - x0) > 0.0 && p[1] < y1 {
            return false;
        }
        for f in [f1, f2] {
            if in_corner_region(f, p) && dist(p, f.centre) > f.radius {
                return false;
            }
        }
        true
    }

    /// Distance (cm) from a point of the right fold to its free surface (every face but the
    /// lateral one).
    ///
    /// One pass over the segments: each one's nearest point, its squared distance, and `hypot`
    /// only where that squared distance is within round-off (10⁻⁹, relative) of the smallest so
    /// far — a set that holds the segment of the smallest `hypot`, so the value is the smallest
    /// `hypot` over every segment bit for bit, at a fraction of the cost
    /// ([`Self::cover_thickness`] asks it at ~10⁶ points of the seed's fold).
    pub fn depth(&self, p: [f64; 2], outline: &[[f64; 2]]) -> f64 {
        let n = outline.len();
        let xl = self.medial() + self.width;
        let (mut nearest2, mut depth) = (f64::INFINITY, f64::INFINITY);
        for i in 0..n {
            let (a, b) = (outline[i], outline[(i + 1) % n]);
            if (a[0] - xl).abs() < 1e-12 && (b[0] - xl).abs() < 1e-12 {
                continue; // the lateral face
            }
            let q = segment_nearest(p, a, b);
            let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
            if d2 <= nearest2 * (1.0 + 1e-9) + f64::MIN_POSITIVE {
                depth = depth.min(dist(p, q));
            }
            nearest2 = nearest2.min(d2);
        }
        depth
    }

    /// Cover thickness (cm) whose layer holds `cover_fraction` of the area, found by bisection
    /// on a fine grid (spacing/4) independent of the particle lattice (0.0198 cm for the seed's
    /// fold: 4.7 particle spacings of 0.0042 cm).
    pub fn cover_thickness(&self, spacing: f64) -> f64 {
        let outline = self.outline(64);
        let fillets = self.fillets();
        let h = spacing / 4.0;
        let m = self.medial();
        let (nx, nz) = ((self.width / h).ceil() as usize, (self.height / h).ceil() as usize);
        // independent points, on the pool's threads (collected in order)
        let depths: Vec<f64> = (0..nx * nz)
            .into_par_iter()
            .with_min_len(4096)
            .filter_map(|k| {
                let p = [m + (k % nx) as f64 * h + 0.5 * h, (k / nx) as f64 * h + 0.5 * h];
                self.contains_with(&fillets, p).then(|| self.depth(p, &outline))
            })
            .collect();
        let (mut lo, mut hi) = (0.0, self.width.min(self.height));
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            let frac = depths.iter().filter(|d| **d < mid).count() as f64 / depths.len() as f64;
            if frac < self.cover_fraction {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// Both folds on a square lattice of `spacing` (cm): [`Self::sample_right`] and its mirror
    /// image about the mid-line, left fold first.
    pub fn sample(&self, spacing: f64, fixed_depth: f64) -> FoldParticles {
        let right = self.sample_right(spacing, fixed_depth);
        let mut out = FoldParticles { cover_thickness: right.cover_thickness, ..Default::default() };
        for side in [-1i8, 1] {
            for i in 0..right.position.len() {
                let [lat, z] = right.position[i];
                out.position.push([side as f64 * lat, z]);
                out.layer.push(right.layer[i]);
                out.fixed.push(right.fixed[i]);
                out.side.push(side);
            }
        }
        out
    }

    /// The right fold on a square lattice of `spacing` (cm), from l₀/2 inside its medial
    /// surface and bottom face. Particles within `fixed_depth` of the lateral face are fixed
    /// (the cartilage).
    pub fn sample_right(&self, spacing: f64, fixed_depth: f64) -> FoldParticles {
        let m = self.medial();
        let xl = m + self.width;
        let outline = self.outline(64);
        let fillets = self.fillets();
        let (nx, nz) = ((self.width / spacing).ceil() as usize, (self.height / spacing).ceil() as usize);
        let mut right = Vec::new();
        for j in 0..nz {
            for i in 0..nx {
                let p = [m + (i as f64 + 0.5) * spacing, (j as f64 + 0.5) * spacing];
                if self.contains_with(&fillets, p) {
                    right.push(p);
                }
            }
        }
        // The cover: the `cover_fraction` of the particles nearest the free surface (each
        // particle stands for l₀² of tissue, so the layer's volume is its count). Whole rows of
        // the faces that follow the lattice share one depth; where the cut falls inside such a
        // row, its particles nearest the mid-line (the vibrating medial side) join the cover
        // first, so the layer is one row thicker there, over part of that face.
        let depth: Vec<f64> = right.iter().map(|p| self.depth(*p, &outline)).collect();
        let mut order: Vec<usize> = (0..right.len()).collect();
        order.sort_by(|&a, &b| depth[a].total_cmp(&depth[b]).then(right[a][0].total_cmp(&right[b][0])));
        let k = ((self.cover_fraction * right.len() as f64).round() as usize).clamp(1, right.len() - 1);
        let mut is_cover = vec![false; right.len()];
        for &i in &order[..k] {
            is_cover[i] = true;
        }
        let cover = depth[order[k - 1]];
        let mut out = FoldParticles { cover_thickness: cover, ..Default::default() };
        for (p, c) in right.iter().zip(&is_cover) {
            out.position.push(*p);
            out.layer.push(if *c { Layer::Cover } else { Layer::Body });
            out.fixed.push(xl - p[0] < fixed_depth);
            out.side.push(1);
        }
        out
    }
}

impl FoldSection {
    /// The 3D fold of seed §3.4.3: the section extruded along the fold length (y from the
    /// anterior end, 0 … length), sampled on a cubic lattice of `spacing`, mirrored about the
    /// mid-plane. Read from the seed (decisions):
    /// - the glottal opening widens linearly from 0 at the anterior end to `opening` (cm) at the
    ///   posterior end, on top of the section's gap G: at y the folds are G + opening·y/length
    ///   apart (each section shifted laterally by half of it);
    /// - layers: the cover is the outer `cover_fraction` under the free surface of each section
    ///   (as in 2D); of the rest, the part outside the quarter ellipse centred on the
    ///   medial-posterior edge with semi-axes width (lateral) and length (along the fold) is the
    ///   thyroid cartilage / thyroarytenoid layer, the remainder the body;
    /// - fixed: within `fixed_depth` of the lateral face or of the anterior face, and of the
    ///   posterior face except the cover ("the posterior fixed end applies to the body only").
    pub fn sample_3d(&self, spacing: f64, fixed_depth: f64, opening: f64) -> FoldParticles3 {
        let section = self.sample_right(spacing, fixed_depth);
        let ny = (self.length / spacing).round().max(1.0) as usize;
        let mut out = FoldParticles3::default();
        for side in [-1i8, 1] {
            for j in 0..ny {
                let y = (j as f64 + 0.5) * self.length / ny as f64;
                let shift = 0.5 * opening * y / self.length;
                for k in 0..section.position.len() {
                    let [lat, z] = section.position[k];
                    let medial_distance = lat - 0.5 * self.gap; // from the section's medial surface
                    let from_posterior = self.length - y;
                    let mut layer = section.layer[k];
                    if layer == Layer::Body && (medial_distance / self.width).powi(2) + (from_posterior / self.length).powi(2) > 1.0 {
                        layer = Layer::Thyroarytenoid;
                    }
                    let fixed = section.fixed[k] || y < fixed_depth || (from_posterior < fixed_depth && layer != Layer::Cover);
                    out.position.push([side as f64 * (lat + shift), y, z]);
                    out.layer.push(layer);
                    out.fixed.push(fixed);
                    out.side.push(side);
                }
            }
        }
        out
    }
}

/// Titze's body–cover cases of seed §3.4.1 (Young's moduli, dyn/cm²).
///
/// Decision: the seed's case list gives body 1.0 and cover 10.0 × 10⁵ for A (and body 1.0,
/// cover 100.0 for C), but its narrative — and Titze's cases it follows — have the body (muscle)
/// stiffer than the cover (mucosa); the list swaps the two layers. Here cover/body =
/// 1/10, 2/20, 1/100, 2/200 × 10⁵ dyn/cm² for A, B, C, D (B is A doubled, D is C doubled).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum BodyCoverCase {
    A,
    B,
    C,
    D,
}

impl BodyCoverCase {
    /// (cover, body) Young's moduli (dyn/cm²).
    pub fn young(self) -> (f64, f64) {
        match self {
            BodyCoverCase::A => (1.0e5, 10.0e5),
            BodyCoverCase::B => (2.0e5, 20.0e5),
            BodyCoverCase::C => (1.0e5, 100.0e5),
            BodyCoverCase::D => (2.0e5, 200.0e5),
        }
    }

    /// The seed's f0 (Hz) for the case (§3.4.1 results: ≈ 110, 180, 140–150, 190 Hz).
    pub fn seed_f0(self) -> f64 {
        match self {
            BodyCoverCase::A => 110.0,
            BodyCoverCase::B => 180.0,
            BodyCoverCase::C => 145.0,
            BodyCoverCase::D => 190.0,
        }
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The point of segment a–b nearest to `p`.
fn segment_nearest(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    [a[0] + t * dx, a[1] + t * dy]
}

/// The fillet of radius `r` at corner `b` of the path a → b → c.
fn fillet(a: [f64; 2], b: [f64; 2], c: [f64; 2], r: f64) -> Fillet {
    let unit = |p: [f64; 2], q: [f64; 2]| {
        let l = dist(p, q);
        [(q[0] - p[0]) / l, (q[1] - p[1]) / l]
    };
    let (u, v) = (unit(b, a), unit(b, c)); // from the corner along both edges
    let interior = (u[0] * v[0] + u[1] * v[1]).clamp(-1.0, 1.0).acos();
    let t = r / (0.5 * interior).tan(); // tangent length
    let tangent_in = [b[0] + t * u[0], b[1] + t * u[1]];
    let tangent_out = [b[0] + t * v[0], b[1] + t * v[1]];
    let bis = unit([0.0, 0.0], [u[0] + v[0], u[1] + v[1]]);
    let h = r / (0.5 * interior).sin();
    let centre = [b[0] + h * bis[0], b[1] + h * bis[1]];
    let ang = |p: [f64; 2]| (p[1] - centre[1]).atan2(p[0] - centre[0]);
    let turning = PI - interior;
    Fillet {
        corner: b,
        centre,
        radius: r,
        from: ang(tangent_in),
        to: ang(tangent_out),
        tangent_in,
        tangent_out,
        removed_area: r * r * ((0.5 * turning).tan() - 0.5 * turning),
    }
}

/// Interior points of the arc from `tangent_in` to `tangent_out` (the short way).
fn arc(f: &Fillet, n: usize) -> Vec<[f64; 2]> {
    let mut d = f.to - f.from;
    while d > PI {
        d -= 2.0 * PI;
    }
    while d < -PI {
        d += 2.0 * PI;
    }
    (1..n)
        .map(|k| {
            let a = f.from + d * k as f64 / n as f64;
            [f.centre[0] + f.radius * a.cos(), f.centre[1] + f.radius * a.sin()]
        })
        .rev()
        .collect()
}

/// Whether `p` lies in the triangle (corner, tangent points): the region the rounding trims
/// where it lies outside the arc's circle.
fn in_corner_region(f: &Fillet, p: [f64; 2]) -> bool {
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let (a, b, c) = (f.corner, f.tangent_in, f.tangent_out);
    let (d1, d2, d3) = (cross(a, b, p), cross(b, c, p), cross(c, a, p));
    !((d1 < 0.0 || d2 < 0.0 || d3 < 0.0) && (d1 > 0.0 || d2 > 0.0 || d3 > 0.0))
}

#[cfg(test)]
#[path = "fold_tests.rs"]
mod tests;
