// MPS orthotropic viscoelastic solid (seed 000 §2.2) — GPU twins of src/solid/{forces,
// rotation,implicit}.rs, f32. One thread per particle; every kernel gathers over the particle's
// own bond list (CSR), so no atomics are needed. Vectors are vec4 (xyz + a packed scalar).

struct Params {
    n: u32,
    dim: u32,
    contact: u32,
    _pad: u32,
    dt: f32,
    _p0: f32,
    _p1: f32,
    _p2: f32,
    gravity: vec4<f32>,
};

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> offs: array<u32>;
@group(0) @binding(2) var<storage, read> nbr: array<u32>;
@group(0) @binding(3) var<storage, read> rev: array<u32>;
// r⁰.xyz, ŵ
@group(0) @binding(4) var<storage, read> bond_r0: array<vec4<f32>>;
// pair stiffness k of each bond (4 B: the periodic shift, already in r⁰ = X_j + shift − X_i, is
// not sent)
@group(0) @binding(5) var<storage, read> bond_stiffness: array<f32>;
// gradient weight g.xyz, pair damping c
@group(0) @binding(6) var<storage, read> bond_grad: array<vec4<f32>>;
// C' = C − C_pair, 36 per particle (Voigt, row-major)
@group(0) @binding(7) var<storage, read> cstiff: array<f32>;
// mass, inertia, volume, fixed (1.0)
@group(0) @binding(8) var<storage, read> pinfo: array<vec4<f32>>;
// displacement u = x − X from the reference position (the host adds X back): a bond's current
// vector is r⁰ + (u_j − u_i), which keeps f32's relative precision on the bond's own length
// instead of on the particles' distance from the origin (x_j − x_i of absolute f32 positions
// loses |x|/l₀ of it: strains of ~1e-5 at |x| = 130 l₀)
@group(0) @binding(9) var<storage, read_write> pos: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> spin: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> quat: array<vec4<f32>>;
// constant load.xyz; added mass M_a in .w (seed 2.129; both integrators)
@group(0) @binding(13) var<storage, read> load: array<vec4<f32>>;
@group(0) @binding(14) var<storage, read_write> rot: array<mat3x3<f32>>;
@group(0) @binding(15) var<storage, read_write> qmat: array<mat3x3<f32>>;
@group(0) @binding(16) var<storage, read_write> torque_g: array<vec4<f32>>;
@group(0) @binding(17) var<storage, read_write> force: array<vec4<f32>>;
@group(0) @binding(18) var<storage, read_write> torque: array<vec4<f32>>;
// contact force/torque (added by the contact stage; zero without contact)
@group(0) @binding(19) var<storage, read_write> extra_force: array<vec4<f32>>;
@group(0) @binding(20) var<storage, read_write> extra_torque: array<vec4<f32>>;

fn idx(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * 65535u * 64u;
}

fn outer(a: vec3<f32>, b: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(a * b.x, a * b.y, a * b.z);
}

fn quat_to_mat(q: vec4<f32>) -> mat3x3<f32> {
    let x2 = q.x + q.x;
    let y2 = q.y + q.y;
    let z2 = q.z + q.z;
    let xx = q.x * x2;
    let xy = q.x * y2;
    let xz = q.x * z2;
    let yy = q.y * y2;
    let yz = q.y * z2;
    let zz = q.z * z2;
    let wx = q.w * x2;
    let wy = q.w * y2;
    let wz = q.w * z2;
    return mat3x3<f32>(
        vec3<f32>(1.0 - (yy + zz), xy + wz, xz - wy),
        vec3<f32>(xy - wz, 1.0 - (xx + zz), yz + wx),
        vec3<f32>(xz + wy, yz - wx, 1.0 - (xx + yy)),
    );
}

fn quat_mul(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz), a.w * b.w - dot(a.xyz, b.xyz));
}

fn axis_angle(axis: vec3<f32>, angle: f32) -> vec4<f32> {
    return vec4<f32>(axis * sin(0.5 * angle), cos(0.5 * angle));
}

// Voigt (xx, yy, zz, yz+zy, zx+xz, xy+yx) of a symmetric tensor
fn to_voigt(e: mat3x3<f32>, v: ptr<function, array<f32, 6>>) {
    (*v)[0] = e[0][0];
    (*v)[1] = e[1][1];
    (*v)[2] = e[2][2];
    (*v)[3] = e[2][1] + e[1][2];
    (*v)[4] = e[0][2] + e[2][0];
    (*v)[5] = e[1][0] + e[0][1];
}

// ---------------------------------------------------------------- rotations

@compute @workgroup_size(64)
fn rotation_matrices(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    rot[i] = quat_to_mat(quat[i]);
}

// ---------------------------------------------------------------- strain_stress

