//! Every case of the validation suite ([`super`]): its name, what it checks against which
//! reference, its wall time here, and its runner — the data `phonation validate` runs and
//! `--list` prints.

use super::{Case, Row};

mod fluid;
mod glottis;
mod moving_bodies;
mod schafer_turek;
mod solid;
mod two_mass;

/// A case from its parts (the fields of [`Case`]).
fn case(name: &'static str, checks: &'static str, cost: &'static str, run: fn() -> Vec<Row>) -> Case {
    Case { name, checks, cost, run }
}

/// All cases, in the order `phonation validate` runs them: the fluid alone, the two-mass model,
/// the couplings on moving bodies, the glottis, Schäfer–Turek 2D-1, the implicit solid.
pub fn cases() -> Vec<Case> {
    [fluid::cases(), two_mass::cases(), moving_bodies::cases(), glottis::cases(), schafer_turek::cases(), solid::cases()].concat()
}
