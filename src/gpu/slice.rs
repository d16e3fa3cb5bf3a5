//! A plane of a GPU-stepped FDLB lattice as a colour-mapped RGBA8 image made on the device
//! (shaders/slice.wgsl): the plane's moments from the populations of the last completed step
//! (the probe kernel, [`GpuFluid::moments_at`]), the values in scene units, the colour scale's
//! range reduced on the device, the pixels in rows from the top padded to 256 bytes, ready to
//! be copied into a texture — the twin of `output::fields::slice` with
//! `output::png_map::rgba_top_down` (the PNG snapshots' maps). Only the two ends of the range
//! need to come back (for a legend).

use super::context::{GpuContext, buffer_layout, compute_pipelines, dispatch_grid, read_buffer};
use super::fdlb::{GpuFluid, MomentsAt};
use crate::fluid::Grid;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

pub(crate) const SHADER: &str = include_str!("../../shaders/slice.wgsl");

/// (uniform?, read-only?) per binding of the shader, in binding order (checked against it by the
/// `Params` mirror test).
const LAYOUT: [(bool, bool); 6] = [(true, true), (false, true), (false, true), (false, false), (false, false), (false, false)];

/// What a pixel shows: the lattice quantity q and the map to scene units, (q − `offset`) ·
/// `scale` (vorticity: ω_z · `scale`), on the signed (diverging) map or not.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneMap {
    pub quantity: Quantity,
    pub scale: f64,
    pub offset: f64,
    pub signed: bool,
}

/// The lattice quantity of a plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// ρ
    Density = 0,
    /// |u|
    Speed = 1,
    /// p = ρθ
    Pressure = 2,
    /// θ
    Temperature = 3,
    /// ω_z = ∂u_y/∂x − ∂u_x/∂y by central differences (0 next to a wall)
    Vorticity = 4,
}

/// The kernels' uniform (`Params` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Params {
    n: [u32; 4],
    halo: [u32; 4],
    padded: [u32; 4],
    scale: f32,
    offset: f32,
    row_words: u32,
    _pad: u32,
}

/// The kernels and buffers of one plane of one lattice.
pub struct GpuSlice {
    moments_at: MomentsAt,
    moments: wgpu::Buffer,
    pipelines: [wgpu::ComputePipeline; 3],
    group: wgpu::BindGroup,
    range: wgpu::Buffer,
    pixels: wgpu::Buffer,
    nx: u32,
    ny: u32,
    row_words: u32,
}

impl GpuSlice {
    /// The z = n_z/2 plane of `fluid` (whose lattice is `grid`) drawn as `map` says.
    pub fn new(device: &wgpu::Device, fluid: &GpuFluid, grid: &Grid, map: PlaneMap) -> Self {
        let kind = fluid.macro_buffers().1;
        let z = (grid.n[2] / 2) as i64;
        let plane: Vec<usize> = (0..grid.n[1] as i64).flat_map(|y| (0..grid.n[0] as i64).map(move |x| grid.index([x, y, z]))).collect();
        let moments_at = fluid.moments_at(&plane);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("slice"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = buffer_layout(device, "slice", &LAYOUT);
        let pl =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("slice"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let mut map_of = compute_pipelines(device, &module, &pl, &["slice_values", "slice_range", "slice_colour"]);
        let pipelines = ["slice_values", "slice_range", "slice_colour"].map(|e| map_of.remove(e).expect("an entry point"));
        let (nx, ny) = (grid.n[0] as u32, grid.n[1] as u32);
        // rows padded to 256 bytes (wgpu's COPY_BYTES_PER_ROW_ALIGNMENT): 64 pixels
        let row_words = nx.div_ceil(64) * 64;
        let params = Params {
            n: [nx, ny, (grid.n[2] / 2) as u32, map.quantity as u32],
            halo: [grid.halo[0] as u32, grid.halo[1] as u32, grid.halo[2] as u32, map.signed as u32],
            padded: [grid.padded[0] as u32, grid.padded[1] as u32, grid.padded[2] as u32, 0],
            scale: map.scale as f32,
            offset: map.offset as f32,
            row_words,
            _pad: 0,
        };
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("slice params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let storage = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let moments = storage("slice moments", 4 * (1 + 5 * plane.len()) as u64);
        let values = storage("slice values", 4 * (nx * ny) as u64);
        let range = storage("slice range", 16);
        let pixels = storage("slice pixels", 4 * (row_words * ny) as u64);
        let buffers = [&uniform, &moments, kind, &values, &range, &pixels];
        let entries: Vec<wgpu::BindGroupEntry> =
            buffers.iter().enumerate().map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() }).collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("slice"), layout: &layout, entries: &entries });
        GpuSlice { moments_at, moments, pipelines, group, range, pixels, nx, ny, row_words }
    }

    /// Records the plane's moments and the three passes into `enc` (`fluid`: the lattice this
    /// slice was made for).
    pub fn record(&self, fluid: &GpuFluid, enc: &mut wgpu::CommandEncoder) {
        fluid.record_moments(enc, &self.moments_at, &self.moments);
        let ((gx, gy), _) = dispatch_grid((self.nx * self.ny) as usize);
        for (k, p) in self.pipelines.iter().enumerate() {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("slice"), timestamp_writes: None });
            pass.set_pipeline(p);
            pass.set_bind_group(0, &self.group, &[]);
            if k == 1 { pass.dispatch_workgroups(1, 1, 1) } else { pass.dispatch_workgroups(gx, gy, 1) }
        }
    }

    /// The pixels: RGBA8 rows from the top, `bytes_per_row` apart.
    pub fn pixels(&self) -> &wgpu::Buffer {
        &self.pixels
    }

    /// The colour scale's ends (two f32, scene units).
    pub fn range(&self) -> &wgpu::Buffer {
        &self.range
    }

    pub fn bytes_per_row(&self) -> u32 {
        4 * self.row_words
    }

    /// Image size (pixels).
    pub fn size(&self) -> (u32, u32) {
        (self.nx, self.ny)
    }

    /// The image (RGBA8, rows from the top, unpadded) and the range, read back: for the tests.
    pub fn download(&self, ctx: &GpuContext) -> (Vec<u8>, (f64, f64)) {
        let px = read_buffer(&ctx.device, &ctx.queue, &self.pixels);
        let r = read_buffer(&ctx.device, &ctx.queue, &self.range);
        let r: &[f32] = bytemuck::cast_slice(&r);
        let row = self.bytes_per_row() as usize;
        let data = (0..self.ny as usize).flat_map(|y| px[y * row..y * row + 4 * self.nx as usize].to_vec()).collect();
        (data, (r[0] as f64, r[1] as f64))
    }
}

#[cfg(test)]
mod mirror_tests {
    use super::Params;
    use crate::gpu::wgsl_check::{check_bindings, check_mirror, mirror};

    #[test]
    fn params_match_the_shader_layout() {
        check_mirror("shaders/slice.wgsl", super::SHADER, "Params", mirror!(Params { n, halo, padded, scale, offset, row_words, _pad }));
        check_bindings("shaders/slice.wgsl", super::SHADER, 0, &super::LAYOUT);
    }
}
