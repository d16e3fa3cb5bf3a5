//! The parts of [`super::GpuSolid::from_solver`]: the implicit solve's preconditioner as the
//! device holds it, the size check against the device's binding limit, the buffers filled from
//! the CPU solver's discretisation, and the bind groups and pipelines over them.

use super::bindings::{Buf, Buffers, G0, G1, Pipelines};
use super::solve::{CoarseArrays, PatchArrays, device_coarse, device_patches};
use super::{Params, SHADER, m3, v4};
use crate::gpu::context::{GpuContext, GpuError};
use crate::solid::{Integrator, Preconditioner, SolidSolver};
use wgpu::util::DeviceExt;

/// The block-Jacobi inverses (3×3 blocks padded to 12 f32) of an implicit solver, its smoother and
/// coarse space built as the CPU step builds them; zeros for an explicit solver (never read).
pub(super) fn prepare_preconditioner(s: &mut SolidSolver) -> Vec<[f32; 12]> {
    if s.options.integrator != Integrator::Implicit {
        return vec![[0f32; 12]; s.particles.len()];
    }
    let blocks = s.preconditioner().blocks().iter().map(m3).collect();
    // the options' smoother and the coarse space, as the CPU step builds them
    s.prepare_preconditioner();
    blocks
}

/// The implicit solve's preconditioner as the device holds it: the CPU options' patch smoother
/// where its patches fit the device (else block Jacobi, `note` says why), and the CPU's coarse
/// space where it fits (else none, `coarse_note` says why; `None` for an explicit solver).
pub(super) struct DevicePreconditioner<'a> {
    /// Block-Jacobi inverses, one a particle ([`prepare_preconditioner`]).
    pub blocks: Vec<[f32; 12]>,
    pub smoother: Preconditioner,
    /// The patches' members and the solver's own packed inverses (empty with block Jacobi).
    pub patches: PatchArrays<'a>,
    pub note: Option<String>,
    pub coarse: Option<CoarseArrays>,
    pub coarse_note: Option<String>,
}

impl<'a> DevicePreconditioner<'a> {
    /// What of `s`'s preconditioner the device takes under the binding limit `limit` (bytes).
    pub fn of(s: &'a SolidSolver, blocks: Vec<[f32; 12]>, limit: u64) -> Self {
        let implicit = s.options.integrator == Integrator::Implicit;
        let wants_patches = implicit && s.options.preconditioner == Preconditioner::Patches;
        let patches = wants_patches.then(|| device_patches(s.built_patch_smoother().expect("built by prepare_preconditioner"), limit));
        let (smoother, patches, note) = match patches {
            Some(Ok(a)) => (Preconditioner::Patches, a, None),
            Some(Err(why)) => (Preconditioner::BlockJacobi, PatchArrays::default(), Some(why)),
            None => (Preconditioner::BlockJacobi, PatchArrays::default(), None),
        };
        let coarse = match (implicit, s.coarse_space()) {
            (false, _) => Err(None),
            (true, None) => Err(Some(
                "no coarse space (a periodic solid, an A_c not positive definite, or dropped by `SolidSolver::drop_coarse_space`): the smoother alone"
                    .to_string(),
            )),
            (true, Some(c)) => device_coarse(c, &s.particles.reference, 4 * patches.inverse.len() as u64, limit).map_err(Some),
        };
        let (coarse, coarse_note) = match coarse {
            Ok(c) => (Some(c), None),
            Err(why) => (None, why),
        };
        Self { blocks, smoother, patches, note, coarse, coarse_note }
    }
}

/// Refuses a solid whose largest arrays pass the device's `max_storage_buffer_binding_size`
/// (`limit`, bytes), before any buffer is made.
pub(super) fn check_sizes(s: &SolidSolver, limit: u64) -> Result<(), GpuError> {
    let (n, nb) = (s.particles.len() as u64, s.disc.bonds.len() as u64);
    for (what, bytes) in [("bond arrays", 16 * nb), ("stiffness array", 144 * n), ("CG vectors", 112 * n)] {
        if bytes > limit {
            return Err(GpuError::TooLarge { what, bytes, limit, unit: "bytes", limit_name: "max_storage_buffer_binding_size" });
        }
    }
    Ok(())
}

