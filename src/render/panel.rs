//! The egui panel: a preset (glottis cases A–D, the coarse glottis, the Wall flap), the lung
//! pressure, the folds' cover and body Young's moduli and the coupling method in physical units;
//! pause / single step / steps per frame; what to draw, with the slice's legend; and live
//! figures (glottal flow plot, f0, steps/s, particles, momentum).
//!
//! The parameters live in [`PanelState`]; [`apply_panel`] rebuilds the simulation of the
//! [`PanelTarget`] entity whenever they differ from what it was built with, whether the change
//! came from the panel's widgets or from the app's own code (tests set the state directly).

use super::slice::{SliceView, unit_of};
use super::{DrawSettings, DrawSystems};
use crate::plugin::{CoupledDiagnostics, CoupledGlottis, CoupledSimulation, CoupledStatus, SimulationControl, VoiceDiagnostics};
use crate::scene::coupled::CoupledScene;
use crate::scene::schema::Field;
use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};

/// The scenes the panel offers.
pub const PRESETS: [&str; 6] = ["glottis_2d_a", "glottis_2d_b", "glottis_2d_c", "glottis_2d_d", "glottis_2d_coarse", "wall_flap"];

/// The simulation's parameters as the panel shows them (scene units: dyn/cm²).
#[derive(Resource, Debug, Clone, PartialEq)]
pub struct PanelState {
    pub preset: String,
    /// Lung pressure (gauge, dyn/cm²) of a glottis preset; `None` keeps the preset's.
    pub lung_pressure: Option<f64>,
    /// Cover and body Young's moduli (dyn/cm²) of the folds; `None` keeps the preset's.
    pub fold_moduli: Option<(f64, f64)>,
    /// "weak" (method 1) or "conserving" (method 2); `None` keeps the preset's.
    pub method: Option<String>,
}

impl Default for PanelState {
    fn default() -> Self {
        PanelState { preset: "glottis_2d_c".into(), lung_pressure: None, fold_moduli: None, method: None }
    }
}

/// The entity whose simulation the panel rebuilds, with the state it was built from and why
/// the last rebuild failed, if it did.
#[derive(Component, Debug, Clone, Default)]
pub struct PanelTarget {
    pub built: Option<PanelState>,
    pub error: Option<String>,
}

/// The scene of `state`: the preset with its lung pressure, fold moduli and method replaced.
pub fn scene_of(state: &PanelState) -> Result<CoupledScene, String> {
    let text = crate::scene::builtin(&state.preset).ok_or_else(|| format!("preset: no built-in scene {}", state.preset))?;
    let mut doc: toml::Table = text.parse().map_err(|e| format!("preset {}: {e}", state.preset))?;
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
    let mut sc = CoupledScene::parse(&toml::to_string(&doc).map_err(|e| e.to_string())?).map_err(|e| e.to_string())?;
    if let Some((cover, body)) = state.fold_moduli {
        if !(cover > 0.0 && body > 0.0) {
            return Err(format!("fold_moduli: ({cover}, {body}) dyn/cm² must be positive"));
        }
        sc.set_fold_moduli(cover, body);
    }
    Ok(sc)
}

pub struct PanelPlugin;

impl Plugin for PanelPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<PanelState>().add_systems(Update, apply_panel.in_set(DrawSystems::Panel));
        if !app.is_plugin_added::<EguiPlugin>() {
            app.add_plugins(EguiPlugin::default());
        }
        app.add_systems(EguiPrimaryContextPass, panel_ui);
    }
}

