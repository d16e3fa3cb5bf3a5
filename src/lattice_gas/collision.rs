//! Collision of the FCHC lattice gas (seed 002 §3.3): the 2²⁴ states of a site are grouped into
//! classes of equal mass and 4-momentum, and a collision replaces a state by a member of its
//! class chosen by a counter-based random number of (seed, step, site) — reproducible, and the
//! same on the CPU and the GPU. Mass and momentum are conserved exactly by construction.
//!
//! A state's class is a function of its mass and momentum, so the table needs no entry per
//! state: the class key (mass, p_X, p_Y, p_Z, p_R) is computed from popcounts of the state
//! (each momentum component lies in −6..=6), a dense key table (25 · 13⁴ entries) gives the class,
//! and the members of every class lie contiguously in `members` (2²⁴ × u32 = 64 MiB), classes in
//! order of increasing mass — so the states of a gas at moderate density touch a few MiB of it.
//! Built once per process (≈ 0.3 s) and shared; the GPU uploads the same three arrays.

use super::velocities::{Q, VELOCITIES};
use std::sync::OnceLock;

/// Number of states of a site.
pub const STATES: usize = 1 << Q;

/// Values of one momentum component (−6..=6).
const SPAN: usize = 13;
/// Number of class keys: mass 0..=24 times four momentum components.
pub const KEYS: usize = 25 * SPAN * SPAN * SPAN * SPAN;

/// Bits of the velocities with c_a = +1 (`[0][a]`) and c_a = −1 (`[1][a]`).
pub const AXIS_MASKS: [[u32; 4]; 2] = axis_masks();

const fn axis_masks() -> [[u32; 4]; 2] {
    let mut m = [[0u32; 4]; 2];
    let mut k = 0;
    while k < Q {
        let mut a = 0;
        while a < 4 {
            if VELOCITIES[k][a] > 0 {
                m[0][a] |= 1 << k;
            } else if VELOCITIES[k][a] < 0 {
                m[1][a] |= 1 << k;
            }
            a += 1;
        }
        k += 1;
    }
    m
}

/// The class key of a state: mass and the four momentum components, from nine popcounts.
#[inline]
pub fn class_key(state: u32) -> usize {
    let mut key = state.count_ones() as usize;
    for a in 0..4 {
        let p = (state & AXIS_MASKS[0][a]).count_ones() as i32 - (state & AXIS_MASKS[1][a]).count_ones() as i32;
        key = key * SPAN + (p + 6) as usize;
    }
    key
}

pub struct CollisionTable {
    /// Class index of every key (`u32::MAX` for keys no state has).
    pub key_class: Vec<u32>,
    /// Class c holds `members[start[c]..start[c + 1]]` (states in increasing order).
    pub start: Vec<u32>,
    pub members: Vec<u32>,
    /// Per key, the first member and the size of its class (0 for keys no state has): one
    /// lookup instead of two dependent ones in the CPU's collision (the GPU uses the three
    /// arrays above).
    key_range: Vec<[u32; 2]>,
}

impl CollisionTable {
    /// Builds the table (a counting sort of the states by class key).
    pub fn build() -> Self {
        let keys: Vec<u32> = (0..STATES as u32).map(|s| class_key(s) as u32).collect();
        let mut count = vec![0u32; KEYS];
        for &k in &keys {
            count[k as usize] += 1;
        }
        // dense class ids in key order (mass first)
        let mut key_class = vec![u32::MAX; KEYS];
        let mut start = vec![0u32];
        for (k, &c) in count.iter().enumerate() {
            if c > 0 {
                key_class[k] = (start.len() - 1) as u32;
                start.push(start.last().unwrap() + c);
            }
        }
        let mut fill: Vec<u32> = start[..start.len() - 1].to_vec();
        let mut members = vec![0u32; STATES];
        for (s, &k) in keys.iter().enumerate() {
            let c = key_class[k as usize];
            members[fill[c as usize] as usize] = s as u32;
            fill[c as usize] += 1;
        }
        let key_range =
            key_class.iter().map(|&c| if c == u32::MAX { [0, 0] } else { [start[c as usize], start[c as usize + 1] - start[c as usize]] }).collect();
        Self { key_class, start, members, key_range }
    }

