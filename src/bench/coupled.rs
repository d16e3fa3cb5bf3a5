//! The coupled and voice benches: the glottis scenes' coupled steps per second from rest, the
//! two-mass model's cost against its error, and the coupled cylinder at three resolutions.

use super::*;

/// Speed of a glottis scene from rest (the first steps: the pressure wave has not yet reached
/// the folds, so the fluid geometry is rebuilt only where it changes).
#[derive(Clone, Debug, Serialize)]
pub struct GlottisSpeed {
    pub scene: String,
    pub nodes: usize,
    pub particles: usize,
    /// Coupled (= fluid) step (s).
    pub dt: f64,
    pub coupled_steps_per_s: f64,
    /// Wall seconds per simulated millisecond.
    pub wall_per_simulated_ms: f64,
    pub stage_shares: Vec<(String, f64)>,
}

/// The solver of the built-in coupled scene `name`.
fn built_in(name: &str) -> crate::coupling::CoupledSolver {
    crate::scene::coupled::CoupledScene::parse(crate::scene::builtin(name).expect("built in")).expect("valid").build().expect("builds")
}

/// `steps` coupled steps of each built-in glottis scene of `names`.
pub fn glottis_speed(names: &[&str], steps: u64) -> Vec<GlottisSpeed> {
    names
        .iter()
        .map(|name| {
            let mut c = built_in(name);
            let t = Instant::now();
            c.run(steps).expect("stable from rest");
            let wall = t.elapsed().as_secs_f64();
            let n = c.fluid.layout.grid.n;
            GlottisSpeed {
                scene: name.to_string(),
                nodes: n[0] * n[1] * n[2],
                particles: c.solid.particles.len(),
                dt: c.dt(),
                coupled_steps_per_s: steps as f64 / wall,
                wall_per_simulated_ms: wall / (steps as f64 * c.dt() * 1e3),
                stage_shares: c.stage_shares().into_iter().map(|(n, f)| (n.to_string(), f)).collect(),
            }
        })
        .collect()
}

/// One RK4 rate of the two-mass speed-vs-error table.
#[derive(Clone, Debug, Serialize)]
pub struct TwoMassSpeed {
    /// RK4 steps per second of simulated time (Hz).
    pub rate_hz: f64,
    pub steps_per_s: f64,
    /// Wall seconds per simulated second.
    pub wall_per_simulated_s: f64,
    pub f0_hz: f64,
    /// |f0 − f0(finest)| / f0(finest) and the same for the peak flow.
    pub f0_error: f64,
    pub peak_flow_error: f64,
}

/// The two-mass rows: 0.4 s at 8 cmH₂O with RK4 at 1, 2, 4, 8 × 44.1 kHz against 32 × 44.1 kHz.
pub fn two_mass_speed_vs_error() -> Vec<TwoMassSpeed> {
    use crate::analysis::voice::{VoiceOptions, voice_measures};
    use crate::two_mass::{CM_H2O, TwoMassParams, simulate};
    let runs: Vec<(f64, f64, crate::analysis::voice::VoiceMeasures)> = [1.0, 2.0, 4.0, 8.0, 32.0]
        .iter()
        .map(|k| {
            let rate = 44_100.0 * k;
            let steps = (0.4 * rate) as usize;
            let t = Instant::now();
            let run = simulate(&TwoMassParams::default(), 8.0 * CM_H2O, 1.0 / rate, steps);
            let wall = t.elapsed().as_secs_f64();
            (rate, wall, voice_measures(&run.flow, 1.0 / rate, &VoiceOptions::default()).expect("the standard model oscillates at 8 cmH2O"))
        })
        .collect();
    let (_, _, fine) = runs.last().expect("five rates").clone();
    runs.iter()
        .map(|(rate, wall, m)| TwoMassSpeed {
            rate_hz: *rate,
            steps_per_s: 0.4 * rate / wall,
            wall_per_simulated_s: wall / 0.4,
            f0_hz: m.f0_autocorrelation_hz,
            f0_error: (m.f0_autocorrelation_hz / fine.f0_autocorrelation_hz - 1.0).abs(),
            peak_flow_error: (m.peak_flow / fine.peak_flow - 1.0).abs(),
        })
        .collect()
}

