//! The 24 velocities of the single-speed FCHC model (seed 002 §3.3): all permutations of
//! (±1, ±1, 0, 0) in the coordinates (X, Y, Z, R), speed √2 in lattice units (site spacing per
//! step, integer 4D coordinates). Bit k of a site's state is the particle with velocity k.

/// Number of velocities.
pub const Q: usize = 24;

/// The velocities, ordered by axis pair (XY, XZ, XR, YZ, YR, ZR) and then signs (++, +−, −+, −−).
pub const VELOCITIES: [[i8; 4]; Q] = velocities();

const fn velocities() -> [[i8; 4]; Q] {
    let pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
    let signs = [(1, 1), (1, -1), (-1, 1), (-1, -1)];
    let mut out = [[0i8; 4]; Q];
    let mut p = 0;
    while p < 6 {
        let mut s = 0;
        while s < 4 {
            out[4 * p + s][pairs[p].0] = signs[s].0;
            out[4 * p + s][pairs[p].1] = signs[s].1;
            s += 1;
        }
        p += 1;
    }
    out
}

/// Index of the velocity −c_k.
pub const fn opposite(k: usize) -> usize {
    // within a pair's group of four, (++)↔(−−) and (+−)↔(−+)
    4 * (k / 4) + 3 - k % 4
}

/// Mass (popcount) and 4-momentum of a state.
pub fn moments(state: u32) -> (u32, [i32; 4]) {
    let mut p = [0i32; 4];
    let mut bits = state;
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        for a in 0..4 {
            p[a] += VELOCITIES[k][a] as i32;
        }
        bits &= bits - 1;
    }
    (state.count_ones(), p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fchc_velocities_are_the_24_permutations_and_isotropic_to_fourth_order() {
        let mut seen = std::collections::HashSet::new();
        for c in VELOCITIES {
            assert_eq!(c.iter().map(|x| (*x as i32).abs()).sum::<i32>(), 2);
            assert!(seen.insert(c));
        }
        for k in 0..Q {
            let (c, o) = (VELOCITIES[k], VELOCITIES[opposite(k)]);
            assert!((0..4).all(|a| c[a] == -o[a]));
        }
        // Σ c_a c_b = 12 δ_ab; Σ c_a c_b c_c c_d = 4 (δδ + δδ + δδ) (fourth-order isotropy in 4D)
        for a in 0..4 {
            for b in 0..4 {
                let s: i32 = VELOCITIES.iter().map(|c| c[a] as i32 * c[b] as i32).sum();
                assert_eq!(s, if a == b { 12 } else { 0 });
                for c_ in 0..4 {
                    for d in 0..4 {
                        let s4: i32 = VELOCITIES.iter().map(|c| (c[a] * c[b] * c[c_] * c[d]) as i32).sum();
                        let delta = |i: usize, j: usize| (i == j) as i32;
                        assert_eq!(s4, 4 * (delta(a, b) * delta(c_, d) + delta(a, c_) * delta(b, d) + delta(a, d) * delta(b, c_)));
                    }
                }
            }
        }
        // the 3D projections (X, Y, Z): 18 distinct directions, the six axis ones twice
        let proj: std::collections::HashMap<[i8; 3], usize> = VELOCITIES.iter().fold(Default::default(), |mut m, c| {
            *m.entry([c[0], c[1], c[2]]).or_insert(0) += 1;
            m
        });
        assert_eq!(proj.len(), 18);
        assert_eq!(proj.values().filter(|&&n| n == 2).count(), 6);
    }
}
