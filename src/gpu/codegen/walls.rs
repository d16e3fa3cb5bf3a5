//! The thin-wall kernels: the stencils next to thin walls with their side ghosts (`thin_wall`) and the
//! face-flux record of the momentum exchange (`face_fluxes`, `thin_wall_fluxes`).

use super::{PARAMS, Split, WORKGROUP, f};
use crate::fluid::Equilibrium;
use std::fmt::Write;

/// The WGSL factor |c_a|/6 of a thin tap (`tp`) for a velocity c, zero unless the tap's axis is
/// one of c's and its sign is c's there; `None` for the rest velocity (no tap applies).
fn thin_tap_factor(c: [i32; 3]) -> Option<String> {
    let terms: Vec<String> = (0..3)
        .filter(|&a| c[a] != 0)
        .map(|a| format!("select(0.0, {}, tp.axis == {a}u && tp.sign == {})", f(c[a].unsigned_abs() as f64 / 6.0), c[a].signum()))
        .collect();
    (!terms.is_empty()).then(|| terms.join(" + "))
}

/// The side ghosts' part of a thin tap's correction (`tp`), FULL[tap] · h(side node) for the
/// taps +s, −s, −2s that have one: `h(idx)` indexes value v's array at node `idx`. The index is
/// clamped into the array where a tap has none (the select discards that read).
fn side_terms(h: impl Fn(&str) -> String) -> String {
    [("x", "2.0"), ("y", "-6.0"), ("z", "1.0")]
        .iter()
        .map(|(c, w)| format!(" + select(0.0, {w} * {}, tp.side.{c} != 0xffffffffu)", h(&format!("min(tp.side.{c}, N - 1u)"))))
        .collect()
}