/// Every buffer of shaders/solid.wgsl: the bond lists and per-bond constants, the particles'
/// constants, the preconditioner `pre`, and zeroed state (written by `upload_state`).
pub(super) fn create_buffers(ctx: &GpuContext, s: &SolidSolver, pre: &DevicePreconditioner) -> Buffers {
    let device = &ctx.device;
    let storage = |label: &str, data: &[u8]| {
        let data: &[u8] = if data.is_empty() { &[0u8; 64] } else { data };
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: data,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        })
    };
    let (p, b) = (&s.particles, &s.disc.bonds);
    let (n, nb) = (p.len(), b.len());
    let (patches, coarse) = (&pre.patches, &pre.coarse);
    let zeros4 = vec![[0f32; 4]; n];
    let zeros12 = vec![[0f32; 12]; n];
    let params = Params { n: n as u32, dim: p.dim as u32, contact: 0, pad: 0, dt: s.dt as f32, _p: [0.0; 3], gravity: v4(s.options.gravity, 0.0) };
    let r0: Vec<[f32; 4]> = (0..nb).map(|k| v4(b.r0[k], b.w_hat[k])).collect();
    let stiffness: Vec<f32> = b.stiffness.iter().map(|k| *k as f32).collect();
    let gr: Vec<[f32; 4]> = (0..nb).map(|k| v4(b.grad[k], b.damping[k])).collect();
    let cs: Vec<f32> = s.disc.grad_stiffness.iter().flat_map(|c| c.iter().flat_map(|row| row.iter().map(|x| *x as f32))).collect();
    let info: Vec<[f32; 4]> = (0..n).map(|i| [p.mass[i] as f32, p.inertia[i] as f32, p.volume[i] as f32, if p.fixed[i] { 1.0 } else { 0.0 }]).collect();
    Buffers::new(|buf| {
        let name = buf.name();
        match buf {
            Buf::Params => device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("solid params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            }),
            Buf::Offs => storage(name, bytemuck::cast_slice(&b.offset)),
            Buf::Nbr => storage(name, bytemuck::cast_slice(&b.neighbour)),
            Buf::Rev => storage(name, bytemuck::cast_slice(&b.reverse)),
            Buf::BondR0 => storage(name, bytemuck::cast_slice(&r0)),
            Buf::BondStiffness => storage(name, bytemuck::cast_slice(&stiffness)),
            Buf::BondGrad => storage(name, bytemuck::cast_slice(&gr)),
            Buf::Cstiff => storage(name, bytemuck::cast_slice(&cs)),
            Buf::Pinfo => storage(name, bytemuck::cast_slice(&info)),
            Buf::Rot | Buf::Qmat | Buf::Jinv => storage(name, bytemuck::cast_slice(&zeros12)),
            Buf::Theta => storage(name, bytemuck::cast_slice(&vec![[0f32; 4]; 2 * n])),
            Buf::Cg => storage(name, bytemuck::cast_slice(&vec![[0f32; 4]; 7 * n])),
            Buf::Precond => storage(name, bytemuck::cast_slice(&pre.blocks)),
            // the dot products' partial sums, then the coarse space's g and u
            Buf::Partials => storage(name, bytemuck::cast_slice(&vec![0f32; 4 * n.div_ceil(256) + 4 + 2 * coarse.as_ref().map_or(0, |c| c.unknowns as usize)])),
            Buf::Scalars => storage(name, bytemuck::cast_slice(&[0f32; 8])),
            // block Jacobi: Q = 0 (the smoother is never dispatched then); the coarse
            // space's arrays follow the patches'
            Buf::PatchIndex => match coarse {
                Some(c) => storage(name, bytemuck::cast_slice(&[&patches.index[..], &c.index].concat())),
                None => storage(name, bytemuck::cast_slice(&patches.index)),
            },
            Buf::PatchInverse => match coarse {
                Some(c) => {
                    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some(name),
                        size: 4 * (patches.inverse.len() + c.values.len()) as u64,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    });
                    ctx.queue.write_buffer(&buffer, 0, bytemuck::cast_slice(patches.inverse));
                    ctx.queue.write_buffer(&buffer, 4 * patches.inverse.len() as u64, bytemuck::cast_slice(&c.values));
                    buffer
                }
                None => storage(name, bytemuck::cast_slice(patches.inverse)),
            },
            // the per-particle vectors
            Buf::Pos
            | Buf::Vel
            | Buf::Spin
            | Buf::Quat
            | Buf::Load
            | Buf::TorqueG
            | Buf::Force
            | Buf::Torque
            | Buf::ExtraForce
            | Buf::ExtraTorque
            | Buf::LinX
            | Buf::LinV
            | Buf::Lambda => storage(name, bytemuck::cast_slice(&zeros4)),
        }
    })
}

/// The two bind groups over `buffers` (layouts [`G0`], [`G1`]) and every kernel's pipeline,
/// compiled from [`SHADER`].
pub(super) fn bind_and_compile(device: &wgpu::Device, buffers: &Buffers) -> ([wgpu::BindGroup; 2], Pipelines) {
    let layout_of = |g: &[(Buf, bool)]| {
        let kinds: Vec<(bool, bool)> = g.iter().map(|(buf, ro)| (*buf == Buf::Params, *ro)).collect();
        crate::gpu::context::buffer_layout(device, "solid", &kinds)
    };
    let l0 = layout_of(&G0);
    let l1 = layout_of(&G1);
    let group = |layout: &wgpu::BindGroupLayout, g: &[(Buf, bool)]| {
        let entries: Vec<wgpu::BindGroupEntry> =
            g.iter().enumerate().map(|(k, (buf, _))| wgpu::BindGroupEntry { binding: k as u32, resource: buffers[*buf].as_entire_binding() }).collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("solid"), layout, entries: &entries })
    };
    let groups = [group(&l0, &G0), group(&l1, &G1)];
    let pl =
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("solid"), bind_group_layouts: &[Some(&l0), Some(&l1)], immediate_size: 0 });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("solid.wgsl"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
    (groups, Pipelines::new(device, &module, &pl))
}
