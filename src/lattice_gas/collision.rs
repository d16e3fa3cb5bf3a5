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

    /// The output of a collision of `state` with the random number `r` ("uniform within the
    /// class": member r mod |class|; the modulo bias is below |class| / 2³² < 3e-6).
    /// [`Self::collide`] of 16 sites at once, in phases (all class keys, then all class
    /// ranges, then all members) so that the table reads of different sites overlap instead of
    /// waiting on each other: the same outputs.
    #[inline]
    pub fn collide16(&self, states: &mut [u64], r: impl Fn(usize) -> u32) {
        let mut ranges = [[0u32; 2]; 16];
        for (range, s) in ranges.iter_mut().zip(states.iter()) {
            *range = self.key_range[class_key(*s as u32)];
        }
        for (v, (s, [start, size])) in states.iter_mut().zip(ranges).enumerate() {
            if size != 1 {
                *s = self.members[(start + r(v) % size) as usize] as u64;
            }
        }
    }

    /// [`Self::collide`] through the class index, as the GPU kernel does (key → class → its
    /// start and size → member): the plain form, for the reference collision and tests.
    pub fn collide_by_class(&self, state: u32, r: u32) -> u32 {
        let c = self.class_of(state);
        let size = self.start[c + 1] - self.start[c];
        self.members[(self.start[c] + r % size) as usize]
    }

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
            let mut sixteen = [s as u64; 16];
            t.collide16(&mut sixteen, |v| site_random(1, 3, i) ^ v as u32);
            assert!(sixteen.iter().enumerate().all(|(v, &o)| o as u32 == t.collide_by_class(s, site_random(1, 3, i) ^ v as u32)));
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