fn strain_stress_at(i: u32, full: bool, x_i: vec3<f32>) {
    var f = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var k = offs[i]; k < offs[i + 1u]; k++) {
        let j = nbr[k];
        var r: vec3<f32>;
        if full {
            r = bond_r0[k].xyz + (pos[j].xyz - x_i);
        } else {
            r = lin_x[j].xyz - x_i;
        }
        f += outer(r, bond_grad[k].xyz);
    }
    if full && P.dim == 2u {
        f[2][2] = 1.0;
    }
    let r_i = rot[i];
    var h = transpose(r_i) * f;
    if full {
        h[0][0] -= 1.0;
        h[1][1] -= 1.0;
        h[2][2] -= 1.0;
    }
    let eps = 0.5 * (h + transpose(h));
    var ev: array<f32, 6>;
    to_voigt(eps, &ev);
    var sv: array<f32, 6>;
    for (var p = 0u; p < 6u; p++) {
        var acc = 0.0;
        for (var q = 0u; q < 6u; q++) {
            acc += cstiff[36u * i + 6u * p + q] * ev[q];
        }
        sv[p] = acc;
    }
    let sigma = mat3x3<f32>(vec3<f32>(sv[0], sv[5], sv[4]), vec3<f32>(sv[5], sv[1], sv[3]), vec3<f32>(sv[4], sv[3], sv[2]));
    let v = pinfo[i].z;
    qmat[i] = v * (r_i * sigma);
    if full {
        let b = f * sigma * transpose(r_i);
        torque_g[i] = vec4<f32>(v * vec3<f32>(b[2][1] - b[1][2], b[0][2] - b[2][0], b[1][0] - b[0][1]), 0.0);
    } else {
        torque_g[i] = vec4<f32>(0.0);
    }
}

@compute @workgroup_size(64)
fn strain_stress_full(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    strain_stress_at(i, true, pos[i].xyz);
}

@compute @workgroup_size(64)
fn strain_stress_linear(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    strain_stress_at(i, false, lin_x[i].xyz);
}

// ---------------------------------------------------------------- bond_forces

fn bond_forces_at(i: u32, full: bool, follow: bool) {
    var f = vec3<f32>(0.0);
    var t = torque_g[i].xyz;
    let r_i = rot[i];
    var w_i = vec3<f32>(0.0);
    var x_i: vec3<f32>;
    var v_i: vec3<f32>;
    if full {
        w_i = spin[i].xyz;
        x_i = pos[i].xyz;
        v_i = vel[i].xyz;
    } else {
        x_i = lin_x[i].xyz;
        v_i = lin_v[i].xyz;
    }
    for (var k = offs[i]; k < offs[i + 1u]; k++) {
        let j = nbr[k];
        let r0 = bond_r0[k].xyz;
        let g = bond_grad[k];
        f += qmat[i] * g.xyz - qmat[j] * bond_grad[rev[k]].xyz;
        let a_i = r_i * r0;
        let a_j = rot[j] * r0;
        var r: vec3<f32>;
        var u: vec3<f32>;
        var v_j: vec3<f32>;
        var w_bar: vec3<f32>;
        if full {
            r = bond_r0[k].xyz + (pos[j].xyz - x_i);
            u = r - 0.5 * (a_i + a_j);
            v_j = vel[j].xyz;
            w_bar = 0.5 * (w_i + spin[j].xyz);
        } else {
            let p = lin_x[j].xyz - x_i;
            u = p;
            w_bar = vec3<f32>(0.0);
            if follow {
                u = p - 0.5 * (cross(theta[i].xyz, a_i) + cross(theta[j].xyz, a_j));
                w_bar = 0.5 * (theta[P.n + i].xyz + theta[P.n + j].xyz);
            }
            r = 0.5 * (a_i + a_j);
            v_j = lin_v[j].xyz;
        }
        let kk = bond_stiffness[k];
        f += kk * u;
        t += 0.5 * kk * cross(a_i, u);
        let c = g.w;
        if c != 0.0 {
            let vij = v_j - v_i - cross(w_bar, r);
            f += c * vij;
            t += 0.5 * c * cross(r, vij);
        }
    }
    force[i] = vec4<f32>(f, 0.0);
    torque[i] = vec4<f32>(t, 0.0);
}

@compute @workgroup_size(64)
fn bond_forces_full(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    bond_forces_at(i, true, false);
}

@compute @workgroup_size(64)
fn bond_forces_linear(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    bond_forces_at(i, false, true);
}

// ---------------------------------------------------------------- explicit integration

// (2.44)–(2.45), (2.52)–(2.56)
@compute @workgroup_size(64)
fn integrate_explicit(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    let info = pinfo[i];
    if info.w > 0.5 {
        vel[i] = vec4<f32>(0.0);
        spin[i] = vec4<f32>(0.0);
        return;
    }
    let dt = P.dt;
    let f = force[i].xyz + extra_force[i].xyz + load[i].xyz + info.x * P.gravity.xyz;
    // (M + M_a) ΔV = Δt f: the fluid's added mass of a momentum-conserving coupling (2.129)
    let v = vel[i].xyz + dt * f / (info.x + load[i].w);
    let w = spin[i].xyz + dt * (torque[i].xyz + extra_torque[i].xyz) / info.y;
    vel[i] = vec4<f32>(v, 0.0);
    spin[i] = vec4<f32>(w, 0.0);
    let ang = length(w) * dt;
    if ang > 0.0 {
        quat[i] = normalize(quat_mul(axis_angle(w / length(w), ang), quat[i]));
    }
    pos[i] = vec4<f32>(pos[i].xyz + dt * v, 0.0);
}

// The implicit method's bindings and kernels follow in shaders/solid_implicit.wgsl (the host
// compiles the two files as one module).
