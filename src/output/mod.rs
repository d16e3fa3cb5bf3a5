//! Outputs of a run: probe time series (CSV), field snapshots (PNG colour maps, legacy VTK for
//! ParaView) and a summary (JSON). Each writer flushes as it goes so that a run that stops early
//! keeps everything written so far.

pub mod axis;
pub mod coarse;
pub mod fields;
pub mod mesh;
pub mod png_map;
pub mod probes;
pub mod voice;
pub mod vtk;
