// Method 2's coupling kernels (seed 000 §2.4.2), f32 — GPU twins of
// src/fluid/kernel_level_set.rs (`level`, `velocity_at`) and src/coupling/conserving.rs
// (`momentum_exchange`). Lattice coordinates (cells), c units. The particles of one or more
// bodies, each body's level set binned by its CPU twin's bins of side r_e (CSR: bin b of set s
// holds s.first.x + order[s.first.x + start[s.first.y + b] ...]); a query sums over the sets in
// order, as the CPU's stage does. Every kernel is a gather (one thread per query, node or
// particle), so no atomics and no order dependence.

// One body's level set: its bins and where its points and bins start in the joint arrays.
struct SetGrid {
    // bins' origin (the points' bounding box grown by r_e), .w unused
    lo: vec4<f32>,
    // bounding box's far corner, .w unused
    hi: vec4<f32>,
    // bins per axis, .w number of points
    bins: vec4<u32>,
    // .x the set's first point (in points, velocities and bin_order), .y its first entry of
    // bin_start, .zw unused
    first: vec4<u32>,
};

struct Params {
    // padded lattice: px, py, pz and the halo width (the same on every axis of the lattice)
    padded: vec4<u32>,
    halo: vec4<u32>,
    re: f32,
    r_min: f32,
    phi: f32,
    // momentum → force: the physical momentum per lattice unit over the step (seed units)
    factor: f32,
    // queries, nodes or particles
    count: u32,
    // number of level sets in set_grids
    sets: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> velocities: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> bin_start: array<u32>;
@group(0) @binding(4) var<storage, read> bin_order: array<u32>;
// level_set_at: query points; exchange_gather: the particles' positions
@group(0) @binding(5) var<storage, read> queries: array<vec4<f32>>;
// level_set_at: (L, ∇L) and (wall velocity, Σw) per query
@group(0) @binding(6) var<storage, read_write> level_out: array<vec4<f32>>;
// each lattice node's wall momentum (xyz) and mass (w) over the step (the GPU fluid's face-flux
// record, to which add_node_changes adds the geometry stage's node changes)
@group(0) @binding(7) var<storage, read_write> wall: array<vec4<f32>>;
// exchange_weights: wall / Σ_j w_j at each node (zero where no particle is within r_e)
@group(0) @binding(8) var<storage, read_write> scaled: array<vec4<f32>>;
// exchange_gather: the force on each particle (xyz)
@group(0) @binding(9) var<storage, read_write> force: array<vec4<f32>>;
// add_node_changes: the momentum (xyz) and mass (w) booked to a node that changed side, and
// that node (distinct nodes, so no two threads write one entry)
@group(0) @binding(10) var<storage, read> change_momentum: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> change_node: array<u32>;
// exchange_weights: per workgroup, the sums over its nodes of the exchange's diagnostics (CPU
// twin: the run sums of `momentum_exchange`), two vec4 per workgroup: (the momentum of nodes with
// no particle within r_e — walls that are no coupled body —, the mass all wall nodes took) and
// (Σ (p − u_w m), the momentum in the wall's frame, 0)
@group(0) @binding(12) var<storage, read_write> diag_partials: array<vec4<f32>>;
// the level sets, bodies in order
@group(0) @binding(13) var<storage, read> set_grids: array<SetGrid>;

var<workgroup> diag_a: array<vec4<f32>, 64>;
var<workgroup> diag_b: array<vec4<f32>, 64>;

fn thread_index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 64u;
}

fn near(p: vec3<f32>, g: SetGrid) -> bool {
    return all(p >= g.lo.xyz) && all(p <= g.hi.xyz);
}

// The kernel weight w(r) = r_e / max(r, r_min) − 1 (2.124), for r ≤ r_e.
fn weight(r: f32) -> f32 {
    return P.re / max(r, P.r_min) - 1.0;
}

// Visits the particles in the 3ᴰ bins around p of each set (CPU twin: KernelLevelSet::candidates,
// set after set) and sums L, ∇L, Σ w v and Σ w over those within r_e.
struct Sums { l: f32, g: vec3<f32>, wv: vec3<f32>, w: f32 };

fn kernel_sums(p: vec3<f32>) -> Sums {
    var s = Sums(-P.phi, vec3<f32>(0.0), vec3<f32>(0.0), 0.0);
    for (var si = 0u; si < P.sets; si = si + 1u) {
        let g = set_grids[si];
        if (!near(p, g)) { continue; }
        let c = vec3<i32>(floor((p - g.lo.xyz) / P.re));
        let b = vec3<i32>(g.bins.xyz);
        let lo = max(c - vec3<i32>(1), vec3<i32>(0));
        let hi = min(c + vec3<i32>(1), b - vec3<i32>(1));
        for (var z = lo.z; z <= hi.z; z = z + 1) {
            for (var y = lo.y; y <= hi.y; y = y + 1) {
                for (var x = lo.x; x <= hi.x; x = x + 1) {
                    let bin = g.first.y + u32((z * b.y + y) * b.x + x);
                    for (var k = bin_start[bin]; k < bin_start[bin + 1u]; k = k + 1u) {
                        let j = g.first.x + bin_order[g.first.x + k];
                        let d = p - points[j].xyz;
                        let r = length(d);
                        if (r > P.re) { continue; }
                        let w = weight(r);
                        s.l += w;
                        s.w += w;
                        s.wv += w * velocities[j].xyz;
                        if (r > P.r_min) {
                            s.g += (-P.re / (r * r * r)) * d;
                        }
                    }
                }
            }
        }
    }
    return s;
}

