//! planetwear: nonlinear dynamics of a spur planetary gear set whose tooth
//! flanks wear.
//!
//! The crate reads as a pipeline, one module per stage; a stage imports only
//! from the stages before it (checked by `tests/layers.rs`):
//!
//! 0. [`files`]: bounded reading, durable writing, the one hash.
//! 1. [`scene`]: what a user writes, and its validation.
//! 2. [`model`]: the validated, immutable gear set in SI units.
//! 3. [`geometry`]: flank outlines and profile deviations.
//! 4. [`contact`]: separation, stiffness, Hertz, loaded tooth contact.
//! 5. [`dynamics`]: equations of motion, integrators, steady states.
//! 6. [`wear`]: Archard wear, the stepper, the worn-profile state.
//! 7. [`analysis`]: modes, order tracking, accuracy, calibration, validation.
//! 8. Front ends: [`fmi`] (the FMU), [`package`] (the `.fmu` archive and its
//!    regression references), [`report`] (files for the tool), and the
//!    command-line tool (`src/main.rs`).
#![deny(clippy::print_stdout, clippy::print_stderr)]

pub mod analysis;
pub mod contact;
pub mod dynamics;
pub mod files;
pub mod fmi;
pub mod geometry;
pub mod model;
pub mod package;
pub mod report;
pub mod scene;
pub mod wear;
