//! Marching cubes on the GPU (shaders/marching_cubes.wgsl, f32): the twin of
//! [`crate::mesh::extract`], reading the same generated case table
//! ([`crate::mesh::marching_cubes::CASES`], uploaded once). It appends each cell's triangles
//! with one atomic counter: the order of the cells in the output is the scheduler's (a
//! drawing does not care; [`GpuMarchingCubes::extract`] sorts them back for a comparison).
//! The kernel writes three unindexed vertices per triangle, so a renderer can draw the
//! buffers as they are, with the counter as the draw's vertex count / 3.

use super::context::{GpuContext, buffer_layout, compute_pipelines, dispatch_grid, read_buffer};
use crate::mesh::marching_cubes::{CASES, ScalarGrid};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use wgpu::util::DeviceExt;

const SHADER: &str = include_str!("../../shaders/marching_cubes.wgsl");

/// (uniform?, read-only?) per binding of the shader, in binding order (checked against it by the
/// `Params` mirror test).
const LAYOUT: [(bool, bool); 6] = [(true, true), (false, true), (false, true), (false, false), (false, false), (false, false)];

/// The kernel's uniform (`Params` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    dims: [u32; 4],
    origin: [f32; 4],
    iso: f32,
    capacity: u32,
    row: u32,
    body: u32,
}

/// One triangle as the GPU made it: its body (the tag of the extraction that made it), its
/// grid cell, its rank among the cell's triangles, and its three vertices' positions and unit
/// normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuTriangle {
    pub body: u32,
    pub cell: u32,
    pub rank: u32,
    pub positions: [DVec3; 3],
    pub normals: [DVec3; 3],
}

/// Where the kernel appends its triangles: the counter (`[0]`: triangles emitted, cleared by
/// the caller before the first extraction of a frame), three vec4 positions and three vec4
/// normals per triangle (`normals[..].w`: the body tag), room for `capacity` triangles.
pub struct SurfaceBuffers<'a> {
    pub counter: &'a wgpu::Buffer,
    pub positions: &'a wgpu::Buffer,
    pub normals: &'a wgpu::Buffer,
    pub capacity: u32,
}

/// The scalar field a kernel reads: `dims` nodes (x fastest) from `origin`, `spacing` apart.
pub struct FieldOnDevice<'a> {
    pub values: &'a wgpu::Buffer,
    pub dims: [usize; 3],
    pub origin: DVec3,
    pub spacing: f64,
}

/// The compiled kernel and the case table on the device.
pub struct GpuMarchingCubes {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    table: wgpu::Buffer,
}

impl GpuMarchingCubes {
    pub fn new(ctx: &GpuContext) -> Self {
        Self::on_device(&ctx.device)
    }

    /// The kernel on any device (Bevy's render device in the plugin).
    pub fn on_device(device: &wgpu::Device) -> Self {
        let module =
            device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("marching_cubes"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = buffer_layout(device, "marching_cubes", &LAYOUT);
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("marching_cubes"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = compute_pipelines(device, &module, &pl, &["marching_cubes"]).remove("marching_cubes").expect("the entry point");
        let table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("marching_cubes table"),
            contents: bytemuck::cast_slice(&CASES.packed()),
            usage: wgpu::BufferUsages::STORAGE,
        });
        Self { pipeline, layout, table }
    }

