// Distinct-element contact of the MPS solid (seed 000 §2.2.2, 2.22–2.37) on the GPU — twin of
// src/solid/contact.rs. A uniform grid of cells of side l₀ is rebuilt every step (counting
// sort with atomics), then every particle gathers its contacts with particles of other bodies
// and with the walls. Tangential-spring anchors persist in per-particle slots (double
// buffered); a pair's anchors are kept in the canonical order (lower index first) by both of
// its particles, which compute bit-identical pair forces with opposite signs.

struct ContactUniform {
    kn: f32,
    kt: f32,
    mu_s: f32,
    mu_d: f32,
    damping: f32,
    l0: f32,
    n_walls: u32,
    multi_body: u32,
    origin: vec4<f32>,
    dims: vec4<u32>,
    walls: array<vec4<f32>, 4>,
    n: u32,
    dim: u32,
    slots: u32,
    cells: u32,
};

const WALL: u32 = 0x80000000u;
const NONE: u32 = 0xffffffffu;

@group(0) @binding(0) var<uniform> C: ContactUniform;
@group(0) @binding(1) var<storage, read> pos: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> rot: array<mat3x3<f32>>;
@group(0) @binding(4) var<storage, read> pinfo: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> body: array<u32>;
@group(0) @binding(6) var<storage, read_write> extra_force: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> extra_torque: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> cell_of: array<u32>;
@group(0) @binding(9) var<storage, read_write> cell_count: array<atomic<u32>>;
@group(0) @binding(10) var<storage, read_write> cell_start: array<u32>;
@group(0) @binding(11) var<storage, read_write> sorted: array<u32>;
// slot s of particle i at 2 (i·slots + s): (anchor of the lower particle, partner bits), (anchor of the higher particle / wall point, -)
@group(0) @binding(12) var<storage, read> hist_in: array<vec4<f32>>;
@group(0) @binding(13) var<storage, read_write> hist_out: array<vec4<f32>>;
// reference positions X: a particle is at X + u (`pos` holds u, see shaders/solid.wgsl)
@group(0) @binding(14) var<storage, read> ref_pos: array<vec4<f32>>;

fn position(i: u32) -> vec3<f32> {
    return ref_pos[i].xyz + pos[i].xyz;
}

fn idx(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * 65535u * 64u;
}

fn cell_coord(x: vec3<f32>) -> vec3<i32> {
    let t = floor((x - C.origin.xyz) / C.l0);
    let hi = vec3<f32>(f32(C.dims.x) - 1.0, f32(C.dims.y) - 1.0, f32(C.dims.z) - 1.0);
    return vec3<i32>(clamp(t, vec3<f32>(0.0), hi));
}

fn cell_index(c: vec3<i32>) -> u32 {
    return (u32(c.z) * C.dims.y + u32(c.y)) * C.dims.x + u32(c.x);
}

@compute @workgroup_size(64)
fn grid_count(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= C.n { return; }
    let c = cell_index(cell_coord(position(i)));
    cell_of[i] = c;
    atomicAdd(&cell_count[c], 1u);
}

var<workgroup> chunk: array<u32, 256>;

// exclusive prefix sum of the counts (one workgroup: serial chunks, then a scan of the chunks)
@compute @workgroup_size(256)
fn grid_scan(@builtin(local_invocation_index) li: u32) {
    let per = (C.cells + 255u) / 256u;
    let lo = min(li * per, C.cells);
    let hi = min(lo + per, C.cells);
    var s = 0u;
    for (var c = lo; c < hi; c++) {
        s += atomicLoad(&cell_count[c]);
    }
    chunk[li] = s;
    workgroupBarrier();
    if li == 0u {
        var acc = 0u;
        for (var k = 0u; k < 256u; k++) {
            let v = chunk[k];
            chunk[k] = acc;
            acc += v;
        }
        cell_start[C.cells] = acc;
    }
    workgroupBarrier();
    var run = chunk[li];
    for (var c = lo; c < hi; c++) {
        cell_start[c] = run;
        run += atomicLoad(&cell_count[c]);
    }
}

// after the counts were cleared again: scatter the particle indices by cell
@compute @workgroup_size(64)
fn grid_scatter(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= C.n { return; }
    let c = cell_of[i];
    sorted[cell_start[c] + atomicAdd(&cell_count[c], 1u)] = i;
}

fn find_slot(i: u32, partner: u32) -> i32 {
    for (var s = 0u; s < C.slots; s++) {
        let h = hist_in[2u * (i * C.slots + s)];
        let p = bitcast<u32>(h.w);
        if p == NONE { return -1; }
        if p == partner { return i32(s); }
    }
    return -1;
}

// tangential force of the spring cs capped by friction; .w = 1 when it slid
fn friction(cs: vec3<f32>, fn_mag: f32) -> vec4<f32> {
    let fc = C.kt * cs;
    if length(fc) > C.mu_s * fn_mag {
        let len = length(cs);
        var dir = vec3<f32>(0.0);
        if len > 0.0 { dir = cs / len; }
        return vec4<f32>(C.mu_d * fn_mag * dir, 1.0);
    }
    return vec4<f32>(fc, 0.0);
}

