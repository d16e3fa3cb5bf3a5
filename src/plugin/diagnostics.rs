//! Simulation figures in Bevy's diagnostics store (`DiagnosticsStore`, read by any
//! diagnostics overlay or logger): steps per second of wall time, lattice node updates per
//! second, particles, the largest Mach number and the air's mass drift, summed or taken over
//! every fluid and coupled simulation entity.

use super::{CoupledSimulation, FluidSimulation, PhonationSystems, SolidSimulation, StepsThisFrame};
use bevy::diagnostic::{Diagnostic, DiagnosticPath, Diagnostics, RegisterDiagnostic};
use bevy::prelude::*;

pub const STEPS_PER_SECOND: DiagnosticPath = DiagnosticPath::const_new("phonation/steps_per_second");
pub const NODE_UPDATES_PER_SECOND: DiagnosticPath = DiagnosticPath::const_new("phonation/node_updates_per_second");
pub const PARTICLES: DiagnosticPath = DiagnosticPath::const_new("phonation/particles");
pub const MAX_MACH: DiagnosticPath = DiagnosticPath::const_new("phonation/max_mach");
/// (M − M₀)/M₀ of the air since the entity's first frame, the largest in magnitude.
pub const MASS_DRIFT: DiagnosticPath = DiagnosticPath::const_new("phonation/mass_drift");

/// The air's mass when an entity was first measured.
#[derive(Component, Debug, Clone, Copy)]
pub struct InitialMass(pub f64);

pub struct PhonationDiagnosticsPlugin;

impl Plugin for PhonationDiagnosticsPlugin {
    fn build(&self, app: &mut App) {
        app.register_diagnostic(Diagnostic::new(STEPS_PER_SECOND).with_suffix(" steps/s"))
            .register_diagnostic(Diagnostic::new(NODE_UPDATES_PER_SECOND).with_suffix(" nodes/s"))
            .register_diagnostic(Diagnostic::new(PARTICLES))
            .register_diagnostic(Diagnostic::new(MAX_MACH))
            .register_diagnostic(Diagnostic::new(MASS_DRIFT))
            .add_systems(Update, measure.in_set(PhonationSystems::Diagnostics));
    }
}

#[allow(clippy::type_complexity)]
fn measure(
    steps: Res<StepsThisFrame>,
    time: Res<Time<Real>>,
    fluids: Query<(Entity, &FluidSimulation, Option<&InitialMass>, Has<super::GpuFluidHandle>)>,
    coupled: Query<(Entity, &CoupledSimulation, Option<&InitialMass>, Option<&super::GpuCoupledReadback>)>,
    solids: Query<&SolidSimulation>,
    mut diagnostics: Diagnostics,
    mut commands: Commands,
) {
    let dt = time.delta_secs_f64();
    let mut nodes = 0usize;
    let mut particles = 0usize;
    let mut mach = 0.0f64;
    // (entity, mass now, its recorded initial mass or the mass to record)
    let mut masses: Vec<(Entity, f64, Result<f64, f64>)> = Vec::new();
    let initial = |m0: Option<&InitialMass>, now: &dyn Fn() -> f64| m0.map(|m| m.0).ok_or_else(now);
    for (e, sim, m0, on_gpu) in &fluids {
        nodes += sim.solver.layout.grid.interior_len();
        if !on_gpu {
            // (stepped on the device, its CPU solver holds the initial state: no Mach or mass
            // drift from it)
            mach = mach.max(sim.solver.max_mach());
            let m = sim.solver.totals().mass;
            masses.push((e, m, initial(m0, &|| m)));
        }
    }
    for (e, sim, m0, gpu) in &coupled {
        let air = &sim.solver.fluid;
        nodes += air.layout.grid.interior_len();
        particles += sim.solver.solid.particles.len();
        match gpu {
            None => {
                mach = mach.max(air.max_mach());
                let m = air.totals().mass;
                masses.push((e, m, initial(m0, &|| m)));
            }
            // stepped on the device: the mass now is the device's sum, the initial one that of
            // the CPU solver's air (the uploaded state); no Mach
            Some(r) => {
                if let Some(t) = r.totals {
                    masses.push((e, t.mass, initial(m0, &|| air.totals().mass)));
                }
            }
        }
    }
    particles += solids.iter().map(|s| s.solver.particles.len()).sum::<usize>();
    let mut drift = 0.0f64;
    for (e, m, m0) in masses {
        let m0 = m0.unwrap_or_else(|m0| {
            commands.entity(e).insert(InitialMass(m0));
            m0
        });
        let d = (m - m0) / m0;
        if d.abs() > drift.abs() {
            drift = d;
        }
    }
    if dt > 0.0 {
        diagnostics.add_measurement(&STEPS_PER_SECOND, || steps.0 as f64 / dt);
        diagnostics.add_measurement(&NODE_UPDATES_PER_SECOND, || (steps.0 as f64 * nodes as f64) / dt);
    }
    diagnostics.add_measurement(&PARTICLES, || particles as f64);
    diagnostics.add_measurement(&MAX_MACH, || mach);
    diagnostics.add_measurement(&MASS_DRIFT, || drift);
}
