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
// periodic shift.xyz (r⁰ = X_j + shift − X_i already holds it), pair stiffness k
@group(0) @binding(5) var<storage, read> bond_shift: array<vec4<f32>>;
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
        let kk = bond_shift[k].w;
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

// ---------------------------------------------------------------- implicit method

// increments of the linear operator and the rotations that follow them
@group(1) @binding(0) var<storage, read_write> lin_x: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read_write> lin_v: array<vec4<f32>>;
// θ of the position increments [0, n) and of the velocity increments [n, 2n)
@group(1) @binding(2) var<storage, read_write> theta: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> jinv: array<mat3x3<f32>>;
@group(1) @binding(4) var<storage, read_write> lambda: array<vec4<f32>>;
// CG vectors, n each: x (ΔV), r, z, p, Ap, b, and the internal force of the state
@group(1) @binding(5) var<storage, read_write> cg: array<vec4<f32>>;
// block-Jacobi inverse blocks
@group(1) @binding(6) var<storage, read> precond: array<mat3x3<f32>>;
// partial sums (four per workgroup) and the scalars: [pAp, rz, rr, bb, -, rz_old, -, -]
@group(1) @binding(7) var<storage, read_write> partials: array<f32>;
@group(1) @binding(8) var<storage, read_write> scalars: array<f32>;
// the patch smoother (src/solid/patch_jacobi.rs), in two arrays (the stage's storage bindings
// are 32 at most on some devices): `patch_index` = [Q, where each of the Q patches' members
// start (Q + 1 offsets), where each patch's inverse starts (Q + 1), the free particles patch by
// patch], and the packed lower triangles of A_PP⁻¹
@group(1) @binding(9) var<storage, read> patch_index: array<u32>;
@group(1) @binding(10) var<storage, read> patch_inverse: array<f32>;

// (2.74) by Müller's fixed-point step far from the solution and Newton near it, warm-started
// from the current quaternion; then J⁻¹ of (2.74) at the solution.
@compute @workgroup_size(64)
fn solve_rotations(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    if pinfo[i].w > 0.5 {
        jinv[i] = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        rot[i] = quat_to_mat(quat[i]);
        return;
    }
    var q = quat[i];
    let x_i = pos[i].xyz;
    var scale = 0.0;
    for (var k = offs[i]; k < offs[i + 1u]; k++) {
        scale += bond_r0[k].w * dot(bond_r0[k].xyz, bond_r0[k].xyz);
    }
    scale = max(scale, 1e-30);
    var jac = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var it = 0u; it < 40u; it++) {
        let rm = quat_to_mat(q);
        var g = vec3<f32>(0.0);
        var align = 0.0;
        jac = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        for (var k = offs[i]; k < offs[i + 1u]; k++) {
            let r = bond_r0[k].xyz + (pos[nbr[k]].xyz - x_i);
            let a = rm * bond_r0[k].xyz;
            let w = bond_r0[k].w;
            g += w * cross(r, a);
            align += w * dot(r, a);
            let ra = dot(r, a);
            jac += w * (mat3x3<f32>(vec3<f32>(ra, 0.0, 0.0), vec3<f32>(0.0, ra, 0.0), vec3<f32>(0.0, 0.0, ra)) - outer(a, r));
        }
        if length(g) <= 1e-6 * scale { break; }
        var delta: vec3<f32>;
        var newton = false;
        if P.dim == 2u {
            if jac[2][2] > 0.5 * abs(align) && align > 0.0 {
                delta = vec3<f32>(0.0, 0.0, -g.z / jac[2][2]);
                newton = true;
            }
        } else {
            let s = 0.5 * (jac + transpose(jac));
            if s[0][0] > 0.0 && s[0][0] * s[1][1] - s[0][1] * s[1][0] > 0.0 && determinant(s) > 0.0 && align > 0.0 && length(g) < 0.1 * align {
                let d = determinant(jac);
                if abs(d) > 1e-12 * scale * scale * scale {
                    // inverse via the adjugate
                    let c0 = cross(jac[1], jac[2]);
                    let c1 = cross(jac[2], jac[0]);
                    let c2 = cross(jac[0], jac[1]);
                    let inv = transpose(mat3x3<f32>(c0, c1, c2)) * (1.0 / d);
                    delta = -(inv * g);
                    newton = true;
                }
            }
        }
        if !newton {
            delta = -g / (abs(align) + 1e-12 * scale);
            if P.dim == 2u { delta = vec3<f32>(0.0, 0.0, delta.z); }
        }
        let ang = length(delta);
        if ang < 1e-12 { break; }
        q = normalize(quat_mul(axis_angle(delta / ang, min(ang, 0.5)), q));
    }
    quat[i] = q;
    rot[i] = quat_to_mat(q);
    if P.dim == 2u {
        var m = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        if abs(jac[2][2]) > 0.0 { m[2][2] = 1.0 / jac[2][2]; }
        jinv[i] = m;
    } else {
        let d = determinant(jac);
        let c0 = cross(jac[1], jac[2]);
        let c1 = cross(jac[2], jac[0]);
        let c2 = cross(jac[0], jac[1]);
        jinv[i] = transpose(mat3x3<f32>(c0, c1, c2)) * (1.0 / d);
    }
}