/// One resolution of the coupled speed-vs-error table.
#[derive(Clone, Debug, Serialize)]
pub struct CoupledSpeed {
    /// "method 1" (weak) or "method 2" (momentum-conserving).
    pub method: &'static str,
    pub cells_per_diameter: usize,
    pub nodes: usize,
    pub particles: usize,
    pub solid_substeps: u32,
    pub coupled_steps_per_s: f64,
    /// Wall seconds per simulated second.
    pub wall_per_simulated_s: f64,
    /// C_D averaged over the last quarter of the run.
    pub drag_coefficient: f64,
    /// |C_D − C_D(finest)| / C_D(finest) (0 for the finest).
    pub error_vs_finest: f64,
    /// |C_D − 5.5795| / 5.5795 (the steady reference; short runs are still settling).
    pub error_vs_reference: f64,
    pub stage_shares: Vec<(String, f64)>,
}

/// The coupled rows: D = 10, 20, 30 cells (quick: 10, 20) for `duration` simulated seconds,
/// method 1 then method 2 (each against its own finest run).
pub fn coupled_speed_vs_error(quick: bool) -> Vec<CoupledSpeed> {
    use crate::coupling::TractionModel;
    use crate::validation::fsi::CylinderBody;
    let (sizes, duration): (&[usize], f64) = if quick { (&[10, 20], 0.1) } else { (&[10, 20, 30], 1.0) };
    let methods = [("method 1", CylinderBody::WeakCoupled(TractionModel::PressureAndShear)), ("method 2", CylinderBody::ConservingCoupled)];
    methods.into_iter().flat_map(|(name, body)| coupled_rows(name, body, sizes, duration)).collect()
}

pub(super) fn coupled_rows(method: &'static str, body: crate::validation::fsi::CylinderBody, sizes: &[usize], duration: f64) -> Vec<CoupledSpeed> {
    use crate::validation::fsi::{ChannelStart, ST_2D1_DRAG, schafer_turek_2d1};
    let runs: Vec<_> = sizes.iter().map(|&d| (d, schafer_turek_2d1(d, 0.1, ChannelStart::Impulsive, duration, body))).collect();
    let finest = runs.last().map(|(_, r)| r.drag_coefficient).unwrap_or(f64::NAN);
    runs.into_iter()
        .map(|(d, r)| CoupledSpeed {
            method,
            cells_per_diameter: d,
            nodes: (22 * d) * (41 * d / 10),
            particles: r.particles,
            solid_substeps: r.substeps,
            coupled_steps_per_s: r.steps as f64 / r.wall_s,
            wall_per_simulated_s: r.wall_s / r.simulated_s,
            drag_coefficient: r.drag_coefficient,
            error_vs_finest: (r.drag_coefficient - finest).abs() / finest,
            error_vs_reference: (r.drag_coefficient - ST_2D1_DRAG).abs() / ST_2D1_DRAG,
            stage_shares: r.stage_shares,
        })
        .collect()
}

/// The fluid_geometry stage of a coupled scene on its own: what building the walls costs the
/// host at every step, at the scene's full size.
#[derive(Clone, Debug, Serialize)]
pub struct GeometrySpeed {
    pub scene: String,
    /// "weak" (surface polygons) or "momentum_conserving" (kernel level sets).
    pub method: &'static str,
    pub nodes: usize,
    pub particles: usize,
    pub steps: u64,
    /// Wall time of one fluid_geometry stage (s): the walls built and installed, the level
    /// sets' questions answered on this host's threads.
    pub seconds_per_step: f64,
    /// 1 / [`Self::seconds_per_step`]: the most coupled steps per second while the walls are
    /// built on this host.
    pub ceiling_steps_per_s: f64,
    /// Of [`Self::seconds_per_step`], the level sets' questions (the nodes' sides, the ghosts'
    /// wall points: [`crate::fluid::LevelSetQueries`]) that the GPU backend asks of a device
    /// with f64 (method 2; zero for method 1).
    pub device_answerable_seconds_per_step: f64,
    /// 1 / (the rest): the ceiling where those questions go to a device.
    pub ceiling_with_device_questions_steps_per_s: f64,
    /// Timed steps whose walls differ from the step before's (the ghosts' depths or wall
    /// velocities): every one, or the figures timed no work.
    pub walls_rebuilt: u64,
    /// The host's own work split: each part of the layout's build
    /// ([`crate::fluid::LayoutPart`], in its order) per step, then `bodies` (the rest of making
    /// the walls: the particles in lattice units, the level sets binned or the surface polygons
    /// made) and `install` (the walls installed in the fluid: fresh nodes initialised, method
    /// 2's momentum of the nodes that changed side booked).
    pub host_parts: Vec<GeometryPart>,
}

