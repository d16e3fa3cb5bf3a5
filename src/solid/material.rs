//! Orthotropic linear elasticity with Kelvin–Voigt viscosity (seed 000 §2.1, eqs. 2.1–2.15).
//!
//! Units: any consistent system (the scenes use cgs: dyn/cm², g/cm³, g/(cm·s), or SI).
//! Strains and stresses use Voigt order (xx, yy, zz, yz, zx, xy) with engineering shear
//! strains γ = 2ε, so that σ_V = C ε_V and the energy density is ½ ε_V · C ε_V.

use crate::error::SceneError;
use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

/// 6×6 stiffness in Voigt order with engineering shear strains.
pub type Voigt6 = [[f64; 6]; 6];

/// Elastic and viscous constants of one material layer.
///
/// Poisson ratios follow ν_ij = −ε_j/ε_i under uniaxial stress along i; the reciprocal ones
/// come from the symmetry ν_ij/E_i = ν_ji/E_j.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Orthotropic {
    /// Young's moduli E_x, E_y, E_z (pressure units).
    pub young: [f64; 3],
    /// Poisson ratios ν_xy, ν_yz, ν_zx.
    pub poisson: [f64; 3],
    /// Shear moduli G_yz, G_zx, G_xy (pressure units) — seed (2.9) μ.
    pub shear: [f64; 3],
    /// Density ρ (mass / volume).
    pub density: f64,
    /// Kelvin–Voigt viscosity η of (2.15) (pressure × time).
    #[serde(default)]
    pub viscosity: f64,
}

impl Orthotropic {
    /// Isotropic material from E and ν (G = E / (2(1+ν)), seed 2.10).
    pub fn isotropic(young: f64, poisson: f64, density: f64, viscosity: f64) -> Self {
        let g = young / (2.0 * (1.0 + poisson));
        Self { young: [young; 3], poisson: [poisson; 3], shear: [g; 3], density, viscosity }
    }

    /// The vocal-fold case of the seed: the x–z plane isotropic (E_x = E_z = `e_plane`, in-plane
    /// Poisson ratio `nu_plane`, G_zx = E_plane / (2(1+ν_plane))), the fibre along y with
    /// `e_fibre`, Poisson ratio ν_yx = `nu_fibre_plane` (contraction across the fibre under
    /// stretch along it) and longitudinal shear modulus `g_fibre` (= G_xy = G_yz).
    pub fn transversely_isotropic(e_plane: f64, e_fibre: f64, nu_plane: f64, nu_fibre_plane: f64, g_fibre: f64, density: f64, viscosity: f64) -> Self {
        // ν_xy = ν_yx E_x / E_y ; ν_yz = ν_yx (z ≡ x in the plane).
        let nu_xy = nu_fibre_plane * e_plane / e_fibre;
        let nu_yz = nu_fibre_plane;
        let g_plane = e_plane / (2.0 * (1.0 + nu_plane));
        Self { young: [e_plane, e_fibre, e_plane], poisson: [nu_xy, nu_yz, nu_plane], shear: [g_fibre, g_plane, g_fibre], density, viscosity }
    }

    /// The same material with every modulus (Young's and shear) times `factor`: the Poisson
    /// ratios, density and viscosity kept (how Titze's body–cover cases scale a layer).
    pub fn scaled(&self, factor: f64) -> Self {
        Self { young: self.young.map(|e| e * factor), shear: self.shear.map(|g| g * factor), ..self.clone() }
    }

    /// Compliance of the normal block, seed (2.8): S₁ = C₁⁻¹.
    fn normal_compliance(&self) -> [[f64; 3]; 3] {
        let [ex, ey, ez] = self.young;
        let [nxy, nyz, nzx] = self.poisson;
        // Reciprocal ratios.
        let nyx = nxy * ey / ex;
        let nzy = nyz * ez / ey;
        let nxz = nzx * ex / ez;
        [[1.0 / ex, -nyx / ey, -nzx / ez], [-nxy / ex, 1.0 / ey, -nzy / ez], [-nxz / ex, -nyz / ey, 1.0 / ez]]
    }

