//! The momentum the air hands to the walls in one FDLB step, link by link (seed 000 §2.4.2,
//! 2.120–2.123 and 2.127–2.128, adapted to this solver's finite-difference advection).
//!
//! The seed follows each lattice link that crosses the body's surface: the population that
//! arrives at the wall carries W_in = f_in c (2.122), the one that leaves it W_out, and the
//! coupling conserves momentum because the solid receives exactly W_in + W_out (2.123). This
//! solver advects by 3rd-order upwind differences (`fluid::upwind`), which along an axis a,
//! for a velocity with s = sign(c_a), is the difference of two **face fluxes**:
//!
//! c_a ∂h/∂x ≈ |c_a| (F_{x+s/2} − F_{x−s/2}),   F_{x+s/2} = [2h(x+s) + 5h(x) − h(x−s)]/6,
//!
//! (expanding gives the stencil [2, 3, −6, 1]/6). Between two fluid nodes the face's flux
//! leaves one and enters the other, so the sum over the fluid telescopes: the fluid's
//! momentum changes only through the faces between a fluid node and a wall (ghost) node. Those
//! face fluxes are the W_in − W_out of the link: what the wall node takes out of the fluid,
//! exactly, in the same floating-point values the fluid used. [`add_face_fluxes`] adds them up
//! per wall node for one advection stage; with Heun's method the first stage enters the new
//! state with weight ½ ([`stage_weight`]). The collision conserves momentum at every node, so
//! over a step the fluid's momentum changes by minus the sum of what the wall nodes received
//! (to round-off) — checked by the test below in a periodic box with a fixed obstacle.
//!
//! Where a wall is thinner than the stencil (two walls that close on each other, a thin plate)
//! the fluid's stencils take side ghosts or one-sided weights (`fluid::thin_wall`), not in flux
//! form; what their corrections change in the fluid's momentum is booked
//! to the thin wall next to the reader, so the balance stays exact.
//!
//! Units: lattice units (momentum Σ c_i f_i per cell).

use crate::fluid::FluidSolver;
use crate::fluid::layout::NodeKind;
use crate::fluid::thin_wall::tap_correction;
use crate::stages::{Stage, StageKind};
use glam::DVec4;

/// The weight of an advection stage's face fluxes in the step's result: the stage's
/// advection factor times Δt, times ½ for the first Heun stage (fⁿ⁺¹ = ½ fⁿ + ½ f¹ + …);
/// `None` for the stages that do not advect.
/// Both Heun stages come to ½Δt: the first advects with factor 1 into f¹, which enters with
/// ½; the second advects with factor ½ into fⁿ⁺¹ directly.
pub fn stage_weight(stage: &Stage, dt: f64) -> Option<f64> {
    (stage.kind == StageKind::Advect).then_some(0.5 * dt)
}

/// Whether the fluid's stencils read `kind` as a wall (not fluid, not a periodic copy).
pub(crate) fn is_wall(kind: NodeKind) -> bool {
    !matches!(kind, NodeKind::Fluid | NodeKind::Periodic)
}

/// Adds to `wall[node]` the momentum that the advection stage just run (advected field h in
/// [`FluidSolver::stage_arrays`]) moved from the fluid into the wall node `node` through its
/// faces with fluid nodes, times `weight` ([`stage_weight`]). `wall` has one entry per padded
/// node, momentum in x, y, z and mass in w. With `reference` (the populations of the air at rest in its reference state, one per
/// velocity), each face's flux is counted against that state's: the walls receive the gauge
/// momentum, so that the ambient pressure p₀ does not squeeze a body whose reference shape is
/// its shape in air at p₀. The reference fluxes of a closed wall cancel (along every lattice
/// line a wall has as many upstream as downstream faces), so the total is unchanged.
pub fn add_face_fluxes(fluid: &FluidSolver, weight: f64, reference: Option<&[f64]>, wall: &mut [DVec4]) {
    let (_, _, h, _) = fluid.stage_arrays();
    let layout = &fluid.layout;
    let grid = &layout.grid;
    let kind = &layout.kind;
    let pop = &fluid.pop;
    let c = &fluid.eq.set.c;
    let q = fluid.eq.q();
    let at = |node: usize, d: isize| (node as isize + d) as usize;
    // (c_i, 1): momentum and mass of one unit of population i
    let cv = |i: usize| DVec4::new(c[i][0] as f64, c[i][1] as f64, c[i][2] as f64, 1.0);
    // Only a fluid node with a wall next to it along an axis has a wall face: the layout lists
    // them, in the order a scan of the lattice would meet them (the sums stay bit for bit).
    for &node in &layout.wall_faces {
        for (i, ci) in c.iter().enumerate().take(q) {
            let hv = |n: usize| h[pop.index(n, i)];
            let h0 = reference.map_or(0.0, |r| r[i]);
            for a in 0..grid.dim {
                if ci[a] == 0 {
                    continue;
                }
                let m = ci[a].unsigned_abs() as f64;
                let s = ci[a].signum() as isize * grid.stride[a] as isize;
                let (plus, minus) = (at(node, s), at(node, -s));
                if is_wall(kind[plus]) {
                    // Out of the fluid through the downstream face.
                    let flux = (2.0 * hv(plus) + 5.0 * hv(node) - hv(minus)) / 6.0;
                    wall[plus] += weight * m * (flux - h0) * cv(i);
                }
                if is_wall(kind[minus]) {
                    // Into the fluid through the upstream face.
                    let flux = (2.0 * hv(node) + 5.0 * hv(minus) - hv(at(node, -2 * s))) / 6.0;
                    wall[minus] -= weight * m * (flux - h0) * cv(i);
                }
            }
        }
    }
    // The stencils next to thin walls ([`crate::fluid::thin_wall`]: side ghosts, or one-sided)
    // change the fluid's momentum by their correction, which is not a face flux: the wall next to the
    // reader (its first non-fluid tap) takes the opposite. A correction of a uniform field at
    // rest is zero (the weights sum to zero; a side ghost then holds the far node's value), so
    // there is no reference part.
    let (side_h, nv) = (fluid.side_ghost_values(), fluid.eq.values_per_node());
    let mut slot = 0;
    for t in &layout.thin_taps {
        let s = t.sign as isize * grid.stride[t.axis] as isize;
        let taps = [t.node, at(t.node, s), at(t.node, -s), at(t.node, -2 * s)];
        let target = taps[1..].iter().copied().find(|&n| is_wall(kind[n])).unwrap_or(taps[1]);
        let first_slot = slot;
        slot += t.sides.len();
        for (i, ci) in c.iter().enumerate().take(q) {
            if ci[t.axis].signum() as i64 != t.sign {
                continue;
            }
            let corr = tap_correction(t, i, nv, first_slot, side_h, |m| h[pop.index(at(t.node, m * s), i)]);
            // The fluid node changed by −weight·|c_a|/6·corr.
            wall[target] += weight * (ci[t.axis].unsigned_abs() as f64 / 6.0) * corr * cv(i);
        }
    }
}

