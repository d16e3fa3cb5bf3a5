//! The fluid's saved state ([`SaveState`]): the populations at every node (fluid, halo, ghost
//! and solid nodes alike, so that nodes a moving body uncovers later start from the same
//! values), the body force, the step counter and the time. The geometry comes from the scene
//! (or, for moving bodies, from the coupling's saved surfaces); the stage buffers are scratch.

use super::FluidSolver;
use crate::state::{SaveState, StateError, StateReader, StateWriter};

impl SaveState for FluidSolver {
    fn save_state(&self, w: &mut StateWriter) {
        w.u64("fluid.step_count", self.step_count);
        w.f64("fluid.time", self.time);
        w.f64s("fluid.body_force", &self.body_force);
        w.f64s("fluid.populations", &self.f);
    }

    fn load_state(&mut self, r: &mut StateReader) -> Result<(), StateError> {
        self.step_count = r.u64("fluid.step_count")?;
        self.time = r.f64("fluid.time")?;
        r.f64s_into("fluid.body_force", &mut self.body_force)?;
        r.f64s_into("fluid.populations", &mut self.f)
    }
}