/// One part of the host's work per step of the geometry bench.
#[derive(Clone, Debug, Serialize)]
pub struct GeometryPart {
    pub part: &'static str,
    pub seconds_per_step: f64,
}

/// The CPU's answers to the level sets' questions, timed, and the layout's parts' times.
#[derive(Default)]
struct TimedQueries {
    asked: std::sync::Mutex<f64>,
    parts: std::sync::Mutex<[f64; crate::fluid::LayoutPart::ALL.len()]>,
}

impl TimedQueries {
    fn time<T>(&self, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let out = f();
        *self.asked.lock().expect("not poisoned") += t.elapsed().as_secs_f64();
        out
    }

    fn reset(&self) {
        *self.asked.lock().expect("not poisoned") = 0.0;
        *self.parts.lock().expect("not poisoned") = Default::default();
    }
}

impl crate::fluid::LevelSetQueries for TimedQueries {
    fn outside_distances(&self, which: usize, set: &crate::fluid::KernelLevelSet, points: &[[f64; 3]]) -> Vec<Option<f64>> {
        self.time(|| crate::fluid::OnThePool.outside_distances(which, set, points))
    }

    fn ghost_walls(&self, which: usize, set: &crate::fluid::KernelLevelSet, queries: &[crate::fluid::GhostQuery]) -> Vec<crate::fluid::GhostWall> {
        self.time(|| crate::fluid::OnThePool.ghost_walls(which, set, queries))
    }

    fn part_timed(&self, part: crate::fluid::LayoutPart, elapsed: std::time::Duration) {
        self.parts.lock().expect("not poisoned")[part as usize] += elapsed.as_secs_f64();
    }
}

/// Lattice cells by which [`geometry_speed`] moves the particles at its steps (a few times a
/// real step's displacement: the glottis's folds move ≲ 10⁻² cells a step).
pub const GEOMETRY_BENCH_CELLS: f64 = 0.02;

