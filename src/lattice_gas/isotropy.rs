//! The gas at rest (issue 5): its equilibrium noise, and the isotropy of its velocity
//! populations under the interference operation — in a fluid without mean flow the seed
//! (002 §4 (2)) saw "spontaneous vortices" at p = 0.2.
//!
//! Reference: with the uniform-in-class collision the product measure — every link occupied
//! independently with probability d — is exactly invariant under collision (it weighs a state by
//! its mass only; the collision keeps the mass and picks uniformly in the class) and under
//! propagation. A block of N sites then has particle-count variance 24 N d (1 − d) and, per
//! component X, Y, Z, momentum variance Σ_k c_kα² N d (1 − d) = 12 N d (1 − d), and each of the
//! six families of velocities (the four in one coordinate plane XY, XZ, XR, YZ, YR, ZR) holds a
//! sixth of the particles. The ratios below are 1 in that equilibrium.
//!
//! Measured (`phonation isotropy`, d = 0.2, 8³ cells, 8 seeds, 8,000 steps): with any p > 0
//! tried (0.01–1) the isotropic state does not last. After a delay that shrinks with p (the
//! smallest share falls below 0.8 at step ≈ 5,900, 3,450, 1,550, 700, 350, 200, 100 for p = 0.01,
//! 0.02, 0.05, 0.1, 0.2, 0.4, 1; medians) the shares spread — rms departure 0.07–0.47 at the end
//! against ≤ 0.015 at p = 0, in most runs one family down to a few per cent of its share — and the
//! block variances fall to 0.25–0.8 of the equilibrium values: the gas is quieter than an
//! equilibrium gas and anisotropic. At rest the momentum flux Π_αα = Σ_k c_kα² n_k sums the
//! families that contain axis α, and it ends up unequal between axes (by 50 % in the test's
//! runs): the gas at rest carries an anisotropic stress. The collision alone keeps every share at
//! 1 ± 0.01; the correlations that the interference leaves between sites overcome it.
//! Units: ratios and shares (dimensionless); steps.

use super::coarse::block_sums;
use super::collision::CollisionTable;
use super::lattice::{Diagonals, LatticeGas};
use super::velocities::Q;
use crate::analysis::fit::slope;
use serde::Serialize;

/// The families of velocities, by the coordinate plane of their two nonzero components (the
/// order of [`super::velocities::VELOCITIES`], four velocities each).
pub const FAMILIES: [&str; 6] = ["XY", "XZ", "XR", "YZ", "YR", "ZR"];

/// Each family's share of the particles, times 6 (1 in the isotropic equilibrium).
pub fn family_shares(g: &LatticeGas) -> [f64; 6] {
    let mut counts = [0u64; 6];
    for block in &g.blocks {
        for (k, w) in block.iter().enumerate() {
            counts[k / 4] += w.count_ones() as u64;
        }
    }
    let total = counts.iter().sum::<u64>().max(1) as f64;
    counts.map(|c| 6.0 * c as f64 / total)
}

/// The smallest family share.
pub fn smallest_share(shares: &[f64; 6]) -> f64 {
    shares.iter().copied().fold(f64::INFINITY, f64::min)
}

/// The root-mean-square departure of the family shares from 1.
pub fn anisotropy(shares: &[f64; 6]) -> f64 {
    (shares.iter().map(|s| (s - 1.0).powi(2)).sum::<f64>() / 6.0).sqrt()
}

/// The diagonal of the momentum flux at rest, Π_αα = Σ_k c_kα² n_k for α = X, Y, Z, R, in units
/// of its isotropic value: the mean share of the three families that contain axis α.
pub fn momentum_flux_diagonal(shares: &[f64; 6]) -> [f64; 4] {
    std::array::from_fn(|axis| (0..6).filter(|&f| FAMILIES[f].contains(["X", "Y", "Z", "R"][axis])).map(|f| shares[f]).sum::<f64>() / 3.0)
}

/// The state of a gas at rest at one step.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RestSample {
    pub step: u32,
    /// Variance of the particle counts of blocks of B³ cells over the product-measure value.
    pub mass_variance: f64,
    /// Variance of the blocks' momentum components (mean of X, Y, Z) over the product-measure
    /// value.
    pub momentum_variance: f64,
    /// [`family_shares`].
    pub shares: [f64; 6],
}

impl RestSample {
    pub fn anisotropy(&self) -> f64 {
        anisotropy(&self.shares)
    }

    /// The smallest family share.
    pub fn smallest_share(&self) -> f64 {
        smallest_share(&self.shares)
    }
}

