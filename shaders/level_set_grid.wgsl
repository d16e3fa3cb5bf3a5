// The level set L of one body's particles (seed 000 2.124: L = Σ_j (r_e / max(r, r_min) − 1)
// over the particles within r_e, minus the surface level φ; positive inside) sampled at the
// nodes of a grid, f32: the GPU twin of src/mesh/particle_field.rs `level_set_grid`, whose
// output the marching-cubes kernel (shaders/marching_cubes.wgsl) reads. Particles are binned by
// the CPU twin's bins of side r_e (KernelLevelSet::bin_lists, CSR: bin b holds
// order[start[b] .. start[b + 1]]); one thread per grid node, a gather, so no atomics. A 2D body
// is sampled as ScalarGrid::slab does: the plane z = 0 in the middle layer of three, and
// iso − |L − iso| in the layers below and above, so that its surface closes as a prism.

struct Params {
    // bins' origin (the points' bounding box grown by r_e), .w: r_e
    lo: vec4<f32>,
    // bounding box's far corner, .w: r_min
    hi: vec4<f32>,
    // bins per axis, .w: number of points
    bins: vec4<u32>,
    // position of grid node (0, 0, 0), .w: node spacing
    origin: vec4<f32>,
    // nodes per axis, .w: 1 for a 2D slab
    dims: vec4<u32>,
    phi: f32,
    iso: f32,
    // nodes in a row of the dispatch grid (threads per workgroup row × workgroups along x)
    row: u32,
    _pad: u32,
};

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> bin_start: array<u32>;
@group(0) @binding(3) var<storage, read> bin_order: array<u32>;
@group(0) @binding(4) var<storage, read_write> field: array<f32>;

// L at p (CPU twin: KernelLevelSet::level, its candidates in the 3ᴰ bins around p).
fn level(p: vec3<f32>) -> f32 {
    var l = -P.phi;
    if (any(p < P.lo.xyz) || any(p > P.hi.xyz)) {
        return l;
    }
    let re = P.lo.w;
    let c = vec3<i32>(floor((p - P.lo.xyz) / re));
    let b = vec3<i32>(P.bins.xyz);
    let lo = max(c - vec3<i32>(1), vec3<i32>(0));
    let hi = min(c + vec3<i32>(1), b - vec3<i32>(1));
    for (var z = lo.z; z <= hi.z; z = z + 1) {
        for (var y = lo.y; y <= hi.y; y = y + 1) {
            for (var x = lo.x; x <= hi.x; x = x + 1) {
                let bin = u32((z * b.y + y) * b.x + x);
                for (var k = bin_start[bin]; k < bin_start[bin + 1u]; k = k + 1u) {
                    let r = length(p - points[bin_order[k]].xyz);
                    if (r <= re) {
                        l += re / max(r, P.hi.w) - 1.0;
                    }
                }
            }
        }
    }
    return l;
}

@compute @workgroup_size(64)
fn level_set_grid(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = gid.x + gid.y * P.row;
    let nx = P.dims.x;
    let ny = P.dims.y;
    if (t >= nx * ny * P.dims.z) {
        return;
    }
    let n = vec3<u32>(t % nx, (t / nx) % ny, t / (nx * ny));
    var p = P.origin.xyz + P.origin.w * vec3<f32>(n);
    if (P.dims.w == 1u) {
        // the slab's middle layer is the plane of the 2D body
        p.z = P.origin.z + P.origin.w;
        let l = level(p);
        field[t] = select(P.iso - abs(l - P.iso), l, n.z == 1u);
    } else {
        field[t] = level(p);
    }
}