// θ_i = J_i⁻¹ Σ_j ŵ (R_i r⁰) × (p_j − p_i), for the position and the velocity increments
@compute @workgroup_size(64)
fn rotation_increments(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    var sx = vec3<f32>(0.0);
    var sv = vec3<f32>(0.0);
    for (var k = offs[i]; k < offs[i + 1u]; k++) {
        let j = nbr[k];
        let a = rot[i] * bond_r0[k].xyz;
        sx += bond_r0[k].w * cross(a, lin_x[j].xyz - lin_x[i].xyz);
        sv += bond_r0[k].w * cross(a, lin_v[j].xyz - lin_v[i].xyz);
    }
    theta[i] = vec4<f32>(jinv[i] * sx, 0.0);
    theta[P.n + i] = vec4<f32>(jinv[i] * sv, 0.0);
}

// λ_i = J_i⁻ᵀ τ_i
@compute @workgroup_size(64)
fn chain_lambda(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    lambda[i] = vec4<f32>(transpose(jinv[i]) * torque[i].xyz, 0.0);
}

// f_m −= Σ_j ŵ (λ_j × R_j r⁰ + λ_m × R_m r⁰)
@compute @workgroup_size(64)
fn chain_forces(@builtin(global_invocation_id) gid: vec3<u32>) {
    let m = idx(gid);
    if m >= P.n { return; }
    var s = vec3<f32>(0.0);
    for (var k = offs[m]; k < offs[m + 1u]; k++) {
        let j = nbr[k];
        let r0 = bond_r0[k].xyz;
        s += bond_r0[k].w * (cross(lambda[j].xyz, rot[j] * r0) + cross(lambda[m].xyz, rot[m] * r0));
    }
    force[m] = vec4<f32>(force[m].xyz - s, 0.0);
}

// B = Δt (f + Δt K v): `force` holds K v, cg[6n + i] the internal force of the state,
// `extra_force` the contact force
@compute @workgroup_size(64)
fn cg_rhs(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    var b = vec3<f32>(0.0);
    if pinfo[i].w < 0.5 {
        b = P.dt * (cg[6u * P.n + i].xyz + extra_force[i].xyz + load[i].xyz + pinfo[i].x * P.gravity.xyz + P.dt * force[i].xyz);
    }
    cg[5u * P.n + i] = vec4<f32>(b, 0.0);
    cg[i] = vec4<f32>(0.0);
    cg[1u * P.n + i] = vec4<f32>(b, 0.0);
    let z = select(precond[i] * b, vec3<f32>(0.0), pinfo[i].w > 0.5);
    cg[2u * P.n + i] = vec4<f32>(z, 0.0);
    cg[3u * P.n + i] = vec4<f32>(z, 0.0);
    // the linear operator reads its increments from lin_x / lin_v
    lin_x[i] = vec4<f32>(z, 0.0);
    lin_v[i] = vec4<f32>(z / P.dt, 0.0);
}

