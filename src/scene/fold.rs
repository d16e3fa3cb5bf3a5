//! Vocal folds as bodies of solid and coupled scenes (seed 000 §3.4.1): `fold = { side,
//! origin, cover_material, fixed_depth, section }` in `[[solid.bodies]]`, placed in the scene
//! and checked field by field before anything is sampled.

use super::solid::{SolidSpec, vec3};
use crate::scene::SceneError;
use crate::solid::fold::{FoldSection, Layer};
use glam::DVec3;
use serde::{Deserialize, Serialize};

fn err<T>(field: impl Into<String>, reason: impl Into<String>) -> Result<T, SceneError> {
    Err(SceneError { field: field.into(), reason: reason.into() })
}

/// A vocal fold as a body (seed 000 §3.4.1, [`FoldSection`]): the section's particles on one
/// side of the glottal mid-line, the cover layer (the outer `section.cover_fraction` under the
/// free surface) of `cover_material`, the inner part of the body's `material`, and the particles
/// within `fixed_depth` of the lateral face clamped (the thyroid cartilage). The lateral axis
/// is x, the vertical (flow) axis y: the tracheal (lung) side is below, the vocal tract above.
///
/// In 3D (seed §3.4.3, [`FoldSection::sample_3d`]) the section is extruded along z over the
/// fold's `length`, from the anterior end at `origin.z`: the glottis widens by `opening` from
/// the anterior to the posterior end, the thyroarytenoid layer is of `ta_material`, and the
/// anterior face and the posterior face (but its cover) are clamped as well.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FoldBodySpec {
    /// Fig. 3.9 dimensions in the scene's length unit; the defaults are the seed's, in cm.
    #[serde(default)]
    pub section: FoldSection,
    pub side: FoldSide,
    /// The point of the glottal mid-line level with the fold's tracheal face (scene units).
    pub origin: Vec<f64>,
    pub cover_material: usize,
    /// Depth under the lateral face that is clamped; default 2 l₀.
    pub fixed_depth: Option<f64>,
    /// 3D: how much wider the glottis is at the posterior end than at the anterior end (scene
    /// units; the seed's 0.06 cm); default 0.
    pub opening: Option<f64>,
    /// 3D: the material of the thyroarytenoid layer; default the body's `material`.
    pub ta_material: Option<usize>,
}

/// Which fold: the left one lies at x below the mid-line, the right one above it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FoldSide {
    Left,
    Right,
}

impl FoldBodySpec {
    fn sign(&self) -> f64 {
        match self.side {
            FoldSide::Left => -1.0,
            FoldSide::Right => 1.0,
        }
    }

    /// Fold coordinates (lateral, vertical) → scene position.
    pub fn to_scene(&self, p: [f64; 2]) -> DVec3 {
        DVec3::new(self.origin[0] + self.sign() * p[0], self.origin[1] + p[1], 0.0)
    }

    /// The particles of this fold on a lattice of `spacing`: scene position, layer, clamped.
    pub fn sample(&self, spacing: f64) -> Vec<(DVec3, Layer, bool)> {
        let s = self.section.sample_right(spacing, self.clamp_depth(spacing));
        (0..s.position.len()).map(|i| (self.to_scene(s.position[i]), s.layer[i], s.fixed[i])).collect()
    }

    /// 3D fold coordinates (lateral, along the fold from the anterior end, vertical) → scene
    /// position (x lateral, y vertical, z along the fold).
    pub fn to_scene_3d(&self, p: [f64; 3]) -> DVec3 {
        DVec3::new(self.origin[0] + self.sign() * p[0], self.origin[1] + p[2], self.origin[2] + p[1])
    }

    /// The particles of this fold in `dim` dimensions (2D: [`Self::sample`]; 3D: the extruded
    /// fold of [`FoldSection::sample_3d`]).
    pub fn sample_in(&self, dim: usize, spacing: f64) -> Vec<(DVec3, Layer, bool)> {
        if dim == 2 {
            return self.sample(spacing);
        }
        let s = self.section.sample_3d(spacing, self.clamp_depth(spacing), self.opening.unwrap_or(0.0));
        (0..s.position.len()).filter(|&i| s.side[i] == 1).map(|i| (self.to_scene_3d(s.position[i]), s.layer[i], s.fixed[i])).collect()
    }

    /// The section's outline in scene coordinates, counter-clockwise.
    pub fn outline(&self) -> Vec<DVec3> {
        let mut v: Vec<DVec3> = self.section.outline(16).into_iter().map(|p| self.to_scene(p)).collect();
        if self.side == FoldSide::Left {
            v.reverse(); // the mirror image turns the other way
        }
        v
    }

    /// Depth under the lateral face that is clamped, for particles of `spacing`.
    pub fn clamp_depth(&self, spacing: f64) -> f64 {
        self.fixed_depth.unwrap_or(2.0 * spacing)
    }

