//! Hints to the memory system for the CPU FDLB passes ([`super::solver`]): stores that bypass the
//! caches, and fetching rows ahead of their use. Neither changes a value: they change only when
//! and how bytes move between memory and the caches (the golden state hashes hold).
//!
//! Why, measured with `phonation bench --only fdlb` (2 cores of an Intel Xeon, 2026-12-05):
//! - **Streaming stores.** The moments–collision pass writes h and the stage output, 2 × 8 B per
//!   value that no later part of the pass reads. Ordinary stores first read each line into the
//!   cache (write-allocate): 624 B per D3Q39 node of reads the pass does not need. Written with
//!   streaming stores, D3Q39 at 96³ went from 3.67 to 4.0·10⁶ node updates per second.
//! - **Fetching ahead.** A row of D3Q39 at 96³ is 39 pieces of 800 B (one per value), read piece
//!   by piece: too short for the hardware's stream prefetcher to ramp up. The passes ask for the
//!   next row's pieces while they work on the current one (the collision: the next row's stage
//!   input and fⁿ; the advection: the next row's stage output and the h row two planes on, the
//!   one its taps reach first), 4.0 → 5.3–5.5·10⁶. Long rows (D2Q21 at 1216², 9.8 kB a piece)
//!   lose by it (9.9 → 9.1·10⁶: a whole row ahead pushes the current one out of L2), so only
//!   rows of at most [`PREFETCH_MAX_PX`] nodes are fetched ahead.
//!
//! Which of them a solver uses depends on its size against the cache: [`MemoryHints::choose`].

/// How a solver's passes move their bytes ([`super::FluidSolver::memory_hints`]). Either
/// choice gives the same values, to the bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryHints {
    /// The moments–collision pass writes h and its stage output with streaming stores.
    pub streaming_stores: bool,
    /// The passes fetch the next row ahead of its use.
    pub prefetch_rows: bool,
}

/// Rows of at most this many nodes (padded) are fetched ahead ([`MemoryHints::choose`]).
pub const PREFETCH_MAX_PX: usize = 512;

impl MemoryHints {
    /// The hints for a solver whose arrays take `footprint` bytes, with rows of `px` nodes, on a
    /// machine whose last-level cache holds `llc` bytes:
    /// - streaming stores when the arrays are at least twice the cache. A lattice that fits the
    ///   cache reads its next pass from it, and streaming stores would send it to memory
    ///   instead: D2Q21 at 128²–512² and D3Q39 at 32³ ran 1.4–1.7× slower with them;
    /// - rows fetched ahead when they are short (at most `PREFETCH_MAX_PX` nodes) and the
    ///   arrays at least half the cache: D3Q39 at 64³ (386 MB) 3.9 → 5.0·10⁶ node updates per
    ///   second, at 32³ (57 MB, read from the cache) 2–3 % slower with them.
    pub fn choose(footprint: usize, px: usize, llc: usize) -> Self {
        MemoryHints { streaming_stores: footprint >= 2 * llc, prefetch_rows: px <= PREFETCH_MAX_PX && 2 * footprint >= llc }
    }
}

/// Asks for the cache lines of the `bytes` bytes from address `addr` (into L2). A hint: it never
/// faults, whatever the address, and it changes no value.
#[inline(always)]
pub fn prefetch_bytes(addr: usize, bytes: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        let mut o = 0;
        while o < bytes {
            // SAFETY: a prefetch is a hint; it reads nothing the program sees and never faults.
            unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T1 }>((addr + o) as *const i8) };
            o += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (addr, bytes);
}

/// Orders this thread's streaming stores ([`copy_streaming`]) before
/// its later stores: called by every task that used them, before the task ends (so before any
/// other thread can read what they wrote).
#[inline(always)]
pub fn streaming_fence() {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: sfence has no operands and no preconditions.
    unsafe {
        std::arch::x86_64::_mm_sfence()
    }
}