    /// The shared table of this process.
    pub fn shared() -> &'static CollisionTable {
        static TABLE: OnceLock<CollisionTable> = OnceLock::new();
        TABLE.get_or_init(Self::build)
    }

    pub fn classes(&self) -> usize {
        self.start.len() - 1
    }

    pub fn class_size(&self, c: usize) -> u32 {
        self.start[c + 1] - self.start[c]
    }

    /// The class of a state.
    #[inline]
    pub fn class_of(&self, state: u32) -> usize {
        self.key_class[class_key(state)] as usize
    }

    /// [`Self::collide`] of the 64 sites of a block (`states[i]`: site `first_site + i`, drawn
    /// from the stream of `key`), in phases — all class keys, then all member indices, then all
    /// member reads — so that the 2 × 64 table reads, which miss the caches (the hot part of the
    /// tables is ~10 MiB), overlap instead of each waiting on the arithmetic before it: the same
    /// outputs as [`Self::collide`] site by site. The step runs the three phases of
    /// different blocks interleaved ([`Self::class_keys`], [`Self::member_indices`],
    /// [`Self::read_members`]), each phase prefetching what the next one reads.
    #[inline]
    pub fn collide64(&self, states: &mut [u64; 64], key: u32, first_site: u32) {
        let (mut keys, mut index) = ([0u32; 64], [0u32; 64]);
        self.class_keys(states, &mut keys);
        self.member_indices(&keys, key, first_site, &mut index);
        self.read_members(&index, states);
    }

    /// Phase 1 of [`Self::collide64`]: the class key of every state; prefetches its range.
    #[inline]
    pub fn class_keys(&self, states: &[u64; 64], keys: &mut [u32; 64]) {
        for (k, s) in keys.iter_mut().zip(states) {
            *k = class_key(*s as u32) as u32;
            prefetch(&self.key_range[*k as usize]);
        }
    }

    /// Phase 2 of [`Self::collide64`]: the index in `members` of every state's output, member
    /// r mod |class| of its class; prefetches the member.
    #[inline]
    pub fn member_indices(&self, keys: &[u32; 64], key: u32, first_site: u32, index: &mut [u32; 64]) {
        for (v, (i, k)) in index.iter_mut().zip(keys).enumerate() {
            let [start, size] = self.key_range[*k as usize];
            // every state has a class (size ≥ 1); `max` only spares the division a zero check
            *i = start + remainder(keyed_random(key, first_site.wrapping_add(v as u32)), size.max(1));
            prefetch(&self.members[*i as usize]);
        }
    }

    /// Phase 3 of [`Self::collide64`]: the outputs. A class of one member holds the state
    /// itself, so every state reads its member (no branch).
    #[inline]
    pub fn read_members(&self, index: &[u32; 64], states: &mut [u64; 64]) {
        for (s, i) in states.iter_mut().zip(index) {
            *s = self.members[*i as usize] as u64;
        }
    }

    /// [`Self::collide`] through the class index, as the GPU kernel does (key → class → its
    /// start and size → member): the plain form, for the reference collision and tests.
    pub fn collide_by_class(&self, state: u32, r: u32) -> u32 {
        let c = self.class_of(state);
        let size = self.start[c + 1] - self.start[c];
        self.members[(self.start[c] + r % size) as usize]
    }

    /// The output of a collision of `state` with the random number `r` ("uniform within the
    /// class": member r mod |class|; the modulo bias is below |class| / 2³² < 3e-6).
    #[inline]
    pub fn collide(&self, state: u32, r: u32) -> u32 {
        let [start, size] = self.key_range[class_key(state)];
        if size == 1 {
            // the state is its class's only member
            return state;
        }
        self.members[(start + r % size) as usize]
    }
}

/// r mod d (d ≥ 1), exactly, without an integer division (whose latency the collision's member
/// index waited on): the quotient from one f64 product, r · fl(1/d), is within 1 of ⌊r/d⌋
/// (relative error ≤ 2⁻⁵² on a quotient < 2³²), and one correction each way makes the remainder
/// exact. Test: `the_remainder_without_division_is_exact`.
#[inline(always)]
pub fn remainder(r: u32, d: u32) -> u32 {
    let (r, d64) = (r as i64, d as i64);
    let q = (r as f64 * (1.0 / d as f64)) as i64;
    let mut x = r - q * d64;
    if x < 0 {
        x += d64;
    }
    if x >= d64 {
        x -= d64;
    }
    x as u32
}

/// Asks the cache for the line of `x` without waiting for it (a no-op off x86-64).
#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing into the program and cannot fault; `x` is a valid reference.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(x as *const T as *const i8)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// 32-bit integer hash (Wellons' "lowbias32"), the building block of the random stream.
pub use crate::hash::mix32;

