//! Choice of the time step Δt, the relaxation time τ and the stabilising coefficient A of
//! (2.77), in lattice units, from the stability limits of the scheme:
//!
//! * advection: Heun + 3rd-order upwind, applied axis by axis, is stable while
//!   Δt · max_i Σ_α |c_iα| ≤ σ_max ≈ 0.87 ([`super::upwind::max_courant`]);
//! * collision: Heun on df/dt = −(f − f⁰)/τ is stable for Δt ≤ 2τ; we keep Δt/τ ≤
//!   [`MAX_DT_OVER_TAU`] for accuracy of the non-equilibrium part.
//!
//! The viscosity is ν = θ₀(τ − A) (2.101). When ν/θ₀ is smaller than the τ the collision
//! limit needs, τ is raised to Δt/MAX_DT_OVER_TAU and A = τ − ν/θ₀ > 0 removes the excess
//! (the seed's "negative viscosity" term; A is kept as small as the step allows).

use thiserror::Error;

/// Default fraction of the advection limit used by the automatic choice.
pub const DEFAULT_COURANT_SAFETY: f64 = 0.8;
/// Largest Δt/τ accepted.
pub const MAX_DT_OVER_TAU: f64 = 1.0;

/// Δt, τ and A in lattice time units.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StepParams {
    pub dt: f64,
    pub tau: f64,
    pub a: f64,
}

#[derive(Debug, Error, PartialEq)]
pub enum TimeStepError {
    #[error(
        "time_step: Δt = {dt} lattice units exceeds the advection stability limit {limit:.4} (Courant {sigma:.3} / max Σ|c_iα| = {l1}) of 3rd-order upwind + Runge–Kutta 2"
    )]
    Advection { dt: f64, limit: f64, sigma: f64, l1: i32 },
    #[error("time_step: Δt/τ = {ratio:.3} exceeds {max} (τ = {tau}); the explicit collision would be inaccurate or unstable")]
    Collision { ratio: f64, max: f64, tau: f64 },
    #[error("viscosity: ν = {nu} must be positive")]
    Viscosity { nu: f64 },
    #[error("time_step: must be positive and finite, got {dt}")]
    NonPositive { dt: f64 },
}

/// Advection limit of Δt for a set whose largest Σ_α|c_iα| is `l1`.
pub fn advection_limit(l1: i32) -> f64 {
    super::upwind::max_courant() / l1 as f64
}

/// Chooses (Δt, τ, A) for kinematic viscosity `nu` at reference temperature `theta0`.
/// `fixed_dt`: a Δt the scene imposes (checked, not changed).
pub fn choose(nu: f64, theta0: f64, l1: i32, fixed_dt: Option<f64>, courant_safety: f64) -> Result<StepParams, TimeStepError> {
    if !(nu > 0.0 && nu.is_finite()) {
        return Err(TimeStepError::Viscosity { nu });
    }
    let sigma = super::upwind::max_courant();
    let limit = sigma / l1 as f64;
    let dt = match fixed_dt {
        Some(dt) => {
            if !(dt > 0.0 && dt.is_finite()) {
                return Err(TimeStepError::NonPositive { dt });
            }
            if dt > limit {
                return Err(TimeStepError::Advection { dt, limit, sigma, l1 });
            }
            dt
        }
        None => courant_safety * limit,
    };
    let tau_nu = nu / theta0;
    let tau = tau_nu.max(dt / MAX_DT_OVER_TAU);
    Ok(StepParams { dt, tau, a: tau - tau_nu })
}

/// Checks explicit (Δt, τ, A) given by a scene.
pub fn check(p: StepParams, l1: i32) -> Result<(), TimeStepError> {
    let sigma = super::upwind::max_courant();
    let limit = sigma / l1 as f64;
    if !(p.dt > 0.0 && p.dt.is_finite()) {
        return Err(TimeStepError::NonPositive { dt: p.dt });
    }
    if p.dt > limit {
        return Err(TimeStepError::Advection { dt: p.dt, limit, sigma, l1 });
    }
    if p.dt / p.tau > MAX_DT_OVER_TAU * 2.0 {
        return Err(TimeStepError::Collision { ratio: p.dt / p.tau, max: 2.0 * MAX_DT_OVER_TAU, tau: p.tau });
    }
    Ok(())
}