// L, ∇L (2.124–2.126) and the wall velocity (2.130) at each query point.
@compute @workgroup_size(64)
fn level_set_at(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = thread_index(gid, nwg);
    if (t >= P.count) { return; }
    let s = kernel_sums(queries[t].xyz);
    var v = vec3<f32>(0.0);
    if (s.w > 0.0) { v = s.wv / s.w; }
    level_out[2u * t] = vec4<f32>(s.l, s.g);
    level_out[2u * t + 1u] = vec4<f32>(v, s.w);
}

fn node_coords(t: u32) -> vec3<f32> {
    let px = P.padded.x;
    let py = P.padded.y;
    let x = i32(t % px) - i32(P.halo.x);
    let y = i32((t / px) % py) - i32(P.halo.y);
    let z = i32(t / (px * py)) - i32(P.halo.z);
    return vec3<f32>(f32(x), f32(y), f32(z));
}

// The geometry stage's node changes (covered nodes hand the air's momentum to the body, fresh
// ones take it from the body) join the face fluxes before the hand-over (CPU twin: the entries
// that `CoupledSolver::install_level_set_walls` books to the wall array).
@compute @workgroup_size(64)
fn add_node_changes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = thread_index(gid, nwg);
    if (i >= P.count) { return; }
    let node = change_node[i];
    wall[node] = wall[node] + change_momentum[i];
}

// (2.127–2.128), first half: each wall node's momentum over the kernel weights' sum there, so
// that the particles' shares sum to what the node took out of the air; and the exchange's
// diagnostics summed per workgroup.
@compute @workgroup_size(64)
fn exchange_weights(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    let t = thread_index(gid, nwg);
    var a = vec4<f32>(0.0);
    var b = vec4<f32>(0.0);
    if (t < P.count) {
        let w4 = wall[t];
        var out = vec4<f32>(0.0);
        if (any(w4 != vec4<f32>(0.0))) {
            let s = kernel_sums(node_coords(t));
            var uw = vec3<f32>(0.0);
            if (s.w > 0.0) {
                out = w4 / s.w;
                uw = s.wv / s.w;
            } else {
                a = vec4<f32>(w4.xyz, 0.0);
            }
            a.w = w4.w;
            b = vec4<f32>(w4.xyz - uw * w4.w, 0.0);
        }
        scaled[t] = out;
    }
    // the workgroup's sums by a fixed tree (deterministic)
    diag_a[li] = a;
    diag_b[li] = b;
    workgroupBarrier();
    for (var k = 32u; k > 0u; k = k >> 1u) {
        if (li < k) {
            diag_a[li] = diag_a[li] + diag_a[li + k];
            diag_b[li] = diag_b[li] + diag_b[li + k];
        }
        workgroupBarrier();
    }
    if (li == 0u) {
        let g = wid.x + wid.y * nwg.x;
        diag_partials[2u * g] = diag_a[0];
        diag_partials[2u * g + 1u] = diag_b[0];
    }
}

// Second half: each particle gathers w_ij · scaled_j from the lattice nodes within r_e of it
// (its position from `points`, the set's own: nothing else goes up for it).
@compute @workgroup_size(64)
fn exchange_gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = thread_index(gid, nwg);
    if (i >= P.count) { return; }
    let x = points[i].xyz;
    let h = vec3<i32>(P.halo.xyz);
    let n = vec3<i32>(P.padded.xyz) - h;
    let lo = max(vec3<i32>(ceil(x - vec3<f32>(P.re))), -h);
    let hi = min(vec3<i32>(floor(x + vec3<f32>(P.re))), n - vec3<i32>(1));
    var f = vec3<f32>(0.0);
    for (var z = lo.z; z <= hi.z; z = z + 1) {
        for (var y = lo.y; y <= hi.y; y = y + 1) {
            for (var xx = lo.x; xx <= hi.x; xx = xx + 1) {
                let node = u32(((z + h.z) * i32(P.padded.y) + (y + h.y)) * i32(P.padded.x) + (xx + h.x));
                let m = scaled[node];
                if (all(m.xyz == vec3<f32>(0.0))) { continue; }
                let r = length(vec3<f32>(f32(xx), f32(y), f32(z)) - x);
                if (r > P.re) { continue; }
                f += weight(r) * m.xyz;
            }
        }
    }
    force[i] = vec4<f32>(f * P.factor, 0.0);
}
