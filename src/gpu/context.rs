//! A headless wgpu device (no window, no Bevy): a real GPU when one exists, or Mesa's software
//! Vulkan ("lavapipe") on machines without one.

use std::sync::{Arc, Mutex};
use thiserror::Error;

#[derive(Debug, Error)]
pub enum GpuError {
    #[error("no GPU adapter found ({0}); on Linux without a GPU install Mesa's lavapipe (mesa-vulkan-drivers, libvulkan1)")]
    NoAdapter(String),
    #[error("requesting the device failed: {0}")]
    Device(String),
    #[error("{what} needs {bytes} {unit}, more than the adapter's {limit_name} of {limit}")]
    TooLarge { what: &'static str, bytes: u64, limit: u64, unit: &'static str, limit_name: &'static str },
    #[error("the device failed while the state was uploaded: {0}")]
    Failed(String),
    /// A part of the scene that the GPU backend does not run (the message names the field).
    #[error("{0}")]
    Unsupported(String),
}

/// What went wrong with a device after it was opened — lost (driver reset, removed, destroyed),
/// out of memory, or a command it rejected — recorded by wgpu's callbacks instead of wgpu's
/// default panic, so that a run can stop with a diagnosis and keep the outputs written so far
/// (the run layer checks it after every advance). A loss outranks the errors it causes.
#[derive(Clone, Debug)]
pub struct DeviceHealth {
    state: Arc<Mutex<Health>>,
    device: wgpu::Device,
}

#[derive(Debug, Default)]
struct Health {
    lost: Option<String>,
    error: Option<String>,
}

impl DeviceHealth {
    /// Installs the callbacks on `device`.
    pub fn watch(device: &wgpu::Device) -> Self {
        let h = DeviceHealth { state: Arc::default(), device: device.clone() };
        let lost = h.state.clone();
        device.set_device_lost_callback(move |reason, msg| {
            let msg = if msg.is_empty() { String::new() } else { format!(": {msg}") };
            lost.lock().expect("device health").lost.get_or_insert_with(|| format!("device lost ({reason:?}){msg}"));
        });
        let err = h.state.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let what = match &e {
                wgpu::Error::OutOfMemory { .. } => format!("out of GPU memory: {e}"),
                _ => format!("the device rejected a command: {e}"),
            };
            eprintln!("gpu: {what}");
            err.lock().expect("device health").error.get_or_insert(what);
        }));
        h
    }

    /// A device whose failures its owner watches (Bevy's render device: Bevy installs its own
    /// callbacks, which this must not replace). [`Self::failure`] stays `None`; [`Self::settle`]
    /// still waits for the device.
    pub fn unwatched(device: &wgpu::Device) -> Self {
        DeviceHealth { state: Arc::default(), device: device.clone() }
    }

    /// The first failure since the device was opened, a loss first (None: healthy).
    pub fn failure(&self) -> Option<String> {
        let h = self.state.lock().expect("device health");
        h.lost.clone().or_else(|| h.error.clone())
    }

    /// Destroys the device (tests: what a driver reset does to a run).
    #[doc(hidden)]
    pub fn destroy_device(&self) {
        self.device.destroy();
    }

    /// The device watched (tests that exhaust its memory).
    #[doc(hidden)]
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// Waits for the work submitted so far, then [`Self::failure`].
    pub fn settle(&self) -> Option<String> {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
        self.failure()
    }
}

/// Device, queue and what the adapter is.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    /// Timestamp queries available (per-stage GPU timings).
    pub timestamps: bool,
    /// Loss and errors of the device since it was opened.
    pub health: DeviceHealth,
}

