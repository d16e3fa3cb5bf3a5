//! Drawing a simulation in a Bevy app (feature `render`): the folds as a marching-cubes mesh,
//! the air as tracers and a colour-mapped slice, an egui panel, and [`PhonationPlugins`], the
//! plugin group that puts them together with the simulation stepping.
//!
//! | plugin | what it adds | system set |
//! |---|---|---|
//! | [`crate::plugin::PhonationPlugin`] | steps every simulation entity on the CPU (pause, single step, steps per frame) | [`crate::plugin::PhonationSystems`] (one set per solver stage list) |
//! | [`crate::plugin::PhonationDiagnosticsPlugin`] | steps/s, node updates/s, particles, max Mach, mass drift in Bevy's `DiagnosticsStore` | [`crate::plugin::PhonationSystems::Diagnostics`] |
//! | [`DrawPlugin`] | [`DrawSettings`] and the drawing's order; [`view::FrameSimulation`] cameras | [`DrawSystems`] |
//! | [`fold_mesh::FoldMeshPlugin`] | each coupled or solid simulation's bodies as a mesh ([`crate::mesh`]: the level set the air sees, marching cubes on the CPU), coloured per body — in apps without a render device or with [`DrawSettings::folds_on_gpu`] off | [`DrawSystems::FoldMesh`] |
//! | [`gpu_fold_mesh::GpuFoldMeshPlugin`] | the same surfaces made on the GPU in the render world on the frames the simulation stepped (level set on a grid and marching cubes, [`crate::gpu::fold_surface`]) and drawn from the kernels' buffers by a material — no readback but the triangle count | [`DrawSystems::FoldMesh`] (sources), the `RenderGraph` schedule (kernels) |
//! | [`tracers::TracerPlugin`] | tracers born at the inlet and carried by the air ([`crate::fluid::tracers`], RK2), drawn as streaks coloured by speed | [`DrawSystems::Tracers`] |
//! | [`gpu_tracers::GpuTracerPlugin`] | the tracers of a GPU-stepped fluid ([`crate::plugin::GpuStepping`] with [`crate::plugin::PhonationGpuPlugin`]) advected in the render world after the frame's steps and drawn from the device's buffer by a line material — no readback | [`DrawSystems::Tracers`] (spawning), the `RenderGraph` schedule (kernel) |
//! | [`slice::SlicePlugin`] | the plane of the 2D lattice (coupled, fluid) or the lattice gas's coarse-grained field as an image of speed, pressure, vorticity, …, with its range and unit | [`DrawSystems::Slice`] |
//! | [`gpu_slice::GpuSlicePlugin`] | the slice of a GPU-stepped fluid made by compute passes in the render world after the frame's steps (the plane's moments, values in scene units, range, colours: [`crate::gpu::slice`]) and copied into its texture — only the range comes back, for the legend | [`DrawSystems::Slice`] (set-up), the `RenderGraph` schedule (kernels) |
//! | [`panel::PanelPlugin`] | the egui panel: presets of every drawn kind ([`presets`]), lung pressure, fold moduli, coupling method, pause / step / steps per frame, what to draw, diagnostics and live plots ([`plots`]: glottal flow, f0, a probe's velocity) | [`DrawSystems::Panel`] |
//!
//! The drawing systems run after the simulation's sets in `Update`; every plugin can be left
//! out of the group (`PhonationPlugins.build().disable::<TracerPlugin>()`). What is drawn is
//! chosen by the [`DrawSettings`] resource. The folds' surfaces are made on the GPU from the CPU
//! solvers' particles (their level sets go up, the mesh never comes back); the tracers and slices
//! of CPU-stepped simulations are computed on the CPU and uploaded each frame; a GPU-stepped
//! fluid's tracers and slice stay on the device ([`gpu_tracers`], [`gpu_slice`]).

use crate::plugin::{PhonationDiagnosticsPlugin, PhonationPlugin, PhonationSystems};
use bevy::app::PluginGroupBuilder;
use bevy::prelude::*;

pub mod fold_mesh;
pub mod gpu_fold_mesh;
pub mod gpu_slice;
pub mod gpu_tracers;
pub mod panel;
pub mod plots;
pub mod presets;
pub mod slice;
pub mod tracers;
pub mod view;

/// What the drawing plugins draw (the panel edits it).
#[derive(Resource, Debug, Clone, PartialEq)]
pub struct DrawSettings {
    pub folds: bool,
    /// Make the folds' surface on the GPU in the render world ([`gpu_fold_mesh`]) when the app
    /// has a render device; otherwise, or when off, on the CPU ([`fold_mesh`]).
    pub folds_on_gpu: bool,
    pub tracers: bool,
    /// Tracers per simulation.
    pub tracer_count: usize,
    /// The field of the slice, `None` for no slice.
    pub slice: Option<crate::scene::schema::Field>,
}

impl Default for DrawSettings {
    fn default() -> Self {
        DrawSettings { folds: true, folds_on_gpu: true, tracers: true, tracer_count: 4000, slice: Some(crate::scene::schema::Field::Speed) }
    }
}

/// The air of a fluid or coupled simulation entity (queried as
/// `AnyOf<(&FluidSimulation, &CoupledSimulation)>`) and its units when it has them.
pub fn air_of<'a>(
    sim: (Option<&'a crate::plugin::FluidSimulation>, Option<&'a crate::plugin::CoupledSimulation>),
) -> (&'a crate::fluid::FluidSolver, Option<crate::units::Units>) {
    match sim {
        (Some(f), _) => (&f.solver, f.units),
        (None, Some(c)) => (&c.solver.fluid, Some(c.solver.units)),
        (None, None) => unreachable!("AnyOf matches one of the two"),
    }
}

/// The drawing systems, after the simulation's sets.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub enum DrawSystems {
    FoldMesh,
    Tracers,
    Slice,
    Panel,
}

/// The simulation stepping plus every drawing plugin.
pub struct PhonationPlugins;

impl PluginGroup for PhonationPlugins {
    fn build(self) -> PluginGroupBuilder {
        PluginGroupBuilder::start::<Self>()
            .add(PhonationPlugin)
            .add(PhonationDiagnosticsPlugin)
            .add(DrawPlugin)
            .add(fold_mesh::FoldMeshPlugin)
            .add(gpu_fold_mesh::GpuFoldMeshPlugin)
            .add(tracers::TracerPlugin)
            .add(gpu_tracers::GpuTracerPlugin)
            .add(slice::SlicePlugin)
            .add(gpu_slice::GpuSlicePlugin)
            .add(panel::PanelPlugin)
    }
}

/// The drawing's shared settings and system order.
pub struct DrawPlugin;

impl Plugin for DrawPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<DrawSettings>().configure_sets(
            Update,
            (DrawSystems::Panel, DrawSystems::FoldMesh, DrawSystems::Tracers, DrawSystems::Slice).chain().after(PhonationSystems::Diagnostics),
        );
        app.add_systems(Update, view::frame_simulations.after(DrawSystems::Panel).before(DrawSystems::FoldMesh));
    }
}
