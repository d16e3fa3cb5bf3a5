//! The MPS solid on the GPU (shaders/solid.wgsl, f32): the same stage lists as the CPU solver
//! ([`crate::stages::SOLID_EXPLICIT_STEP`], [`crate::stages::SOLID_IMPLICIT_STEP`]), each stage a
//! few dispatches of kernels whose CPU twins live in `src/solid/`. The implicit step runs
//! preconditioned CG entirely on the GPU (matrix-free products over the bond lists, dot
//! products by workgroup tree reductions) and reads back one residual every few iterations.
//!
//! Contact (shaders/solid_contact.wgsl): a uniform grid rebuilt every step by a counting sort
//! with atomics, then a gather of pair and wall contacts with anchors kept in per-particle
//! slots ([`CONTACT_SLOTS`] per particle, double-buffered).
//!
//! Positions are stored as displacements from the reference configuration, so that a bond's
//! vector r⁰ + (u_j − u_i) keeps f32's precision on the bond's length (shaders/solid.wgsl).
//!
//! Bytes per particle: state 5 × 16, rotation and Q 2 × 48, forces/torques 4 × 16, stiffness
//! 144, per bond 3 × 16 + 12.

use super::context::{GpuContext, GpuError};
use crate::solid::{Integrator, SolidSolver};
use crate::stages::SolidStageKind;
use glam::{DMat3, DQuat, DVec3};
use std::collections::HashMap;
use wgpu::util::DeviceExt;

const SHADER: &str = include_str!("../../shaders/solid.wgsl");
const CONTACT_SHADER: &str = include_str!("../../shaders/solid_contact.wgsl");

/// Contacts remembered per particle (pairs and walls).
pub const CONTACT_SLOTS: u32 = 16;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ContactUniform {
    kn: f32,
    kt: f32,
    mu_s: f32,
    mu_d: f32,
    damping: f32,
    l0: f32,
    n_walls: u32,
    multi_body: u32,
    origin: [f32; 4],
    dims: [u32; 4],
    walls: [[f32; 4]; 4],
    n: u32,
    dim: u32,
    slots: u32,
    cells: u32,
}

struct GpuContact {
    pipelines: HashMap<&'static str, wgpu::ComputePipeline>,
    /// Ping-pong of the anchor history.
    groups: [wgpu::BindGroup; 2],
    cur: usize,
    cell_count: wgpu::Buffer,
}

fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

fn m3(m: &DMat3) -> [f32; 12] {
    let c = m.to_cols_array();
    [c[0] as f32, c[1] as f32, c[2] as f32, 0.0, c[3] as f32, c[4] as f32, c[5] as f32, 0.0, c[6] as f32, c[7] as f32, c[8] as f32, 0.0]
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    n: u32,
    dim: u32,
    contact: u32,
    pad: u32,
    dt: f32,
    _p: [f32; 3],
    gravity: [f32; 4],
}

/// Buffers that can be read back.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SolidArray {
    Position,
    Velocity,
    Spin,
    Quaternion,
    Force,
    Torque,
    StressTorque,
    Q,
    Rotation,
    /// ΔV of the last implicit solve (the CG solution).
    DeltaV,
    /// Contact force of the last contact stage.
    ContactForce,
}

pub struct GpuSolid {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pub n: usize,
    pub dim: usize,
    pub integrator: Integrator,
    pub dt: f64,
    buffers: HashMap<&'static str, wgpu::Buffer>,
    pipelines: HashMap<&'static str, wgpu::ComputePipeline>,
    groups: [wgpu::BindGroup; 2],
    pub cg_tolerance: f64,
    pub cg_max_iterations: usize,
    /// Iterations and relative residual of the last CG solve.
    pub last_cg: (usize, f64),
    pub step_count: u64,
    contact: Option<GpuContact>,
    /// Reference positions X: the `pos` buffer holds the displacement u = x − X
    /// (shaders/solid.wgsl).
    reference: Vec<DVec3>,
}

