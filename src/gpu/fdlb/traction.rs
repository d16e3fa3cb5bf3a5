//! Method 1's traction on the device ([`codegen::traction`]): the plan of the pieces
//! ([`TractionPlan`], made on the CPU from the particles) goes up, the kernels read the air
//! where the pieces sample it and write the surface particles' loads into the solid's load
//! buffer — no population crosses the bus. The pieces' forces stay on the device until an
//! output reads them ([`GpuFluid::download_piece_forces`]).

use super::{GpuFluid, pipeline_of};
use crate::coupling::traction::TractionModel;
use crate::coupling::traction_plan::TractionPlan;
use crate::gpu::codegen;
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// The kernels' uniform (the WGSL `TractionParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct TractionParams {
    pieces: u32,
    targets: u32,
    n_nodes: u32,
    model: u32,
    p0: f32,
    relaxation: f32,
    dim_factor: f32,
    force_unit: f32,
}

/// A surface piece (the WGSL `Piece`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct Piece {
    normal: [f32; 4],
    tangent: [f32; 4],
    wall: [f32; 4],
    dvds: [f32; 4],
    area: f32,
    s0: u32,
    s1: u32,
    s2: u32,
}

/// A loaded particle (the WGSL `Target`): the scene's own load, its range of shares.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct Target {
    base: [f32; 4],
    particle: u32,
    first: u32,
    last: u32,
    _pad: u32,
}

/// The two kernels and their buffers (grown by powers of two).
pub(super) struct TractionKernel {
    pieces_force: wgpu::ComputePipeline,
    spread: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    pieces: wgpu::Buffer,
    stencil: wgpu::Buffer,
    piece_force: wgpu::Buffer,
    targets: wgpu::Buffer,
    shares: wgpu::Buffer,
    /// Pieces of the last plan (whose forces `piece_force` holds).
    count: usize,
    /// The two kernels' bind groups per placement of fⁿ (buffer 0 or 2) with the load buffer
    /// they were made for, kept while these buffers live.
    groups: [Option<(wgpu::Buffer, wgpu::BindGroup, wgpu::BindGroup)>; 2],
}

fn v4(v: DVec3) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, 0.0]
}