impl GpuContext {
    /// Opens the best adapter (high performance first). Raises the storage limits to what the
    /// adapter allows, so that large lattices fit.
    pub fn new() -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor { backends: wgpu::Backends::all(), ..wgpu::InstanceDescriptor::new_without_display_handle() });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let supported = adapter.limits();
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: supported.max_storage_buffer_binding_size,
            max_buffer_size: supported.max_buffer_size,
            max_storage_buffers_per_shader_stage: supported.max_storage_buffers_per_shader_stage.min(64),
            max_compute_workgroups_per_dimension: supported.max_compute_workgroups_per_dimension,
            ..wgpu::Limits::default()
        };
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        // f64 in shaders where the adapter has it: method 2's level-set questions
        // (`super::level_set_queries`)
        let required_features = adapter.features() & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::SHADER_F64);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("phonation"),
            required_features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        let health = DeviceHealth::watch(&device);
        Ok(GpuContext { device, queue, info, limits, timestamps, health })
    }

    /// A device opened by someone else (Bevy's render device) with the limits it was opened
    /// with; its failures are left to its owner ([`DeviceHealth::unwatched`]).
    pub fn shared(device: wgpu::Device, queue: wgpu::Queue, info: wgpu::AdapterInfo, limits: wgpu::Limits) -> Self {
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let health = DeviceHealth::unwatched(&device);
        GpuContext { device, queue, info, limits, timestamps, health }
    }

    /// Pretends the adapter allows at most `bytes` per storage binding, so that tests can drive
    /// the split-binding path ([`super::codegen::Split`]) on small lattices.
    pub fn with_binding_limit(mut self, bytes: u64) -> Self {
        self.limits.max_storage_buffer_binding_size = self.limits.max_storage_buffer_binding_size.min(bytes);
        self
    }

    /// Pretends the adapter allows at most `bytes` per buffer (tests of the refusals).
    pub fn with_buffer_limit(mut self, bytes: u64) -> Self {
        self.limits.max_buffer_size = self.limits.max_buffer_size.min(bytes);
        self
    }

    /// One line naming the adapter, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)".
    pub fn describe(&self) -> String {
        format!("{} ({:?}, {:?})", self.info.name, self.info.backend, self.info.device_type)
    }
}

/// Workgroups of 64 threads for `threads` threads (2D past 65,535 along x), and the threads in
/// a row of that grid: a kernel's thread index is `gid.x + gid.y · row`.
pub fn dispatch_grid(threads: usize) -> ((u32, u32), u32) {
    let groups = (threads as u32).div_ceil(64).max(1);
    let (gx, gy) = if groups <= 65_535 { (groups, 1) } else { (65_535, groups.div_ceil(65_535)) };
    ((gx, gy), gx * 64)
}

/// Copies a storage buffer into a mappable one and reads it back (blocks until done). When the
/// read fails (a lost device, no memory left for the staging buffer) zeros of the buffer's size
/// come back, and the run layer, which checks the device's health after every advance, stops
/// with the failure; a reader whose outputs must not see those zeros uses [`try_read_buffer`].
pub fn read_buffer(device: &wgpu::Device, queue: &wgpu::Queue, b: &wgpu::Buffer) -> Vec<u8> {
    try_read_buffer(device, queue, b).unwrap_or_else(|| vec![0; b.size() as usize])
}

/// [`read_buffer`], or None when the read fails (nothing allocated for the failed read).
pub fn try_read_buffer(device: &wgpu::Device, queue: &wgpu::Queue, b: &wgpu::Buffer) -> Option<Vec<u8>> {
    try_read_ranges(device, queue, b, &[(0, b.size())])
}

/// The byte ranges (offset, length; multiples of 4) of `b`, one after the other, or None when
/// the read fails: one staging buffer, one copy per range.
pub fn try_read_ranges(device: &wgpu::Device, queue: &wgpu::Queue, b: &wgpu::Buffer, ranges: &[(u64, u64)]) -> Option<Vec<u8>> {
    let parts: Vec<(&wgpu::Buffer, u64, u64)> = ranges.iter().map(|&(o, l)| (b, o, l)).collect();
    try_read_parts(device, queue, &parts)
}

/// The bytes of one trip's read cut back into its parts of `lengths` bytes, in order.
pub fn split_read(all: &[u8], lengths: impl IntoIterator<Item = u64>) -> Vec<Vec<u8>> {
    let mut at = 0;
    lengths
        .into_iter()
        .map(|len| {
            let part = all[at..at + len as usize].to_vec();
            at += len as usize;
            part
        })
        .collect()
}

/// The byte ranges (buffer, offset, length; multiples of 4), one after the other in one staging
/// buffer, or None when the read fails.
fn try_read_parts(device: &wgpu::Device, queue: &wgpu::Queue, parts: &[(&wgpu::Buffer, u64, u64)]) -> Option<Vec<u8>> {
    let size: u64 = parts.iter().map(|r| r.2).sum();
    if size == 0 {
        return Some(Vec::new());
    }
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    try_read_parts_into(device, queue, device.create_command_encoder(&Default::default()), parts, &staging)
}

/// `enc`'s commands, then the byte ranges (buffer, offset, length; multiples of 4) copied one
/// after the other into `staging` (MAP_READ | COPY_DST, large enough; kept by the caller, so
/// that the read makes no buffer) and read from there, in one submission and one wait; None
/// when the read fails.
pub fn try_read_parts_into(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mut enc: wgpu::CommandEncoder,
    parts: &[(&wgpu::Buffer, u64, u64)],
    staging: &wgpu::Buffer,
) -> Option<Vec<u8>> {
    let size: u64 = parts.iter().map(|r| r.2).sum();
    let mut at = 0;
    for &(b, offset, len) in parts {
        enc.copy_buffer_to_buffer(b, offset, staging, at, len);
        at += len;
    }
    if size == 0 {
        queue.submit([enc.finish()]);
        return Some(Vec::new());
    }
    submit_and_map(device, queue, enc, staging, size)
}

