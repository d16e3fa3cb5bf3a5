//! The complete mutable state of a solver as bytes: what a checkpoint stores
//! ([`crate::run::checkpoint`]) and what the determinism hash ([`state_hash`]) is taken of.
//!
//! A solver is rebuilt from its scene (everything the scene fixes: grid, materials, bonds,
//! geometry of rigid obstacles) and then given its saved state (populations, particle positions,
//! velocities, rotations, contact anchors, random-stream position, step counter, time). The
//! state is a sequence of named sections, little-endian, f64 stored as their bits, so that a
//! resumed run continues bit for bit; reading checks each section's name and length against the
//! solver the scene built, so a state of another scene or solver is refused with what differs.
//! Lives below the physics core (like [`crate::step`]), which implements [`SaveState`].

use glam::{DQuat, DVec3};

/// A solver whose state can be saved and restored bit for bit.
pub trait SaveState {
    /// Appends the complete mutable state (scratch buffers excluded: every step rewrites them).
    fn save_state(&self, w: &mut StateWriter);
    /// Restores what [`SaveState::save_state`] wrote, into a solver built from the same scene.
    fn load_state(&mut self, r: &mut StateReader) -> Result<(), StateError>;
}

/// Why a saved state does not fit the solver.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StateError {
    #[error("the state ends inside section `{0}` (truncated)")]
    Truncated(String),
    #[error("state section `{found}` where `{expected}` was expected (a state of another kind of solver)")]
    Section { expected: String, found: String },
    #[error("state section `{what}` holds {found} values, the scene's solver has {expected} (a state of another scene)")]
    Length { what: String, expected: usize, found: usize },
    #[error("state section `{what}`: {reason}")]
    Value { what: String, reason: String },
    #[error("{0} bytes left after the whole state (a state of another scene)")]
    Trailing(usize),
}

/// Writes named sections.
#[derive(Default)]
pub struct StateWriter {
    buf: Vec<u8>,
}

impl StateWriter {
    pub fn new() -> Self {
        Self::default()
    }

    fn tag(&mut self, name: &str, count: usize) {
        let n = u16::try_from(name.len()).expect("section names are short");
        self.buf.extend_from_slice(&n.to_le_bytes());
        self.buf.extend_from_slice(name.as_bytes());
        self.buf.extend_from_slice(&(count as u64).to_le_bytes());
    }

    pub fn u64s(&mut self, name: &str, v: &[u64]) {
        self.tag(name, v.len());
        v.iter().for_each(|x| self.buf.extend_from_slice(&x.to_le_bytes()));
    }

    pub fn u64(&mut self, name: &str, v: u64) {
        self.u64s(name, &[v]);
    }

    /// f64 values, stored as their bits (NaN payloads and signed zeros included).
    pub fn f64s(&mut self, name: &str, v: &[f64]) {
        self.tag(name, v.len());
        v.iter().for_each(|x| self.buf.extend_from_slice(&x.to_bits().to_le_bytes()));
    }

    pub fn f64(&mut self, name: &str, v: f64) {
        self.f64s(name, &[v]);
    }

    pub fn vec3s(&mut self, name: &str, v: &[DVec3]) {
        self.f64s(name, &v.iter().flat_map(|x| x.to_array()).collect::<Vec<_>>());
    }

    pub fn quats(&mut self, name: &str, v: &[DQuat]) {
        self.f64s(name, &v.iter().flat_map(|x| x.to_array()).collect::<Vec<_>>());
    }

    pub fn bytes(&self) -> &[u8] {
        &self.buf
    }

    pub fn into_bytes(self) -> Vec<u8> {
        self.buf
    }
}

