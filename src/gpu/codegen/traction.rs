//! Method 1's traction on the device (seed 000 §2.4.1, 2.110–2.113; CPU twin
//! [`crate::coupling::traction::surface_forces`], laid out by
//! [`crate::coupling::traction_plan::TractionPlan`]): `pieces_force` samples the air at one and
//! two cells along each surface piece's normal — the moments of the populations at each
//! stencil node, weighted — and makes the piece's force; `spread` hands the pieces' forces to
//! their edges' particles, whose loads become the scene's own plus the air's. Nothing comes
//! back: the loads are written into the solid's load buffer.

use super::{Split, WORKGROUP, moments_code};
use crate::fluid::Equilibrium;
use std::fmt::Write;

/// `TractionModel` codes of the WGSL `TractionParams::model`.
pub const TRACTION_SEED_PRESSURE: u32 = 0;
pub const TRACTION_PRESSURE_AND_SHEAR: u32 = 1;

const DECLARATIONS: &str = r#"
struct TractionParams {
    pieces: u32, targets: u32, n_nodes: u32, model: u32,
    p0: f32, relaxation: f32, dim_factor: f32, force_unit: f32,
};
struct Piece {
    normal: vec4<f32>, tangent: vec4<f32>, wall: vec4<f32>, dvds: vec4<f32>,
    area: f32, s0: u32, s1: u32, s2: u32,
};
struct Target { base: vec4<f32>, particle: u32, first: u32, last: u32, _pad: u32 };
struct Sample { rho: f32, u: vec3<f32>, theta: f32 };
@group(0) @binding(0) var<uniform> TP: TractionParams;
@group(0) @binding(1) var<storage, read> pieces: array<Piece>;
@group(0) @binding(2) var<storage, read> stencil: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> piece_force: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> targets: array<Target>;
@group(0) @binding(5) var<storage, read> shares: array<vec2<u32>>;
@group(0) @binding(6) var<storage, read_write> load: array<vec4<f32>>;
"#;

const KERNELS: &str = r#"
// The sample Σ w_k (ρ, u, θ)_k over stencil entries first..last (node, bits of w).
fn sample_at(first: u32, last: u32) -> Sample {
    var m = Sample(0.0, vec3<f32>(0.0), 0.0);
    for (var e = first; e < last; e++) {
        let entry = stencil[e];
        let w = bitcast<f32>(entry.y);
        let mk = node_macro(entry.x);
        m.rho += w * mk.rho;
        m.theta += w * mk.theta;
        m.u += w * mk.u;
    }
    return m;
}

// One piece's force (physical units per unit depth): the wall values extrapolated from the
// samples at 1 and 2 cells, p_w = 2 p(1) − p(2) − p₀, then 2.110 (model 0) or the Newtonian
// traction −p_w N + σ'·N with the wall's velocity gradient (model 1).
@compute @workgroup_size(WG)
fn pieces_force(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = gid.x + gid.y * nwg.x * WG;
    if (k >= TP.pieces) { return; }
    let pc = pieces[k];
    if (pc.s0 == pc.s2) {
        piece_force[k] = vec4<f32>(0.0);
        return;
    }
    let m1 = sample_at(pc.s0, pc.s1);
    let m2 = sample_at(pc.s1, pc.s2);
    let n = pc.normal.xyz;
    let vw = pc.wall.xyz;
    let pw = 2.0 * (m1.rho * m1.theta) - m2.rho * m2.theta - TP.p0;
    var t: vec3<f32>;
    if (TP.model == 0u) {
        let vn = dot(m1.u - vw, n);
        t = -(pw + 0.5 * m1.rho * vn * vn) * n;
    } else {
        let tg = pc.tangent.xyz;
        let dvds = pc.dvds.xyz;
        let sampled = (4.0 * (m1.u - vw) - (m2.u - vw)) * 0.5;
        let dudn = sampled - dot(sampled, n) * n - dot(dvds, tg) * n;
        // G = [c0 c1 0] (columns), (G + Gᵀ) N − (2/D) tr G N
        let c0 = dudn * n.x + dvds * tg.x;
        let c1 = dudn * n.y + dvds * tg.y;
        let div = c0.x + c1.y;
        let mu = (2.0 * m1.rho - m2.rho) * (2.0 * m1.theta - m2.theta) * TP.relaxation;
        let gn = c0 * n.x + c1 * n.y;
        let gtn = vec3<f32>(dot(c0, n), dot(c1, n), 0.0);
        t = -pw * n + mu * (gn + gtn - TP.dim_factor * div * n);
    }
    piece_force[k] = vec4<f32>(pc.area * TP.force_unit * t, 0.0);
}

// Each loaded particle: the scene's load plus its shares of its pieces' forces (2.113); the
// added mass (w) is kept.
@compute @workgroup_size(WG)
fn spread(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let j = gid.x + gid.y * nwg.x * WG;
    if (j >= TP.targets) { return; }
    let tg = targets[j];
    var f = vec3<f32>(0.0);
    for (var e = tg.first; e < tg.last; e++) {
        let sh = shares[e];
        f += bitcast<f32>(sh.y) * piece_force[sh.x].xyz;
    }
    load[tg.particle] = vec4<f32>(tg.base.xyz + f, load[tg.particle].w);
}
"#;

/// The module of `pieces_force` and `spread` for the populations fⁿ bound from binding 10.
pub fn traction(eq: &Equilibrium, split: Split) -> String {
    let nv = eq.values_per_node();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n");
    s += DECLARATIONS;
    s += &split.declare("src", "read", 10);
    s += "\n// ρ, u, θ of a node from its populations.\nfn node_macro(node: u32) -> Sample {\n    let N = TP.n_nodes;\n";
    for v in 0..nv {
        let _ = writeln!(s, "    let f{v} = {};", split.at("src", v, "node"));
    }
    s += &moments_code(eq);
    // (`vec3(…)`, not `vec3<f32>(…)`: the diatomic gas has a population named f32)
    s += "    return Sample(rho, vec3(ux, uy, uz), theta);\n}\n";
    s += KERNELS;
    s
}
