//! Marching cubes on the GPU (shaders/marching_cubes.wgsl, f32): the twin of
//! [`crate::mesh::extract`], reading the same generated case table
//! ([`crate::mesh::marching_cubes::CASES`], uploaded once). It appends each cell's triangles
//! with one atomic counter: the order of the cells in the output is the scheduler's (a
//! drawing does not care; [`GpuMarchingCubes::extract`] sorts them back for a comparison).
//! The kernel writes three unindexed vertices per triangle, so a renderer can draw the
//! buffers as they are, with the counter as the draw's vertex count / 3.

use super::context::{GpuContext, buffer_layout, compute_pipelines, read_buffer};
use crate::mesh::marching_cubes::{CASES, ScalarGrid};
use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use wgpu::util::DeviceExt;

const SHADER: &str = include_str!("../../shaders/marching_cubes.wgsl");
const WORKGROUP: u32 = 64;

/// The kernel's uniform (`Params` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    dims: [u32; 4],
    origin: [f32; 4],
    iso: f32,
    capacity: u32,
    row: u32,
    _pad: u32,
}

/// One triangle as the GPU made it: its grid cell, its rank among the cell's triangles, and
/// its three vertices' positions and unit normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuTriangle {
    pub cell: u32,
    pub rank: u32,
    pub positions: [DVec3; 3],
    pub normals: [DVec3; 3],
}

/// The compiled kernel and the case table on the device.
pub struct GpuMarchingCubes {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    table: wgpu::Buffer,
}

impl GpuMarchingCubes {
    pub fn new(ctx: &GpuContext) -> Self {
        let device = &ctx.device;
        let module =
            device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("marching_cubes"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = buffer_layout(device, "marching_cubes", &[(true, true), (false, true), (false, true), (false, false), (false, false), (false, false)]);
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

    /// The kernel's buffers and bind group for `grid`, and its dispatch size.
    fn prepare(&self, ctx: &GpuContext, grid: &ScalarGrid, iso: f32, capacity: u32) -> Prepared {
        let device = &ctx.device;
        let cells = grid.cells() as u32;
        let groups = cells.div_ceil(WORKGROUP).max(1);
        let (gx, gy) = if groups <= 65_535 { (groups, 1) } else { (65_535, groups.div_ceil(65_535)) };
        let params = Params {
            dims: [grid.dims[0] as u32, grid.dims[1] as u32, grid.dims[2] as u32, 1 + 3 * CASES.max_triangles() as u32],
            origin: [grid.origin.x as f32, grid.origin.y as f32, grid.origin.z as f32, grid.spacing as f32],
            iso,
            capacity,
            row: gx * WORKGROUP,
            _pad: 0,
        };
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
        };
        let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let uniform = init("marching_cubes params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM);
        let field = init("marching_cubes field", bytemuck::cast_slice(&grid.values), wgpu::BufferUsages::STORAGE);
        let counter = init("marching_cubes counter", bytemuck::cast_slice(&[0u32; 4]), rw);
        let out = vec![[0f32; 4]; 3 * capacity.max(1) as usize];
        let positions = init("marching_cubes positions", bytemuck::cast_slice(&out), rw);
        let normals = init("marching_cubes normals", bytemuck::cast_slice(&out), rw);
        let buffers = [&uniform, &field, &self.table, &counter, &positions, &normals];
        let entries: Vec<wgpu::BindGroupEntry> =
            buffers.iter().enumerate().map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() }).collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("marching_cubes"), layout: &self.layout, entries: &entries });
        Prepared { group, counter, positions, normals, groups: (gx, gy) }
    }

    fn dispatch(&self, ctx: &GpuContext, p: &Prepared) {
        ctx.queue.write_buffer(&p.counter, 0, bytemuck::cast_slice(&[0u32; 4]));
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("marching_cubes"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &p.group, &[]);
            pass.dispatch_workgroups(p.groups.0, p.groups.1, 1);
        }
        ctx.queue.submit([enc.finish()]);
    }

    /// Best-of-`reps` wall time (s) of one extraction on the device (dispatch to completion, no
    /// readback), for the benchmark.
    pub fn kernel_seconds(&self, ctx: &GpuContext, grid: &ScalarGrid, iso: f32, capacity: u32, reps: usize) -> f64 {
        let p = self.prepare(ctx, grid, iso, capacity);
        let mut best = f64::INFINITY;
        for _ in 0..reps {
            let t = std::time::Instant::now();
            self.dispatch(ctx, &p);
            let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
            best = best.min(t.elapsed().as_secs_f64());
        }
        best
    }

    /// The triangles of {f = iso} of `grid` (inside f > iso), at most `capacity` of them
    /// written, and how many the kernel counted (more than `capacity` means the buffers were
    /// too small). Sorted by (cell, rank): the CPU twin's order.
    pub fn extract(&self, ctx: &GpuContext, grid: &ScalarGrid, iso: f32, capacity: u32) -> (Vec<GpuTriangle>, u32) {
        let device = &ctx.device;
        let p = self.prepare(ctx, grid, iso, capacity);
        self.dispatch(ctx, &p);
        let count = bytemuck::cast_slice::<u8, u32>(&read_buffer(device, &ctx.queue, &p.counter))[0];
        let pos_bytes = read_buffer(device, &ctx.queue, &p.positions);
        let nor_bytes = read_buffer(device, &ctx.queue, &p.normals);
        let (p, n): (&[[f32; 4]], &[[f32; 4]]) = (bytemuck::cast_slice(&pos_bytes), bytemuck::cast_slice(&nor_bytes));
        let v = |a: [f32; 4]| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
        let mut tris: Vec<GpuTriangle> = (0..count.min(capacity) as usize)
            .map(|t| GpuTriangle {
                cell: p[3 * t][3].to_bits(),
                rank: p[3 * t + 1][3].to_bits(),
                positions: [v(p[3 * t]), v(p[3 * t + 1]), v(p[3 * t + 2])],
                normals: [v(n[3 * t]), v(n[3 * t + 1]), v(n[3 * t + 2])],
            })
            .collect();
        tris.sort_by_key(|t| (t.cell, t.rank));
        (tris, count)
    }
}

/// The buffers of one extraction.
struct Prepared {
    group: wgpu::BindGroup,
    counter: wgpu::Buffer,
    positions: wgpu::Buffer,
    normals: wgpu::Buffer,
    groups: (u32, u32),
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror("shaders/marching_cubes.wgsl", super::SHADER, "Params", mirror!(Params { dims, origin, iso, capacity, row, _pad }));
    }
}
