//! Collision of the FCHC lattice gas (seed 002 §3.3): the 2²⁴ states of a site are grouped into
//! classes of equal mass and 4-momentum, and a collision replaces a state by a member of its
//! class chosen by a counter-based random number of (seed, step, site) — reproducible, and the
//! same on the CPU and the GPU. Mass and momentum are conserved exactly by construction.
//!
//! The table is built once per process by a counting sort over the class keys (≈ 0.2 s) and
//! shared: `class_of` (2²⁴ × u32) and the members in class order (2²⁴ × u32), 128 MiB in all.

use super::velocities::{Q, moments};
use std::sync::OnceLock;

/// Number of states of a site.
pub const STATES: usize = 1 << Q;

pub struct CollisionTable {
    /// Class index of every state.
    pub class_of: Vec<u32>,
    /// Class c holds `members[start[c]..start[c + 1]]` (states in increasing order).
    pub start: Vec<u32>,
    pub members: Vec<u32>,
}

/// (mass, momentum) → a dense key: mass 0..=24, each momentum component −12..=12.
fn key(state: u32) -> usize {
    let (m, p) = moments(state);
    let mut k = m as usize;
    for c in p {
        k = k * 25 + (c + 12) as usize;
    }
    k
}

const KEYS: usize = 25 * 25 * 25 * 25 * 25;

impl CollisionTable {
    /// Builds the table (a counting sort of the states by class key).
    pub fn build() -> Self {
        let keys: Vec<u32> = (0..STATES as u32).map(|s| key(s) as u32).collect();
        let mut count = vec![0u32; KEYS];
        for &k in &keys {
            count[k as usize] += 1;
        }
        // dense class ids in key order
        let mut class_id = vec![u32::MAX; KEYS];
        let mut start = vec![0u32];
        for (k, &c) in count.iter().enumerate() {
            if c > 0 {
                class_id[k] = (start.len() - 1) as u32;
                start.push(start.last().unwrap() + c);
            }
        }
        let mut fill: Vec<u32> = start[..start.len() - 1].to_vec();
        let mut members = vec![0u32; STATES];
        let mut class_of = vec![0u32; STATES];
        for (s, &k) in keys.iter().enumerate() {
            let c = class_id[k as usize];
            class_of[s] = c;
            members[fill[c as usize] as usize] = s as u32;
            fill[c as usize] += 1;
        }
        Self { class_of, start, members }
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

    /// The output of a collision of `state` with the random number `r` ("uniform within the
    /// class": member r mod |class|; the modulo bias is below |class| / 2³² < 3e-6).
    pub fn collide(&self, state: u32, r: u32) -> u32 {
        let c = self.class_of[state as usize] as usize;
        let size = self.start[c + 1] - self.start[c];
        self.members[(self.start[c] + r % size) as usize]
    }
}

/// 32-bit integer hash (Wellons' "lowbias32"), the building block of the random stream.
pub const fn mix32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The random number of a site at a step: a counter-based stream, identical on every backend.
pub const fn site_random(seed: u32, step: u32, site: u32) -> u32 {
    mix32(site ^ mix32(step ^ mix32(seed)))
}

#[cfg(test)]
mod tests {
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
                assert_eq!(t.class_of[s as usize] as usize, c);
                assert_eq!(moments(s), first);
            }
        }
        assert!(seen.iter().all(|&x| x));
        // collisions: outputs in the input's class
        for i in 0..200_000u32 {
            let s = site_random(7, 0, i) & (STATES as u32 - 1);
            let out = t.collide(s, site_random(1, 3, i));
            assert_eq!(moments(out), moments(s));
        }
        // spread uniformly over it: 5000 draws from a class of n give n (1 − e^(−5000/n))
        // distinct outputs on average (2847 for n = 3975)
        let probe = 0x00F0F0u32;
        let outs: std::collections::HashSet<u32> = (0..5000).map(|r| t.collide(probe, site_random(3, r, 11))).collect();
        let size = t.class_size(t.class_of[probe as usize] as usize) as usize;
        println!("state {probe:#x}: class of {size}, {} distinct outputs in 5000 draws", outs.len());
        let expected = size as f64 * (1.0 - (-5000.0 / size as f64).exp());
        assert!((outs.len() as f64 / expected - 1.0).abs() < 0.03, "{} vs {expected}", outs.len());
    }
}
