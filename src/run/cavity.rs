//! What a fluid run of the lid-driven square cavity reports against Ghia, Ghia & Shin (1982):
//! the largest deviation of its final centreline velocities from their tables at Re = 100
//! ([`crate::analysis::cavity`]) — the error the built-in `lid_cavity`'s speed is read against.

use crate::analysis::cavity::ghia_deviation;
use crate::fluid::{FaceCondition, FluidSolver};
use crate::scene::FluidScene;
use crate::scene::schema::FaceSpec;
use serde::Serialize;

/// Ghia et al.'s tables are at this Reynolds number only.
pub const GHIA_REYNOLDS: f64 = 100.0;

/// A cavity run against Ghia et al. (the scene's units).
#[derive(Clone, Debug, Serialize)]
pub struct CavityReport {
    /// The cavity's side and the lid's speed.
    pub side: f64,
    pub lid_speed: f64,
    /// U L ρ / μ.
    pub reynolds: f64,
    /// Lid transits run, U t / L: the flow is steady after ~15 at Re = 100.
    pub lid_transits: f64,
    /// Largest |u − u_Ghia| / U over both centreline tables at the run's end; None when Re is
    /// not within 1 % of Ghia's 100.
    pub ghia_max_deviation: Option<f64>,
}

/// The square 2D cavity with still walls and one lid at y_max moving along +x (Ghia's layout):
/// its side and the lid's speed.
fn lid_driven_cavity(scene: &FluidScene) -> Option<(f64, f64)> {
    let f = &scene.file;
    let [lx, ly] = f.domain.size.as_slice() else { return None };
    if lx != ly || !f.obstacles.is_empty() || f.initial.body_force.iter().any(|&g| g != 0.0) {
        return None;
    }
    let wall_velocity = |face: Option<&FaceSpec>| match face {
        Some(FaceSpec::Wall { velocity, .. }) => Some([velocity.first().copied().unwrap_or(0.0), velocity.get(1).copied().unwrap_or(0.0)]),
        _ => None,
    };
    let faces = f.boundaries.named();
    for (_, face) in &faces[..3] {
        if wall_velocity(*face)? != [0.0; 2] {
            return None;
        }
    }
    let [u, v] = wall_velocity(faces[3].1)?;
    (u > 0.0 && v == 0.0).then_some((*lx, u))
}

/// The cavity report of a run of `scene` that ended in the state `s`; `None` for a scene that is
/// not a lid-driven square cavity.
pub fn cavity_report(scene: &FluidScene, s: &FluidSolver) -> Option<CavityReport> {
    let (side, lid_speed) = lid_driven_cavity(scene)?;
    let reynolds = lid_speed * side * scene.file.gas.density / scene.file.gas.viscosity;
    // the lid's speed in lattice units, as the state's velocities
    let FaceCondition::Wall { velocity, .. } = &s.layout.boundaries.faces[3] else { return None };
    let ghia_max_deviation = ((reynolds / GHIA_REYNOLDS - 1.0).abs() <= 0.01).then(|| ghia_deviation(s, velocity[0]));
    let lid_transits = lid_speed * scene.units.time_to_physical(s.time) / side;
    Some(CavityReport { side, lid_speed, reynolds, lid_transits, ghia_max_deviation })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(text: &str) -> FluidScene {
        crate::scene::load(text).expect("parses")
    }

    /// The lid_cavity scene started in a uniform stream of a tenth of the lid's speed along x: the
    /// report takes Re = 100 and the side from the scene, and reads against Ghia's tables the
    /// largest |u − u_Ghia| / U of that state — 0.84123 − 0.1 at y = 0.9766 on the vertical
    /// centreline (Table I), the largest of both tables (Table II's largest |v| is 0.24533).
    #[test]
    fn the_cavity_report_reads_ghia_against_the_state() {
        let text = crate::scene::builtin("lid_cavity").expect("built in");
        let uniform = text.replace("[run]", "[initial]\nvelocity = [1.537, 0.0]\n\n[run]");
        assert_ne!(uniform, text);
        let sc = scene(&uniform);
        let s = sc.build_solver();
        let r = cavity_report(&sc, &s).expect("a lid-driven cavity");
        assert_eq!((r.side, r.lid_speed, r.lid_transits), (1.0, 15.37, 0.0));
        assert!((r.reynolds / 100.0 - 1.0).abs() < 1e-3, "{}", r.reynolds);
        let d = r.ghia_max_deviation.expect("Re = 100");
        assert!((d - (0.84123 - 0.1)).abs() < 1e-9, "{d}");
        // Re = 400: no table; a cylinder in a stream: no cavity
        let re400 = scene(&text.replace("viscosity = 1.82e-4", "viscosity = 4.55e-5"));
        let r = cavity_report(&re400, &re400.build_solver()).expect("still a cavity");
        assert!((r.reynolds / 400.0 - 1.0).abs() < 1e-2 && r.ghia_max_deviation.is_none(), "{r:?}");
        let wake = scene(crate::scene::builtin("cylinder_wake").unwrap());
        assert!(cavity_report(&wake, &wake.build_solver()).is_none());
    }
}
