//! Bit layout of a cell (seed 002 §3.2): the 16 vertex sites of a 4D cell are bits of one 16-bit
//! lane, vertex v = b_X | b_Y << 1 | b_Z << 2 | b_R << 3 (b = 1 for the offset +ℓ/2). Words hold
//! several lanes — four cells along X in a u64 on the CPU, two in a u32 on the GPU — and every
//! operation below acts lane by lane, so the same masks serve both (replicated per lane).

use super::lattice::Diagonals;
use super::velocities::{Q, VELOCITIES};

/// Bits of a lane whose vertex has coordinate bit `axis` = 0.
pub const LOW: [u16; 4] = [0x5555, 0x3333, 0x0F0F, 0x00FF];

/// A lane mask repeated in every lane of a u64.
#[inline]
pub const fn replicate64(m: u16) -> u64 {
    m as u64 * 0x0001_0001_0001_0001
}

/// The word with every vertex v moved to v ^ (1 << axis), in every lane.
#[inline]
pub fn flip(w: u64, axis: usize) -> u64 {
    let s = 1 << axis;
    let low = replicate64(LOW[axis]);
    ((w & low) << s) | ((w >> s) & low)
}

/// Vertices of a lane whose coordinate bits (a, b) equal (ba, bb).
#[inline]
pub const fn vertex_mask(a: usize, ba: bool, b: usize, bb: bool) -> u16 {
    let ma = if ba { !LOW[a] } else { LOW[a] };
    let mb = if bb { !LOW[b] } else { LOW[b] };
    ma & mb
}

/// [`flip`] on axes a and b (a ≠ b) of a word holding only the vertices with bits (ba, bb) on
/// them, as one rotation: each such vertex moves by ±2^a ± 2^b and stays in its lane, so
/// `flip(flip(w & m, a), b) == (w & m).rotate_left(r)` with m = [`vertex_mask`]`(a, ba, b, bb)`
/// replicated (test below) — one operation instead of two flips of three.
pub const fn quadrant_flip_rotation(a: usize, ba: bool, b: usize, bb: bool) -> u32 {
    (vertex_step(a, ba) + vertex_step(b, bb)).rem_euclid(64) as u32
}

/// The move of a vertex's bit index when its bit on `axis` flips from `bit`.
const fn vertex_step(axis: usize, bit: bool) -> i32 {
    if bit { -(1 << axis) } else { 1 << axis }
}

/// The two nonzero axes of velocity k with their signs.
pub const fn axes(k: usize) -> ((usize, i8), (usize, i8)) {
    let c = VELOCITIES[k];
    let mut first = 4;
    let mut a = 0;
    while a < 4 {
        if c[a] != 0 {
            if first == 4 {
                first = a;
            } else {
                return ((first, c[first]), (a, c[a]));
            }
        }
        a += 1;
    }
    panic!("a velocity has two nonzero components")
}

/// The four moves of velocity k's particles, one per quadrant of source vertices: the quadrant's
/// lane mask (source bits (ba, bb) on the velocity's axes) and the cell offset (X, Y, Z) of the
/// source relative to the destination (−1, 0, +1). A particle at a vertex with bit b on an axis
/// of sign s leaves its cell when s > 0 and b = 1, or s < 0 and b = 0; its vertex bits on both
/// axes flip.
/// The third element is the rotation that flips the quadrant's vertices on both axes
/// ([`quadrant_flip_rotation`]).
pub fn propagation_moves(k: usize) -> [(u16, [i64; 3], u32); 4] {
    let ((a, sa), (b, sb)) = axes(k);
    [(false, false), (false, true), (true, false), (true, true)].map(|(ba, bb)| {
        let mut offset = [0i64; 3];
        for (axis, sign, bit) in [(a, sa, ba), (b, sb, bb)] {
            if axis < 3 {
                let leaves = if sign > 0 && bit {
                    1
                } else if sign < 0 && !bit {
                    -1
                } else {
                    0
                };
                offset[axis] = -leaves;
            }
        }
        (vertex_mask(a, ba, b, bb), offset, quadrant_flip_rotation(a, ba, b, bb))
    })
}

