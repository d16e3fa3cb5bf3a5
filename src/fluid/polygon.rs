//! A closed polygon in the x–y plane (a prism along z in 3D): the wall that the weak coupling
//! (seed §2.4.1) hands the fluid each step, built from the folds' surface particles. The lattice
//! asks it, for every node near the body, which side the node is on and how far the wall is
//! (`sdf`), and at ghost nodes the wall's normal and velocity; each of these questions is
//! answered from a uniform grid of bins over the edges ([`EdgeBins`]), so that a question costs
//! the edges near the point instead of all of them — with the same answer, bit for bit, as the
//! plain loop over every edge (the test below compares them).

use super::geometry::Outside;

/// A closed, simple polygon in the x–y plane (lattice units), counter-clockwise, with a wall
/// velocity (c units) at every vertex, linear along each edge. Immutable once built: a moving
/// wall is a new polygon each step.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    vertices: Vec<[f64; 2]>,
    velocities: Vec<[f64; 3]>,
    /// Bounding box (min x, min y, max x, max y).
    bounds: [f64; 4],
    /// The edges binned for the nearest-edge and crossing-number queries (None for polygons of
    /// a few edges, which the plain loop answers as fast).
    bins: Option<EdgeBins>,
}

/// Polygons with fewer edges than this are not binned.
const BIN_FROM_EDGES: usize = 16;
/// At most this many bins along an axis (a larger polygon gets larger bins).
const MAX_BINS_PER_AXIS: usize = 256;

impl Polygon {
    /// `vertices` counter-clockwise; one velocity per vertex.
    pub fn new(vertices: Vec<[f64; 2]>, velocities: Vec<[f64; 3]>) -> Self {
        assert_eq!(vertices.len(), velocities.len(), "one velocity per vertex");
        let mut bounds = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        for v in &vertices {
            bounds = [bounds[0].min(v[0]), bounds[1].min(v[1]), bounds[2].max(v[0]), bounds[3].max(v[1])];
        }
        let mut p = Polygon { vertices, velocities, bounds, bins: None };
        if p.vertices.len() >= BIN_FROM_EDGES && bounds.iter().all(|b| b.is_finite()) {
            p.bins = Some(EdgeBins::new(&p));
        }
        p
    }

