//! A headless wgpu device (no window, no Bevy): a real GPU when one exists, or Mesa's software
//! Vulkan ("lavapipe") on machines without one.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum GpuError {
    #[error("no GPU adapter found ({0}); on Linux without a GPU install Mesa's lavapipe (mesa-vulkan-drivers, libvulkan1)")]
    NoAdapter(String),
    #[error("requesting the device failed: {0}")]
    Device(String),
    #[error("{what} needs {bytes} bytes in one storage binding, more than the adapter's {limit}")]
    TooLarge { what: &'static str, bytes: u64, limit: u64 },
}

/// Device, queue and what the adapter is.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    /// Timestamp queries available (per-stage GPU timings).
    pub timestamps: bool,
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
        let required_features = if timestamps { wgpu::Features::TIMESTAMP_QUERY } else { wgpu::Features::empty() };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("phonation"),
            required_features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(GpuContext { device, queue, info, limits, timestamps })
    }

    /// Pretends the adapter allows at most `bytes` per storage binding, so that tests can drive
    /// the split-binding path ([`super::codegen::Split`]) on small lattices.
    pub fn with_binding_limit(mut self, bytes: u64) -> Self {
        self.limits.max_storage_buffer_binding_size = self.limits.max_storage_buffer_binding_size.min(bytes);
        self
    }

    /// One line naming the adapter, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)".
    pub fn describe(&self) -> String {
        format!("{} ({:?}, {:?})", self.info.name, self.info.backend, self.info.device_type)
    }
}
