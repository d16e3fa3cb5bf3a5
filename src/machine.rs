//! Facts about the machine that the physics core and the benchmarks need below the run layer:
//! the last-level cache (the benchmarks' sizes, the fluid's memory hints), and when a measured
//! rate may be called a fraction of the memory bandwidth.

/// The last-level cache of this CPU in bytes (Linux sysfs: the largest cache of cpu0, read once
/// per process), 32 MiB when it cannot be read.
pub fn last_level_cache_bytes() -> usize {
    static LLC: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *LLC.get_or_init(read_last_level_cache)
}

fn read_last_level_cache() -> usize {
    let parse = |s: &str| -> Option<usize> {
        let s = s.trim();
        let (num, unit) = s.split_at(s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len()));
        let k: usize = num.parse().ok()?;
        Some(match unit {
            "K" => k << 10,
            "M" => k << 20,
            "G" => k << 30,
            _ => k,
        })
    };
    (0..8)
        .filter_map(|i| std::fs::read_to_string(format!("/sys/devices/system/cpu/cpu0/cache/index{i}/size")).ok().and_then(|s| parse(&s)))
        .max()
        .unwrap_or(32 << 20)
}

/// The fraction `bytes_per_s` of the measured bandwidth `bw`, or `None` when the benchmark's data
/// (`footprint` bytes) is less than twice the last-level cache: such a run reads from the cache,
/// and a fraction of the memory bandwidth would overstate it.
pub fn fraction_of_bandwidth(bytes_per_s: f64, footprint: usize, bw: f64) -> Option<f64> {
    (footprint >= 2 * last_level_cache_bytes()).then_some(bytes_per_s / bw)
}