    /// The vertices (lattice units), counter-clockwise.
    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.vertices
    }

    /// The wall velocity at each vertex (c units).
    pub fn velocities(&self) -> &[[f64; 3]] {
        &self.velocities
    }

    /// Bounding box (min x, min y, max x, max y).
    pub fn bounds(&self) -> [f64; 4] {
        self.bounds
    }

    /// Twice the signed area (positive when counter-clockwise).
    pub fn signed_area(&self) -> f64 {
        let n = self.vertices.len();
        (0..n)
            .map(|k| {
                let (a, b) = (self.vertices[k], self.vertices[(k + 1) % n]);
                a[0] * b[1] - b[0] * a[1]
            })
            .sum::<f64>()
            * 0.5
    }

    /// Edge k from vertex k to vertex k + 1 (cyclic).
    #[inline]
    fn edge(&self, k: usize) -> ([f64; 2], [f64; 2]) {
        (self.vertices[k], self.vertices[(k + 1) % self.vertices.len()])
    }

    /// Closest point of edge `k` to `p`: (parameter t ∈ [0, 1] along it, squared distance).
    #[inline]
    fn edge_distance(&self, k: usize, p: [f64; 2]) -> (f64, f64) {
        let (a, b) = self.edge(k);
        let e = [b[0] - a[0], b[1] - a[1]];
        let l2 = e[0] * e[0] + e[1] * e[1];
        let t = if l2 > 0.0 { (((p[0] - a[0]) * e[0] + (p[1] - a[1]) * e[1]) / l2).clamp(0.0, 1.0) } else { 0.0 };
        let d = [a[0] + t * e[0] - p[0], a[1] + t * e[1] - p[1]];
        (t, d[0] * d[0] + d[1] * d[1])
    }

    /// Closest point of the boundary to `p`: (edge index, parameter t ∈ [0, 1] along it, squared
    /// distance); of several edges equally near, the lowest index.
    pub fn closest(&self, p: [f64; 2]) -> (usize, f64, f64) {
        if let Some(best) = self.bins.as_ref().and_then(|b| b.closest(self, p, None)) {
            return best;
        }
        self.closest_by_every_edge(p)
    }

    /// [`Self::closest`] by the plain loop over every edge.
    pub fn closest_by_every_edge(&self, p: [f64; 2]) -> (usize, f64, f64) {
        let mut best = (0, 0.0, f64::INFINITY);
        for k in 0..self.vertices.len() {
            let (t, d2) = self.edge_distance(k, p);
            if d2 < best.2 {
                best = (k, t, d2);
            }
        }
        best
    }

    /// Whether edge k crosses the ray from `p` towards +x (crossing-number rule).
    #[inline]
    fn crosses(&self, k: usize, p: [f64; 2]) -> bool {
        let (a, b) = self.edge(k);
        (a[1] > p[1]) != (b[1] > p[1]) && p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0])
    }

    /// Whether `p` lies inside (crossing number).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        if p[0] < self.bounds[0] || p[0] > self.bounds[2] || p[1] < self.bounds[1] || p[1] > self.bounds[3] {
            return false;
        }
        match self.bins.as_ref().and_then(|b| b.band(p[1])) {
            Some(edges) => edges.iter().filter(|&&k| self.crosses(k as usize, p)).count() % 2 == 1,
            None => self.contains_by_every_edge(p),
        }
    }

    /// [`Self::contains`] by the plain loop over every edge.
    pub fn contains_by_every_edge(&self, p: [f64; 2]) -> bool {
        if p[0] < self.bounds[0] || p[0] > self.bounds[2] || p[1] < self.bounds[1] || p[1] > self.bounds[3] {
            return false;
        }
        (0..self.vertices.len()).filter(|&k| self.crosses(k, p)).count() % 2 == 1
    }

    /// Wall velocity at the boundary point closest to `p` (linear along the edge).
    pub fn velocity_at(&self, p: [f64; 2]) -> [f64; 3] {
        let (k, t, _) = self.closest(p);
        let (a, b) = (self.velocities[k], self.velocities[(k + 1) % self.vertices.len()]);
        std::array::from_fn(|i| (1.0 - t) * a[i] + t * b[i])
    }

    /// Signed distance, positive outside. Outside the bounding box it returns the distance to
    /// the box, a lower bound of the true distance with the right sign (the layout only uses
    /// the value inside a solid).
    pub(super) fn sdf(&self, p: [f64; 2]) -> f64 {
        if let Some(d) = self.box_distance(p) {
            return d;
        }
        let d = self.closest(p).2.sqrt();
        if self.contains(p) { -d } else { d }
    }

    /// The distance from `p` to the bounding box where `p` lies outside it ([`Self::sdf`]
    /// there), None inside the box.
    fn box_distance(&self, p: [f64; 2]) -> Option<f64> {
        let b = self.bounds;
        let q = [(b[0] - p[0]).max(p[0] - b[2]).max(0.0), (b[1] - p[1]).max(p[1] - b[3]).max(0.0)];
        (q[0] > 0.0 || q[1] > 0.0).then(|| (q[0] * q[0] + q[1] * q[1]).sqrt())
    }

    /// `None` where `p` is inside (`sdf(p) < 0`), else `Some(sdf(p))`, bit for bit: a point inside
    /// needs only the crossing number and whether an edge passes exactly through it (where
    /// `sdf` is −0), not the distance to the wall, which for a point deep inside a fold is the
    /// costly part of [`Self::sdf`].
    pub(super) fn outside_distance(&self, p: [f64; 2]) -> Option<f64> {
        self.outside_distance_within(p, None)
    }

    /// [`Self::outside_distance`] where it is below `limit` (bit for bit), else
    /// [`Outside::Beyond`]: outside, the bins are searched only in the rings that reach `limit`
    /// ([`EdgeBins::closest`] `within` it), not out to the nearest edge — for a point in the
    /// polygon's box but far from its boundary (a concave outline's gap, the air between two
    /// folds) the full search visits most of the bins.
    pub(super) fn outside_distance_below(&self, p: [f64; 2], limit: f64) -> Outside {
        Outside::of(self.outside_distance_within(p, Some(limit)), limit)
    }

    /// [`Self::outside_distance`], its value exact wherever it lies below `within` (when given);
    /// at or beyond it, a distance at least that large.
    fn outside_distance_within(&self, p: [f64; 2], within: Option<f64>) -> Option<f64> {
        if let Some(d) = self.box_distance(p) {
            return Some(d);
        }
        if self.contains(p) {
            return self.on_boundary(p).then_some(-0.0);
        }
        let (_, _, d2) = self.bins.as_ref().and_then(|b| b.closest(self, p, within)).unwrap_or_else(|| self.closest_by_every_edge(p));
        Some(d2.sqrt())
    }

    /// Whether an edge passes exactly through `p` (squared distance 0, as [`Self::closest`]
    /// computes it).
    fn on_boundary(&self, p: [f64; 2]) -> bool {
        match self.bins.as_ref().and_then(|b| b.bin_edges(p)) {
            Some(edges) => edges.iter().any(|&k| self.edge_distance(k as usize, p).1 == 0.0),
            None => (0..self.vertices.len()).any(|k| self.edge_distance(k, p).1 == 0.0),
        }
    }

    /// Unit normal pointing out of the polygon at the boundary point closest to `p`.
    pub(super) fn normal(&self, p: [f64; 2]) -> [f64; 3] {
        let (k, t, d2) = self.closest(p);
        self.normal_from(p, (k, t, d2), || self.contains(p))
    }

    /// [`Self::sdf`] and [`Self::normal`] at `p`, bit for bit, from one nearest-edge search and
    /// one crossing number (each of the two alone takes both): a ghost node's wall.
    pub(super) fn sdf_and_normal(&self, p: [f64; 2]) -> (f64, [f64; 3]) {
        if let Some(d) = self.box_distance(p) {
            return (d, self.normal(p));
        }
        let best = self.closest(p);
        let inside = self.contains(p);
        let d = best.2.sqrt();
        (if inside { -d } else { d }, self.normal_from(p, best, || inside))
    }

    /// The normal of [`Self::normal`] from `p`'s closest boundary point `(k, t, d2)`
    /// ([`Self::closest`]) and whether `p` lies inside (asked only off the boundary).
    fn normal_from(&self, p: [f64; 2], (k, t, d2): (usize, f64, f64), inside: impl FnOnce() -> bool) -> [f64; 3] {
        let (a, b) = self.edge(k);
        let c = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
        if d2 > 1e-20 {
            let s = if inside() { -1.0 } else { 1.0 };
            let d = d2.sqrt();
            return [s * (p[0] - c[0]) / d, s * (p[1] - c[1]) / d, 0.0];
        }
        // On the boundary: the edge's outward normal (counter-clockwise: (e_y, −e_x)).
        let e = [b[0] - a[0], b[1] - a[1]];
        let l = (e[0] * e[0] + e[1] * e[1]).sqrt().max(1e-300);
        [e[1] / l, -e[0] / l, 0.0]
    }
}

