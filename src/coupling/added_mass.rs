//! The air's added mass in method 2's solid update (seed 000 (2.129)):
//!
//! (M_s + ∫_S w_n f_c1,in ds) V^{n+1} = M_s V* − M_s Δt D V^{n+1} + ∫_S W_n ds.
//!
//! The seed adds to the particles' mass the air that meets the wall within the step, so that
//! the air's answer to the wall's **new** velocity is part of the solid's update instead of
//! arriving one step late (the staggered exchange that makes light bodies unstable,
//! `validation::fsi::added_mass_stability`).
//!
//! **What M_a is here.** This solver advects by finite differences, so no population "arrives"
//! at the wall; the air's answer within a step to a change δV of the wall's normal velocity is
//! the acoustic one, δp = ρ₀ c_s δV_n (a piston's), i.e. a momentum ρ₀ c_s Δt A δV_n through a
//! wall of area A over the step — the seed's f_c1,in (the mass the links bring in one step)
//! for a continuum. Per wall node with `n` faces to fluid nodes (area 1 cell^(D−1) each), the
//! scalar the solid's mass matrix can hold is the mean over directions of the face's normal
//! tensor n⊗n: m_node = ρ₀ c_s Δt n / D (lattice units). It is shared among the particles
//! within r_e with the kernel weights normalised to one, as the momentum is (2.127–2.128),
//! once, from the initial walls (a surface particle stays one); clamped particles take none.
//!
//! **Momentum.** The walls moved at Vⁿ during the fluid step, so the air's momentum loss P
//! already carries the reaction −M_a Vⁿ; with (M + M_a) ΔV = Δt f the solid receives
//! P − M_a ΔV, which replaces that stale part by −M_a V^{n+1}. What the solid does not receive
//! is booked in the ledger Σ m_a v ([`CoupledSolver::added_mass_momentum`]): air + Σ m v +
//! Σ m_a v is conserved to round-off. The ledger is bounded by M_a max|V| (M_a ∝ Δt), and the
//! change of the scheme is O(Δt²) per step: consistent for any M_a ∝ Δt.
//!
//! Units: particles' added mass in the solid's physical units (kg, or kg/m in 2D).

use super::momentum_exchange::is_wall;
use super::solver::CoupledSolver;
use crate::fluid::layout::NodeKind;
use glam::DVec3;

impl CoupledSolver {
    /// Method 2's added mass of every particle (2.129) from the current walls and level sets
    /// (physical mass units; zero for clamped or prescribed particles and for particles with no
    /// wall node within r_e).
    pub(super) fn fluid_added_mass(&self) -> Vec<f64> {
        let p = &self.solid.particles;
        let mut added = vec![0.0; p.len()];
        let Some(ex) = self.exchange.as_ref() else { return added };
        let grid = &self.fluid.layout.grid;
        let kind = &self.fluid.layout.kind;
        let dim = grid.dim;
        // ρ₀ c_s Δt per cell face, lattice units → physical mass (ρ Δx^D per lattice unit)
        let per_face = self.fluid.eq.sound_speed(self.units.theta0) * self.fluid.params.dt / dim as f64 * self.units.density * self.units.dx.powi(dim as i32);
        for node in 0..grid.len() {
            if !is_wall(kind[node]) {
                continue;
            }
            let faces = (0..dim)
                .flat_map(|a| [1isize, -1].map(|s| node as isize + s * grid.stride[a] as isize))
                .filter(|&n| n >= 0 && (n as usize) < grid.len() && matches!(kind[n as usize], NodeKind::Fluid | NodeKind::Periodic))
                .count();
            if faces == 0 {
                continue;
            }
            let x = grid.coords(node);
            let at = [x[0] as f64, x[1] as f64, x[2] as f64];
            let weights: Vec<(usize, f64)> =
                ex.sets().iter().zip(self.members.bodies()).flat_map(|(s, m)| s.weights(at).map(move |(j, wj)| (m[j], wj))).collect();
            let sum: f64 = weights.iter().map(|(_, w)| w).sum();
            if sum <= 0.0 {
                continue;
            }
            for (i, wj) in weights {
                added[i] += wj / sum * faces as f64 * per_face;
            }
        }
        for (i, m) in added.iter_mut().enumerate() {
            if p.fixed[i] {
                *m = 0.0;
            }
        }
        added
    }

    /// The momentum in transit of method 2's added mass, Σ m_a v (physical units; zero without
    /// added mass): air + particles + this is what the coupling conserves to round-off.
    pub fn added_mass_momentum(&self) -> DVec3 {
        let p = &self.solid.particles;
        (0..p.len()).map(|i| p.added_mass[i] * p.velocity[i]).sum()
    }
}
