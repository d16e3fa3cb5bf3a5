//! Generator of the FDLB compute kernels (WGSL) from one description of the velocity set
//! ([`crate::fluid::Equilibrium`]): every loop over velocities is unrolled and every lattice
//! constant (c_i, shell of i, stencil taps) is written into the code, so no kernel indexes a
//! `const` array at run time (naga + lavapipe copy such arrays per access, DESIGN §7).
//!
//! GPU memory layout: structure of arrays, value v of padded node `node` at `v·N + node`
//! (N = padded node count rounded up to a multiple of 64); macro fields ρ, u_x, u_y, u_z, θ at
//! `k·N + node`. f32 throughout. When a population array exceeds the adapter's storage-binding
//! limit, it is bound as several ranges of `per_binding` populations ([`Split`]): population v
//! is element `(v mod per_binding)·N + node` of binding `v / per_binding` of that array.
//! The kernels are the GPU twins of the CPU stages ([`crate::stages::FDLB_STEP`]):
//! `moments_collide`, `advect`, and the boundary fill `ghost_fill`, `face_fill`, `periodic_copy`.

use crate::fluid::Equilibrium;
use crate::fluid::layout::HaloReach;
use crate::fluid::upwind::stencils;
use std::fmt::Write;

/// Threads per workgroup of every kernel.
pub const WORKGROUP: u32 = 64;

/// How the NV populations of one array are spread over storage bindings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Split {
    pub nv: usize,
    /// Populations per binding.
    pub per_binding: usize,
}

impl Split {
    /// Everything in one binding.
    pub fn whole(nv: usize) -> Self {
        Split { nv, per_binding: nv }
    }
    pub fn groups(&self) -> usize {
        self.nv.div_ceil(self.per_binding)
    }
    /// Populations in binding `g`.
    pub fn len(&self, g: usize) -> usize {
        self.per_binding.min(self.nv - g * self.per_binding)
    }
    /// `array{g}[{r}u * N + {index}]` for population v.
    fn at(&self, array: &str, v: usize, index: &str) -> String {
        format!("{array}{}[{}u * N + {index}]", v / self.per_binding, v % self.per_binding)
    }
    /// Declarations of the bindings of `array`, from binding number `first`.
    fn declare(&self, array: &str, access: &str, first: u32) -> String {
        (0..self.groups()).map(|g| format!("@group(0) @binding({}) var<storage, {access}> {array}{g}: array<f32>;\n", first + g as u32)).collect()
    }
}

const PARAMS: &str = r#"
struct Params {
    n_nodes: u32, px: u32, py: u32, pz: u32,
    nx: u32, ny: u32, nz: u32, hx: u32,
    hy: u32, hz: u32, count: u32, stage: u32,
    dt: f32, tau: f32, a: f32, window_lo: f32,
    window_hi: f32, gx: f32, gy: f32, gz: f32,
};
@group(0) @binding(0) var<uniform> P: Params;

// Linear thread index of a 2D dispatch (rows of 65535 workgroups at most).
fn thread_index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * WG;
}

// Padded node of interior item i (x fastest).
fn interior_node(i: u32) -> u32 {
    let x = i % P.nx;
    let y = (i / P.nx) % P.ny;
    let z = i / (P.nx * P.ny);
    return (x + P.hx) + P.px * ((y + P.hy) + P.py * (z + P.hz));
}
"#;

fn f(x: f64) -> String {
    // WGSL abstract-float literal that round-trips to the nearest f32.
    let v = x as f32;
    if v == 0.0 { "0.0".into() } else { format!("{v:e}") }
}

