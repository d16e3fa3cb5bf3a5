//! Boundary conditions of the FDLB solver (lattice units) and the fill that sets halo and ghost
//! nodes before every Runge–Kutta stage.
//!
//! * **Periodic** faces copy the opposite side.
//! * **Walls** (no-slip, moving lid, obstacles with a sub-cell wall position) use ghost nodes
//!   inside the solid: the state at the image point of a ghost (mirrored across the wall, at
//!   least one cell into the fluid) is interpolated from fluid nodes; the ghost gets the wall
//!   velocity extrapolated linearly through the wall, the image density (zero normal pressure
//!   gradient), the wall temperature (isothermal) or the image temperature (adiabatic), and
//!   the image's non-equilibrium part (the non-equilibrium extrapolation of Guo, Zheng & Shi,
//!   Chin. Phys. 11, 366 (2002), applied at the ghost-cell image point of Mittal et al.,
//!   J. Comput. Phys. 227, 4825 (2008)).
//! * **Pressure inlet**: fixed density and temperature (the lung pressure), velocity and
//!   non-equilibrium part from the first interior node.
//! * **Velocity inlet**: fixed velocity and temperature, density and non-equilibrium part
//!   from the first interior node.
//! * **Outlet**: zero gradient of every population (copy of the first interior node).

use super::equilibrium::{Equilibrium, MACRO_FIELDS, Macro};
use super::layout::Layout;
use super::storage::{RowBlocked, copy_runs_parallel};
use super::timestep::StepParams;

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
    pub fn face(&self, f: Face) -> &FaceCondition {
        &self.faces[f as usize]
    }
}

/// Node state arrays of one Runge–Kutta stage: populations f, the advected field
/// h = (1 − A/τ) f + (A/τ) f⁰, and the macroscopic fields.
pub struct StageFields<'a> {
    pub f: &'a mut [f64],
    pub h: &'a mut [f64],
    pub mac: &'a mut [f64],
    pub pop: RowBlocked,
    pub mac_layout: RowBlocked,
}

/// Fills ghost, inlet/outlet and periodic halo nodes of `fields` (seed §2.3 boundaries; see the
/// module docs). Fluid nodes must already hold their moments and equilibria.
pub fn fill_boundaries(layout: &Layout, eq: &Equilibrium, fields: &mut StageFields, p: StepParams) {
    let k_eq = p.a / p.tau;
    let nv = eq.values_per_node();
    let mut w = vec![0.0; eq.set.shells.len()];
    let mut fe = vec![0.0; nv];
    let mut neq = vec![0.0; nv];
    let mut fk = vec![0.0; nv];

    // Ghost nodes inside walls and obstacles.
    for g in &layout.ghosts {
        let mut m = [0.0; MACRO_FIELDS];
        neq.iter_mut().for_each(|v| *v = 0.0);
        for &(k, wk) in &g.image {
            let mk = read_macro(fields, k);
            for (v, x) in m.iter_mut().zip([mk.rho, mk.u[0], mk.u[1], mk.u[2], mk.theta]) {
                *v += wk * x;
            }
            eq.feq_into(&mk, &mut w, &mut fe);
            fields.pop.gather(fields.f, k, &mut fk);
            for i in 0..nv {
                neq[i] += wk * (fk[i] - fe[i]);
            }
        }
        let r = g.ratio;
        let uw = g.wall_velocity;
        let u = [uw[0] + r * (m[1] - uw[0]), uw[1] + r * (m[2] - uw[1]), uw[2] + r * (m[3] - uw[2])];
        let theta = match g.wall_temperature {
            Some(tw) => tw + r * (m[4] - tw),
            None => m[4],
        };
        // Zero normal pressure gradient: the ghost keeps the image pressure at its own temperature.
        let mg = Macro { rho: m[0] * m[4] / theta, u, theta };
        set_node(eq, fields, g.node, &mg, &neq, k_eq, &mut w, &mut fe);
    }

    // Inlet and outlet halos.
    for h in &layout.face_halos {
        let src = h.source;
        match &layout.boundaries.faces[h.face as usize] {
            FaceCondition::Outlet => {
                copy_node(fields, src, h.node);
            }
            FaceCondition::PressureInlet { rho, theta } => {
                let ms = read_macro(fields, src);
                non_equilibrium(eq, fields, src, &mut w, &mut fe, &mut neq);
                let m = Macro { rho: *rho, u: ms.u, theta: *theta };
                set_node(eq, fields, h.node, &m, &neq, k_eq, &mut w, &mut fe);
            }
            FaceCondition::VelocityInlet { velocity, theta, profile } => {
                let ms = read_macro(fields, src);
                non_equilibrium(eq, fields, src, &mut w, &mut fe, &mut neq);
                let k = profile.factor(&layout.grid, h.face, layout.grid.coords(h.node));
                let m = Macro { rho: ms.rho, u: velocity.map(|v| k * v), theta: *theta };
                set_node(eq, fields, h.node, &m, &neq, k_eq, &mut w, &mut fe);
            }
            FaceCondition::Periodic | FaceCondition::Wall { .. } => unreachable!("not a face halo"),
        }
    }

    // Periodic halos last, so that they also copy ghosts that lie next to a periodic face.
    copy_runs_parallel(fields.pop, fields.f, &layout.periodic);
    copy_runs_parallel(fields.pop, fields.h, &layout.periodic);
    copy_runs_parallel(fields.mac_layout, fields.mac, &layout.periodic);
}

fn read_macro(fields: &StageFields, node: usize) -> Macro {
    let mut m = [0.0; MACRO_FIELDS];
    fields.mac_layout.gather(fields.mac, node, &mut m);
    Macro { rho: m[0], u: [m[1], m[2], m[3]], theta: m[4] }
}

/// f − f⁰ of `node` into `neq`.
fn non_equilibrium(eq: &Equilibrium, fields: &StageFields, node: usize, w: &mut [f64], fe: &mut [f64], neq: &mut [f64]) {
    eq.feq_into(&read_macro(fields, node), w, fe);
    fields.pop.gather(fields.f, node, neq);
    for (n, e) in neq.iter_mut().zip(fe.iter()) {
        *n -= e;
    }
}

fn copy_node(fields: &mut StageFields, src: usize, dst: usize) {
    fields.pop.copy_node(fields.f, src, dst);
    fields.pop.copy_node(fields.h, src, dst);
    fields.mac_layout.copy_node(fields.mac, src, dst);
}

/// Writes macro `m`, f = f⁰ + neq and h = f + (A/τ)(f⁰ − f) = f⁰ + (1 − A/τ) neq into `node`.
#[allow(clippy::too_many_arguments)]
fn set_node(eq: &Equilibrium, fields: &mut StageFields, node: usize, m: &Macro, neq: &[f64], k_eq: f64, w: &mut [f64], fe: &mut [f64]) {
    eq.feq_into(m, w, fe);
    let f: Vec<f64> = fe.iter().zip(neq).map(|(e, n)| e + n).collect();
    let h: Vec<f64> = fe.iter().zip(neq).map(|(e, n)| e + (1.0 - k_eq) * n).collect();
    fields.pop.scatter(fields.f, node, &f);
    fields.pop.scatter(fields.h, node, &h);
    fields.mac_layout.scatter(fields.mac, node, &[m.rho, m.u[0], m.u[1], m.u[2], m.theta]);
}
