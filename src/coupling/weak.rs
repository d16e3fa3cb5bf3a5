//! The weak coupling (method 1, seed 000 §2.4.1) on the CPU: one coupled step runs
//! [`crate::stages::COUPLED_WEAK_STEP`] — the bodies' surfaces become moving walls of the
//! fluid, the fluid takes one step, the air's tractions load the surface particles, and the
//! explicit solid sub-steps over the fluid's time step ([`super::solver::CoupledSolver`]).
//!
//! The fluid side of the moving wall: the seed adapts Mei et al.'s curved bounce-back (2.105–
//! 2.109) to the FDLB, sub-dividing the step for the speeds that cross 2 and 3 cells. This
//! solver's FDLB advects by 3rd-order upwind finite differences whose stencil reads up to two
//! nodes behind a fluid node, so its walls enter through ghost nodes (see
//! [`crate::fluid::boundary`]: image-point extrapolation of the macroscopic state, the wall
//! velocity imposed, non-equilibrium part carried over) — already validated for fixed and
//! moving walls; here each ghost takes the wall velocity of the closest point of the body's
//! surface polygon. No per-speed sub-division is needed: the ghost state serves every
//! velocity of the stencil. The moving body must not cross more than one cell per step. Where
//! two bodies close on each other the wall between two fluid regions becomes thinner than the
//! stencil; the fluid nodes there read side ghosts of their own side, or one-sided stencils
//! where none can be built ([`crate::fluid::thin_wall`]), so that no state passes through the
//! contact.
//!
//! Units: the solid works in the scene's physical units; the fluid in lattice units; positions
//! map through [`crate::units::Units::position_to_lattice`] (the same origin).

use super::solver::CoupledSolver;
use super::traction::{SurfaceForces, TractionModel, surface_forces};
use super::traction_plan::TractionPlan;
use crate::fluid::layout::Layout;
use crate::fluid::{LayoutChange, Polygon, Shape};
use crate::step::{Instability, Site};

/// Options of the weak coupling.
#[derive(Clone, Copy, Debug)]
pub struct WeakOptions {
    pub traction: TractionModel,
    /// Longest surface piece (lattice cells) of the traction quadrature.
    pub piece_length: f64,
    /// Largest surface displacement per fluid step (cells).
    pub max_cells_per_step: f64,
}

impl Default for WeakOptions {
    fn default() -> Self {
        Self { traction: TractionModel::default(), piece_length: 1.0, max_cells_per_step: 1.0 }
    }
}

/// Method 1's walls at the particles' positions ([`CoupledSolver::next_polygon_walls`]).
pub struct PolygonWalls {
    polygons: Vec<Polygon>,
    layout: Layout,
    change: std::cell::OnceCell<LayoutChange>,
}

impl PolygonWalls {
    /// The fluid's layout with these walls.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The change of layout installing these walls in a fluid of layout `current` makes (made
    /// once and kept: the walls are built for the fluid they are installed in).
    pub fn change(&self, current: &Layout) -> &LayoutChange {
        self.change.get_or_init(|| LayoutChange::between(current, &self.layout))
    }

    /// Whether installing these walls in a fluid of layout `current` makes nodes enter or leave
    /// the fluid (their populations, and their fluid neighbours', are then read and written).
    pub fn changes_nodes(&self, current: &Layout) -> bool {
        !self.change(current).nodes.is_empty()
    }
}

impl CoupledSolver {
    /// The surface polygons in lattice coordinates, with wall velocities in c units.
    pub fn polygons(&self) -> Vec<Polygon> {
        let u = &self.units;
        let p = &self.solid.particles;
        self.bodies
            .iter()
            .map(|b| {
                let x = b.surface.points(p);
                let v = b.surface.velocities(p);
                Polygon::new(
                    x.iter().map(|x| [u.position_to_lattice(x.x), u.position_to_lattice(x.y)]).collect(),
                    v.iter().map(|v| (*v / u.velocity).to_array()).collect(),
                )
            })
            .collect()
    }