    /// A fold is attached to the larynx: its lateral face to the thyroid cartilage (the
    /// domain's side wall) and, in 3D, its ends to the anterior and posterior walls. One whose
    /// lateral face lies inside the domain (or, in 3D, whose length falls short of the
    /// domain's) leaves a channel of air between it and the wall through which the lungs' air
    /// goes around the glottis — and, where that channel is narrower than a cell, nodes that
    /// leave and rejoin the air as the fold moves (the coarse 3D glottis as first built had a
    /// slit 0.5–1.2 cells wide along each side wall and went unstable in it at step 665,
    /// 0.38 ms). `size` is the domain's extent; `f` names the body in errors.
    pub(super) fn check_attached(&self, f: &str, size: &[f64]) -> Result<(), SceneError> {
        let m = 0.5 * self.section.gap;
        // the lateral face nearest the mid-line: in 3D the anterior end's (the opening only
        // moves it outward, towards the posterior end)
        let (face, wall) = match self.side {
            FoldSide::Left => (self.origin[0] - m - self.section.width, 0.0),
            FoldSide::Right => (self.origin[0] + m + self.section.width, size[0]),
        };
        let inside = self.sign() * (wall - face);
        if inside > 1e-9 * size[0] {
            return err(
                format!("{f}.origin"),
                format!(
                    "the fold's lateral face lies at x = {face} (its anterior end in 3D), {inside:.4} inside the domain's side wall at x = {wall}: \
                     the air would flow between the fold and the wall, around the glottis; place the fold so that its lateral face \
                     (origin.x ± (gap/2 + width)) reaches the wall or beyond (the clamped strip, fixed_depth, may lie beyond it), or narrow the domain"
                ),
            );
        }
        if self.origin.len() == 3 {
            let (z0, z1) = (self.origin[2], self.origin[2] + self.section.length);
            if z0 > 1e-9 * size[2] || z1 < size[2] * (1.0 - 1e-9) {
                return err(
                    format!("{f}.section.length"),
                    format!(
                        "the fold spans z = [{z0}, {z1}] of the domain's [0, {}]: its anterior and posterior ends must meet the domain's walls \
                         (origin.z = 0, length = the domain's size along z), or the air flows around them",
                        size[2]
                    ),
                );
            }
        }
        Ok(())
    }

    /// Bounding box (scene coordinates) of the fold less its clamped lateral strip: the part
    /// that moves, which must lie in the air's domain (the clamped strip is attached to the
    /// cartilage and may lie beyond the domain's wall).
    pub fn free_bounds(&self, spacing: f64) -> (DVec3, DVec3) {
        let m = 0.5 * self.section.gap;
        let lateral = m + self.section.width - self.clamp_depth(spacing);
        if self.origin.len() == 3 {
            let widen = 0.5 * self.opening.unwrap_or(0.0);
            let (a, b) = (self.to_scene_3d([m, 0.0, 0.0]), self.to_scene_3d([lateral + widen, self.section.length, self.section.height]));
            return (a.min(b), a.max(b));
        }
        let (a, b) = (self.to_scene([m, 0.0]), self.to_scene([lateral, self.section.height]));
        (a.min(b), a.max(b))
    }
}

/// Checks a fold body `f` and returns its particle count estimate.
pub(super) fn check_fold(fold: &FoldBodySpec, f: &str, s: &SolidSpec, units: crate::scene::schema::UnitSystem, materials: usize) -> Result<f64, SceneError> {
    let dim = s.dimension;
    fold.section.check(&format!("{f}.fold.section"))?;
    if units == crate::scene::schema::UnitSystem::Si && fold.section == FoldSection::default() {
        return err(format!("{f}.fold.section"), "the default dimensions are the seed's, in cm: give them in m for an SI scene (or use units = \"cgs\")");
    }
    vec3(&format!("{f}.fold.origin"), &fold.origin, dim, false)?;
    if fold.cover_material >= materials {
        return err(format!("{f}.fold.cover_material"), format!("no material {} (there are {materials})", fold.cover_material));
    }
    if dim == 2 {
        if fold.opening.is_some() {
            return err(format!("{f}.fold.opening"), "is a setting of the 3D fold (solid.dimension = 3): a 2D section has no length to widen along");
        }
        if fold.ta_material.is_some() {
            return err(format!("{f}.fold.ta_material"), "is a setting of the 3D fold (solid.dimension = 3): the 2D section has body and cover only");
        }
    }
    if let Some(o) = fold.opening
        && !(o.is_finite() && o >= 0.0 && o < fold.section.width)
    {
        return err(format!("{f}.fold.opening"), format!("must lie in [0, width = {}), got {o}", fold.section.width));
    }
    if let Some(m) = fold.ta_material
        && m >= materials
    {
        return err(format!("{f}.fold.ta_material"), format!("no material {m} (there are {materials})"));
    }
    if let Some(d) = fold.fixed_depth
        && !(d.is_finite() && d >= s.spacing && d < fold.section.width)
    {
        return err(format!("{f}.fold.fixed_depth"), format!("must lie in [l₀ = {}, width = {}), got {d}", s.spacing, fold.section.width));
    }
    // The cover must be at least one particle thick where it is thinnest.
    let cover = fold.section.cover_thickness(s.spacing);
    if cover < s.spacing {
        return err(
            "solid.spacing",
            format!(
                "l₀ = {} is coarser than the fold's cover layer ({cover:.4}, {} of the section): use l₀ ≤ {cover:.4}",
                s.spacing, fold.section.cover_fraction
            ),
        );
    }
    Ok(match dim {
        3 => fold.section.area() * fold.section.length / s.spacing.powi(3),
        _ => fold.section.area() / (s.spacing * s.spacing),
    })
}