    /// Checks the constants and returns the stiffness matrix C (2.5–2.9), refusing sets whose C
    /// is not positive definite. `field` prefixes the error (e.g. `solid.materials[1]`).
    pub fn stiffness(&self, field: &str) -> Result<Voigt6, SceneError> {
        let bad = |f: &str, reason: String| Err(SceneError { field: format!("{field}.{f}"), reason });
        for (k, e) in self.young.iter().enumerate() {
            if !(e.is_finite() && *e > 0.0) {
                return bad(&format!("young[{k}]"), format!("Young's modulus must be finite and > 0, got {e}"));
            }
        }
        for (k, g) in self.shear.iter().enumerate() {
            if !(g.is_finite() && *g > 0.0) {
                return bad(&format!("shear[{k}]"), format!("shear modulus must be finite and > 0, got {g}"));
            }
        }
        for (k, n) in self.poisson.iter().enumerate() {
            if !n.is_finite() {
                return bad(&format!("poisson[{k}]"), format!("Poisson ratio must be finite, got {n}"));
            }
        }
        if !(self.density.is_finite() && self.density > 0.0) {
            return bad("density", format!("must be finite and > 0, got {}", self.density));
        }
        if !(self.viscosity.is_finite() && self.viscosity >= 0.0) {
            return bad("viscosity", format!("must be finite and ≥ 0, got {}", self.viscosity));
        }
        let s = self.normal_compliance();
        // C₁ is positive definite iff S₁ is: leading principal minors of S₁ (scaled by E).
        let [ex, ey, _] = self.young;
        let nyx = self.poisson[0] * ey / ex;
        let m2 = s[0][0] * s[1][1] - s[0][1] * s[1][0];
        let det = det3(&s);
        if m2 <= 0.0 {
            return bad("poisson", format!("1 − ν_xy ν_yx = {:.4} ≤ 0: the stiffness matrix is not positive definite", 1.0 - self.poisson[0] * nyx));
        }
        let scaled = det * self.young.iter().product::<f64>();
        if det <= 0.0 {
            return bad(
                "poisson",
                format!(
                    "1 − ν_xy ν_yx − ν_yz ν_zy − ν_zx ν_xz − 2 ν_yx ν_zy ν_xz = {scaled:.4} ≤ 0: the stiffness matrix is not positive definite (Poisson ratios too large for these moduli)"
                ),
            );
        }
        let c1 = inv3(&s);
        let mut c = [[0.0; 6]; 6];
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] = c1[i][j];
            }
        }
        c[3][3] = self.shear[0];
        c[4][4] = self.shear[1];
        c[5][5] = self.shear[2];
        Ok(c)
    }
}

pub(crate) fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

fn inv3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let a = DMat3::from_cols_array_2d(m).transpose().inverse().transpose();
    a.to_cols_array_2d()
}

/// ε (symmetric 3×3) → Voigt vector with engineering shear strains.
pub fn to_voigt(e: &DMat3) -> [f64; 6] {
    [e.x_axis.x, e.y_axis.y, e.z_axis.z, e.z_axis.y + e.y_axis.z, e.x_axis.z + e.z_axis.x, e.y_axis.x + e.x_axis.y]
}

/// Voigt stress vector → symmetric 3×3 tensor.
pub fn from_voigt(s: &[f64; 6]) -> DMat3 {
    DMat3::from_cols(DVec3::new(s[0], s[5], s[4]), DVec3::new(s[5], s[1], s[3]), DVec3::new(s[4], s[3], s[2]))
}

pub fn mul6(c: &Voigt6, e: &[f64; 6]) -> [f64; 6] {
    let mut s = [0.0; 6];
    for i in 0..6 {
        s[i] = (0..6).map(|j| c[i][j] * e[j]).sum();
    }
    s
}

/// Smallest eigenvalue of C in Mandel form (the stiffness per unit of |ε|² for the stiffest
/// softest mode): shear rows scaled so that ε:C:ε = ε_M · C_M ε_M with |ε_M| = |ε|.
pub fn min_mandel_eigenvalue(c: &Voigt6) -> f64 {
    let s = [1.0, 1.0, 1.0, std::f64::consts::SQRT_2, std::f64::consts::SQRT_2, std::f64::consts::SQRT_2];
    let mut m = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            m[i][j] = c[i][j] * s[i] * s[j];
        }
    }
    jacobi_eigenvalues(m).into_iter().fold(f64::INFINITY, f64::min)
}

/// Eigenvalues of a symmetric 6×6 matrix by cyclic Jacobi rotations.
pub fn jacobi_eigenvalues(mut a: Voigt6) -> [f64; 6] {
    for _sweep in 0..50 {
        let off: f64 = (0..6).flat_map(|i| (0..6).filter(move |&j| j != i).map(move |j| (i, j))).map(|(i, j)| a[i][j] * a[i][j]).sum();
        if off < 1e-30 * (0..6).map(|i| a[i][i] * a[i][i]).sum::<f64>().max(1e-300) {
            break;
        }
        for p in 0..6 {
            for q in p + 1..6 {
                if a[p][q].abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..6 {
                    let akp = a[k][p];
                    let akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..6 {
                    let apk = a[p][k];
                    let aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
            }
        }
    }
    std::array::from_fn(|i| a[i][i])
}

/// Plane-wave speeds of a homogeneous orthotropic medium along a coordinate axis `a`:
/// longitudinal √(C_aa/ρ) and the two transverse ones √(G/ρ) (Christoffel equation for an axis
/// of symmetry). Returns (longitudinal, [transverse polarised along the other two axes]).
pub fn axis_wave_speeds(c: &Voigt6, density: f64, a: usize) -> (f64, [(usize, f64); 2]) {
    // shear index of the plane (a, b): yz→3, zx→4, xy→5
    let shear = |a: usize, b: usize| match (a.min(b), a.max(b)) {
        (1, 2) => 3,
        (0, 2) => 4,
        _ => 5,
    };
    let others: Vec<usize> = (0..3).filter(|&b| b != a).collect();
    let t = |b: usize| (b, (c[shear(a, b)][shear(a, b)] / density).sqrt());
    ((c[a][a] / density).sqrt(), [t(others[0]), t(others[1])])
}
