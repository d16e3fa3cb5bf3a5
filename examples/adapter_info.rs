//! Prints the GPU adapter the GPU backend would use, its limits and whether it has timestamps.
fn main() {
    match phonation::gpu::GpuContext::new() {
        Ok(c) => {
            println!("{}", c.describe());
            println!("timestamps: {}", c.timestamps);
            println!("max storage binding: {} bytes", c.limits.max_storage_buffer_binding_size);
            println!("max buffer: {} bytes", c.limits.max_buffer_size);
            println!("storage buffers per shader stage: {}", c.limits.max_storage_buffers_per_shader_stage);
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