/// The stencils next to thin walls ([`crate::fluid::thin_wall`]), applied after the
/// advection: one thread per fluid node that has any, walking its taps (so no two threads write
/// the same value). Each tap carries the correction weights w − w_full on (0, +s, −s, −2s), the
/// step to the +s neighbour and the nodes of its side ghosts (past the lattice); value v is
/// corrected when its velocity component along the tap's axis has the tap's sign:
/// dst −= k·|c_a|/6·(Σ w·h + Σ w_full·h_side).
pub fn thin_wall(eq: &Equilibrium, split: Split) -> String {
    let g = split.groups() as u32;
    let nv = eq.values_per_node();
    let q = eq.q();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n{PARAMS}\n");
    s += r#"
struct ThinTap { node: u32, axis: u32, sign: i32, step: i32, w: vec4<f32>, side: vec4<u32>, };
@group(0) @binding(1) var<storage, read> taps: array<ThinTap>;
@group(0) @binding(2) var<storage, read> ranges: array<vec2<u32>>;
"#;
    s += &split.declare("h", "read", 10);
    s += &split.declare("dst", "read_write", 10 + g);
    s += r#"
@compute @workgroup_size(WG)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = thread_index(gid, nwg);
    if (i >= P.count) { return; }
    let range = ranges[i];
    let N = P.n_nodes;
    let k = select(1.0, 0.5, P.stage == 2u) * P.dt;
    for (var t = range.x; t < range.x + range.y; t = t + 1u) {
        let tp = taps[t];
        let st = tp.step;
"#;
    for v in 0..nv {
        let i = if v < q { v } else { v - q };
        let c = eq.set.c[i];
        let (grp, r) = (v / split.per_binding, v % split.per_binding);
        let Some(m) = thin_tap_factor(c) else { continue };
        let sides = side_terms(|idx| format!("h{grp}[{r}u * N + {idx}]"));
        let _ = writeln!(
            s,
            "        {{ let m = {m}; if (m != 0.0) {{ let c = i32({r}u * N + tp.node); let corr = tp.w.x * h{grp}[c] + tp.w.y * h{grp}[c + st] + tp.w.z * h{grp}[c - st] + tp.w.w * h{grp}[c - 2 * st]{sides}; dst{grp}[c] = dst{grp}[c] - k * m * corr; }} }}"
        );
    }
    s += "    }\n}\n";
    s
}

/// `face_fluxes`: the momentum (xyz) and mass (w) each wall node takes out of the air through
/// its faces with fluid nodes in the advection stage just run, times ½Δt (both Heun stages), added
/// to `wall` — the GPU twin of [`crate::coupling::momentum_exchange::add_face_fluxes`] (its
/// thin-wall part is [`thin_wall_fluxes`]), as a gather: one thread per wall node (not fluid, not a periodic copy), which
/// visits, per velocity i and axis a with s = sign(c_ia)·stride_a, the fluid node n − s whose
/// downstream face it is (flux F = [2h(n) + 5h(n−s) − h(n−2s)]/6 leaves the air) and the fluid
/// node n + s whose upstream face it is (F = [2h(n+s) + 5h(n) − h(n−s)]/6 enters it), each
/// counted against the reference state's `reference[i]`. No two threads write one node, so no
/// atomics; the order of the sums differs from the CPU's (a scatter from the fluid nodes).
pub fn face_fluxes(eq: &Equilibrium, split: Split) -> String {
    let q = eq.q();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n{PARAMS}\n");
    s += r#"
@group(0) @binding(1) var<storage, read> kind: array<u32>;
@group(0) @binding(2) var<storage, read> reference: array<f32>;
@group(0) @binding(3) var<storage, read_write> wall: array<vec4<f32>>;
"#;
    s += &split.declare("h", "read", 10);
    s += r#"
fn is_fluid(m: i32) -> bool {
    return m >= 0 && u32(m) < P.n_nodes && kind[u32(m)] == 0u;
}

@compute @workgroup_size(WG)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = thread_index(gid, nwg);
    if (i >= P.n_nodes) { return; }
    let k = kind[i];
    // fluid nodes and periodic copies are no wall (the stencils read copies as fluid); the
    // side ghosts past the lattice are none either
    if (k == 0u || k == 3u || i >= P.px * P.py * P.pz) { return; }
    let N = P.n_nodes;
    let n = i32(i);
    let sy = i32(P.px);
    let sz = i32(P.px * P.py);
    let w = 0.5 * P.dt;
    var acc = vec4<f32>(0.0);
"#;
    for (v, c) in eq.set.c.iter().enumerate().take(q) {
        let (grp, r) = (v / split.per_binding, v % split.per_binding);
        let h = |idx: &str| format!("h{grp}[{r}u * N + u32({idx})]");
        let cv = format!("vec4<f32>({}.0, {}.0, {}.0, 1.0)", c[0], c[1], c[2]);
        for a in 0..3 {
            if c[a] == 0 {
                continue;
            }
            let stride = ["1", "sy", "sz"][a];
            let step = if c[a] > 0 { stride.to_string() } else { format!("-{stride}") };
            let m = f(c[a].unsigned_abs() as f64);
            let _ = writeln!(
                s,
                "    {{ let st = {step}; let cv = {m} * w * {cv}; let rv = reference[{v}u];\n      if (is_fluid(n - st)) {{ acc += (({} * 2.0 + {} * 5.0 - {}) / 6.0 - rv) * cv; }}\n      if (is_fluid(n + st)) {{ acc -= (({} * 2.0 + {} * 5.0 - {}) / 6.0 - rv) * cv; }} }}",
                h("n"),
                h("n - st"),
                h("n - 2 * st"),
                h("n + st"),
                h("n"),
                h("n - st"),
            );
        }
    }
    s += "    wall[i] += acc;\n}\n";
    s
}

/// `thin_wall_fluxes`: the thin-wall part of the face-flux record (after `face_fluxes`, same
/// stage). A thin-wall stencil changes a fluid node by −½Δt·|c_a|/6·(Σ w·h + Σ w_full·h_side), which is no face flux;
/// the wall next to it takes the opposite, as in the CPU twin. One thread per such wall node
/// (`targets`: node, first, count; the first `P.count` of them), walking its taps (`order`
/// into `taps`), so no atomics.
pub fn thin_wall_fluxes(eq: &Equilibrium, split: Split) -> String {
    let q = eq.q();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n{PARAMS}\n");
    s += r#"
struct ThinTap { node: u32, axis: u32, sign: i32, step: i32, w: vec4<f32>, side: vec4<u32>, };
@group(0) @binding(1) var<storage, read> taps: array<ThinTap>;
@group(0) @binding(2) var<storage, read> order: array<u32>;
@group(0) @binding(3) var<storage, read> targets: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read_write> wall: array<vec4<f32>>;
"#;
    s += &split.declare("h", "read", 10);
    s += r#"
@compute @workgroup_size(WG)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = thread_index(gid, nwg);
    if (i >= P.count) { return; }
    let tg = targets[i];
    if (tg.z == 0u) { return; }
    let N = P.n_nodes;
    let w = 0.5 * P.dt;
    var acc = vec4<f32>(0.0);
    for (var t = tg.y; t < tg.y + tg.z; t = t + 1u) {
        let tp = taps[order[t]];
        let st = tp.step;
        let c0 = i32(tp.node);
"#;
    for (v, &c) in eq.set.c.iter().enumerate().take(q) {
        let (grp, r) = (v / split.per_binding, v % split.per_binding);
        let Some(m) = thin_tap_factor(c) else { continue };
        let h = |off: &str| format!("h{grp}[{r}u * N + u32(c0{off})]");
        let sides = side_terms(|idx| format!("h{grp}[{r}u * N + {idx}]"));
        let _ = writeln!(
            s,
            "        {{ let m = {m}; if (m != 0.0) {{ let corr = tp.w.x * {} + tp.w.y * {} + tp.w.z * {} + tp.w.w * {}{sides}; acc += (w * m * corr) * vec4<f32>({}.0, {}.0, {}.0, 1.0); }} }}",
            h(""),
            h(" + st"),
            h(" - st"),
            h(" - 2 * st"),
            c[0],
            c[1],
            c[2]
        );
    }
    s += "    }\n    wall[tg.x] += acc;\n}\n";
    s
}
