//! Tracers in the air of every [`CoupledSimulation`] (and [`FluidSimulation`]): born in a thin
//! box along the first inflow face (y_min, the tracheal side of a glottis; x_min for a channel;
//! anywhere in the air of a flow with no inlet: [`birth_box`]),
//! carried by the frame's simulated time through the velocity of the last step
//! ([`crate::fluid::tracers`], RK2, sub-stepped so that no tracer moves more than half a cell
//! per sub-step), drawn as streaks from where they were to where they are, coloured by speed.
//! A GPU-stepped fluid's tracers are advected and drawn on the GPU ([`super::gpu_tracers`]).

use super::{DrawSettings, DrawSystems};
use crate::fluid::FluidSolver;
use crate::fluid::tracers::{Tracers, VelocityField, birth_box};
use crate::plugin::{CoupledSimulation, FluidSimulation, StepsThisFrame};
use bevy::prelude::*;
use glam::DVec3;

/// The tracers of a simulation entity and where they were a frame ago (lattice coordinates).
#[derive(Component, Debug, Clone)]
pub struct FlowTracers {
    pub tracers: Tracers,
    pub previous: Vec<DVec3>,
    /// Speed (lattice units) mapped to the top of the colour scale.
    pub speed_scale: f64,
}

impl FlowTracers {
    /// `count` tracers spread over the domain of `s`, born again along its first inflow face
    /// (or anywhere in the air where it has none: [`birth_box`]).
    pub fn at_inlet(s: &FluidSolver, count: usize) -> Self {
        let g = &s.layout.grid;
        let n = |a: usize| (g.n[a] as f64 - 1.0).max(0.0);
        let z = if g.dim == 3 { (1.0, n(2) - 1.0) } else { (0.0, 0.0) };
        let seed = birth_box(&s.layout);
        let mut tracers = Tracers::new(count, seed);
        // the first generation spread over the whole domain (those in a body are born again
        // at the inlet on the first step), so that the air is seen at once
        let all = Tracers::new(count, (DVec3::new(0.5, 0.5, z.0), DVec3::new(n(0) - 0.5, n(1) - 0.5, z.1)));
        tracers.positions = all.positions;
        let previous = tracers.positions.clone();
        FlowTracers { tracers, previous, speed_scale: 0.1 }
    }

    /// Carries the tracers through `s`'s current velocity for `time` (lattice time).
    pub fn advance(&mut self, s: &FluidSolver, time: f64) {
        let field = VelocityField::of(s);
        let u_max = field.u.iter().map(|u| (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt() as f64).fold(1e-9, f64::max);
        self.speed_scale = 0.9 * self.speed_scale + 0.1 * u_max;
        let sub = ((u_max * time / 0.5).ceil() as usize).clamp(1, 64);
        self.previous.clone_from(&self.tracers.positions);
        for _ in 0..sub {
            self.tracers.advect(&field, time / sub as f64);
        }
    }
}

/// A tracer's colour at speed `t` ∈ [0, 1] of the scale: sky blue when slow to warm white when
/// fast — bright over the dark background and the slice's dark end alike.
pub fn tracer_colour(t: f64) -> Color {
    let t = t.clamp(0.0, 1.0) as f32;
    Color::srgb(0.35 + 0.65 * t, 0.75 + 0.2 * t, 1.0 - 0.55 * t)
}

/// Fluid entities stepped on the CPU (coupled ones are drawn apart, GPU-stepped ones by
/// [`super::gpu_tracers`]).
type CpuSteppedFluid = (Without<CoupledSimulation>, Without<crate::plugin::GpuFluidHandle>);

pub struct TracerPlugin;

impl Plugin for TracerPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(Update, advance_tracers.in_set(DrawSystems::Tracers));
    }
}

pub(super) fn advance_tracers(
    settings: Res<DrawSettings>,
    steps: Res<StepsThisFrame>,
    mut coupled: Query<(Entity, &CoupledSimulation, Option<&mut FlowTracers>), Without<crate::plugin::GpuCoupledHandle>>,
    mut fluids: Query<(Entity, &FluidSimulation, Option<&mut FlowTracers>), CpuSteppedFluid>,
    mut gizmos: Gizmos,
    mut commands: Commands,
) {
    if !settings.tracers {
        return;
    }
    let mut draw = |t: &FlowTracers, dx: f64, dim: usize| {
        let world = |p: DVec3| {
            let z = if dim == 3 { (p.z + 0.5) * dx } else { 0.3 * dx };
            Vec3::new(((p.x + 0.5) * dx) as f32, ((p.y + 0.5) * dx) as f32, z as f32)
        };
        for (a, b) in t.previous.iter().zip(&t.tracers.positions) {
            let d = (*b - *a).length();
            if d > 2.0 {
                continue; // born again this frame
            }
            // at least a third of a cell long, so that slow tracers show
            let (pa, mut pb) = (world(*a), world(*b));
            let min = (dx / 3.0) as f32;
            if pb.distance(pa) < min {
                pb = pa + (pb - pa).try_normalize().unwrap_or(Vec3::Y) * min;
            }
            gizmos.line(pa, pb, tracer_colour(d / (t.speed_scale.max(1e-9) * 4.0)));
        }
    };
    for (e, sim, tr) in &mut coupled {
        let s = &sim.solver.fluid;
        let (dx, dim) = (sim.solver.units.dx, s.layout.grid.dim);
        match tr {
            Some(mut t) => {
                if steps.0 > 0 {
                    t.advance(s, s.params.dt * steps.0 as f64);
                }
                draw(&t, dx, dim);
            }
            None => {
                commands.entity(e).insert(FlowTracers::at_inlet(s, settings.tracer_count));
            }
        }
    }
    for (e, sim, tr) in &mut fluids {
        let s = &sim.solver;
        let dx = sim.units.map_or(1.0, |u| u.dx);
        match tr {
            Some(mut t) => {
                if steps.0 > 0 {
                    t.advance(s, s.params.dt * steps.0 as f64);
                }
                draw(&t, dx, s.layout.grid.dim);
            }
            None => {
                commands.entity(e).insert(FlowTracers::at_inlet(s, settings.tracer_count));
            }
        }
    }
}
