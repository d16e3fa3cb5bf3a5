//! Lattice-gas scene files (a `[lattice_gas]` table; seed 002 §3.5): the box of cells, the fill,
//! the interference probability, an optional channel inlet and cylinder, the outputs. Every value
//! is checked, with the field and the reason, before anything is allocated. The run writes the
//! coarse-grained velocity (CSV, VTK, PNG), a wake probe and a summary with the Strouhal number.
//!
//! Units: lengths in ℓ (site spacing; cell centres every 2ℓ), velocities in ℓ per step.

use crate::lattice_gas::lattice::{Diagonals, Inlet, LANES, LatticeGas, Outlet};
use crate::lattice_gas::velocities::Q;
use crate::scene::SceneError;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LatticeGasSceneFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub lattice_gas: LatticeGasSection,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LatticeGasSection {
    /// Cells along X, Y, Z (X a multiple of 4).
    pub cells: [usize; 3],
    /// Initial fill: particles per link, in (0, 1); at rest, random directions.
    pub density: f64,
    /// Probability p of the interference operation, in [0, 1].
    #[serde(default)]
    pub interference: f64,
    /// Diagonals the interference exchanges along: `own_plane` (default) or `all_perpendicular`
    /// ([`Diagonals`]).
    #[serde(default)]
    pub diagonals: Diagonals,
    #[serde(default = "default_seed")]
    pub seed: u32,
    pub steps: u64,
    /// Channel: +X injection at X = 0 and a zero-gradient outlet; absent: periodic in X.
    pub inlet: Option<InletSection>,
    pub cylinder: Option<CylinderSection>,
    #[serde(default)]
    pub output: OutputSection,
}

