//! The bodies' surfaces on the GPU: each body's level set L (seed 000 2.124) sampled on its
//! [`SurfaceGrid`] by shaders/level_set_grid.wgsl, then passed through marching cubes
//! ([`GpuMarchingCubes`]), every body appending to one set of output buffers with its index as
//! the triangles' tag — the GPU twin of [`crate::mesh::particle_field::body_surfaces`]. The
//! particles and their bins ([`KernelLevelSet::bin_lists`], built on the CPU in O(N)) go up;
//! nothing comes back: the plugin draws the buffers (`render::gpu_fold_mesh`, feature
//! `render`).

use super::context::{GpuContext, buffer_layout, compute_pipelines, dispatch_grid, read_buffer};
use super::marching_cubes::{FieldOnDevice, GpuMarchingCubes, SurfaceBuffers};
use crate::fluid::KernelLevelSet;
use crate::mesh::ScalarGrid;
use crate::mesh::particle_field::SurfaceGrid;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

pub(crate) const SHADER: &str = include_str!("../../shaders/level_set_grid.wgsl");

/// (uniform?, read-only?) per binding of the shader, in binding order (checked against it by the
/// `Params` mirror test).
const LAYOUT: [(bool, bool); 5] = [(true, true), (false, true), (false, true), (false, true), (false, false)];

/// The level-set kernel's uniform (`Params` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    lo: [f32; 4],
    hi: [f32; 4],
    bins: [u32; 4],
    origin: [f32; 4],
    dims: [u32; 4],
    phi: f32,
    iso: f32,
    row: u32,
    _pad: u32,
}

/// The level-set and marching-cubes kernels on one device.
pub struct GpuFoldSurface {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    cubes: GpuMarchingCubes,
}

impl GpuFoldSurface {
    pub fn new(device: &wgpu::Device) -> Self {
        let module =
            device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("level_set_grid"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = buffer_layout(device, "level_set_grid", &LAYOUT);
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("level_set_grid"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = compute_pipelines(device, &module, &pl, &["level_set_grid"]).remove("level_set_grid").expect("the entry point");
        GpuFoldSurface { pipeline, layout, cubes: GpuMarchingCubes::on_device(device) }
    }

    /// Records L of `set` at the nodes of `grid` into `field` (f32, x fastest; at least
    /// `grid.nodes()` values).
    pub fn record_level_set(&self, device: &wgpu::Device, enc: &mut wgpu::CommandEncoder, set: &KernelLevelSet, grid: &SurfaceGrid, field: &wgpu::Buffer) {
        let (lo, hi, bins) = set.bin_box();
        let (groups, row) = dispatch_grid(grid.nodes());
        let f = |a: [f64; 3], w: f64| [a[0] as f32, a[1] as f32, a[2] as f32, w as f32];
        let params = Params {
            lo: f(lo, set.re),
            hi: f(hi, set.r_min),
            bins: [bins[0] as u32, bins[1] as u32, bins[2] as u32, set.points.len() as u32],
            origin: f(grid.origin.to_array(), grid.spacing),
            dims: [grid.dims[0] as u32, grid.dims[1] as u32, grid.dims[2] as u32, grid.slab as u32],
            phi: set.phi as f32,
            iso: 0.0,
            row,
            _pad: 0,
        };
        let (start, order) = set.bin_lists();
        let points: Vec<[f32; 4]> = set.points.iter().map(|p| f(*p, 0.0)).collect();
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            // an empty list still needs a buffer (a body with no particles samples −φ)
            let contents = if contents.is_empty() { &[0u8; 16][..] } else { contents };
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
        };
        let uniform = init("level_set_grid params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM);
        let storage = wgpu::BufferUsages::STORAGE;
        let buffers = [
            uniform,
            init("level_set_grid points", bytemuck::cast_slice(&points), storage),
            init("level_set_grid bin starts", bytemuck::cast_slice(start), storage),
            init("level_set_grid bin order", bytemuck::cast_slice(order), storage),
        ];
        let mut entries: Vec<wgpu::BindGroupEntry> =
            buffers.iter().enumerate().map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() }).collect();
        entries.push(wgpu::BindGroupEntry { binding: 4, resource: field.as_entire_binding() });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("level_set_grid"), layout: &self.layout, entries: &entries });
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("level_set_grid"), timestamp_writes: None });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
    }

    /// Records the surfaces {L = 0} of `sets` (grid spacing `h` in the sets' unit, dimension
    /// `dim`) into `out`: its counter cleared, then per body k its level set and marching cubes,
    /// the triangles tagged k. The positions are in the sets' coordinates.
    pub fn record(&self, device: &wgpu::Device, enc: &mut wgpu::CommandEncoder, sets: &[KernelLevelSet], h: f64, dim: usize, out: &SurfaceBuffers) {
        enc.clear_buffer(out.counter, 0, None);
        for (k, set) in sets.iter().enumerate() {
            if set.points.is_empty() {
                continue;
            }
            let grid = SurfaceGrid::around(set, h, dim);
            let field = field_buffer(device, grid.nodes());
            self.record_level_set(device, enc, set, &grid, &field);
            let on_device = FieldOnDevice { values: &field, dims: grid.dims, origin: grid.origin, spacing: grid.spacing };
            self.cubes.record(device, enc, &on_device, 0.0, k as u32, out);
        }
    }

    /// L of `set` on its [`SurfaceGrid::around`], read back: the twin of
    /// [`crate::mesh::particle_field::level_set_grid`], for the tests.
    pub fn level_set_grid(&self, ctx: &GpuContext, set: &KernelLevelSet, h: f64, dim: usize) -> ScalarGrid {
        let grid = SurfaceGrid::around(set, h, dim);
        let field = field_buffer(&ctx.device, grid.nodes());
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.record_level_set(&ctx.device, &mut enc, set, &grid, &field);
        ctx.queue.submit([enc.finish()]);
        let values = bytemuck::cast_slice::<u8, f32>(&read_buffer(&ctx.device, &ctx.queue, &field))[..grid.nodes()].to_vec();
        ScalarGrid { dims: grid.dims, origin: grid.origin, spacing: grid.spacing, values }
    }
}

fn field_buffer(device: &wgpu::Device, nodes: usize) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("level_set_grid field"),
        size: 4 * nodes.max(4) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_bindings, check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror("shaders/level_set_grid.wgsl", super::SHADER, "Params", mirror!(Params { lo, hi, bins, origin, dims, phi, iso, row, _pad }));
        check_bindings("shaders/level_set_grid.wgsl", super::SHADER, 0, &super::LAYOUT);
    }
}
