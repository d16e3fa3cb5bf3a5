//! The egui panel: a preset ([`PRESETS`]: glottis cases A–D, the coarse glottis, the Wall flap,
//! the FDLB cylinder wake, the lattice gas's cylinder wake), the lung pressure, the folds' cover
//! and body Young's moduli and the coupling method in physical units; pause / single step /
//! steps per frame; what to draw, with the slice's legend; and live figures and plots (glottal
//! flow and f0, a probe's velocity; steps/s, node or site updates/s, particles, Mach, momentum,
//! the lattice gas's invariants).
//!
//! The parameters live in [`PanelState`]; [`apply_panel`] (in [`super::presets`]) rebuilds the
//! simulation of the [`PanelTarget`] entity whenever they differ from what it was built with.

use super::fold_mesh::FoldMesh;
use super::gpu_fold_mesh::GpuFoldMesh;
use super::plots::{F0, PROBE_UY_CM_S, PROBE_UY_LATTICE, PlotHistory, glottal_flow_points, record_plots, show_line};
pub use super::presets::{PRESETS, RESOLUTIONS, apply_panel, build_preset, preset_moduli, scene_of};
use super::slice::SliceView;
use super::{DrawSettings, DrawSystems};
use crate::plugin::diagnostics::{MASS_DRIFT, MAX_MACH, NODE_UPDATES_PER_SECOND, STEPS_PER_SECOND};
use crate::plugin::{
    CoupledDiagnostics, CoupledGlottis, CoupledSimulation, CoupledStatus, FluidSimulation, FluidStatus, GpuProbes, LatticeGasDiagnostics, LatticeGasSimulation,
    SimulationControl, VoiceDiagnostics,
};
use crate::scene::schema::Field;
use bevy::diagnostic::{DiagnosticPath, DiagnosticsStore};
use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};

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
    /// Factor of the preset's lattice cells (the particles' spacing divided by it; one of
    /// [`super::presets::RESOLUTIONS`] in the panel); `None` keeps the preset's.
    pub resolution: Option<f64>,
    /// How the bodies' walls exchange heat with the air; `None` keeps the preset's (the glottis
    /// presets: isothermal at T₀, which the real air at their ×0.5 lattice needs to pass a
    /// closure — README, "The coupled glottis"; the other coupled presets: adiabatic).
    pub walls: Option<WallHeat>,
    /// Step a fluid preset's air, or a coupled preset's air and bodies, on the render device
    /// ([`crate::plugin::GpuStepping`]; the app needs [`crate::plugin::PhonationGpuPlugin`]):
    /// the tracers and slice are then made on the device too. Refused for the lattice-gas
    /// presets, which the app steps on the CPU. Changed alone, it moves the running simulation
    /// (its state with it) instead of rebuilding it.
    pub air_on_gpu: bool,
}

/// How a coupled scene's bodies' walls exchange heat with the air.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WallHeat {
    /// At T₀ (`coupling.wall_temperature_ratio = 1.0`).
    Isothermal,
    /// No heat through the wall (no `wall_temperature_ratio`).
    Adiabatic,
}

impl Default for PanelState {
    fn default() -> Self {
        PanelState { preset: "glottis_2d_c".into(), lung_pressure: None, fold_moduli: None, method: None, resolution: None, walls: None, air_on_gpu: false }
    }
}

/// The entity whose simulation the panel rebuilds, with the state it was built from and why
/// the last rebuild failed, if it did.
#[derive(Component, Debug, Clone, Default)]
pub struct PanelTarget {
    pub built: Option<PanelState>,
    pub error: Option<String>,
}

pub struct PanelPlugin;

impl Plugin for PanelPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<PanelState>().add_systems(Update, (apply_panel, record_plots).in_set(DrawSystems::Panel));
        if !app.is_plugin_added::<EguiPlugin>() {
            app.add_plugins(EguiPlugin::default());
        }
        app.add_systems(EguiPrimaryContextPass, panel_ui);
    }
}

/// The figures every kind of simulation shows: Bevy's smoothed diagnostics.
struct Smoothed<'a>(Option<&'a DiagnosticsStore>);

impl Smoothed<'_> {
    fn get(&self, p: &DiagnosticPath) -> f64 {
        self.0.and_then(|d| d.get(p)).and_then(|d| d.smoothed()).unwrap_or(f64::NAN)
    }
}

