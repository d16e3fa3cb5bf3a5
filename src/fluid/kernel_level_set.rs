//! A solid given by the level set of a cloud of particles (seed 000 §2.4.2, 2.124–2.126,
//! 2.130): the wall the momentum-conserving coupling (method 2) shows the fluid, with no
//! surface polygon.
//!
//! * (2.124) L(x) = Σ_{j: r_j ≤ r_e} w(r_j) − φ, w(r) = r_e/r − 1 (the MPS kernel (2.20)), over
//!   the particles j at distance r_j from x: positive inside, negative outside. The kernel is
//!   singular at r = 0, so r is clamped at `r_min`.
//! * The signed distance the fluid's ghost nodes need is L's first-order estimate
//!   −L(x)/|∇L(x)| (∇L analytic), and the outward normal is −∇L/|∇L| (2.126) — the seed's
//!   central difference of L at nodes, taken here at the point itself.
//! * (2.130) The wall velocity at a point is the particles' velocities averaged with the
//!   kernel weights there, normalised to sum to one.
//!
//! Units: lattice cells for positions and lengths, c for velocities.

use rayon::prelude::*;

/// The particles of one body and the level set they define.
#[derive(Clone, Debug)]
pub struct KernelLevelSet {
    /// Particle positions (lattice coordinates).
    pub points: Vec<[f64; 3]>,
    /// Particle velocities (c units; read through [`Self::velocities`]: their bin-ordered copy
    /// is made with the bins).
    velocities: Vec<[f64; 3]>,
    /// Kernel radius r_e (cells).
    pub re: f64,
    /// Clamp of r in the kernel (cells).
    pub r_min: f64,
    /// Surface level φ.
    pub phi: f64,
    /// Bounding box of the points grown by r_e (min, max).
    bounds: ([f64; 3], [f64; 3]),
    /// Bins of side r_e over the box: bin b holds the points `order[start[b]..start[b + 1]]`,
    /// so that a point's kernel sum visits the 3ᴰ bins around it only.
    bins: [usize; 3],
    start: Vec<u32>,
    order: Vec<u32>,
    /// The points in bin order (`points[order[k]]` at k): [`Self::level`] reads each bin's as
    /// one contiguous run.
    sorted: Vec<[f64; 3]>,
    /// The velocities in the same order (`velocities[order[k]]` at k): what
    /// [`Self::velocity_at`] and a device's twin of it read.
    sorted_velocities: Vec<[f64; 3]>,
    /// Per bin, the sum of its points' coordinates and their number: the coarse picture of the
    /// body [`Self::mass_outward`] reads.
    bin_sums: Vec<[f64; 4]>,
    /// Which binning this is ([`Self::id`]).
    id: u64,
}

