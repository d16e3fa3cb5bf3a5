//! Contact between bodies and against walls with the distinct-element model of seed 000
//! §2.2.2 (2.22–2.37): a normal spring on the overlap, a tangential spring anchored at the first
//! contact point and carried by the particles' rotations, capped by static friction and
//! replaced by dynamic friction when it slips, and a damping force on the relative velocity.
//!
//! Forces act at the contact point, equal and opposite on the two particles, so linear and
//! angular momentum are conserved. Units: stiffnesses force/length, damping force·time/length.

use super::grid::SearchGrid;
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactParams {
    /// Normal spring k of (2.24).
    pub normal_stiffness: f64,
    /// Tangential spring k_s of (2.34).
    pub tangential_stiffness: f64,
    /// μ_s of (2.35) and μ_d of (2.36).
    pub static_friction: f64,
    pub dynamic_friction: f64,
    /// Damping coefficient η of (2.37). It acts on the normal relative velocity only: a
    /// tangential damping would add a viscous drag to Coulomb friction (and make a sliding
    /// block's acceleration depend on η).
    #[serde(default)]
    pub damping: f64,
}

/// A plane wall {x : n·x = offset}; bodies live on the side n·x > offset.
#[derive(Clone, Debug, PartialEq)]
pub struct Wall {
    pub normal: DVec3,
    pub offset: f64,
}

/// Tangential-spring anchors in each particle's own (unrotated) frame, (2.29)–(2.30).
#[derive(Clone, Copy, Debug)]
pub(super) struct Anchor {
    pub(super) ri: DVec3,
    pub(super) rj: DVec3,
}

#[derive(Clone, Debug, Default)]
pub struct Contacts {
    pub(super) pairs: HashMap<(u32, u32), Anchor>,
    pub(super) walls: HashMap<(u32, u16), Anchor>,
    /// Deepest overlap of the last evaluation, as a fraction of the particle diameter l₀.
    pub max_overlap: f64,
    /// Active contacts of the last evaluation (pairs, wall contacts) and how many slid.
    pub active: (usize, usize),
    pub sliding: usize,
}

pub struct ContactInput<'a> {
    pub x: &'a [DVec3],
    pub v: &'a [DVec3],
    pub rot: &'a [DMat3],
    pub body: &'a [u16],
    pub fixed: &'a [bool],
    /// Particle diameter l₀ (contact when d_ij < l₀, 2.23).
    pub diameter: f64,
}

/// Tangential force of a spring `c_s` capped by friction: (force on i, slid?).
fn friction(p: &ContactParams, cs: DVec3, fn_mag: f64) -> (DVec3, bool) {
    let fc = p.tangential_stiffness * cs;
    let cap = p.static_friction * fn_mag;
    if fc.length() > cap {
        let len = cs.length();
        let dir = if len > 0.0 { cs / len } else { DVec3::ZERO };
        (p.dynamic_friction * fn_mag * dir, true)
    } else {
        (fc, false)
    }
}

/// Whether each particle lies within `reach` (a little more, for round-off) of the bounding box
/// of a body other than its own; `None` when no two bodies' boxes come that close, so that no
/// particle can (a particle lies in its own body's box: its distance to another box is at
/// least the distance between the boxes). Both passes on the pool's threads (the boxes' min and
/// max are exact in any order).
fn near_another_body(x: &[DVec3], body: &[u16], reach: f64) -> Option<Vec<bool>> {
    let bodies = body.iter().map(|&b| b as usize + 1).max().unwrap_or(0);
    let empty = vec![(DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)); bodies];
    let boxes = x
        .par_iter()
        .zip(body)
        .fold(
            || empty.clone(),
            |mut boxes, (p, &b)| {
                let (lo, hi) = &mut boxes[b as usize];
                (*lo, *hi) = (lo.min(*p), hi.max(*p));
                boxes
            },
        )
        .reduce(|| empty.clone(), |a, b| a.iter().zip(&b).map(|((la, ha), (lb, hb))| (la.min(*lb), ha.max(*hb))).collect());
    let reach2 = (1.01 * reach).powi(2);
    // the gap between two boxes, with a margin far above round-off
    let apart = |(la, ha): &(DVec3, DVec3), (lb, hb): &(DVec3, DVec3)| {
        let gap = (*la - *hb).max(*lb - *ha).max(DVec3::ZERO);
        gap.length_squared() > 1.001 * reach2
    };
    let occupied: Vec<&(DVec3, DVec3)> = boxes.iter().filter(|(lo, hi)| lo.x <= hi.x).collect();
    if occupied.iter().enumerate().all(|(k, a)| occupied[k + 1..].iter().all(|b| apart(a, b))) {
        return None;
    }
    Some(
        x.par_iter()
            .zip(body)
            .map(|(p, &b)| boxes.iter().enumerate().any(|(k, (lo, hi))| k != b as usize && lo.x <= hi.x && (p.clamp(*lo, *hi) - *p).length_squared() <= reach2))
            .collect(),
    )
}

