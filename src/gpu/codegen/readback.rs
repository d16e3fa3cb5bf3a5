//! The kernels of a list of nodes: their macroscopic state (`probes`) and their populations
//! (`gather`), so that a reader of a few nodes brings back only those, and the way back
//! (`scatter`), so that a writer of a few nodes sends up only those.

use super::{Split, WORKGROUP, moments_code};
use crate::fluid::Equilibrium;
use std::fmt::Write;

/// `probes`: the macroscopic state of listed nodes of the state array, with the step index, in
/// one small buffer for readback: `out[0]` = step, `out[1 + 5k + j]` = bits of (ρ, u_x, u_y,
/// u_z, θ)_j of probe k.
pub fn probes(eq: &Equilibrium, split: Split) -> String {
    let nv = eq.values_per_node();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n");
    s += r#"
struct ProbeParams { step: u32, count: u32, n_nodes: u32, _pad: u32 };
@group(0) @binding(0) var<uniform> PP: ProbeParams;
@group(0) @binding(1) var<storage, read> nodes: array<u32>;
@group(0) @binding(2) var<storage, read_write> out: array<u32>;
"#;
    s += &split.declare("src", "read", 10);
    s += "@compute @workgroup_size(WG)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {\n";
    s += "    let k = gid.x + gid.y * nwg.x * WG;\n    if (k == 0u) { out[0] = PP.step; }\n    if (k >= PP.count) { return; }\n    let node = nodes[k];\n    let N = PP.n_nodes;\n";
    for v in 0..nv {
        let _ = writeln!(s, "    let f{v} = {};", split.at("src", v, "node"));
    }
    s += &moments_code(eq);
    s += "    let b = 1u + 5u * k;\n    out[b] = bitcast<u32>(rho); out[b + 1u] = bitcast<u32>(ux); out[b + 2u] = bitcast<u32>(uy); out[b + 3u] = bitcast<u32>(uz); out[b + 4u] = bitcast<u32>(theta);\n}\n";
    s
}

/// The `gather` kernel: the populations of a list of nodes, node after node (`out[k · nv + v]`
/// = value v of `nodes[k]`), so that a CPU stage reading a few nodes (method 1's traction)
/// brings back only those ([`crate::gpu::GpuFluid::download_nodes_into`]).
pub fn gather_populations(eq: &Equilibrium, split: Split) -> String {
    node_list(eq, split, false)
}

/// The `scatter` kernel, the inverse of [`gather_populations`]: the populations of a list of
/// nodes, packed node after node (`vals[k · nv + v]` = value v of `nodes[k]`), written into the
/// state array, so that a CPU stage that changes a few nodes (the nodes a moving body uncovers)
/// sends up only those ([`crate::gpu::GpuFluid::upload_nodes_from`]).
pub fn scatter_populations(eq: &Equilibrium, split: Split) -> String {
    node_list(eq, split, true)
}

/// A node-list kernel: gather (state → packed `vals`) or `scatter` (packed `vals` → state).
fn node_list(eq: &Equilibrium, split: Split, scatter: bool) -> String {
    let nv = eq.values_per_node();
    let (vals, state) = if scatter { ("read", "read_write") } else { ("read_write", "read") };
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n");
    s += &format!(
        "
struct GatherParams {{ count: u32, n_nodes: u32, _p0: u32, _p1: u32 }};
@group(0) @binding(0) var<uniform> GP: GatherParams;
@group(0) @binding(1) var<storage, read> nodes: array<u32>;
@group(0) @binding(2) var<storage, {vals}> vals: array<f32>;
"
    );
    s += &split.declare("state", state, 10);
    s += "@compute @workgroup_size(WG)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {\n";
    s += "    let k = gid.x + gid.y * nwg.x * WG;\n    if (k >= GP.count) { return; }\n    let node = nodes[k];\n    let N = GP.n_nodes;\n";
    let _ = writeln!(s, "    let b = k * {nv}u;");
    for v in 0..nv {
        let at = split.at("state", v, "node");
        let _ = if scatter { writeln!(s, "    {at} = vals[b + {v}u];") } else { writeln!(s, "    vals[b + {v}u] = {at};") };
    }
    s += "}\n";
    s
}

/// Nodes each thread of the `totals` kernel sums before the workgroup's tree reduction: a
/// workgroup covers `WORKGROUP × TOTALS_PER_THREAD` = 1024 nodes, 20 bytes come back for them.
pub const TOTALS_PER_THREAD: u32 = 16;

/// The `totals` kernel: the fluid's mass Σ f_i, momentum Σ f_i c_i and energy Σ f_i c_i²/2 + Σ g
/// over the fluid nodes (kind 0), as [`crate::fluid::FluidSolver::totals`] sums them, reduced on
/// the device to one partial sum per workgroup (`out[5 g + j]`, j = mass, j_x, j_y, j_z,
/// energy; f32), which the CPU adds in f64 — so that a reader of the totals (the coupled run's
/// csv) does not bring the lattice back.
pub fn totals(eq: &Equilibrium, split: Split) -> String {
    let nv = eq.values_per_node();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\nconst PER_THREAD: u32 = {TOTALS_PER_THREAD}u;\n");
    s += r#"
struct TotalsParams { n_nodes: u32, groups: u32, _p0: u32, _p1: u32 };
@group(0) @binding(0) var<uniform> TP: TotalsParams;
@group(0) @binding(1) var<storage, read> kind: array<u32>;
@group(0) @binding(2) var<storage, read_write> out: array<f32>;
var<workgroup> s_m: array<f32, WG>;
var<workgroup> s_x: array<f32, WG>;
var<workgroup> s_y: array<f32, WG>;
var<workgroup> s_z: array<f32, WG>;
var<workgroup> s_e: array<f32, WG>;
"#;
    s += &split.declare("src", "read", 10);
    s += "@compute @workgroup_size(WG)\nfn main(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {\n";
    s += "    let g = wid.x + wid.y * nwg.x;\n    let N = TP.n_nodes;\n";
    s += "    var m = 0.0; var px = 0.0; var py = 0.0; var pz = 0.0; var e = 0.0;\n";
    s += "    if (g < TP.groups) {\n        for (var j = 0u; j < PER_THREAD; j++) {\n            let node = (g * PER_THREAD + j) * WG + lid;\n            if (node < N && kind[node] == 0u) {\n";
    for v in 0..nv {
        let _ = writeln!(s, "    let f{v} = {};", split.at("src", v, "node"));
    }
    s += &moments_code(eq);
    s += "                m += rho; px += jx; py += jy; pz += jz; e += en;\n            }\n        }\n    }\n";
    s += r#"    s_m[lid] = m; s_x[lid] = px; s_y[lid] = py; s_z[lid] = pz; s_e[lid] = e;
    workgroupBarrier();
    for (var w = WG / 2u; w > 0u; w = w / 2u) {
        if (lid < w) {
            s_m[lid] += s_m[lid + w]; s_x[lid] += s_x[lid + w]; s_y[lid] += s_y[lid + w];
            s_z[lid] += s_z[lid + w]; s_e[lid] += s_e[lid + w];
        }
        workgroupBarrier();
    }
    if (lid == 0u && g < TP.groups) {
        out[5u * g] = s_m[0]; out[5u * g + 1u] = s_x[0]; out[5u * g + 2u] = s_y[0];
        out[5u * g + 3u] = s_z[0]; out[5u * g + 4u] = s_e[0];
    }
}
"#;
    s
}
