//! The solid's saved state ([`SaveState`]): particle positions, velocities, rotations (the
//! implicit method's Newton solve starts from them), angular velocities, loads and added
//! masses (the coupling sets them each step), the contact anchors (the tangential springs'
//! memory, (2.29)–(2.30), in a fixed order), the step counter and the time. Reference shape,
//! bonds, materials and the time step come from the scene; forces, stresses and the implicit
//! step's vectors are recomputed by every step.

use super::SolidSolver;
use super::contact::{Anchor, Contacts};
use crate::state::{SaveState, StateError, StateReader, StateWriter};
use glam::DVec3;

impl SaveState for SolidSolver {
    fn save_state(&self, w: &mut StateWriter) {
        let p = &self.particles;
        w.u64("solid.step_count", self.step_count);
        w.f64("solid.time", self.time);
        w.vec3s("solid.position", &p.position);
        w.vec3s("solid.velocity", &p.velocity);
        w.quats("solid.rotation", &p.rotation);
        w.vec3s("solid.spin", &p.spin);
        w.vec3s("solid.load", &p.load);
        w.f64s("solid.added_mass", &p.added_mass);
        self.contacts.save_state(w);
    }

    fn load_state(&mut self, r: &mut StateReader) -> Result<(), StateError> {
        self.step_count = r.u64("solid.step_count")?;
        self.time = r.f64("solid.time")?;
        let p = &mut self.particles;
        r.vec3s_into("solid.position", &mut p.position)?;
        r.vec3s_into("solid.velocity", &mut p.velocity)?;
        r.quats_into("solid.rotation", &mut p.rotation)?;
        r.vec3s_into("solid.spin", &mut p.spin)?;
        r.vec3s_into("solid.load", &mut p.load)?;
        r.f64s_into("solid.added_mass", &mut p.added_mass)?;
        let n = p.len();
        self.contacts.load_state(r)?;
        if let Some(&(i, j)) = self.contacts.pairs.keys().find(|&&(i, j)| i as usize >= n || j as usize >= n) {
            return Err(StateError::Value {
                what: "solid.contact_pairs".into(),
                reason: format!("pair ({i}, {j}) names a particle beyond the {n} of the scene"),
            });
        }
        Ok(())
    }
}

/// Anchors in the order of their keys (the maps' own order differs between processes).
impl SaveState for Contacts {
    fn save_state(&self, w: &mut StateWriter) {
        let mut pairs: Vec<_> = self.pairs.iter().collect();
        pairs.sort_by_key(|(k, _)| **k);
        w.u64s("solid.contact_pairs", &pairs.iter().map(|((i, j), _)| (*i as u64) << 32 | *j as u64).collect::<Vec<_>>());
        w.vec3s("solid.contact_pair_anchors", &pairs.iter().flat_map(|(_, a)| [a.ri, a.rj]).collect::<Vec<_>>());
        let mut walls: Vec<_> = self.walls.iter().collect();
        walls.sort_by_key(|(k, _)| **k);
        w.u64s("solid.contact_walls", &walls.iter().map(|((i, wall), _)| (*i as u64) << 16 | *wall as u64).collect::<Vec<_>>());
        w.vec3s("solid.contact_wall_anchors", &walls.iter().flat_map(|(_, a)| [a.ri, a.rj]).collect::<Vec<_>>());
        w.f64("solid.contact_max_overlap", self.max_overlap);
    }

    fn load_state(&mut self, r: &mut StateReader) -> Result<(), StateError> {
        let pairs = r.u64s("solid.contact_pairs")?;
        let mut anchors = vec![DVec3::ZERO; 2 * pairs.len()];
        r.vec3s_into("solid.contact_pair_anchors", &mut anchors)?;
        self.pairs = pairs.iter().zip(anchors.chunks_exact(2)).map(|(k, a)| (((k >> 32) as u32, *k as u32), Anchor { ri: a[0], rj: a[1] })).collect();
        let walls = r.u64s("solid.contact_walls")?;
        let mut anchors = vec![DVec3::ZERO; 2 * walls.len()];
        r.vec3s_into("solid.contact_wall_anchors", &mut anchors)?;
        self.walls = walls.iter().zip(anchors.chunks_exact(2)).map(|(k, a)| (((k >> 16) as u32, *k as u16), Anchor { ri: a[0], rj: a[1] })).collect();
        self.max_overlap = r.f64("solid.contact_max_overlap")?;
        Ok(())
    }
}
