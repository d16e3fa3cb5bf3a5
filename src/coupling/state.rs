//! The coupled solver's saved state ([`SaveState`]): its step counter and time, the air's
//! forces of the last step (the loads they set are in the solid's state), the geometry
//! changes so far, the surface polygons the fluid's geometry was last built from (restoring
//! them rebuilds the same lattice geometry), then the fluid's and the solid's own states.
//! Method 2 adds the particle positions its level-set walls were last built from (restoring
//! them rebuilds the same lattice geometry) and the momentum handed to non-body walls.

use super::CoupledSolver;
use super::solver::Method;
use super::traction::SurfaceForces;
use crate::fluid::{Polygon, Shape};
use crate::state::{SaveState, StateError, StateReader, StateWriter};
use glam::DVec3;

impl SaveState for CoupledSolver {
    fn save_state(&self, w: &mut StateWriter) {
        w.u64("coupling.step_count", self.step_count);
        w.f64("coupling.time", self.time);
        w.vec3s("coupling.surface_force", &self.forces.force);
        w.vec3s("coupling.body_force_totals", &self.forces.total);
        w.u64s("coupling.pieces", &[self.forces.pieces as u64, self.forces.pieces_without_fluid as u64]);
        let g = &self.geometry;
        w.u64s("coupling.geometry_counts", &[g.uncovered as u64, g.covered as u64, g.isolated as u64]);
        w.f64("coupling.geometry_mass_change", g.mass_change);
        let polys = self.built.as_deref().unwrap_or_default();
        w.u64s("coupling.polygon_sizes", &polys.iter().map(|p| p.vertices().len() as u64).collect::<Vec<_>>());
        for p in polys {
            w.f64s("coupling.polygon_vertices", p.vertices().as_flattened());
            w.f64s("coupling.polygon_velocities", p.velocities().as_flattened());
        }
        if let Some(ex) = &self.exchange {
            let pts: Vec<DVec3> = ex.built.clone().unwrap_or_default();
            w.vec3s("coupling.level_set_points", &pts);
            w.f64s("coupling.momentum_to_walls", &ex.walls.to_array());
        }
        self.fluid.save_state(w);
        self.solid.save_state(w);
    }

    fn load_state(&mut self, r: &mut StateReader) -> Result<(), StateError> {
        self.step_count = r.u64("coupling.step_count")?;
        self.time = r.f64("coupling.time")?;
        let n = self.solid.particles.len();
        let mut force = vec![DVec3::ZERO; n];
        r.vec3s_into("coupling.surface_force", &mut force)?;
        let mut total = vec![DVec3::ZERO; self.bodies.len()];
        r.vec3s_into("coupling.body_force_totals", &mut total)?;
        let pieces = r.u64s("coupling.pieces")?;
        let counts = r.u64s("coupling.geometry_counts")?;
        let (&[pieces, without], &[uncovered, covered, isolated]) = (pieces.as_slice(), counts.as_slice()) else {
            return Err(StateError::Value { what: "coupling.pieces / coupling.geometry_counts".into(), reason: "expected 2 and 3 counts".into() });
        };
        self.forces = SurfaceForces { force, total, pieces: pieces as usize, pieces_without_fluid: without as usize };
        self.geometry.uncovered = uncovered as usize;
        self.geometry.covered = covered as usize;
        self.geometry.isolated = isolated as usize;
        self.geometry.mass_change = r.f64("coupling.geometry_mass_change")?;
        let sizes = r.u64s("coupling.polygon_sizes")?;
        // method 1 keeps one polygon per body; method 2 has none (its walls are level sets)
        let expected = if let Method::Weak(_) = self.method { self.bodies.len() } else { 0 };
        if sizes.len() != expected {
            return Err(StateError::Length { what: "coupling.polygon_sizes".into(), expected, found: sizes.len() });
        }
        let mut polys = Vec::with_capacity(sizes.len());
        for &m in &sizes {
            let (v, u) = (r.f64s("coupling.polygon_vertices")?, r.f64s("coupling.polygon_velocities")?);
            if v.len() as u64 != 2 * m || u.len() as u64 != 3 * m {
                return Err(StateError::Length { what: "coupling.polygon_vertices".into(), expected: 2 * m as usize, found: v.len() });
            }
            polys.push(Polygon::new(v.chunks_exact(2).map(|c| [c[0], c[1]]).collect(), u.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()));
        }
        // the lattice geometry of those surfaces (then the populations, whole, from the state)
        let mut all = self.obstacles.clone();
        if let Method::Conserving(_) = self.method {
            let mut pts = vec![DVec3::ZERO; self.solid.particles.len()];
            r.vec3s_into("coupling.level_set_points", &mut pts)?;
            let walls = r.f64s("coupling.momentum_to_walls")?;
            let &[wx, wy, wz] = walls.as_slice() else {
                return Err(StateError::Length { what: "coupling.momentum_to_walls".into(), expected: 3, found: walls.len() });
            };
            // The level sets at the positions of the last build (the wall velocities are set
            // again by the next step's geometry stage, before the air sees them).
            all.extend(self.body_walls(self.level_sets_at(&pts).into_iter().map(|s| Shape::KernelLevelSet(std::sync::Arc::new(s)))));
            let ex = self.exchange.as_mut().expect("method 2 has its exchange state");
            ex.built = Some(pts);
            ex.walls = DVec3::new(wx, wy, wz);
            ex.clear();
        }
        all.extend(self.body_walls(polys.iter().cloned().map(Shape::Polygon)));
        self.fluid.set_obstacles(&all);
        if let Method::Weak(_) = self.method {
            self.built = Some(polys);
        }
        self.fluid.load_state(r)?;
        self.solid.load_state(r)
    }
}
