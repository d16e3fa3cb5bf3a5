//! A CSV output read back by column name (numbers only): what the reports that read a run's
//! whole history at its end (the wake from `probes.csv`, the beam from `solid.csv`) share.

use anyhow::Context;

/// A CSV file's columns by header name (numbers only).
pub(crate) struct Columns {
    names: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl Columns {
    pub(crate) fn parse(text: &str) -> anyhow::Result<Self> {
        let mut lines = text.lines();
        let names = lines.next().context("empty file")?.split(',').map(|s| s.trim().to_string()).collect();
        let rows = lines
            .filter(|l| !l.trim().is_empty())
            .enumerate()
            .map(|(k, l)| l.split(',').map(|v| v.trim().parse::<f64>().with_context(|| format!("row {}: {v:?} is not a number", k + 1))).collect())
            .collect::<anyhow::Result<_>>()?;
        Ok(Columns { names, rows })
    }

    pub(crate) fn get(&self, name: &str) -> anyhow::Result<Vec<f64>> {
        let i = self.names.iter().position(|n| n == name).with_context(|| format!("no column {name}"))?;
        self.rows.iter().enumerate().map(|(k, r)| r.get(i).copied().with_context(|| format!("row {}: no {name}", k + 1))).collect()
    }
}