/// Shared helpers: shell weights W(θ), one equilibrium function per value v.
fn equilibrium_functions(eq: &Equilibrium) -> String {
    let mut s = String::new();
    let shells = &eq.set.shells;
    let _ = writeln!(s, "struct W {{ {} }};", (0..shells.len()).map(|k| format!("w{k}: f32")).collect::<Vec<_>>().join(", "));
    let _ = writeln!(s, "fn shell_weights(t: f32) -> W {{");
    let _ = writeln!(s, "    var w: W;");
    for (k, sh) in shells.iter().enumerate() {
        let [a0, a1, a2, a3] = sh.poly;
        let _ = writeln!(s, "    w.w{k} = {} + t * ({} + t * ({} + t * {}));", f(a0), f(a1), f(a2), f(a3));
    }
    let _ = writeln!(s, "    return w;\n}}");
    // Equilibrium (2.78): fe = w ρ [b + ξ (b + ξ (1/2 + ξ/6))], ξ = c·u/θ, b = 1 − u²/(2θ).
    let q = eq.q();
    for v in 0..eq.values_per_node() {
        let i = if v < q { v } else { v - q };
        let c = eq.set.c[i];
        let mut xi = Vec::new();
        for (a, comp) in ["ux", "uy", "uz"].iter().enumerate() {
            match c[a] {
                0 => {}
                1 => xi.push(comp.to_string()),
                -1 => xi.push(format!("-{comp}")),
                k => xi.push(format!("{k}.0 * {comp}")),
            }
        }
        let xi = if xi.is_empty() { "0.0".to_string() } else { xi.join(" + ") };
        let rot = if v >= q { format!(" * {} * theta", f(eq.rot_half)) } else { String::new() };
        let _ = writeln!(
            s,
            "fn feq{v}(w: W, rho: f32, ux: f32, uy: f32, uz: f32, inv: f32, b: f32, theta: f32) -> f32 {{ let xi = ({xi}) * inv; return w.w{} * rho * (b + xi * (b + xi * (0.5 + xi * (1.0 / 6.0)))){rot}; }}",
            eq.set.shell_of[i]
        );
    }
    s
}

/// Code computing ρ, u, θ from values `f0 … f{nv−1}` already loaded into locals.
fn moments_code(eq: &Equilibrium) -> String {
    let q = eq.q();
    let mut s = String::new();
    let sum = |w: &dyn Fn(usize) -> Option<String>| -> String {
        let terms: Vec<String> = (0..q).filter_map(w).collect();
        if terms.is_empty() { "0.0".into() } else { terms.join(" + ") }
    };
    let _ = writeln!(s, "    let rho = {};", sum(&|i| Some(format!("f{i}"))));
    for (a, name) in ["jx", "jy", "jz"].iter().enumerate() {
        let e = sum(&|i| match eq.set.c[i][a] {
            0 => None,
            1 => Some(format!("f{i}")),
            -1 => Some(format!("-f{i}")),
            k => Some(format!("{k}.0 * f{i}")),
        });
        let _ = writeln!(s, "    let {name} = {e};");
    }
    let mut en: Vec<String> = (0..q).filter(|&i| eq.half_c2[i] != 0.0).map(|i| format!("{} * f{i}", f(eq.half_c2[i]))).collect();
    en.extend((q..eq.values_per_node()).map(|v| format!("f{v}")));
    let _ = writeln!(s, "    let en = {};", en.join(" + "));
    let _ = writeln!(s, "    let irho = 1.0 / rho;");
    let _ = writeln!(s, "    let ux = jx * irho; let uy = jy * irho; let uz = jz * irho;");
    let _ = writeln!(s, "    let u2 = ux * ux + uy * uy + uz * uz;");
    let _ = writeln!(s, "    let theta = (en * irho - 0.5 * u2) / {};", f(eq.energy_dof_half));
    s
}