/// Runs one fluid step and returns what every wall node received (lattice units, one entry
/// per padded node: momentum in x, y, z, mass in w).
pub fn step_with_exchange(fluid: &mut FluidSolver, reference: Option<&[f64]>) -> Result<Vec<DVec4>, crate::step::Instability> {
    let mut wall = vec![DVec4::ZERO; fluid.layout.grid.len()];
    let dt = fluid.params.dt;
    fluid.step_observed(|stage, f| {
        if let Some(w) = stage_weight(stage, dt) {
            add_face_fluxes(f, w, reference, &mut wall);
        }
    })?;
    Ok(wall)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::{Boundaries, Equilibrium, GasModel, Grid, Macro, Obstacle, Shape, VelocitySet, VelocitySetKind, timestep};
    use glam::DVec3;

    /// A fixed disc in a fully periodic box of air moving at Mach ≈ 0.1 with a pressure bump:
    /// over every step, the air's momentum changes by exactly minus what the wall nodes
    /// received through their faces (to round-off: ≤ 1e-13 of the air's momentum), and the
    /// walls do receive momentum (the drag). Without the obstacle the air's momentum does not
    /// change (the telescoping of the face fluxes, and the collision's local conservation).
    #[test]
    fn the_air_loses_exactly_what_the_walls_receive() {
        let vs = VelocitySet::new(VelocitySetKind::D2q21);
        let l1 = vs.max_l1_speed();
        let eq = Equilibrium::new(vs, GasModel::Monatomic);
        let theta0 = 0.6;
        let params = timestep::choose(0.05, theta0, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        let u0 = 0.1 * eq.sound_speed(theta0);
        let init = move |x: [f64; 3]| {
            let r2 = (x[0] - 8.0).powi(2) + (x[1] - 12.0).powi(2);
            Macro { rho: 1.0 + 0.01 * (-r2 / 9.0).exp(), u: [u0, 0.3 * u0, 0.0], theta: theta0 }
        };
        let disc = Obstacle { shape: Shape::Cylinder { center: [16.3, 11.8, 0.0], radius: 4.2 }, velocity: [0.0; 3], temperature: None };
        for obstacles in [vec![disc], vec![]] {
            let mut f = crate::fluid::FluidSolver::new(eq.clone(), Grid::new(2, [32, 24, 1]), Boundaries::periodic(), &obstacles, params, init);
            let p0 = DVec3::from_array(f.totals().momentum);
            let mut received = DVec3::ZERO;
            let mut worst: f64 = 0.0;
            for _ in 0..50 {
                let before = DVec3::from_array(f.totals().momentum);
                let wall = step_with_exchange(&mut f, None).unwrap();
                let w: DVec3 = wall.iter().copied().sum::<DVec4>().truncate();
                let after = DVec3::from_array(f.totals().momentum);
                worst = worst.max((after - before + w).length() / p0.length());
                received += w;
            }
            assert!(worst < 1e-13, "obstacles {}: imbalance {worst:e} of the air's momentum", obstacles.len());
            if obstacles.is_empty() {
                assert_eq!(received, DVec3::ZERO);
            } else {
                // The disc is pushed downstream.
                assert!(received.x > 1e-3 * p0.length(), "{received:?} vs {p0:?}");
            }
            eprintln!("obstacles {}: worst per-step imbalance {worst:.2e}, walls received {received:?} of {p0:?}", obstacles.len());
        }
    }
}
