//! # phonation
//!
//! Vocal-fold fluid–structure interaction: a compressible thermal finite-difference lattice
//! Boltzmann fluid (D2Q21 / D3Q39, seed 000 §2.3), an MPS orthotropic viscoelastic solid
//! (§2.1–2.2), their two couplings (§2.4: the weak one and the momentum-conserving one), GPU
//! twins of the fluid, solid and coupling kernels (the coupled step of either method runs on the GPU), an
//! integer lattice gas (seed 002), the voice measures and a two-mass reference model.
//! It ships as a headless simulator (`phonation` binary) and a Bevy plugin (feature `bevy`).
//!
//! | module | what |
//! |---|---|
//! | [`fluid`] | FDLB: velocity sets, equilibrium, boundaries, CPU reference solver |
//! | [`mesh`] | marching cubes (a generated, watertight case table shared with the GPU kernel) and the surface of a body of particles: the fold mesh drawn and written for ParaView |
//! | [`lattice_gas`] | FCHC integer lattice gas (second fluid backend, seed 002): collision classes, interference, bit-parallel propagation, channel and cylinder, coarse-graining, viscosity tables, scenes; GPU twin in [`gpu::lattice_gas`] |
//! | [`analysis`] | fits, spectra, f0, the glottal-flow (voice) measures, a cylinder wake's Strouhal number against Williamson's fit, band-limited resampling, synthetic test signals |
//! | [`two_mass`] | the Ishizaka–Flanagan two-mass model of the folds (the yardstick of the glottis) |
//! | [`hash`] | the counter-based hash shared by CPU and GPU random streams (lattice gas, tracers) |
//! | [`error`] | the field-naming input error shared by every layer |
//! | [`coupling`] | fluid–structure coupling: surfaces, tractions, prescribed motions, the weak coupling (method 1), level sets and momentum exchange (method 2), the glottal readouts (2D and 3D) |
//! | [`solid`] | MPS orthotropic viscoelastic solid: materials, particles, forces, contact, explicit and implicit steps, the vocal-fold geometry |
//! | [`stages`] | the ordered stage list of one step (CPU, GPU, Bevy, timings) |
//! | [`state`] | a solver's complete state as bytes (checkpoints) and its determinism hash |
//! | [`step`] | the one step interface of every solver ([`step::Solver`]) and its failure ([`step::Instability`]) |
//! | [`units`] | physical (cgs / SI) ↔ lattice units, Mach scaling |
//! | [`scene`] | scene files (TOML), validation of user input, building a solver |
//! | [`run`] | running a scene on a backend ([`run::backend`]: picking the GPU, one engine per solver) through one run loop ([`run::driver`]) and writing its outputs: fluid, solid, lattice gas, coupled, two-mass; parameter sweeps (parallel or a Slurm job array) |
//! | [`output`] | probes CSV, PNG colour maps, VTK, summary JSON, voice outputs (voice.json, plots, WAV) |
//! | [`validation`] | analytic references and validation cases (Taylor–Green, Sod, …) |
//! | [`bench`](mod@bench) | memory bandwidth and cells/s measurements, cost per update against size |
//! | [`machine`] | the last-level cache, and when a rate is a fraction of the memory bandwidth |
//! | [`gpu`] | wgpu compute twins of the core (no Bevy): the generated FDLB kernels, the solid, the lattice gas, the coupling kernels (method 1's traction, method 2's level set and hand-over) and the coupled step ([`gpu::coupled`]), marching cubes, tracers; each kernel checked against its CPU twin (tests/gpu/) |
//! | `plugin` | Bevy plugin that steps simulations (feature `bevy`) |
//! | `render` | drawing in Bevy (feature `render`, on by default): `render::PhonationPlugins`, the fold mesh, tracers, slices, the egui panel |

// Two style lints the physics code departs from on purpose: `!(x > 0.0)` is how a check that
// must also reject NaN is written (a `partial_cmp` chain would hide that), and loops over axes
// and velocities index several arrays by the same component (`a`, `i`), as the equations do.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod analysis;
pub mod bench;
pub mod coupling;
pub mod error;
pub mod fluid;
pub mod gpu;
pub mod hash;
pub mod lattice_gas;
pub mod machine;
pub mod mesh;
pub mod output;
#[cfg(feature = "bevy")]
pub mod plugin;
#[cfg(feature = "render")]
pub mod render;
pub mod run;
pub mod scene;
pub mod solid;
pub mod stages;
pub mod state;
pub mod step;
pub mod two_mass;
pub mod units;
pub mod validation;

/// The physics core imports nothing above it, and fluid and solid meet only in `coupling`.
#[cfg(test)]
mod layering {
    fn sources(dir: &str) -> Vec<(String, String)> {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src").join(dir);
        let mut out = Vec::new();
        let mut stack = vec![root];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    // Code only: doc comments may point upward (to the GPU twin, say).
                    let code: String =
                        std::fs::read_to_string(&p).unwrap().lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
                    out.push((p.display().to_string(), code));
                }
            }
        }
        out
    }

    #[test]
    fn the_physics_core_imports_nothing_above_it() {
        let above = ["gpu", "engine", "run", "plugin", "output", "scene", "validation", "bench"];
        let mut violations = Vec::new();
        for core in ["fluid", "solid", "lattice_gas", "coupling", "analysis", "two_mass"] {
            for (path, text) in sources(core) {
                for m in above {
                    for pat in [format!("crate::{m}::"), format!("crate::{m};"), format!("crate::{m}}}"), format!("phonation::{m}::")] {
                        if text.contains(&pat) {
                            violations.push(format!("{path}: {pat}"));
                        }
                    }
                }
                let other = match core {
                    "fluid" => Some("solid"),
                    "solid" => Some("fluid"),
                    _ => None,
                };
                if let Some(o) = other
                    && text.contains(&format!("crate::{o}::"))
                {
                    violations.push(format!("{path}: fluid and solid meet only in coupling (crate::{o}::)"));
                }
            }
        }
        assert!(sources("coupling").len() >= 4, "the scan reads the core's files");
        assert!(violations.is_empty(), "{violations:#?}");
    }
}
