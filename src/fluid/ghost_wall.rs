//! The wall point of a ghost node inside a kernel level set (seed 000 §2.4.2, 2.124–2.126): where
//! the fluid's ghost-node boundary extrapolates through a body of particles.
//!
//! Near a thin body's surface Newton's steps along ∇L find the distance to the zero contour
//! ([`KernelLevelSet::sdf`]). A ghost node of a thick body (a vocal fold) can lie where L has
//! levelled off — every position within r_e of it holds particles — and there ∇L is the
//! particles' granularity, not the surface's direction: Newton's steps wander and end, if at
//! all, on whatever part of the contour the walk meets (up to 0.46 cells farther than the
//! nearest point on the test's ball), and where they give up L/|∇L| says up to 8.5 cells. Two
//! bracketed searches from the node find points of the contour besides: along the direction
//! away from the body's mass within three cells ([`KernelLevelSet::mass_outward`]), and along
//! the axis to the fluid node that makes the node a ghost (a fluid node is outside the body,
//! L ≤ 0, so the contour is bracketed between them). Every candidate lies on the contour, so
//! its distance bounds the nearest point's from above: [`KernelLevelSet::ghost_wall`] takes the
//! smallest, Newton's unless a search beats it by more than [`NEWTON_TIE`].
//!
//! Units: lattice cells.

use super::bracket::illinois;
use super::geometry::norm as length;
use super::kernel_level_set::{FLAT, KernelLevelSet};

/// Radius (cells) over which [`KernelLevelSet::mass_outward`] looks for the surface: beyond the
/// two cells a ghost lies from the fluid.
const MASS_RADIUS: f64 = 3.0;
/// Farthest (cells) a search looks for the contour along a direction: a ghost lies within two
/// cells of the fluid along an axis.
const SEARCH_REACH: f64 = 4.0;
/// Width (cells) to which a crossing is bracketed.
const CROSSING_TOLERANCE: f64 = 1e-9;
/// A search's contour point replaces Newton's when it is nearer by more than this (cells):
/// where Newton finds the nearest point a search along the same line finds it again, to the
/// bracket's width.
const NEWTON_TIE: f64 = 1e-6;

/// −g/|g|, the outward normal of a level set of gradient g; zero where g is.
fn outward(g: [f64; 3]) -> [f64; 3] {
    let n = length(g);
    if n > 0.0 { [-g[0] / n, -g[1] / n, -g[2] / n] } else { [0.0; 3] }
}

impl KernelLevelSet {
    /// The ghost node `p`'s signed distance to the wall (cells, negative inside, as
    /// [`Self::sdf`]) and the outward unit normal n along which its wall point p − d·n lies,
    /// given `outside`, a point where L ≤ 0 within `SEARCH_REACH` of `p` (the fluid node
    /// that makes `p` a ghost). Outside, and inside wherever Newton's point is the nearest of
    /// the candidates (the module's doc), (`sdf(p)`, `normal(p)`) bit for bit; else the nearer
    /// search's point of the contour and its direction. Falls back to `sdf` and `normal` when
    /// neither Newton nor a search reaches the contour.
    pub fn ghost_wall(&self, p: [f64; 3], outside: [f64; 3]) -> (f64, [f64; 3]) {
        let (l, g) = self.level(p);
        if !(l > 0.0) {
            return (-l / length(g).max(FLAT), outward(g));
        }
        // every candidate is a point of the contour, so its distance bounds the nearest one's
        // from above: the smallest wins, Newton's unless a search beats it by more than a tie
        let mut best: Option<(f64, [f64; 3])> = self.depth(p, (l, g)).map(|d| (d, outward(g)));
        let to = [outside[0] - p[0], outside[1] - p[1], outside[2] - p[2]];
        let reach = length(to);
        for dir in [self.mass_outward(p, MASS_RADIUS), to.map(|x| x / reach)] {
            if dir == [0.0; 3] {
                continue;
            }
            // a search wins only below this: it stops as soon as it cannot
            let cutoff = best.map_or(f64::INFINITY, |(b, _)| b - NEWTON_TIE);
            if let Some(t) = self.first_crossing(p, l, dir, reach, cutoff) {
                best = Some((t, dir));
            }
        }
        // neither: `sdf`'s first-order estimate and `normal`, from the evaluation at p
        let (d, n) = best.unwrap_or((l / length(g).max(FLAT), outward(g)));
        (-if d == 0.0 { f64::MIN_POSITIVE } else { d }, n)
    }