/// All of `b` copied into `staging` (MAP_READ | COPY_DST, at least as large; made once by the
/// caller) and read from there: a read that allocates nothing on the device. None when it fails.
pub fn try_read_into(device: &wgpu::Device, queue: &wgpu::Queue, b: &wgpu::Buffer, staging: &wgpu::Buffer) -> Option<Vec<u8>> {
    let mut enc = device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(b, 0, staging, 0, b.size());
    submit_and_map(device, queue, enc, staging, b.size())
}

/// Submits `enc` (its copies into `staging`), waits for the device and reads the first `size`
/// bytes of `staging` back; None when the mapping fails (the device lost, or `staging` never
/// made for want of memory).
fn submit_and_map(device: &wgpu::Device, queue: &wgpu::Queue, enc: wgpu::CommandEncoder, staging: &wgpu::Buffer, size: u64) -> Option<Vec<u8>> {
    queue.submit([enc.finish()]);
    let slice = staging.slice(..size);
    let mapped = Arc::new(Mutex::new(None));
    let done = mapped.clone();
    slice.map_async(wgpu::MapMode::Read, move |r| *done.lock().expect("readback") = Some(r));
    let _ = device.poll(wgpu::PollType::wait_indefinitely());
    if !matches!(mapped.lock().expect("readback").take(), Some(Ok(()))) {
        eprintln!("gpu: reading a buffer back failed (device lost or out of memory)");
        return None;
    }
    let out = slice.get_mapped_range().to_vec();
    staging.unmap();
    Some(out)
}

/// Compute pipelines for the named entry points of one module, sharing a pipeline layout.
pub fn compute_pipelines(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    entries: &[&'static str],
) -> std::collections::HashMap<&'static str, wgpu::ComputePipeline> {
    entries
        .iter()
        .map(|e| {
            let desc = wgpu::ComputePipelineDescriptor {
                label: Some(e),
                layout: Some(layout),
                module,
                entry_point: Some(e),
                compilation_options: Default::default(),
                cache: None,
            };
            (*e, device.create_compute_pipeline(&desc))
        })
        .collect()
}

/// A bind-group layout of buffers for compute: per binding (uniform?, read-only storage?).
pub fn buffer_layout(device: &wgpu::Device, label: &str, kinds: &[(bool, bool)]) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = kinds
        .iter()
        .enumerate()
        .map(|(k, (uniform, ro))| wgpu::BindGroupLayoutEntry {
            binding: k as u32,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: if *uniform { wgpu::BufferBindingType::Uniform } else { wgpu::BufferBindingType::Storage { read_only: *ro } },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        })
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries: &entries })
}

/// Timestamp queries around the compute passes of one step's stages (per-stage GPU timings):
/// pass i writes its start and end into slots 2i and 2i + 1.
pub struct StageTimestamps {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    stages: usize,
    /// Seconds per timestamp tick.
    period: f64,
    /// Summed GPU seconds per stage.
    pub total: Vec<f64>,
}

impl StageTimestamps {
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, stages: usize) -> Self {
        let count = 2 * stages as u32;
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor { label: Some("stage timestamps"), ty: wgpu::QueryType::Timestamp, count });
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: 8 * count as u64,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Self { queries, resolve, stages, period: queue.get_timestamp_period() as f64 * 1e-9, total: vec![0.0; stages] }
    }

    /// The pass descriptor of stage i.
    pub fn pass(&self, i: usize, label: &'static str) -> wgpu::ComputePassDescriptor<'_> {
        let tw = wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(2 * i as u32),
            end_of_pass_write_index: Some(2 * i as u32 + 1),
        };
        wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: Some(tw) }
    }

    /// Records the copy of the step's timestamps (after the stages' passes).
    pub fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&self.queries, 0..2 * self.stages as u32, &self.resolve, 0);
    }

    /// After the step's submission: reads the timestamps back and adds each stage's time.
    pub fn accumulate(&mut self, device: &wgpu::Device, queue: &wgpu::Queue) {
        let ts: Vec<u64> = bytemuck::cast_slice(&read_buffer(device, queue, &self.resolve)).to_vec();
        for (i, t) in self.total.iter_mut().enumerate() {
            *t += ts[2 * i + 1].saturating_sub(ts[2 * i]) as f64 * self.period;
        }
    }
}
