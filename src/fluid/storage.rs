//! CPU memory layout of node values: **row-blocked structure of arrays**. For every padded row
//! (fixed y, z) the values of one population (or macro field) are contiguous along x, and the
//! populations of a row follow each other: index = (row · n_values + v) · p_x + x.
//! Inner loops run along x over contiguous memory (vectorisable), and a row is one contiguous
//! chunk, so rows are updated in parallel without sharing.

use super::equilibrium::{Equilibrium, Macro};
use super::layout::PeriodicRun;

/// The number type the populations (fⁿ, f¹, fⁿ⁺¹ and the advected h) are stored in between the
/// passes of a step: `f64`, the reference, or `f32`, half the bytes per node for scenes that
/// tolerate its rounding (`[numerics] storage = "f32"`). Every pass loads its inputs into f64,
/// computes in f64 and rounds once on the store; the macroscopic fields, the boundaries' scratch
/// and the side ghosts stay f64. The errors it costs are measured on Taylor–Green and Sod
/// (`phonation bench --only storage`, `tests/fluid.rs`).
///
/// A shifted storage (f32) holds each population as its departure from a constant per velocity,
/// f − s_i, with s_i the equilibrium at rest of the initial state's mean density and temperature
/// rounded to f32 ([`FluidSolver::storage_shift`](super::FluidSolver::storage_shift)): the
/// viscosity lives in the small non-equilibrium part, and f32's 24 bits then resolve it rather
/// than the rest state (the idea of "DDF shifting", Lehmann et al. 2022). Departures below
/// 2⁻²⁸ |s_i| are stored as 0, so that with s_i an f32 number f32 + s_i is exact in f64 and an f64
/// copy of the state converts back to the same f32 bits (checkpoints resume bit for bit).
pub trait Storage: Copy + Default + PartialEq + Send + Sync + std::fmt::Debug + 'static {
    /// Whether the populations are stored shifted (above).
    const SHIFTED: bool;
    /// The stored value as f64 (exact).
    fn load(self) -> f64;
    /// `x` rounded to the storage type (to nearest; exact for f64).
    fn store(x: f64) -> Self;

    /// The population whose stored value this is, given its velocity's shift `s`.
    #[inline(always)]
    fn decode(self, s: f64) -> f64 {
        if Self::SHIFTED { self.load() + s } else { self.load() }
    }

    /// The stored value of population `x` of a velocity whose shift is `s`.
    #[inline(always)]
    fn encode(x: f64, s: f64) -> Self {
        if Self::SHIFTED { Self::store_departure(x - s, s) } else { Self::store(x) }
    }

    /// A departure `d` = f − s already formed (unshifted storage: the population itself),
    /// stored: below 2⁻²⁸ |s| as 0 when shifted.
    #[inline(always)]
    fn store_departure(d: f64, s: f64) -> Self {
        if Self::SHIFTED && d.abs() < s.abs() * DEPARTURE_FLOOR { Self::store(0.0) } else { Self::store(d) }
    }

    /// `dst.copy_from_slice(src)` with streaming stores (`fluid::memory_hints`): for values
    /// written now and read only by a later pass. The writing task ends with
    /// `fluid::memory_hints::streaming_fence`.
    #[inline(always)]
    fn copy_streaming(dst: &mut [Self], src: &[Self]) {
        dst.copy_from_slice(src)
    }
}

/// Departures below this fraction of their shift are stored as 0 ([`Storage`]): with the
/// departure's exponent at most 28 below the shift's, f32 + shift fits f64's 53 bits.
pub const DEPARTURE_FLOOR: f64 = 1.0 / (1u64 << 28) as f64;

impl Storage for f64 {
    const SHIFTED: bool = false;
    #[inline(always)]
    fn load(self) -> f64 {
        self
    }
    #[inline(always)]
    fn store(x: f64) -> Self {
        x
    }

    #[inline(always)]
    fn copy_streaming(dst: &mut [f64], src: &[f64]) {
        super::memory_hints::copy_streaming(dst, src)
    }
}