// A p = (m + m_a) p − Δt² (K p + D p/Δt), `force` holds K p + D p/Δt
@compute @workgroup_size(64)
fn cg_apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    var ap = vec3<f32>(0.0);
    if pinfo[i].w < 0.5 {
        ap = (pinfo[i].x + load[i].w) * cg[3u * P.n + i].xyz - P.dt * P.dt * force[i].xyz;
    }
    cg[4u * P.n + i] = vec4<f32>(ap, 0.0);
}

var<workgroup> red: array<f32, 256>;

// partial sums of four dot products: p·Ap, r·z, r·r, b·b (one workgroup of 256 per 256 particles)
@compute @workgroup_size(256)
fn cg_dots(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>) {
    let i = gid.x;
    var vals = vec4<f32>(0.0);
    if i < P.n {
        vals = vec4<f32>(dot(cg[3u * P.n + i].xyz, cg[4u * P.n + i].xyz), dot(cg[1u * P.n + i].xyz, cg[2u * P.n + i].xyz), dot(cg[1u * P.n + i].xyz, cg[1u * P.n + i].xyz), dot(cg[5u * P.n + i].xyz, cg[5u * P.n + i].xyz));
    }
    for (var c = 0u; c < 4u; c++) {
        red[li] = vals[c];
        workgroupBarrier();
        for (var s = 128u; s > 0u; s >>= 1u) {
            if li < s { red[li] += red[li + s]; }
            workgroupBarrier();
        }
        if li == 0u { partials[4u * wid.x + c] = red[0]; }
        workgroupBarrier();
    }
}

// sums the partials (single workgroup): scalars[0..4] = (pAp, rz, rr, bb)
@compute @workgroup_size(256)
fn cg_sum(@builtin(local_invocation_index) li: u32) {
    let groups = (P.n + 255u) / 256u;
    for (var c = 0u; c < 4u; c++) {
        var acc = 0.0;
        for (var g = li; g < groups; g += 256u) {
            acc += partials[4u * g + c];
        }
        red[li] = acc;
        workgroupBarrier();
        for (var s = 128u; s > 0u; s >>= 1u) {
            if li < s { red[li] += red[li + s]; }
            workgroupBarrier();
        }
        if li == 0u { scalars[c] = red[0]; }
        workgroupBarrier();
    }
}

// x += α p, r −= α Ap, z = P⁻¹ r (α = rz / pAp); the new r·z goes through cg_dots/cg_sum next
@compute @workgroup_size(64)
fn cg_update(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    let alpha = select(scalars[1] / scalars[0], 0.0, scalars[0] == 0.0);
    cg[i] = vec4<f32>(cg[i].xyz + alpha * cg[3u * P.n + i].xyz, 0.0);
    let r = cg[1u * P.n + i].xyz - alpha * cg[4u * P.n + i].xyz;
    cg[1u * P.n + i] = vec4<f32>(r, 0.0);
    let z = select(precond[i] * r, vec3<f32>(0.0), pinfo[i].w > 0.5);
    cg[2u * P.n + i] = vec4<f32>(z, 0.0);
}

// the most unknowns of one patch (64 particles × 3); the host falls back to block Jacobi above
const PATCH_UNKNOWNS: u32 = 192u;
var<workgroup> patch_r: array<f32, PATCH_UNKNOWNS>;

