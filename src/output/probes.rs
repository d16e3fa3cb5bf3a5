//! Probe time series: pressure (gauge), velocity, density and temperature ratio at fixed nodes,
//! written as CSV rows as the run goes (flushed every row).

use crate::fluid::FluidSolver;
use crate::units::Units;
use std::io::{BufWriter, Write};
use std::path::Path;

pub struct ProbeWriter {
    out: BufWriter<std::fs::File>,
    probes: Vec<(String, usize)>,
    dim: usize,
}

impl ProbeWriter {
    pub fn create(path: &Path, s: &FluidSolver, probes: &[(String, [i64; 3])]) -> std::io::Result<Self> {
        Self::open(path, s, probes, false)
    }

    /// Creates the file with its header, or with `append` continues an existing one (a resumed
    /// run: the header and the rows so far are there).
    pub fn open(path: &Path, s: &FluidSolver, probes: &[(String, [i64; 3])], append: bool) -> std::io::Result<Self> {
        let dim = s.layout.grid.dim;
        let probes_at = probes.iter().map(|(n, x)| (n.clone(), s.layout.grid.index(*x))).collect();
        if append {
            let out = BufWriter::new(std::fs::OpenOptions::new().append(true).open(path)?);
            return Ok(ProbeWriter { out, probes: probes_at, dim });
        }
        let mut out = BufWriter::new(std::fs::File::create(path)?);
        write!(out, "step,time_s")?;
        let axes = ["ux", "uy", "uz"];
        for (name, _) in probes {
            write!(out, ",{name}_pressure,{name}_density")?;
            for a in axes.iter().take(dim) {
                write!(out, ",{name}_{a}")?;
            }
            write!(out, ",{name}_temperature_ratio")?;
        }
        writeln!(out)?;
        Ok(ProbeWriter { out, probes: probes_at, dim })
    }

    /// The nodes the probes read (padded indices): the populations a sample needs.
    pub fn nodes(&self) -> Vec<usize> {
        self.probes.iter().map(|(_, n)| *n).collect()
    }

    /// Appends one row for the solver's current state and flushes it.
    pub fn sample(&mut self, s: &FluidSolver, units: &Units) -> std::io::Result<()> {
        write!(self.out, "{},{:.9e}", s.step_count, units.time_to_physical(s.time))?;
        for (_, node) in &self.probes {
            let m = s.macro_at(*node);
            write!(self.out, ",{:.9e},{:.9e}", units.gauge_pressure_to_physical(m.pressure()), units.density_to_physical(m.rho))?;
            for a in 0..self.dim {
                write!(self.out, ",{:.9e}", units.velocity_to_physical(m.u[a]))?;
            }
            write!(self.out, ",{:.9e}", m.theta / units.theta0)?;
        }
        writeln!(self.out)?;
        self.out.flush()
    }
}