/// A uniform grid of square bins over a polygon's bounding box: each bin lists the edges whose
/// bounding boxes overlap it, and each row of bins (a band in y) lists once every edge whose
/// y-range overlaps it.
#[derive(Clone, Debug, PartialEq)]
struct EdgeBins {
    /// Lower corner and bin side (lattice units).
    origin: [f64; 2],
    side: f64,
    dims: [usize; 2],
    /// Edges of bin (i, j) = `edges[start[j·dims₀ + i]..start[j·dims₀ + i + 1]]`.
    start: Vec<u32>,
    edges: Vec<u32>,
    /// Edges of band j = `band_edges[band_start[j]..band_start[j + 1]]`.
    band_start: Vec<u32>,
    band_edges: Vec<u32>,
}

impl EdgeBins {
    fn new(p: &Polygon) -> Self {
        let n = p.vertices.len();
        let b = p.bounds;
        let perimeter: f64 = (0..n)
            .map(|k| {
                let (a, c) = p.edge(k);
                ((c[0] - a[0]).powi(2) + (c[1] - a[1]).powi(2)).sqrt()
            })
            .sum();
        // bins of about two edges, at least one lattice cell, at most MAX_BINS_PER_AXIS a side
        let extent = (b[2] - b[0]).max(b[3] - b[1]);
        let side = (2.0 * perimeter / n as f64).max(1.0).max(extent / MAX_BINS_PER_AXIS as f64);
        let origin = [b[0], b[1]];
        let dims = [((b[2] - b[0]) / side).floor() as usize + 1, ((b[3] - b[1]) / side).floor() as usize + 1];
        let cell = |x: f64, a: usize| (((x - origin[a]) / side).floor().max(0.0) as usize).min(dims[a] - 1);
        let ranges: Vec<[usize; 4]> = (0..n)
            .map(|k| {
                let (a, c) = p.edge(k);
                [cell(a[0].min(c[0]), 0), cell(a[0].max(c[0]), 0), cell(a[1].min(c[1]), 1), cell(a[1].max(c[1]), 1)]
            })
            .collect();
        let in_bins = ranges.iter().enumerate().flat_map(|(k, r)| (r[2]..=r[3]).flat_map(move |j| (r[0]..=r[1]).map(move |i| (j * dims[0] + i, k as u32))));
        let in_bands = ranges.iter().enumerate().flat_map(|(k, r)| (r[2]..=r[3]).map(move |j| (j, k as u32)));
        let (start, edges) = by_cell(dims[0] * dims[1], in_bins);
        let (band_start, band_edges) = by_cell(dims[1], in_bands);
        EdgeBins { origin, side, dims, start, edges, band_start, band_edges }
    }