// z_P = A_PP⁻¹ r_P, one workgroup per patch (CPU twin: PatchJacobi::apply). It overwrites z
// at every free particle (each is in one patch) after cg_rhs / cg_update wrote r; clamped
// particles keep the z = 0 those kernels gave them. Unknown a of a patch is component a % 3 of
// its member a / 3; the inverse is symmetric, stored as its lower triangle row by row.
@compute @workgroup_size(64)
fn cg_patches(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let q = wid.x + wid.y * 65535u;
    let patches = patch_index[0];
    if q >= patches { return; }
    // the members of patch q at patch_index[first ..), 3 unknowns each
    let members = 3u + 2u * patches;
    let first = members + patch_index[1u + q];
    let m = 3u * (patch_index[2u + q] - patch_index[1u + q]);
    for (var a = li; a < m; a += 64u) {
        patch_r[a] = cg[P.n + patch_index[first + a / 3u]][a % 3u];
    }
    workgroupBarrier();
    let base = patch_index[2u + patches + q];
    for (var a = li; a < m; a += 64u) {
        let row = base + a * (a + 1u) / 2u;
        var z = 0.0;
        for (var c = 0u; c <= a; c++) {
            z += patch_inverse[row + c] * patch_r[c];
        }
        for (var c = a + 1u; c < m; c++) {
            z += patch_inverse[base + c * (c + 1u) / 2u + a] * patch_r[c];
        }
        cg[2u * P.n + patch_index[first + a / 3u]][a % 3u] = z;
    }
}

// p = z and the operator's first input, after the patch smoother gave the first z
@compute @workgroup_size(64)
fn cg_first_direction(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    let z = cg[2u * P.n + i].xyz;
    cg[3u * P.n + i] = vec4<f32>(z, 0.0);
    lin_x[i] = vec4<f32>(z, 0.0);
    lin_v[i] = vec4<f32>(z / P.dt, 0.0);
}

// after the sums of the new r: β = rz_new / rz_old; p = z + β p; the operator's next input
@compute @workgroup_size(64)
fn cg_direction(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    let beta = select(scalars[1] / scalars[5], 0.0, scalars[5] == 0.0);
    let p = cg[2u * P.n + i].xyz + beta * cg[3u * P.n + i].xyz;
    cg[3u * P.n + i] = vec4<f32>(p, 0.0);
    lin_x[i] = vec4<f32>(p, 0.0);
    lin_v[i] = vec4<f32>(p / P.dt, 0.0);
}

// keeps rz of this iteration (scalars[5]) for the next β
@compute @workgroup_size(1)
fn cg_keep() {
    scalars[5] = scalars[1];
}

// v += ΔV; x += Δt v (2.57)
@compute @workgroup_size(64)
fn integrate_implicit(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    if pinfo[i].w > 0.5 {
        vel[i] = vec4<f32>(0.0);
        return;
    }
    let v = vel[i].xyz + cg[i].xyz;
    vel[i] = vec4<f32>(v, 0.0);
    pos[i] = vec4<f32>(pos[i].xyz + P.dt * v, 0.0);
}

// ω_i of (2.73) for the viscous term of the implicit method
@compute @workgroup_size(64)
fn angular_velocity(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    var rhs = vec3<f32>(0.0);
    var a = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var k = offs[i]; k < offs[i + 1u]; k++) {
        let j = nbr[k];
        let r = bond_r0[k].xyz + (pos[j].xyz - pos[i].xyz);
        let w = bond_r0[k].w;
        rhs += w * cross(r, vel[j].xyz - vel[i].xyz);
        let rr = dot(r, r);
        a += w * (mat3x3<f32>(vec3<f32>(rr, 0.0, 0.0), vec3<f32>(0.0, rr, 0.0), vec3<f32>(0.0, 0.0, rr)) - outer(r, r));
    }
    var w = vec3<f32>(0.0);
    if P.dim == 2u {
        if abs(a[2][2]) > 0.0 { w = vec3<f32>(0.0, 0.0, rhs.z / a[2][2]); }
    } else {
        let d = determinant(a);
        if abs(d) > 0.0 {
            let inv = transpose(mat3x3<f32>(cross(a[1], a[2]), cross(a[2], a[0]), cross(a[0], a[1]))) * (1.0 / d);
            w = inv * rhs;
        }
    }
    spin[i] = vec4<f32>(w, 0.0);
}

// the operator's input for K v: lin_x = v, lin_v = 0
@compute @workgroup_size(64)
fn prepare_kv(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    lin_x[i] = vec4<f32>(vel[i].xyz, 0.0);
    lin_v[i] = vec4<f32>(0.0);
}
