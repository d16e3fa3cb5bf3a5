//! The panel's presets: which built-in scenes it offers, the scene of a [`PanelState`] (a
//! preset with the panel's parameters written into it) and [`apply_panel`], which rebuilds the
//! [`PanelTarget`] entity's simulation — coupled, fluid or lattice gas, whichever kind the preset
//! is — whenever the state differs from what it was built with, whether the change came from the
//! panel's widgets or from the app's own code (tests set the state directly).

use super::panel::{PanelState, PanelTarget, WallHeat};
use crate::plugin::{CoupledGlottis, CoupledSimulation, FluidSimulation, GpuStepping, LatticeGasSimulation};
use crate::scene::coupled::CoupledScene;
use crate::scene::{Scene, SceneKind};
use bevy::ecs::system::EntityCommands;
use bevy::prelude::*;

/// The scenes the panel offers: the glottis cases, the Wall flap, the FDLB cylinder wake and the
/// lattice gas's cylinder wake.
pub const PRESETS: [&str; 8] =
    ["glottis_2d_a", "glottis_2d_b", "glottis_2d_c", "glottis_2d_d", "glottis_2d_coarse", "wall_flap", "cylinder_wake", "lattice_gas_wake"];

/// The resolutions the panel offers: factors of the preset's lattice (and of its particles'
/// spacing, divided by the factor).
pub const RESOLUTIONS: [f64; 4] = [0.5, 1.0, 1.5, 2.0];

/// The preset's scene text as a TOML table, at `state`'s resolution
/// ([`crate::scene::resolution::at_resolution`]: `domain.cells` times the factor, each a whole
/// number or refused naming `resolution`, and `solid.spacing` divided by it).
fn preset_table(state: &PanelState) -> Result<toml::Table, String> {
    let text = crate::scene::builtin(&state.preset).ok_or_else(|| format!("preset: no built-in scene {}", state.preset))?;
    let mut doc: toml::Table = text.parse().map_err(|e| format!("preset {}: {e}", state.preset))?;
    let Some(s) = state.resolution else { return Ok(doc) };
    crate::scene::resolution::at_resolution(&mut doc, s).map_err(|e| format!("resolution: preset {}: {}", state.preset, e.reason))?;
    Ok(doc)
}

/// A coupled built-in scene's walls and coupling method as its file has them (the method as the
/// panel names it, "weak" or "conserving"); `None` for a scene without `[coupling]`.
fn coupling_choices(preset: &str) -> Option<(WallHeat, Option<&'static str>)> {
    let doc: toml::Table = crate::scene::builtin(preset)?.parse().ok()?;
    let coupling = doc.get("coupling")?.as_table()?;
    let walls = if coupling.contains_key("wall_temperature_ratio") { WallHeat::Isothermal } else { WallHeat::Adiabatic };
    let method = match coupling.get("method").and_then(|m| m.as_str()) {
        Some("weak") => Some("weak"),
        Some("momentum_conserving" | "conserving") => Some("conserving"),
        _ => None,
    };
    Some((walls, method))
}

/// A coupled preset's wall model and coupling method name, as [`coupling_choices`] reads them.
type CouplingChoices = (WallHeat, Option<&'static str>);

/// [`coupling_choices`] of `preset`: read once per panel preset (the panel asks every frame),
/// parsed on demand for any other built-in scene.
fn preset_choices(preset: &str) -> Option<CouplingChoices> {
    static PANEL: std::sync::OnceLock<Vec<Option<CouplingChoices>>> = std::sync::OnceLock::new();
    match PRESETS.iter().position(|p| *p == preset) {
        Some(i) => PANEL.get_or_init(|| PRESETS.iter().map(|p| coupling_choices(p)).collect())[i],
        None => coupling_choices(preset),
    }
}

/// The walls of a coupled preset as its scene file has them (`None`: no such coupled preset).
pub fn preset_walls(preset: &str) -> Option<WallHeat> {
    preset_choices(preset).map(|(w, _)| w)
}

/// The coupling method of a coupled preset as the panel names it ("weak" or "conserving").
pub fn preset_method(preset: &str) -> Option<&'static str> {
    preset_choices(preset).and_then(|(_, m)| m)
}