    /// Method 1's fluid_geometry stage: the surface polygons become the fluid's moving walls.
    pub(super) fn polygon_geometry(&mut self, o: WeakOptions) -> Result<(), Instability> {
        if let Some(walls) = self.next_polygon_walls(o)? {
            self.install_polygon_walls(walls);
        }
        Ok(())
    }

    /// The walls of the surface polygons at the particles' current positions, with the layout
    /// they give the fluid, without installing them; `None` when no polygon moved (nor changed
    /// its wall velocities) since the walls were last built. Refuses a surface that moved more
    /// than `o.max_cells_per_step` cells.
    pub fn next_polygon_walls(&self, o: WeakOptions) -> Result<Option<PolygonWalls>, Instability> {
        self.next_polygon_walls_with(o, &crate::fluid::OnThePool)
    }

    /// [`Self::next_polygon_walls`] with the layout built through `queries`: a polygon asks no
    /// level-set question, but `queries` hears how long the layout's parts took
    /// ([`crate::fluid::LevelSetQueries::part_timed`]: the geometry bench).
    pub fn next_polygon_walls_with(&self, o: WeakOptions, queries: &dyn crate::fluid::LevelSetQueries) -> Result<Option<PolygonWalls>, Instability> {
        let polys = self.polygons();
        if let Some(old) = &self.built {
            let mut moved = false;
            for (k, (a, b)) in old.iter().zip(&polys).enumerate() {
                let d = a.vertices().iter().zip(b.vertices()).map(|(p, q)| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()).fold(0.0, f64::max);
                if d > o.max_cells_per_step {
                    return Err(self.moved_too_far(
                        Site::Body(self.bodies[k].surface.body),
                        "surface displacement in one step (cells)",
                        d,
                        o.max_cells_per_step,
                    ));
                }
                // Wall velocities change even when the vertices do not (a body set moving).
                moved |= d > 0.0 || a.velocities() != b.velocities();
            }
            if !moved {
                return Ok(None);
            }
        }
        let mut all = self.obstacles.clone();
        all.extend(self.body_walls(polys.iter().cloned().map(Shape::Polygon)));
        let layout = self.fluid.layout_with_level_sets(&all, queries);
        Ok(Some(PolygonWalls { polygons: polys, layout, change: Default::default() }))
    }

    /// Installs walls from [`Self::next_polygon_walls`]: nodes the bodies uncovered take their
    /// fluid neighbours' populations, covered ones leave with their mass (counted in
    /// [`Self::geometry`]).
    pub fn install_polygon_walls(&mut self, walls: PolygonWalls) {
        let plan = walls.change(&self.fluid.layout).clone();
        let ch = self.fluid.apply_layout(walls.layout, &plan);
        self.geometry.uncovered += ch.uncovered;
        self.geometry.covered += ch.covered;
        self.geometry.isolated += ch.isolated;
        self.geometry.mass_change += ch.mass_change;
        self.built = Some(walls.polygons);
    }

    /// Method 1's traction laid out for a backend that holds the populations (the GPU), at the
    /// particles' current positions ([`TractionPlan`]: the surface_traction stage's arithmetic
    /// on the solid's side).
    pub fn traction_plan(&self, o: WeakOptions) -> TractionPlan {
        TractionPlan::new(&self.fluid, &self.units, self.bodies.iter().map(|b| &b.surface), &self.solid.particles, o.traction, o.piece_length)
    }

    /// The scene's own loads on the particles (physical units), to which the air's forces add.
    pub fn base_loads(&self) -> &[glam::DVec3] {
        &self.base_load
    }

    /// Takes the air's forces a backend computed for the surface_traction stage (the GPU's
    /// tractions, brought back for the outputs) as this solver's, with the loads they give.
    pub fn set_surface_forces(&mut self, forces: SurfaceForces) {
        self.forces = forces;
        self.apply_forces();
    }

    /// Method 1's surface_traction stage: the air's tractions on the surface pieces, spread to
    /// the surface particles (2.110–2.113), become their loads.
    pub(super) fn surface_traction(&mut self, o: WeakOptions) {
        let surfaces = self.bodies.iter().map(|b| &b.surface);
        self.forces = surface_forces(&self.fluid, &self.units, surfaces, &self.solid.particles, o.traction, o.piece_length);
        self.apply_forces();
    }
}
