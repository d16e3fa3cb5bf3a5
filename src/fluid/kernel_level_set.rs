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
    /// Particle velocities (c units).
    pub velocities: Vec<[f64; 3]>,
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
    /// `the_binned_sums_see_every_particle_within_reach_in_3d`), for less: asked for the wall
    /// velocity of every ghost node of method 2 at every step.
    pub fn weights(&self, p: [f64; 3]) -> impl Iterator<Item = (usize, f64)> + '_ {
        // r² above this is r > r_e whatever the rounding of r = √r²
        let far = self.re * self.re * (1.0 + 1e-12);
        self.runs(p).flat_map(move |run| {
            self.sorted[run.clone()].iter().zip(&self.order[run]).filter_map(move |(x, &j)| {
                let d = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
                let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                if r2 > far {
                    return None;
                }
                let r = r2.sqrt();
                (r <= self.re).then(|| (j as usize, self.re / r.max(self.r_min) - 1.0))
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
    /// (zero where no particle is within r_e).
    pub fn velocity_at(&self, p: [f64; 3]) -> [f64; 3] {
        let mut v = [0.0; 3];
        let mut sum = 0.0;
        for (j, w) in self.weights(p) {
            sum += w;
            for a in 0..3 {
                v[a] += w * self.velocities[j][a];
            }
        }
        if sum > 0.0 { v.map(|x| x / sum) } else { v }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`KernelLevelSet::new`]'s loops on the pool's threads give the bins, the bin-ordered
    /// points and the bins' sums of one thread bit for bit (and so the same L everywhere):
    /// 50,000 scattered points, many times `PAR_POINTS`, on one thread and on four.
    #[test]
    fn the_bins_built_on_the_pool_are_one_threads_bit_for_bit() {
        let n = 50_000;
        let pts: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let f = i as f64;
                [(f * 0.618_034).fract() * 40.0 - 3.3, (f * 0.414_213).fract() * 25.0 + 1.1, (f * 0.732_05).fract() * 30.0]
            })
            .collect();
        let vel: Vec<[f64; 3]> = (0..n).map(|i| [i as f64 * 1e-3, 0.0, -1.0]).collect();
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| KernelLevelSet::new(pts.clone(), vel.clone(), 1.5, 0.5, 0.7))
        };
        let (one, four) = (build(1), build(4));
        let bits = |v: &[[f64; 3]]| v.iter().flat_map(|x| x.map(f64::to_bits)).collect::<Vec<u64>>();
        assert_eq!(one.bin_box(), four.bin_box());
        assert_eq!(one.bin_lists(), four.bin_lists());
        assert_eq!(bits(&one.sorted), bits(&four.sorted));
        let sums = |s: &KernelLevelSet| s.bin_sums.iter().flat_map(|x| x.map(f64::to_bits)).collect::<Vec<u64>>();
        assert_eq!(sums(&one), sums(&four));
        assert!(one.bin_lists().0.len() > 10_000, "{} bins", one.bin_lists().0.len());
        for p in [[5.0, 7.0, 3.0], [17.3, 12.2, 29.9], [-3.0, 1.5, 0.0]] {
            assert_eq!(one.level(p).0.to_bits(), four.level(p).0.to_bits(), "L at {p:?}");
        }
    }

    /// A single particle: L = r_e/r − 1 − φ, zero at r = r_e/(1 + φ); the distance estimate
    /// −L/|∇L| is exact to first order there, the normal radial, the velocity the particle's.
    #[test]
    fn one_particle_gives_a_circle_of_the_expected_radius() {
        let (re, phi) = (2.0, 1.0);
        let s = KernelLevelSet::new(vec![[5.0, 5.0, 0.0]], vec![[0.1, -0.2, 0.0]], re, 0.25, phi);
        let r0 = re / (1.0 + phi);
        let (l, _) = s.level([5.0 + r0, 5.0, 0.0]);
        assert!(l.abs() < 1e-14, "{l}");
        // Slightly outside: sign and first-order distance; inside, deep or not: the distance
        // to the circle (Newton steps), where −L/|∇L| would say 0.33 at half the radius.
        let d = s.sdf([5.0 + r0 + 0.01, 5.0, 0.0]);
        assert!((d - 0.01).abs() < 2e-4, "{d}");
        for depth in [0.01, 0.3, 0.5] {
            let d = s.sdf([5.0 + r0 - depth, 5.0, 0.0]);
            assert!((d + depth).abs() < 1e-9, "{depth}: {d}");
        }
        let n = s.normal([5.0, 5.0 + 0.7, 0.0]);
        assert!((n[1] - 1.0).abs() < 1e-12 && n[0].abs() < 1e-12, "{n:?}");
        let v = s.velocity_at([5.5, 5.0, 0.0]);
        assert!((v[0] - 0.1).abs() < 1e-15 && (v[1] + 0.2).abs() < 1e-15, "{v:?}");
        // Far away: positive, no particle seen.
        assert!(s.sdf([20.0, 20.0, 0.0]) > 10.0);
        assert_eq!(s.weights([20.0, 20.0, 0.0]).count(), 0);
    }

    /// The binned kernel sum equals the sum over every particle (a scattered cloud, points
    /// in and out of its box), and, bit for bit, the sum over the bins' particles in index order.
    #[test]
    fn the_binned_sum_sees_every_particle_within_reach() {
        let pts: Vec<[f64; 3]> = (0..300)
            .map(|k| {
                let t = k as f64 * 0.618_033_988_75;
                [10.0 + 6.0 * (t * 7.1).sin() * t.fract(), 9.0 + 5.0 * (t * 3.3).cos() * (1.0 - t.fract()), 0.0]
            })
            .collect();
        let s = KernelLevelSet::new(pts.clone(), vec![[0.0; 3]; pts.len()], 2.2, 0.1, 3.0);
        for k in 0..200 {
            let p = [2.0 + 0.09 * k as f64, 1.0 + 0.085 * k as f64, 0.0];
            let brute: f64 = pts
                .iter()
                .map(|x| {
                    let r = ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2)).sqrt();
                    if r <= 2.2 { 2.2 / r.max(0.1) - 1.0 } else { 0.0 }
                })
                .sum::<f64>()
                - 3.0;
            let (l, g) = s.level(p);
            assert!((l - brute).abs() < 1e-9 * brute.abs().max(1.0), "{p:?}: {l} vs {brute}");
            // the same sums, bit for bit, as over `candidates` (the bins' particles through `order`
            // and `points`, where `level` reads the bin-ordered copy)
            let (mut l_ref, mut g_ref) = (-s.phi, [0.0; 3]);
            for j in s.candidates(p) {
                let d = [p[0] - pts[j][0], p[1] - pts[j][1], p[2] - pts[j][2]];
                let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                if r <= s.re {
                    l_ref += s.re / r.max(s.r_min) - 1.0;
                    if r > s.r_min {
                        (0..3).for_each(|a| g_ref[a] += -s.re / (r * r * r) * d[a]);
                    }
                }
            }
            assert_eq!((l.to_bits(), g.map(f64::to_bits)), (l_ref.to_bits(), g_ref.map(f64::to_bits)), "{p:?}");
            assert_eq!(s.weights(p).count(), pts.iter().filter(|x| ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2)).sqrt() <= 2.2).count());
        }
    }

    /// In 3D, with particles and points on bin edges and exactly r_e apart (a lattice of
    /// particles, spacing 0.4, r_e = 1, probed at the particles, at r_e from them along axes and
    /// diagonals, and scattered): the binned sums equal the sums over every particle,
    /// `weights` finds exactly the particles within r_e, `level_value` is `level`'s L bit for
    /// bit, and `outside_distance` stops early (`sums`) exactly where L > 0.
    #[test]
    fn the_binned_sums_see_every_particle_within_reach_in_3d() {
        let mut pts = Vec::new();
        for k in -12..=12 {
            for j in -12..=12 {
                for i in -12..=12 {
                    let x = [0.4 * i as f64, 0.4 * j as f64, 0.4 * k as f64];
                    if x[0] * x[0] + x[1] * x[1] + x[2] * x[2] <= 16.0 {
                        pts.push([x[0] + 7.0, x[1] + 7.0, x[2] + 7.0]);
                    }
                }
            }
        }
        let (re, r_min) = (1.0, 0.5);
        let s = KernelLevelSet::new(pts.clone(), vec![[0.0; 3]; pts.len()], re, r_min, 2.0);
        let mut probes = Vec::new();
        for (n, x) in pts.iter().enumerate().step_by(7) {
            let unit = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.6, 0.8, 0.0], [0.0, 0.6, -0.8]][n % 5];
            probes.push([x[0] + re * unit[0], x[1] + re * unit[1], x[2] + re * unit[2]]);
            probes.push(*x);
        }
        for k in 0..3000 {
            let t = k as f64;
            probes.push([7.0 + 5.0 * (t * 0.731).sin(), 7.0 + 5.0 * (t * 0.397).cos(), 7.0 + 5.0 * (t * 0.113).sin()]);
        }
        let mut inside = 0;
        for p in &probes {
            let within: Vec<&[f64; 3]> = pts.iter().filter(|x| ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2) + (x[2] - p[2]).powi(2)).sqrt() <= re).collect();
            let brute: f64 =
                within.iter().map(|x| re / ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2) + (x[2] - p[2]).powi(2)).sqrt().max(r_min) - 1.0).sum::<f64>()
                    - s.phi;
            assert_eq!(s.weights(*p).count(), within.len(), "{p:?}");
            // the weights read from the bin-ordered positions: the candidates' own positions'
            // weights, one at a time, in the same order, bit for bit
            let one_by_one: Vec<(usize, u64)> = s
                .candidates(*p)
                .filter_map(|j| {
                    let x = pts[j];
                    let r = ((x[0] - p[0]).powi(2) + (x[1] - p[1]).powi(2) + (x[2] - p[2]).powi(2)).sqrt();
                    (r <= re).then(|| (j, (re / r.max(r_min) - 1.0).to_bits()))
                })
                .collect();
            assert_eq!(s.weights(*p).map(|(j, w)| (j, w.to_bits())).collect::<Vec<_>>(), one_by_one, "{p:?}");
            let (l, _) = s.level(*p);
            assert!((l - brute).abs() < 1e-12 * brute.abs().max(1.0), "{p:?}: {l} vs {brute}");
            assert_eq!(s.level_value(*p).to_bits(), l.to_bits(), "{p:?}");
            assert_eq!(s.outside_distance(*p).is_none(), l > 0.0, "{p:?}");
            if l > 0.0 {
                inside += 1;
            }
        }
        assert!(inside > 1000 && inside < probes.len() - 1000, "{inside} of {} inside", probes.len());
    }

    /// The layout classifies nodes by `outside_distance` and must find the same side and, outside,
    /// the same distance as `sdf`, bit for bit: checked at 24 000 points on and around a ball of
    /// particles (3D, r_e = 2 cells, clamp r_e/2, φ its surface level) — including points on
    /// its contour, where L changes sign — and at a point exactly on a one-particle circle.
    #[test]
    fn outside_distance_agrees_with_sdf_bit_for_bit() {
        let mut pts = Vec::new();
        for k in -8..8 {
            for j in -8..8 {
                for i in -8..8 {
                    let x = [(i as f64 + 0.5) * 0.5, (j as f64 + 0.5) * 0.5, (k as f64 + 0.5) * 0.5];
                    if x[0] * x[0] + x[1] * x[1] + x[2] * x[2] < 9.0 {
                        pts.push([x[0] + 10.2, x[1] + 9.7, x[2] + 10.0]);
                    }
                }
            }
        }
        let mut s = KernelLevelSet::new(pts.clone(), vec![[0.0; 3]; pts.len()], 2.0, 1.0, 0.0);
        s.phi = s.level([13.2, 9.7, 10.0]).0;
        let (mut inside, mut outside, mut on) = (0, 0, 0);
        for k in 0..24_000 {
            let t = k as f64;
            let p = [10.2 + 4.5 * (t * 0.731).sin(), 9.7 + 4.5 * (t * 0.397).cos(), 10.0 + 4.5 * (t * 0.113).sin()];
            // every tenth point moved onto the contour along its ray from the centre
            let p = if k % 10 == 0 {
                let c = [10.2, 9.7, 10.0];
                let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
                let (mut lo, mut hi) = (0.0, 1.5);
                for _ in 0..80 {
                    let m = 0.5 * (lo + hi);
                    if s.level([c[0] + m * d[0], c[1] + m * d[1], c[2] + m * d[2]]).0 > 0.0 { lo = m } else { hi = m }
                }
                on += 1;
                [c[0] + lo * d[0], c[1] + lo * d[1], c[2] + lo * d[2]]
            } else {
                p
            };
            let d = s.sdf(p);
            match s.outside_distance(p) {
                None => {
                    assert!(d < 0.0, "{p:?}: sdf {d} but classified inside");
                    inside += 1;
                }
                Some(o) => {
                    assert_eq!(o.to_bits(), d.to_bits(), "{p:?}");
                    outside += 1;
                }
            }
        }
        assert!(inside > 2000 && outside > 2000 && on == 2400, "{inside} {outside} {on}");
        // on the contour of one particle: L = 0 exactly is outside, with distance 0
        let one = KernelLevelSet::new(vec![[5.0, 5.0, 0.0]], vec![[0.0; 3]], 2.0, 0.25, 1.0);
        assert_eq!(one.level([6.0, 5.0, 0.0]).0, 0.0);
        assert_eq!(one.outside_distance([6.0, 5.0, 0.0]).map(f64::to_bits), Some(one.sdf([6.0, 5.0, 0.0]).to_bits()));
        assert!(one.sdf([5.999, 5.0, 0.0]) < 0.0 && one.outside_distance([5.999, 5.0, 0.0]).is_none());
    }

    /// (2.130): two particles' velocities mix in the ratio of their kernel weights.
    #[test]
    fn the_wall_velocity_is_the_normalised_kernel_mean() {
        let s = KernelLevelSet::new(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 2.0, 0.1, 0.5);
        // At x = 0.25: r = 0.25 and 0.75, weights 7 and 5/3.
        let v = s.velocity_at([0.25, 0.0, 0.0]);
        let (a, b) = (7.0, 5.0 / 3.0);
        assert!((v[0] - a / (a + b)).abs() < 1e-14 && (v[1] - b / (a + b)).abs() < 1e-14, "{v:?}");
    }
}
