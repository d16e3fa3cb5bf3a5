//! What a [`FluidSolver`]'s state says: the macroscopic fields (moments (2.79)–(2.81) of fⁿ),
//! the conserved totals over fluid nodes and the largest local Mach number (lattice units).

use super::equilibrium::Macro;
use super::layout::NodeKind;
use super::solver::FluidSolver;
use super::storage::Storage;
use rayon::prelude::*;

/// Totals over fluid nodes (lattice units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Totals {
    pub mass: f64,
    pub momentum: [f64; 3],
    pub energy: f64,
}

impl<S: Storage> FluidSolver<S> {
    /// Macroscopic state of a padded node of fⁿ.
    pub fn macro_at(&self, node: usize) -> Macro {
        self.eq.moments(&self.node_populations(node))
    }

    /// Macroscopic state at interior node coordinates.
    pub fn macro_at_coords(&self, x: [i64; 3]) -> Macro {
        self.macro_at(self.layout.grid.index(x))
    }

    /// Macroscopic fields of every interior node, x fastest (solid nodes: `None`).
    pub fn interior_macros(&self) -> Vec<Option<Macro>> {
        let g = &self.layout.grid;
        let mut out = Vec::with_capacity(g.interior_len());
        for z in 0..g.n[2] as i64 {
            for y in 0..g.n[1] as i64 {
                for x in 0..g.n[0] as i64 {
                    let node = g.index([x, y, z]);
                    out.push((self.layout.kind[node] == NodeKind::Fluid).then(|| self.macro_at(node)));
                }
            }
        }
        out
    }

    /// Mass, momentum and total energy (Σ f c²/2 + Σ G) summed over fluid nodes.
    pub fn totals(&self) -> Totals {
        let q = self.eq.q();
        let eq = &self.eq;
        let kind = &self.layout.kind;
        let (mass, mx, my, mz, energy) = (0..self.layout.grid.len())
            .into_par_iter()
            .with_min_len(1024)
            .filter(|node| kind[*node] == NodeKind::Fluid)
            .map(|node| {
                let f = self.node_populations(node);
                let mut t = (0.0, 0.0, 0.0, 0.0, 0.0);
                for i in 0..q {
                    let c = eq.cf[i];
                    t.0 += f[i];
                    t.1 += f[i] * c[0];
                    t.2 += f[i] * c[1];
                    t.3 += f[i] * c[2];
                    t.4 += f[i] * eq.half_c2[i];
                }
                for &g in &f[q..] {
                    t.4 += g;
                }
                t
            })
            .reduce(|| (0.0, 0.0, 0.0, 0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3, a.4 + b.4));
        Totals { mass, momentum: [mx, my, mz], energy }
    }

    /// Largest local Mach number |u|/c_s over fluid nodes.
    pub fn max_mach(&self) -> f64 {
        let kind = &self.layout.kind;
        (0..self.layout.grid.len())
            .into_par_iter()
            .with_min_len(1024)
            .filter(|node| kind[*node] == NodeKind::Fluid)
            .map(|node| {
                let m = self.macro_at(node);
                m.speed2().sqrt() / self.eq.sound_speed(m.theta)
            })
            .reduce(|| 0.0, f64::max)
    }
}
