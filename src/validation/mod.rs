//! Validation cases with analytic or published references (../shared/reference). Each case
//! returns its measured figure next to the reference; the tests and the `validate` CLI
//! subcommand assert the tolerances.

pub mod beam;
pub mod cavity;
pub mod channel;
pub mod contact;
pub mod cylinder;
pub mod fsi;
pub mod fsi_flap;
pub mod fsi_momentum;
pub mod fsi_plate;
pub mod fsi_schafer_turek;
pub mod glottis;
pub mod riemann;
pub mod soak;
pub mod sod;
pub mod sound;
pub mod suite;
pub mod taylor_green;
pub mod waves;
