//! Marching cubes (Lorensen & Cline, SIGGRAPH 1987): the surface {f = iso} of a scalar field
//! sampled at the nodes of a regular grid, as a closed triangle mesh. The CPU twin of the GPU
//! kernel (`shaders/marching_cubes.wgsl`, `crate::gpu::marching_cubes`); both read the case
//! table made here ([`CaseTable`], uploaded as a buffer), so they cannot disagree about a case.
//!
//! **Inside** is f > iso (the level set of the coupling is positive inside a body).
//!
//! **The case table is generated, not typed in.** For each of the 256 inside/outside patterns of
//! a cube's corners, each face of the cube contributes one segment per run of inside corners met
//! along its edge cycle, from the edge where the run begins to the edge where it ends (an
//! ambiguous face, two inside corners on a diagonal, thus cuts both off: the "separate the inside
//! corners" rule). A face's segments depend on that face's four corners only, so two cubes
//! sharing a face draw the same segments on it, and each crossing edge begins one segment and
//! ends another: the segments close into loops, each loop is fanned into triangles. The mesh is
//! therefore watertight wherever the field is outside at the grid's border (the classic 1987
//! table is not: its ambiguous faces may crack). Triangles are wound counter-clockwise seen from
//! outside: their normals (v₁ − v₀) × (v₂ − v₀) point out of the inside.
//!
//! Vertices lie on grid edges at the linear zero crossing of f − iso and are shared by the
//! triangles around them (indexed by the grid edge); their normals are −∇f (central
//! differences at the nodes, one-sided at the border) interpolated along the edge.

use glam::DVec3;
use std::collections::HashMap;
use std::sync::LazyLock;

/// Corner `i` of a cube sits at offset (i & 1, (i >> 1) & 1, (i >> 2) & 1) from its lowest node.
pub fn corner_offset(i: usize) -> [usize; 3] {
    [i & 1, (i >> 1) & 1, (i >> 2) & 1]
}

/// Edge `4a + k` of a cube runs along axis `a` from the `k`-th corner (in increasing index order)
/// whose bit `a` is clear to the corner with that bit set.
pub fn edge_corners(e: usize) -> [usize; 2] {
    let a = e / 4;
    let k = e % 4;
    let from = (0..8).filter(|c| c >> a & 1 == 0).nth(k).expect("four corners per axis");
    [from, from | 1 << a]
}

fn edge_between(c0: usize, c1: usize) -> usize {
    (0..12)
        .find(|&e| {
            let [a, b] = edge_corners(e);
            (a, b) == (c0, c1) || (a, b) == (c1, c0)
        })
        .expect("neighbouring corners share an edge")
}

/// The triangles of each of the 256 corner patterns (bit i set: corner i inside), as cube edges.
pub struct CaseTable {
    /// Triangles of case c: `triangles[c]`, three cube edges each.
    pub triangles: Vec<Vec<[u8; 3]>>,
}

impl CaseTable {
    fn generate() -> Self {
        CaseTable { triangles: (0..256).map(case_triangles).collect() }
    }

    /// Largest number of triangles in one cube.
    pub fn max_triangles(&self) -> usize {
        self.triangles.iter().map(Vec::len).max().unwrap_or(0)
    }

    /// The table as the GPU kernel reads it (one storage buffer): the two corners of each of the
    /// 12 edges (24 words), then per case `1 + 3 · max_triangles()` words: the case's triangle
    /// count and its triangles' cube edges (12 past its triangles).
    pub fn packed(&self) -> Vec<u32> {
        let max = self.max_triangles();
        let mut out: Vec<u32> = (0..12).flat_map(|e| edge_corners(e).map(|c| c as u32)).collect();
        for t in &self.triangles {
            out.push(t.len() as u32);
            for k in 0..max {
                out.extend(t.get(k).map_or([12; 3], |tri| tri.map(u32::from)));
            }
        }
        out
    }
}

/// The generated table (made once).
pub static CASES: LazyLock<CaseTable> = LazyLock::new(CaseTable::generate);

