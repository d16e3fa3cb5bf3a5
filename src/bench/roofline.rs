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
    flop_rate(reps, 2.0 * (FMA_CHAINS * ITERATIONS) as f64, |seed| {
        let mut a = [seed; FMA_CHAINS];
        let (b, c) = (std::hint::black_box(0.999_999_9), std::hint::black_box(1e-7));
        for _ in 0..ITERATIONS {
            for x in a.iter_mut() {
                *x = x.mul_add(b, c);
            }
        }
        a.iter().sum::<f64>()
    })
}

/// The rate of `reps` timed runs in which every rayon thread computes `chains(seed)` (`flops`
/// flops each, from a seed of its own), fastest first.
fn flop_rate(reps: usize, flops: f64, chains: impl Fn(f64) -> f64 + Sync) -> FlopRate {
    let threads = rayon::current_num_threads();
    let mut rates: Vec<f64> = (0..reps.max(1))
        .map(|r| {
            let t = Instant::now();
            let sum: f64 = (0..threads).into_par_iter().map(|i| chains(1.0 + (i + r) as f64 * 1e-9)).sum();
            std::hint::black_box(sum);
            flops * threads as f64 / t.elapsed().as_secs_f64()
        })
        .collect();
    rates.sort_by(|a, b| b.total_cmp(a));
    FlopRate { best: rates[0], median: rates[rates.len() / 2], repetitions: rates.len() }
}

/// Independent scalar FMA chains per thread: 4 cycles of latency on 2 ports need 8; 12 leave
/// room (each chain one xmm register).
#[cfg(target_arch = "x86_64")]
const SCALAR_CHAINS: usize = 12;

/// The f64 rate of **scalar** FMAs (one f64 per instruction, `vfmadd213sd`), all threads: the
/// roof of code that does not vectorise, as the solid's bond loops over glam's `DVec3` and
/// `DMat3` (scalar f64 arithmetic) do not. `None` where the CPU has no FMA or is not x86-64.
/// Written in assembly so that LLVM cannot pack the chains into vectors as it does
/// [`fma_peak`]'s.
pub fn scalar_fma_peak(reps: usize) -> Option<FlopRate> {
    #[cfg(target_arch = "x86_64")]
    {
        const ITERATIONS: usize = 1 << 24;
        if !std::arch::is_x86_feature_detected!("fma") {
            return None;
        }
        // SAFETY: the CPU has FMA (checked above)
        Some(flop_rate(reps, 2.0 * (SCALAR_CHAINS * ITERATIONS) as f64, |seed| unsafe { scalar_fma_chains(ITERATIONS, seed) }))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = reps;
        None
    }
}

/// `iterations` × [`SCALAR_CHAINS`] scalar FMAs a = a·b + c in independent chains.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
unsafe fn scalar_fma_chains(iterations: usize, seed: f64) -> f64 {
    let (b, c) = (std::hint::black_box(0.999_999_9f64), std::hint::black_box(1e-7f64));
    let mut a = [seed; SCALAR_CHAINS];
    let [mut a0, mut a1, mut a2, mut a3, mut a4, mut a5, mut a6, mut a7, mut a8, mut a9, mut a10, mut a11] = a;
    for _ in 0..iterations {
        // SAFETY: register-only arithmetic; the caller checked that the CPU has FMA
        unsafe {
            std::arch::asm!(
                "vfmadd213sd {a0}, {b}, {c}",
                "vfmadd213sd {a1}, {b}, {c}",
                "vfmadd213sd {a2}, {b}, {c}",
                "vfmadd213sd {a3}, {b}, {c}",
                "vfmadd213sd {a4}, {b}, {c}",
                "vfmadd213sd {a5}, {b}, {c}",
                "vfmadd213sd {a6}, {b}, {c}",
                "vfmadd213sd {a7}, {b}, {c}",
                "vfmadd213sd {a8}, {b}, {c}",
                "vfmadd213sd {a9}, {b}, {c}",
                "vfmadd213sd {a10}, {b}, {c}",
                "vfmadd213sd {a11}, {b}, {c}",
                a0 = inout(xmm_reg) a0,
                a1 = inout(xmm_reg) a1,
                a2 = inout(xmm_reg) a2,
                a3 = inout(xmm_reg) a3,
                a4 = inout(xmm_reg) a4,
                a5 = inout(xmm_reg) a5,
                a6 = inout(xmm_reg) a6,
                a7 = inout(xmm_reg) a7,
                a8 = inout(xmm_reg) a8,
                a9 = inout(xmm_reg) a9,
                a10 = inout(xmm_reg) a10,
                a11 = inout(xmm_reg) a11,
                b = in(xmm_reg) b,
                c = in(xmm_reg) c,
                options(pure, nomem, nostack),
            );
        }
    }
    a = [a0, a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, a11];
    a.iter().sum()
}

/// f64 per array of the full benchmark's triad: 256 MiB, or the power of two at or above the
/// last-level cache `llc` (bytes) where that is larger, so that the three arrays together are
/// at least three times the cache (a machine here reports 480 MiB of L3, where three arrays of
/// 256 MiB would be read partly from the cache).
pub fn triad_elements(llc: usize) -> usize {
    (1usize << 25).max((llc / 8).next_power_of_two())
}

#[cfg(test)]
mod tests {
    /// The scalar rate's assembly computes what it claims: twelve chains of a = a·b + c, each
    /// the same as `f64::mul_add` (both round once), whose sum it returns.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_scalar_fma_chains_compute_fused_multiply_adds() {
        if !std::arch::is_x86_feature_detected!("fma") {
            return;
        }
        let (seed, n) = (1.25, 1000);
        // SAFETY: the CPU has FMA (checked above)
        let got = unsafe { super::scalar_fma_chains(n, seed) };
        let mut a = seed;
        for _ in 0..n {
            a = a.mul_add(0.999_999_9, 1e-7);
        }
        assert_eq!(got.to_bits(), [a; 12].iter().sum::<f64>().to_bits());
        assert!((got - 12.0 * seed).abs() > 1e-6, "the chains moved: {got}");
    }
}
