//! Method 2's record of what the walls take out of the air, on the GPU fluid: the
//! `face_fluxes` and `thin_wall_fluxes` kernels ([`codegen::face_fluxes`],
//! [`codegen::thin_wall_fluxes`]) dispatched after each advection stage
//! ([`GpuFluid::record_stage`]) once [`GpuFluid::record_face_fluxes`] is called.

use super::{GpuFluid, Params, pipeline_of, storage};
use crate::fluid::FluidSolver;
use crate::gpu::codegen;
use crate::gpu::growing::GrowingBuffer;
use wgpu::util::DeviceExt;

/// The `face_fluxes` kernel ([`codegen::face_fluxes`]) with its buffers: after each advection
/// stage it adds what every wall node took out of the air to `wall` (vec4 per padded node).
pub(super) struct FaceFluxes {
    pub(super) pipeline: wgpu::ComputePipeline,
    pub(super) wall: wgpu::Buffer,
    /// The populations of the air at rest the fluxes are counted against (bound in `group`,
    /// owned here).
    _reference: wgpu::Buffer,
    pub(super) group: wgpu::BindGroup,
    /// The thin-wall part (`thin_wall_fluxes`), its bind group and thread count.
    pub(super) thin: (wgpu::ComputePipeline, wgpu::BindGroup, u32),
    /// Its tables ([`crate::gpu::thin_wall::flux_targets`]: the taps in the order of their wall
    /// nodes, and per wall node its first tap and count), rewritten at each geometry change,
    /// and its parameters (the thread count).
    thin_tables: ThinFluxTables,
}

/// The thin-wall flux kernel's tables and parameters.
pub(super) struct ThinFluxTables {
    order: GrowingBuffer,
    targets: GrowingBuffer,
    params: wgpu::Buffer,
}

impl FaceFluxes {
    /// Buffers the thin-wall flux tables have made, their first ones included.
    pub(super) fn thin_tables_made(&self) -> u64 {
        self.thin_tables.order.made() + self.thin_tables.targets.made()
    }
}

impl GpuFluid {
    /// From now on, every advection stage adds to a per-node record what each wall node took out
    /// of the air through its faces (momentum xyz, mass w; lattice units), counted against the
    /// populations `reference` of the air at rest (one per velocity, at least q) — method 2's
    /// exchange ([`crate::coupling::momentum_exchange::step_with_exchange`]) on the GPU, with the
    /// thin-wall corrections. `s` is the solver this GPU fluid was uploaded from (its thin taps
    /// give the walls that take their corrections). Read and cleared by [`Self::take_face_fluxes`]
    /// (a copy to the CPU), or on the device by the coupled step's hand-over
    /// ([`Self::face_flux_buffer`]).
    pub fn record_face_fluxes(&mut self, s: &FluidSolver, reference: &[f64]) {
        let pipeline = pipeline_of(&self.device, "face_fluxes", &codegen::face_fluxes(&self.eq, self.split), "main");
        let wall = storage(&self.device, "wall fluxes", bytemuck::cast_slice(&vec![[0f32; 4]; self.stride]));
        let reference: Vec<f32> = reference.iter().map(|&x| x as f32).collect();
        let reference = storage(&self.device, "reference populations", bytemuck::cast_slice(&reference));
        let group = self.bind(&pipeline, &[(0, &self.params_stage[0]), (1, &self.kind), (2, &reference), (3, &wall)], &[(10, &self.h)]);
        let thin_pipeline = pipeline_of(&self.device, "thin_wall_fluxes", &codegen::thin_wall_fluxes(&self.eq, self.split), "main");
        let (order, targets) = super::super::thin_wall::flux_targets(&s.layout);
        let count = targets.len() as u32;
        let thin_tables = ThinFluxTables {
            order: GrowingBuffer::storage(&self.device, "thin flux order", bytemuck::cast_slice(&order)),
            targets: GrowingBuffer::storage(&self.device, "thin flux targets", bytemuck::cast_slice(&targets)),
            params: self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("thin flux params"),
                contents: bytemuck::bytes_of(&Params { stage: 1, count, ..self.base }),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            }),
        };
        let thin_group = self.thin_flux_group(&thin_pipeline, &thin_tables, &wall);
        let thin = (thin_pipeline, thin_group, count);
        self.face_fluxes = Some(FaceFluxes { pipeline, wall, _reference: reference, group, thin, thin_tables });
    }

    /// The thin-wall flux kernel's bind group over `tables`.
    fn thin_flux_group(&self, pipeline: &wgpu::ComputePipeline, tables: &ThinFluxTables, wall: &wgpu::Buffer) -> wgpu::BindGroup {
        self.bind(
            pipeline,
            &[(0, &tables.params), (1, self.thin.0.buffer()), (2, tables.order.buffer()), (3, tables.targets.buffer()), (4, wall)],
            &[(10, &self.h)],
        )
    }

    /// After a geometry change ([`Self::set_geometry`]): the thin-wall flux tables of the new
    /// taps of `s` rewritten in place (nothing when the fluxes are not recorded), and the thread
    /// count with them; a new bind group only when a table outgrew its buffer or the taps'
    /// buffer was remade (`taps_remade`).
    pub(super) fn refresh_thin_fluxes(&mut self, s: &FluidSolver, taps_remade: bool) {
        let Some(mut ff) = self.face_fluxes.take() else { return };
        let (order, targets) = super::super::thin_wall::flux_targets(&s.layout);
        let count = targets.len() as u32;
        let t = &mut ff.thin_tables;
        let remade =
            t.order.write(&self.device, &self.queue, bytemuck::cast_slice(&order)) | t.targets.write(&self.device, &self.queue, bytemuck::cast_slice(&targets));
        if count != ff.thin.2 {
            self.queue.write_buffer(&t.params, 0, bytemuck::bytes_of(&Params { stage: 1, count, ..self.base }));
            ff.thin.2 = count;
        }
        if remade || taps_remade {
            ff.thin.1 = self.thin_flux_group(&ff.thin.0, &ff.thin_tables, &ff.wall);
        }
        self.face_fluxes = Some(ff);
    }

    /// The face-flux record on the device (one `vec4<f32>` per node, momentum xyz and mass w,
    /// at least the lattice's node count), for kernels that read it there
    /// ([`crate::gpu::coupling::CouplingKernels::hand_over`], which also clears it); `None`
    /// when the fluxes are not recorded.
    pub fn face_flux_buffer(&self) -> Option<&wgpu::Buffer> {
        self.face_fluxes.as_ref().map(|ff| &ff.wall)
    }

    /// What each padded node's walls took out of the air since the last call (momentum xyz,
    /// mass w; lattice units), and the record cleared; empty when the fluxes are not recorded.
    pub fn take_face_fluxes(&mut self) -> Vec<[f32; 4]> {
        let Some(ff) = &self.face_fluxes else { return Vec::new() };
        let raw: Vec<[f32; 4]> = bytemuck::cast_slice(&self.read_buffer(&ff.wall)).to_vec();
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&ff.wall, 0, None);
        self.queue.submit([enc.finish()]);
        raw[..self.n_nodes].to_vec()
    }
}
