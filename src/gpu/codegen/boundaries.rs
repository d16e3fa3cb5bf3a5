//! The boundary fill kernels (`ghost_fill`, `face_fill`, `periodic_copy`) and the codes of
//! their entries, shared with the tables built in [`crate::gpu::fdlb`].

use super::{PARAMS, Split, WORKGROUP, equilibrium_functions};
use crate::fluid::Equilibrium;
use crate::fluid::layout::HaloReach;
use std::fmt::Write;

/// Boundary fill kernels (`ghost_fill`, `face_fill`, `periodic_copy`) in one module.
pub fn boundaries(eq: &Equilibrium, split: Split) -> String {
    let g = split.groups() as u32;
    let nv = eq.values_per_node();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n{PARAMS}\n");
    s += r#"
struct Entry {
    node: u32, source: u32, code: u32, n_img: u32,
    rho: f32, theta: f32, ux: f32, uy: f32,
    uz: f32, ratio: f32, _p0: f32, _p1: f32,
};
@group(0) @binding(1) var<storage, read> entries: array<Entry>;
@group(0) @binding(2) var<storage, read> images: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> mac: array<f32>;
"#;
    s += &split.declare("fv", "read_write", 10);
    s += &split.declare("h", "read_write", 10 + g);
    s += &equilibrium_functions(eq);
    // set_node: f = fe + n, h = fe + (1 − A/τ) n, macro fields.
    let _ = writeln!(s, "fn set_node(node: u32, rho: f32, ux: f32, uy: f32, uz: f32, theta: f32, n: array<f32, {nv}>) {{");
    s += "    let N = P.n_nodes;\n    let w = shell_weights(theta);\n    let inv = 1.0 / theta;\n    let b = 1.0 - 0.5 * (ux * ux + uy * uy + uz * uz) * inv;\n    let kf = 1.0 - P.a / P.tau;\n";
    for v in 0..nv {
        let (fa, ha) = (split.at("fv", v, "node"), split.at("h", v, "node"));
        let _ = writeln!(s, "    {{ let fe = feq{v}(w, rho, ux, uy, uz, inv, b, theta); {fa} = fe + n[{v}]; {ha} = fe + kf * n[{v}]; }}");
    }
    s += "    mac[node] = rho; mac[N + node] = ux; mac[2u * N + node] = uy; mac[3u * N + node] = uz; mac[4u * N + node] = theta;\n}\n";
    // neq_add: n += wgt (f − fe) of node k.
    let _ = writeln!(s, "fn neq_of(k: u32) -> array<f32, {nv}> {{");
    s +=
        "    let N = P.n_nodes;\n    let rho = mac[k]; let ux = mac[N + k]; let uy = mac[2u * N + k]; let uz = mac[3u * N + k]; let theta = mac[4u * N + k];\n";
    s += "    let w = shell_weights(theta);\n    let inv = 1.0 / theta;\n    let b = 1.0 - 0.5 * (ux * ux + uy * uy + uz * uz) * inv;\n";
    let _ = writeln!(s, "    var n: array<f32, {nv}>;");
    for v in 0..nv {
        let _ = writeln!(s, "    n[{v}] = {} - feq{v}(w, rho, ux, uy, uz, inv, b, theta);", split.at("fv", v, "k"));
    }
    s += "    return n;\n}\n";
    // copy_node: every value of node s onto node d (loops over each binding's populations).
    s += "fn copy_node(s: u32, d: u32) {\n    let N = P.n_nodes;\n";
    for grp in 0..split.groups() {
        let _ = writeln!(
            s,
            "    for (var v = 0u; v < {}u; v = v + 1u) {{ fv{grp}[v * N + d] = fv{grp}[v * N + s]; h{grp}[v * N + d] = h{grp}[v * N + s]; }}",
            split.len(grp)
        );
    }
    s += "    for (var k = 0u; k < 5u; k = k + 1u) { mac[k * N + d] = mac[k * N + s]; }\n}\n";
    // mirror_node: the mirror image of node s across a plane normal to `axis` onto node d (a
    // slip face; fluid::boundary::mirror_node): values permuted, u[axis] negated.
    s += "fn mirror_node(s: u32, d: u32, axis: u32) {\n    let N = P.n_nodes;\n";
    for axis in 0..eq.set.dim {
        let perm = eq.mirror_permutation(axis);
        let _ = writeln!(s, "    if (axis == {axis}u) {{");
        for (v, &p) in perm.iter().enumerate() {
            let _ = writeln!(s, "        {} = {};", split.at("fv", v, "d"), split.at("fv", p, "s"));
            let _ = writeln!(s, "        {} = {};", split.at("h", v, "d"), split.at("h", p, "s"));
        }
        s += "    }\n";
    }
    s += "    for (var k = 0u; k < 5u; k = k + 1u) { mac[k * N + d] = mac[k * N + s]; }\n";
    s += "    mac[(1u + axis) * N + d] = -mac[(1u + axis) * N + s];\n}\n";
    s += &face_codes_wgsl();
    s += r#"
// Ghost nodes: image-point state extrapolated through the wall (see fluid::boundary).
@compute @workgroup_size(WG)
fn ghost_fill(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = thread_index(gid, nwg);
    if (t >= P.count) { return; }
    let e = entries[t];
    let N = P.n_nodes;
    var m = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
"#;
    let _ = writeln!(s, "    var n: array<f32, {nv}>;");
    s += r#"    for (var j = 0u; j < e.n_img; j = j + 1u) {
        let im = images[t * 8u + j];
        let k = im.x;
        let wk = bitcast<f32>(im.y);
        m[0] += wk * mac[k]; m[1] += wk * mac[N + k]; m[2] += wk * mac[2u * N + k]; m[3] += wk * mac[3u * N + k]; m[4] += wk * mac[4u * N + k];
        let nk = neq_of(k);
"#;
    for v in 0..nv {
        let _ = writeln!(s, "        n[{v}] += wk * nk[{v}];");
    }
    s += r#"    }
    let r = e.ratio;
    let ux = e.ux + r * (m[1] - e.ux);
    let uy = e.uy + r * (m[2] - e.uy);
    let uz = e.uz + r * (m[3] - e.uz);
    var theta = m[4];
    if (e.code == GHOST_ISOTHERMAL) { theta = e.theta + r * (m[4] - e.theta); }
    set_node(e.node, m[0] * m[4] / theta, ux, uy, uz, theta, n);
}

// Inlet / outlet / slip halos: FACE_OUTLET (copy), FACE_PRESSURE_INLET, FACE_VELOCITY_INLET,
// FACE_SLIP + axis (mirror image).
@compute @workgroup_size(WG)
fn face_fill(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = thread_index(gid, nwg);
    if (t >= P.count) { return; }
    let e = entries[t];
    let N = P.n_nodes;
    let s = e.source;
    if (e.code == FACE_OUTLET) {
        copy_node(s, e.node);
        return;
    }
    if (e.code >= FACE_SLIP) {
        mirror_node(s, e.node, e.code - FACE_SLIP);
        return;
    }
    let n = neq_of(s);
    if (e.code == FACE_PRESSURE_INLET) {
        set_node(e.node, e.rho, mac[N + s], mac[2u * N + s], mac[3u * N + s], e.theta, n);
    } else {
        set_node(e.node, mac[s], e.ux, e.uy, e.uz, e.theta, n);
    }
}

// Periodic halos: (destination, source, reach code of fluid::layout::HaloReach, 0); only the
// values of h that the advection reads at the destination are copied (periodic_reach_code).
@group(0) @binding(4) var<storage, read> periodic_pairs: array<vec4<u32>>;
@compute @workgroup_size(WG)
fn periodic_copy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = thread_index(gid, nwg);
    if (t >= P.count) { return; }
    let e = periodic_pairs[t];
    let d = e.x;
    let s = e.y;
    let N = P.n_nodes;
    switch e.z {
"#;
    for axis in 0..eq.set.dim {
        for depth in [-2i8, -1, 1, 2] {
            let reach = HaloReach::Axis { axis, depth };
            let _ = writeln!(s, "        case {}u: {{", periodic_reach_code(reach));
            for &v in eq.values_read_at(reach) {
                let _ = writeln!(s, "            {} = {};", split.at("h", v, "d"), split.at("h", v, "s"));
            }
            s += "        }\n";
        }
    }
    s += "        default: {}\n    }\n}\n";
    s
}

/// The code of a periodic halo node's [`HaloReach`] in the `periodic_copy` kernel's table:
/// 0 for a node no stencil reads (left out of the table), else 1 + [`HaloReach::index`].
pub fn periodic_reach_code(reach: HaloReach) -> u32 {
    reach.index().map_or(0, |k| 1 + k as u32)
}

/// The codes of the boundary kernels' entries (`Entry.code`), defined once here and written
/// into the WGSL by `face_codes_wgsl`: a ghost's code says whether its wall is isothermal; a
/// face halo's says its condition (a slip face adds its axis to [`FaceCode::Slip`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum FaceCode {
    Outlet = 0,
    PressureInlet = 1,
    VelocityInlet = 2,
    Slip = 3,
}

/// `Entry.code` of a ghost node whose wall holds its temperature (else 0: adiabatic).
pub const GHOST_ISOTHERMAL: u32 = 1;

fn face_codes_wgsl() -> String {
    format!(
        "const FACE_OUTLET: u32 = {}u;\nconst FACE_PRESSURE_INLET: u32 = {}u;\nconst FACE_VELOCITY_INLET: u32 = {}u;\nconst FACE_SLIP: u32 = {}u;\nconst GHOST_ISOTHERMAL: u32 = {}u;\n",
        FaceCode::Outlet as u32,
        FaceCode::PressureInlet as u32,
        FaceCode::VelocityInlet as u32,
        FaceCode::Slip as u32,
        GHOST_ISOTHERMAL
    )
}
