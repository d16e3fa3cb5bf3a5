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
//! `moments_collide`, `advect` (here), the boundary fill `ghost_fill`, `face_fill`,
//! `periodic_copy` (module `boundaries`), the thin walls and the face-flux record (module `walls`), and the
//! read-back kernels `probes` and `gather` (module `readback`).

use crate::fluid::Equilibrium;
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

mod boundaries;
mod readback;
mod traction;
mod walls;
pub use boundaries::{FaceCode, GHOST_ISOTHERMAL, boundaries, periodic_reach_code};
pub use readback::{TOTALS_PER_THREAD, gather_populations, probes, scatter_populations, totals};
pub use traction::{TRACTION_PRESSURE_AND_SHEAR, TRACTION_SEED_PRESSURE, traction};
pub use walls::{face_fluxes, thin_wall, thin_wall_fluxes};

// Every generated module is validated by naga in `gpu::wgsl_check`.