/// The scene of `state`: the preset with its resolution, lung pressure, fold moduli, method and
/// wall temperature replaced.
pub fn scene_of(state: &PanelState) -> Result<CoupledScene, String> {
    let mut doc = preset_table(state)?;
    if let Some(p) = state.lung_pressure {
        let face = doc
            .get_mut("boundaries")
            .and_then(|b| b.get_mut("y_min"))
            .and_then(|f| f.as_table_mut())
            .filter(|f| f.get("type").and_then(|t| t.as_str()) == Some("pressure_inlet"));
        match face {
            Some(f) => {
                f.insert("pressure".into(), toml::Value::Float(p));
            }
            None => return Err(format!("lung_pressure: preset {} has no pressure inlet at y_min", state.preset)),
        }
    }
    if let Some(m) = &state.method {
        match doc.get_mut("coupling").and_then(|c| c.as_table_mut()) {
            Some(c) => {
                c.insert("method".into(), toml::Value::String(m.clone()));
            }
            None => return Err(format!("method: preset {} has no coupling", state.preset)),
        }
    }
    if let Some(w) = state.walls {
        match doc.get_mut("coupling").and_then(|c| c.as_table_mut()) {
            Some(c) => {
                match w {
                    WallHeat::Isothermal => c.insert("wall_temperature_ratio".into(), toml::Value::Float(1.0)),
                    WallHeat::Adiabatic => c.remove("wall_temperature_ratio"),
                };
            }
            None => return Err(format!("walls: preset {} has no coupling", state.preset)),
        }
    }
    let mut sc = CoupledScene::parse(&toml::to_string(&doc).map_err(|e| e.to_string())?).map_err(|e| e.to_string())?;
    if let Some((cover, body)) = state.fold_moduli {
        if !(cover > 0.0 && body > 0.0) {
            return Err(format!("fold_moduli: ({cover}, {body}) dyn/cm² must be positive"));
        }
        sc.set_fold_moduli(cover, body);
    }
    Ok(sc)
}

/// The glottis presets on the seed's lattice (124 × 128 cells), which an app without a hardware
/// GPU steps at ×0.5 ([`choose_backend`]).
const SEED_LATTICE_PRESETS: [&str; 4] = ["glottis_2d_a", "glottis_2d_b", "glottis_2d_c", "glottis_2d_d"];

/// Where an app steps `state`'s preset when it was not told (`--backend auto`, as `phonation
/// run` does): on the render device when `adapter` (its name and type) is a hardware GPU
/// ([`crate::run::is_hardware_gpu`]) and the preset is a fluid or coupled scene; otherwise on
/// the CPU backend, the glottis presets on the seed's lattice at ×0.5 resolution (62 × 64
/// cells) unless a resolution was set. Returns the line that says which (for a window title).
pub fn choose_backend(state: &mut PanelState, adapter: Option<(&str, wgpu::DeviceType)>) -> String {
    let steppable = gpu_steppable(&state.preset);
    match adapter {
        Some((name, kind)) if crate::run::is_hardware_gpu(kind) && steppable => {
            state.air_on_gpu = true;
            format!("stepped on the GPU: {name}")
        }
        _ => {
            state.air_on_gpu = false;
            let why = match adapter {
                Some((name, _)) if steppable => format!("{name} is not a hardware GPU"),
                Some(_) => "the app steps this preset on the CPU".to_string(),
                None => "no render device".to_string(),
            };
            if state.resolution.is_none() && SEED_LATTICE_PRESETS.contains(&state.preset.as_str()) {
                state.resolution = Some(0.5);
                format!("CPU backend at ×0.5 resolution: {why}")
            } else {
                format!("CPU backend: {why}")
            }
        }
    }
}

/// Whether the app steps `preset` on the render device when asked (a fluid or coupled scene;
/// not the lattice gas).
fn gpu_steppable(preset: &str) -> bool {
    crate::scene::builtin(preset).is_some_and(|t| matches!(SceneKind::of(t), SceneKind::Fluid | SceneKind::Coupled))
}

/// What a preset builds.
pub enum PresetSimulation {
    /// Air and bodies (the glottis, the flap), with the glottis's readouts when it has folds.
    Coupled(Box<CoupledSimulation>, Option<CoupledGlottis>),
    Fluid(Box<FluidSimulation>),
    LatticeGas(Box<LatticeGasSimulation>),
}

/// The simulation of `state`, or why it is refused (naming the parameter).
pub fn build_preset(state: &PanelState) -> Result<PresetSimulation, String> {
    let text = crate::scene::builtin(&state.preset).ok_or_else(|| format!("preset: no built-in scene {}", state.preset))?;
    if state.air_on_gpu && !gpu_steppable(&state.preset) {
        return Err(format!(
            "air_on_gpu: preset {} is a {:?} scene, which the app steps on the CPU (fluid and coupled presets step on the GPU; `phonation run --backend gpu` runs a lattice-gas scene on the GPU)",
            state.preset,
            SceneKind::of(text)
        ));
    }
    if SceneKind::of(text) == SceneKind::Coupled {
        let sc = scene_of(state)?;
        let solver = sc.build().map_err(|e| e.to_string())?;
        let glottis = CoupledGlottis::of(&sc, &solver, 0.05);
        return Ok(PresetSimulation::Coupled(Box::new(CoupledSimulation { solver }), glottis));
    }
    // the folds' parameters belong to the coupled presets
    for (set, name) in [(state.lung_pressure.is_some(), "lung_pressure"), (state.fold_moduli.is_some(), "fold_moduli"), (state.method.is_some(), "method")] {
        if set {
            return Err(format!("{name}: preset {} has no folds (it is a {:?} scene)", state.preset, SceneKind::of(text)));
        }
    }
    let doc = toml::to_string(&preset_table(state)?).map_err(|e| e.to_string())?;
    match Scene::read(&doc).map_err(|e| format!("preset {}: {e}", state.preset))? {
        Scene::Fluid(sc) => Ok(PresetSimulation::Fluid(Box::new(FluidSimulation::from_scene(&sc)))),
        Scene::LatticeGas(sc) => Ok(PresetSimulation::LatticeGas(Box::new(LatticeGasSimulation::from_scene(&sc)))),
        other => Err(format!("preset: {} is a {:?} scene, which the panel does not draw", state.preset, other.kind())),
    }
}

