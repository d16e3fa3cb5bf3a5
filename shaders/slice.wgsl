// A plane of a GPU-stepped FDLB lattice as a colour-mapped image, f32, from the moments of the
// plane's nodes (written just before by the probe kernel from the populations of the last
// completed step: moments[1 + 5t + k], k = ρ, ux, uy, uz, θ of plane node t = x + nx·y) and the
// node kinds (0 = fluid): the GPU twin of src/output/fields.rs `slice` and
// src/output/png_map.rs `colour_range` / `colour` / `rgba_top_down` (the PNG snapshots' maps).
// Three passes: `slice_values` writes each plane node's value in scene units (SOLID where the
// node is not fluid), `slice_range` reduces them to the colour scale's ends in one workgroup,
// `slice_colour` maps them to RGBA8 rows from the top, each row padded to 256 bytes so that the
// buffer copies into a texture as it is.

struct Params {
    // interior nodes per axis (x, y), the plane's z, .w: field (0 density, 1 speed,
    // 2 pressure, 3 temperature, 4 vorticity)
    n: vec4<u32>,
    // halo per axis, .w: 1 for the signed (diverging) map
    halo: vec4<u32>,
    // padded nodes per axis, .w unused
    padded: vec4<u32>,
    // value = (q − offset) · scale, q the lattice quantity
    scale: f32,
    offset: f32,
    // pixels (u32 words) per padded row
    row_words: u32,
    _pad: u32,
};

const SOLID: f32 = 3.0e38;

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> moments: array<f32>;
@group(0) @binding(2) var<storage, read> kind: array<u32>;
@group(0) @binding(3) var<storage, read_write> values: array<f32>;
// [0], [1]: the colour scale's ends
@group(0) @binding(4) var<storage, read_write> range: array<f32>;
@group(0) @binding(5) var<storage, read_write> pixels: array<u32>;

var<workgroup> lo_part: array<f32, 256>;
var<workgroup> hi_part: array<f32, 256>;

fn node(x: i32, y: i32) -> u32 {
    let p = vec3<u32>(vec3<i32>(x, y, i32(P.n.z)) + vec3<i32>(P.halo.xyz));
    return p.x + P.padded.x * (p.y + P.padded.y * p.z);
}

fn fluid(x: i32, y: i32) -> bool {
    return x >= 0 && y >= 0 && x < i32(P.n.x) && y < i32(P.n.y) && kind[node(x, y)] == 0u;
}

fn q(k: u32, x: i32, y: i32) -> f32 {
    return moments[1u + 5u * (u32(x) + P.n.x * u32(y)) + k];
}

@compute @workgroup_size(64)
fn slice_values(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = gid.x + gid.y * nwg.x * 64u;
    if (t >= P.n.x * P.n.y) {
        return;
    }
    let x = i32(t % P.n.x);
    let y = i32(t / P.n.x);
    if (!fluid(x, y)) {
        values[t] = SOLID;
        return;
    }
    var v = 0.0;
    switch P.n.w {
        case 0u: { v = q(0u, x, y); }
        case 1u: { v = length(vec3<f32>(q(1u, x, y), q(2u, x, y), q(3u, x, y))); }
        case 2u: { v = q(0u, x, y) * q(4u, x, y); }
        case 3u: { v = q(4u, x, y); }
        default: {
            // ω_z = ∂v/∂x − ∂u/∂y, central differences where the four neighbours are fluid
            if (fluid(x + 1, y) && fluid(x - 1, y) && fluid(x, y + 1) && fluid(x, y - 1)) {
                v = 0.5 * (q(2u, x + 1, y) - q(2u, x - 1, y)) - 0.5 * (q(1u, x, y + 1) - q(1u, x, y - 1));
            }
        }
    }
    if (P.n.w == 4u) {
        values[t] = v * P.scale;
    } else {
        values[t] = (v - P.offset) * P.scale;
    }
}

// One workgroup: the finite values' min and max (symmetric about 0 on the signed map; a
// unit-wide range when there is one value or none).
@compute @workgroup_size(256)
fn slice_range(@builtin(local_invocation_index) i: u32) {
    var lo = SOLID;
    var hi = -SOLID;
    for (var t = i; t < P.n.x * P.n.y; t = t + 256u) {
        let v = values[t];
        if (v < SOLID) {
            lo = min(lo, v);
            hi = max(hi, v);
        }
    }
    lo_part[i] = lo;
    hi_part[i] = hi;
    workgroupBarrier();
    for (var s = 128u; s > 0u; s = s >> 1u) {
        if (i < s) {
            lo_part[i] = min(lo_part[i], lo_part[i + s]);
            hi_part[i] = max(hi_part[i], hi_part[i + s]);
        }
        workgroupBarrier();
    }
    if (i == 0u) {
        var a = lo_part[0];
        var b = hi_part[0];
        if (P.halo.w == 1u) {
            // (the CPU floors at 1e-300, below f32's range)
            let m = max(max(abs(a), abs(b)), 1e-30);
            a = -m;
            b = m;
        }
        if (!(b > a)) {
            b = a + 1.0;
        }
        range[0] = a;
        range[1] = b;
    }
}

fn ramp_sequential(t: f32) -> vec3<f32> {
    var stops = array<vec3<f32>, 5>(
        vec3<f32>(0.05, 0.03, 0.25), vec3<f32>(0.35, 0.1, 0.5), vec3<f32>(0.75, 0.2, 0.4), vec3<f32>(0.98, 0.55, 0.15), vec3<f32>(0.99, 0.95, 0.4)
    );
    let s = clamp(t, 0.0, 1.0) * 4.0;
    let k = min(u32(floor(s)), 3u);
    return mix(stops[k], stops[k + 1u], s - f32(k));
}

fn ramp_diverging(t: f32) -> vec3<f32> {
    var stops = array<vec3<f32>, 3>(vec3<f32>(0.15, 0.3, 0.75), vec3<f32>(0.97, 0.97, 0.97), vec3<f32>(0.75, 0.1, 0.1));
    let s = clamp(t, 0.0, 1.0) * 2.0;
    let k = min(u32(floor(s)), 1u);
    return mix(stops[k], stops[k + 1u], s - f32(k));
}

@compute @workgroup_size(64)
fn slice_colour(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = gid.x + gid.y * nwg.x * 64u;
    if (t >= P.n.x * P.n.y) {
        return;
    }
    let x = t % P.n.x;
    let y = t / P.n.x;
    let v = values[t];
    // solids grey, as the PNG snapshots
    var c = vec3<u32>(110u);
    if (v < SOLID) {
        let s = (v - range[0]) / (range[1] - range[0]);
        var rgb = ramp_sequential(s);
        if (P.halo.w == 1u) {
            rgb = ramp_diverging(s);
        }
        c = vec3<u32>(rgb * 255.0);
    }
    // rows from the top: y up in the world
    pixels[(P.n.y - 1u - y) * P.row_words + x] = c.r | (c.g << 8u) | (c.b << 16u) | (255u << 24u);
}
