//! Distinct-element contact of the GPU solid (shaders/solid_contact.wgsl; CPU twin
//! `solid::contact`): a uniform grid rebuilt every step by a counting sort with atomics, then a
//! gather of pair and wall contacts with anchors kept in per-particle slots ([`CONTACT_SLOTS`]
//! per particle, double-buffered).

use super::bindings::Buf;
use super::{GpuSolid, v4};
use crate::solid::SolidSolver;
use glam::DVec3;
use wgpu::util::DeviceExt;

const CONTACT_SHADER: &str = include_str!("../../../shaders/solid_contact.wgsl");

/// Contacts remembered per particle (pairs and walls).
pub const CONTACT_SLOTS: u32 = 16;

/// The entry points of shaders/solid_contact.wgsl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ContactKernel {
    GridCount,
    GridScan,
    GridScatter,
    ContactForces,
}

impl ContactKernel {
    const ALL: [ContactKernel; 4] = [ContactKernel::GridCount, ContactKernel::GridScan, ContactKernel::GridScatter, ContactKernel::ContactForces];
    fn entry(self) -> &'static str {
        match self {
            ContactKernel::GridCount => "grid_count",
            ContactKernel::GridScan => "grid_scan",
            ContactKernel::GridScatter => "grid_scatter",
            ContactKernel::ContactForces => "contact_forces",
        }
    }
}

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

pub(super) struct GpuContact {
    pipelines: [wgpu::ComputePipeline; 4],
    /// Ping-pong of the anchor history.
    groups: [wgpu::BindGroup; 2],
    cur: usize,
    cell_count: wgpu::Buffer,
}

impl ContactUniform {
    /// The contact law of `cp` and the grid of `s`'s particles: it covers the bodies' reference
    /// box grown by its size on every side (beyond: the edge cells), in cells of l₀.
    fn of(s: &SolidSolver, cp: &crate::solid::ContactParams) -> Self {
        let p = &s.particles;
        let l0 = p.spacing;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for x in &p.reference {
            lo = lo.min(*x);
            hi = hi.max(*x);
        }
        let ext = (hi - lo).max(DVec3::splat(2.0 * l0));
        let origin = lo - ext;
        let mut dims = [1u32; 3];
        for a in 0..p.dim {
            dims[a] = ((3.0 * ext[a]) / l0).ceil() as u32 + 1;
        }
        let mut walls = [[0f32; 4]; 4];
        for (k, w) in s.options.walls.iter().enumerate() {
            walls[k] = v4(w.normal, w.offset);
        }
        ContactUniform {
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
            n: p.len() as u32,
            dim: p.dim as u32,
            slots: CONTACT_SLOTS,
            cells: dims[0] * dims[1] * dims[2],
        }
    }
}

/// The contact stage's own buffers (the particles' are the solid's).
struct ContactBuffers {
    uniform: wgpu::Buffer,
    /// Each particle's body index.
    body: wgpu::Buffer,
    /// The grid's counting sort: each particle's cell, the cells' counts and starts, the
    /// particles in cell order.
    cell_of: wgpu::Buffer,
    cell_count: wgpu::Buffer,
    cell_start: wgpu::Buffer,
    sorted: wgpu::Buffer,
    /// The anchors' history, ping-pong: [`CONTACT_SLOTS`] slots per particle of two vec4 each
    /// (the lower particle's anchor with the partner's tag, the higher one's anchor or the wall
    /// point), an empty slot's tag all ones.
    hist: [wgpu::Buffer; 2],
    /// The particles' reference positions.
    reference: wgpu::Buffer,
}

impl ContactBuffers {
    fn create(device: &wgpu::Device, p: &crate::solid::Particles, uni: &ContactUniform) -> Self {
        let n = p.len();
        let cells = uni.cells as usize;
        let init = |label: &str, data: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: data, usage })
        };
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
        let body: Vec<u32> = p.body.iter().map(|&b| b as u32).collect();
        let empty: Vec<[f32; 4]> = (0..2 * n * CONTACT_SLOTS as usize).map(|_| [0.0, 0.0, 0.0, f32::from_bits(u32::MAX)]).collect();
        let reference: Vec<[f32; 4]> = p.reference.iter().map(|x| v4(*x, 0.0)).collect();
        ContactBuffers {
            uniform: init("contact uniform", bytemuck::bytes_of(uni), wgpu::BufferUsages::UNIFORM),
            body: init("body", bytemuck::cast_slice(&body), st),
            cell_of: init("cell_of", bytemuck::cast_slice(&vec![0u32; n]), st),
            cell_count: init("cell_count", bytemuck::cast_slice(&vec![0u32; cells]), st),
            cell_start: init("cell_start", bytemuck::cast_slice(&vec![0u32; cells + 1]), st),
            sorted: init("sorted", bytemuck::cast_slice(&vec![0u32; n]), st),
            hist: [init("hist a", bytemuck::cast_slice(&empty), st), init("hist b", bytemuck::cast_slice(&empty), st)],
            reference: init("reference positions", bytemuck::cast_slice(&reference), st),
        }
    }
}