@compute @workgroup_size(64)
fn contact_forces(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= C.n { return; }
    let x_i = position(i);
    let fixed_i = pinfo[i].w > 0.5;
    var f = vec3<f32>(0.0);
    var t = vec3<f32>(0.0);
    var used = 0u;
    if C.multi_body != 0u {
        let c0 = cell_coord(x_i);
        let zr = select(0, 1, C.dim == 3u);
        for (var dz = -zr; dz <= zr; dz++) {
            for (var dy = -1; dy <= 1; dy++) {
                for (var dx = -1; dx <= 1; dx++) {
                    let c = c0 + vec3<i32>(dx, dy, dz);
                    if any(c < vec3<i32>(0)) || c.x >= i32(C.dims.x) || c.y >= i32(C.dims.y) || c.z >= i32(C.dims.z) { continue; }
                    let cell = cell_index(c);
                    for (var k = cell_start[cell]; k < cell_start[cell + 1u]; k++) {
                        let j = sorted[k];
                        if j == i || body[j] == body[i] { continue; }
                        let lo = min(i, j);
                        let hi = max(i, j);
                        let x_lo = position(lo);
                        let x_hi = position(hi);
                        let xij = (ref_pos[hi].xyz - ref_pos[lo].xyz) + (pos[hi].xyz - pos[lo].xyz);
                        let d = length(xij);
                        if d >= C.l0 || d == 0.0 { continue; }
                        let nrm = xij / d;
                        let cdepth = C.l0 - d;
                        let fn_vec = -C.kn * cdepth * nrm;
                        let r_lo = rot[lo];
                        let r_hi = rot[hi];
                        var a_lo_ref: vec3<f32>;
                        var a_hi_ref: vec3<f32>;
                        let s = find_slot(i, j);
                        if s >= 0 {
                            a_lo_ref = hist_in[2u * (i * C.slots + u32(s))].xyz;
                            a_hi_ref = hist_in[2u * (i * C.slots + u32(s)) + 1u].xyz;
                        } else {
                            let cp = 0.5 * (x_lo + x_hi);
                            a_lo_ref = transpose(r_lo) * (cp - x_lo);
                            a_hi_ref = transpose(r_hi) * (cp - x_hi);
                        }
                        let a_lo = x_lo + r_lo * a_lo_ref;
                        let a_hi = x_hi + r_hi * a_hi_ref;
                        let cij = a_hi - a_lo;
                        let cs = cij - dot(cij, nrm) * nrm;
                        let fr = friction(cs, C.kn * cdepth);
                        if fr.w > 0.5 {
                            let keep = length(fr.xyz) / C.kt;
                            var cs_new = vec3<f32>(0.0);
                            if length(cs) > 0.0 { cs_new = cs * (keep / length(cs)); }
                            a_hi_ref = transpose(r_hi) * (a_hi - (cs - cs_new) - x_hi);
                        }
                        let fd = C.damping * dot(vel[hi].xyz - vel[lo].xyz, nrm) * nrm;
                        let force_lo = fn_vec + fr.xyz + fd;
                        let cp = 0.5 * (a_lo + a_hi);
                        if !fixed_i {
                            if i == lo {
                                f += force_lo;
                                t += cross(cp - x_lo, force_lo);
                            } else {
                                f -= force_lo;
                                t -= cross(cp - x_hi, force_lo);
                            }
                        }
                        if used < C.slots {
                            let o = 2u * (i * C.slots + used);
                            hist_out[o] = vec4<f32>(a_lo_ref, bitcast<f32>(j));
                            hist_out[o + 1u] = vec4<f32>(a_hi_ref, 0.0);
                            used++;
                        }
                    }
                }
            }
        }
    }
    if !fixed_i {
        for (var w = 0u; w < C.n_walls; w++) {
            let wall = C.walls[w];
            let dist = dot(wall.xyz, x_i) - wall.w;
            let cdepth = 0.5 * C.l0 - dist;
            if cdepth <= 0.0 { continue; }
            let r_i = rot[i];
            var a_ref: vec3<f32>;
            var foot: vec3<f32>;
            let s = find_slot(i, WALL | w);
            if s >= 0 {
                a_ref = hist_in[2u * (i * C.slots + u32(s))].xyz;
                foot = hist_in[2u * (i * C.slots + u32(s)) + 1u].xyz;
            } else {
                foot = x_i - dist * wall.xyz;
                a_ref = transpose(r_i) * (foot - x_i);
            }
            let a_i = x_i + r_i * a_ref;
            let cij = foot - a_i;
            let cs = cij - dot(cij, wall.xyz) * wall.xyz;
            let fn_mag = C.kn * cdepth;
            let fr = friction(cs, fn_mag);
            if fr.w > 0.5 {
                let keep = length(fr.xyz) / C.kt;
                var cs_new = vec3<f32>(0.0);
                if length(cs) > 0.0 { cs_new = cs * (keep / length(cs)); }
                foot -= cs - cs_new;
            }
            f += fn_mag * wall.xyz + fr.xyz - C.damping * dot(vel[i].xyz, wall.xyz) * wall.xyz;
            t += cross(a_i - x_i, fr.xyz);
            if used < C.slots {
                let o = 2u * (i * C.slots + used);
                hist_out[o] = vec4<f32>(a_ref, bitcast<f32>(WALL | w));
                hist_out[o + 1u] = vec4<f32>(foot, 0.0);
                used++;
            }
        }
    }
    if used < C.slots {
        hist_out[2u * (i * C.slots + used)] = vec4<f32>(0.0, 0.0, 0.0, bitcast<f32>(NONE));
    }
    extra_force[i] = vec4<f32>(f, 0.0);
    extra_torque[i] = vec4<f32>(t, 0.0);
}
