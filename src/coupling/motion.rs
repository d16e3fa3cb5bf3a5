//! Bodies whose motion is prescribed (rigid kinematics imposed on every particle): a body
//! towed at constant velocity, turning at constant angular velocity, or oscillating
//! harmonically. The air still acts on them (the force is reported), but it does not move them.
//! Physical units (lengths of the scene, seconds, radians).

use crate::solid::Particles;
use glam::{DQuat, DVec3};

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Motion {
    /// x(t) = X + v t.
    Translation {
        #[serde(deserialize_with = "vector")]
        velocity: [f64; 3],
    },
    /// x(t) = c + R(ω t)(X − c), about the z axis (2D) through `centre`.
    Rotation {
        #[serde(deserialize_with = "vector")]
        centre: [f64; 3],
        angular_velocity: f64,
    },
    /// x(t) = X + a sin(2π f t).
    Harmonic {
        #[serde(deserialize_with = "vector")]
        amplitude: [f64; 3],
        frequency: f64,
    },
}

/// A vector of 2 (z = 0) or 3 components.
fn vector<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v: Vec<f64> = serde::Deserialize::deserialize(d)?;
    match v.len() {
        2 => Ok([v[0], v[1], 0.0]),
        3 => Ok([v[0], v[1], v[2]]),
        n => Err(serde::de::Error::custom(format!("expected 2 or 3 components, got {n}"))),
    }
}

impl Motion {
    /// Sets position, velocity, rotation and spin of every particle of `body` at time `t`.
    pub fn apply(&self, p: &mut Particles, body: u16, t: f64) {
        for i in 0..p.len() {
            if p.body[i] != body {
                continue;
            }
            let x0 = p.reference[i];
            let (x, v, q, w) = match self {
                Motion::Translation { velocity } => {
                    let v = DVec3::from_array(*velocity);
                    (x0 + t * v, v, DQuat::IDENTITY, DVec3::ZERO)
                }
                Motion::Rotation { centre, angular_velocity } => {
                    let c = DVec3::from_array(*centre);
                    let q = DQuat::from_rotation_z(angular_velocity * t);
                    let d = q * (x0 - c);
                    let w = DVec3::new(0.0, 0.0, *angular_velocity);
                    (c + d, w.cross(d), q, w)
                }
                Motion::Harmonic { amplitude, frequency } => {
                    let a = DVec3::from_array(*amplitude);
                    let phase = std::f64::consts::TAU * frequency * t;
                    (x0 + a * phase.sin(), a * (std::f64::consts::TAU * frequency * phase.cos()), DQuat::IDENTITY, DVec3::ZERO)
                }
            };
            p.position[i] = x;
            p.velocity[i] = v;
            p.rotation[i] = q;
            p.spin[i] = w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prescribed_velocities_are_the_time_derivatives_of_the_positions() {
        let mut p = Particles::new(2, 0.1);
        p.push(DVec3::new(1.0, 0.5, 0.0), 1.0, 0, 0, false);
        p.push(DVec3::new(0.2, 0.4, 0.0), 1.0, 0, 1, false);
        let motions = [
            Motion::Translation { velocity: [0.3, -0.1, 0.0] },
            Motion::Rotation { centre: [0.5, 0.5, 0.0], angular_velocity: 2.5 },
            Motion::Harmonic { amplitude: [0.0, 0.05, 0.0], frequency: 3.0 },
        ];
        for m in &motions {
            let (t, h) = (0.37, 1e-6);
            let mut a = p.clone();
            let mut b = p.clone();
            m.apply(&mut a, 0, t - h);
            m.apply(&mut b, 0, t + h);
            m.apply(&mut p, 0, t);
            let fd = (b.position[0] - a.position[0]) / (2.0 * h);
            assert!((fd - p.velocity[0]).length() < 1e-6, "{m:?}: {fd} vs {}", p.velocity[0]);
            assert_eq!(p.position[1], p.reference[1], "other bodies are untouched");
        }
    }
}
