//! The subcommands of the `phonation` binary, one module per family.

pub mod bench;
pub mod lattice_gas;
pub mod run;
pub mod voice;
