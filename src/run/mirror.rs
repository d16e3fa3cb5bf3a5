//! A GPU engine's CPU mirror: what it holds and what came back from the device
//! ([`Mirror`], [`Readback`]), and the diagnoses a run stops with when the device fails or a
//! read of its state does.

use crate::gpu::DeviceHealth;
use crate::step::{Instability, Part, Site};
use serde::Serialize;

/// The instability a run stops with when its device fails (lost, out of memory, a rejected
/// command) during the advance that ended at `step`: the run loop then keeps the outputs
/// written so far, and the mirror holds the last state downloaded before the failure.
pub(super) fn device_failure(why: String, step: u64, time: f64, time_unit: &'static str, n: u64, kept: u64) -> Instability {
    Instability {
        part: Part::Device,
        step,
        time,
        time_unit,
        site: Site::Everywhere,
        quantity: "device state",
        value: f64::NAN,
        reason: format!("{why} (within the last {n} steps; the state kept is the last one downloaded, step {kept}'s)"),
    }
}

/// The instability of a download after an advance that failed (the mirror was left as it was):
/// the device's failure if it recorded one.
pub(super) fn failed_download(health: Option<&DeviceHealth>, step: u64, time: f64, time_unit: &'static str, n: u64, kept: u64) -> Instability {
    let why = health.and_then(|h| h.settle()).unwrap_or_else(|| "reading the state back failed".into());
    device_failure(why, step, time, time_unit, n, kept)
}

/// What a GPU run brought back from the device (the instability flag of every advance aside).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Readback {
    /// Whole states (every node's populations).
    pub whole_states: u64,
    /// Nodes (lattice gas: cells) read for probe samples: the fluid's gathered on the device,
    /// the lattice gas's in bands of rows.
    pub gathered: u64,
    /// Sums of the air's totals made on the device (a coupled run's csv rows).
    pub totals: u64,
    /// Bytes these carried (fluid: f32 populations and partial sums; a coupled run's solid as
    /// well; lattice gas: 16-bit words).
    pub bytes: u64,
}

/// The bookkeeping of a GPU engine's CPU mirror, which receives the device's state only when
/// an output reads it: the step whose whole state it holds, a read that failed, what came back.
pub(super) struct Mirror {
    /// The step whose whole state the mirror holds (the uploaded one before any read).
    pub(super) whole: u64,
    /// The device failed, reported an instability or a read failed: no more reads (the mirror
    /// keeps the last state brought back).
    pub(super) failed: bool,
    /// A read that failed (a lost device, no memory for the staging buffer), returned by the
    /// next advance.
    pub(super) read_failure: Option<Instability>,
    pub(super) readback: Readback,
}

impl Mirror {
    pub(super) fn new(step: u64) -> Self {
        Mirror { whole: step, failed: false, read_failure: None, readback: Readback::default() }
    }

    /// Whether a read at `step` must go to the device.
    pub(super) fn behind(&self, step: u64) -> bool {
        !self.failed && self.whole != step
    }

    /// Records a read of step `step`'s state that failed; the diagnosis names the device's
    /// failure (when `health` recorded one) and the step of the state kept.
    pub(super) fn failed_read(&mut self, health: Option<&DeviceHealth>, step: u64, time: f64, time_unit: &'static str) -> Instability {
        self.failed = true;
        let why = health.and_then(|h| h.settle()).unwrap_or_else(|| "reading the state back failed".into());
        let kept = self.whole;
        let mut e = device_failure(why.clone(), step, time, time_unit, 0, kept);
        e.reason = format!("{why} (reading step {step}'s state back; the state kept is the last one downloaded, step {kept}'s)");
        self.read_failure = Some(e.clone());
        e
    }

    /// `t` (the mirror), or the failed read that left it behind.
    pub(super) fn pending<'a, T>(&self, t: &'a T) -> Result<&'a T, Instability> {
        match &self.read_failure {
            Some(e) => Err(e.clone()),
            None => Ok(t),
        }
    }
}
