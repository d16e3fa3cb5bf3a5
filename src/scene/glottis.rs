//! The glottis of a coupled scene with two vocal folds (seed 000 §3.4): the glottal readouts'
//! geometry (which bodies are the left and right fold, the mid-line, the margins), the
//! body–cover cases (Titze's Young's moduli set on the fold layers) and the lung pressure.

use super::coupled::CoupledScene;
use super::fold::{FoldBodySpec, FoldSide};
use crate::coupling::CoupledSolver;
use crate::coupling::glottis::Glottis;

impl CoupledScene {
    /// The indices of the left and the right fold body and the right fold's spec, when the
    /// solid has exactly one left and one right fold about the same mid-line.
    fn fold_pair(&self) -> Option<(usize, usize, &FoldBodySpec)> {
        let folds: Vec<(usize, &FoldBodySpec)> = self.solid.file.solid.bodies.iter().enumerate().filter_map(|(k, b)| b.fold.as_ref().map(|f| (k, f))).collect();
        let [(a, fa), (b, fb)] = folds[..] else { return None };
        let (l, (r, fr)) = match (fa.side, fb.side) {
            (FoldSide::Left, FoldSide::Right) => (a, (b, fb)),
            (FoldSide::Right, FoldSide::Left) => (b, (a, fa)),
            _ => return None,
        };
        (fa.origin[0] == fb.origin[0]).then_some((l, r, fr))
    }

    /// Whether the scene is a glottis (one left and one right fold about the same mid-line):
    /// its runs write the glottal flow and the voice measures.
    pub fn has_glottis(&self) -> bool {
        self.fold_pair().is_some()
    }

    /// The glottis when the solid has exactly one left and one right fold about the same
    /// mid-line: glottal gap, flow and margins are then sampled during a run.
    pub fn glottis(&self, c: &CoupledSolver) -> Option<Glottis> {
        let (l, r, fr) = self.fold_pair()?;
        let sec = &fr.section;
        let m = 0.5 * sec.gap;
        // the margins of the medial surface (in 3D at mid-length)
        let (lower, upper) = if self.fluid.grid.dim == 3 {
            (fr.to_scene_3d([m, 0.5 * sec.length, sec.height - sec.t2]), fr.to_scene_3d([m, 0.5 * sec.length, sec.height]))
        } else {
            (fr.to_scene([m, sec.height - sec.t2]), fr.to_scene([m, sec.height]))
        };
        Some(Glottis::new(c, l, r, fr.origin[0], sec.length, lower, upper))
    }

    /// Sets the folds' layers to a body–cover case: the fold bodies' `material` to in-plane
    /// Young's modulus `body`, their `cover_material` to `cover` (shear moduli scaled with them,
    /// Poisson ratios kept). Materials shared with non-fold bodies change for those too.
    pub fn set_fold_moduli(&mut self, cover: f64, body: f64) {
        let folds: Vec<(usize, usize)> = self.solid.file.solid.bodies.iter().filter_map(|b| b.fold.as_ref().map(|f| (b.material, f.cover_material))).collect();
        for (b, c) in folds {
            for (m, e) in [(b, body), (c, cover)] {
                let mat = &mut self.solid.materials[m];
                *mat = mat.scaled(e / mat.young[0]);
            }
        }
    }

