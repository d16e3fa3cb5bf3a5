//! Validation cases with analytic or published references (../shared/reference). Each case
//! returns its measured figure next to the reference; the tests and the `validate` CLI
//! subcommand assert the tolerances.

pub mod beam;
pub mod cavity;
pub mod channel;
pub mod contact;
pub mod cylinder;
pub mod fsi;
pub mod fsi_flap;
pub mod fsi_momentum;
pub mod fsi_plate;
pub mod fsi_schafer_turek;
pub mod glottis;
pub mod glottis_3d;
pub mod glottis_energy;
pub mod glottis_modes;
pub mod glottis_self_oscillation;
pub mod glottis_stiffness;
pub mod riemann;
pub mod soak;
pub mod sod;
pub mod sound;
pub mod suite;
pub mod taylor_green;
pub mod waves;

use crate::fluid::FluidSolver;
use crate::fluid::storage::Storage;
use crate::run::FluidEngine;
use crate::step::{Instability, Solver};

/// A fluid run that a validation case steps and reads: the engine (populations in f64, on
/// either backend) or a CPU solver whose populations are stored as `S` (the f32 storage option).
pub(crate) trait FluidRun<S: Storage> {
    fn advance(&mut self, n: u64) -> Result<(), Instability>;
    /// The whole state of the step reached.
    fn state(&mut self) -> &FluidSolver<S>;
}

impl FluidRun<f64> for FluidEngine {
    fn advance(&mut self, n: u64) -> Result<(), Instability> {
        Solver::advance(self, n)
    }
    fn state(&mut self) -> &FluidSolver {
        FluidEngine::state(self).expect("the state comes back from the backend")
    }
}

impl<S: Storage> FluidRun<S> for FluidSolver<S> {
    fn advance(&mut self, n: u64) -> Result<(), Instability> {
        self.run(n)
    }
    fn state(&mut self) -> &FluidSolver<S> {
        self
    }
}
