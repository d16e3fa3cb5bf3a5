//! Method 2's record of what the walls take out of the air, on the GPU fluid: the
//! `face_fluxes` and `thin_wall_fluxes` kernels ([`codegen::face_fluxes`],
//! [`codegen::thin_wall_fluxes`]) dispatched after each advection stage
//! ([`GpuFluid::record_stage`]) once [`GpuFluid::record_face_fluxes`] is called.

use super::{GpuFluid, pipeline_of, storage};
use crate::fluid::FluidSolver;
use crate::gpu::codegen;

/// The `face_fluxes` kernel ([`codegen::face_fluxes`]) with its buffers: after each advection
/// stage it adds what every wall node took out of the air to `wall` (vec4 per padded node).
pub(super) struct FaceFluxes {
    pub(super) pipeline: wgpu::ComputePipeline,
    pub(super) wall: wgpu::Buffer,
    /// The populations of the air at rest the fluxes are counted against.
    reference: wgpu::Buffer,
    pub(super) group: wgpu::BindGroup,
    /// The thin-wall part (`thin_wall_fluxes`), its bind group and thread count.
    pub(super) thin: (wgpu::ComputePipeline, wgpu::BindGroup, u32),
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
        let (thin_group, thin_count) = self.thin_flux_group(s, &thin_pipeline, &wall);
        let thin = (thin_pipeline, thin_group, thin_count);
        self.face_fluxes = Some(FaceFluxes { pipeline, wall, reference, group, thin });
    }

    /// The thin-wall flux kernel's bind group for the layout of `s` and its thread count.
    fn thin_flux_group(&self, s: &FluidSolver, pipeline: &wgpu::ComputePipeline, wall: &wgpu::Buffer) -> (wgpu::BindGroup, u32) {
        let (order, targets) = super::super::thin_wall::flux_targets(&s.layout);
        let count = targets.len() as u32;
        let order = storage(&self.device, "thin flux order", bytemuck::cast_slice(&order));
        let targets = storage(&self.device, "thin flux targets", bytemuck::cast_slice(&targets));
        (self.bind(pipeline, &[(0, &self.params_stage[0]), (1, &self.thin.0), (2, &order), (3, &targets), (4, wall)], &[(10, &self.h)]), count)
    }

    /// After a geometry change ([`Self::set_geometry`]): the face-flux kernels' bind groups for
    /// the new tables of `s` (nothing when the fluxes are not recorded).
    /// `whole`: the node-kind or thin-tap buffers were replaced, so the main group is made again
    /// too; otherwise only the thin-wall part, whose targets follow the layout's thin taps.
    pub(super) fn rebind_face_fluxes(&mut self, s: &FluidSolver, whole: bool) {
        let Some(ff) = self.face_fluxes.take() else { return };
        let group = if whole {
            self.bind(&ff.pipeline, &[(0, &self.params_stage[0]), (1, &self.kind), (2, &ff.reference), (3, &ff.wall)], &[(10, &self.h)])
        } else {
            ff.group
        };
        let (thin_group, thin_count) = self.thin_flux_group(s, &ff.thin.0, &ff.wall);
        self.face_fluxes = Some(FaceFluxes { group, thin: (ff.thin.0, thin_group, thin_count), ..ff });
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