/// The next [`KernelLevelSet::id`].
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Equal points, velocities, kernel and level: the bins are made from them ([`KernelLevelSet::new`]
/// is deterministic), and the [`KernelLevelSet::id`] of the binning is left aside (one body
/// binned alike at two steps is the same wall: `Layout::rebuilt` compares the obstacles each step).
impl PartialEq for KernelLevelSet {
    fn eq(&self, o: &Self) -> bool {
        (&self.points, &self.velocities, self.re, self.r_min, self.phi) == (&o.points, &o.velocities, o.re, o.r_min, o.phi)
    }
}

/// Points per task of [`KernelLevelSet::new`]'s parallel loops.
const PAR_POINTS: usize = 4096;

/// Smallest |∇L| (per cell) used in −L/|∇L|: deep inside a body, or far outside it, where L is
/// flat, the estimate becomes large with the right sign instead of infinite.
pub(super) const FLAT: f64 = 1e-6;

/// Newton steps [`KernelLevelSet::depth`] takes before it gives up. Where L has a gradient that
/// points at the surface the steps converge in 3–6 (measured on the flap and the cylinder of
/// the coupled scenes: every call of their first two steps); deep in a thick body, where every particle
/// within r_e of the point is there and L has levelled off, ∇L is the particles' granularity and
/// the steps wander (the coarse 3D glottis: 954 of 5446 ghost depths ran all of an earlier cap
/// of 32 steps, ≈ 1100 more ended after 9–31 on whatever part of the contour the walk met).
const NEWTON_STEPS: usize = 8;

impl KernelLevelSet {
    /// The level set of `points` (with their `velocities`), binned. Built once a step for every
    /// body (and, on the GPU backend, once more for all bodies' particles together), so the
    /// per-point work runs on the pool's threads: the box (a minimum and maximum, the same
    /// whatever the order), each point's bin, the points gathered in bin order and each bin's
    /// sums (each bin's own points in their order) — the same bins and sums bit for bit as one
    /// by one; only the counting sort's two passes are serial.
    pub fn new(points: Vec<[f64; 3]>, velocities: Vec<[f64; 3]>, re: f64, r_min: f64, phi: f64) -> Self {
        assert_eq!(points.len(), velocities.len(), "one velocity per particle");
        let grow = |(mut lo, mut hi): ([f64; 3], [f64; 3]), p: &[f64; 3]| {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] - re);
                hi[a] = hi[a].max(p[a] + re);
            }
            (lo, hi)
        };
        let empty = || ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let (lo, hi) = points
            .par_iter()
            .with_min_len(PAR_POINTS)
            .fold(empty, grow)
            .reduce(empty, |a, b| (std::array::from_fn(|k| a.0[k].min(b.0[k])), std::array::from_fn(|k| a.1[k].max(b.1[k]))));
        let bins: [usize; 3] = std::array::from_fn(|a| if points.is_empty() { 1 } else { (((hi[a] - lo[a]) / re).ceil() as usize).max(1) });
        let mut s = KernelLevelSet {
            points,
            velocities,
            re,
            r_min,
            phi,
            bounds: (lo, hi),
            bins,
            start: Vec::new(),
            order: Vec::new(),
            sorted: Vec::new(),
            sorted_velocities: Vec::new(),
            bin_sums: Vec::new(),
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        };
        let n_bins = bins[0] * bins[1] * bins[2];
        let key: Vec<usize> = s.points.par_iter().with_min_len(PAR_POINTS).map(|p| s.bin_of(*p).expect("a point lies in its own box")).collect();
        let mut count = vec![0u32; n_bins + 1];
        for &k in &key {
            count[k + 1] += 1;
        }
        for b in 0..n_bins {
            count[b + 1] += count[b];
        }
        let mut fill = count.clone();
        let mut order = vec![0u32; key.len()];
        for (j, &k) in key.iter().enumerate() {
            order[fill[k] as usize] = j as u32;
            fill[k] += 1;
        }
        s.sorted = order.par_iter().with_min_len(PAR_POINTS).map(|&j| s.points[j as usize]).collect();
        s.sorted_velocities = order.par_iter().with_min_len(PAR_POINTS).map(|&j| s.velocities[j as usize]).collect();
        s.bin_sums = (0..n_bins)
            .into_par_iter()
            .with_min_len(PAR_POINTS / 8)
            .map(|b| {
                let run = &s.sorted[count[b] as usize..count[b + 1] as usize];
                let mut sum = [0.0, 0.0, 0.0, run.len() as f64];
                for x in run {
                    (0..3).for_each(|a| sum[a] += x[a]);
                }
                sum
            })
            .collect();
        (s.start, s.order) = (count, order);
        s
    }

    /// The bins' box (lower and upper corner: the points' bounding box grown by r_e) and the
    /// number of bins per axis (each of side r_e).
    pub fn bin_box(&self) -> ([f64; 3], [f64; 3], [usize; 3]) {
        (self.bounds.0, self.bounds.1, self.bins)
    }

    /// The bins as lists: bin b holds the points `order[start[b]..start[b + 1]]`.
    pub fn bin_lists(&self) -> (&[u32], &[u32]) {
        (&self.start, &self.order)
    }

    /// A number no other binning made by [`Self::new`] in this process has (a clone keeps it):
    /// a device that holds a set's bins knows by it whether they are the ones it holds.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// The points in bin order (bin b's are `start[b]..start[b + 1]` of these, in the order
    /// the sums visit them) and each bin's sum of coordinates and count: what a device's twin
    /// of [`Self::ghost_wall`] reads.
    pub fn binned_points(&self) -> (&[[f64; 3]], &[[f64; 4]]) {
        (&self.sorted, &self.bin_sums)
    }

    /// The particles' velocities in bin order (those of [`Self::binned_points`]' points): what a
    /// device's twin of [`Self::velocity_at`] reads.
    pub fn binned_velocities(&self) -> &[[f64; 3]] {
        &self.sorted_velocities
    }

    /// The particles' velocities (c units), in the order of [`Self::points`].
    pub fn velocities(&self) -> &[[f64; 3]] {
        &self.velocities
    }

    fn near(&self, p: [f64; 3]) -> bool {
        let (lo, hi) = self.bounds;
        (0..3).all(|a| p[a] >= lo[a] && p[a] <= hi[a])
    }

    fn cell_of(&self, p: [f64; 3]) -> [i64; 3] {
        std::array::from_fn(|a| ((p[a] - self.bounds.0[a]) / self.re).floor() as i64)
    }

    fn bin_of(&self, p: [f64; 3]) -> Option<usize> {
        let c = self.cell_of(p);
        (0..3).all(|a| c[a] >= 0 && (c[a] as usize) < self.bins[a]).then(|| (c[2] as usize * self.bins[1] + c[1] as usize) * self.bins[0] + c[0] as usize)
    }

    /// The bins around `p` as runs of bin-ordered slots (indices into `order` and `sorted`):
    /// one run per row of up to three bins along x, rows in z then y order; none when `p` is
    /// farther than r_e from every point's box.
    fn runs(&self, p: [f64; 3]) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let near = self.near(p);
        let c = self.cell_of(p);
        let b = self.bins;
        let range = move |a: usize| (c[a] - 1).max(0)..=(c[a] + 1).min(b[a] as i64 - 1);
        let (x0, x1) = (*range(0).start(), *range(0).end());
        range(2).filter(move |_| near).flat_map(move |z| {
            range(1).map(move |y| {
                let row = (z as usize * b[1] + y as usize) * b[0];
                self.start[row + x0 as usize] as usize..self.start[row + x1 as usize + 1] as usize
            })
        })
    }

    /// The direction away from the body's mass that `p` sees within `radius` (cells), from the
    /// bins' centroids: Σ_b n_b (p − c_b) (1 − |p − c_b|/R)² over the bins whose
    /// centroid c_b (of n_b points) lies within R = `radius`, normalised; zero where the sum is.
    /// Deep in a thick body, where ∇L over r_e sees only the particles' granularity, this sees
    /// the surface (`fluid::ghost_wall`) for the cost of one bin per r_e³.
    pub(super) fn mass_outward(&self, p: [f64; 3], radius: f64) -> [f64; 3] {
        let c = self.cell_of(p);
        let k = (radius / self.re).ceil() as i64;
        let range = |a: usize| (c[a] - k).max(0)..=(c[a] + k).min(self.bins[a] as i64 - 1);
        let mut v = [0.0; 3];
        for z in range(2) {
            for y in range(1) {
                for x in range(0) {
                    let b = (z as usize * self.bins[1] + y as usize) * self.bins[0] + x as usize;
                    let [sx, sy, sz, n] = self.bin_sums[b];
                    if n == 0.0 {
                        continue;
                    }
                    let d = [p[0] - sx / n, p[1] - sy / n, p[2] - sz / n];
                    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    if r > 0.0 && r < radius {
                        let w = n * (1.0 - r / radius).powi(2);
                        (0..3).for_each(|a| v[a] += w * d[a]);
                    }
                }
            }
        }
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if len > 0.0 { v.map(|x| x / len) } else { [0.0; 3] }
    }

    /// The particles in the bins around `p` (every particle within r_e of it, and some more),
    /// through `order`: the reference the tests hold the bin-ordered sums and weights to.
    #[cfg(test)]
    fn candidates(&self, p: [f64; 3]) -> impl Iterator<Item = usize> + '_ {
        self.runs(p).flat_map(move |run| self.order[run].iter().map(|&j| j as usize))
    }

    /// The kernel weight of every particle within r_e of `p`: (particle, w) (2.124), in the
    /// bins' order around `p` (rows in z then y). The positions are read from `Self::sorted`
    /// one run per row of bins (as [`Self::level`] reads them), and the particles beyond r_e by
    /// more than round-off are passed over before the square root: the same weights bit for
    /// bit as from `points[j]` one particle at a time (test
    /// `the_binned_sums_see_every_particle_within_reach_in_3d`), for less: the hand-over
    /// (2.127–2.128) asks it at every crossing point of method 2 at every step.
    pub fn weights(&self, p: [f64; 3]) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.slot_weights(p).map(|(k, w)| (self.order[k] as usize, w))
    }

    /// [`Self::weights`] by bin-ordered slot (an index into `sorted` and `sorted_velocities`)
    /// instead of by particle: the same weights in the same order.
    fn slot_weights(&self, p: [f64; 3]) -> impl Iterator<Item = (usize, f64)> + '_ {
        // r² above this is r > r_e whatever the rounding of r = √r²
        let far = self.re * self.re * (1.0 + 1e-12);
        self.runs(p).flat_map(move |run| {
            self.sorted[run.clone()].iter().zip(run).filter_map(move |(x, k)| {
                let d = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
                let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                if r2 > far {
                    return None;
                }
                let r = r2.sqrt();
                (r <= self.re).then(|| (k, self.re / r.max(self.r_min) - 1.0))
            })
        })
    }

    /// L(p) and ∇L(p) (per cell), summed over the particles of the bins around `p` in the
    /// bins' order (read from `Self::sorted` as one run per row of bins: the same sums bit for
    /// bit as over the particles through `order`, tests below);
    /// those beyond r_e by more than round-off are passed over before the square root.
    pub fn level(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        self.sums::<true, false>(p).expect("runs to the end")
    }

    /// L(p) alone: the same value as `level(p).0`, bit for bit (the same sum in the same order),
    /// without the gradient: the ghost walls' searches along a line need only L.
    pub(super) fn level_value(&self, p: [f64; 3]) -> f64 {
        self.sums::<false, false>(p).expect("runs to the end").0
    }

    /// The kernel sums at `p`: L and, with `GRADIENT`, ∇L (else zero). With `STOP_INSIDE`,
    /// `None` as soon as L > 0 after a row of bins: every term r_e/max(r, r_min) − 1 is ≥ 0 in
    /// floating point too (r ≤ r_e), and a rounded sum with a term ≥ 0 added does not fall, so
    /// the whole sum would be > 0 as well — the point is inside; a sum that does not stop is
    /// the full one, bit for bit.
    fn sums<const GRADIENT: bool, const STOP_INSIDE: bool>(&self, p: [f64; 3]) -> Option<(f64, [f64; 3])> {
        let mut l = -self.phi;
        let mut g = [0.0; 3];
        // r² above this is r > r_e whatever the rounding of r = √r²; below it, r is compared
        let far = self.re * self.re * (1.0 + 1e-12);
        for run in self.runs(p) {
            for x in &self.sorted[run] {
                let d = [p[0] - x[0], p[1] - x[1], p[2] - x[2]];
                let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                if r2 > far {
                    continue;
                }
                let r = r2.sqrt();
                if r > self.re {
                    continue;
                }
                l += self.re / r.max(self.r_min) - 1.0;
                if GRADIENT && r > self.r_min {
                    // d/dr (r_e/r) = −r_e/r², along d/r.
                    let k = -self.re / (r * r * r);
                    for a in 0..3 {
                        g[a] += k * d[a];
                    }
                }
            }
            if STOP_INSIDE && l > 0.0 {
                return None;
            }
        }
        Some((l, g))
    }

    /// Signed distance (cells), positive outside. Outside (L ≤ 0) the first-order estimate
    /// −L/|∇L| (φ/`FLAT`, far, where no particle is within r_e), enough for the layout's
    /// inside/outside and pinch tests. Inside, where ghost nodes need their distance to the
    /// wall and L flattens away from the surface (−L/|∇L| there overestimates the depth several
    /// times, which would put a ghost's image point far out in the flow), the distance to the
    /// zero contour found by Newton steps along ∇L from the point.
    ///
    /// Inside means L > 0: `sdf(p) < 0` exactly where L(p) > 0 (a Newton distance that comes
    /// out as 0 is raised to the smallest positive number), so that
    /// [`Self::outside_distance`] can classify a node from L alone.
    pub fn sdf(&self, p: [f64; 3]) -> f64 {
        let (l, g) = self.level(p);
        let n = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if !(l > 0.0) {
            return -l / n.max(FLAT);
        }
        let depth = self.depth(p, (l, g)).unwrap_or(l / n.max(FLAT));
        -if depth == 0.0 { f64::MIN_POSITIVE } else { depth }
    }

    /// `None` inside (L > 0, where [`Self::sdf`] would run its Newton steps), else
    /// `Some(sdf(p))` — the same value, bit for bit — from one evaluation of L and ∇L: the
    /// layout classifies every node by this and asks for the depth of its ghost nodes only.
    /// Inside, the sum stops at the first row of bins after which L > 0 (`Self::sums`).
    pub fn outside_distance(&self, p: [f64; 3]) -> Option<f64> {
        let (l, g) = self.sums::<true, true>(p)?;
        (!(l > 0.0)).then(|| -l / (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt().max(FLAT))
    }

    /// Distance from an inside point to the zero contour by Newton steps x ← x − L ∇L/|∇L|²
    /// (each at most half a cell); `None` if L is flat, if a step does not bring L closer to 0
    /// (where L has levelled off, deep in a thick body, ∇L is the particles' granularity and
    /// the steps wander: `fluid::ghost_wall`) or if the steps do not reach the contour within
    /// [`NEWTON_STEPS`].
    /// `at_p` is L and ∇L at `p` (the callers have them already).
    pub(super) fn depth(&self, p: [f64; 3], at_p: (f64, [f64; 3])) -> Option<f64> {
        let mut x = p;
        let mut last = f64::INFINITY;
        for k in 0..NEWTON_STEPS {
            let (l, g) = if k == 0 { at_p } else { self.level(x) };
            let g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
            if g2 < FLAT * FLAT || !(l.abs() < last) {
                return None;
            }
            last = l.abs();
            let mut step = [-l * g[0] / g2, -l * g[1] / g2, -l * g[2] / g2];
            let len = (step[0] * step[0] + step[1] * step[1] + step[2] * step[2]).sqrt();
            if len > 0.5 {
                step = step.map(|s| s * 0.5 / len);
            }
            for a in 0..3 {
                x[a] += step[a];
            }
            if len < 1e-9 {
                return Some(((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2) + (x[2] - p[2]).powi(2)).sqrt());
            }
        }
        None
    }

    /// Outward unit normal −∇L/|∇L| (2.126); zero where L is flat.
    pub fn normal(&self, p: [f64; 3]) -> [f64; 3] {
        let (_, g) = self.level(p);
        let n = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if n > 0.0 { [-g[0] / n, -g[1] / n, -g[2] / n] } else { [0.0; 3] }
    }

    /// Wall velocity at `p` (2.130): the kernel-weighted mean of the particles' velocities
    /// (zero where no particle is within r_e), summed in the bins' order from the bin-ordered
    /// velocities (shaders/level_set_queries.wgsl `wall_velocity` is its twin).
    pub fn velocity_at(&self, p: [f64; 3]) -> [f64; 3] {
        let mut v = [0.0; 3];
        let mut sum = 0.0;
        for (k, w) in self.slot_weights(p) {
            sum += w;
            for a in 0..3 {
                v[a] += w * self.sorted_velocities[k][a];
            }
        }
        if sum > 0.0 { v.map(|x| x / sum) } else { v }
    }
}

#[cfg(test)]
#[path = "kernel_level_set_tests.rs"]
mod tests;