/// Reads the sections back, checking names and lengths.
pub struct StateReader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> StateReader<'a> {
    pub fn new(buf: &'a [u8]) -> Self {
        Self { buf, pos: 0 }
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], StateError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.buf.len()).ok_or_else(|| StateError::Truncated(what.into()))?;
        let s = &self.buf[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    /// The next section's count, after checking its name.
    fn tag(&mut self, name: &str) -> Result<usize, StateError> {
        let n = u16::from_le_bytes(self.take(2, name)?.try_into().unwrap()) as usize;
        let found = self.take(n, name)?;
        if found != name.as_bytes() {
            return Err(StateError::Section { expected: name.into(), found: String::from_utf8_lossy(found).into() });
        }
        let count = u64::from_le_bytes(self.take(8, name)?.try_into().unwrap());
        // a count the rest of the buffer cannot hold is a truncation, not an allocation
        if count > ((self.buf.len() - self.pos) / 8) as u64 {
            return Err(StateError::Truncated(name.into()));
        }
        Ok(count as usize)
    }

    fn words(&mut self, name: &str) -> Result<Vec<u64>, StateError> {
        let n = self.tag(name)?;
        let raw = self.take(8 * n, name)?;
        Ok(raw.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().unwrap())).collect())
    }

    fn words_exact(&mut self, name: &str, expected: usize) -> Result<Vec<u64>, StateError> {
        let v = self.words(name)?;
        if v.len() != expected {
            return Err(StateError::Length { what: name.into(), expected, found: v.len() });
        }
        Ok(v)
    }

    /// A section of any length.
    pub fn u64s(&mut self, name: &str) -> Result<Vec<u64>, StateError> {
        self.words(name)
    }

    pub fn u64(&mut self, name: &str) -> Result<u64, StateError> {
        Ok(self.words_exact(name, 1)?[0])
    }

    /// A section of any length.
    pub fn f64s(&mut self, name: &str) -> Result<Vec<f64>, StateError> {
        Ok(self.words(name)?.into_iter().map(f64::from_bits).collect())
    }

    pub fn f64(&mut self, name: &str) -> Result<f64, StateError> {
        Ok(f64::from_bits(self.words_exact(name, 1)?[0]))
    }

    /// Fills `out`, whose length the section must have.
    pub fn f64s_into(&mut self, name: &str, out: &mut [f64]) -> Result<(), StateError> {
        let v = self.words_exact(name, out.len())?;
        out.iter_mut().zip(v).for_each(|(o, w)| *o = f64::from_bits(w));
        Ok(())
    }

    pub fn vec3s_into(&mut self, name: &str, out: &mut [DVec3]) -> Result<(), StateError> {
        let mut flat = vec![0.0; 3 * out.len()];
        self.f64s_into(name, &mut flat).map_err(|e| per_item(e, 3))?;
        out.iter_mut().zip(flat.chunks_exact(3)).for_each(|(o, c)| *o = DVec3::from_slice(c));
        Ok(())
    }

    pub fn quats_into(&mut self, name: &str, out: &mut [DQuat]) -> Result<(), StateError> {
        let mut flat = vec![0.0; 4 * out.len()];
        self.f64s_into(name, &mut flat).map_err(|e| per_item(e, 4))?;
        out.iter_mut().zip(flat.chunks_exact(4)).for_each(|(o, c)| *o = DQuat::from_slice(c));
        Ok(())
    }

    /// Fails unless the whole buffer was read.
    pub fn finish(self) -> Result<(), StateError> {
        match self.buf.len() - self.pos {
            0 => Ok(()),
            n => Err(StateError::Trailing(n)),
        }
    }
}

/// Length errors of vector sections counted in vectors, not in scalars.
fn per_item(e: StateError, k: usize) -> StateError {
    match e {
        StateError::Length { what, expected, found } => StateError::Length { what, expected: expected / k, found: found / k },
        e => e,
    }
}

/// The determinism hash of a solver's state: BLAKE3 of [`SaveState::save_state`]'s bytes, as
/// 64 hex digits. Equal hashes mean bit-identical states.
pub fn state_hash(s: &impl SaveState) -> String {
    let mut w = StateWriter::new();
    s.save_state(&mut w);
    blake3::hash(w.bytes()).to_hex().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_round_trip_bit_for_bit_and_mismatches_are_named() {
        let mut w = StateWriter::new();
        w.u64("step", 7);
        w.f64s("f", &[1.5, -0.0, f64::MIN_POSITIVE, f64::from_bits(0x7ff8_0000_0000_0001)]);
        w.vec3s("x", &[DVec3::new(1.0, 2.0, 3.0)]);
        let bytes = w.into_bytes();
        let mut r = StateReader::new(&bytes);
        assert_eq!(r.u64("step").unwrap(), 7);
        let mut f = [0.0; 4];
        r.f64s_into("f", &mut f).unwrap();
        assert_eq!(f.map(f64::to_bits), [1.5f64.to_bits(), (-0.0f64).to_bits(), f64::MIN_POSITIVE.to_bits(), 0x7ff8_0000_0000_0001]);
        let mut x = [DVec3::ZERO];
        r.vec3s_into("x", &mut x).unwrap();
        assert_eq!(x[0], DVec3::new(1.0, 2.0, 3.0));
        r.finish().unwrap();

        // another name, another length, a cut, an extra byte
        let mut r = StateReader::new(&bytes);
        assert_eq!(r.u64("time"), Err(StateError::Section { expected: "time".into(), found: "step".into() }));
        let mut r = StateReader::new(&bytes);
        r.u64("step").unwrap();
        assert_eq!(r.f64s_into("f", &mut [0.0; 3]), Err(StateError::Length { what: "f".into(), expected: 3, found: 4 }));
        let mut r = StateReader::new(&bytes[..bytes.len() - 1]);
        r.u64("step").unwrap();
        r.f64s("f").unwrap();
        assert_eq!(r.vec3s_into("x", &mut [DVec3::ZERO]), Err(StateError::Truncated("x".into())));
        let mut longer = bytes.clone();
        longer.push(0);
        let mut r = StateReader::new(&longer);
        r.u64("step").unwrap();
        r.f64s("f").unwrap();
        r.vec3s_into("x", &mut [DVec3::ZERO]).unwrap();
        assert_eq!(r.finish(), Err(StateError::Trailing(1)));
    }

    #[test]
    fn a_huge_count_in_a_damaged_state_is_a_truncation_not_an_allocation() {
        let mut w = StateWriter::new();
        w.f64s("f", &[1.0]);
        let mut bytes = w.into_bytes();
        // the count sits after the 2-byte name length and the name
        bytes[3..11].copy_from_slice(&u64::MAX.to_le_bytes());
        assert_eq!(StateReader::new(&bytes).f64s("f"), Err(StateError::Truncated("f".into())));
    }
}