/// The triangles of one corner pattern (see the module docs for the rule).
fn case_triangles(case: usize) -> Vec<[u8; 3]> {
    let inside = |c: usize| case >> c & 1 == 1;
    // (edge where a run of inside corners begins, edge where it ends), per face
    let mut segments: Vec<(usize, usize)> = Vec::new();
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for side in 0..2 {
            // the face's corners counter-clockwise seen from outside the cube (e_b × e_c = e_a)
            let mut cycle: Vec<usize> = [(0, 0), (1, 0), (1, 1), (0, 1)].iter().map(|&(i, j)| side << a | i << b | j << c).collect();
            if side == 0 {
                cycle.reverse();
            }
            let ins: Vec<bool> = cycle.iter().map(|&c| inside(c)).collect();
            for k in 0..4 {
                if ins[k] && !ins[(k + 3) % 4] {
                    let begin = edge_between(cycle[(k + 3) % 4], cycle[k]);
                    let mut last = k;
                    while ins[(last + 1) % 4] {
                        last = (last + 1) % 4;
                    }
                    let end = edge_between(cycle[last], cycle[(last + 1) % 4]);
                    segments.push((begin, end));
                }
            }
        }
    }
    // chain the segments into loops and fan each loop
    let mut triangles = Vec::new();
    while let Some((start, mut next)) = segments.pop() {
        let mut polygon = vec![start];
        while next != start {
            polygon.push(next);
            let k = segments.iter().position(|s| s.0 == next).expect("each crossing edge begins one segment");
            next = segments.swap_remove(k).1;
        }
        for i in 1..polygon.len() - 1 {
            triangles.push([polygon[0] as u8, polygon[i] as u8, polygon[i + 1] as u8]);
        }
    }
    triangles
}

/// A scalar field at the nodes of a regular grid: node (i, j, k) at `origin + spacing·(i, j, k)`,
/// its value at `values[i + nx·(j + ny·k)]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalarGrid {
    pub dims: [usize; 3],
    pub origin: DVec3,
    /// Node spacing (same unit as `origin`).
    pub spacing: f64,
    pub values: Vec<f32>,
}

impl ScalarGrid {
    /// The field `f` sampled at the nodes.
    pub fn sample(dims: [usize; 3], origin: DVec3, spacing: f64, f: impl Fn(DVec3) -> f64) -> Self {
        let mut values = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    values.push(f(origin + spacing * DVec3::new(i as f64, j as f64, k as f64)) as f32);
                }
            }
        }
        Self { dims, origin, spacing, values }
    }

    /// A 2D field (`dims` x, y; values x-fastest) as a slab one spacing thick: the field in the
    /// middle layer and −|f − iso| + iso in the layers below and above, so that the surface of a
    /// 2D body is a closed prism with its caps at z = ±spacing/2 (the crossing is halfway).
    pub fn slab(dims: [usize; 2], origin: DVec3, spacing: f64, values: &[f32], iso: f32) -> Self {
        let n = dims[0] * dims[1];
        assert_eq!(values.len(), n, "one value per node");
        let cap: Vec<f32> = values.iter().map(|v| iso - (v - iso).abs()).collect();
        let mut v = Vec::with_capacity(3 * n);
        v.extend_from_slice(&cap);
        v.extend_from_slice(values);
        v.extend_from_slice(&cap);
        Self { dims: [dims[0], dims[1], 3], origin: origin - DVec3::new(0.0, 0.0, spacing), spacing, values: v }
    }

    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Cells (cubes) of the grid.
    pub fn cells(&self) -> usize {
        self.dims.iter().map(|d| d.saturating_sub(1)).product()
    }

    /// ∇f at node (i, j, k) by central differences (one-sided at the border), per unit length.
    pub fn gradient(&self, n: [usize; 3]) -> DVec3 {
        let mut g = DVec3::ZERO;
        for a in 0..3 {
            if self.dims[a] < 2 {
                continue;
            }
            let (mut lo, mut hi) = (n, n);
            lo[a] = n[a].saturating_sub(1);
            hi[a] = (n[a] + 1).min(self.dims[a] - 1);
            let d = self.values[self.index(hi[0], hi[1], hi[2])] as f64 - self.values[self.index(lo[0], lo[1], lo[2])] as f64;
            g[a] = d / ((hi[a] - lo[a]) as f64 * self.spacing);
        }
        g
    }
}

/// A triangle mesh: shared vertices with unit normals, triangles counter-clockwise seen from
/// outside, and the grid cell each triangle came from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// The grid cell (x-fastest over the cells) of each triangle.
    pub cells: Vec<u32>,
    /// A value per vertex for colouring (e.g. the body or layer it belongs to), if any.
    pub scalars: Vec<f32>,
}

