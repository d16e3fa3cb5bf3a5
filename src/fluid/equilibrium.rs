//! Local equilibrium (seed 000 eq. 2.78), macroscopic moments (2.79–2.81) and the diatomic
//! extension (2.96–2.104), in lattice units (lattice speed c = 1, cell size Δx = 1).
//!
//! Notation: `θ = p/ρ` (velocity², the gas "RT"); `T = θ/c²` selects the weights. The
//! translational internal energy is `Dθ/2`; a diatomic gas carries `ζθ/2` more in the second
//! distribution `G_i` (ζ = 5 − D rotational degrees of freedom so that γ = 1.4 in 2D and 3D).

use super::layout::HaloReach;
use super::velocity_set::VelocitySet;
use serde::{Deserialize, Serialize};

/// Thermodynamic model of the gas.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GasModel {
    /// Only translational energy: γ = (D + 2)/D (2 in 2D, 5/3 in 3D).
    Monatomic,
    /// Rotational energy carried by G_i = f_i E_i (2.96–2.99): γ = 1.4.
    Diatomic,
}

impl GasModel {
    /// Extra (rotational) degrees of freedom ζ for a D-dimensional lattice.
    pub fn extra_dof(self, dim: usize) -> f64 {
        match self {
            GasModel::Monatomic => 0.0,
            GasModel::Diatomic => 5.0 - dim as f64,
        }
    }

    /// Ratio of specific heats γ = (D + ζ + 2)/(D + ζ).
    pub fn gamma(self, dim: usize) -> f64 {
        let n = dim as f64 + self.extra_dof(dim);
        (n + 2.0) / n
    }

    /// Number of distributions per velocity: f, plus G for the diatomic gas.
    pub fn distributions(self) -> usize {
        match self {
            GasModel::Monatomic => 1,
            GasModel::Diatomic => 2,
        }
    }
}

/// Macroscopic state at one node: density ρ, velocity u (c units), temperature θ = p/ρ (c²).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Macro {
    pub rho: f64,
    pub u: [f64; 3],
    pub theta: f64,
}

impl Macro {
    /// Pressure p = ρθ (2.100 with e the translational+rotational internal energy).
    pub fn pressure(&self) -> f64 {
        self.rho * self.theta
    }
    pub fn speed2(&self) -> f64 {
        self.u[0] * self.u[0] + self.u[1] * self.u[1] + self.u[2] * self.u[2]
    }
}

/// Number of stored macroscopic fields per node: ρ, u_x, u_y, u_z, θ.
pub const MACRO_FIELDS: usize = 5;

/// Precomputed per-set data for the equilibrium and the moments.
#[derive(Clone, Debug)]
pub struct Equilibrium {
    pub set: VelocitySet,
    pub gas: GasModel,
    /// c_i as f64.
    pub cf: Vec<[f64; 3]>,
    /// |c_i|²/2.
    pub half_c2: Vec<f64>,
    /// (D + ζ)/2: internal energy per unit θ.
    pub energy_dof_half: f64,
    /// ζ/2: rotational energy per unit θ (E of 2.98 divided by θ).
    pub rot_half: f64,
    /// Per axis, [`Self::mirror_permutation`] (built once: the slip faces use it every stage).
    mirror: [Vec<usize>; 3],
    /// Per [`HaloReach::index`], [`Self::values_read_at`] (built once: the periodic fill uses
    /// it every stage).
    halo_reads: Vec<Vec<usize>>,
}