#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn panel_ui(
    mut contexts: EguiContexts,
    mut state: ResMut<PanelState>,
    mut control: ResMut<SimulationControl>,
    mut settings: ResMut<DrawSettings>,
    coupled: Query<(
        &CoupledSimulation,
        Option<&PanelTarget>,
        Option<&CoupledDiagnostics>,
        Option<&VoiceDiagnostics>,
        Option<&CoupledGlottis>,
        Option<&CoupledStatus>,
        Option<&PlotHistory>,
        Option<&SliceView>,
        (Option<&FoldMesh>, Option<&GpuFoldMesh>, Has<crate::plugin::GpuCoupledHandle>),
    )>,
    fluids: Query<
        (&FluidSimulation, Option<&PanelTarget>, Option<&FluidStatus>, Option<&PlotHistory>, Option<&SliceView>, Option<&GpuProbes>),
        Without<CoupledSimulation>,
    >,
    gases: Query<(&LatticeGasSimulation, Option<&PanelTarget>, Option<&LatticeGasDiagnostics>, Option<&PlotHistory>, Option<&SliceView>)>,
    targets: Query<(), With<PanelTarget>>,
    time: Res<Time<Real>>,
    store: Option<Res<DiagnosticsStore>>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    let has_target = !targets.is_empty();
    let smoothed = Smoothed(store.as_deref());
    egui::Window::new("phonation").default_pos([8.0, 8.0]).default_width(320.0).show(ctx, |ui| {
        // the scene's parameters only where the panel owns a simulation (a PanelTarget)
        ui.add_enabled_ui(has_target, |ui| scene_controls(ui, &mut state));
        ui.separator();
        run_controls(ui, &mut control);
        ui.separator();
        draw_controls(ui, &mut settings);
        let rates = format!("{:.0} frames/s · {:.0} steps/s", 1.0 / time.delta_secs().max(1e-6), smoothed.get(&STEPS_PER_SECOND));
        let shown = Shown { settings: &settings, smoothed: &smoothed, rates: &rates };
        for (sim, target, diag, voice, glottis, status, plots, slice, (cpu_folds, gpu_folds, on_gpu)) in &coupled {
            ui.separator();
            target_error(ui, target);
            let folds = fold_surface_line(cpu_folds, gpu_folds).filter(|_| settings.folds);
            shown.coupled(ui, CoupledView { sim, diag, voice, glottis, status, plots, slice, folds, on_gpu });
        }
        for (sim, target, status, plots, slice, gpu) in &fluids {
            ui.separator();
            target_error(ui, target);
            shown.fluid(ui, sim, status, plots, slice, gpu);
        }
        for (sim, target, diag, plots, slice) in &gases {
            ui.separator();
            target_error(ui, target);
            shown.lattice_gas(ui, sim, diag, plots, slice);
        }
    });
    Ok(())
}

/// Pause, single step and the steps per frame.
fn run_controls(ui: &mut egui::Ui, control: &mut SimulationControl) {
    ui.horizontal(|ui| {
        ui.checkbox(&mut control.paused, "paused");
        if ui.button("step").clicked() {
            control.paused = true;
            control.single_steps += 1;
        }
    });
    ui.add(egui::Slider::new(&mut control.steps_per_frame, 1..=500).logarithmic(true).text("steps per frame"));
}

/// What to draw: the folds (and where their mesh is made), the tracers, the slice's field.
fn draw_controls(ui: &mut egui::Ui, settings: &mut DrawSettings) {
    ui.checkbox(&mut settings.folds, "folds (marching cubes)");
    ui.checkbox(&mut settings.folds_on_gpu, "folds made on the GPU (when rendering)");
    ui.checkbox(&mut settings.tracers, "tracers (FDLB air)");
    let mut field = settings.slice;
    egui::ComboBox::from_label("slice").selected_text(field.map_or("none".to_string(), |f| format!("{f:?}").to_lowercase())).show_ui(ui, |ui| {
        ui.selectable_value(&mut field, None, "none");
        for f in [Field::Speed, Field::Pressure, Field::Vorticity, Field::Temperature, Field::Density] {
            ui.selectable_value(&mut field, Some(f), format!("{f:?}").to_lowercase());
        }
    });
    settings.slice = field;
}

/// One coupled simulation as the panel shows it: its components, the folds' surface line (when
/// the folds are drawn) and whether it is stepped on the GPU.
struct CoupledView<'a> {
    sim: &'a CoupledSimulation,
    diag: Option<&'a CoupledDiagnostics>,
    voice: Option<&'a VoiceDiagnostics>,
    glottis: Option<&'a CoupledGlottis>,
    status: Option<&'a CoupledStatus>,
    plots: Option<&'a PlotHistory>,
    slice: Option<&'a SliceView>,
    folds: Option<String>,
    on_gpu: bool,
}