fn default_seed() -> u32 {
    1
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InletSection {
    /// Inflow velocity along +X (ℓ/step); the inlet density is the fill's.
    pub velocity: f64,
    /// `copy` (zero gradient, the seed's) or `free_stream` (refilled like the inlet).
    #[serde(default)]
    pub outlet: Outlet,
}

/// An infinite cylinder along Z.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderSection {
    /// Axis position (X, Y) in ℓ.
    pub center: [f64; 2],
    /// Radius in ℓ.
    pub radius: f64,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSection {
    /// Cells per coarse-graining block edge (4 in the seed).
    pub coarse_block: usize,
    /// Steps between coarse-grained snapshots.
    pub every: u64,
    /// Steps between probe samples.
    pub probe_every: u64,
    /// Probe position (X, Y) in ℓ; default: two diameters behind the cylinder's axis.
    pub probe: Option<[f64; 2]>,
}

impl Default for OutputSection {
    fn default() -> Self {
        Self { coarse_block: 4, every: 1000, probe_every: 10, probe: None }
    }
}

/// Most cells a scene may have (site indices 24 · cell + k must fit in 32 bits).
pub const MAX_CELLS: usize = (u32::MAX / Q as u32) as usize;
/// Most cells with [`Diagonals::AllPerpendicular`] (the complementary draws' indices
/// 2 · (24 · cell + k) + diagonal must fit in 32 bits).
pub const MAX_CELLS_ALL_PERPENDICULAR: usize = (u32::MAX / (2 * Q as u32)) as usize;

#[derive(Clone, Debug)]
pub struct LatticeGasScene {
    pub file: LatticeGasSceneFile,
    /// Probe position in ℓ, if the scene has one.
    pub probe: Option<[f64; 2]>,
}

fn err<T>(field: &str, reason: impl Into<String>) -> Result<T, SceneError> {
    Err(SceneError { field: format!("lattice_gas.{field}"), reason: reason.into() })
}

/// Why a fill density (particles per link) is refused, if it is: it must lie in (0, 1). Shared by
/// scene files and the `viscosity` / `isotropy` commands.
pub fn density_problem(d: f64) -> Option<String> {
    (!(d > 0.0 && d < 1.0)).then(|| format!("fill {d} must lie in (0, 1) particles per link"))
}

/// Why an interference probability is refused, if it is: it must lie in [0, 1].
pub fn interference_problem(p: f64) -> Option<String> {
    (!(0.0..=1.0).contains(&p)).then(|| format!("probability {p} must lie in [0, 1]"))
}

impl LatticeGasScene {
    pub fn parse(text: &str) -> Result<Self, SceneError> {
        let file: LatticeGasSceneFile = toml::from_str(text).map_err(|e| SceneError::from_toml("lattice_gas", &e, text))?;
        Self::new(file)
    }

    /// Validates every value (nothing is allocated).
    pub fn new(file: LatticeGasSceneFile) -> Result<Self, SceneError> {
        let s = &file.lattice_gas;
        let [nx, ny, nz] = s.cells;
        if nx < 8 || nx % LANES != 0 {
            return err("cells", format!("X = {nx} cells: must be a multiple of {LANES} and at least 8 (four cells per 64-bit word)"));
        }
        if ny == 0 || nz == 0 {
            return err("cells", format!("Y and Z must be at least 1 cell, got {ny} × {nz}"));
        }
        let cells = nx.checked_mul(ny).and_then(|c| c.checked_mul(nz)).unwrap_or(usize::MAX);
        if cells > MAX_CELLS {
            return err("cells", format!("{cells} cells exceed the limit of {MAX_CELLS} (32-bit site indices of the random streams)"));
        }
        if s.diagonals == Diagonals::AllPerpendicular && cells > MAX_CELLS_ALL_PERPENDICULAR {
            return err(
                "cells",
                format!(
                    "{cells} cells exceed the limit of {MAX_CELLS_ALL_PERPENDICULAR} with all_perpendicular diagonals (32-bit indices of the interference draws)"
                ),
            );
        }
        if let Some(reason) = density_problem(s.density) {
            return err("density", reason);
        }
        if let Some(reason) = interference_problem(s.interference) {
            return err("interference", reason);
        }
        if s.steps == 0 {
            return err("steps", "must be at least 1");
        }
        if let Some(inlet) = &s.inlet {
            let u = inlet.velocity;
            if !(u >= 0.0) || s.density * (1.0 + 2.0 * u) > 1.0 || u >= 0.5 {
                return err(
                    "inlet.velocity",
                    format!(
                        "{u} ℓ/step: must be ≥ 0 and below 0.5 with density·(1 + 2u) ≤ 1 (the inlet's +X links fill with d(1 + 2u)); the sound speed is 1/√2"
                    ),
                );
            }
        }
        let (lx, ly) = (2.0 * nx as f64, 2.0 * ny as f64);
        if let Some(c) = &s.cylinder {
            if !(c.radius > 0.0) {
                return err("cylinder.radius", format!("{} ℓ must be positive", c.radius));
            }
            // inside the box, clear of the inlet cell and the two outlet cells
            let (x0, x1) = if s.inlet.is_some() { (2.0, lx - 5.0) } else { (0.0, lx - 1.0) };
            if c.center[0] - c.radius < x0 || c.center[0] + c.radius > x1 || c.center[1] - c.radius < 0.0 || c.center[1] + c.radius > ly - 1.0 {
                return err(
                    "cylinder",
                    format!(
                        "centre {:?} ℓ, radius {} ℓ: the cylinder must lie inside the domain, X in [{x0}, {x1}] and Y in [0, {}] ℓ (cell centres at 2·index)",
                        c.center,
                        c.radius,
                        ly - 1.0
                    ),
                );
            }
        }
        let o = &s.output;
        if o.coarse_block == 0 || o.coarse_block > nx.min(ny) {
            return err("output.coarse_block", format!("{} cells: must be at least 1 and at most the box's X and Y", o.coarse_block));
        }
        if o.every == 0 || o.probe_every == 0 {
            return err("output", "every and probe_every must be at least 1 step");
        }
        let probe = o.probe.or_else(|| s.cylinder.as_ref().map(|c| [c.center[0] + 4.0 * c.radius, c.center[1]]));
        if let Some(p) = probe
            && !(p[0] >= 0.0 && p[0] <= lx - 1.0 && p[1] >= 0.0 && p[1] <= ly - 1.0)
        {
            return err("output.probe", format!("{p:?} ℓ lies outside the domain [0, {}] × [0, {}] ℓ", lx - 1.0, ly - 1.0));
        }
        Ok(Self { file, probe })
    }

    /// Allocates and fills the gas (at rest, density d per link), with its cylinder and inlet.
    pub fn build(&self) -> LatticeGas {
        let s = &self.file.lattice_gas;
        let mut g = LatticeGas::new(s.cells, s.seed, s.interference);
        g.diagonals = s.diagonals;
        if let Some(c) = &s.cylinder {
            g.add_cylinder(c.center, c.radius);
        }
        g.inlet = s.inlet.as_ref().map(|i| Inlet::new(s.density, i.velocity, i.outlet));
        g.fill(s.density, |_| [0.0; 4], s.seed.wrapping_add(0x5bd1_e995));
        g
    }
}

/// The cell rows `y0..=y1` that [`region_velocity`] reads for a square of half-width `half` ℓ
/// around `at` (ℓ) in a gas of `dims` cells.
pub fn region_rows(dims: [usize; 3], at: [f64; 2], half: f64) -> (usize, usize) {
    let y0 = ((at[1] - half) / 2.0).ceil().max(0.0) as usize;
    let y1 = (((at[1] + half) / 2.0).floor() as usize).min(dims[1] - 1);
    (y0, y1)
}

/// Mean velocity (X, Y; ℓ/step) of the fluid sites of the cells within a square of half-width
/// `half` ℓ around `at` (ℓ), over all Z.
pub fn region_velocity(g: &LatticeGas, at: [f64; 2], half: f64) -> [f64; 2] {
    let (mut n, mut j) = (0u64, [0i64; 2]);
    let x0 = ((at[0] - half) / 2.0).ceil().max(0.0) as usize;
    let x1 = (((at[0] + half) / 2.0).floor() as usize).min(g.dims[0] - 1);
    let (y0, y1) = region_rows(g.dims, at, half);
    for z in 0..g.dims[2] {
        for y in y0..=y1 {
            for x in x0..=x1 {
                let cell = g.cell_index(x, y, z);
                if g.solid[cell] {
                    continue;
                }
                let (cn, cj) = g.cell_moments(cell);
                n += cn;
                j[0] += cj[0];
                j[1] += cj[1];
            }
        }
    }
    if n == 0 { [0.0; 2] } else { j.map(|v| v as f64 / n as f64) }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) const SMALL: &str = r#"
name = "small_wake"
[lattice_gas]
cells = [32, 16, 2]
density = 0.2
interference = 0.1
steps = 60
[lattice_gas.inlet]
velocity = 0.2
[lattice_gas.cylinder]
center = [20.0, 16.0]
radius = 4.0
[lattice_gas.output]
coarse_block = 4
every = 30
probe_every = 5
"#;

    fn with(replace: &str, by: &str) -> Result<LatticeGasScene, SceneError> {
        assert!(SMALL.contains(replace), "{replace}");
        LatticeGasScene::parse(&SMALL.replace(replace, by))
    }

    #[test]
    fn bad_input_is_refused_with_the_field_and_the_reason() {
        assert!(LatticeGasScene::parse(SMALL).is_ok());
        for (name, text) in crate::scene::LATTICE_GAS_BUILTIN {
            assert_eq!(crate::scene::SceneKind::of(text), crate::scene::SceneKind::LatticeGas);
            LatticeGasScene::parse(text).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        assert_ne!(crate::scene::SceneKind::of(crate::scene::BUILTIN[0].1), crate::scene::SceneKind::LatticeGas);
        let cases = [
            ("interference = 0.1", "interference = 1.5", "lattice_gas.interference", "[0, 1]"),
            ("interference = 0.1", "interference = -0.01", "lattice_gas.interference", "[0, 1]"),
            ("density = 0.2", "density = 0.0", "lattice_gas.density", "(0, 1)"),
            ("density = 0.2", "density = 1.0", "lattice_gas.density", "(0, 1)"),
            ("center = [20.0, 16.0]", "center = [20.0, 40.0]", "lattice_gas.cylinder", "inside the domain"),
            ("center = [20.0, 16.0]", "center = [62.0, 16.0]", "lattice_gas.cylinder", "inside the domain"),
            ("radius = 4.0", "radius = 0.0", "lattice_gas.cylinder.radius", "positive"),
            ("cells = [32, 16, 2]", "cells = [30, 16, 2]", "lattice_gas.cells", "multiple of 4"),
            ("cells = [32, 16, 2]", "cells = [4000, 4000, 4000]", "lattice_gas.cells", "exceed"),
            ("velocity = 0.2", "velocity = 0.6", "lattice_gas.inlet.velocity", "below 0.5"),
            ("coarse_block = 4", "coarse_block = 0", "lattice_gas.output.coarse_block", "at least 1"),
            ("steps = 60", "steps = 60\nviscosity = 2", "lattice_gas.viscosity", "unknown field"),
            ("interference = 0.1", "interference = 0.1\ndiagonals = \"all\"", "lattice_gas.diagonals", "all_perpendicular"),
            ("interference = 0.1", "interference = \"high\"", "lattice_gas.interference", "invalid type"),
            ("cells = [32, 16, 2]", "cells = [1024, 1024, 96]\ndiagonals = \"all_perpendicular\"", "lattice_gas.cells", "all_perpendicular"),
            ("velocity = 0.2", "velocity = 0.2\noutlet = \"open\"", "lattice_gas.inlet.outlet", "free_stream"),
        ];
        for (a, b, field, reason) in cases {
            let e = with(a, b).expect_err(b);
            println!("{b}: {e}");
            assert_eq!(e.field, field, "{b}");
            assert!(e.reason.contains(reason), "{b}: {}", e.reason);
        }
    }

    #[test]
    fn the_interference_diagonals_are_read_from_the_scene() {
        assert_eq!(LatticeGasScene::parse(SMALL).unwrap().build().diagonals, Diagonals::OwnPlane);
        let all = with("interference = 0.1", "interference = 0.1\ndiagonals = \"all_perpendicular\"").unwrap();
        assert_eq!(all.build().diagonals, Diagonals::AllPerpendicular);
    }
}
