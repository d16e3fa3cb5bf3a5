//! Prints the GPU adapter the GPU backend would use, its limits and whether it has timestamps.
fn main() {
    match phonation::gpu::GpuContext::new() {
        Ok(c) => println!(
            "{}\ntimestamps: {}\nmax storage binding: {} bytes\nmax buffer: {} bytes",
            c.describe(),
            c.timestamps,
            c.limits.max_storage_buffer_binding_size,
            c.limits.max_buffer_size
        ),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
