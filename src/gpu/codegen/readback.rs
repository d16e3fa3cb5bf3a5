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
/// brings back only those ([`super::fdlb::GpuFluid::download_nodes_into`]).
pub fn gather_populations(eq: &Equilibrium, split: Split) -> String {
    let nv = eq.values_per_node();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n");
    s += r#"
struct GatherParams { count: u32, n_nodes: u32, _p0: u32, _p1: u32 };
@group(0) @binding(0) var<uniform> GP: GatherParams;
@group(0) @binding(1) var<storage, read> nodes: array<u32>;
@group(0) @binding(2) var<storage, read_write> out: array<f32>;
"#;
    s += &split.declare("src", "read", 10);
    s += "@compute @workgroup_size(WG)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {\n";
    s += "    let k = gid.x + gid.y * nwg.x * WG;\n    if (k >= GP.count) { return; }\n    let node = nodes[k];\n    let N = GP.n_nodes;\n";
    let _ = writeln!(s, "    let b = k * {nv}u;");
    for v in 0..nv {
        let _ = writeln!(s, "    out[b + {v}u] = {};", split.at("src", v, "node"));
    }
    s += "}\n";
    s
}

/// The `scatter` kernel, the inverse of [`gather_populations`]: the populations of a list of
/// nodes, packed node after node (`vals[k · nv + v]` = value v of `nodes[k]`), written into the
/// state array, so that a CPU stage that changes a few nodes (the nodes a moving body uncovers)
/// sends up only those ([`super::fdlb::GpuFluid::upload_nodes_from`]).
pub fn scatter_populations(eq: &Equilibrium, split: Split) -> String {
    let nv = eq.values_per_node();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n");
    s += r#"
struct GatherParams { count: u32, n_nodes: u32, _p0: u32, _p1: u32 };
@group(0) @binding(0) var<uniform> GP: GatherParams;
@group(0) @binding(1) var<storage, read> nodes: array<u32>;
@group(0) @binding(2) var<storage, read> vals: array<f32>;
"#;
    s += &split.declare("dst", "read_write", 10);
    s += "@compute @workgroup_size(WG)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {\n";
    s += "    let k = gid.x + gid.y * nwg.x * WG;\n    if (k >= GP.count) { return; }\n    let node = nodes[k];\n    let N = GP.n_nodes;\n";
    let _ = writeln!(s, "    let b = k * {nv}u;");
    for v in 0..nv {
        let _ = writeln!(s, "    {} = vals[b + {v}u];", split.at("dst", v, "node"));
    }
    s += "}\n";
    s
}