impl TriangleMesh {
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// Total area.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// Enclosed volume by the divergence theorem, Σ v₀·(v₁ × v₂)/6: positive for a closed
    /// surface wound counter-clockwise from outside.
    pub fn volume(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Directed edges not matched by exactly one opposite edge (zero for a closed, consistently
    /// wound surface: every edge shared by two triangles traversing it in opposite directions).
    pub fn unmatched_edges(&self) -> usize {
        // per undirected edge: (triangles using it, uses in increasing − in decreasing direction)
        let mut edges: HashMap<(u32, u32), (usize, i64)> = HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let e = edges.entry((a.min(b), a.max(b))).or_default();
                e.0 += 1;
                e.1 += if a < b { 1 } else { -1 };
            }
        }
        edges.values().filter(|(uses, net)| *uses != 2 || *net != 0).count()
    }

    /// Appends `other` (indices shifted).
    pub fn append(&mut self, other: &TriangleMesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.scalars.extend_from_slice(&other.scalars);
        self.triangles.extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
        self.cells.extend_from_slice(&other.cells);
    }
}

/// The surface {f = iso} of `grid` (inside f > iso).
pub fn extract(grid: &ScalarGrid, iso: f32) -> TriangleMesh {
    let cases = &*CASES;
    let [nx, ny, nz] = grid.dims;
    let mut mesh = TriangleMesh::default();
    if nx < 2 || ny < 2 || nz < 2 {
        return mesh;
    }
    // vertex of each crossed grid edge, keyed by 3·(its lower node) + axis
    let mut vertex_of: HashMap<usize, u32> = HashMap::new();
    let mut cell = 0u32;
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let node = |c: usize| {
                    let o = corner_offset(c);
                    [i + o[0], j + o[1], k + o[2]]
                };
                let mut case = 0;
                for c in 0..8 {
                    let n = node(c);
                    if grid.values[grid.index(n[0], n[1], n[2])] > iso {
                        case |= 1 << c;
                    }
                }
                for tri in &cases.triangles[case] {
                    let idx = tri.map(|e| {
                        let [c0, c1] = edge_corners(e as usize);
                        let (n0, n1) = (node(c0), node(c1));
                        let key = 3 * grid.index(n0[0], n0[1], n0[2]) + e as usize / 4;
                        *vertex_of.entry(key).or_insert_with(|| {
                            let (f0, f1) = (grid.values[grid.index(n0[0], n0[1], n0[2])] as f64, grid.values[grid.index(n1[0], n1[1], n1[2])] as f64);
                            let t = (iso as f64 - f0) / (f1 - f0);
                            let p = |n: [usize; 3]| grid.origin + grid.spacing * DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
                            mesh.positions.push(p(n0) + t * (p(n1) - p(n0)));
                            let g = grid.gradient(n0) * (1.0 - t) + grid.gradient(n1) * t;
                            mesh.normals.push(-g.normalize_or_zero());
                            (mesh.positions.len() - 1) as u32
                        })
                    });
                    mesh.triangles.push(idx);
                    mesh.cells.push(cell);
                }
                cell += 1;
            }
        }
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_generated_table_cuts_off_a_single_corner_with_one_outward_triangle() {
        let t = &CASES.triangles;
        assert!(t[0].is_empty() && t[255].is_empty());
        for c in 0..8 {
            assert_eq!(t[1 << c].len(), 1, "corner {c} alone");
            assert_eq!(t[255 ^ (1 << c)].len(), 1, "all but corner {c}");
        }
        // corner 0 inside: the triangle's normal points away from it, towards (1, 1, 1)
        let mid = |e: u8| {
            let [a, b] = edge_corners(e as usize);
            let (pa, pb) = (corner_offset(a), corner_offset(b));
            DVec3::new((pa[0] + pb[0]) as f64, (pa[1] + pb[1]) as f64, (pa[2] + pb[2]) as f64) * 0.5
        };
        let [a, b, c] = t[1][0].map(mid);
        let n = (b - a).cross(c - a);
        assert!(n.dot(DVec3::ONE) > 0.0, "normal {n} of the corner-0 triangle");
        // a half cube (the four corners with z = 0 inside): two triangles, normal +z
        let [a, b, c] = t[0b0000_1111][0].map(mid);
        assert!((b - a).cross(c - a).normalize().dot(DVec3::Z) > 0.999);
        assert_eq!(t[0b0000_1111].len(), 2);
        // ambiguous checkerboard: the four inside corners cut off one by one
        assert_eq!(t[0b0110_1001].len(), 4);
        assert!(CASES.max_triangles() <= 12);
    }

    #[test]
    fn every_case_of_a_cube_pair_closes_across_the_shared_face() {
        // two cubes side by side, all 2¹² corner patterns, field outside around them: every
        // surface closed (the ambiguous faces agree between the two cubes)
        for pattern in 0..1u32 << 12 {
            let dims = [5, 4, 4];
            let mut values = vec![-1.0f32; 5 * 4 * 4];
            for n in 0..12 {
                let (i, j, k) = (1 + n % 3, 1 + (n / 3) % 2, 1 + n / 6);
                values[i + 5 * (j + 4 * k)] = if pattern >> n & 1 == 1 { 1.0 } else { -1.0 };
            }
            let g = ScalarGrid { dims, origin: DVec3::ZERO, spacing: 1.0, values };
            let m = extract(&g, 0.0);
            assert_eq!(m.unmatched_edges(), 0, "pattern {pattern:012b}");
            let inside = pattern.count_ones();
            assert_eq!(m.volume() > 0.0, inside > 0, "pattern {pattern:012b}: volume {}", m.volume());
        }
    }

    /// A sphere of radius 20 spacings at 64³ (signed distance, inside positive).
    fn sphere() -> (ScalarGrid, f64) {
        let r = 20.0;
        let c = DVec3::splat(31.7);
        (ScalarGrid::sample([64; 3], DVec3::ZERO, 1.0, |x| r - (x - c).length()), r)
    }

    #[test]
    fn a_sphere_at_64_cubed_has_its_area_and_volume_within_a_percent_and_is_closed() {
        let (g, r) = sphere();
        let m = extract(&g, 0.0);
        let (area, volume) = (m.area(), m.volume());
        let (a0, v0) = (4.0 * std::f64::consts::PI * r * r, 4.0 / 3.0 * std::f64::consts::PI * r.powi(3));
        eprintln!(
            "sphere r = {r} at 64³: {} triangles, area {:+.3} %, volume {:+.3} %",
            m.triangles.len(),
            100.0 * (area / a0 - 1.0),
            100.0 * (volume / v0 - 1.0)
        );
        assert!((area / a0 - 1.0).abs() < 0.01, "area {area} vs {a0}");
        assert!((volume / v0 - 1.0).abs() < 0.01, "volume {volume} vs {v0}");
        assert_eq!(m.unmatched_edges(), 0, "watertight");
        // vertices on the sphere to f32 and interpolation accuracy, normals radial
        let c = DVec3::splat(31.7);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            assert!(((*p - c).length() - r).abs() < 0.02, "vertex {p} at {}", (*p - c).length());
            assert!(n.dot((*p - c).normalize()) > 0.999, "normal {n} at {p}");
        }
        // Euler characteristic of a sphere: V − E + F = 2
        let (v, f) = (m.positions.len() as i64, m.triangles.len() as i64);
        assert_eq!(v - 3 * f / 2 + f, 2);
    }

    #[test]
    fn a_slab_closes_a_2d_disc_into_a_prism() {
        let (n, r) = (40usize, 12.0);
        let c = DVec3::new(19.5, 20.2, 0.0);
        let vals: Vec<f32> = (0..n * n).map(|k| (r - (DVec3::new((k % n) as f64, (k / n) as f64, 0.0) - c).length()) as f32).collect();
        let g = ScalarGrid::slab([n, n], DVec3::ZERO, 1.0, &vals, 0.0);
        let m = extract(&g, 0.0);
        assert_eq!(m.unmatched_edges(), 0);
        // a prism one spacing thick over the disc, its rim bevelled (within the rim's cells
        // the surface runs from the contour at z = 0 to the caps at the inner nodes): its
        // volume between the prisms over the discs of radius r − 1 and r
        let v = m.volume();
        let (outer, inner) = (std::f64::consts::PI * r * r, std::f64::consts::PI * (r - 1.0) * (r - 1.0));
        assert!(v < outer && v > inner, "prism volume {v}, not in ({inner}, {outer})");
        // the section z = 0 is the disc's contour
        let rim: Vec<f64> = m.positions.iter().filter(|p| p.z.abs() < 1e-9).map(|p| (*p - c).length()).collect();
        assert!(rim.len() > 50 && rim.iter().all(|d| (d - r).abs() < 0.05), "rim radii {rim:?}");
        let (lo, hi) = m.positions.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p.z), hi.max(p.z)));
        assert!((lo + 0.5).abs() < 1e-6 && (hi - 0.5).abs() < 1e-6, "caps at {lo}, {hi}");
    }
}
