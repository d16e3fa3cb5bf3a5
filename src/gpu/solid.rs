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
use crate::solid::{Integrator, Preconditioner, SolidSolver};
use crate::stages::SolidStageKind;
use glam::{DMat3, DQuat, DVec3};

mod bindings;
mod contact;
mod solve;
mod upload;

pub use contact::CONTACT_SLOTS;
use contact::GpuContact;
pub use solve::PATCH_MAX_PARTICLES;

use bindings::{Buf, Buffers, Kernel, Pipelines};

/// shaders/solid.wgsl (state, forces, explicit step) and shaders/solid_implicit.wgsl (the
/// implicit method), one module.
pub(crate) const SHADER: &str = concat!(include_str!("../../shaders/solid.wgsl"), include_str!("../../shaders/solid_implicit.wgsl"));

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
    /// The particles' loads (scene's and air's; the added mass beside them left out).
    Load,
}

pub struct GpuSolid {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pub n: usize,
    pub dim: usize,
    pub integrator: Integrator,
    pub dt: f64,
    buffers: Buffers,
    pipelines: Pipelines,
    groups: [wgpu::BindGroup; 2],
    pub cg_tolerance: f64,
    pub cg_max_iterations: usize,
    /// Iterations and relative residual of the last CG solve.
    pub last_cg: (usize, f64),
    /// Every CG solve on the device so far (as the CPU solver's).
    pub cg_tally: crate::solid::implicit::CgTally,
    /// What smooths in the implicit solve's preconditioner here: the CPU options' patches
    /// ([`crate::solid::patch_jacobi`]) or block Jacobi — chosen by the options, or when the
    /// patches do not fit (`preconditioner_note` says why); the CPU's coarse space is added
    /// where the device holds it ([`Self::coarse_unknowns`], `coarse_note`).
    pub preconditioner: Preconditioner,
    pub preconditioner_note: Option<String>,
    /// Patches of the patch smoother (0 with block Jacobi).
    patch_count: u32,
    /// The coarse space's aggregates and unknowns on the device (0 without one:
    /// `coarse_note` says why).
    coarse_aggregates: u32,
    coarse_unknowns: u32,
    pub coarse_note: Option<String>,
    pub step_count: u64,
    contact: Option<GpuContact>,
    /// Reference positions X: the `pos` buffer holds the displacement u = x − X
    /// (shaders/solid.wgsl).
    reference: Vec<DVec3>,
    /// The staging buffer of the coupled step's reads of the particles, kept between reads.
    readback: super::growing::Readback,
}

