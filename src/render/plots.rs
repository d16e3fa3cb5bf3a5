//! The panel's live plots ([`egui_plot`]): the glottal flow over the kept window and f0 over the
//! run for a glottis, the transverse velocity at the scene's first probe for a fluid scene (the
//! wake's shedding) and for the lattice gas. [`record_plots`] appends a point per frame in which
//! the simulation stepped to each entity's [`PlotHistory`]; the glottal flow is drawn from
//! [`CoupledGlottis`]'s own per-step samples.

use crate::plugin::{CoupledGlottis, FluidSimulation, GpuProbes, LatticeGasDiagnostics, StepsThisFrame, VoiceDiagnostics};
use bevy::prelude::*;
use bevy_egui::egui;
use egui_plot::{Line, Plot};
use std::collections::VecDeque;

/// Points kept per series (older ones are dropped).
pub const HISTORY_POINTS: usize = 4000;

/// One recorded series: its name with its unit, the x axis's name with its unit, the points.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub x_label: &'static str,
    pub points: VecDeque<[f64; 2]>,
}

impl Series {
    fn push(&mut self, p: [f64; 2]) {
        if self.points.back().is_some_and(|q| q[0] >= p[0]) {
            return; // nothing new (paused, or the same step)
        }
        self.points.push_back(p);
        while self.points.len() > HISTORY_POINTS {
            self.points.pop_front();
        }
    }
}

/// On a simulation entity: the series its panel plots, recorded frame by frame.
#[derive(Component, Debug, Clone, Default, PartialEq)]
pub struct PlotHistory {
    pub series: Vec<Series>,
}

impl PlotHistory {
    /// Appends `p` to the series `name` (created on first use).
    pub fn push(&mut self, name: &str, x_label: &'static str, p: [f64; 2]) {
        match self.series.iter_mut().find(|s| s.name == name) {
            Some(s) => s.push(p),
            None => self.series.push(Series { name: name.into(), x_label, points: VecDeque::from([p]) }),
        }
    }

    pub fn get(&self, name: &str) -> Option<&Series> {
        self.series.iter().find(|s| s.name == name)
    }
}

/// The series [`record_plots`] writes.
pub const F0: &str = "f0 (Hz)";
pub const PROBE_UY_CM_S: &str = "u_y at the first probe (cm/s)";
pub const PROBE_UY_LATTICE: &str = "u_Y at the probe (ℓ/step)";

/// Appends this frame's f0 (glottis), first probe's transverse velocity (fluid scene) or
/// probe velocity (lattice gas) to each entity's [`PlotHistory`].
#[allow(clippy::type_complexity)]
pub fn record_plots(
    steps: Res<StepsThisFrame>,
    mut sims: Query<
        (Entity, Option<&VoiceDiagnostics>, Option<&FluidSimulation>, Option<&GpuProbes>, Option<&LatticeGasDiagnostics>, Option<&mut PlotHistory>),
        Or<(With<VoiceDiagnostics>, With<FluidSimulation>, With<LatticeGasDiagnostics>)>,
    >,
    mut commands: Commands,
) {
    if steps.0 == 0 {
        return;
    }
    for (e, voice, fluid, gpu, gas, history) in &mut sims {
        let record = |h: &mut PlotHistory| {
            if let Some(v) = voice
                && let Some(m) = &v.measures
            {
                h.push(F0, "t (ms)", [v.time * 1e3, m.f0_autocorrelation_hz]);
            }
            if let Some(p) = fluid.and_then(|f| first_probe_uy(f, gpu)) {
                // a GPU readback is new when its time is (readbacks lag the frames)
                let last = h.get(PROBE_UY_CM_S).and_then(|s| s.points.back()).map(|q| q[0]);
                if gpu.is_none() || last != Some(p[0]) {
                    h.push(PROBE_UY_CM_S, "t (ms)", p);
                }
            }
            if let Some(d) = gas
                && let Some(v) = d.probe_velocity
            {
                h.push(PROBE_UY_LATTICE, "step", [d.steps as f64, v[1]]);
            }
        };
        match history {
            Some(mut h) => record(&mut h),
            None => {
                let mut h = PlotHistory::default();
                record(&mut h);
                if !h.series.is_empty() {
                    commands.entity(e).insert(h);
                }
            }
        }
    }
}

/// The first probe's transverse velocity of a fluid scene with units: (t in ms, u_y in cm/s).
/// A GPU-stepped fluid ([`GpuProbes`]) reads the device's last probe readback (its CPU solver
/// is not stepped), `None` before the first one.
pub fn first_probe_uy(f: &FluidSimulation, gpu: Option<&GpuProbes>) -> Option<[f64; 2]> {
    let (u, (_, node)) = (f.units.as_ref()?, f.probes.first()?);
    let (time, uy) = match gpu {
        Some(p) => (p.step as f64 * f.solver.params.dt, p.values.first().filter(|_| p.readbacks > 0)?[2] as f64),
        None => (f.solver.time, f.solver.macro_at(*node).u[1]),
    };
    Some([u.time_to_physical(time) * 1e3, u.velocity_to_physical(uy)])
}

/// A small plot of `points` under its name `name` (the x axis labelled `x_label`).
pub fn show_line(ui: &mut egui::Ui, id: &str, name: &str, x_label: &str, points: Vec<[f64; 2]>) {
    ui.label(egui::RichText::new(name).small());
    // labels with the digits of the tick spacing (egui_plot's own print a flow of ~0 as
    // 0.00000000000 and −0.0000000000001)
    let label = |mark: egui_plot::GridMark, _: &std::ops::RangeInclusive<f64>| crate::output::axis::tick_label(mark.value, 10.0 * mark.step_size);
    Plot::new(id).height(90.0).x_axis_label(x_label.to_string()).x_axis_formatter(label).y_axis_formatter(label).allow_scroll(false).allow_zoom(false).show(
        ui,
        |p| {
            p.line(Line::new(name.to_string(), points));
        },
    );
}

/// The glottal flow kept by `g` (cm³/s) against time (ms), its last sample at `t_now` (s), one
/// sample per coupled step of `dt` (s).
pub fn glottal_flow_points(g: &CoupledGlottis, t_now: f64, dt: f64) -> Vec<[f64; 2]> {
    let n = g.flow.len();
    let stride = (n / 1000).max(1);
    g.flow.iter().enumerate().step_by(stride).map(|(i, q)| [(t_now - (n - 1 - i) as f64 * dt) * 1e3, *q]).collect()
}