/// What every simulation's section reads: the draw settings, Bevy's smoothed diagnostics and
/// the frame and step rates' line.
struct Shown<'a> {
    settings: &'a DrawSettings,
    smoothed: &'a Smoothed<'a>,
    rates: &'a str,
}

impl Shown<'_> {
    /// A coupled simulation's section: where it runs, its time, rates and Mach, the slice's
    /// legend, the folds' surface, the momenta, the voice and the glottal flow's plot, f0's
    /// history.
    fn coupled(&self, ui: &mut egui::Ui, v: CoupledView) {
        if let Some(CoupledStatus::Unstable(why)) = v.status {
            ui.colored_label(egui::Color32::LIGHT_RED, format!("stopped: {why}"));
        }
        let s = &v.sim.solver;
        let backend = if v.on_gpu { "GPU backend (render device)" } else { "CPU backend" };
        ui.label(format!("{backend} · {} nodes · {} particles", s.fluid.layout.grid.interior_len(), s.solid.particles.len()));
        let read = if v.on_gpu { " read back" } else { "" };
        ui.label(format!("t = {:.3} ms ({} steps{read})", s.time * 1e3, s.step_count));
        ui.label(format!("{} · {:.2e} nodes/s · max Mach {:.3}", self.rates, self.smoothed.get(&NODE_UPDATES_PER_SECOND), self.smoothed.get(&MAX_MACH)));
        slice_legend(ui, v.slice, self.settings.slice);
        if let Some(line) = v.folds {
            ui.label(line);
        }
        if let Some(d) = v.diag {
            ui.label(format!("air momentum {:.3e} · solid {:.3e}", d.fluid_momentum.length(), d.solid_momentum.length()));
        }
        if let Some(voice) = v.voice {
            ui.label(format!("glottal flow {:.1} cm³/s · area {:.4} cm²", voice.flow, voice.area));
            match &voice.measures {
                Some(m) => ui.label(format!("f0 {:.1} Hz · OQ {:.2}", m.f0_autocorrelation_hz, m.open_quotient)),
                None => ui.label(voice.no_voice.clone().unwrap_or_default()),
            };
        }
        if let Some(g) = v.glottis {
            show_line(ui, "glottal_flow", "glottal flow (cm³/s)", "t (ms)", glottal_flow_points(g, s.time, s.dt()));
        }
        history_plot(ui, v.plots, F0);
    }

    /// An air-only simulation's section: where it runs, its time, rates (and on the CPU Mach
    /// and the mass drift), the slice's legend, the probe's history.
    fn fluid(
        &self,
        ui: &mut egui::Ui,
        sim: &FluidSimulation,
        status: Option<&FluidStatus>,
        plots: Option<&PlotHistory>,
        slice: Option<&SliceView>,
        gpu: Option<&GpuProbes>,
    ) {
        if let Some(FluidStatus::Unstable(why)) = status {
            ui.colored_label(egui::Color32::LIGHT_RED, format!("stopped: {why}"));
        }
        let [backend, time] = fluid_status(sim, gpu);
        ui.label(backend);
        ui.label(time);
        if gpu.is_some() {
            // its state stays on the device: Mach and mass drift come from a CPU solver,
            // which is not stepped (its slice is made on the device: render::gpu_slice)
            ui.label(format!("{} · {:.2e} nodes/s", self.rates, self.smoothed.get(&NODE_UPDATES_PER_SECOND)));
        } else {
            ui.label(format!("{} · {:.2e} nodes/s · max Mach {:.3}", self.rates, self.smoothed.get(&NODE_UPDATES_PER_SECOND), self.smoothed.get(&MAX_MACH)));
            ui.label(format!("mass drift {:.2e}", self.smoothed.get(&MASS_DRIFT)));
        }
        slice_legend(ui, slice, self.settings.slice);
        history_plot(ui, plots, PROBE_UY_CM_S);
    }

    /// A lattice gas's section: its cells and sites, rates, invariants and isotropy, the slice's
    /// legend, the probe's history.
    fn lattice_gas(
        &self,
        ui: &mut egui::Ui,
        sim: &LatticeGasSimulation,
        diag: Option<&LatticeGasDiagnostics>,
        plots: Option<&PlotHistory>,
        slice: Option<&SliceView>,
    ) {
        let g = &sim.gas;
        let sites = 16 * g.dims.iter().product::<usize>();
        ui.label(format!("CPU backend · FCHC lattice gas · {} × {} × {} cells ({sites} sites)", g.dims[0], g.dims[1], g.dims[2]));
        ui.label(format!("{} · {:.2e} site updates/s", self.rates, self.smoothed.get(&STEPS_PER_SECOND) * sites as f64));
        if let Some(d) = diag {
            ui.label(format!("step {} · {} particles · smallest velocity-family share {:.4}", d.steps, d.invariants.particles, d.smallest_family_share));
        }
        slice_legend(ui, slice, self.settings.slice);
        history_plot(ui, plots, PROBE_UY_LATTICE);
    }
}

