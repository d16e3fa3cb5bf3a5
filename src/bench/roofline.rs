//! What the machine itself reaches, measured in the bench's own process: the memory bandwidth
//! of a STREAM-like triad and the f64 FMA peak — the roofs every kernel's figure is a fraction of.

use super::*;

/// The memory bandwidth the triad a\[i\] = b\[i\] + s·c\[i\] reaches (3 × 8 bytes per element, the
/// STREAM convention), over repetitions: the machines are shared, so the best is the figure the
/// fractions use and the spread says how much to trust it.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Bandwidth {
    /// Bytes/s of the fastest, median and slowest repetition.
    pub best: f64,
    pub median: f64,
    pub worst: f64,
    pub repetitions: usize,
    /// Bytes of each of the three arrays.
    pub array_bytes: usize,
}

/// The triad over `n` f64 per array, `reps` times (the arrays should be well beyond the
/// last-level cache: [`last_level_cache_bytes`]).
pub fn triad(n: usize, reps: usize) -> Bandwidth {
    let mut a = vec![0.0f64; n];
    let b: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let c: Vec<f64> = (0..n).map(|i| (n - i) as f64).collect();
    let mut times = Vec::with_capacity(reps);
    // a first, untimed pass maps a's pages (a freshly allocated zeroed vector is mapped on first
    // write, which would otherwise count against the first repetition)
    a.par_chunks_mut(1 << 16).for_each(|a| a.fill(1.0));
    for r in 0..reps.max(1) {
        let s = 1.0 + r as f64 * 1e-3;
        let t = Instant::now();
        a.par_chunks_mut(1 << 16).zip(b.par_chunks(1 << 16)).zip(c.par_chunks(1 << 16)).for_each(|((a, b), c)| {
            for i in 0..a.len() {
                a[i] = b[i] + s * c[i];
            }
        });
        times.push(t.elapsed().as_secs_f64());
    }
    std::hint::black_box(&a);
    times.sort_by(f64::total_cmp);
    let rate = |t: f64| 24.0 * n as f64 / t;
    Bandwidth { best: rate(times[0]), median: rate(times[times.len() / 2]), worst: rate(times[times.len() - 1]), repetitions: times.len(), array_bytes: 8 * n }
}

/// The f64 arithmetic rate of the CPU, all threads, over repetitions (flop/s; an FMA counts 2).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct FlopRate {
    pub best: f64,
    pub median: f64,
    pub repetitions: usize,
}

/// Independent FMA chains per thread: enough to cover the FMA latency on every FMA port (4
/// cycles × 2 ports × 8 f64 lanes with AVX-512, twice what AVX2 needs) so that the loop runs at
/// the ports' throughput.
pub(super) const FMA_CHAINS: usize = 64;

/// The peak f64 rate of the roofline: every rayon thread runs `FMA_CHAINS` independent chains
/// of `a = a · b + c` (vectorised, FMA where the CPU has it — this build's own instruction
/// set), `reps` times, in registers (no memory traffic).
pub fn fma_peak(reps: usize) -> FlopRate {
    const ITERATIONS: usize = 1 << 22;
    let threads = rayon::current_num_threads();
    let mut rates: Vec<f64> = (0..reps.max(1))
        .map(|r| {
            let t = Instant::now();
            let sum: f64 = (0..threads)
                .into_par_iter()
                .map(|i| {
                    let mut a = [1.0 + (i + r) as f64 * 1e-9; FMA_CHAINS];
                    let (b, c) = (std::hint::black_box(0.999_999_9), std::hint::black_box(1e-7));
                    for _ in 0..ITERATIONS {
                        for x in a.iter_mut() {
                            *x = x.mul_add(b, c);
                        }
                    }
                    a.iter().sum::<f64>()
                })
                .sum();
            std::hint::black_box(sum);
            2.0 * (FMA_CHAINS * ITERATIONS * threads) as f64 / t.elapsed().as_secs_f64()
        })
        .collect();
    rates.sort_by(|a, b| b.total_cmp(a));
    FlopRate { best: rates[0], median: rates[rates.len() / 2], repetitions: rates.len() }
}

/// f64 per array of the full benchmark's triad: 256 MiB, or the power of two at or above the
/// last-level cache `llc` (bytes) where that is larger, so that the three arrays together are
/// at least three times the cache (a machine here reports 480 MiB of L3, where three arrays of
/// 256 MiB would be read partly from the cache).
pub fn triad_elements(llc: usize) -> usize {
    (1usize << 25).max((llc / 8).next_power_of_two())
}