impl GpuFluid {
    /// Method 1's surface_traction stage on the device: the air's tractions on `plan`'s pieces
    /// (2.110–2.112) spread to their particles (2.113), whose loads in `load` (the solid's
    /// load buffer, `[f32; 4]` per particle: load, added mass) become `base` (the scene's own
    /// loads, physical units) plus the air's; the added mass is kept. Submitted, not waited for.
    pub fn surface_traction(&mut self, plan: &TractionPlan, base: &[DVec3], load: &wgpu::Buffer) {
        let pieces: Vec<Piece> = plan
            .pieces
            .iter()
            .map(|p| Piece {
                normal: v4(p.normal),
                tangent: v4(p.tangent),
                wall: v4(p.wall_velocity),
                dvds: v4(p.dvds),
                area: p.area as f32,
                s0: p.stencil[0],
                s1: p.stencil[1],
                s2: p.stencil[2],
            })
            .collect();
        let stencil: Vec<[u32; 2]> = plan.stencil.iter().map(|&(n, w)| [n, (w as f32).to_bits()]).collect();
        let targets: Vec<Target> =
            plan.targets.iter().map(|(i, r)| Target { base: v4(base[*i as usize]), particle: *i, first: r.start, last: r.end, _pad: 0 }).collect();
        let shares: Vec<[u32; 2]> = plan.shares.iter().map(|&(k, w)| [k, (w as f32).to_bits()]).collect();
        self.prepare_traction(pieces.len(), stencil.len(), targets.len(), shares.len());
        let k = self.traction.as_mut().expect("built by prepare_traction");
        k.count = pieces.len();
        let params = TractionParams {
            pieces: pieces.len() as u32,
            targets: targets.len() as u32,
            n_nodes: self.stride as u32,
            model: match plan.model {
                TractionModel::SeedPressure => codegen::TRACTION_SEED_PRESSURE,
                TractionModel::PressureAndShear => codegen::TRACTION_PRESSURE_AND_SHEAR,
            },
            p0: plan.p0 as f32,
            relaxation: plan.relaxation as f32,
            dim_factor: 2.0 / plan.dim as f32,
            force_unit: plan.force_unit as f32,
        };
        let q = &self.queue;
        q.write_buffer(&k.params, 0, bytemuck::bytes_of(&params));
        for (b, bytes) in [
            (&k.pieces, bytemuck::cast_slice::<Piece, u8>(&pieces)),
            (&k.stencil, bytemuck::cast_slice(&stencil)),
            (&k.targets, bytemuck::cast_slice(&targets)),
            (&k.shares, bytemuck::cast_slice(&shares)),
        ] {
            if !bytes.is_empty() {
                q.write_buffer(b, 0, bytes);
            }
        }
        let k = self.traction.as_ref().expect("built by prepare_traction");
        let slot = self.cur / 2;
        if k.groups[slot].as_ref().is_none_or(|(l, _, _)| l != load) {
            let forces = self.bind(&k.pieces_force, &[(0, &k.params), (1, &k.pieces), (2, &k.stencil), (3, &k.piece_force)], &[(10, &self.f[self.cur])]);
            let spread = self.bind(&k.spread, &[(0, &k.params), (3, &k.piece_force), (4, &k.targets), (5, &k.shares), (6, load)], &[]);
            self.traction_objects_made += 2;
            self.traction.as_mut().expect("built by prepare_traction").groups[slot] = Some((load.clone(), forces, spread));
        }
        let k = self.traction.as_ref().expect("built by prepare_traction");
        let (_, forces, spread) = k.groups[slot].as_ref().expect("made above");
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            Self::dispatch(&mut pass, &k.pieces_force, forces, pieces.len() as u32);
            Self::dispatch(&mut pass, &k.spread, spread, targets.len() as u32);
        }
        self.queue.submit([enc.finish()]);
    }

    /// The forces of the last [`Self::surface_traction`]'s pieces (physical units per unit
    /// depth, f32 → f64), or None when the read fails.
    pub fn download_piece_forces(&self) -> Option<Vec<DVec3>> {
        let Some(k) = self.traction.as_ref().filter(|k| k.count > 0) else { return Some(Vec::new()) };
        let raw = self.piece_readback.read_parts(&self.device, &self.queue, &[(&k.piece_force, 0, 16 * k.count as u64)])?;
        let v: &[[f32; 4]] = bytemuck::cast_slice(&raw);
        Some(v.iter().map(|f| DVec3::new(f[0] as f64, f[1] as f64, f[2] as f64)).collect())
    }

    /// Bytes [`Self::download_piece_forces`] brings back.
    pub fn piece_forces_bytes(&self) -> u64 {
        self.traction.as_ref().map_or(0, |k| 16 * k.count as u64)
    }

    /// The traction kernels (built at their first use) with room for the counts given.
    fn prepare_traction(&mut self, pieces: usize, stencil: usize, targets: usize, shares: usize) {
        use wgpu::BufferUsages as U;
        let room = |b: &wgpu::Buffer, bytes: usize| b.size() as usize >= bytes.max(16);
        let fits = self.traction.as_ref().is_some_and(|k| {
            room(&k.pieces, 80 * pieces)
                && room(&k.stencil, 8 * stencil)
                && room(&k.piece_force, 16 * pieces)
                && room(&k.targets, 32 * targets)
                && room(&k.shares, 8 * shares)
        });
        if fits {
            return;
        }
        let dev = &self.device;
        let buffer = |label, bytes: usize, usage| {
            dev.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: bytes.max(16).next_power_of_two() as u64, usage, mapped_at_creation: false })
        };
        let (pieces_force, spread) = match self.traction.take() {
            Some(k) => (k.pieces_force, k.spread),
            None => {
                let src = codegen::traction(&self.eq, self.split);
                (pipeline_of(dev, "traction", &src, "pieces_force"), pipeline_of(dev, "traction", &src, "spread"))
            }
        };
        self.traction = Some(TractionKernel {
            pieces_force,
            spread,
            params: buffer("traction params", size_of::<TractionParams>(), U::UNIFORM | U::COPY_DST),
            pieces: buffer("traction pieces", 80 * pieces, U::STORAGE | U::COPY_DST),
            stencil: buffer("traction stencils", 8 * stencil, U::STORAGE | U::COPY_DST),
            piece_force: buffer("traction piece forces", 16 * pieces, U::STORAGE | U::COPY_SRC),
            targets: buffer("traction targets", 32 * targets, U::STORAGE | U::COPY_DST),
            shares: buffer("traction shares", 8 * shares, U::STORAGE | U::COPY_DST),
            count: 0,
            groups: [None, None],
        });
        self.traction_objects_made += 6;
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::{Piece, Target, TractionParams};
    use crate::fluid::{Equilibrium, GasModel, VelocitySet, VelocitySetKind};
    use crate::gpu::codegen::{Split, traction};
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    /// The traction's Rust mirrors lay out as the generated WGSL structs (naga reflection).
    #[test]
    fn traction_structs_match_the_shader_layout() {
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let src = traction(&eq, Split::whole(eq.values_per_node()));
        check_mirror("traction", &src, "TractionParams", mirror!(TractionParams { pieces, targets, n_nodes, model, p0, relaxation, dim_factor, force_unit }));
        check_mirror("traction", &src, "Piece", mirror!(Piece { normal, tangent, wall, dvds, area, s0, s1, s2 }));
        check_mirror("traction", &src, "Target", mirror!(Target { base, particle, first, last, _pad }));
    }
}