/// (uniform?, read-only?) per binding of shaders/solid_contact.wgsl, in the order
/// [`GpuSolid::contact_bind_groups`] binds them (checked against the shader by
/// `the_contact_uniform_and_kernels_match_the_shader`).
const CONTACT_BINDINGS: [(bool, bool); 15] = [
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

impl GpuSolid {
    /// The contact stage of `s` with the law `cp`: its grid and buffers, its two bind groups
    /// (the anchors' history read from one buffer and written to the other, then the other way)
    /// and the four kernels.
    pub(super) fn build_contact(&self, s: &SolidSolver, cp: &crate::solid::ContactParams) -> GpuContact {
        let device = &self.device;
        let uni = ContactUniform::of(s, cp);
        let c = ContactBuffers::create(device, &s.particles, &uni);
        let layout = crate::gpu::context::buffer_layout(device, "contact", &CONTACT_BINDINGS);
        let groups = self.contact_bind_groups(&layout, &c);
        let pl =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("contact"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let module = device
            .create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("solid_contact.wgsl"), source: wgpu::ShaderSource::Wgsl(CONTACT_SHADER.into()) });
        let mut map = crate::gpu::context::compute_pipelines(device, &module, &pl, &ContactKernel::ALL.map(ContactKernel::entry));
        let pipelines = ContactKernel::ALL.map(|k| map.remove(k.entry()).expect("one pipeline per entry point"));
        GpuContact { pipelines, groups, cur: 0, cell_count: c.cell_count }
    }

    /// The contact kernels' two bind groups over the solid's particle buffers and `c`'s, the
    /// anchors' history `hist[0] → hist[1]` in the first and back in the second.
    fn contact_bind_groups(&self, layout: &wgpu::BindGroupLayout, c: &ContactBuffers) -> [wgpu::BindGroup; 2] {
        let b = &self.buffers;
        let group = |inp: &wgpu::Buffer, out: &wgpu::Buffer| {
            let res = [
                &c.uniform,
                &b[Buf::Pos],
                &b[Buf::Vel],
                &b[Buf::Rot],
                &b[Buf::Pinfo],
                &c.body,
                &b[Buf::ExtraForce],
                &b[Buf::ExtraTorque],
                &c.cell_of,
                &c.cell_count,
                &c.cell_start,
                &c.sorted,
                inp,
                out,
                &c.reference,
            ];
            let entries: Vec<wgpu::BindGroupEntry> =
                res.iter().enumerate().map(|(k, buf)| wgpu::BindGroupEntry { binding: k as u32, resource: buf.as_entire_binding() }).collect();
            self.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("contact"), layout, entries: &entries })
        };
        [group(&c.hist[0], &c.hist[1]), group(&c.hist[1], &c.hist[0])]
    }

    /// Records the contact stage (grid rebuild and contact forces) into `enc`.
    pub(super) fn record_contact(&mut self, enc: &mut wgpu::CommandEncoder) {
        let n = self.n as u32;
        let Some(c) = self.contact.as_mut() else { return };
        let w = n.div_ceil(64).max(1);
        let (wx, wy) = if w <= 65_535 { (w, 1) } else { (65_535, w.div_ceil(65_535)) };
        let run = |enc: &mut wgpu::CommandEncoder, c: &GpuContact, kernels: [ContactKernel; 2]| {
            let mut pass = enc.begin_compute_pass(&Default::default());
            for k in kernels {
                pass.set_pipeline(&c.pipelines[k as usize]);
                pass.set_bind_group(0, &c.groups[c.cur], &[]);
                if k == ContactKernel::GridScan { pass.dispatch_workgroups(1, 1, 1) } else { pass.dispatch_workgroups(wx, wy, 1) }
            }
        };
        enc.clear_buffer(&c.cell_count, 0, None);
        run(enc, c, [ContactKernel::GridCount, ContactKernel::GridScan]);
        enc.clear_buffer(&c.cell_count, 0, None);
        run(enc, c, [ContactKernel::GridScatter, ContactKernel::ContactForces]);
        c.cur = 1 - c.cur;
    }
}

#[cfg(test)]
mod tests {
    use super::{CONTACT_BINDINGS, CONTACT_SHADER, ContactKernel, ContactUniform};
    use crate::gpu::wgsl_check::{check_bindings, check_mirror, mirror, validate};

    #[test]
    fn the_contact_uniform_and_kernels_match_the_shader() {
        check_mirror(
            "solid_contact.wgsl",
            CONTACT_SHADER,
            "ContactUniform",
            mirror!(ContactUniform { kn, kt, mu_s, mu_d, damping, l0, n_walls, multi_body, origin, dims, walls, n, dim, slots, cells }),
        );
        let module = validate("solid_contact.wgsl", CONTACT_SHADER);
        let mut entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
        let mut ours: Vec<&str> = ContactKernel::ALL.iter().map(|k| k.entry()).collect();
        entries.sort();
        ours.sort();
        assert_eq!(entries, ours);
        check_bindings("solid_contact.wgsl", CONTACT_SHADER, 0, &CONTACT_BINDINGS);
    }
}