    /// The lung pressure: the gauge pressure of the inlet on the tracheal face (y_min), if any.
    pub fn lung_pressure(&self) -> Option<f64> {
        match self.fluid.file.boundaries.y_min {
            crate::scene::schema::FaceSpec::PressureInlet { pressure, .. } => Some(pressure),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn glottis_text(name: &str) -> &'static str {
        crate::scene::builtin(name).unwrap()
    }

    #[test]
    fn the_glottis_scenes_carry_the_seed_folds_and_titze_cases() {
        use crate::solid::fold::{BodyCoverCase, FoldSection};
        for (name, case) in
            [("glottis_2d_a", BodyCoverCase::A), ("glottis_2d_b", BodyCoverCase::B), ("glottis_2d_c", BodyCoverCase::C), ("glottis_2d_d", BodyCoverCase::D)]
        {
            let sc = CoupledScene::parse(glottis_text(name)).unwrap();
            let s = &sc.solid.file.solid;
            // body = material 0, cover = material 1, in-plane E and ν = 0.97, fibre decoupled
            let (cover, body) = case.young();
            assert_eq!((s.materials.len(), sc.solid.materials[0].young[0], sc.solid.materials[1].young[0]), (2, body, cover), "{name}");
            for m in &sc.solid.materials {
                assert_eq!(m.poisson, [0.97, 0.0, 0.0], "{name}");
                assert!((m.shear[2] - m.young[0] / (2.0 * 1.97)).abs() < 1e-3 * m.shear[2], "{name}: G_xy = E/(2(1+ν))");
                assert_eq!((m.density, m.viscosity), (1.043, 5.0), "{name}");
            }
            for b in &s.bodies {
                let f = b.fold.as_ref().unwrap();
                assert_eq!((&f.section, f.cover_material, b.material), (&FoldSection::default(), 1, 0), "{name}");
            }
            assert_eq!(sc.lung_pressure(), Some(8000.0), "{name}");
            assert_eq!((sc.fluid.grid.n[0], sc.fluid.grid.n[1]), (124, 128), "{name}");
            // the coarse scene set to this case (as `validate --case glottis_2d` does) carries
            // the same layers
            let mut coarse = CoupledScene::parse(glottis_text("glottis_2d_coarse")).unwrap();
            coarse.set_fold_moduli(cover, body);
            for (a, b) in coarse.solid.materials.iter().zip(&sc.solid.materials) {
                for k in 0..3 {
                    assert!((a.young[k] / b.young[k] - 1.0).abs() < 1e-12 && (a.shear[k] / b.shear[k] - 1.0).abs() < 1e-3, "{name}: {a:?} vs {b:?}");
                }
                assert_eq!((a.poisson, a.density, a.viscosity), (b.poisson, b.density, b.viscosity));
            }
        }
    }

    /// A `pressure_outlet` on the vocal-tract face is the fixed-pressure condition at the gauge
    /// pressure given (0 by default: the atmosphere); the lung pressure is still the tracheal
    /// inlet's; an outlet pressure that leaves no absolute pressure is refused naming the field.
    #[test]
    fn a_pressure_outlet_holds_the_vocal_tract_side_at_its_pressure() {
        use crate::fluid::boundary::{Face, FaceCondition};
        let outlet = "y_max = { type = \"pressure_outlet\" }";
        let text = glottis_text("glottis_2d_coarse").replace("y_max = { type = \"outlet\" }", outlet);
        assert!(text.contains(outlet));
        let sc = CoupledScene::parse(&text).unwrap();
        assert_eq!(sc.lung_pressure(), Some(8000.0));
        let b = &sc.fluid.boundaries;
        let (FaceCondition::PressureInlet { rho: r_out, theta: t_out }, FaceCondition::PressureInlet { rho: r_in, theta: t_in }) =
            (b.face(Face::YMax), b.face(Face::YMin))
        else {
            panic!("{:?}", b.faces)
        };
        // p = ρθ in lattice units: the outlet at the reference pressure, the lungs above it
        let p0 = sc.fluid.units.gauge_pressure_to_lattice(0.0);
        assert!((r_out * t_out / p0 - 1.0).abs() < 1e-12, "{r_out} {t_out} {p0}");
        assert!(r_in * t_in > p0 && t_in == t_out);
        let bad = text.replace(outlet, "y_max = { type = \"pressure_outlet\", pressure = -2.0e9 }");
        let e = CoupledScene::parse(&bad).expect_err("refused").to_string();
        assert!(e.contains("boundaries.y_max.pressure") && e.contains("non-positive absolute pressure"), "{e}");
    }

    /// The air's power on the folds is booked with the right sign and units: from rest, the
    /// work it has done (∫ P dt over its three parts, every step, 0.38 ms) is the kinetic and
    /// elastic energy the folds hold — all of it with inviscid tissue (measured 0.9994: the
    /// force is held over the step and the power read with the velocity at its end, an O(Δt)
    /// booking, hence the bound of 0.5 %), less what the tissue's viscosity of 5 g/(cm·s) has
    /// dissipated with it (measured 0.827: the onset's fast motions are damped hard).
    #[test]
    fn the_airs_work_on_the_folds_is_the_energy_they_gain() {
        let held_over_work = |viscosity: f64| {
            let mut sc = CoupledScene::parse(glottis_text("glottis_2d_coarse")).unwrap();
            for m in sc.solid.materials.iter_mut() {
                m.viscosity = viscosity;
            }
            let mut c = sc.build().unwrap();
            let g = sc.glottis(&c).expect("a glottis");
            let dt = c.dt();
            let mut power = g.air_power(&c).iter().sum::<f64>();
            let mut work = 0.0;
            for _ in 0..1200 {
                c.step().unwrap();
                let p: f64 = g.air_power(&c).iter().sum();
                work += 0.5 * (power + p) * dt;
                power = p;
            }
            let mut solid = c.solid.clone();
            let e = solid.energies();
            assert!((g.kinetic_energy(&c) / (e.kinetic * g.length) - 1.0).abs() < 1e-12);
            // the lung pressure has pushed the folds apart and up
            assert!(work > 10.0, "work {work} erg");
            (e.kinetic + e.elastic) * g.length / work
        };
        let inviscid = held_over_work(0.0);
        assert!((inviscid - 1.0).abs() < 5e-3, "inviscid folds hold {inviscid} of the air's work");
        let viscous = held_over_work(5.0);
        assert!(viscous > 0.5 && viscous < 0.95, "viscous folds hold {viscous} of the air's work");
    }

    /// The CPU-sized 3D glottis (seed §3.4.3) builds the two extruded folds of the seed's
    /// three layers — cover 1/9, the thyroarytenoid layer outside the quarter ellipse, the body —
    /// mirrored about the mid-line, the glottis widening by 0.06 cm from the anterior to the
    /// posterior end, the anterior face clamped and the posterior face clamped but its cover;
    /// coupled by method 2 it takes steps with a finite state.
    #[test]
    fn the_3d_glottis_builds_three_layer_folds_and_runs() {
        let sc = CoupledScene::parse(glottis_text("glottis_3d_coarse")).unwrap();
        let mut c = sc.build().unwrap();
        let p = &c.solid.particles;
        let section = crate::solid::fold::FoldSection::default();
        let l0 = p.spacing;
        // each fold holds its volume in particles of l₀³ (within the lattice sampling's 2 %)
        let expected = 2.0 * section.area() * section.length / l0.powi(3);
        assert!((p.len() as f64 / expected - 1.0).abs() < 0.02, "{} particles, expected {expected:.0}", p.len());
        let share = |m: u16| p.material.iter().filter(|x| **x == m).count() as f64 / p.len() as f64;
        let (cover, ta) = (share(1), share(2));
        assert!((cover - 1.0 / 9.0).abs() < 0.015, "cover fraction {cover}");
        // outside a quarter ellipse of semi-axes width × length: 1 − π/4 of the section's
        // bounding box, less the cover — a sizeable layer
        assert!(ta > 0.05 && ta < 0.3, "thyroarytenoid fraction {ta}");
        let x0 = 1.4875 / 2.0;
        let (l, r): (Vec<usize>, Vec<usize>) = (0..p.len()).partition(|&i| p.body[i] == 0);
        assert_eq!(l.len(), r.len());
        assert!(l.iter().all(|&i| p.reference[i].x < x0) && r.iter().all(|&i| p.reference[i].x > x0));
        // the medial surface of the right fold: G/2 from the mid-line at the anterior end,
        // G/2 + 0.03 cm at the posterior end
        let medial = |z: f64| r.iter().filter(|&&i| (p.reference[i].z - z).abs() < 0.5 * l0).map(|&i| p.reference[i].x - x0).fold(f64::INFINITY, f64::min);
        let (front, back) = (medial(0.5 * l0), medial(section.length - 0.5 * l0));
        assert!((back - front - 0.06 * (1.0 - l0 / section.length) / 2.0).abs() < 0.6 * l0, "medial surface at {front} (anterior), {back} (posterior)");
        // anterior face clamped, posterior cover free
        let at = |z: f64, m: u16| r.iter().filter(|&&i| (p.reference[i].z - z).abs() < 0.5 * l0 && p.material[i] == m).map(|&i| p.fixed[i]).collect::<Vec<_>>();
        assert!(at(0.5 * l0, 1).iter().all(|f| *f), "the anterior face is clamped");
        // (but where the cover meets the clamped lateral strip)
        let back_cover = at(section.length - 0.5 * l0, 1);
        let free = back_cover.iter().filter(|f| !**f).count() as f64 / back_cover.len() as f64;
        assert!(free > 0.8, "the posterior cover is free: {free} of it");
        assert!(at(section.length - 0.5 * l0, 0).iter().all(|f| *f), "the posterior body is clamped");
        // the lattice sees mirror-image folds: every node's kind equals its mirror's about x₀
        // (a sheared sample's surface once broke this: 90 nodes, see BodySurface::build)
        let (g, kind) = (&c.fluid.layout.grid, &c.fluid.layout.kind);
        let n = g.n;
        let asymmetric = (0..n[2] as i64)
            .flat_map(|z| (0..n[1] as i64).flat_map(move |y| (0..n[0] as i64).map(move |x| [x, y, z])))
            .filter(|x| kind[g.index(*x)] != kind[g.index([n[0] as i64 - 1 - x[0], x[1], x[2]])])
            .count();
        assert_eq!(asymmetric, 0, "nodes whose mirror image has another kind");
        // each fold seals against its side wall over the whole length: no air beside the
        // folds, around the glottis, at the lattice columns next to the side walls over the
        // folds' height (y = 0.4 … 0.875 cm: nodes 9 … 19; as first built, with the lateral
        // faces 0.5–1.2 cells inside the walls, these columns were fluid)
        let leaks: Vec<[i64; 3]> = (0..n[2] as i64)
            .flat_map(|z| (9..=19).flat_map(move |y| [[0, y, z], [n[0] as i64 - 1, y, z]]))
            .filter(|x| kind[g.index(*x)] == crate::fluid::layout::NodeKind::Fluid)
            .collect();
        assert!(leaks.is_empty(), "fluid nodes between a fold and its side wall: {} (first {:?})", leaks.len(), leaks.first());
        c.run(3).expect("the 3D glottis steps");
        assert!(c.solid.non_finite().is_none() && c.fluid.totals().mass.is_finite());
        // the 3D glottal readouts: the narrowest section between the folds' walls as the air
        // sees them lies within the folds' height, and its area is the opening's, (G + 0.06/2)·L
        // (G at the anterior end widening linearly by 0.06 cm), within 0.4 cells per line
        // (each wall within 0.2 cells of the face its particles sample:
        // coupling::glottis `the_narrowest_3d_section_of_two_slab_folds`)
        let glottis = sc.glottis(&c).expect("two folds");
        let s = glottis.sample(&c);
        let (y0, h) = (0.4, section.height);
        assert!(s.narrowest_y > y0 && s.narrowest_y < y0 + h + 0.05, "narrowest section at y = {}", s.narrowest_y);
        let opening = (section.gap + 0.03) * section.length;
        let dx = c.units.dx;
        assert!((s.area - opening).abs() < 0.4 * dx * section.length, "area {} cm², the opening {opening} cm²", s.area);
        assert!(s.flow.is_finite() && s.gap > 0.0);
        eprintln!("3D glottis after 3 steps: area {:.3e} cm², gap {:.3e} cm at y = {:.3} cm, flow {:.3e} cm³/s", s.area, s.gap, s.narrowest_y, s.flow);
    }

    #[test]
    fn the_glottis_builds_two_folds_with_their_layers_clamps_and_gap() {
        let sc = CoupledScene::parse(glottis_text("glottis_2d_coarse")).unwrap();
        let c = sc.build().unwrap();
        let p = &c.solid.particles;
        let section = crate::solid::fold::FoldSection::default();
        let l0 = p.spacing;
        // each fold holds its section's area in particles of l₀² (within the lattice sampling's 2 %)
        let expected = 2.0 * section.area() / (l0 * l0);
        assert!((p.len() as f64 / expected - 1.0).abs() < 0.02, "{} particles, expected {expected:.0}", p.len());
        // the cover (material 1) is 1/9 of each fold
        let cover = p.material.iter().filter(|m| **m == 1).count() as f64 / p.len() as f64;
        assert!((cover - 1.0 / 9.0).abs() < 0.01, "cover fraction {cover}");
        // the clamped particles are those within fixed_depth = 0.025 cm of a lateral face (x₀ ± (G/2 + width))
        let x0 = 1.513671875 / 2.0;
        let lateral = 0.5 * section.gap + section.width;
        for i in 0..p.len() {
            let depth = lateral - (p.reference[i].x - x0).abs();
            assert_eq!(p.fixed[i], depth < 0.025, "particle {i} at depth {depth}");
        }
        assert!(p.fixed.iter().any(|f| *f));
        // the left fold mirrors the right one
        let (l, r): (Vec<usize>, Vec<usize>) = (0..p.len()).partition(|&i| p.body[i] == 0);
        assert_eq!(l.len(), r.len());
        assert!(l.iter().all(|&i| p.reference[i].x < x0) && r.iter().all(|&i| p.reference[i].x > x0));
        // the glottis: the seed's initial gap G = 0.021 cm at the medial surface, no flow at rest,
        // margins at rest
        let g = sc.glottis(&c).expect("two folds make a glottis");
        let s = g.sample(&c);
        assert!((s.gap - section.gap).abs() < 1e-9, "gap {}", s.gap);
        assert!((s.area - section.gap * section.length).abs() < 1e-9, "area {}", s.area);
        assert!(s.narrowest_y > 0.45 + section.height - section.t2 - 1e-9 && s.narrowest_y < 0.45 + section.height + 1e-9, "narrowest at {}", s.narrowest_y);
        assert_eq!((s.flow, s.lower_margin, s.upper_margin), (0.0, 0.0, 0.0));
        // the lower margin sits at the foot of the vertical medial surface, the upper one at its top
        for (k, want) in [(g.lower_margin[1], 0.45 + section.height - section.t2), (g.upper_margin[1], 0.45 + section.height)] {
            assert!((p.reference[k].y - want).abs() < 1.5 * l0, "margin particle at {:?}, expected y ≈ {want}", p.reference[k]);
        }
    }

    #[test]
    fn the_glottal_flow_is_the_volume_flux_through_the_narrowest_section() {
        // Air moving up at a uniform 1000 cm/s with density ρ₀ (1.02 ρ₀): the probe reads
        // u × (the fluid nodes' width between the folds) × the fold length (× 1.02).
        let text = glottis_text("glottis_2d_a").replace("spacing = 0.006103515625", "spacing = 0.0042");
        let sc = CoupledScene::parse(&text).unwrap();
        let mut c = sc.build().unwrap();
        let g = sc.glottis(&c).unwrap();
        let u = c.units;
        let before = g.sample(&c);
        let row = u.position_to_lattice(before.narrowest_y).round() as i64;
        let grid = c.fluid.layout.grid.clone();
        let open: usize = (0..grid.n[0] as i64).filter(|&i| c.fluid.layout.kind[grid.index([i, row, 0])] == crate::fluid::layout::NodeKind::Fluid).count();
        assert!(open >= 1, "the 0.021 cm gap holds {open} nodes of {} cm", u.dx);
        for rho in [1.0, 1.02] {
            let theta = u.theta0;
            let uy = u.velocity_to_lattice(1000.0);
            c.fluid.initialise(|_| crate::fluid::Macro { rho, u: [0.0, uy, 0.0], theta });
            let s = g.sample(&c);
            let want = rho * 1000.0 * open as f64 * u.dx * 1.4;
            assert!((s.flow - want).abs() < 1e-9 * want, "flow {} vs {want}", s.flow);
        }
    }

    #[test]
    fn bad_fold_bodies_are_refused_with_the_field() {
        let base = glottis_text("glottis_2d_coarse");
        let left = "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, fixed_depth = 0.025 }, material = 0 }";
        assert!(base.contains(left));
        let cases: [(&str, &str); 8] = [
            // settings of the 3D fold in a 2D scene
            ("{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, opening = 0.06 }, material = 0 }", "solid.bodies[0].fold.opening"),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, ta_material = 1 }, material = 0 }",
                "solid.bodies[0].fold.ta_material",
            ),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, fixed_depth = 0.025 }, material = 0, radius = 0.1 }",
                "solid.bodies[0].fold",
            ),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 5, fixed_depth = 0.025 }, material = 0 }",
                "solid.bodies[0].fold.cover_material",
            ),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, fixed_depth = 0.025, section = { t2 = 0.6 } }, material = 0 }",
                "solid.bodies[0].fold.section.t2",
            ),
            ("{ fold = { side = \"left\", origin = [0.7568359375], cover_material = 1, fixed_depth = 0.025 }, material = 0 }", "solid.bodies[0].fold.origin"),
            // the free part of the fold would reach past the domain's side wall
            ("{ fold = { side = \"left\", origin = [0.7, 0.45], cover_material = 1, fixed_depth = 0.025 }, material = 0 }", "solid.bodies[0]"),
            (
                "{ fold = { side = \"left\", origin = [0.7568359375, 0.45], cover_material = 1, fixed_depth = 0.9 }, material = 0 }",
                "solid.bodies[0].fold.fixed_depth",
            ),
        ];
        for (to, field) in cases {
            let e = CoupledScene::parse(&base.replacen(left, to, 1)).err().unwrap_or_else(|| panic!("{to} accepted"));
            assert_eq!(e.field, field, "{to}: {e}");
        }
        // the 3D fold: a missing thyroarytenoid material, an opening as wide as the fold
        let base3 = glottis_text("glottis_3d_coarse");
        for (from, to, field) in
            [("ta_material = 2", "ta_material = 3", "solid.bodies[0].fold.ta_material"), ("opening = 0.06", "opening = 0.9", "solid.bodies[0].fold.opening")]
        {
            assert!(base3.contains(from));
            let e = CoupledScene::parse(&base3.replacen(from, to, 1)).err().unwrap_or_else(|| panic!("{to} accepted"));
            assert_eq!(e.field, field, "{to}: {e}");
        }
        // a fold whose lateral face stops short of the side wall (air between them, around the
        // glottis): the 2D domain widened by two cells, which leaves the right fold's face
        // 0.025 cm inside its wall; the coarse 3D glottis as first built (38 cells across: its
        // faces 0.021–0.051 cm inside); a 3D fold shorter than the domain along z
        let wide = base.replace("size = [1.513671875, 1.5625]", "size = [1.5625, 1.5625]").replace("cells = [62, 64]", "cells = [64, 64]");
        assert_ne!(wide, base);
        let e = CoupledScene::parse(&wide).expect_err("a fold short of its wall accepted");
        assert_eq!(e.field, "solid.bodies[1].fold.origin", "{e}");
        assert!(e.reason.contains("0.0252") && e.reason.contains("around the glottis"), "{e}");
        let first = base3
            .replace("size = [1.4875, 1.4, 1.4]", "size = [1.6625, 1.4, 1.4]")
            .replace("cells = [34, 32, 32]", "cells = [38, 32, 32]")
            .replace("0.74375", "0.83125");
        assert_ne!(first, base3);
        let e = CoupledScene::parse(&first).expect_err("the first coarse 3D glottis accepted");
        assert_eq!(e.field, "solid.bodies[0].fold.origin", "{e}");
        let short = base3.replacen("opening = 0.06,", "opening = 0.06, section = { length = 1.2 },", 1);
        assert_ne!(short, base3);
        let e = CoupledScene::parse(&short).expect_err("a 3D fold shorter than the domain accepted");
        assert_eq!(e.field, "solid.bodies[0].fold.section.length", "{e}");
        // particles coarser than the cover layer (≈ 0.02 cm)
        let e = CoupledScene::parse(&base.replace("spacing = 0.01220703125", "spacing = 0.024")).err().unwrap();
        assert_eq!(e.field, "solid.spacing", "{e}");
        // the seed's cm defaults in an SI scene
        let e = CoupledScene::parse(&base.replace("units = \"cgs\"", "units = \"si\"")).err().unwrap();
        assert_eq!(e.field, "solid.bodies[0].fold.section", "{e}");
    }
}