/// Block-variance ratios of `g` over blocks of `block`³ cells (sample variances over the
/// blocks — unbiased also with the box's totals fixed; d is the box's mean occupation) and the
/// family shares.
pub fn sample(g: &LatticeGas, block: usize) -> RestSample {
    assert!(g.dims.iter().all(|&n| n % block == 0), "blocks must tile the box");
    let (_, sums) = block_sums(g, block);
    let sites = (16 * block * block * block) as f64;
    let counts: Vec<f64> = sums.iter().map(|s| s.particles as f64).collect();
    let d = counts.iter().sum::<f64>() / (counts.len() as f64 * Q as f64 * sites);
    let variance = |xs: &[f64]| {
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (xs.len() as f64 - 1.0)
    };
    let unit = sites * d * (1.0 - d);
    let momentum = (0..3).map(|a| variance(&sums.iter().map(|s| s.momentum[a] as f64).collect::<Vec<_>>())).sum::<f64>();
    RestSample { step: g.step, mass_variance: variance(&counts) / (24.0 * unit), momentum_variance: momentum / (3.0 * 12.0 * unit), shares: family_shares(g) }
}

/// A periodic box of n³ cells filled at rest with density d per link and interference
/// probability p, sampled (blocks of `block`³ cells) at step 0 and every `every` steps up to
/// `steps`.
#[allow(clippy::too_many_arguments, reason = "each is a parameter of the experiment, named at every call")]
pub fn rest_history(density: f64, interference: f64, diagonals: Diagonals, n: usize, block: usize, steps: u32, every: u32, seed: u32) -> Vec<RestSample> {
    let table = CollisionTable::shared();
    let mut g = LatticeGas::new([n, n, n], seed, interference);
    g.diagonals = diagonals;
    g.fill(density, |_| [0.0; 4], seed.wrapping_add(1));
    let mut out = vec![sample(&g, block)];
    for t in 1..=steps {
        g.advance(table);
        if t % every == 0 {
            out.push(sample(&g, block));
        }
    }
    out
}

/// The first sampled step at which the smallest family share is below `threshold` (`None`
/// if it never is).
pub fn onset(history: &[RestSample], threshold: f64) -> Option<u32> {
    history.iter().find(|s| s.smallest_share() < threshold).map(|s| s.step)
}

/// Exponential growth rate (per step) of the anisotropy while it grows from 2× its starting
/// (noise) level to 0.1 — a least-squares fit of its logarithm; `None` with fewer than three
/// samples in that window.
pub fn growth_rate(history: &[RestSample]) -> Option<f64> {
    let floor = history.first()?.anisotropy();
    let start = history.iter().position(|s| s.anisotropy() > 2.0 * floor)?;
    let window: Vec<(f64, f64)> = history[start..].iter().take_while(|s| s.anisotropy() < 0.1).map(|s| (s.step as f64, s.anisotropy().ln())).collect();
    if window.len() < 3 {
        return None;
    }
    let (steps, logs): (Vec<f64>, Vec<f64>) = window.into_iter().unzip();
    Some(slope(&steps, &logs))
}

/// One gas at rest followed over time: its history, the step at which the smallest family
/// share first falls below 0.8, and the early growth rate of the anisotropy.
#[derive(Clone, Debug, Serialize)]
pub struct IsotropyRun {
    pub density: f64,
    pub interference: f64,
    pub seed: u32,
    pub onset_step: Option<u32>,
    /// Per step.
    pub growth_rate: Option<f64>,
    pub history: Vec<RestSample>,
}

/// [`rest_history`] for every p and `seeds` seeds (n³ cells, blocks of 2³, sampled every
/// `every` steps), in parallel.
pub fn isotropy_table(density: f64, interference: &[f64], diagonals: Diagonals, n: usize, steps: u32, every: u32, seeds: usize) -> Vec<IsotropyRun> {
    use rayon::prelude::*;
    let runs: Vec<(f64, u32)> = interference.iter().flat_map(|&p| (0..seeds as u32).map(move |s| (p, 3 + 7919 * s))).collect();
    runs.par_iter()
        .map(|&(p, seed)| {
            let history = rest_history(density, p, diagonals, n, 2, steps, every, seed);
            IsotropyRun { density, interference: p, seed, onset_step: onset(&history, 0.8), growth_rate: growth_rate(&history), history }
        })
        .collect()
}