#[cfg(test)]
mod tests {
    use crate::scene::solid::SolidScene;

    /// Two folds pushed onto each other for 10⁴ explicit steps: the distinct-element contact
    /// closes the glottis without the folds passing through each other, and the state stays
    /// finite with bounded energy.
    #[test]
    fn two_folds_pushed_together_close_without_interpenetration() {
        let text = r#"
name = "fold_closure"
units = "cgs"
[solid]
dimension = 2
spacing = 0.018
materials = [
  { kind = "orthotropic", young = [1.0e6, 1.0e6, 1.0e6], poisson = [0.97, 0.0, 0.0], shear = [2.538e5, 2.538e5, 2.538e5], density = 1.043, viscosity = 5.0 },
  { kind = "orthotropic", young = [1.0e5, 1.0e5, 1.0e5], poisson = [0.97, 0.0, 0.0], shear = [2.538e4, 2.538e4, 2.538e4], density = 1.043, viscosity = 5.0 },
]
bodies = [
  { fold = { side = "left", origin = [0.0, 0.0], cover_material = 1 }, material = 0 },
  { fold = { side = "right", origin = [0.0, 0.0], cover_material = 1 }, material = 0 },
]
# the medial quarter of each fold pushed towards the mid-line (dyn per cm of fold length)
loads = [
  { min = [-0.2, 0.0], max = [-0.01, 0.475], total_force = [4.0e4, 0.0] },
  { min = [0.01, 0.0], max = [0.2, 0.475], total_force = [-4.0e4, 0.0] },
]
[solid.contact]
normal_stiffness = 1.0e7
tangential_stiffness = 5.0e6
static_friction = 0.1
dynamic_friction = 0.05
damping = 1.0
[run]
duration = 1.0
"#;
        let sc = SolidScene::parse(text).unwrap();
        let mut s = sc.build().unwrap();
        let l0 = s.particles.spacing;
        let e0 = s.energies().total();
        let mut closed_at = None;
        let mut deepest: f64 = 0.0;
        let (mut highest, mut lowest) = (f64::NEG_INFINITY, f64::INFINITY);
        for k in 0..10_000 {
            s.step().expect("the closing folds stay finite");
            let p = &s.particles;
            if k % 100 == 99 {
                // the smallest distance between particles of the two folds
                let (l, r): (Vec<usize>, Vec<usize>) = (0..p.len()).filter(|&i| (p.reference[i].x).abs() < 0.2).partition(|&i| p.body[i] == 0);
                let d =
                    l.iter().flat_map(|&i| r.iter().map(move |&j| (i, j))).map(|(i, j)| (p.position[i] - p.position[j]).length()).fold(f64::INFINITY, f64::min);
                if closed_at.is_none() && d < 1.05 * l0 {
                    closed_at = Some(k + 1);
                }
                deepest = deepest.max(s.contacts().max_overlap);
                let e = s.energies().total();
                (highest, lowest) = (highest.max(e), lowest.min(e));
                assert!(d > 0.5 * l0, "step {}: particles of the two folds {d:.2e} cm apart (l₀ = {l0})", k + 1);
            }
        }
        assert!(s.non_finite().is_none());
        let closed = closed_at.expect("the folds touch");
        // the gap of 0.021 cm (plus l₀) closes within the first tenth of the run, and the deepest
        // overlap stays a small fraction of a particle
        assert!(closed < 1000, "closed at step {closed}");
        assert!(deepest > 0.0 && deepest < 0.2, "deepest overlap {deepest} l₀");
        // kinetic + elastic − work of the loads: the viscosity and the contact damping only take
        // energy out (the contact springs hold some while compressed), so it never rises above
        // its start, and the loads did work (it fell)
        assert!(lowest < -1.0 && highest <= e0 + 1e-6 * lowest.abs(), "energy from {e0} within [{lowest}, {highest}]");
        assert!(s.contacts().active.0 > 0, "still in contact at the end");
    }
}