    /// The distance t along the unit direction `dir` from `p` (where L = `l_p` > 0) at which L
    /// first falls to 0 or below, bracketed to [`CROSSING_TOLERANCE`] by the Illinois variant
    /// of regula falsi; the bracket's outer end starts at `end` and moves out by half cells up
    /// to [`SEARCH_REACH`]. `None` when L stays positive that far. The returned t is the
    /// bracket's outer end (L ≤ 0 there).
    ///
    /// Only a t below `cutoff` (the distance a search must beat, [`Self::ghost_wall`]) is
    /// returned, and the search stops as soon as the bracket's inner end reaches it: that end
    /// only moves out and t lies beyond it, so the search would end at t ≥ `cutoff`. Where it
    /// does not stop early the evaluations are the full search's, so t is the same bit for bit
    /// (test `a_cut_off_search_ends_where_the_full_one_does`).
    fn first_crossing(&self, p: [f64; 3], l_p: f64, dir: [f64; 3], end: f64, cutoff: f64) -> Option<f64> {
        if 0.0 >= cutoff {
            return None;
        }
        let l_at = |t: f64| self.level_value([p[0] + t * dir[0], p[1] + t * dir[1], p[2] + t * dir[2]]);
        let (mut a, mut fa) = (0.0, l_p);
        let mut b = end.min(SEARCH_REACH);
        let mut fb = l_at(b);
        while fb > 0.0 {
            if b >= SEARCH_REACH {
                return None;
            }
            (a, fa) = (b, fb);
            if a >= cutoff {
                return None;
            }
            b = (b + 0.5).min(SEARCH_REACH);
            fb = l_at(b);
        }
        let (_, _, b, _) = illinois(l_at, (a, fa), (b, fb), 100, |_, a, b| b - a < CROSSING_TOLERANCE || a >= cutoff);
        (b < cutoff).then_some(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Particles on a square (2D) or cubic (3D) grid of spacing 0.4 cells inside a disc or ball
    /// of radius `radius` cells about `centre`; r_e = 1 cell, r clamped at 0.5, φ half the
    /// level at the centre: the coarse 3D glottis's kernel over a body many kernels thick.
    fn thick_body(dim: usize, centre: [f64; 3], radius: f64) -> KernelLevelSet {
        let mut pts = Vec::new();
        let m = (radius / 0.4).ceil() as i64 + 1;
        let zs = if dim == 3 { -m..=m } else { 0..=0 };
        for k in zs {
            for j in -m..=m {
                for i in -m..=m {
                    let x = [i as f64 * 0.4, j as f64 * 0.4, k as f64 * 0.4];
                    if x[0] * x[0] + x[1] * x[1] + x[2] * x[2] <= radius * radius {
                        pts.push([centre[0] + x[0], centre[1] + x[1], centre[2] + x[2]]);
                    }
                }
            }
        }
        let mut s = KernelLevelSet::new(pts.clone(), vec![[0.0; 3]; pts.len()], 1.0, 0.5, 0.0);
        s.phi = 0.5 * s.level(centre).0;
        s
    }

    /// The contour of `s` along `n` rays from `c`: 2D, evenly spaced angles; 3D, a Fibonacci
    /// sphere. By bisection between radius − 3 (inside) and radius + 2 (outside).
    fn contour(s: &KernelLevelSet, dim: usize, c: [f64; 3], radius: f64, n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|k| {
                let u = if dim == 2 {
                    let th = k as f64 * std::f64::consts::TAU / n as f64;
                    [th.cos(), th.sin(), 0.0]
                } else {
                    let z = 1.0 - (2.0 * k as f64 + 1.0) / n as f64;
                    let th = k as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
                    let r = (1.0 - z * z).sqrt();
                    [r * th.cos(), r * th.sin(), z]
                };
                let at = |r: f64| [c[0] + r * u[0], c[1] + r * u[1], c[2] + r * u[2]];
                let (mut a, mut b) = (radius - 3.0, radius + 2.0);
                assert!(s.level(at(a)).0 > 0.0 && !(s.level(at(b)).0 > 0.0));
                for _ in 0..45 {
                    let m = 0.5 * (a + b);
                    if s.level(at(m)).0 > 0.0 { a = m } else { b = m }
                }
                at(a)
            })
            .collect()
    }

    /// On a thick disc and a thick ball of particles (r_e = 1 cell, spacing 0.4 cells, bodies
    /// 14 and 10 cells across), every ghost-like node's wall distance is the nearest contour
    /// point's — found by sampling the contour along 4000 (2D) or 20,000 (3D) rays from the
    /// centre — within 0.08 cells (measured 0.045 in 2D and 0.063 in 3D: the contour is bumpy
    /// on the particles' scale, and the searches' directions follow the body's mean surface),
    /// and a searched wall point lies on the contour (L changes sign within 10⁻⁸ cells of it
    /// along the normal). Where Newton's point is kept the result is `sdf` and `normal`, bit
    /// for bit. Printed beside: what `sdf` says at the nodes where Newton gives up, and
    /// Newton's error where it converges.
    #[test]
    fn a_ghost_deep_in_a_thick_body_gets_the_nearest_point_of_the_contour() {
        for dim in [2usize, 3] {
            let (c, radius, rays) = if dim == 2 { ([20.13, 19.71, 0.0], 7.0, 4000) } else { ([12.13, 11.71, 12.37], 5.0, 20_000) };
            let s = thick_body(dim, c, radius);
            let span = radius as i64 + 3;
            let lo = [c[0] as i64 - span, c[1] as i64 - span, if dim == 3 { c[2] as i64 - span } else { 0 }];
            let hi = [c[0] as i64 + span, c[1] as i64 + span, if dim == 3 { c[2] as i64 + span } else { 0 }];
            let rim = contour(&s, dim, c, radius, rays);
            let nearest = |p: [f64; 3]| rim.iter().map(|r| length([r[0] - p[0], r[1] - p[1], r[2] - p[2]])).fold(f64::INFINITY, f64::min);
            let (mut searched, mut kept, mut gave_up) = (0, 0, 0);
            let (mut worst, mut worst_sdf, mut worst_newton) = (0.0f64, 0.0f64, 0.0f64);
            for (p, q) in crate::fluid::fixtures::level_set_ghosts(&s, dim, lo, hi) {
                let (d, n) = s.ghost_wall(p, q);
                assert!(d < 0.0, "{p:?}: inside, so a negative distance ({d})");
                let truth = nearest(p);
                worst = worst.max((-d - truth).abs());
                match s.depth(p, s.level(p)) {
                    Some(newton) => worst_newton = worst_newton.max((newton - truth).abs()),
                    None => {
                        gave_up += 1;
                        worst_sdf = worst_sdf.max((-s.sdf(p) - truth).abs());
                    }
                }
                if (d.to_bits(), n.map(f64::to_bits)) == (s.sdf(p).to_bits(), s.normal(p).map(f64::to_bits)) {
                    assert!(s.depth(p, s.level(p)).is_some(), "{p:?}: sdf's value where Newton gave up");
                    kept += 1;
                    continue;
                }
                searched += 1;
                let w = [p[0] - d * n[0], p[1] - d * n[1], p[2] - d * n[2]];
                let along = |t: f64| s.level([w[0] + t * n[0], w[1] + t * n[1], w[2] + t * n[2]]).0;
                assert!(along(-1e-8) > 0.0 && !(along(1e-8) > 0.0), "{p:?}: the wall point {w:?} is not on the contour");
            }
            println!(
                "{dim}D: {kept} ghosts keep Newton's point, {searched} a search's ({gave_up} where Newton gave up); distance error {worst:.4} cells (sdf's {worst_sdf:.3} where Newton gave up, Newton's {worst_newton:.4} where it converged)"
            );
            assert!(searched >= 10 && kept >= 10 && gave_up >= 10, "{dim}D: every path exercised: {kept} kept, {searched} searched, {gave_up} gave up");
            assert!(worst < 0.08, "{dim}D: {worst} cells from the nearest contour point");
        }
    }

    /// The searches' cut-off changes nothing but the work: on the thick disc and ball, for every
    /// ghost-like node and both search directions, a search cut off at Newton's distance less the
    /// tie (as [`KernelLevelSet::ghost_wall`] runs it), and at 0.1, 0.5 and 1 times the full
    /// search's own distance and just above it, returns the full search's distance bit for bit
    /// where that is below the cut-off, and `None` where it is not.
    #[test]
    fn a_cut_off_search_ends_where_the_full_one_does() {
        for dim in [2usize, 3] {
            let (c, radius) = if dim == 2 { ([20.13, 19.71, 0.0], 7.0) } else { ([12.13, 11.71, 12.37], 5.0) };
            let s = thick_body(dim, c, radius);
            let span = radius as i64 + 3;
            let lo = [c[0] as i64 - span, c[1] as i64 - span, if dim == 3 { c[2] as i64 - span } else { 0 }];
            let hi = [c[0] as i64 + span, c[1] as i64 + span, if dim == 3 { c[2] as i64 + span } else { 0 }];
            let (mut checked, mut won, mut cut) = (0, 0, 0);
            for (p, q) in crate::fluid::fixtures::level_set_ghosts(&s, dim, lo, hi) {
                let (l, g) = s.level(p);
                let to = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                let reach = length(to);
                for dir in [s.mass_outward(p, MASS_RADIUS), to.map(|x| x / reach)] {
                    if dir == [0.0; 3] {
                        continue;
                    }
                    let full = s.first_crossing(p, l, dir, reach, f64::INFINITY);
                    let mut cutoffs = vec![];
                    if let Some(d) = s.depth(p, (l, g)) {
                        cutoffs.push(d - NEWTON_TIE);
                    }
                    if let Some(t) = full {
                        cutoffs.extend([0.5 * t, 0.1 * t, t, t + 1e-12]);
                    }
                    for cutoff in cutoffs {
                        let got = s.first_crossing(p, l, dir, reach, cutoff);
                        match full {
                            Some(t) if t < cutoff => {
                                assert_eq!(got.map(f64::to_bits), Some(t.to_bits()), "{p:?} {dir:?}: cut off at {cutoff}");
                                won += 1;
                            }
                            _ => {
                                assert_eq!(got, None, "{p:?} {dir:?}: cut off at {cutoff}, full {full:?}");
                                cut += 1;
                            }
                        }
                        checked += 1;
                    }
                }
            }
            println!("{dim}D: {checked} cut-off searches, {won} reach the full one's distance, {cut} stop short");
            assert!(won >= 10 && cut >= 10, "{dim}D: both outcomes exercised: {won} reached, {cut} stopped");
        }
    }
}