/// `steps` fluid_geometry stages of each built-in coupled scene of `names`, at rest but for a
/// translation of every particle along x by ±[`GEOMETRY_BENCH_CELLS`] cells in turn, so that
/// every wall moves at every step, as in a run where the folds vibrate, and no other stage
/// runs (the 3D glottis's solid step would take minutes here).
pub fn geometry_speed(names: &[&str], steps: u64) -> Vec<GeometrySpeed> {
    use crate::coupling::Method;
    names
        .iter()
        .map(|name| {
            let mut c = built_in(name);
            let shift = GEOMETRY_BENCH_CELLS * c.units.dx;
            let (mut wall, mut installing, queries, mut rebuilt) = (0.0, 0.0, TimedQueries::default(), 0);
            // one untimed stage first (the walls of the scene's first step)
            for k in 0..=steps {
                let dx = if k % 2 == 0 { shift } else { -shift };
                c.solid.particles.position.iter_mut().for_each(|x| x.x += dx);
                if k == 1 {
                    queries.reset();
                }
                let before = c.fluid.layout.ghosts.clone();
                // the stage's two halves (the walls made, then installed in the fluid) as the
                // CPU backend runs them, the level sets' questions and the layout's parts timed
                let t = Instant::now();
                let install = match c.method {
                    Method::Weak(o) => {
                        let walls = c.next_polygon_walls_with(o, &queries).expect("a shift of a fraction of a cell");
                        let t = Instant::now();
                        if let Some(walls) = walls {
                            c.install_polygon_walls(walls);
                        }
                        t.elapsed()
                    }
                    Method::Conserving(_) => {
                        let walls = c.next_level_set_walls_with(&queries).expect("a shift of a fraction of a cell");
                        let t = Instant::now();
                        c.install_level_set_walls(walls);
                        t.elapsed()
                    }
                };
                if k > 0 {
                    wall += t.elapsed().as_secs_f64();
                    installing += install.as_secs_f64();
                    rebuilt += u64::from(c.fluid.layout.ghosts != before);
                }
            }
            let asked = *queries.asked.lock().expect("not poisoned") / steps as f64;
            let n = c.fluid.layout.grid.n;
            let per = wall / steps as f64;
            let parts = *queries.parts.lock().expect("not poisoned");
            let mut host_parts: Vec<GeometryPart> =
                crate::fluid::LayoutPart::ALL.iter().zip(parts).map(|(p, t)| GeometryPart { part: p.name(), seconds_per_step: t / steps as f64 }).collect();
            let layout: f64 = host_parts.iter().map(|p| p.seconds_per_step).sum();
            let install = installing / steps as f64;
            // the particles to lattice units, the level sets binned or the surface polygons made
            host_parts.push(GeometryPart { part: "bodies", seconds_per_step: per - asked - layout - install });
            host_parts.push(GeometryPart { part: "install", seconds_per_step: install });
            GeometrySpeed {
                scene: name.to_string(),
                method: match c.method {
                    Method::Weak(_) => "weak",
                    Method::Conserving(_) => "momentum_conserving",
                },
                nodes: n[0] * n[1] * n[2],
                particles: c.solid.particles.len(),
                steps,
                seconds_per_step: per,
                ceiling_steps_per_s: 1.0 / per,
                device_answerable_seconds_per_step: asked,
                ceiling_with_device_questions_steps_per_s: 1.0 / (per - asked),
                walls_rebuilt: rebuilt,
                host_parts,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The geometry bench times real work: on the flap (both methods), every timed step's walls
    /// differ from the step before's; method 2's level-set questions are a part of the stage
    /// (method 1 asks none), and each ceiling is one over its time; the layout's parts, each
    /// timed, the bodies' walls and their install add up to the host's part.
    #[test]
    fn the_geometry_bench_rebuilds_the_walls_at_every_timed_step() {
        let rows = geometry_speed(&["wall_flap", "wall_flap_conserving"], 3);
        assert_eq!(rows.iter().map(|r| r.method).collect::<Vec<_>>(), ["weak", "momentum_conserving"]);
        for r in &rows {
            assert_eq!(r.walls_rebuilt, 3, "{}", r.scene);
            assert!(r.seconds_per_step > 0.0 && r.seconds_per_step.is_finite(), "{r:?}");
            assert!((r.ceiling_steps_per_s * r.seconds_per_step - 1.0).abs() < 1e-12);
            let host = r.seconds_per_step - r.device_answerable_seconds_per_step;
            assert!((r.ceiling_with_device_questions_steps_per_s * host - 1.0).abs() < 1e-9);
        }
        for r in &rows {
            // the layout's parts and the rest add up to the host's part; every part ran
            let host = r.seconds_per_step - r.device_answerable_seconds_per_step;
            let names: Vec<&str> = r.host_parts.iter().map(|p| p.part).collect();
            let mut expected: Vec<&str> = crate::fluid::LayoutPart::ALL.iter().map(|p| p.name()).collect();
            expected.extend(["bodies", "install"]);
            assert_eq!(names, expected, "{}", r.scene);
            let sum: f64 = r.host_parts.iter().map(|p| p.seconds_per_step).sum();
            assert!((sum - host).abs() <= 1e-9 * host.max(1.0), "{}: parts {sum} against the host's {host}", r.scene);
            assert!(r.host_parts.iter().all(|p| p.seconds_per_step >= -1e-9), "{r:?}");
            let layout: f64 = r.host_parts[..crate::fluid::LayoutPart::ALL.len()].iter().map(|p| p.seconds_per_step).sum();
            assert!(layout > 0.0 && layout <= host, "{}: layout {layout} of {host}", r.scene);
            for part in ["owners", "images", "thin_taps", "bodies", "install"] {
                assert!(r.host_parts.iter().any(|p| p.part == part && p.seconds_per_step > 0.0), "{}: {part}: {r:?}", r.scene);
            }
        }
        assert_eq!(rows[0].device_answerable_seconds_per_step, 0.0);
        assert!(rows[1].device_answerable_seconds_per_step > 0.0 && rows[1].device_answerable_seconds_per_step < rows[1].seconds_per_step, "{:?}", rows[1]);
    }
}
