//! Plane-wave speeds of an orthotropic block along each axis (issue 4): a periodic box, long
//! along the propagation axis a, is given the standing wave u = A sin(k x_a) e_p; the mode
//! amplitude oscillates as cos(ωt), and c = ω/k is compared with √(C_aa/ρ) (p = a) or
//! √(G_ap/ρ) (p ≠ a) from the Christoffel equation along an axis of symmetry.

use crate::solid::material::axis_wave_speeds;
use crate::solid::particles::sample_box;
use crate::solid::{Orthotropic, Particles, SolidOptions, SolidSolver};
use glam::DVec3;

#[derive(Clone, Debug, serde::Serialize)]
pub struct WaveSpeed {
    pub axis: usize,
    pub polarisation: usize,
    pub measured: f64,
    pub theory: f64,
    pub relative_error: f64,
}

/// Measures the speed of the wave travelling along `axis` polarised along `pol`, in a
/// periodic box `long` particles long and `cross` particles across (3D).
pub fn wave_speed(mat: &Orthotropic, axis: usize, pol: usize, long: usize, cross: usize, spacing: f64) -> WaveSpeed {
    let mut n = [cross; 3];
    n[axis] = long;
    let size = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64) * spacing;
    let mut p = Particles::new(3, spacing);
    for x in sample_box(3, DVec3::ZERO, size, spacing) {
        p.push(x, mat.density, 0, 0, false);
    }
    let periods = [Some(size.x), Some(size.y), Some(size.z)];
    let mut s = SolidSolver::new(p, vec![mat.clone()], SolidOptions { periods, ..Default::default() }).expect("valid block");
    let k = 2.0 * std::f64::consts::PI / size[axis];
    let amp = 1e-4 * spacing;
    let modes: Vec<f64> = s.particles.reference.iter().map(|x| (k * x[axis]).sin()).collect();
    let norm: f64 = modes.iter().map(|m| m * m).sum();
    for (i, m) in modes.iter().enumerate() {
        s.particles.position[i][pol] += amp * m;
    }
    let amplitude =
        |s: &SolidSolver| (0..s.particles.len()).map(|i| (s.particles.position[i][pol] - s.particles.reference[i][pol]) * modes[i]).sum::<f64>() / norm;
    // zero crossings of cos(ωt): T/4 (down) and 3T/4 (up)
    let mut prev = amplitude(&s);
    let mut crossings = Vec::new();
    while crossings.len() < 2 && s.step_count < 1_000_000 {
        s.step().expect("the wave stays finite");
        let a = amplitude(&s);
        if (prev > 0.0) != (a > 0.0) {
            crossings.push(s.time - s.dt + prev / (prev - a) * s.dt);
        }
        prev = a;
    }
    let period = 2.0 * (crossings[1] - crossings[0]);
    let measured = size[axis] / period;
    let c = mat.stiffness("material").expect("valid material");
    let (l, t) = axis_wave_speeds(&c, mat.density, axis);
    let theory = if pol == axis { l } else { t.iter().find(|(b, _)| *b == pol).unwrap().1 };
    WaveSpeed { axis, polarisation: pol, measured, theory, relative_error: (measured - theory) / theory }
}
