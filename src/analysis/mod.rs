//! Analysis of measured series (physics core: imports nothing above it) and the closed forms
//! they are read against: least-squares fits, spectra, the work a force does per period, where
//! the glottis closes, f0, the glottal-flow (voice) measures, a wake's Strouhal number,
//! band-limited resampling, synthetic test signals with known answers, beam theory and Ghia et
//! al.'s cavity tables.

pub mod beam;
pub mod cavity;
pub mod closure;
pub mod energy;
pub mod fit;
pub mod lag;
pub mod oscillation;
pub mod path;
pub mod pitch;
pub mod resample;
pub mod spectrum;
pub mod synthetic;
pub mod voice;
pub mod wake;