    /// The bin coordinates of `p`, when it lies in the grid.
    fn bin_of(&self, p: [f64; 2]) -> Option<[usize; 2]> {
        let f = |a: usize| (p[a] - self.origin[a]) / self.side;
        let (x, y) = (f(0), f(1));
        (x >= 0.0 && y >= 0.0 && (x as usize) < self.dims[0] && (y as usize) < self.dims[1]).then_some([x as usize, y as usize])
    }

    /// The edges listed in `p`'s bin (every edge through `p` is among them).
    fn bin_edges(&self, p: [f64; 2]) -> Option<&[u32]> {
        let [i, j] = self.bin_of(p)?;
        let c = j * self.dims[0] + i;
        Some(&self.edges[self.start[c] as usize..self.start[c + 1] as usize])
    }

    /// The edges whose y-range overlaps the band of height `y` (None outside the grid).
    fn band(&self, y: f64) -> Option<&[u32]> {
        let j = (y - self.origin[1]) / self.side;
        (j >= 0.0 && (j as usize) < self.dims[1]).then(|| {
            let j = j as usize;
            &self.band_edges[self.band_start[j] as usize..self.band_start[j + 1] as usize]
        })
    }

    /// [`Polygon::closest`] from the bins in rings around `p`'s bin: after ring r every edge not
    /// yet seen lies at least r bin sides away, so the search stops once the best squared
    /// distance is below (r·side)². None when `p` lies outside the grid.
    ///
    /// With `within`, the search also stops after the first ring r whose r·side exceeds it
    /// (by a relative 10⁻⁹, far above the rounding of a squared distance): what it returns is
    /// then the closest edge wherever that lies nearer than `within`, and otherwise an edge at
    /// `within` or farther, not necessarily the closest.
    fn closest(&self, poly: &Polygon, p: [f64; 2], within: Option<f64>) -> Option<(usize, f64, f64)> {
        let [ci, cj] = self.bin_of(p)?;
        let mut best = (0usize, 0.0, f64::INFINITY);
        let reach = ci.max(self.dims[0] - 1 - ci).max(cj).max(self.dims[1] - 1 - cj);
        for r in 0..=reach {
            let (i0, i1) = (ci.saturating_sub(r), (ci + r).min(self.dims[0] - 1));
            let (j0, j1) = (cj.saturating_sub(r), (cj + r).min(self.dims[1] - 1));
            for j in j0..=j1 {
                let on_edge_row = j + r == cj || j == cj + r;
                for i in i0..=i1 {
                    // the ring's bins only: its top and bottom rows, and the two side columns
                    if !on_edge_row && i + r != ci && i != ci + r {
                        continue;
                    }
                    let c = j * self.dims[0] + i;
                    for &k in &self.edges[self.start[c] as usize..self.start[c + 1] as usize] {
                        let k = k as usize;
                        let (t, d2) = poly.edge_distance(k, p);
                        if d2 < best.2 || (d2 == best.2 && k < best.0) {
                            best = (k, t, d2);
                        }
                    }
                }
            }
            let seen = r as f64 * self.side;
            if best.2 < seen * seen || within.is_some_and(|l| seen > l * (1.0 + 1e-9)) {
                break;
            }
        }
        Some(best)
    }
}

