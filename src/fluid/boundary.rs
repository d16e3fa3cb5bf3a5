//! Boundary conditions of the FDLB solver (lattice units); the fill that sets halo and ghost
//! nodes from them before every Runge–Kutta stage is [`super::boundary_fill`].
//!
//! * **Periodic** faces copy the opposite side: the values of h that the advection reads there.
//! * **Walls** (no-slip, moving lid, obstacles with a sub-cell wall position) use ghost nodes
//!   inside the solid: the state at the image point of a ghost (mirrored across the wall, at
//!   least one cell into the fluid) is interpolated from fluid nodes; the ghost gets the wall
//!   velocity extrapolated linearly through the wall, the image density (zero normal pressure
//!   gradient), the wall temperature (isothermal) or the image temperature (adiabatic), and
//!   the image's non-equilibrium part (the non-equilibrium extrapolation of Guo, Zheng & Shi,
//!   Chin. Phys. 11, 366 (2002), applied at the ghost-cell image point of Mittal et al.,
//!   J. Comput. Phys. 227, 4825 (2008)).
//! * **Pressure inlet**: fixed density and temperature (the lung pressure), velocity and
//!   non-equilibrium part from the first interior node. A scene's `pressure_outlet` is the same
//!   condition at the pressure the air leaves to.
//! * **Velocity inlet**: fixed velocity and temperature, density and non-equilibrium part
//!   from the first interior node.
//! * **Outlet**: zero gradient of every population (copy of the first interior node).
//! * **Slip** (a symmetry plane half a cell outside the last interior node): each halo node
//!   holds the mirror image of the interior node as far inside, populations reflected across
//!   the face and the normal velocity negated — zero normal velocity, no shear stress, zero
//!   normal gradients, and a flow that is symmetric about the plane is computed exactly as in
//!   the domain twice as large.

/// One of the 2·D faces of the domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Face {
    XMin,
    XMax,
    YMin,
    YMax,
    ZMin,
    ZMax,
}

impl Face {
    pub const ALL: [Face; 6] = [Face::XMin, Face::XMax, Face::YMin, Face::YMax, Face::ZMin, Face::ZMax];
    pub fn axis(self) -> usize {
        (self as usize) / 2
    }
    pub fn is_max(self) -> bool {
        (self as usize) % 2 == 1
    }
    pub fn name(self) -> &'static str {
        ["x_min", "x_max", "y_min", "y_max", "z_min", "z_max"][self as usize]
    }
}

/// The condition on one face (lattice units).
#[derive(Clone, Debug, PartialEq)]
pub enum FaceCondition {
    Periodic,
    /// A wall half a cell outside the last interior node, moving tangentially with `velocity`.
    Wall {
        velocity: [f64; 3],
        temperature: Option<f64>,
    },
    PressureInlet {
        rho: f64,
        theta: f64,
    },
    VelocityInlet {
        /// The velocity (uniform), or the peak velocity on the centre line (parabolic).
        velocity: [f64; 3],
        theta: f64,
        profile: InletProfile,
    },
    Outlet,
    /// Free-slip wall: the face is a mirror (symmetry) plane half a cell outside the last
    /// interior node.
    Slip,
}

/// Shape of a velocity inlet's profile across the face.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InletProfile {
    #[default]
    Uniform,
    /// Poiseuille: 4s(1 − s) along every transverse axis (s = 0 and 1 at the faces, half a
    /// cell beyond the last nodes), times the peak velocity.
    Parabolic,
}

impl InletProfile {
    /// The profile's factor at node `x` (interior coordinates) of the inlet on `face`.
    pub fn factor(self, grid: &super::grid::Grid, face: Face, x: [i64; 3]) -> f64 {
        match self {
            InletProfile::Uniform => 1.0,
            InletProfile::Parabolic => (0..grid.dim)
                .filter(|&b| b != face.axis())
                .map(|b| {
                    let s = (x[b] as f64 + 0.5) / grid.n[b] as f64;
                    4.0 * s * (1.0 - s)
                })
                .product(),
        }
    }
}

/// Conditions on every face, indexed by [`Face`].
#[derive(Clone, Debug, PartialEq)]
pub struct Boundaries {
    pub faces: [FaceCondition; 6],
}

impl Boundaries {
    pub fn periodic() -> Self {
        Boundaries { faces: std::array::from_fn(|_| FaceCondition::Periodic) }
    }

    /// Which of the first `dim` axes are periodic (their min face periodic; the checks make
    /// both faces agree), the rest `false`.
    pub fn periodic_axes(&self, dim: usize) -> [bool; 3] {
        std::array::from_fn(|a| a < dim && matches!(self.faces[2 * a], FaceCondition::Periodic))
    }
    pub fn face(&self, f: Face) -> &FaceCondition {
        &self.faces[f as usize]
    }