/// `moments_collide`: moments, instability check, h, and the local part of the RK stage.
pub fn moments_collide(eq: &Equilibrium, split: Split) -> String {
    let g = split.groups() as u32;
    let nv = eq.values_per_node();
    let q = eq.q();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n{PARAMS}\n");
    s += r#"
@group(0) @binding(1) var<storage, read> kind: array<u32>;
@group(0) @binding(2) var<storage, read_write> mac: array<f32>;
@group(0) @binding(3) var<storage, read_write> status: array<atomic<u32>, 2>;
"#;
    s += &split.declare("src", "read", 10);
    s += &split.declare("base", "read", 10 + g);
    s += &split.declare("h", "read_write", 10 + 2 * g);
    s += &split.declare("dst", "read_write", 10 + 3 * g);
    s += &equilibrium_functions(eq);
    s += "@compute @workgroup_size(WG)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {\n";
    s += "    let i = thread_index(gid, nwg);\n    if (i >= P.nx * P.ny * P.nz) { return; }\n    let node = interior_node(i);\n    if (kind[node] != 0u) { return; }\n    let N = P.n_nodes;\n";
    for v in 0..nv {
        let _ = writeln!(s, "    let f{v} = {};", split.at("src", v, "node"));
    }
    s += &moments_code(eq);
    s += r#"    // Instability: the lowest failing node index wins (status[0]); status[1] says what.
    var code = 0u;
    if (!(rho > 0.0) || rho != rho) { code = 1u; }
    else if (u2 != u2) { code = 2u; }
    else if (!(theta > P.window_lo && theta < P.window_hi)) { code = 3u; }
    if (code != 0u) {
        let prev = atomicMin(&status[0], node);
        if (node < prev) { atomicStore(&status[1], code); }
        return;
    }
    let w = shell_weights(theta);
    let inv = 1.0 / theta;
    let b = 1.0 - 0.5 * u2 * inv;
    let kf = 1.0 - P.a / P.tau;
    let keq = P.a / P.tau;
    let dt_tau = P.dt / P.tau;
    let gu = P.gx * ux + P.gy * uy + P.gz * uz;
    let second = P.stage == 2u;
"#;
    for v in 0..nv {
        let i = if v < q { v } else { v - q };
        let c = eq.set.c[i];
        let gc = format!("(P.gx * {}.0 + P.gy * {}.0 + P.gz * {}.0)", c[0], c[1], c[2]);
        let _ = writeln!(s, "    {{ let fe = feq{v}(w, rho, ux, uy, uz, inv, b, theta);");
        let _ = writeln!(s, "      {} = kf * f{v} + keq * fe;", split.at("h", v, "node"));
        let _ = writeln!(s, "      let local = f{v} - dt_tau * (f{v} - fe) + P.dt * fe * ({gc} - gu) * inv;");
        let (d, b) = (split.at("dst", v, "node"), split.at("base", v, "node"));
        let _ = writeln!(s, "      if (second) {{ {d} = 0.5 * ({b} + local); }} else {{ {d} = local; }} }}");
    }
    s += "    mac[node] = rho; mac[N + node] = ux; mac[2u * N + node] = uy; mac[3u * N + node] = uz; mac[4u * N + node] = theta;\n}\n";
    s
}

/// `advect`: dst −= k Δt c·∇h with the unrolled 3rd-order upwind stencil of every velocity.
pub fn advect(eq: &Equilibrium, split: Split) -> String {
    let g = split.groups() as u32;
    let nv = eq.values_per_node();
    let q = eq.q();
    let st = stencils(&eq.set.c);
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n{PARAMS}\n");
    s += r#"
@group(0) @binding(1) var<storage, read> kind: array<u32>;
"#;
    s += &split.declare("h", "read", 10);
    s += &split.declare("dst", "read_write", 10 + g);
    s += r#"
@compute @workgroup_size(WG)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = thread_index(gid, nwg);
    if (i >= P.nx * P.ny * P.nz) { return; }
    let node = interior_node(i);
    if (kind[node] != 0u) { return; }
    let N = P.n_nodes;
    let sy = i32(P.px);
    let sz = i32(P.px * P.py);
    let k = select(1.0, 0.5, P.stage == 2u) * P.dt;
"#;
    for v in 0..nv {
        let i = if v < q { v } else { v - q };
        let stc = &st[i];
        let (grp, r) = (v / split.per_binding, v % split.per_binding);
        let _ = write!(s, "    {{ let c = i32({r}u * N + node); let adv = {} * h{grp}[c]", f(stc.centre));
        for (d, coef) in &stc.taps {
            let off = match (d[0], d[1], d[2]) {
                (dx, 0, 0) => format!("{dx}"),
                (0, dy, 0) => format!("{dy} * sy"),
                (0, 0, dz) => format!("{dz} * sz"),
                _ => unreachable!("axis-wise stencil"),
            };
            let _ = write!(s, " + {} * h{grp}[c + {off}]", f(*coef));
        }
        let _ = writeln!(s, ";\n      dst{grp}[c] = dst{grp}[c] - k * adv; }}");
    }
    s += "}\n";
    s
}