/// The items of (cell, item) pairs listed by cell (a counting sort): the start of each cell's
/// run (length cells + 1) and the items in cell order.
fn by_cell(cells: usize, pairs: impl Iterator<Item = (usize, u32)> + Clone) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; cells + 1];
    for (c, _) in pairs.clone() {
        start[c + 1] += 1;
    }
    for c in 1..=cells {
        start[c] += start[c - 1];
    }
    let mut fill = start.clone();
    let mut items = vec![0u32; start[cells] as usize];
    for (c, k) in pairs {
        items[fill[c] as usize] = k;
        fill[c] += 1;
    }
    (start, items)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wavy closed curve of `n` vertices (a star-shaped outline, like a fold's section).
    fn wavy(n: usize) -> Polygon {
        let verts: Vec<[f64; 2]> = (0..n)
            .map(|k| {
                let a = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
                let r = 12.0 + 3.0 * (5.0 * a).sin() + 0.7 * (13.0 * a).cos();
                [30.3 + r * a.cos(), 21.7 + 0.6 * r * a.sin()]
            })
            .collect();
        let vel = (0..n).map(|k| [k as f64, 0.0, 0.0]).collect();
        Polygon::new(verts, vel)
    }

    #[test]
    fn the_binned_queries_answer_as_every_edge_does_bit_for_bit() {
        let poly = wavy(400);
        assert!(poly.bins.is_some());
        let (mut inside, mut points, mut beyond, mut within) = (0, 0, 0, 0);
        // every node of the box and 3 cells around it, and points between nodes
        for j in -40..=200 {
            for i in -40..=280 {
                let p = [0.25 * i as f64 + 11.0, 0.25 * j as f64 + 3.5];
                points += 1;
                let (a, b) = (poly.closest(p), poly.closest_by_every_edge(p));
                assert_eq!((a.0, a.1.to_bits(), a.2.to_bits()), (b.0, b.1.to_bits(), b.2.to_bits()), "closest at {p:?}");
                let c = poly.contains(p);
                assert_eq!(c, poly.contains_by_every_edge(p), "contains at {p:?}");
                let sdf = poly.sdf(p);
                let (d, n) = poly.sdf_and_normal(p);
                assert_eq!((d.to_bits(), n.map(f64::to_bits)), (sdf.to_bits(), poly.normal(p).map(f64::to_bits)), "sdf and normal at {p:?}");
                let expected = if sdf < 0.0 { None } else { Some(sdf.to_bits()) };
                assert_eq!(poly.outside_distance(p).map(f64::to_bits), expected, "outside distance at {p:?}");
                for limit in [0.5, 1.7, 6.0] {
                    let below = poly.outside_distance_below(p, limit);
                    match (below, poly.outside_distance(p)) {
                        (Outside::Inside, None) | (Outside::Beyond, Some(_)) if sdf >= limit || sdf < 0.0 => {}
                        (Outside::Within(d), Some(e)) => assert_eq!(d.to_bits(), e.to_bits(), "distance below {limit} at {p:?}"),
                        (b, e) => panic!("below {limit} at {p:?}: {b:?}, outside distance {e:?}"),
                    }
                    beyond += (below == Outside::Beyond) as usize;
                    within += matches!(below, Outside::Within(_)) as usize;
                }
                inside += c as usize;
            }
        }
        // the points inside, 16 per unit area, measure the polygon's area (both answers exercised)
        let area = poly.signed_area();
        assert!((inside as f64 / 16.0 / area - 1.0).abs() < 0.02, "{inside} of {points} points inside, area {area}");
        // the limited search was asked both near the outline and far from it
        assert!(within > 1000 && beyond > 10_000, "{within} answers within a limit, {beyond} beyond");
        // vertices themselves (distance exactly 0, two edges equally near: the lower index)
        for (k, v) in poly.vertices().iter().enumerate() {
            let (e, _, d2) = poly.closest(*v);
            assert_eq!(d2, 0.0);
            assert_eq!(poly.outside_distance(*v).map(f64::to_bits), Some(poly.sdf(*v).to_bits()), "vertex {k}");
            assert_eq!(e, if k == 0 { 0 } else { k - 1 }, "vertex {k}");
        }
    }

    #[test]
    fn small_polygons_are_not_binned() {
        let sq = Polygon::new(vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]], vec![[0.0; 3]; 4]);
        assert!(sq.bins.is_none());
        assert!(sq.contains([1.0, 1.0]) && !sq.contains([3.0, 1.0]));
    }
}