/// Salt of the interference stream (seed ^ salt, step, 24·cell + k).
pub const INTERFERENCE_STREAM: u32 = 0x9e37_79b9;
/// Extra salt of the complementary-plane interference draws (seed ^ [`INTERFERENCE_STREAM`] ^
/// salt, step, 2·(24·cell + k) + diagonal), used with [`super::lattice::Diagonals::AllPerpendicular`].
pub const COMPLEMENTARY_STREAM: u32 = 0xc2b2_ae35;
/// Salt of the inlet stream (seed ^ salt, 24·step + k, 16·cell + v).
pub const INLET_STREAM: u32 = 0x85eb_ca6b;

/// The random number of a site at a step: a counter-based stream, identical on every backend.
pub const fn site_random(seed: u32, step: u32, site: u32) -> u32 {
    keyed_random(stream_key(seed, step), site)
}

/// The part of [`site_random`] shared by every site of a step (computed once per step on the
/// CPU: two of the three hashes).
#[inline]
pub const fn stream_key(seed: u32, step: u32) -> u32 {
    mix32(step ^ mix32(seed))
}

/// [`site_random`] of `site` from its step's [`stream_key`].
#[inline]
pub const fn keyed_random(key: u32, site: u32) -> u32 {
    mix32(site ^ key)
}

#[cfg(test)]
mod tests {
    use super::super::velocities::moments;
    use super::*;

    #[test]
    fn the_remainder_without_division_is_exact() {
        // every divisor up to 20,000 (classes hold at most 11,740) at the edges of its
        // multiples, and 10⁷ random pairs of every magnitude
        for d in 1..20_000u32 {
            let top = u32::MAX / d * d;
            for r in [0, 1, d - 1, d, d + 1, 2 * d - 1, top, top - 1, top.wrapping_add(d - 1), u32::MAX, u32::MAX - 1, 1 << 31, (1 << 31) - 1] {
                assert_eq!(remainder(r, d), r % d, "{r} mod {d}");
            }
        }
        let mut x = 1u32;
        for i in 0..10_000_000u32 {
            x = mix32(x ^ i);
            let d = (mix32(x ^ 0x55) >> (mix32(x ^ 0xaa) % 32)).max(1);
            assert_eq!(remainder(x, d), x % d, "{x} mod {d}");
        }
    }

    #[test]
    fn collision_classes_match_the_reference_counts_and_conserve_exactly() {
        let t = CollisionTable::shared();
        let largest = (0..t.classes()).map(|c| t.class_size(c)).max().unwrap();
        println!("{} classes, largest {largest}", t.classes());
        assert_eq!(t.classes(), 72_047);
        assert_eq!(largest, 11_740);
        // every state is in exactly one class, and its class has its mass and momentum
        let mut seen = vec![false; STATES];
        for c in 0..t.classes() {
            let first = moments(t.members[t.start[c] as usize]);
            for &s in &t.members[t.start[c] as usize..t.start[c + 1] as usize] {
                assert!(!seen[s as usize]);
                seen[s as usize] = true;
                assert_eq!(t.class_of(s), c);
                assert_eq!(moments(s), first);
            }
        }
        assert!(seen.iter().all(|&x| x));
        // collisions: outputs in the input's class
        for i in 0..200_000u32 {
            let s = site_random(7, 0, i) & (STATES as u32 - 1);
            let out = t.collide(s, site_random(1, 3, i));
            assert_eq!(moments(out), moments(s));
            // the CPU's one-lookup form is the GPU's class-index form
            assert_eq!(out, t.collide_by_class(s, site_random(1, 3, i)));
        }
        // the block form: 64 different states (of every mass) with their own draws
        let key = stream_key(1, 3);
        for b in 0..3_000u32 {
            let states: [u64; 64] = std::array::from_fn(|v| (site_random(9, b, v as u32) & (STATES as u32 - 1)) as u64);
            let mut out = states;
            t.collide64(&mut out, key, 64 * b);
            for v in 0..64 {
                assert_eq!(out[v] as u32, t.collide_by_class(states[v] as u32, keyed_random(key, 64 * b + v as u32)));
            }
        }
        // spread uniformly over it: 5000 draws from a class of n give n (1 − e^(−5000/n))
        // distinct outputs on average (2847 for n = 3975)
        let probe = 0x00F0F0u32;
        let outs: std::collections::HashSet<u32> = (0..5000).map(|r| t.collide(probe, site_random(3, r, 11))).collect();
        let size = t.class_size(t.class_of(probe)) as usize;
        println!("state {probe:#x}: class of {size}, {} distinct outputs in 5000 draws", outs.len());
        let expected = size as f64 * (1.0 - (-5000.0 / size as f64).exp());
        assert!((outs.len() as f64 / expected - 1.0).abs() < 0.03, "{} vs {expected}", outs.len());
    }
}