/// Writes `isotropy.csv` (every sample of every run), `isotropy.json` (onset and growth rate
/// per run) and `isotropy.svg` (the anisotropy against the step, log scale, one line per run)
/// into `dir`; returns the paths.
pub fn write_isotropy(dir: &std::path::Path, runs: &[IsotropyRun]) -> anyhow::Result<Vec<std::path::PathBuf>> {
    use plotters::prelude::*;
    std::fs::create_dir_all(dir)?;
    let csv = dir.join("isotropy.csv");
    let mut text =
        format!("density,interference,seed,step,mass_variance_ratio,momentum_variance_ratio,anisotropy,{}\n", FAMILIES.map(|f| format!("share_{f}")).join(","));
    for r in runs {
        for s in &r.history {
            let shares: Vec<String> = s.shares.iter().map(|x| format!("{x:.5}")).collect();
            text += &format!(
                "{},{},{},{},{:.5},{:.5},{:.5},{}\n",
                r.density,
                r.interference,
                r.seed,
                s.step,
                s.mass_variance,
                s.momentum_variance,
                s.anisotropy(),
                shares.join(",")
            );
        }
    }
    std::fs::write(&csv, text)?;
    let json = dir.join("isotropy.json");
    let summary: Vec<_> = runs
        .iter()
        .map(|r| serde_json::json!({"density": r.density, "interference": r.interference, "seed": r.seed, "onset_step": r.onset_step, "growth_rate_per_step": r.growth_rate, "final": r.history.last()}))
        .collect();
    std::fs::write(&json, serde_json::to_string_pretty(&summary)?)?;
    let svg = dir.join("isotropy.svg");
    {
        let root = SVGBackend::new(&svg, (720, 480)).into_drawing_area();
        root.fill(&WHITE)?;
        let t_max = runs.iter().filter_map(|r| r.history.last()).map(|s| s.step).max().unwrap_or(1) as f64;
        let mut chart = ChartBuilder::on(&root)
            .caption("FCHC lattice gas at rest: anisotropy of the velocity families", ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_max, (1e-3f64..1.0f64).log_scale())?;
        chart.configure_mesh().x_desc("step").y_desc("rms departure of the family shares from 1").draw()?;
        let mut ps: Vec<f64> = runs.iter().map(|r| r.interference).collect();
        ps.sort_by(f64::total_cmp);
        ps.dedup();
        for (i, &p) in ps.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            for (j, r) in runs.iter().filter(|r| r.interference == p).enumerate() {
                let series = chart.draw_series(LineSeries::new(r.history.iter().map(|s| (s.step as f64, s.anisotropy().max(1e-3))), color.stroke_width(1)))?;
                if j == 0 {
                    series.label(format!("p = {p}")).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
                }
            }
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
        root.present()?;
    }
    Ok(vec![csv, json, svg])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gas_at_rest_keeps_its_equilibrium_without_interference_and_loses_isotropy_with_it() {
        // p = 0: the product measure is invariant. 16³ cells in blocks of 2³: 512 blocks, so a
        // variance ratio has a relative standard error √(2/511) = 6.3 %; a family share (≈ 13,100
        // particles of 78,600) has a standard deviation ≈ 0.8 % of its share.
        let quiet = rest_history(0.2, 0.0, Diagonals::OwnPlane, 16, 2, 1000, 250, 3);
        for s in &quiet {
            println!("p = 0, step {}: variance ratios {:.3} (mass), {:.3} (momentum); shares {:.3?}", s.step, s.mass_variance, s.momentum_variance, s.shares);
            assert!((s.mass_variance - 1.0).abs() < 0.25 && (s.momentum_variance - 1.0).abs() < 0.25);
            assert!(s.smallest_share() > 0.96 && s.anisotropy() < 0.025, "{:?}", s.shares);
            assert!(momentum_flux_diagonal(&s.shares).iter().all(|x| (x - 1.0).abs() < 0.02));
        }
        // p > 0: after a delay that shrinks as p grows the shares spread and the gas becomes
        // quieter than the product measure (8³ cells, d = 0.2, seed 3: the smallest share
        // below 0.8 from step 1,550 at p = 0.05 and 350 at p = 0.2; over 8 seeds every run with
        // p ≥ 0.01 ends, after 8,000 steps, with an rms departure ≥ 0.069)
        let onsets: Vec<u32> = [0.05, 0.2]
            .iter()
            .map(|&p| {
                let h = rest_history(0.2, p, Diagonals::OwnPlane, 8, 2, 3000, 50, 3);
                let last = h.last().unwrap();
                println!(
                    "p = {p}: smallest share below 0.8 from step {:?}; growth rate {:.2e}/step; at step {}: shares {:.3?}, anisotropy {:.3}, variance ratios {:.3}, {:.3}",
                    onset(&h, 0.8),
                    growth_rate(&h).unwrap_or(f64::NAN),
                    last.step,
                    last.shares,
                    last.anisotropy(),
                    last.mass_variance,
                    last.momentum_variance
                );
                assert!(last.anisotropy() > 0.1, "p = {p}: {:?}", last.shares);
                // an anisotropic stress at rest: the diagonal momentum flux differs between axes
                let flux = momentum_flux_diagonal(&last.shares);
                let (lo, hi) = flux.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
                println!("  momentum flux Π_αα / isotropic (X, Y, Z, R): {flux:.3?}");
                assert!(hi / lo > 1.2, "{flux:?}");
                assert!(last.mass_variance < 0.8 && last.momentum_variance < 0.8);
                onset(&h, 0.8).unwrap()
            })
            .collect();
        assert!(onsets[1] < onsets[0]);
    }
}