/// The two sides of the interference operation for velocity k (seed 002 §3.4, Fig. 2): in each
/// of the cell's 4 squares parallel to the plane of c_k's axes (a, b), the diagonal perpendicular
/// to c_k joins the vertex at (+s_a/2, −s_b/2) (side A) to the one at (−s_a/2, +s_b/2) (side B).
/// Returns the lane masks of sides A and B.
pub const fn interference_sides(k: usize) -> (u16, u16) {
    let ((a, sa), (b, sb)) = axes(k);
    (vertex_mask(a, sa > 0, b, sb < 0), vertex_mask(a, sa < 0, b, sb > 0))
}

/// The sides of the interference operation for velocity k in the cell's other family of squares
/// that has diagonals perpendicular to c_k: the squares parallel to the plane of the two axes
/// (p, q) on which c_k is zero. Both of their diagonals are perpendicular to c_k; returns, for
/// the diagonal joining (0, 0) to (1, 1) and the one joining (0, 1) to (1, 0) in (b_p, b_q), the
/// lane masks of its two ends and the axes (p, q).
pub const fn complementary_sides(k: usize) -> [(u16, u16, usize, usize); 2] {
    let ((a, _), (b, _)) = axes(k);
    let mut pq = [0usize; 2];
    let (mut i, mut axis) = (0, 0);
    while axis < 4 {
        if axis != a && axis != b {
            pq[i] = axis;
            i += 1;
        }
        axis += 1;
    }
    let (p, q) = (pq[0], pq[1]);
    [(vertex_mask(p, false, q, false), vertex_mask(p, true, q, true), p, q), (vertex_mask(p, false, q, true), vertex_mask(p, true, q, false), p, q)]
}

/// One exchange of the interference operation on a lane: the vertex masks of its two sides
/// (A, B) and the two axes that pair them.
pub type Exchange = (u16, u16, usize, usize);

/// Per velocity k, the exchange of [`interfere_lane`]: (side A, side B, the axes a, b of c_k) —
/// a table, for loops whose k is not a constant.
pub const OWN_PLANE_EXCHANGES: [Exchange; Q] = own_plane_exchanges();

const fn own_plane_exchanges() -> [Exchange; Q] {
    let mut t = [(0, 0, 0, 0); Q];
    let mut k = 0;
    while k < Q {
        let ((a, _), (b, _)) = axes(k);
        let (mask_a, mask_b) = interference_sides(k);
        t[k] = (mask_a, mask_b, a, b);
        k += 1;
    }
    t
}

/// The interference operation on one lane (16 sites) of velocity k's word: side B is moved onto
/// side A's positions (flip on both axes); the sparser side gets the AND of each pair, the denser
/// the OR (equal counts: unchanged). Particle number and momentum are conserved pair by pair.
#[inline]
pub fn interfere_lane(w: u16, k: usize) -> u16 {
    let (mask_a, mask_b, a, b) = OWN_PLANE_EXCHANGES[k];
    exchange_lane(w, mask_a, mask_b, a, b)
}

/// The sparser-AND / denser-OR exchange between the sites `mask_a` and `mask_b` of a lane, paired
/// by flipping the vertex bits on axes a and b.
#[inline]
pub fn exchange_lane(w: u16, mask_a: u16, mask_b: u16, a: usize, b: usize) -> u16 {
    let u = w & mask_a;
    let v = flip(flip((w & mask_b) as u64, a), b) as u16;
    let (na, nb) = (u.count_ones(), v.count_ones());
    if na == nb {
        return w;
    }
    let (and, or) = (u & v, u | v);
    let (new_a, new_b) = if na < nb { (and, or) } else { (or, and) };
    (w & !(mask_a | mask_b)) | new_a | flip(flip(new_b as u64, a), b) as u16
}