/// The panel's first two lines for a fluid: where it is stepped, and its time and step — for
/// a GPU-stepped fluid ([`GpuProbes`]) those of the device's last readback, as its CPU solver is
/// not stepped.
pub fn fluid_status(sim: &FluidSimulation, gpu: Option<&GpuProbes>) -> [String; 2] {
    let s = &sim.solver;
    let nodes = s.layout.grid.interior_len();
    let ms = |t: f64| sim.units.map_or(f64::NAN, |u| u.time_to_physical(t)) * 1e3;
    match gpu {
        Some(p) => [
            format!("GPU backend (render device) · FDLB air · {nodes} nodes"),
            format!("t = {:.3} ms (step {} read back)", ms(p.step as f64 * s.params.dt), p.step),
        ],
        None => [format!("CPU backend · FDLB air · {nodes} nodes"), format!("t = {:.3} ms ({} steps)", ms(s.time), s.step_count)],
    }
}

/// Why the panel's last rebuild was refused, if it was.
fn target_error(ui: &mut egui::Ui, target: Option<&PanelTarget>) {
    if let Some(err) = target.and_then(|t| t.error.as_ref()) {
        ui.colored_label(egui::Color32::LIGHT_RED, err);
    }
}

/// What the folds' surface is: its triangles and where it was made (on the GPU: the count read
/// back, and the room its buffers have).
pub fn fold_surface_line(cpu: Option<&FoldMesh>, gpu: Option<&GpuFoldMesh>) -> Option<String> {
    match (gpu, cpu) {
        (Some(g), _) => Some(match g.triangles {
            Some(t) => format!("folds: {t} triangles, made on the GPU (room for {})", g.capacity),
            None => "folds: made on the GPU (count not read back yet)".to_string(),
        }),
        (None, Some(c)) => Some(format!("folds: {} triangles, made on the CPU", c.triangles)),
        (None, None) => None,
    }
}

/// The slice's range and unit, or why the field is not drawn.
fn slice_legend(ui: &mut egui::Ui, slice: Option<&SliceView>, field: Option<Field>) {
    let Some(field) = field else { return };
    match slice.filter(|v| v.field == field) {
        // a slice made on the device until its range is read back
        Some(v) if v.range.0.is_nan() => ui.label(format!("slice {:?}: range not read back yet ({})", v.field, v.unit)),
        Some(v) => ui.label(format!("slice {:?}: {:.3e} … {:.3e} {}", v.field, v.range.0, v.range.1, v.unit)),
        None => ui.label(format!("slice {field:?}: not a field of this simulation")),
    };
}

/// The recorded series `name`, once it has two points.
fn history_plot(ui: &mut egui::Ui, plots: Option<&PlotHistory>, name: &str) {
    if let Some(s) = plots.and_then(|p| p.get(name)).filter(|s| s.points.len() > 1) {
        show_line(ui, name, name, s.x_label, s.points.iter().copied().collect());
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
    let kind = crate::scene::builtin(&state.preset).map(crate::scene::SceneKind::of);
    if kind.is_some_and(|k| k != crate::scene::SceneKind::LatticeGas) {
        let now = state.resolution.unwrap_or(1.0);
        egui::ComboBox::from_label("resolution (× the preset's cells)").selected_text(format!("×{now}")).show_ui(ui, |ui| {
            for r in RESOLUTIONS {
                if ui.selectable_label(now == r, format!("×{r}")).clicked() {
                    state.resolution = (r != 1.0).then_some(r);
                }
            }
        });
    }
    if kind == Some(crate::scene::SceneKind::Fluid) {
        ui.checkbox(&mut state.air_on_gpu, "stepped on the GPU (render device)");
    }
    if kind != Some(crate::scene::SceneKind::Coupled) {
        return;
    }
    ui.horizontal(|ui| {
        ui.label(if state.walls.is_none() { "walls (the preset's)" } else { "walls" });
        let shown = state.walls.or_else(|| super::presets::preset_walls(&state.preset));
        for (w, label) in [(WallHeat::Isothermal, "isothermal at T₀"), (WallHeat::Adiabatic, "adiabatic")] {
            if ui.radio(shown == Some(w), label).clicked() {
                state.walls = Some(w);
            }
        }
    });
    let mut method = state.method.clone().or_else(|| super::presets::preset_method(&state.preset).map(String::from)).unwrap_or_default();
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
