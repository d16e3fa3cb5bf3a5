// Marching cubes (Lorensen & Cline 1987), f32: the GPU twin of src/mesh/marching_cubes.rs
// (`extract`). One thread per grid cell; the case table is the CPU twin's generated table,
// uploaded as a buffer (CaseTable::packed). A cell's triangles are appended at a slot taken
// with one atomicAdd on a counter (order across cells is the scheduler's; within a cell, the
// table's), three vertices each, unindexed: ready for a non-indexed or indirect draw. The
// first vertex's w holds the cell index and the second's the triangle's rank in its cell (bit
// patterns), so a test can put the triangles back in the CPU twin's order. Past `capacity` the
// triangles are counted but not written. Every normal's w carries the extraction's body tag, so
// that several bodies (the two folds) share one set of output buffers and one draw.

struct Params {
    // nodes per axis, .w: the table's words per case
    dims: vec4<u32>,
    // position of node (0, 0, 0), .w: node spacing
    origin: vec4<f32>,
    iso: f32,
    // triangles the output buffers hold
    capacity: u32,
    // cells in a row of the dispatch grid (threads per workgroup row × workgroups along x)
    row: u32,
    // the tag written in every normal's w (the body's index)
    body: u32,
};

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> field: array<f32>;
@group(0) @binding(2) var<storage, read> table: array<u32>;
// [0]: triangles emitted (may exceed capacity)
@group(0) @binding(3) var<storage, read_write> counter: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> positions: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> normals: array<vec4<f32>>;

fn node_index(n: vec3<u32>) -> u32 {
    return n.x + P.dims.x * (n.y + P.dims.y * n.z);
}

fn value(n: vec3<u32>) -> f32 {
    return field[node_index(n)];
}

fn corner(c: u32) -> vec3<u32> {
    return vec3<u32>(c & 1u, (c >> 1u) & 1u, (c >> 2u) & 1u);
}

// ∇f at a node, central differences (one-sided at the border), per unit length
fn gradient(n: vec3<u32>) -> vec3<f32> {
    var g = vec3<f32>(0.0);
    for (var a = 0u; a < 3u; a++) {
        if (P.dims[a] < 2u) {
            continue;
        }
        var lo = n;
        var hi = n;
        lo[a] = select(n[a] - 1u, 0u, n[a] == 0u);
        hi[a] = min(n[a] + 1u, P.dims[a] - 1u);
        g[a] = (value(hi) - value(lo)) / (f32(hi[a] - lo[a]) * P.origin.w);
    }
    return g;
}

@compute @workgroup_size(64)
fn marching_cubes(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cells_x = P.dims.x - 1u;
    let cells_y = P.dims.y - 1u;
    let cells = cells_x * cells_y * (P.dims.z - 1u);
    let cell = gid.x + gid.y * P.row;
    if (cell >= cells) {
        return;
    }
    let base = vec3<u32>(cell % cells_x, (cell / cells_x) % cells_y, cell / (cells_x * cells_y));
    var case_index = 0u;
    for (var c = 0u; c < 8u; c++) {
        if (value(base + corner(c)) > P.iso) {
            case_index |= 1u << c;
        }
    }
    let record = 24u + case_index * P.dims.w;
    let count = table[record];
    if (count == 0u) {
        return;
    }
    let first = atomicAdd(&counter[0], count);
    for (var t = 0u; t < count; t++) {
        let slot = first + t;
        if (slot >= P.capacity) {
            return;
        }
        for (var v = 0u; v < 3u; v++) {
            let e = table[record + 1u + 3u * t + v];
            let n0 = base + corner(table[2u * e]);
            let n1 = base + corner(table[2u * e + 1u]);
            let f0 = value(n0);
            let f1 = value(n1);
            let s = (P.iso - f0) / (f1 - f0);
            let p0 = P.origin.xyz + P.origin.w * vec3<f32>(n0);
            let p1 = P.origin.xyz + P.origin.w * vec3<f32>(n1);
            var tag = 0.0;
            if (v == 0u) {
                tag = bitcast<f32>(cell);
            } else if (v == 1u) {
                tag = bitcast<f32>(t);
            }
            positions[3u * slot + v] = vec4<f32>(p0 + s * (p1 - p0), tag);
            let g = gradient(n0) * (1.0 - s) + gradient(n1) * s;
            let len = length(g);
            normals[3u * slot + v] = vec4<f32>(select(vec3<f32>(0.0), -g / len, len > 0.0), f32(P.body));
        }
    }
}
