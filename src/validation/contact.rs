//! Contact validations (issue 4): two blocks driven into each other, and a block on a slope
//! below and above its friction angle (2D, plane strain).

use crate::solid::particles::sample_box;
use crate::solid::{ContactParams, Orthotropic, Particles, SolidOptions, SolidSolver, Wall};
use glam::DVec3;

fn material() -> Orthotropic {
    Orthotropic::isotropic(1.0e6, 0.3, 1.0, 0.0)
}

/// Contact springs scaled with the material: k = 20 E (per unit depth in 2D).
pub fn contact_params(static_friction: f64, dynamic_friction: f64) -> ContactParams {
    let e = material().young[0];
    ContactParams { normal_stiffness: 20.0 * e, tangential_stiffness: 10.0 * e, static_friction, dynamic_friction, damping: 0.0 }
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Collision {
    /// Deepest overlap over the run as a fraction of l₀.
    pub max_overlap: f64,
    /// Relative change of total linear momentum.
    pub momentum_change: f64,
    /// Centre-of-mass velocities of the two blocks at the end (x).
    pub final_velocities: [f64; 2],
}

/// Two 10×10 blocks approaching at ± `speed` (as a fraction of √(E/ρ)), for `time` s.
pub fn two_blocks(speed: f64, steps: u64) -> Collision {
    let l0 = 0.1;
    let m = material();
    let mut p = Particles::new(2, l0);
    for (b, x0) in [(0u16, 0.0), (1u16, 1.0 + 1.0 * l0)] {
        for x in sample_box(2, DVec3::new(x0, 0.0, 0.0), DVec3::new(x0 + 1.0, 1.0, 0.0), l0) {
            p.push(x, m.density, 0, b, false);
        }
    }
    let c = (m.young[0] / m.density).sqrt();
    for i in 0..p.len() {
        p.velocity[i] = DVec3::new(if p.body[i] == 0 { speed * c } else { -speed * c }, 0.0, 0.0);
    }
    let mut s = SolidSolver::new(p, vec![m], SolidOptions { contact: Some(contact_params(0.3, 0.2)), ..Default::default() }).expect("valid blocks");
    let p0 = s.particles.linear_momentum();
    let scale: f64 = (0..s.particles.len()).map(|i| s.particles.mass[i] * s.particles.velocity[i].length()).sum();
    let mut max_overlap: f64 = 0.0;
    for _ in 0..steps {
        s.step().expect("the colliding bodies stay finite");
        max_overlap = max_overlap.max(s.contacts().max_overlap);
    }
    let com_v = |b: u16| {
        let (mut mv, mut mm) = (0.0, 0.0);
        for i in 0..s.particles.len() {
            if s.particles.body[i] == b {
                mv += s.particles.mass[i] * s.particles.velocity[i].x;
                mm += s.particles.mass[i];
            }
        }
        mv / mm
    };
    Collision { max_overlap, momentum_change: (s.particles.linear_momentum() - p0).length() / scale, final_velocities: [com_v(0), com_v(1)] }
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Slope {
    pub angle_deg: f64,
    /// Mean down-slope displacement of the block after `time`, and its acceleration fitted as
    /// 2 Δx / t² over the second half (from the velocity change).
    pub displacement: f64,
    pub acceleration: f64,
    /// g (sin α − μ_d cos α) when sliding, 0 when sticking.
    pub expected_acceleration: f64,
    pub spacing: f64,
}

/// A 1×0.4 block (viscous, so that its elastic vibrations die out) first settles for
/// `settle` s on the wall y = 0 under vertical gravity, then gravity is tilted by `angle_deg`
/// (equivalent to a slope) for `time` s; μ_s = 0.5 (friction angle 26.6°), μ_d = 0.4.
pub fn block_on_slope(angle_deg: f64, settle: f64, time: f64) -> Slope {
    let l0 = 0.1;
    let mut m = material();
    m.viscosity = 20.0;
    let mut p = Particles::new(2, l0);
    for x in sample_box(2, DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.4, 0.0), l0) {
        p.push(x, m.density, 0, 0, false);
    }
    let g0 = 981.0;
    let a = angle_deg.to_radians();
    let gravity = DVec3::new(g0 * a.sin(), -g0 * a.cos(), 0.0);
    let mut cp = contact_params(0.5, 0.4);
    // critical-ish normal damping of one particle on its spring
    let mass = m.density * l0 * l0;
    cp.damping = (cp.normal_stiffness * mass).sqrt();
    let walls = vec![Wall { normal: DVec3::Y, offset: 0.0 }];
    let mut s =
        SolidSolver::new(p, vec![m], SolidOptions { contact: Some(cp), walls, gravity: DVec3::new(0.0, -g0, 0.0), ..Default::default() }).expect("valid slope");
    while s.time < settle {
        s.step().expect("the block settles on the slope");
    }
    s.options.gravity = gravity;
    s.time = 0.0;
    let com = |s: &SolidSolver| s.particles.position.iter().map(|x| x.x).sum::<f64>() / s.particles.len() as f64;
    let vel = |s: &SolidSolver| s.particles.velocity.iter().map(|v| v.x).sum::<f64>() / s.particles.len() as f64;
    let x0 = com(&s);
    let (mut t_half, mut v_half) = (0.0, 0.0);
    while s.time < time {
        s.step().expect("the block slides and stays finite");
        if t_half == 0.0 && s.time >= 0.5 * time {
            t_half = s.time;
            v_half = vel(&s);
        }
    }
    let acc = (vel(&s) - v_half) / (s.time - t_half);
    let sliding = a.tan() > 0.5;
    Slope {
        angle_deg,
        displacement: com(&s) - x0,
        acceleration: acc,
        expected_acceleration: if sliding { g0 * (a.sin() - 0.4 * a.cos()) } else { 0.0 },
        spacing: l0,
    }
}