/// The WGSL factor |c_a|/6 of a thin tap (`tp`) for a velocity c, zero unless the tap's axis is
/// one of c's and its sign is c's there; `None` for the rest velocity (no tap applies).
fn thin_tap_factor(c: [i32; 3]) -> Option<String> {
    let terms: Vec<String> = (0..3)
        .filter(|&a| c[a] != 0)
        .map(|a| format!("select(0.0, {}, tp.axis == {a}u && tp.sign == {})", f(c[a].unsigned_abs() as f64 / 6.0), c[a].signum()))
        .collect();
    (!terms.is_empty()).then(|| terms.join(" + "))
}

/// The one-sided stencils next to thin walls ([`crate::fluid::thin_wall`]), applied after the
/// advection: one thread per fluid node that has any, walking its taps (so no two threads write
/// the same value). Each tap carries the correction weights w − w_full on (0, +s, −s, −2s) and
/// the step to the +s neighbour; value v is corrected when its velocity component along the
/// tap's axis has the tap's sign: dst −= k·|c_a|/6·Σ w·h.
pub fn thin_wall(eq: &Equilibrium, split: Split) -> String {
    let g = split.groups() as u32;
    let nv = eq.values_per_node();
    let q = eq.q();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n{PARAMS}\n");
    s += r#"
struct ThinTap { node: u32, axis: u32, sign: i32, step: i32, w: vec4<f32>, };
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
        let _ = writeln!(
            s,
            "        {{ let m = {m}; if (m != 0.0) {{ let c = i32({r}u * N + tp.node); let corr = tp.w.x * h{grp}[c] + tp.w.y * h{grp}[c + st] + tp.w.z * h{grp}[c - st] + tp.w.w * h{grp}[c - 2 * st]; dst{grp}[c] = dst{grp}[c] - k * m * corr; }} }}"
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
    // fluid nodes and periodic copies are no wall (the stencils read copies as fluid)
    if (k == 0u || k == 3u) { return; }
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
/// stage). A one-sided stencil changes a fluid node by −½Δt·|c_a|/6·Σ w·h, which is no face flux;
/// the wall next to it takes the opposite, as in the CPU twin. One thread per such wall node
/// (`targets`: node, first, count), walking its taps (`order` into `taps`), so no atomics.
pub fn thin_wall_fluxes(eq: &Equilibrium, split: Split) -> String {
    let q = eq.q();
    let mut s = format!("const WG: u32 = {WORKGROUP}u;\n{PARAMS}\n");
    s += r#"
struct ThinTap { node: u32, axis: u32, sign: i32, step: i32, w: vec4<f32>, };
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
    if (i >= arrayLength(&targets)) { return; }
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
        let _ = writeln!(
            s,
            "        {{ let m = {m}; if (m != 0.0) {{ let corr = tp.w.x * {} + tp.w.y * {} + tp.w.z * {} + tp.w.w * {}; acc += (w * m * corr) * vec4<f32>({}.0, {}.0, {}.0, 1.0); }} }}",
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
/// into the WGSL by [`face_codes_wgsl`]: a ghost's code says whether its wall is isothermal; a
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

// Every generated module is validated by naga in `gpu::wgsl_check`.