const G0: [(&str, bool); 21] = [
    ("params", false),
    ("offs", true),
    ("nbr", true),
    ("rev", true),
    ("bond_r0", true),
    ("bond_shift", true),
    ("bond_grad", true),
    ("cstiff", true),
    ("pinfo", true),
    ("pos", false),
    ("vel", false),
    ("spin", false),
    ("quat", false),
    ("load", true),
    ("rot", false),
    ("qmat", false),
    ("torque_g", false),
    ("force", false),
    ("torque", false),
    ("extra_force", false),
    ("extra_torque", false),
];

const G1: [(&str, bool); 9] = [
    ("lin_x", false),
    ("lin_v", false),
    ("theta", false),
    ("jinv", false),
    ("lambda", false),
    ("cg", false),
    ("precond", true),
    ("partials", false),
    ("scalars", false),
];

const ENTRIES: [&str; 20] = [
    "rotation_matrices",
    "strain_stress_full",
    "strain_stress_linear",
    "bond_forces_full",
    "bond_forces_linear",
    "integrate_explicit",
    "solve_rotations",
    "rotation_increments",
    "chain_lambda",
    "chain_forces",
    "cg_rhs",
    "cg_apply",
    "cg_dots",
    "cg_sum",
    "cg_update",
    "cg_direction",
    "cg_keep",
    "integrate_implicit",
    "angular_velocity",
    "prepare_kv",
];