impl Contacts {
    /// Tangential-spring anchors held: (particle pairs, particle–wall contacts).
    pub fn anchors(&self) -> (usize, usize) {
        (self.pairs.len(), self.walls.len())
    }

    /// Adds contact forces and torques to `force`/`torque`: between particles of different
    /// bodies closer than l₀ (2.23–2.37) and between particles and `walls`.
    pub fn apply(&mut self, p: &ContactParams, walls: &[Wall], inp: &ContactInput, force: &mut [DVec3], torque: &mut [DVec3]) {
        let l0 = inp.diameter;
        let n = inp.x.len();
        let mut seen: HashMap<(u32, u32), Anchor> = HashMap::with_capacity(self.pairs.len());
        self.max_overlap = 0.0;
        self.active = (0, 0);
        self.sliding = 0;
        let multi_body = inp.body.iter().any(|&b| b != inp.body[0]);
        // Only a particle within l₀ of another body's bounding box can touch that body: the
        // others are not searched from (for two folds apart, none is). The grid holds every
        // particle, so each search meets its neighbours in the same order as without the filter.
        let near_other = if multi_body { near_another_body(inp.x, inp.body, l0) } else { None };
        if let Some(near_other) = near_other.filter(|near| near.iter().any(|&b| b)) {
            let grid = SearchGrid::build(inp.x, l0, [None; 3]);
            for i in (0..n).filter(|&i| near_other[i]) {
                let mut near: Vec<(usize, DVec3)> = Vec::new();
                grid.for_each_within(inp.x[i], l0, inp.x, |j, d| {
                    if j > i && inp.body[j] != inp.body[i] {
                        near.push((j, d));
                    }
                });
                for (j, xij) in near {
                    let d = xij.length();
                    if d >= l0 || d == 0.0 {
                        continue;
                    }
                    let nrm = xij / d; // (2.25)
                    let c = l0 - d; // (2.23)
                    self.max_overlap = self.max_overlap.max(c / l0);
                    let fn_vec = -p.normal_stiffness * c * nrm; // (2.24), on i
                    let (ri, rj) = (inp.rot[i], inp.rot[j]);
                    let key = (i as u32, j as u32);
                    let mut anchor = self.pairs.get(&key).copied().unwrap_or_else(|| {
                        // (2.26)–(2.30)
                        let cp = 0.5 * (inp.x[i] + inp.x[j]);
                        Anchor { ri: ri.transpose() * (cp - inp.x[i]), rj: rj.transpose() * (cp - inp.x[j]) }
                    });
                    let ai = inp.x[i] + ri * anchor.ri;
                    let aj = inp.x[j] + rj * anchor.rj;
                    let cij = aj - ai; // (2.31)
                    let cs = cij - cij.dot(nrm) * nrm; // (2.32)–(2.33)
                    let (ft, slid) = friction(p, cs, p.normal_stiffness * c);
                    if slid {
                        // Re-anchor j so the spring holds exactly the dynamic force.
                        let keep = ft.length() / p.tangential_stiffness;
                        let cs_new = if cs.length() > 0.0 { cs * (keep / cs.length()) } else { DVec3::ZERO };
                        anchor.rj = rj.transpose() * (aj - (cs - cs_new) - inp.x[j]);
                        self.sliding += 1;
                    }
                    let dv = inp.v[j] - inp.v[i];
                    let fd = p.damping * dv.dot(nrm) * nrm; // (2.37), normal part
                    let f = fn_vec + ft + fd;
                    let cp = 0.5 * (ai + aj);
                    if !inp.fixed[i] {
                        force[i] += f;
                        torque[i] += (cp - inp.x[i]).cross(f);
                    }
                    if !inp.fixed[j] {
                        force[j] -= f;
                        torque[j] -= (cp - inp.x[j]).cross(f);
                    }
                    seen.insert(key, anchor);
                    self.active.0 += 1;
                }
            }
        }
        self.pairs = seen;
        let mut wall_seen: HashMap<(u32, u16), Anchor> = HashMap::new();
        for (w_idx, wall) in walls.iter().enumerate() {
            for i in 0..n {
                if inp.fixed[i] {
                    continue;
                }
                let dist = wall.normal.dot(inp.x[i]) - wall.offset;
                let c = 0.5 * l0 - dist;
                if c <= 0.0 {
                    continue;
                }
                self.max_overlap = self.max_overlap.max(c / l0);
                let key = (i as u32, w_idx as u16);
                let ri = inp.rot[i];
                // ri: anchor on the particle (own frame); rj: the fixed wall point (world).
                let mut anchor = self.walls.get(&key).copied().unwrap_or_else(|| {
                    let foot = inp.x[i] - dist * wall.normal;
                    Anchor { ri: ri.transpose() * (foot - inp.x[i]), rj: foot }
                });
                let ai = inp.x[i] + ri * anchor.ri;
                let cij = anchor.rj - ai;
                let cs = cij - cij.dot(wall.normal) * wall.normal;
                let fn_mag = p.normal_stiffness * c;
                let (ft, slid) = friction(p, cs, fn_mag);
                if slid {
                    let keep = ft.length() / p.tangential_stiffness;
                    let cs_new = if cs.length() > 0.0 { cs * (keep / cs.length()) } else { DVec3::ZERO };
                    anchor.rj -= cs - cs_new;
                    self.sliding += 1;
                }
                let f = fn_mag * wall.normal + ft - p.damping * inp.v[i].dot(wall.normal) * wall.normal;
                force[i] += f;
                torque[i] += (ai - inp.x[i]).cross(ft);
                wall_seen.insert(key, anchor);
                self.active.1 += 1;
            }
        }
        self.walls = wall_seen;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three bodies of scattered particles, two of them interleaved at their edges, one far:
    /// every particle with another body's particle within l₀ is searched from, the far body's
    /// particles and those deep inside the others are not.
    #[test]
    fn only_particles_near_another_body_are_searched_from() {
        let l0 = 0.1;
        let mut x = Vec::new();
        let mut body = Vec::new();
        for k in 0..3000u32 {
            let t = k as f64;
            let (b, origin) = match k % 3 {
                0 => (0u16, DVec3::ZERO),
                1 => (1, DVec3::new(0.95, 0.0, 0.0)),
                _ => (2, DVec3::new(5.0, 0.0, 0.0)),
            };
            x.push(origin + DVec3::new((t * 0.618_034).fract(), (t * 0.414_214).fract(), (t * 0.732_051).fract()));
            body.push(b);
        }
        let near = near_another_body(&x, &body, l0).expect("two bodies' boxes overlap");
        let mut touching = 0;
        for i in 0..x.len() {
            for j in 0..x.len() {
                if body[i] != body[j] && (x[i] - x[j]).length() < l0 {
                    assert!(near[i] && near[j], "{i} and {j} touch");
                    touching += 1;
                }
            }
        }
        let flagged = near.iter().filter(|&&b| b).count();
        assert!(touching > 100, "{touching} touching pairs");
        assert!((0..x.len()).filter(|&i| body[i] == 2).all(|i| !near[i]), "the far body is never searched from");
        // the two interleaved bodies overlap in a slab 0.05 wide, flagged with l₀ either side
        assert!(flagged > 200 && flagged < 700, "{flagged} of {} flagged", x.len());
    }

    /// Bodies whose boxes lie farther apart than the reach give no flags at all (`None`: no
    /// search, no per-particle pass); a gap just inside the reach flags the particles facing it,
    /// as the per-particle test does.
    #[test]
    fn bodies_apart_are_not_searched_at_all() {
        let l0 = 0.1;
        let scatter = |gap: f64| {
            let (mut x, mut body) = (Vec::new(), Vec::new());
            for k in 0..2000u32 {
                let t = k as f64;
                let b = (k % 2) as u16;
                let origin = DVec3::new(b as f64 * (1.0 + gap), 0.0, 0.0);
                // the first two particles of each body pin its box to the unit cube
                let unit = match k / 2 {
                    0 => DVec3::ZERO,
                    1 => DVec3::ONE,
                    _ => DVec3::new((t * 0.618_034).fract(), (t * 0.414_214).fract(), (t * 0.732_051).fract()),
                };
                x.push(origin + unit);
                body.push(b);
            }
            (x, body)
        };
        for gap in [1.1 * l0, 2.0 * l0, 5.0] {
            let (x, body) = scatter(gap);
            assert!(near_another_body(&x, &body, l0).is_none(), "gap {gap}: no particle can be near");
        }
        let gap = 0.9 * l0;
        let (x, body) = scatter(gap);
        let near = near_another_body(&x, &body, l0).expect("the boxes are within reach");
        let flagged = near.iter().filter(|&&b| b).count();
        // within 1.01 l₀ of the other box: the slabs 0.011 deep on either side of the gap
        assert!(flagged > 10 && flagged < 100, "{flagged} of {} flagged", x.len());
        for i in 0..x.len() {
            let distance = if body[i] == 0 { 1.0 + gap - x[i].x } else { x[i].x - 1.0 };
            if (distance - 1.01 * l0).abs() > 1e-9 {
                assert_eq!(near[i], distance <= 1.01 * l0, "particle {i} {distance:.4} from the other box");
            }
        }
    }
}
