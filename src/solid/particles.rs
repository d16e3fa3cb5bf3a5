//! The particle state of the MPS solid (seed 000 §2.2): positions, velocities, a quaternion
//! and an angular velocity per particle (§2.2.3–2.2.4), mass, volume, layer, body and clamp
//! flags. Units: lengths, masses and times of the scene's unit system.

use glam::{DQuat, DVec3};

/// Structure of arrays, one entry per particle.
#[derive(Clone, Debug, Default)]
pub struct Particles {
    /// 2 (plane strain in the x–y plane, z = 0) or 3.
    pub dim: usize,
    /// Particle spacing l₀ of the sampling.
    pub spacing: f64,
    /// Initial (reference) positions X.
    pub reference: Vec<DVec3>,
    /// Current positions x.
    pub position: Vec<DVec3>,
    /// Velocities v.
    pub velocity: Vec<DVec3>,
    /// Rotation of each particle as a unit quaternion, seed (2.39).
    pub rotation: Vec<DQuat>,
    /// Angular velocity ω (explicit integration only; the implicit method derives it).
    pub spin: Vec<DVec3>,
    /// Mass m = ρ V.
    pub mass: Vec<f64>,
    /// Volume V = l₀^d (per unit depth in 2D).
    pub volume: Vec<f64>,
    /// Moment of inertia I = m l₀² / 6, seed (2.48).
    pub inertia: Vec<f64>,
    /// Index into the scene's material list.
    pub material: Vec<u16>,
    /// Body index (contact acts between different bodies).
    pub body: Vec<u16>,
    /// Clamped particles keep their reference position and rotation.
    pub fixed: Vec<bool>,
    /// Extra (added) mass per particle, used by the implicit method (seed 2.129).
    pub added_mass: Vec<f64>,
    /// Constant external force per particle (loads), force units.
    pub load: Vec<DVec3>,
}

impl Particles {
    pub fn new(dim: usize, spacing: f64) -> Self {
        Self { dim, spacing, ..Default::default() }
    }

    pub fn len(&self) -> usize {
        self.position.len()
    }

    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Appends one particle at rest at `x` with density `rho`.
    pub fn push(&mut self, x: DVec3, rho: f64, material: u16, body: u16, fixed: bool) {
        let v = self.spacing.powi(self.dim as i32);
        let m = rho * v;
        self.reference.push(x);
        self.position.push(x);
        self.velocity.push(DVec3::ZERO);
        self.rotation.push(DQuat::IDENTITY);
        self.spin.push(DVec3::ZERO);
        self.mass.push(m);
        self.volume.push(v);
        self.inertia.push(m * self.spacing * self.spacing / 6.0);
        self.material.push(material);
        self.body.push(body);
        self.fixed.push(fixed);
        self.added_mass.push(0.0);
        self.load.push(DVec3::ZERO);
    }

    /// Linear momentum Σ m v.
    pub fn linear_momentum(&self) -> DVec3 {
        (0..self.len()).map(|i| self.mass[i] * self.velocity[i]).sum()
    }

    /// Angular momentum about the origin: orbital Σ m x × v plus spin Σ I ω.
    pub fn angular_momentum(&self) -> DVec3 {
        (0..self.len()).map(|i| self.mass[i] * self.position[i].cross(self.velocity[i]) + self.inertia[i] * self.spin[i]).sum()
    }

    /// Kinetic energy of translation and rotation.
    pub fn kinetic_energy(&self) -> f64 {
        self.kinetic_energy_of(|_| true)
    }

    /// Kinetic energy of translation and rotation of the particles `i` for which `of(i)` holds.
    pub fn kinetic_energy_of(&self, of: impl Fn(usize) -> bool) -> f64 {
        (0..self.len())
            .filter(|&i| of(i))
            .map(|i| 0.5 * self.mass[i] * self.velocity[i].length_squared() + 0.5 * self.inertia[i] * self.spin[i].length_squared())
            .sum()
    }
}

/// Lattice sample of the axis-aligned box [min, max): particle centres at min + (k + ½) l₀
/// (in 2D the z coordinate is 0). Returns the centres in x-fastest order.
pub fn sample_box(dim: usize, min: DVec3, max: DVec3, spacing: f64) -> Vec<DVec3> {
    let n = |a: usize| (((max[a] - min[a]) / spacing) + 1e-9).floor().max(0.0) as usize;
    let (nx, ny, nz) = (n(0), n(1), if dim == 3 { n(2) } else { 1 });
    let mut out = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let z = if dim == 3 { min.z + (k as f64 + 0.5) * spacing } else { 0.0 };
                out.push(DVec3::new(min.x + (i as f64 + 0.5) * spacing, min.y + (j as f64 + 0.5) * spacing, z));
            }
        }
    }
    out
}

/// Lattice sample of the disc (2D) or sphere (3D) of radius `radius` around `centre`: the
/// centres `centre + (k + ½) l₀` of the lattice aligned with the centre (a lattice point never
/// sits on the centre; the body is symmetric about it) that lie inside. x-fastest order.
pub fn sample_ball(dim: usize, centre: DVec3, radius: f64, spacing: f64) -> Vec<DVec3> {
    let half = (radius / spacing).ceil() as i64;
    let mut out = Vec::new();
    let zr = if dim == 3 { -half..half } else { 0..1 };
    for k in zr {
        for j in -half..half {
            for i in -half..half {
                let z = if dim == 3 { (k as f64 + 0.5) * spacing } else { 0.0 };
                let d = DVec3::new((i as f64 + 0.5) * spacing, (j as f64 + 0.5) * spacing, z);
                if d.length() < radius {
                    out.push(centre + d);
                }
            }
        }
    }
    out
}