    /// Sets the velocity (lattice units; the peak on the centre line for a parabolic profile) of
    /// the velocity inlet on `face`, for an inflow that changes in time (a smooth start). The
    /// next boundary fill uses it; nothing else of the layout depends on it. Refused, naming the
    /// face, when that face is not a velocity inlet.
    pub fn set_inlet_velocity(&mut self, face: Face, velocity: [f64; 3]) -> Result<(), String> {
        match &mut self.faces[face as usize] {
            FaceCondition::VelocityInlet { velocity: v, .. } => {
                *v = velocity;
                Ok(())
            }
            other => Err(format!("{}: not a velocity inlet ({other:?})", face.name())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::equilibrium::{Equilibrium, Macro};
    use crate::fluid::layout::{HaloReach, Layout, NodeKind};
    use crate::fluid::upwind::stencils;
    use crate::fluid::{FluidSolver, GasModel, Grid, VelocitySet, VelocitySetKind, timestep};
    use std::collections::HashSet;
    use std::f64::consts::PI;

    /// [`HaloReach`] says exactly which (periodic halo node, velocity) pairs the advection
    /// stencils of the fluid nodes read: every pair a stencil reads is copied, and no pair it
    /// declares read goes unread (so the copies left out are the unread ones, and no more).
    #[test]
    fn the_halo_reach_is_exactly_what_the_stencils_read() {
        for (kind, n) in [(VelocitySetKind::D2q21, [9, 8, 1]), (VelocitySetKind::D3q39, [7, 6, 5])] {
            let vs = VelocitySet::new(kind);
            let layout = Layout::new(Grid::new(vs.dim, n), Boundaries::periodic(), &[]);
            let grid = &layout.grid;
            let st = stencils(&vs.c);
            let mut read = HashSet::new();
            for node in (0..grid.len()).filter(|&k| layout.kind[k] == NodeKind::Fluid) {
                let x = grid.coords(node);
                for (i, s) in st.iter().enumerate() {
                    for (d, _) in &s.taps {
                        let y = [x[0] + d[0], x[1] + d[1], x[2] + d[2]];
                        if layout.kind[grid.index(y)] == NodeKind::Periodic {
                            read.insert((grid.index(y), i));
                        }
                    }
                }
            }
            let (mut declared, mut halo_nodes) = (0, 0);
            for run in &layout.periodic {
                for node in run.dst..run.dst + run.len {
                    halo_nodes += 1;
                    assert_eq!(run.reach, HaloReach::of(grid, grid.coords(node)), "{kind:?}: one reach per run");
                    for (i, c) in vs.c.iter().enumerate() {
                        let says = run.reach.read_by(*c);
                        declared += says as usize;
                        assert_eq!(says, read.contains(&(node, i)), "{kind:?}: node {:?}, velocity {c:?}", grid.coords(node));
                    }
                }
            }
            assert_eq!(halo_nodes, (0..grid.len()).filter(|&k| layout.kind[k] == NodeKind::Periodic).count());
            assert_eq!(declared, read.len());
            // what is left out: in 3D, 7 × 6 × 5 interior nodes in an 11 × 10 × 9 box
            let all = halo_nodes * vs.c.len();
            eprintln!("{kind:?}: {} of {all} halo values read ({:.0} %)", read.len(), 100.0 * read.len() as f64 / all as f64);
            assert!(read.len() < all / 2, "{kind:?}: {} of {all}", read.len());
        }
    }

    /// The halo values that the boundary fill leaves out are never read: with every value of f,
    /// f¹, fⁿ⁺¹, h and the macroscopic fields at the periodic halo nodes set to NaN, 12 steps
    /// give every fluid node's
    /// populations bit for bit (2D and 3D, periodic in x — and z — with walls, a lid, an
    /// obstacle next to a periodic face, a body force and the rotational energy of a diatomic
    /// gas).
    #[test]
    fn the_unread_periodic_halo_values_are_never_read() {
        for (kind, n) in [(VelocitySetKind::D2q21, [14, 10, 1]), (VelocitySetKind::D3q39, [9, 8, 6])] {
            let scene = || crate::fluid::fixtures::busy_lattice::<f64>(kind, n, 0.8);
            let (mut plain, mut poisoned) = (scene(), scene());
            // the x–z edges of the 3D halo are read by no stencil (in 2D the corners are walls')
            assert_eq!(plain.layout.periodic.iter().any(|r| r.reach == HaloReach::Unread), kind == VelocitySetKind::D3q39);
            poisoned.poison_periodic_halos();
            plain.run(12).unwrap();
            poisoned.run(12).expect("no NaN read");
            for node in (0..plain.layout.grid.len()).filter(|&k| plain.layout.kind[k] == NodeKind::Fluid) {
                let (a, b) = (plain.node_populations(node), poisoned.node_populations(node));
                assert!(a.iter().zip(&b).all(|(a, b)| a.to_bits() == b.to_bits()), "{kind:?}: node {:?}", plain.layout.grid.coords(node));
            }
        }
    }

    /// A velocity inlet takes a new velocity (the rest of its condition kept); any other face
    /// refuses, naming itself.
    #[test]
    fn only_a_velocity_inlet_takes_a_new_velocity() {
        let mut b = Boundaries::periodic();
        b.faces[0] = FaceCondition::VelocityInlet { velocity: [0.1, 0.0, 0.0], theta: 0.6, profile: InletProfile::Parabolic };
        b.set_inlet_velocity(Face::XMin, [0.05, 0.01, 0.0]).unwrap();
        assert_eq!(b.faces[0], FaceCondition::VelocityInlet { velocity: [0.05, 0.01, 0.0], theta: 0.6, profile: InletProfile::Parabolic });
        let e = b.set_inlet_velocity(Face::XMax, [0.05, 0.0, 0.0]).unwrap_err();
        assert!(e.starts_with("x_max: not a velocity inlet"), "{e}");
        assert_eq!(b.faces[1], FaceCondition::Periodic);
    }

    /// A Taylor–Green vortex is mirror-symmetric about the lines where its normal velocity
    /// vanishes; the block between them, with slip faces on those lines, must evolve exactly as
    /// that block of the periodic vortex twice as wide (up to the periodic run's own rounding
    /// asymmetry). No-slip walls there change it at first order.
    #[test]
    fn a_slip_face_is_a_symmetry_plane_of_the_flow() {
        let (n, u0, th0, nu) = (32usize, 0.03, 0.6, 0.02);
        let k = 2.0 * PI / n as f64;
        let eq = || Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Monatomic);
        let l1 = eq().set.max_l1_speed();
        let params = timestep::choose(nu, th0, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        // Node i of the periodic box sits at x = i + ½, so that the symmetry lines x = n/4 and
        // 3n/4 fall half-way between nodes, where a slip face puts its plane.
        let vortex = move |shift: f64| {
            move |x: [f64; 3]| {
                let (kx, ky) = (k * (x[0] + shift), k * (x[1] + shift));
                let p = th0 - 0.25 * u0 * u0 * ((2.0 * kx).cos() + (2.0 * ky).cos());
                Macro { rho: p / th0, u: [-u0 * kx.cos() * ky.sin(), u0 * kx.sin() * ky.cos(), 0.0], theta: th0 }
            }
        };
        let mut full = FluidSolver::new(eq(), Grid::new(2, [n, n, 1]), Boundaries::periodic(), &[], params, vortex(0.5));
        let q = n / 4;
        let half = |face: FaceCondition| {
            let mut b = Boundaries::periodic();
            for f in [Face::XMin, Face::XMax, Face::YMin, Face::YMax] {
                b.faces[f as usize] = face.clone();
            }
            FluidSolver::new(eq(), Grid::new(2, [n / 2, n / 2, 1]), b, &[], params, vortex(q as f64 + 0.5))
        };
        let mut slip = half(FaceCondition::Slip);
        let mut no_slip = half(FaceCondition::Wall { velocity: [0.0; 3], temperature: None });
        let steps = 200;
        full.run(steps).unwrap();
        slip.run(steps).unwrap();
        no_slip.run(steps).unwrap();
        let worst = |s: &FluidSolver| {
            let mut d: f64 = 0.0;
            for i in 0..n / 2 {
                for j in 0..n / 2 {
                    let a = s.macro_at_coords([i as i64, j as i64, 0]);
                    let b = full.macro_at_coords([(i + q) as i64, (j + q) as i64, 0]);
                    d = d.max(((a.u[0] - b.u[0]).abs()).max((a.u[1] - b.u[1]).abs()) / u0).max((a.rho - b.rho).abs());
                }
            }
            d
        };
        // The vortex has decayed measurably, so the comparison is not of two initial states.
        let corner = full.macro_at_coords([0, q as i64, 0]).u[0].abs();
        let decay = corner / (u0 * (k * 0.5).cos() * (k * (q as f64 + 0.5)).sin()).abs();
        assert!(decay < 0.95, "decay {decay}");
        let (d_slip, d_wall) = (worst(&slip), worst(&no_slip));
        println!("after {steps} steps (amplitude {decay:.3} of the initial): slip {d_slip:.2e}, no-slip {d_wall:.2e} of U");
        assert!(d_slip < 1e-12, "slip block differs from the periodic vortex by {d_slip:e} of U");
        assert!(d_wall > 1e-2, "no-slip walls differ by only {d_wall:e}: the comparison cannot tell");
    }
}