/// `dst.copy_from_slice(src)` with streaming stores, for elements of 4 or 8 bytes (f32, f64):
/// 16-byte stores once `dst` is 16-byte aligned, one element at a time before and after. The
/// caller calls [`streaming_fence`] before another thread may read `dst`.
#[inline(always)]
pub fn copy_streaming<T: Copy>(dst: &mut [T], src: &[T]) {
    assert_eq!(dst.len(), src.len());
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128i, _mm_loadu_si128, _mm_stream_si32, _mm_stream_si64, _mm_stream_si128};
        let size = std::mem::size_of::<T>();
        assert!(size == 4 || size == 8, "streaming copies of 4- or 8-byte elements");
        let (n, d, s) = (dst.len(), dst.as_mut_ptr(), src.as_ptr());
        // SAFETY: `i < n` for the element at i, the length of both slices; T is 4 or 8 bytes of
        // plain data (f32, f64), read and written whole.
        let one = |i: usize| unsafe {
            if size == 8 {
                _mm_stream_si64(d.add(i) as *mut i64, *(s.add(i) as *const i64));
            } else {
                _mm_stream_si32(d.add(i) as *mut i32, *(s.add(i) as *const i32));
            }
        };
        let per_block = 16 / size;
        let mut i = 0;
        while i < n && !(d.wrapping_add(i) as usize).is_multiple_of(16) {
            one(i);
            i += 1;
        }
        while i + per_block <= n {
            // SAFETY: the 16 bytes from element i lie inside both slices; the store's address is
            // 16-byte aligned (reached above), the load takes any alignment.
            unsafe { _mm_stream_si128(d.add(i) as *mut __m128i, _mm_loadu_si128(s.add(i) as *const __m128i)) };
            i += per_block;
        }
        while i < n {
            one(i);
            i += 1;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    dst.copy_from_slice(src);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_streaming_copies_copy_every_element_at_every_alignment() {
        let src64: Vec<f64> = (0..37).map(|i| i as f64 * 1.5 - 7.0).collect();
        let src32: Vec<f32> = (0..37).map(|i| i as f32 * 0.25 - 3.0).collect();
        for start in 0..5 {
            for len in [0, 1, 2, 3, 5, 8, 17, 32] {
                let mut d64 = [f64::NAN; 40];
                copy_streaming(&mut d64[start..start + len], &src64[..len]);
                streaming_fence();
                assert_eq!(&d64[start..start + len], &src64[..len], "f64 at {start}, {len}");
                assert!(d64[..start].iter().chain(&d64[start + len..]).all(|x| x.is_nan()), "f64 outside the range untouched");
                let mut d32 = [f32::NAN; 40];
                copy_streaming(&mut d32[start..start + len], &src32[..len]);
                streaming_fence();
                assert_eq!(&d32[start..start + len], &src32[..len], "f32 at {start}, {len}");
                assert!(d32[..start].iter().chain(&d32[start + len..]).all(|x| x.is_nan()), "f32 outside the range untouched");
            }
        }
        prefetch_bytes(0, 4096); // a hint at an address that is not mapped: no fault
    }

    #[test]
    fn the_hints_follow_the_arrays_against_the_cache() {
        let (mib, llc) = (1usize << 20, 480usize << 20);
        // D3Q39 at 32³ (57 MiB), 64³ (386 MiB), 96³ (1228 MiB); D2Q21 at 1216² (1 GiB, 1220-node rows)
        assert_eq!(MemoryHints::choose(57 * mib, 36, llc), MemoryHints { streaming_stores: false, prefetch_rows: false });
        assert_eq!(MemoryHints::choose(386 * mib, 68, llc), MemoryHints { streaming_stores: false, prefetch_rows: true });
        assert_eq!(MemoryHints::choose(1228 * mib, 100, llc), MemoryHints { streaming_stores: true, prefetch_rows: true });
        assert_eq!(MemoryHints::choose(1050 * mib, 1220, llc), MemoryHints { streaming_stores: true, prefetch_rows: false });
    }
}