impl GpuSolid {
    /// Uploads a CPU solver's discretisation and state. The implicit method's preconditioner is
    /// taken from the CPU solver (built at the reference configuration).
    pub fn from_solver(ctx: &GpuContext, s: &mut SolidSolver) -> Result<Self, GpuError> {
        let device = ctx.device.clone();
        let n = s.particles.len();
        let pre: Vec<[f32; 12]> =
            if s.options.integrator == Integrator::Implicit { s.preconditioner().blocks().iter().map(m3).collect() } else { vec![[0f32; 12]; n] };
        let b = &s.disc.bonds;
        let nb = b.len();
        let limit = ctx.limits.max_storage_buffer_binding_size as u64;
        for (what, bytes) in [("bond arrays", 16 * nb as u64), ("stiffness array", 144 * n as u64), ("CG vectors", 112 * n as u64)] {
            if bytes > limit {
                return Err(GpuError::TooLarge { what, bytes, limit, unit: "bytes", limit_name: "max_storage_buffer_binding_size" });
            }
        }
        let storage = |label: &str, data: &[u8]| {
            let data: &[u8] = if data.is_empty() { &[0u8; 64] } else { data };
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: data,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            })
        };
        let p = &s.particles;
        let zeros4 = vec![[0f32; 4]; n];
        let zeros12 = vec![[0f32; 12]; n];
        let mut bufs: HashMap<&'static str, wgpu::Buffer> = HashMap::new();
        let params = Params { n: n as u32, dim: p.dim as u32, contact: 0, pad: 0, dt: s.dt as f32, _p: [0.0; 3], gravity: v4(s.options.gravity, 0.0) };
        bufs.insert(
            "params",
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("solid params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            }),
        );
        bufs.insert("offs", storage("offs", bytemuck::cast_slice(&b.offset)));
        bufs.insert("nbr", storage("nbr", bytemuck::cast_slice(&b.neighbour)));
        bufs.insert("rev", storage("rev", bytemuck::cast_slice(&b.reverse)));
        let r0: Vec<[f32; 4]> = (0..nb).map(|k| v4(b.r0[k], b.w_hat[k])).collect();
        let sh: Vec<[f32; 4]> = (0..nb).map(|k| v4(b.shift[k], b.stiffness[k])).collect();
        let gr: Vec<[f32; 4]> = (0..nb).map(|k| v4(b.grad[k], b.damping[k])).collect();
        bufs.insert("bond_r0", storage("bond_r0", bytemuck::cast_slice(&r0)));
        bufs.insert("bond_shift", storage("bond_shift", bytemuck::cast_slice(&sh)));
        bufs.insert("bond_grad", storage("bond_grad", bytemuck::cast_slice(&gr)));
        let cs: Vec<f32> = s.disc.grad_stiffness.iter().flat_map(|c| c.iter().flat_map(|row| row.iter().map(|x| *x as f32))).collect();
        bufs.insert("cstiff", storage("cstiff", bytemuck::cast_slice(&cs)));
        let info: Vec<[f32; 4]> = (0..n).map(|i| [p.mass[i] as f32, p.inertia[i] as f32, p.volume[i] as f32, if p.fixed[i] { 1.0 } else { 0.0 }]).collect();
        bufs.insert("pinfo", storage("pinfo", bytemuck::cast_slice(&info)));
        for name in ["pos", "vel", "spin", "quat", "load", "torque_g", "force", "torque", "extra_force", "extra_torque"] {
            bufs.insert(name, storage(name, bytemuck::cast_slice(&zeros4)));
        }
        for name in ["rot", "qmat"] {
            bufs.insert(name, storage(name, bytemuck::cast_slice(&zeros12)));
        }
        for name in ["lin_x", "lin_v", "lambda"] {
            bufs.insert(name, storage(name, bytemuck::cast_slice(&zeros4)));
        }
        bufs.insert("theta", storage("theta", bytemuck::cast_slice(&vec![[0f32; 4]; 2 * n])));
        bufs.insert("cg", storage("cg", bytemuck::cast_slice(&vec![[0f32; 4]; 7 * n])));
        bufs.insert("jinv", storage("jinv", bytemuck::cast_slice(&zeros12)));
        bufs.insert("precond", storage("precond", bytemuck::cast_slice(&pre)));
        bufs.insert("partials", storage("partials", bytemuck::cast_slice(&vec![0f32; 4 * n.div_ceil(256) + 4])));
        bufs.insert("scalars", storage("scalars", bytemuck::cast_slice(&[0f32; 8])));

        let layout_of = |g: &[(&str, bool)]| {
            let kinds: Vec<(bool, bool)> = g.iter().map(|(name, ro)| (*name == "params", *ro)).collect();
            super::context::buffer_layout(&device, "solid", &kinds)
        };
        let l0 = layout_of(&G0);
        let l1 = layout_of(&G1);
        let group = |layout: &wgpu::BindGroupLayout, g: &[(&str, bool)]| {
            let entries: Vec<wgpu::BindGroupEntry> =
                g.iter().enumerate().map(|(k, (name, _))| wgpu::BindGroupEntry { binding: k as u32, resource: bufs[name].as_entire_binding() }).collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("solid"), layout, entries: &entries })
        };
        let groups = [group(&l0, &G0), group(&l1, &G1)];
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("solid"),
            bind_group_layouts: &[Some(&l0), Some(&l1)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("solid.wgsl"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let pipelines = super::context::compute_pipelines(&device, &module, &pl, &ENTRIES);
        let mut g = Self {
            device,
            queue: ctx.queue.clone(),
            n,
            dim: p.dim,
            integrator: s.options.integrator,
            dt: s.dt,
            buffers: bufs,
            pipelines,
            groups,
            // f32 cannot reach the CPU default (1e-8); the run layer sets the scene's value
            cg_tolerance: 1e-5,
            cg_max_iterations: s.options.cg_max_iterations,
            last_cg: (0, 0.0),
            step_count: 0,
            contact: None,
            reference: p.reference.clone(),
        };
        if let Some(cp) = &s.options.contact {
            if s.options.walls.len() > 4 {
                return Err(GpuError::Device(format!("the GPU contact kernel takes at most 4 walls, the scene has {}", s.options.walls.len())));
            }
            g.contact = Some(g.build_contact(s, cp));
        }
        g.upload_state(s);
        Ok(g)
    }

    fn build_contact(&self, s: &SolidSolver, cp: &crate::solid::ContactParams) -> GpuContact {
        let device = &self.device;
        let p = &s.particles;
        let n = p.len();
        let l0 = p.spacing;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for x in &p.reference {
            lo = lo.min(*x);
            hi = hi.max(*x);
        }
        // the grid covers the bodies' box grown by its size on every side (beyond: edge cells)
        let ext = (hi - lo).max(DVec3::splat(2.0 * l0));
        let origin = lo - ext;
        let mut dims = [1u32; 3];
        for a in 0..p.dim {
            dims[a] = ((3.0 * ext[a]) / l0).ceil() as u32 + 1;
        }
        let cells = dims[0] * dims[1] * dims[2];
        let mut walls = [[0f32; 4]; 4];
        for (k, w) in s.options.walls.iter().enumerate() {
            walls[k] = v4(w.normal, w.offset);
        }
        let uni = ContactUniform {
            kn: cp.normal_stiffness as f32,
            kt: cp.tangential_stiffness as f32,
            mu_s: cp.static_friction as f32,
            mu_d: cp.dynamic_friction as f32,
            damping: cp.damping as f32,
            l0: l0 as f32,
            n_walls: s.options.walls.len() as u32,
            multi_body: p.body.iter().any(|&b| b != p.body[0]) as u32,
            origin: v4(origin, 0.0),
            dims: [dims[0], dims[1], dims[2], 0],
            walls,
            n: n as u32,
            dim: p.dim as u32,
            slots: CONTACT_SLOTS,
            cells,
        };
        let init = |label: &str, data: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: data, usage })
        };
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
        let uniform = init("contact uniform", bytemuck::bytes_of(&uni), wgpu::BufferUsages::UNIFORM);
        let body: Vec<u32> = p.body.iter().map(|&b| b as u32).collect();
        let body = init("body", bytemuck::cast_slice(&body), st);
        let cell_of = init("cell_of", bytemuck::cast_slice(&vec![0u32; n]), st);
        let cell_count = init("cell_count", bytemuck::cast_slice(&vec![0u32; cells as usize]), st);
        let cell_start = init("cell_start", bytemuck::cast_slice(&vec![0u32; cells as usize + 1]), st);
        let sorted = init("sorted", bytemuck::cast_slice(&vec![0u32; n]), st);
        let empty: Vec<[f32; 4]> = (0..2 * n * CONTACT_SLOTS as usize).map(|_| [0.0, 0.0, 0.0, f32::from_bits(u32::MAX)]).collect();
        let hist = [init("hist a", bytemuck::cast_slice(&empty), st), init("hist b", bytemuck::cast_slice(&empty), st)];
        // (uniform?, read-only?) per binding of shaders/solid_contact.wgsl
        let kinds: [(bool, bool); 15] = [
            (true, true),
            (false, true),
            (false, true),
            (false, true),
            (false, true),
            (false, true),
            (false, false),
            (false, false),
            (false, false),
            (false, false),
            (false, false),
            (false, false),
            (false, true),
            (false, false),
            (false, true),
        ];
        let layout = super::context::buffer_layout(device, "contact", &kinds);
        let reference: Vec<[f32; 4]> = p.reference.iter().map(|x| v4(*x, 0.0)).collect();
        let reference = init("reference positions", bytemuck::cast_slice(&reference), st);
        let b = &self.buffers;
        let group = |inp: &wgpu::Buffer, out: &wgpu::Buffer| {
            let res = [
                &uniform,
                &b["pos"],
                &b["vel"],
                &b["rot"],
                &b["pinfo"],
                &body,
                &b["extra_force"],
                &b["extra_torque"],
                &cell_of,
                &cell_count,
                &cell_start,
                &sorted,
                inp,
                out,
                &reference,
            ];
            let entries: Vec<wgpu::BindGroupEntry> =
                res.iter().enumerate().map(|(k, buf)| wgpu::BindGroupEntry { binding: k as u32, resource: buf.as_entire_binding() }).collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("contact"), layout: &layout, entries: &entries })
        };
        let groups = [group(&hist[0], &hist[1]), group(&hist[1], &hist[0])];
        let pl =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("contact"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let module = device
            .create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("solid_contact.wgsl"), source: wgpu::ShaderSource::Wgsl(CONTACT_SHADER.into()) });
        let pipelines = super::context::compute_pipelines(device, &module, &pl, &["grid_count", "grid_scan", "grid_scatter", "contact_forces"]);
        GpuContact { pipelines, groups, cur: 0, cell_count }
    }

    /// Records the contact stage (grid rebuild and contact forces) into `enc`.
    fn record_contact(&mut self, enc: &mut wgpu::CommandEncoder) {
        let n = self.n as u32;
        let Some(c) = self.contact.as_mut() else { return };
        let w = n.div_ceil(64).max(1);
        let (wx, wy) = if w <= 65_535 { (w, 1) } else { (65_535, w.div_ceil(65_535)) };
        let run = |enc: &mut wgpu::CommandEncoder, c: &GpuContact, entries: &[&str]| {
            let mut pass = enc.begin_compute_pass(&Default::default());
            for e in entries {
                pass.set_pipeline(&c.pipelines[e]);
                pass.set_bind_group(0, &c.groups[c.cur], &[]);
                if *e == "grid_scan" { pass.dispatch_workgroups(1, 1, 1) } else { pass.dispatch_workgroups(wx, wy, 1) }
            }
        };
        enc.clear_buffer(&c.cell_count, 0, None);
        run(enc, c, &["grid_count", "grid_scan"]);
        enc.clear_buffer(&c.cell_count, 0, None);
        run(enc, c, &["grid_scatter", "contact_forces"]);
        c.cur = 1 - c.cur;
    }

    /// Writes positions, velocities, spins, quaternions, loads (+ added mass) and rotation
    /// matrices of a CPU solver.
    pub fn upload_state(&mut self, s: &SolidSolver) {
        let p = &s.particles;
        let w = |name: &str, data: Vec<[f32; 4]>| self.queue.write_buffer(&self.buffers[name], 0, bytemuck::cast_slice(&data));
        w("pos", p.position.iter().zip(&self.reference).map(|(x, r)| v4(*x - *r, 0.0)).collect());
        w("vel", p.velocity.iter().map(|x| v4(*x, 0.0)).collect());
        w("spin", p.spin.iter().map(|x| v4(*x, 0.0)).collect());
        w("quat", p.rotation.iter().map(|q| [q.x as f32, q.y as f32, q.z as f32, q.w as f32]).collect());
        w("load", (0..p.len()).map(|i| v4(p.load[i], p.added_mass[i])).collect());
        let rot: Vec<[f32; 12]> = s.rotations().iter().map(m3).collect();
        self.queue.write_buffer(&self.buffers["rot"], 0, bytemuck::cast_slice(&rot));
        self.step_count = s.step_count;
    }

    /// Writes the particles' loads (+ added mass) of a CPU solver: the air's forces of a
    /// coupled step ([`super::coupled::GpuCoupled`]).
    pub fn upload_loads(&self, s: &SolidSolver) {
        let p = &s.particles;
        let loads: Vec<[f32; 4]> = (0..p.len()).map(|i| v4(p.load[i], p.added_mass[i])).collect();
        self.queue.write_buffer(&self.buffers["load"], 0, bytemuck::cast_slice(&loads));
    }

    fn dispatch(&self, pass: &mut wgpu::ComputePass, entry: &str) {
        pass.set_pipeline(&self.pipelines[entry]);
        pass.set_bind_group(0, &self.groups[0], &[]);
        pass.set_bind_group(1, &self.groups[1], &[]);
        match entry {
            "cg_dots" => pass.dispatch_workgroups((self.n as u32).div_ceil(256).max(1), 1, 1),
            "cg_sum" | "cg_keep" => pass.dispatch_workgroups(1, 1, 1),
            _ => {
                let w = (self.n as u32).div_ceil(64).max(1);
                if w <= 65_535 { pass.dispatch_workgroups(w, 1, 1) } else { pass.dispatch_workgroups(65_535, w.div_ceil(65_535), 1) }
            }
        }
    }

    fn submit(&self, entries: &[&str]) {
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            for e in entries {
                self.dispatch(&mut pass, e);
            }
        }
        self.queue.submit([enc.finish()]);
    }

    /// The linear operator K p + D q of the implicit method with the rotations following the
    /// increments (reads lin_x / lin_v, writes `force`).
    const LINEAR: [&'static str; 5] = ["strain_stress_linear", "rotation_increments", "bond_forces_linear", "chain_lambda", "chain_forces"];

    /// Runs one stage of the step (the kernels of that stage, one submission).
    pub fn run_stage(&mut self, kind: SolidStageKind) {
        let implicit = self.integrator == Integrator::Implicit;
        match kind {
            SolidStageKind::Rotations => {
                if implicit {
                    self.submit(&["solve_rotations", "angular_velocity"])
                } else {
                    self.submit(&["rotation_matrices"])
                }
            }
            SolidStageKind::StrainStress => self.submit(&["strain_stress_full"]),
            SolidStageKind::BondForces => {
                if implicit {
                    self.submit(&["bond_forces_full", "chain_lambda", "chain_forces"])
                } else {
                    self.submit(&["bond_forces_full"])
                }
            }
            SolidStageKind::Contact => {
                let mut enc = self.device.create_command_encoder(&Default::default());
                self.record_contact(&mut enc);
                self.queue.submit([enc.finish()]);
            }
            SolidStageKind::ConjugateGradient => self.conjugate_gradient(),
            SolidStageKind::Integrate => self.submit(&[if implicit { "integrate_implicit" } else { "integrate_explicit" }]),
        }
    }

    fn conjugate_gradient(&mut self) {
        // internal force of the state → cg[6n..7n); K v → force; then B, r, z, p
        let mut enc = self.device.create_command_encoder(&Default::default());
        let bytes = self.buffers["force"].size();
        enc.copy_buffer_to_buffer(&self.buffers["force"], 0, &self.buffers["cg"], 6 * bytes, bytes);
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            self.dispatch(&mut pass, "prepare_kv");
            for e in Self::LINEAR {
                self.dispatch(&mut pass, e);
            }
            self.dispatch(&mut pass, "cg_rhs");
        }
        self.queue.submit([enc.finish()]);
        let mut it = 0;
        let mut rel = f64::INFINITY;
        let check_every = 8;
        while it < self.cg_max_iterations {
            let mut enc = self.device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                for _ in 0..check_every {
                    for e in Self::LINEAR {
                        self.dispatch(&mut pass, e);
                    }
                    for e in ["cg_apply", "cg_dots", "cg_sum", "cg_keep", "cg_update", "cg_dots", "cg_sum", "cg_direction"] {
                        self.dispatch(&mut pass, e);
                    }
                }
            }
            self.queue.submit([enc.finish()]);
            it += check_every;
            let sc = self.read_f32("scalars");
            rel = (sc[2] as f64).max(0.0).sqrt() / (sc[3] as f64).sqrt().max(1e-300);
            if sc[3] == 0.0 {
                rel = 0.0;
            }
            if rel <= self.cg_tolerance || !rel.is_finite() {
                break;
            }
        }
        self.last_cg = (it, rel);
    }

    /// One whole step, stage by stage in the order of the solid's stage list.
    pub fn step(&mut self) {
        let list = match self.integrator {
            Integrator::Explicit => &crate::stages::SOLID_EXPLICIT_STEP[..],
            Integrator::Implicit => &crate::stages::SOLID_IMPLICIT_STEP[..],
        };
        for st in list {
            self.run_stage(st.kind);
        }
        self.step_count += 1;
    }

    /// Runs `n` explicit steps with one submission per 32 steps (implicit: step by step).
    pub fn run(&mut self, n: u64) {
        if self.integrator == Integrator::Implicit {
            for _ in 0..n {
                self.step();
            }
            return;
        }
        let mut done = 0;
        while done < n {
            let batch = (n - done).min(32);
            let mut enc = self.device.create_command_encoder(&Default::default());
            for _ in 0..batch {
                {
                    let mut pass = enc.begin_compute_pass(&Default::default());
                    for e in ["rotation_matrices", "strain_stress_full", "bond_forces_full"] {
                        self.dispatch(&mut pass, e);
                    }
                }
                self.record_contact(&mut enc);
                let mut pass = enc.begin_compute_pass(&Default::default());
                self.dispatch(&mut pass, "integrate_explicit");
            }
            self.queue.submit([enc.finish()]);
            done += batch;
            self.step_count += batch;
        }
    }

    pub fn wait(&self) {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }

    fn read_f32(&self, name: &str) -> Vec<f32> {
        bytemuck::cast_slice(&super::context::read_buffer(&self.device, &self.queue, &self.buffers[name])).to_vec()
    }

    /// A per-particle vector array as f64.
    pub fn download_vectors(&self, which: SolidArray) -> Vec<DVec3> {
        let name = match which {
            SolidArray::Position => "pos",
            SolidArray::Velocity => "vel",
            SolidArray::Spin => "spin",
            SolidArray::Force => "force",
            SolidArray::Torque => "torque",
            SolidArray::StressTorque => "torque_g",
            SolidArray::DeltaV => "cg",
            SolidArray::ContactForce => "extra_force",
            _ => panic!("{which:?} is not a vector array"),
        };
        let raw = self.read_f32(name);
        let v = raw.chunks(4).take(self.n).map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64));
        match which {
            // the buffer holds the displacement from the reference position
            SolidArray::Position => v.zip(&self.reference).map(|(u, x)| *x + u).collect(),
            _ => v.collect(),
        }
    }

    /// A per-particle matrix array (Q or the rotation matrices) as f64.
    pub fn download_matrices(&self, which: SolidArray) -> Vec<DMat3> {
        let name = match which {
            SolidArray::Q => "qmat",
            SolidArray::Rotation => "rot",
            _ => panic!("{which:?} is not a matrix array"),
        };
        self.read_f32(name)
            .chunks(12)
            .take(self.n)
            .map(|c| {
                DMat3::from_cols(
                    DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64),
                    DVec3::new(c[4] as f64, c[5] as f64, c[6] as f64),
                    DVec3::new(c[8] as f64, c[9] as f64, c[10] as f64),
                )
            })
            .collect()
    }

    /// Copies the GPU state (positions, velocities, spins, quaternions) into a CPU solver.
    pub fn download_into(&self, s: &mut SolidSolver) {
        s.particles.position = self.download_vectors(SolidArray::Position);
        s.particles.velocity = self.download_vectors(SolidArray::Velocity);
        s.particles.spin = self.download_vectors(SolidArray::Spin);
        s.particles.rotation =
            self.read_f32("quat").chunks(4).take(self.n).map(|c| DQuat::from_xyzw(c[0] as f64, c[1] as f64, c[2] as f64, c[3] as f64)).collect();
        s.step_count = self.step_count;
        s.time = self.step_count as f64 * self.dt;
    }
}