impl Storage for f32 {
    const SHIFTED: bool = true;
    #[inline(always)]
    fn load(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn store(x: f64) -> Self {
        x as f32
    }

    #[inline(always)]
    fn copy_streaming(dst: &mut [f32], src: &[f32]) {
        super::memory_hints::copy_streaming(dst, src)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowBlocked {
    /// Padded row length p_x.
    pub px: usize,
    /// Values per node.
    pub nv: usize,
}

impl RowBlocked {
    #[inline]
    pub fn index(&self, node: usize, v: usize) -> usize {
        let r = node / self.px;
        let x = node % self.px;
        (r * self.nv + v) * self.px + x
    }

    /// Length of one row chunk.
    #[inline]
    pub fn row_len(&self) -> usize {
        self.nv * self.px
    }

    /// Copies the values of `node` into `out` (length nv).
    #[inline]
    pub fn gather<S: Storage>(&self, a: &[S], node: usize, out: &mut [f64]) {
        let base = self.index(node, 0);
        for (v, o) in out.iter_mut().enumerate() {
            *o = a[base + v * self.px].load();
        }
    }

    /// Writes `vals` (length nv) into `node`.
    #[inline]
    pub fn scatter<S: Storage>(&self, a: &mut [S], node: usize, vals: &[f64]) {
        let base = self.index(node, 0);
        for (v, x) in vals.iter().enumerate() {
            a[base + v * self.px] = S::store(*x);
        }
    }

    /// The populations of `node` (stored as `S` with the per-value shifts `shift`, empty when
    /// `S` is not shifted) into `out` (length nv).
    #[inline]
    pub fn gather_populations<S: Storage>(&self, a: &[S], node: usize, shift: &[f64], out: &mut [f64]) {
        let base = self.index(node, 0);
        for (v, o) in out.iter_mut().enumerate() {
            *o = a[base + v * self.px].decode(shift_of(shift, v));
        }
    }

    /// Writes the populations `vals` (length nv) into `node` (as [`Self::gather_populations`]).
    #[inline]
    pub fn scatter_populations<S: Storage>(&self, a: &mut [S], node: usize, shift: &[f64], vals: &[f64]) {
        let base = self.index(node, 0);
        for (v, x) in vals.iter().enumerate() {
            a[base + v * self.px] = S::encode(*x, shift_of(shift, v));
        }
    }

    /// The values of `node` as stored (no decoding) into `out` (length nv).
    #[inline]
    pub fn gather_raw<T: Copy>(&self, a: &[T], node: usize, out: &mut [T]) {
        let base = self.index(node, 0);
        for (v, o) in out.iter_mut().enumerate() {
            *o = a[base + v * self.px];
        }
    }

    /// Writes the stored values `vals` (length nv) into `node` (as [`Self::gather_raw`]).
    #[inline]
    pub fn scatter_raw<T: Copy>(&self, a: &mut [T], node: usize, vals: &[T]) {
        let base = self.index(node, 0);
        for (v, x) in vals.iter().enumerate() {
            a[base + v * self.px] = *x;
        }
    }

    /// Copies every value of node `src` onto node `dst`.
    #[inline]
    pub fn copy_node<T: Copy>(&self, a: &mut [T], src: usize, dst: usize) {
        let (bs, bd) = (self.index(src, 0), self.index(dst, 0));
        for v in 0..self.nv {
            a[bd + v * self.px] = a[bs + v * self.px];
        }
    }

    /// Offset in values of the same population at a neighbour displaced by `d` nodes, for a
    /// padded grid of `py` rows per z-plane.
    #[inline]
    pub fn neighbour_offset(&self, d: [i64; 3], py: usize) -> isize {
        (d[0] + (d[1] + d[2] * py as i64) * (self.nv * self.px) as i64) as isize
    }
}

/// The shifts of storage `S` for the state at rest `rest`: its equilibrium, each value rounded
/// to `S` (empty when `S` is not shifted).
pub(super) fn rest_shift<S: Storage>(eq: &Equilibrium, rest: &Macro) -> Vec<f64> {
    if !S::SHIFTED {
        return Vec::new();
    }
    let mut w = vec![0.0; eq.set.shells.len()];
    let mut fe = vec![0.0; eq.values_per_node()];
    eq.feq_into(rest, &mut w, &mut fe);
    fe.iter().map(|x| S::store(*x).load()).collect()
}

/// The population array `a` (layout `pop`, stored as `S` with the shifts `from`) into `out`,
/// stored as `T` with the shifts `to`: value v of a row is the chunk of `px` values number
/// (row · nv + v).
pub(super) fn recode_into<S: Storage, T: Storage>(pop: RowBlocked, a: &[S], from: &[f64], to: &[f64], out: &mut [T]) {
    use rayon::prelude::*;
    out.par_chunks_mut(pop.px).zip(a.par_chunks(pop.px)).enumerate().with_min_len(64).for_each(|(c, (o, x))| {
        let v = c % pop.nv;
        let (from, to) = (shift_of(from, v), shift_of(to, v));
        for (o, x) in o.iter_mut().zip(x) {
            *o = T::encode(x.decode(from), to);
        }
    });
}

/// Value `v`'s shift (0 where there are none: unshifted storage).
#[inline(always)]
pub fn shift_of(shift: &[f64], v: usize) -> f64 {
    shift.get(v).copied().unwrap_or(0.0)
}

/// Copies, for every periodic run, the values `values(run)` (indices below `layout.nv`) of its
/// source nodes onto its destination nodes, runs in parallel. The destinations of the runs must
/// be disjoint from each other and from every source (true of periodic halo copies, whose
/// sources are interior nodes and whose destinations are halo nodes).
pub fn copy_runs_parallel<'v, T: Copy + Send>(layout: RowBlocked, a: &mut [T], runs: &[PeriodicRun], values: impl Fn(&PeriodicRun) -> &'v [usize] + Sync) {
    use rayon::prelude::*;
    struct Ptr<T>(*mut T);
    // SAFETY: every task writes only its own run's destination values and reads only sources,
    // which no task writes (the caller's contract above).
    unsafe impl<T: Send> Sync for Ptr<T> {}
    unsafe impl<T: Send> Send for Ptr<T> {}
    let len = a.len();
    let p = Ptr(a.as_mut_ptr());
    runs.par_iter().with_min_len(64).for_each(|run| {
        let p = &p;
        let n = run.len;
        let (bs, bd) = (layout.index(run.src, 0), layout.index(run.dst, 0));
        for &v in values(run) {
            assert!(v < layout.nv);
            let (s0, d0) = (bs + v * layout.px, bd + v * layout.px);
            assert!(s0 + n <= len && d0 + n <= len);
            // SAFETY: in bounds (checked above); source and destination ranges do not overlap.
            // Short runs (the x halo: a few nodes per row) are copied inline, not by a call.
            unsafe {
                if n <= 8 {
                    for k in 0..n {
                        *p.0.add(d0 + k) = *p.0.add(s0 + k);
                    }
                } else {
                    std::ptr::copy_nonoverlapping(p.0.add(s0), p.0.add(d0), n)
                }
            };
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f32 storage against f64 on the boundary kinds a fluid-only scene has: a lid-driven
    /// cavity (moving and resting ghost walls) with a disc obstacle (curved ghost walls), a
    /// diatomic gas (the G populations), 1500 steps. Largest differences over the field,
    /// measured 6.7·10⁻⁸ of the lid speed and 8.1·10⁻⁹ of the mean pressure (1.4·10⁻⁶ and
    /// 2.4·10⁻⁷ with the populations stored whole, before the shift of [`Storage`]): f32's
    /// rounding of the departures, grown over 6000 passes but not into a drift. Bounds: 10⁻⁶
    /// and 10⁻⁷ (15× and 12× what was measured; the unshifted storage fails both), far below the
    /// scheme's own error at this resolution, of order 10⁻² of the lid speed.
    #[test]
    fn f32_storage_follows_the_f64_solver_in_a_lid_driven_cavity_with_an_obstacle() {
        use crate::fluid::{
            Boundaries, Equilibrium, FaceCondition, FluidSolver, GasModel, Grid, Macro, Obstacle, Shape, VelocitySet, VelocitySetKind, timestep,
        };
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Diatomic);
        let params = timestep::choose(0.08, 0.6, eq.set.max_l1_speed(), None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        let lid = 0.08;
        let mut b = Boundaries::periodic();
        for f in 0..4 {
            b.faces[f] = FaceCondition::Wall { velocity: [0.0; 3], temperature: None };
        }
        b.faces[3] = FaceCondition::Wall { velocity: [lid, 0.0, 0.0], temperature: None };
        let disc = Obstacle { shape: Shape::Cylinder { center: [15.3, 13.7, 0.0], radius: 5.2 }, velocity: [0.0; 3], temperature: None };
        let a = FluidSolver::new(eq, Grid::new(2, [40, 40, 1]), b, &[disc], params, |_| Macro { rho: 1.0, u: [0.0; 3], theta: 0.6 });
        let mut b: FluidSolver<f32> = a.converted();
        let mut a = a;
        a.run(1500).unwrap();
        b.run(1500).unwrap();
        let (ma, mb) = (a.interior_macros(), b.interior_macros());
        let (mut du, mut dp, mut umax) = (0.0f64, 0.0f64, 0.0f64);
        for (x, y) in ma.iter().zip(&mb) {
            let (Some(x), Some(y)) = (x, y) else {
                assert_eq!(x.is_some(), y.is_some());
                continue;
            };
            let d = |v: [f64; 3], w: [f64; 3]| ((v[0] - w[0]).powi(2) + (v[1] - w[1]).powi(2)).sqrt();
            du = du.max(d(x.u, y.u));
            dp = dp.max((x.pressure() - y.pressure()).abs());
            umax = umax.max(x.speed2().sqrt());
        }
        let p0 = 0.6;
        eprintln!("f32 − f64 after 1500 steps: |Δu| ≤ {:.2e} of the lid, |Δp| ≤ {:.2e} of p0; largest speed {:.3} of the lid", du / lid, dp / p0, umax / lid);
        assert!(umax > 0.3 * lid, "the cavity is driven: largest speed {umax}");
        assert!(du < 1e-6 * lid, "f32 − f64 velocity {du:e}");
        assert!(dp < 1e-7 * p0, "f32 − f64 pressure {dp:e}");
        assert_ne!(du, 0.0, "f32 storage changed nothing: it did not run");
    }

    /// The claim checkpoints rest on: a departure stored in f32 (through `store_departure`,
    /// which floors the tiny ones) decodes to an f64 that encodes back to the same f32 bits,
    /// for shifts over the range of the lattices' weights and departures of every size and sign
    /// (populations from 10⁻⁹ to 10³ times their shift).
    #[test]
    fn an_f32_departure_round_trips_through_f64_bit_for_bit() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut floored, mut kept) = (0, 0);
        for _ in 0..200_000 {
            let s = (10f64.powf(-6.0 + 6.0 * uniform()) as f32) as f64;
            let sign = if uniform() < 0.5 { -1.0 } else { 1.0 };
            let d = sign * s * 10f64.powf(-12.0 + 15.0 * uniform());
            let x = f32::store_departure(d, s);
            if x == 0.0 {
                floored += 1;
                assert!(d.abs() < s * DEPARTURE_FLOOR, "{d:e} of shift {s:e} was floored");
            } else {
                kept += 1;
            }
            let back = f32::encode(x.decode(s), s);
            assert_eq!(back.to_bits(), x.to_bits(), "shift {s:e}, departure {d:e}: {x:e} came back as {back:e}");
        }
        assert!(floored > 10_000 && kept > 100_000, "floored {floored}, kept {kept}");
        // f64 is stored as it is
        assert_eq!(f64::encode(0.125, 3.0), 0.125);
        assert_eq!(f64::store_departure(1e-300, 1.0), 1e-300);
    }
}
