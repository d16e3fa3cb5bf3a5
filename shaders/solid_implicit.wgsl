// MPS solid on the GPU, the implicit method (seed 000 (2.57)–(2.66), (2.73)–(2.74)): the
// second half of the module that begins in shaders/solid.wgsl, whose bindings, `P` and `idx`
// it uses — the rotations slaved to the positions, the matrix-free linear operator's chain
// rule, preconditioned CG (block Jacobi or the patch smoother, plus the coarse space) and the
// update.

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

// the search direction p of particle i, and the operator's next input from it: position
// increments p, velocity increments p/Δt
fn set_direction(i: u32, p: vec3<f32>) {
    cg[3u * P.n + i] = vec4<f32>(p, 0.0);
    lin_x[i] = vec4<f32>(p, 0.0);
    lin_v[i] = vec4<f32>(p / P.dt, 0.0);
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
    set_direction(i, z);
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
    let r = update_solution_and_residual(i);
    let z = select(precond[i] * r, vec3<f32>(0.0), pinfo[i].w > 0.5);
    cg[2u * P.n + i] = vec4<f32>(z, 0.0);
}

// cg_update without block Jacobi's z, for the patch smoother, which writes z next (clamped
// particles keep the z = 0 that cg_rhs gave them at the start of the solve)
@compute @workgroup_size(64)
fn cg_update_residual(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    update_solution_and_residual(i);
}

// x += α p, r -= α A p; returns the new r
fn update_solution_and_residual(i: u32) -> vec3<f32> {
    let alpha = select(scalars[1] / scalars[0], 0.0, scalars[0] == 0.0);
    cg[i] = vec4<f32>(cg[i].xyz + alpha * cg[3u * P.n + i].xyz, 0.0);
    let r = cg[1u * P.n + i].xyz - alpha * cg[4u * P.n + i].xyz;
    cg[1u * P.n + i] = vec4<f32>(r, 0.0);
    return r;
}

// the most unknowns of one patch (64 particles × 3); the host falls back to block Jacobi above
const PATCH_UNKNOWNS: u32 = 192u;
var<workgroup> patch_r: array<f32, PATCH_UNKNOWNS>;

// z_P = A_PP⁻¹ r_P, one workgroup per patch (CPU twin: PatchJacobi::apply). It overwrites z
// at every free particle (each is in one patch) after cg_rhs / cg_update_residual wrote r; clamped
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

// ---------------------------------------------------------------- coarse space

// The coarse-space correction of the preconditioner, z += P A_c⁻¹ Pᵀ r (CPU twin:
// CoarseSpace::add_correction in src/solid/coarse.rs): the aggregates' affine modes, A_c⁻¹ dense.
// Its arrays follow the patches' in `patch_index` (from coarse_index_at(): [A, m, dimension,
// modes, A + 1 unknown offsets, A + 1 member offsets, the aggregate of each particle (u32 max
// where clamped), the members aggregate by aggregate]) and in `patch_inverse` (from
// coarse_values_at(): [(x − centre)/side, 3 per particle; 12 × 12 mode coefficients per
// aggregate; A_c⁻¹, m × m]); g = Pᵀ r and u = A_c⁻¹ g live in `partials` after the dot
// products' partial sums (coarse_work_at()).
fn coarse_index_at() -> u32 {
    let q = patch_index[0];
    return 3u + 2u * q + patch_index[1u + q];
}

fn coarse_values_at() -> u32 {
    return patch_index[2u + 2u * patch_index[0]];
}

fn coarse_work_at() -> u32 {
    return 4u * ((P.n + 255u) / 256u) + 4u;
}

fn coarse_rel(i: u32) -> vec3<f32> {
    let v = coarse_values_at() + 3u * i;
    return vec3<f32>(patch_inverse[v], patch_inverse[v + 1u], patch_inverse[v + 2u]);
}

// m_k(rel) · v for the affine modes k of CoarseSpace::basis_of: translations, rotations
// (e_k × rel · v = e_k · (rel × v)), normal strains, shears
fn mode_dots(rel: vec3<f32>, v: vec3<f32>, dim: u32) -> array<f32, 12> {
    var d: array<f32, 12>;
    if dim == 2u {
        d[0] = v.x;
        d[1] = v.y;
        d[2] = rel.x * v.y - rel.y * v.x;
        d[3] = rel.x * v.x;
        d[4] = rel.y * v.y;
        d[5] = rel.y * v.x + rel.x * v.y;
    } else {
        let c = cross(rel, v);
        d[0] = v.x;
        d[1] = v.y;
        d[2] = v.z;
        d[3] = c.x;
        d[4] = c.y;
        d[5] = c.z;
        d[6] = rel.x * v.x;
        d[7] = rel.y * v.y;
        d[8] = rel.z * v.z;
        d[9] = rel.y * v.x + rel.x * v.y;
        d[10] = rel.z * v.y + rel.y * v.z;
        d[11] = rel.z * v.x + rel.x * v.z;
    }
    return d;
}

var<workgroup> coarse_sums: array<f32, 768>;