/// The cover and body Young's moduli (dyn/cm²) of a glottis preset: Titze's cases A–D as the
/// built-in scenes set them (cover/body 1/10, 2/20, 1/100, 2/200 × 10⁵; the coarse glottis is
/// case A).
pub fn preset_moduli(preset: &str) -> (f64, f64) {
    match preset {
        "glottis_2d_a" | "glottis_2d_coarse" => (1e5, 1e6),
        "glottis_2d_b" => (2e5, 2e6),
        "glottis_2d_d" => (2e5, 2e7),
        _ => (1e5, 1e7),
    }
}

/// Takes every simulation and every figure and drawing state of one off an entity.
fn clear_simulation(ec: &mut EntityCommands) {
    use crate::plugin::*;
    ec.remove::<(CoupledSimulation, CoupledStatus, CoupledGlottis, CoupledDiagnostics, VoiceDiagnostics, diagnostics::InitialMass)>();
    ec.remove::<(GpuStepping, GpuFluidHandle, GpuProbes, GpuCoupledHandle, GpuCoupledReadback)>();
    ec.remove::<(FluidSimulation, FluidStatus, FluidDiagnostics, LatticeGasSimulation, LatticeGasDiagnostics)>();
    ec.remove::<(super::fold_mesh::FoldMesh, super::gpu_fold_mesh::GpuFoldMesh, super::tracers::FlowTracers, super::slice::SliceView, super::plots::PlotHistory)>();
}