/// Particle updates per second of the GPU solid on the benchmark block of
/// [`crate::solid::bench::benchmark_block`]; `bandwidth` is the device's copy bandwidth (B/s).
pub fn solid_speed(ctx: &GpuContext, side: usize, integrator: Integrator, steps: u64, bandwidth: f64) -> Result<crate::solid::bench::SolidSpeed, GpuError> {
    let t0 = std::time::Instant::now();
    let mut s = crate::solid::bench::benchmark_block(side, integrator);
    let mut g = GpuSolid::from_solver(ctx, &mut s)?;
    let setup = t0.elapsed().as_secs_f64();
    g.run(1);
    g.wait();
    let t = std::time::Instant::now();
    let mut iters = 0;
    for _ in 0..(if integrator == Integrator::Implicit { steps } else { 1 }) {
        g.run(if integrator == Integrator::Implicit { 1 } else { steps });
        iters += g.last_cg.0;
    }
    g.wait();
    let wall = t.elapsed().as_secs_f64();
    Ok(crate::solid::bench::speed_of(false, &s, steps, wall, iters, setup, Vec::new(), bandwidth))
}

#[cfg(test)]
mod mirror_tests {
    use super::{CONTACT_SHADER, ContactUniform, Params, SHADER};
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    #[test]
    fn params_and_contact_uniform_match_the_shader_layout() {
        check_mirror("solid.wgsl", SHADER, "Params", mirror!(Params { n, dim, contact, pad, dt, _p, gravity }));
        check_mirror(
            "solid_contact.wgsl",
            CONTACT_SHADER,
            "ContactUniform",
            mirror!(ContactUniform { kn, kt, mu_s, mu_d, damping, l0, n_walls, multi_body, origin, dims, walls, n, dim, slots, cells }),
        );
    }
}
