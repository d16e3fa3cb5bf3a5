//! The Bevy plugin in a headless app (MinimalPlugins): stepping through the plugin gives exactly
//! the same fields as stepping the solver directly; pause and single-step work; an unstable run
//! is reported on the entity.
//!
//! One test binary (each links Bevy), a module per concern: `stepping`, `render_world`, `panel`,
//! `drawing`, with what they share in `support`.
#![cfg(feature = "bevy")]

mod drawing;
mod panel;
mod render_world;
mod stepping;
mod support;