/// Rebuilds the [`PanelTarget`]'s simulation when [`PanelState`] differs from what it was built
/// with; the drawings of the old one go with it (its fold mesh here, its slice's quad in
/// [`super::slice`]'s own update, which drops a quad whose simulation holds no view). A refused
/// state keeps the old simulation and says why in [`PanelTarget::error`]. A simulation stepped on the GPU (the old one or the new)
/// is rebuilt on a new entity, so that the device's handles, readbacks and their observers go
/// with the old entity. A change of [`PanelState::air_on_gpu`] alone rebuilds nothing: the
/// running simulation moves between the CPU and the render device with its state
/// ([`GpuStepping`] put on or taken off; the plugin uploads it or brings it back).
pub fn apply_panel(
    state: Res<PanelState>,
    mut targets: Query<(Entity, &mut PanelTarget, Has<GpuStepping>)>,
    drawn: Query<(Entity, &super::fold_mesh::FoldMeshOf)>,
    mut commands: Commands,
) {
    for (old, mut t, on_gpu) in &mut targets {
        if t.built.as_ref() == Some(&*state) {
            continue;
        }
        let moves_only = t.error.is_none()
            && gpu_steppable(&state.preset)
            && t.built.as_ref().is_some_and(|b| PanelState { air_on_gpu: state.air_on_gpu, ..b.clone() } == *state);
        t.built = Some(state.clone());
        if moves_only {
            if state.air_on_gpu {
                commands.entity(old).insert(GpuStepping);
            } else {
                commands.entity(old).remove::<GpuStepping>();
            }
            continue;
        }
        match build_preset(&state) {
            Ok(sim) => {
                let e = if on_gpu || state.air_on_gpu {
                    commands.entity(old).despawn();
                    commands.spawn(PanelTarget { built: Some(state.clone()), error: None }).id()
                } else {
                    old
                };
                let mut ec = commands.entity(e);
                clear_simulation(&mut ec);
                match sim {
                    PresetSimulation::Coupled(c, g) => {
                        ec.insert(*c);
                        if let Some(g) = g {
                            ec.insert(g);
                        }
                        if state.air_on_gpu {
                            ec.insert(GpuStepping);
                        }
                    }
                    PresetSimulation::Fluid(f) => {
                        ec.insert(*f);
                        if state.air_on_gpu {
                            ec.insert(GpuStepping);
                        }
                    }
                    PresetSimulation::LatticeGas(g) => {
                        ec.insert(*g);
                    }
                }
                t.error = None;
                for (m, of) in &drawn {
                    if of.0 == old {
                        commands.entity(m).despawn();
                    }
                }
            }
            Err(why) => {
                warn!("phonation: the panel's scene was refused: {why}");
                t.error = Some(why);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::DeviceType;

    /// The panel's walls: the preset's (the glottis presets isothermal at T₀, the flap
    /// adiabatic), or isothermal at T₀ (`wall_temperature_ratio = 1.0`), or adiabatic (none),
    /// whatever the preset says; the folds' ghosts carry θ₀ exactly when isothermal.
    #[test]
    fn the_panel_makes_the_walls_isothermal_or_adiabatic_or_keeps_the_presets() {
        let walls = |preset: &str, walls| scene_of(&PanelState { preset: preset.into(), resolution: Some(0.5), walls, ..PanelState::default() }).unwrap();
        assert_eq!(walls("glottis_2d_c", None).coupling.wall_temperature_ratio, Some(1.0), "the glottis presets are isothermal");
        assert_eq!(walls("glottis_2d_c", Some(WallHeat::Isothermal)).coupling.wall_temperature_ratio, Some(1.0));
        assert_eq!(walls("glottis_2d_c", Some(WallHeat::Adiabatic)).coupling.wall_temperature_ratio, None);
        assert_eq!(walls("wall_flap", None).coupling.wall_temperature_ratio, None, "the flap's preset is adiabatic");
        // what the panel shows as the preset's choice
        assert_eq!(preset_walls("glottis_2d_a"), Some(WallHeat::Isothermal));
        assert_eq!(preset_walls("wall_flap"), Some(WallHeat::Adiabatic));
        assert_eq!(preset_walls("cylinder_wake"), None);
        assert_eq!(preset_method("glottis_2d_c"), Some("weak"));
        assert_eq!(preset_method("wall_flap"), Some("weak"));
        assert_eq!(preset_method("glottis_3d"), Some("conserving"));
        assert_eq!(preset_method("lattice_gas_wake"), None);
        assert_eq!(walls("wall_flap", Some(WallHeat::Isothermal)).coupling.wall_temperature_ratio, Some(1.0));
        for (w, isothermal) in [(None, true), (Some(WallHeat::Adiabatic), false)] {
            let c = walls("glottis_2d_c", w).build().unwrap();
            let folds = c.fluid.layout.ghosts.iter().filter(|g| g.wall_temperature == Some(c.units.theta0)).count();
            assert_eq!(folds > 20, isothermal, "{w:?}: {folds} ghosts at θ₀");
            assert!(c.fluid.layout.ghosts.iter().all(|g| g.wall_temperature.is_none() || g.wall_temperature == Some(c.units.theta0)));
        }
    }

    #[test]
    fn a_hardware_gpu_steps_the_glottis_and_a_software_one_leaves_it_on_the_cpu_at_half_resolution() {
        let mut s = PanelState::default();
        assert_eq!(choose_backend(&mut s, Some(("NVIDIA H200", DeviceType::DiscreteGpu))), "stepped on the GPU: NVIDIA H200");
        assert!(s.air_on_gpu && s.resolution.is_none());

        let mut s = PanelState::default();
        let line = choose_backend(&mut s, Some(("llvmpipe (LLVM 19.1.7, 256 bits)", DeviceType::Cpu)));
        assert_eq!(line, "CPU backend at ×0.5 resolution: llvmpipe (LLVM 19.1.7, 256 bits) is not a hardware GPU");
        assert!(!s.air_on_gpu && s.resolution == Some(0.5));
        // the half-resolution glottis is a scene the panel builds: 62 × 64 cells
        let sc = scene_of(&s).unwrap();
        assert_eq!(sc.build().unwrap().fluid.layout.grid.n[..2], [62, 64]);

        // a resolution the app set is kept; a CPU-sized preset keeps its lattice
        let mut s = PanelState { resolution: Some(1.5), ..PanelState::default() };
        choose_backend(&mut s, None);
        assert_eq!((s.air_on_gpu, s.resolution), (false, Some(1.5)));
        let mut s = PanelState { preset: "glottis_2d_coarse".into(), ..PanelState::default() };
        assert_eq!(choose_backend(&mut s, None), "CPU backend: no render device");
        assert_eq!(s.resolution, None);

        // the lattice gas stays on the CPU even on a hardware GPU
        let mut s = PanelState { preset: "lattice_gas_wake".into(), air_on_gpu: true, ..PanelState::default() };
        assert_eq!(choose_backend(&mut s, Some(("NVIDIA H200", DeviceType::DiscreteGpu))), "CPU backend: the app steps this preset on the CPU");
        assert!(!s.air_on_gpu);
    }
}