impl GpuSolid {
    /// Uploads a CPU solver's discretisation and state. The implicit method's preconditioner is
    /// taken from the CPU solver (built at the reference configuration).
    pub fn from_solver(ctx: &GpuContext, s: &mut SolidSolver) -> Result<Self, GpuError> {
        let device = ctx.device.clone();
        let limit = ctx.limits.max_storage_buffer_binding_size;
        // refused before the device's preconditioner arrays are made
        upload::check_sizes(s, limit)?;
        let blocks = upload::prepare_preconditioner(s);
        // the rest reads the solver only: the inverses go up from the solver's own array
        let s = &*s;
        let pre = upload::DevicePreconditioner::of(s, blocks, limit);
        let buffers = upload::create_buffers(ctx, s, &pre);
        let (groups, pipelines) = upload::bind_and_compile(&device, &buffers);
        let p = &s.particles;
        let mut g = Self {
            device,
            queue: ctx.queue.clone(),
            n: p.len(),
            dim: p.dim,
            integrator: s.options.integrator,
            dt: s.dt,
            buffers,
            pipelines,
            groups,
            // f32 cannot reach the CPU default (1e-8); the run layer sets the scene's value
            cg_tolerance: 1e-5,
            cg_max_iterations: s.options.cg_max_iterations,
            last_cg: (0, 0.0),
            cg_tally: Default::default(),
            preconditioner: pre.smoother,
            patch_count: pre.patches.patches(),
            coarse_aggregates: pre.coarse.as_ref().map_or(0, |c| c.aggregates),
            coarse_unknowns: pre.coarse.as_ref().map_or(0, |c| c.unknowns),
            preconditioner_note: pre.note,
            coarse_note: pre.coarse_note,
            step_count: 0,
            contact: None,
            reference: p.reference.clone(),
            readback: Default::default(),
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

    /// The coarse space's unknowns on the device (0: the smoother alone, `coarse_note` says why).
    pub fn coarse_unknowns(&self) -> usize {
        self.coarse_unknowns as usize
    }

    /// Writes positions, velocities, spins, quaternions, loads (+ added mass) and rotation
    /// matrices of a CPU solver.
    pub fn upload_state(&mut self, s: &SolidSolver) {
        let p = &s.particles;
        self.write_kinematics(p, 0..p.len());
        self.upload_loads(s);
        let rot: Vec<[f32; 12]> = s.rotations().iter().map(m3).collect();
        self.queue.write_buffer(&self.buffers[Buf::Rot], 0, bytemuck::cast_slice(&rot));
        self.step_count = s.step_count;
    }

    /// Writes position, velocity, spin and orientation of the particles `indices` (ascending) of
    /// a CPU solver, one write per run of consecutive indices: the bodies whose motion is
    /// prescribed ([`super::coupled::GpuCoupled`]), without touching the others.
    pub fn upload_kinematics(&self, s: &SolidSolver, indices: &[usize]) {
        for run in indices.chunk_by(|a, b| *b == a + 1) {
            self.write_kinematics(&s.particles, run[0]..run[run.len() - 1] + 1);
        }
    }

    /// Position (as the displacement from the reference), velocity, spin and orientation of the
    /// particles `run`, f32, written at their place in the device's arrays.
    fn write_kinematics(&self, p: &crate::solid::Particles, run: std::ops::Range<usize>) {
        let offset = 16 * run.start as u64;
        let w = |buf: Buf, data: Vec<[f32; 4]>| self.queue.write_buffer(&self.buffers[buf], offset, bytemuck::cast_slice(&data));
        w(Buf::Pos, run.clone().map(|i| v4(p.position[i] - self.reference[i], 0.0)).collect());
        w(Buf::Vel, run.clone().map(|i| v4(p.velocity[i], 0.0)).collect());
        w(Buf::Spin, run.clone().map(|i| v4(p.spin[i], 0.0)).collect());
        w(Buf::Quat, run.map(|i| p.rotation[i]).map(|q| [q.x as f32, q.y as f32, q.z as f32, q.w as f32]).collect());
    }

    /// Writes the particles' loads (+ added mass) of a CPU solver: the air's forces of a
    /// coupled step ([`super::coupled::GpuCoupled`]).
    /// The particles' loads on the device (`[f32; 4]` per particle: load, added mass), which
    /// a coupling kernel may write in place ([`super::GpuFluid::surface_traction`]).
    pub fn load_buffer(&self) -> &wgpu::Buffer {
        &self.buffers[Buf::Load]
    }

    pub fn upload_loads(&self, s: &SolidSolver) {
        let p = &s.particles;
        let loads: Vec<[f32; 4]> = (0..p.len()).map(|i| v4(p.load[i], p.added_mass[i])).collect();
        self.queue.write_buffer(&self.buffers[Buf::Load], 0, bytemuck::cast_slice(&loads));
    }

    fn dispatch(&self, pass: &mut wgpu::ComputePass, kernel: Kernel) {
        pass.set_pipeline(&self.pipelines[kernel]);
        pass.set_bind_group(0, &self.groups[0], &[]);
        pass.set_bind_group(1, &self.groups[1], &[]);
        match kernel {
            Kernel::CgPatches => {
                let w = self.patch_count.max(1);
                if w <= 65_535 { pass.dispatch_workgroups(w, 1, 1) } else { pass.dispatch_workgroups(65_535, w.div_ceil(65_535), 1) }
            }
            Kernel::CoarseRestrict | Kernel::CoarseSolve => {
                let w = if kernel == Kernel::CoarseRestrict { self.coarse_aggregates } else { self.coarse_unknowns }.max(1);
                if w <= 65_535 { pass.dispatch_workgroups(w, 1, 1) } else { pass.dispatch_workgroups(65_535, w.div_ceil(65_535), 1) }
            }
            Kernel::CgDots => pass.dispatch_workgroups((self.n as u32).div_ceil(256).max(1), 1, 1),
            Kernel::CgSum | Kernel::CgKeep => pass.dispatch_workgroups(1, 1, 1),
            _ => {
                let w = (self.n as u32).div_ceil(64).max(1);
                if w <= 65_535 { pass.dispatch_workgroups(w, 1, 1) } else { pass.dispatch_workgroups(65_535, w.div_ceil(65_535), 1) }
            }
        }
    }

    fn submit(&self, kernels: &[Kernel]) {
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            for k in kernels {
                self.dispatch(&mut pass, *k);
            }
        }
        self.queue.submit([enc.finish()]);
    }

    /// The linear operator K p + D q of the implicit method with the rotations following the
    /// increments (reads lin_x / lin_v, writes `force`).
    const LINEAR: [Kernel; 5] = [Kernel::StrainStressLinear, Kernel::RotationIncrements, Kernel::BondForcesLinear, Kernel::ChainLambda, Kernel::ChainForces];

    /// Runs one stage of the step (the kernels of that stage, one submission).
    pub fn run_stage(&mut self, kind: SolidStageKind) {
        let implicit = self.integrator == Integrator::Implicit;
        match kind {
            SolidStageKind::Rotations => {
                if implicit {
                    self.submit(&[Kernel::SolveRotations, Kernel::AngularVelocity])
                } else {
                    self.submit(&[Kernel::RotationMatrices])
                }
            }
            SolidStageKind::StrainStress => self.submit(&[Kernel::StrainStressFull]),
            SolidStageKind::BondForces => {
                if implicit {
                    self.submit(&[Kernel::BondForcesFull, Kernel::ChainLambda, Kernel::ChainForces])
                } else {
                    self.submit(&[Kernel::BondForcesFull])
                }
            }
            SolidStageKind::Contact => {
                let mut enc = self.device.create_command_encoder(&Default::default());
                self.record_contact(&mut enc);
                self.queue.submit([enc.finish()]);
            }
            SolidStageKind::ConjugateGradient => self.conjugate_gradient(),
            SolidStageKind::Integrate => self.submit(&[if implicit { Kernel::IntegrateImplicit } else { Kernel::IntegrateExplicit }]),
        }
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
                    for e in [Kernel::RotationMatrices, Kernel::StrainStressFull, Kernel::BondForcesFull] {
                        self.dispatch(&mut pass, e);
                    }
                }
                self.record_contact(&mut enc);
                let mut pass = enc.begin_compute_pass(&Default::default());
                self.dispatch(&mut pass, Kernel::IntegrateExplicit);
            }
            self.queue.submit([enc.finish()]);
            done += batch;
            self.step_count += batch;
        }
    }

    pub fn wait(&self) {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }

    fn read_f32(&self, buf: Buf) -> Vec<f32> {
        bytemuck::cast_slice(&super::context::read_buffer(&self.device, &self.queue, &self.buffers[buf])).to_vec()
    }

    /// The particles' positions and velocities (f64) in one trip, with the whole of each
    /// buffer of `extra` (another solver's on the same device: the fluid's instability flag)
    /// in the same trip; None when the read fails.
    pub fn download_kinematics(&self, extra: &[&wgpu::Buffer]) -> Option<Kinematics> {
        let mut buffers = vec![&self.buffers[Buf::Pos], &self.buffers[Buf::Vel]];
        buffers.extend_from_slice(extra);
        let mut arrays = self.readback.read(&self.device, &self.queue, &buffers)?;
        let rest = arrays.split_off(2);
        Some((self.positions(&arrays[0]), self.vectors(&arrays[1]), rest))
    }

    /// The first three of each particle's four f32 of a downloaded array, as f64 vectors.
    fn vectors(&self, raw: &[u8]) -> Vec<DVec3> {
        bytemuck::cast_slice::<u8, f32>(raw).chunks(4).take(self.n).map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)).collect()
    }

    /// The positions from a downloaded position buffer, which holds the displacement from the
    /// reference position.
    fn positions(&self, raw: &[u8]) -> Vec<DVec3> {
        self.vectors(raw).into_iter().zip(&self.reference).map(|(u, x)| *x + u).collect()
    }

    /// Staging buffers the reads of [`Self::download_kinematics`] and
    /// [`Self::download_into_with`] have made (one, unless a read outgrew it).
    pub fn readback_buffers_made(&self) -> u64 {
        self.readback.made()
    }

    /// A per-particle vector array as f64.
    pub fn download_vectors(&self, which: SolidArray) -> Vec<DVec3> {
        let buf = match which {
            SolidArray::Position => Buf::Pos,
            SolidArray::Velocity => Buf::Vel,
            SolidArray::Spin => Buf::Spin,
            SolidArray::Force => Buf::Force,
            SolidArray::Torque => Buf::Torque,
            SolidArray::StressTorque => Buf::TorqueG,
            SolidArray::DeltaV => Buf::Cg,
            SolidArray::ContactForce => Buf::ExtraForce,
            SolidArray::Load => Buf::Load,
            _ => panic!("{which:?} is not a vector array"),
        };
        let raw = self.read_f32(buf);
        let v = raw.chunks(4).take(self.n).map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64));
        match which {
            // the buffer holds the displacement from the reference position
            SolidArray::Position => v.zip(&self.reference).map(|(u, x)| *x + u).collect(),
            _ => v.collect(),
        }
    }

    /// A per-particle matrix array (Q or the rotation matrices) as f64.
    pub fn download_matrices(&self, which: SolidArray) -> Vec<DMat3> {
        let buf = match which {
            SolidArray::Q => Buf::Qmat,
            SolidArray::Rotation => Buf::Rot,
            _ => panic!("{which:?} is not a matrix array"),
        };
        self.read_f32(buf)
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

    /// Bytes [`Self::download_into`] brings back: four arrays of four f32 per particle.
    pub fn state_bytes(&self) -> u64 {
        64 * self.n as u64
    }

    /// Copies the GPU state (positions, velocities, spins, quaternions) into a CPU solver. When
    /// a read fails (a lost device, no memory for a staging buffer) `s` is left as it was and
    /// false comes back.
    pub fn download_into(&self, s: &mut SolidSolver) -> bool {
        self.download_into_with(s, &[]).is_some()
    }

    /// [`Self::download_into`] with the whole of each buffer of `extra` (on the same device)
    /// read in the same trip and returned; None (and `s` as it was) when the read fails.
    pub fn download_into_with(&self, s: &mut SolidSolver, extra: &[&wgpu::Buffer]) -> Option<Vec<Vec<u8>>> {
        // one trip for the four arrays and the extra buffers
        let b = |buf: Buf| &self.buffers[buf];
        let mut buffers = vec![b(Buf::Pos), b(Buf::Vel), b(Buf::Spin), b(Buf::Quat)];
        buffers.extend_from_slice(extra);
        let mut arrays = self.readback.read(&self.device, &self.queue, &buffers)?;
        let rest = arrays.split_off(4);
        let [pos, vel, spin, quat] = <[Vec<u8>; 4]>::try_from(arrays).expect("four arrays");
        s.particles.position = self.positions(&pos);
        s.particles.velocity = self.vectors(&vel);
        s.particles.spin = self.vectors(&spin);
        s.particles.rotation = bytemuck::cast_slice::<u8, f32>(&quat)
            .chunks(4)
            .take(self.n)
            .map(|c| DQuat::from_xyzw(c[0] as f64, c[1] as f64, c[2] as f64, c[3] as f64))
            .collect();
        s.step_count = self.step_count;
        s.time = self.step_count as f64 * self.dt;
        Some(rest)
    }
}

/// The particles' positions and velocities (f64) and the bytes of the extra buffers read in
/// the same trip ([`GpuSolid::download_kinematics`]).
pub type Kinematics = (Vec<DVec3>, Vec<DVec3>, Vec<Vec<u8>>);

#[cfg(test)]
mod mirror_tests {
    use super::{Params, SHADER};
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror("solid.wgsl", SHADER, "Params", mirror!(Params { n, dim, contact, pad, dt, _p, gravity }));
    }
}