/// Rebuilds the [`PanelTarget`]'s simulation when [`PanelState`] differs from what it was built
/// with; the drawings of the old one go with it.
pub fn apply_panel(
    state: Res<PanelState>,
    mut targets: Query<(Entity, &mut PanelTarget)>,
    drawn: Query<(Entity, &super::fold_mesh::FoldMeshOf)>,
    slices: Query<(Entity, &super::slice::SliceOf)>,
    mut commands: Commands,
) {
    for (e, mut t) in &mut targets {
        if t.built.as_ref() == Some(&*state) {
            continue;
        }
        t.built = Some(state.clone());
        match scene_of(&state).and_then(|sc| sc.build().map(|s| (sc, s)).map_err(|e| e.to_string())) {
            Ok((sc, solver)) => {
                let glottis = CoupledGlottis::of(&sc, &solver, 0.05);
                let mut ec = commands.entity(e);
                ec.remove::<(
                    CoupledStatus,
                    CoupledGlottis,
                    VoiceDiagnostics,
                    crate::plugin::diagnostics::InitialMass,
                    super::fold_mesh::FoldMesh,
                    super::tracers::FlowTracers,
                    SliceView,
                )>();
                ec.insert(CoupledSimulation { solver });
                if let Some(g) = glottis {
                    ec.insert(g);
                }
                t.error = None;
                for (m, of) in &drawn {
                    if of.0 == e {
                        commands.entity(m).despawn();
                    }
                }
                for (m, of) in &slices {
                    if of.0 == e {
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

#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn panel_ui(
    mut contexts: EguiContexts,
    mut state: ResMut<PanelState>,
    mut control: ResMut<SimulationControl>,
    mut settings: ResMut<DrawSettings>,
    sims: Query<(
        &CoupledSimulation,
        Option<&PanelTarget>,
        Option<&CoupledDiagnostics>,
        Option<&VoiceDiagnostics>,
        Option<&CoupledGlottis>,
        Option<&SliceView>,
        Option<&CoupledStatus>,
    )>,
    targets: Query<(), With<PanelTarget>>,
    time: Res<Time<Real>>,
    store: Option<Res<bevy::diagnostic::DiagnosticsStore>>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    let has_target = !targets.is_empty();
    egui::Window::new("phonation").default_pos([8.0, 8.0]).default_width(300.0).show(ctx, |ui| {
        // the scene's parameters only where the panel owns a simulation (a PanelTarget)
        ui.add_enabled_ui(has_target, |ui| scene_controls(ui, &mut state));
        ui.separator();
        ui.horizontal(|ui| {
            ui.checkbox(&mut control.paused, "paused");
            if ui.button("step").clicked() {
                control.paused = true;
                control.single_steps += 1;
            }
        });
        ui.add(egui::Slider::new(&mut control.steps_per_frame, 1..=500).logarithmic(true).text("steps per frame"));
        ui.separator();
        ui.checkbox(&mut settings.folds, "folds (marching cubes)");
        ui.checkbox(&mut settings.tracers, "tracers");
        let mut field = settings.slice;
        egui::ComboBox::from_label("slice").selected_text(field.map_or("none".to_string(), |f| format!("{f:?}").to_lowercase())).show_ui(ui, |ui| {
            ui.selectable_value(&mut field, None, "none");
            for f in [Field::Speed, Field::Pressure, Field::Vorticity, Field::Temperature, Field::Density] {
                ui.selectable_value(&mut field, Some(f), format!("{f:?}").to_lowercase());
            }
        });
        settings.slice = field;
        for (sim, target, diag, voice, g, slice, status) in &sims {
            ui.separator();
            if let Some(err) = target.and_then(|t| t.error.as_ref()) {
                ui.colored_label(egui::Color32::LIGHT_RED, err);
            }
            if let Some(CoupledStatus::Unstable(why)) = status {
                ui.colored_label(egui::Color32::LIGHT_RED, format!("stopped: {why}"));
            }
            let s = &sim.solver;
            ui.label(format!("CPU backend · {} nodes · {} particles", s.fluid.layout.grid.interior_len(), s.solid.particles.len()));
            let smoothed = |p: &bevy::diagnostic::DiagnosticPath| store.as_ref().and_then(|d| d.get(p)).and_then(|d| d.smoothed()).unwrap_or(f64::NAN);
            ui.label(format!("t = {:.3} ms ({} steps)", s.time * 1e3, s.step_count));
            ui.label(format!(
                "{:.0} frames/s · {:.0} steps/s · {:.2e} nodes/s · max Mach {:.3}",
                1.0 / time.delta_secs().max(1e-6),
                smoothed(&crate::plugin::diagnostics::STEPS_PER_SECOND),
                smoothed(&crate::plugin::diagnostics::NODE_UPDATES_PER_SECOND),
                smoothed(&crate::plugin::diagnostics::MAX_MACH)
            ));
            if let Some(v) = slice {
                ui.label(format!("slice {:?}: {:.3e} … {:.3e} {}", v.field, v.range.0, v.range.1, unit_of(v.field)));
            }
            if let Some(d) = diag {
                ui.label(format!("air momentum {:.3e} · solid {:.3e}", d.fluid_momentum.length(), d.solid_momentum.length()));
            }
            if let Some(v) = voice {
                ui.label(format!("glottal flow {:.1} cm³/s · area {:.4} cm²", v.flow, v.area));
                match &v.measures {
                    Some(m) => ui.label(format!("f0 {:.1} Hz · OQ {:.2}", m.f0_autocorrelation_hz, m.open_quotient)),
                    None => ui.label(v.no_voice.clone().unwrap_or_default()),
                };
            }
            if let Some(g) = g {
                flow_plot(ui, g.flow.iter().copied().collect());
            }
        }
    });
    Ok(())
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

/// The scene's parameters: preset, lung pressure and fold moduli (glottis presets), coupling method.
fn scene_controls(ui: &mut egui::Ui, state: &mut PanelState) {
    egui::ComboBox::from_label("preset").selected_text(state.preset.clone()).show_ui(ui, |ui| {
        for p in PRESETS {
            if ui.selectable_label(state.preset == p, p).clicked() {
                *state = PanelState { preset: p.into(), ..default() };
            }
        }
    });
    let glottis = state.preset.starts_with("glottis");
    if glottis {
        let mut p = state.lung_pressure.unwrap_or(8000.0);
        if ui.add(egui::Slider::new(&mut p, 0.0..=20000.0).text("lung pressure (dyn/cm²)")).changed() {
            state.lung_pressure = Some(p);
        }
        let (mut cover, mut body) = state.fold_moduli.unwrap_or_else(|| preset_moduli(&state.preset));
        let a = ui.add(egui::Slider::new(&mut cover, 1e4..=1e6).logarithmic(true).text("cover E (dyn/cm²)")).changed();
        let b = ui.add(egui::Slider::new(&mut body, 1e5..=1e8).logarithmic(true).text("body E (dyn/cm²)")).changed();
        if a || b {
            state.fold_moduli = Some((cover, body));
        }
    }
    let mut method = state.method.clone().unwrap_or_default();
    ui.horizontal(|ui| {
        ui.label(if state.method.is_none() { "coupling (the preset's)" } else { "coupling" });
        for m in ["weak", "conserving"] {
            if ui.radio(method == m, m).clicked() {
                method = m.into();
                state.method = Some(m.into());
            }
        }
    });
}

/// The kept glottal flow as a line (cm³/s against sample).
fn flow_plot(ui: &mut egui::Ui, flow: Vec<f64>) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width(), 80.0), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, egui::Color32::from_gray(24));
    if flow.len() < 2 {
        return;
    }
    let (lo, hi) = flow.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
    let span = (hi - lo).max(1e-9);
    let stride = (flow.len() / rect.width().max(1.0) as usize).max(1);
    let points: Vec<egui::Pos2> = flow
        .iter()
        .enumerate()
        .step_by(stride)
        .map(|(i, v)| egui::pos2(rect.left() + rect.width() * i as f32 / (flow.len() - 1) as f32, rect.bottom() - rect.height() * ((v - lo) / span) as f32))
        .collect();
    painter.add(egui::Shape::line(points, egui::Stroke::new(1.5, egui::Color32::from_rgb(250, 200, 80))));
    painter.text(
        rect.left_top() + egui::vec2(4.0, 2.0),
        egui::Align2::LEFT_TOP,
        format!("glottal flow {hi:.0} cm³/s"),
        egui::FontId::monospace(10.0),
        egui::Color32::GRAY,
    );
}
