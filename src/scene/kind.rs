//! Any scene file, its kind decided once from its top-level tables, then read by that kind's
//! reader: `[coupling]` → coupled, `[two_mass]` → two-mass, `[lattice_gas]` → lattice gas,
//! `[solid]` → solid, otherwise a fluid scene.

use super::coupled::CoupledScene;
use super::lattice_gas::LatticeGasScene;
use super::solid::SolidScene;
use super::two_mass::TwoMassScene;
use super::{FluidScene, SceneError};

/// The kinds of scene file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum SceneKind {
    Fluid,
    Solid,
    LatticeGas,
    Coupled,
    TwoMass,
}

impl SceneKind {
    /// The kind of a scene text (a text that is not TOML is read as a fluid scene, whose reader
    /// then names the syntax error).
    pub fn of(text: &str) -> SceneKind {
        let Ok(t) = toml::from_str::<toml::Table>(text) else { return SceneKind::Fluid };
        if t.contains_key("coupling") {
            SceneKind::Coupled
        } else if t.contains_key("two_mass") {
            SceneKind::TwoMass
        } else if t.contains_key("lattice_gas") {
            SceneKind::LatticeGas
        } else if t.contains_key("solid") {
            SceneKind::Solid
        } else {
            SceneKind::Fluid
        }
    }
}

/// A checked scene of any kind.
#[derive(Clone, Debug)]
pub enum Scene {
    Fluid(Box<FluidScene>),
    Solid(Box<SolidScene>),
    LatticeGas(Box<LatticeGasScene>),
    Coupled(Box<CoupledScene>),
    TwoMass(Box<TwoMassScene>),
}

impl Scene {
    /// Decide the kind, then read and check the scene with that kind's reader.
    pub fn read(text: &str) -> Result<Scene, SceneError> {
        Ok(match SceneKind::of(text) {
            SceneKind::Fluid => Scene::Fluid(Box::new(super::load(text)?)),
            SceneKind::Solid => Scene::Solid(Box::new(SolidScene::parse(text)?)),
            SceneKind::LatticeGas => Scene::LatticeGas(Box::new(LatticeGasScene::parse(text)?)),
            SceneKind::Coupled => Scene::Coupled(Box::new(CoupledScene::parse(text)?)),
            SceneKind::TwoMass => Scene::TwoMass(Box::new(TwoMassScene::parse(text)?)),
        })
    }

    pub fn kind(&self) -> SceneKind {
        match self {
            Scene::Fluid(_) => SceneKind::Fluid,
            Scene::Solid(_) => SceneKind::Solid,
            Scene::LatticeGas(_) => SceneKind::LatticeGas,
            Scene::Coupled(_) => SceneKind::Coupled,
            Scene::TwoMass(_) => SceneKind::TwoMass,
        }
    }

    /// The scene's `name`.
    pub fn name(&self) -> &str {
        match self {
            Scene::Fluid(s) => &s.file.name,
            Scene::Solid(s) => &s.file.name,
            Scene::LatticeGas(s) => &s.file.name,
            Scene::Coupled(s) => &s.fluid.file.name,
            Scene::TwoMass(s) => &s.file.name,
        }
    }

    /// The scene's `description`.
    pub fn description(&self) -> &str {
        match self {
            Scene::Fluid(s) => &s.file.description,
            Scene::Solid(s) => &s.file.description,
            Scene::LatticeGas(s) => &s.file.description,
            Scene::Coupled(s) => &s.fluid.file.description,
            Scene::TwoMass(s) => &s.file.description,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_scene_is_read_as_its_kind() {
        let lists = [
            (super::super::BUILTIN, SceneKind::Fluid),
            (super::super::SOLID_BUILTIN, SceneKind::Solid),
            (super::super::LATTICE_GAS_BUILTIN, SceneKind::LatticeGas),
            (super::super::COUPLED_BUILTIN, SceneKind::Coupled),
            (super::super::TWO_MASS_BUILTIN, SceneKind::TwoMass),
        ];
        for (list, kind) in lists {
            for (name, text) in list {
                let s = Scene::read(text).unwrap_or_else(|e| panic!("{name}: {e}"));
                assert_eq!(s.kind(), kind, "{name}");
                assert_eq!(s.name(), *name, "the built-in's name is its file's");
                assert!(!s.description().is_empty(), "{name}");
            }
        }
        // a broken text is a fluid scene whose reader names the problem
        assert_eq!(SceneKind::of("name = "), SceneKind::Fluid);
        assert!(Scene::read("name = ").is_err());
    }
}
