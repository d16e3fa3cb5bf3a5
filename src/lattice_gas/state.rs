//! The lattice gas' saved state ([`SaveState`]): every site's occupation bits and the position
//! of the random streams (`step`, which seeds the collision, interference and inlet draws of the
//! next step). Obstacles, seed and inlet come from the scene.

use super::lattice::LatticeGas;
use super::velocities::Q;
use crate::state::{SaveState, StateError, StateReader, StateWriter};

impl SaveState for LatticeGas {
    fn save_state(&self, w: &mut StateWriter) {
        w.u64("lattice_gas.random_stream_step", self.step as u64);
        w.u64s("lattice_gas.bits", self.blocks.as_flattened());
    }

    fn load_state(&mut self, r: &mut StateReader) -> Result<(), StateError> {
        let step = r.u64("lattice_gas.random_stream_step")?;
        self.step = u32::try_from(step)
            .map_err(|_| StateError::Value { what: "lattice_gas.random_stream_step".into(), reason: format!("{step} does not fit the u32 stream position") })?;
        let bits = r.u64s("lattice_gas.bits")?;
        if bits.len() != self.blocks.len() * Q {
            return Err(StateError::Length { what: "lattice_gas.bits".into(), expected: self.blocks.len() * Q, found: bits.len() });
        }
        self.blocks.as_flattened_mut().copy_from_slice(&bits);
        Ok(())
    }
}
