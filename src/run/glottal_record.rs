//! A glottis run's record: one [`GlottalSample`] per probe interval, written to
//! `glottal_flow.csv` as it is taken, and kept for the voice measures and the checkpoints.

use super::checkpoint;
use crate::coupling::glottis::GlottalSample;
use crate::output::voice::GlottalSeries;
use std::io::Write;
use std::path::Path;

/// Glottal samples of a run, one per probe interval, each also written and flushed to
/// `glottal_flow.csv` as it is taken (a run that stops keeps them).
pub(super) struct GlottalRecord {
    pub(super) samples: Vec<GlottalSample>,
    csv: std::io::BufWriter<std::fs::File>,
    dt: f64,
}

/// The columns of `glottal_flow.csv` after `t_s` (the flow first, as `phonation analyze` reads).
/// The air's power on the folds by part ([`crate::coupling::glottis::AIR_POWER_PARTS`]) and
/// their kinetic energy come last: `voice::AIR_POWER_PREFIX`, `voice::KINETIC_ENERGY_COLUMN`; the
/// margins are read by name too (`voice::LOWER_MARGIN_COLUMN`, `voice::UPPER_MARGIN_COLUMN`).
pub(super) const GLOTTAL_COLUMNS: [&str; 10] = [
    "flow_cm3_s",
    "area_cm2",
    "gap_cm",
    "narrowest_y_cm",
    crate::output::voice::LOWER_MARGIN_COLUMN,
    crate::output::voice::UPPER_MARGIN_COLUMN,
    "air_power_inferior_erg_s",
    "air_power_medial_erg_s",
    "air_power_superior_erg_s",
    crate::output::voice::KINETIC_ENERGY_COLUMN,
];

pub(super) fn glottal_values(s: &GlottalSample) -> [f64; 10] {
    let [pi, pm, ps] = s.air_power;
    [s.flow, s.area, s.gap, s.narrowest_y, s.lower_margin, s.upper_margin, pi, pm, ps, s.kinetic_energy]
}

/// The inverse of [`glottal_values`].
pub(super) fn glottal_from_values(v: &[f64]) -> GlottalSample {
    GlottalSample {
        flow: v[0],
        area: v[1],
        gap: v[2],
        narrowest_y: v[3],
        lower_margin: v[4],
        upper_margin: v[5],
        air_power: [v[6], v[7], v[8]],
        kinetic_energy: v[9],
    }
}

impl GlottalRecord {
    /// A new file with its header, or (`resumed`) the existing one continued.
    pub(super) fn open(path: &Path, dt: f64, resumed: bool) -> std::io::Result<Self> {
        let mut csv = std::io::BufWriter::new(checkpoint::output_file(path, resumed)?);
        if !resumed {
            writeln!(csv, "t_s,{}", GLOTTAL_COLUMNS.join(","))?;
        }
        Ok(Self { samples: Vec::new(), csv, dt })
    }

    pub(super) fn push(&mut self, s: GlottalSample) -> std::io::Result<()> {
        write!(self.csv, "{:.9e}", self.samples.len() as f64 * self.dt)?;
        for v in glottal_values(&s) {
            write!(self.csv, ",{v:.9e}")?;
        }
        writeln!(self.csv)?;
        self.csv.flush()?;
        self.samples.push(s);
        Ok(())
    }

    pub(super) fn series(&self) -> GlottalSeries {
        let rows: Vec<[f64; 10]> = self.samples.iter().map(glottal_values).collect();
        let col = |k: usize| (GLOTTAL_COLUMNS[k].to_string(), rows.iter().map(|r| r[k]).collect::<Vec<f64>>());
        GlottalSeries { dt: self.dt, flow: col(0).1, columns: (1..GLOTTAL_COLUMNS.len()).map(col).collect() }
    }
}