/// The exchanges one interference pass applies to velocity k's word, in order: (side A, side B,
/// the two axes that pair them) — c_k's own-plane diagonal, then with
/// [`Diagonals::AllPerpendicular`] the two of [`complementary_sides`].
pub fn exchanges(k: usize, diagonals: Diagonals) -> Vec<Exchange> {
    let ((a, _), (b, _)) = axes(k);
    let (mask_a, mask_b) = interference_sides(k);
    let mut out = vec![(mask_a, mask_b, a, b)];
    if diagonals == Diagonals::AllPerpendicular {
        out.extend(complementary_sides(k));
    }
    out
}

/// The displacement (ℓ, per axis X, Y, Z, R) of a particle moved from side A to side B of an
/// exchange: the pair differs by one vertex step on each of its two axes.
pub fn displacement((mask_a, _, a, b): (u16, u16, usize, usize)) -> [i32; 4] {
    let v = mask_a.trailing_zeros() as usize;
    let partner = v ^ (1 << a) ^ (1 << b);
    std::array::from_fn(|axis| ((partner >> axis) & 1) as i32 - ((v >> axis) & 1) as i32)
}

/// Transposes a 64 × 64 bit matrix in place (row r = word r, column c = bit c): afterwards bit c
/// of word r is what bit r of word c was. Six rounds of block swaps (H. S. Warren, *Hacker's
/// Delight*, §7-3): 6 · 32 word pairs instead of 64 · 64 single-bit moves. It turns a block's 24
/// velocity words into its 64 sites' 24-bit states and back.
/// Each round a const width, so that its loops unroll and the wide rounds (`J` ≥ 4) run on
/// vector registers.
#[inline]
pub fn transpose64(a: &mut [u64; 64]) {
    swap_blocks::<32>(a, 0x0000_0000_FFFF_FFFF);
    swap_blocks::<16>(a, 0x0000_FFFF_0000_FFFF);
    swap_blocks::<8>(a, 0x00FF_00FF_00FF_00FF);
    swap_blocks::<4>(a, 0x0F0F_0F0F_0F0F_0F0F);
    swap_blocks::<2>(a, 0x3333_3333_3333_3333);
    swap_blocks::<1>(a, 0x5555_5555_5555_5555);
}

/// One round of [`transpose64`]: rows k and k + J (k in the upper half of every band of 2J
/// rows) swap blocks — the high J bits of each 2J-bit group of row k with the low J bits of the
/// group in row k + J (`m` selects the low J bits of every group).
#[inline(always)]
fn swap_blocks<const J: usize>(a: &mut [u64; 64], m: u64) {
    for base in (0..64).step_by(2 * J) {
        for k in base..base + J {
            let t = ((a[k] >> J) ^ a[k + J]) & m;
            a[k + J] ^= t;
            a[k] ^= t << J;
        }
    }
}

#[cfg(test)]
mod transpose_tests {
    use super::*;

    #[test]
    fn transpose64_moves_every_bit_to_its_mirror_and_is_an_involution() {
        let mut a = [0u64; 64];
        for (r, w) in a.iter_mut().enumerate() {
            *w = crate::hash::mix32(r as u32) as u64 | (crate::hash::mix32(r as u32 + 1000) as u64) << 32;
        }
        let orig = a;
        transpose64(&mut a);
        for r in 0..64 {
            for c in 0..64 {
                assert_eq!((a[r] >> c) & 1, (orig[c] >> r) & 1, "bit {c} of word {r}");
            }
        }
        transpose64(&mut a);
        assert_eq!(a, orig);
    }

    #[test]
    fn a_quadrants_double_flip_is_one_rotation() {
        for a in 0..4 {
            for b in (0..4).filter(|&b| b != a) {
                for (ba, bb) in [(false, false), (false, true), (true, false), (true, true)] {
                    let (m, r) = (replicate64(vertex_mask(a, ba, b, bb)), quadrant_flip_rotation(a, ba, b, bb));
                    for i in 0..1000u32 {
                        let w = crate::hash::mix32(i) as u64 | (crate::hash::mix32(i ^ 0xdead) as u64) << 32;
                        assert_eq!(flip(flip(w & m, a), b), (w & m).rotate_left(r), "axes {a} {b}, quadrant {ba} {bb}");
                    }
                }
            }
        }
    }
}
