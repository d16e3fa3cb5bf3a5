// Passive tracers, f32: the GPU twin of src/fluid/tracers.rs (`Tracers::advect`). One thread
// per tracer: the midpoint rule through the fluid's velocity interpolated multilinearly from the
// FDLB's macro buffer (mac[k·N + node]: ρ, ux, uy, uz, θ) and node kinds (0 = fluid); a tracer
// that leaves the interior or comes nearest to a node that is not fluid is born again in the
// seed box at a point drawn from the lowbias32 hash (mix32) of (tracer, generation).

struct Params {
    // interior nodes per axis, .w: the dimension (2 or 3)
    n: vec4<u32>,
    // halo per axis, .w: tracers
    halo: vec4<u32>,
    // padded nodes per axis, .w: N, the macro buffer's stride per quantity
    padded: vec4<u32>,
    // seed box: lower corner (.w: the step dt, lattice time) and size
    seed_lo: vec4<f32>,
    seed_size: vec4<f32>,
};

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> mac: array<f32>;
@group(0) @binding(2) var<storage, read> kind: array<u32>;
// xyz: position; w: generation (bits)
@group(0) @binding(3) var<storage, read_write> tracers: array<vec4<f32>>;
// [0]: tracers born again
@group(0) @binding(4) var<storage, read_write> reseeded: array<atomic<u32>>;

fn node(x: vec3<i32>) -> u32 {
    let p = vec3<u32>(x + vec3<i32>(P.halo.xyz));
    return p.x + P.padded.x * (p.y + P.padded.y * p.z);
}

// u at x and whether a tracer may be there (.w = 1)
fn sample(x: vec3<f32>) -> vec4<f32> {
    let d = P.n.w;
    for (var a = 0u; a < d; a++) {
        if (!(x[a] >= 0.0 && x[a] <= f32(P.n[a] - 1u))) {
            return vec4<f32>(0.0);
        }
    }
    var nearest = vec3<i32>(round(x));
    var lo = vec3<i32>(floor(x));
    var t = x - floor(x);
    if (d == 2u) {
        nearest.z = 0;
        lo.z = 0;
        t.z = 0.0;
    }
    if (kind[node(nearest)] != 0u) {
        return vec4<f32>(0.0);
    }
    let N = P.padded.w;
    var u = vec3<f32>(0.0);
    for (var c = 0u; c < (1u << d); c++) {
        let o = vec3<u32>(c & 1u, (c >> 1u) & 1u, (c >> 2u) & 1u);
        var w = 1.0;
        for (var a = 0u; a < d; a++) {
            w *= select(1.0 - t[a], t[a], o[a] == 1u);
        }
        if (w == 0.0) {
            continue;
        }
        let k = node(lo + vec3<i32>(o));
        u += w * vec3<f32>(mac[N + k], mac[2u * N + k], mac[3u * N + k]);
    }
    return vec4<f32>(u, 1.0);
}

// mix32 (shaders/hash.wgsl) is prepended
fn unit(tracer: u32, generation: u32, axis: u32) -> f32 {
    return f32(mix32(mix32(mix32(tracer) ^ generation) ^ axis) >> 8u) / 16777216.0;
}

@compute @workgroup_size(64)
fn advect(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if (k >= P.halo.w) {
        return;
    }
    let dt = P.seed_lo.w;
    let x = tracers[k].xyz;
    let a = sample(x);
    var ok = a.w > 0.0;
    var y = x;
    if (ok) {
        let b = sample(x + 0.5 * dt * a.xyz);
        ok = b.w > 0.0;
        y = x + dt * b.xyz;
        ok = ok && sample(y).w > 0.0;
    }
    if (ok) {
        tracers[k] = vec4<f32>(y, tracers[k].w);
    } else {
        let g = bitcast<u32>(tracers[k].w) + 1u;
        let s = vec3<f32>(unit(k, g, 0u), unit(k, g, 1u), unit(k, g, 2u));
        tracers[k] = vec4<f32>(s * P.seed_size.xyz + P.seed_lo.xyz, bitcast<f32>(g));
        atomicAdd(&reseeded[0], 1u);
    }
}