// g = Pᵀ r, one workgroup per aggregate: the modes' projections of r summed over the members,
// then g_e = Σ_k b_ek S_k for the aggregate's basis vectors e
@compute @workgroup_size(64)
fn coarse_restrict(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let a = wid.x + wid.y * 65535u;
    let c0 = coarse_index_at();
    let aggregates = patch_index[c0];
    if a >= aggregates { return; }
    let dim = patch_index[c0 + 2u];
    let starts = c0 + 5u + aggregates;
    let members = c0 + 6u + 2u * aggregates + P.n;
    var s: array<f32, 12>;
    for (var k = 0u; k < 12u; k++) { s[k] = 0.0; }
    for (var t = patch_index[starts + a] + li; t < patch_index[starts + a + 1u]; t += 64u) {
        let i = patch_index[members + t];
        let d = mode_dots(coarse_rel(i), cg[P.n + i].xyz, dim);
        for (var k = 0u; k < 12u; k++) { s[k] += d[k]; }
    }
    for (var k = 0u; k < 12u; k++) { coarse_sums[12u * li + k] = s[k]; }
    workgroupBarrier();
    for (var h = 32u; h > 0u; h >>= 1u) {
        if li < h {
            for (var k = 0u; k < 12u; k++) { coarse_sums[12u * li + k] += coarse_sums[12u * (li + h) + k]; }
        }
        workgroupBarrier();
    }
    let o = patch_index[c0 + 4u + a];
    let count = patch_index[c0 + 5u + a] - o;
    if li < count {
        let coef = coarse_values_at() + 3u * P.n + 144u * a + 12u * li;
        var g = 0.0;
        for (var k = 0u; k < patch_index[c0 + 3u]; k++) { g += patch_inverse[coef + k] * coarse_sums[k]; }
        partials[coarse_work_at() + o + li] = g;
    }
}

// u = A_c⁻¹ g, one workgroup per row (A_c⁻¹ symmetric, read along its rows)
@compute @workgroup_size(256)
fn coarse_solve(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let p = wid.x + wid.y * 65535u;
    let c0 = coarse_index_at();
    let m = patch_index[c0 + 1u];
    if p >= m { return; }
    let row = coarse_values_at() + 3u * P.n + 144u * patch_index[c0] + p * m;
    let work = coarse_work_at();
    var acc = 0.0;
    for (var q = li; q < m; q += 256u) { acc += patch_inverse[row + q] * partials[work + q]; }
    red[li] = acc;
    workgroupBarrier();
    for (var s = 128u; s > 0u; s >>= 1u) {
        if li < s { red[li] += red[li + s]; }
        workgroupBarrier();
    }
    if li == 0u { partials[work + m + p] = red[0]; }
}

// z += P u: each free particle adds its aggregate's motion Σ_k c_k m_k(rel), c_k = Σ_e u_e b_ek
@compute @workgroup_size(64)
fn coarse_prolong(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    let c0 = coarse_index_at();
    let aggregates = patch_index[c0];
    let a = patch_index[c0 + 6u + 2u * aggregates + i];
    if a == 0xffffffffu { return; }
    let dim = patch_index[c0 + 2u];
    let modes = patch_index[c0 + 3u];
    let o = patch_index[c0 + 4u + a];
    let count = patch_index[c0 + 5u + a] - o;
    let coef = coarse_values_at() + 3u * P.n + 144u * a;
    let u = coarse_work_at() + patch_index[c0 + 1u] + o;
    var c: array<f32, 12>;
    for (var k = 0u; k < 12u; k++) { c[k] = 0.0; }
    for (var e = 0u; e < count; e++) {
        let ue = partials[u + e];
        for (var k = 0u; k < modes; k++) { c[k] += ue * patch_inverse[coef + 12u * e + k]; }
    }
    let rel = coarse_rel(i);
    let dx = mode_dots(rel, vec3<f32>(1.0, 0.0, 0.0), dim);
    let dy = mode_dots(rel, vec3<f32>(0.0, 1.0, 0.0), dim);
    let dz = mode_dots(rel, vec3<f32>(0.0, 0.0, 1.0), dim);
    var z = vec3<f32>(0.0);
    for (var k = 0u; k < modes; k++) { z += c[k] * vec3<f32>(dx[k], dy[k], dz[k]); }
    cg[2u * P.n + i] = vec4<f32>(cg[2u * P.n + i].xyz + z, 0.0);
}

// p = z and the operator's first input, after the patch smoother gave the first z
@compute @workgroup_size(64)
fn cg_first_direction(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    set_direction(i, cg[2u * P.n + i].xyz);
}

// after the sums of the new r: β = rz_new / rz_old; p = z + β p; the operator's next input
@compute @workgroup_size(64)
fn cg_direction(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = idx(gid);
    if i >= P.n { return; }
    let beta = select(scalars[1] / scalars[5], 0.0, scalars[5] == 0.0);
    set_direction(i, cg[2u * P.n + i].xyz + beta * cg[3u * P.n + i].xyz);
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