    /// Records one extraction of {f = iso} of `field` (inside f > iso) into `enc`, appending to
    /// `out` with its triangles tagged `body`; no readback.
    pub fn record(&self, device: &wgpu::Device, enc: &mut wgpu::CommandEncoder, field: &FieldOnDevice, iso: f32, body: u32, out: &SurfaceBuffers) {
        let cells: usize = field.dims.iter().map(|d| d.saturating_sub(1)).product();
        let (groups, row) = dispatch_grid(cells);
        let o = field.origin;
        let params = Params {
            dims: [field.dims[0] as u32, field.dims[1] as u32, field.dims[2] as u32, 1 + 3 * CASES.max_triangles() as u32],
            origin: [o.x as f32, o.y as f32, o.z as f32, field.spacing as f32],
            iso,
            capacity: out.capacity,
            row,
            body,
        };
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("marching_cubes params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let buffers = [&uniform, field.values, &self.table, out.counter, out.positions, out.normals];
        let entries: Vec<wgpu::BindGroupEntry> =
            buffers.iter().enumerate().map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() }).collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("marching_cubes"), layout: &self.layout, entries: &entries });
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("marching_cubes"), timestamp_writes: None });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
    }

    /// Best-of-`reps` wall time (s) of one extraction on the device (dispatch to completion, no
    /// readback), for the benchmark.
    pub fn kernel_seconds(&self, ctx: &GpuContext, grid: &ScalarGrid, iso: f32, capacity: u32, reps: usize) -> f64 {
        let (field, out) = (upload_field(&ctx.device, grid), OwnedSurface::new(&ctx.device, capacity));
        let mut best = f64::INFINITY;
        for _ in 0..reps {
            let t = std::time::Instant::now();
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            enc.clear_buffer(&out.counter, 0, None);
            self.record(&ctx.device, &mut enc, &field_of(grid, &field), iso, 0, &out.buffers());
            ctx.queue.submit([enc.finish()]);
            let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
            best = best.min(t.elapsed().as_secs_f64());
        }
        best
    }

    /// The triangles of {f = iso} of `grid` (inside f > iso), at most `capacity` of them
    /// written, and how many the kernel counted (more than `capacity` means the buffers were
    /// too small). Sorted by (cell, rank): the CPU twin's order.
    pub fn extract(&self, ctx: &GpuContext, grid: &ScalarGrid, iso: f32, capacity: u32) -> (Vec<GpuTriangle>, u32) {
        let (field, out) = (upload_field(&ctx.device, grid), OwnedSurface::new(&ctx.device, capacity));
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.record(&ctx.device, &mut enc, &field_of(grid, &field), iso, 0, &out.buffers());
        ctx.queue.submit([enc.finish()]);
        out.download(ctx)
    }
}

fn upload_field(device: &wgpu::Device, grid: &ScalarGrid) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("marching_cubes field"),
        contents: bytemuck::cast_slice(&grid.values),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

fn field_of<'a>(grid: &ScalarGrid, values: &'a wgpu::Buffer) -> FieldOnDevice<'a> {
    FieldOnDevice { values, dims: grid.dims, origin: grid.origin, spacing: grid.spacing }
}

/// Output buffers of its own (the tests' and the benchmark's extractions; the plugin draws
/// from buffers Bevy owns).
pub struct OwnedSurface {
    pub counter: wgpu::Buffer,
    pub positions: wgpu::Buffer,
    pub normals: wgpu::Buffer,
    pub capacity: u32,
}

impl OwnedSurface {
    /// Zeroed buffers for `capacity` triangles (at least one).
    pub fn new(device: &wgpu::Device, capacity: u32) -> Self {
        let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let zeroed = |label: &str, size: u64| device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage: rw, mapped_at_creation: false });
        let vertices = 3 * 16 * capacity.max(1) as u64;
        OwnedSurface {
            counter: zeroed("marching_cubes counter", 16),
            positions: zeroed("marching_cubes positions", vertices),
            normals: zeroed("marching_cubes normals", vertices),
            capacity,
        }
    }

    pub fn buffers(&self) -> SurfaceBuffers<'_> {
        SurfaceBuffers { counter: &self.counter, positions: &self.positions, normals: &self.normals, capacity: self.capacity }
    }

    /// The triangles written (sorted by body, cell and rank: the CPU twin's order within a body)
    /// and how many the kernels counted.
    pub fn download(&self, ctx: &GpuContext) -> (Vec<GpuTriangle>, u32) {
        let device = &ctx.device;
        let count = bytemuck::cast_slice::<u8, u32>(&read_buffer(device, &ctx.queue, &self.counter))[0];
        let pos_bytes = read_buffer(device, &ctx.queue, &self.positions);
        let nor_bytes = read_buffer(device, &ctx.queue, &self.normals);
        let (p, n): (&[[f32; 4]], &[[f32; 4]]) = (bytemuck::cast_slice(&pos_bytes), bytemuck::cast_slice(&nor_bytes));
        let v = |a: [f32; 4]| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
        let mut tris: Vec<GpuTriangle> = (0..count.min(self.capacity) as usize)
            .map(|t| GpuTriangle {
                body: n[3 * t][3] as u32,
                cell: p[3 * t][3].to_bits(),
                rank: p[3 * t + 1][3].to_bits(),
                positions: [v(p[3 * t]), v(p[3 * t + 1]), v(p[3 * t + 2])],
                normals: [v(n[3 * t]), v(n[3 * t + 1]), v(n[3 * t + 2])],
            })
            .collect();
        tris.sort_by_key(|t| (t.body, t.cell, t.rank));
        (tris, count)
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_bindings, check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror("shaders/marching_cubes.wgsl", super::SHADER, "Params", mirror!(Params { dims, origin, iso, capacity, row, body }));
        check_bindings("shaders/marching_cubes.wgsl", super::SHADER, 0, &super::LAYOUT);
    }
}