impl Equilibrium {
    pub fn new(set: VelocitySet, gas: GasModel) -> Self {
        let cf: Vec<[f64; 3]> = set.c.iter().map(|v| [v[0] as f64, v[1] as f64, v[2] as f64]).collect();
        let half_c2 = cf.iter().map(|v| 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])).collect();
        let zeta = gas.extra_dof(set.dim);
        let q = set.c.len();
        let nv = q * gas.distributions();
        let mirror = std::array::from_fn(|axis| (0..nv).map(|v| (v / q) * q + set.mirror(axis, v % q)).collect());
        let mut halo_reads = vec![Vec::new(); HaloReach::AXIS_REACHES];
        for axis in 0..3 {
            for depth in [-2i8, -1, 1, 2] {
                let reach = HaloReach::Axis { axis, depth };
                halo_reads[reach.index().expect("an axis reach")] = (0..nv).filter(|&v| reach.read_by(set.c[v % q])).collect();
            }
        }
        Equilibrium { energy_dof_half: 0.5 * (set.dim as f64 + zeta), rot_half: 0.5 * zeta, set, gas, cf, half_c2, mirror, halo_reads }
    }

    /// The values of a node (f_i, then the diatomic G_i) whose advection stencil reads a halo
    /// node of `reach` ([`HaloReach::read_by`]); none for an unread one.
    pub fn values_read_at(&self, reach: HaloReach) -> &[usize] {
        reach.index().map_or(&[], |k| &self.halo_reads[k])
    }

    pub fn q(&self) -> usize {
        self.cf.len()
    }

    /// Values per node: Q for f, 2Q with the diatomic G.
    pub fn values_per_node(&self) -> usize {
        self.q() * self.gas.distributions()
    }

    /// For each value index of a node (f_i, then the diatomic G_i), the index of the value that
    /// a node mirrored across a plane normal to `axis` holds there.
    pub fn mirror_permutation(&self, axis: usize) -> &[usize] {
        &self.mirror[axis]
    }

    /// Equilibrium (2.78) with B = −1/(2θ):
    /// f⁰_i = F_i(θ) ρ [1 + ξ/θ + ξ²/(2θ²) − u²/(2θ) − ξu²/(2θ²) + ξ³/(6θ³)], ξ = c_i·u.
    /// For the diatomic gas, G⁰_i = f⁰_i E with E = ζθ/2 (2.97–2.98) is written after the f's.
    /// `shell_w` is scratch of length ≥ number of shells.
    #[inline]
    pub fn feq_into(&self, m: &Macro, shell_w: &mut [f64], out: &mut [f64]) {
        let q = self.q();
        let th = m.theta;
        self.set.shell_weights_into(th, shell_w);
        let inv = 1.0 / th;
        let u2 = m.speed2();
        let base = 1.0 - 0.5 * u2 * inv;
        for i in 0..q {
            let c = &self.cf[i];
            let xi = (c[0] * m.u[0] + c[1] * m.u[1] + c[2] * m.u[2]) * inv;
            // 1 + ξ' + ξ'²/2 − u²/(2θ) − ξ' u²/(2θ) + ξ'³/6, with ξ' = ξ/θ
            let poly = base + xi * (1.0 - 0.5 * u2 * inv + xi * (0.5 + xi * (1.0 / 6.0)));
            out[i] = shell_w[self.set.shell_of[i]] * m.rho * poly;
        }
        if self.gas == GasModel::Diatomic {
            let e = self.rot_half * th;
            for i in 0..q {
                out[q + i] = out[i] * e;
            }
        }
    }

    /// Macroscopic moments (2.79–2.81) of one node's populations `f` (length values_per_node):
    /// ρ = Σf, ρu = Σ f c, and θ from the total energy
    /// ρ(D+ζ)θ/2 + ρu²/2 = Σ f c²/2 + Σ G.
    #[inline]
    pub fn moments(&self, f: &[f64]) -> Macro {
        let q = self.q();
        let (mut rho, mut jx, mut jy, mut jz, mut en) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..q {
            let fi = f[i];
            let c = &self.cf[i];
            rho += fi;
            jx += fi * c[0];
            jy += fi * c[1];
            jz += fi * c[2];
            en += fi * self.half_c2[i];
        }
        if self.gas == GasModel::Diatomic {
            for i in 0..q {
                en += f[q + i];
            }
        }
        let inv = 1.0 / rho;
        let u = [jx * inv, jy * inv, jz * inv];
        let u2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
        let theta = (en * inv - 0.5 * u2) / self.energy_dof_half;
        Macro { rho, u, theta }
    }

    /// Ratio of specific heats of this model.
    pub fn gamma(&self) -> f64 {
        self.gas.gamma(self.set.dim)
    }

    /// Isentropic speed of sound c_s = √(γθ) (2.104), in units of c.
    pub fn sound_speed(&self, theta: f64) -> f64 {
        (self.gamma() * theta).sqrt()
    }

    /// Dynamic viscosity μ = ρθ(τ − A) (2.101), lattice units.
    pub fn dynamic_viscosity(&self, m: &Macro, tau: f64, a: f64) -> f64 {
        m.rho * m.theta * (tau - a)
    }

    /// Kinematic viscosity ν = θ(τ − A).
    pub fn kinematic_viscosity(theta: f64, tau: f64, a: f64) -> f64 {
        theta * (tau - a)
    }
}
