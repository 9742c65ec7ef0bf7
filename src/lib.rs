//! planetwear: nonlinear dynamics of a spur planetary gear set whose tooth
//! flanks wear.
//!
//! The physics core ([`physics`]) is pure; [`scene`] turns what a user writes
//! into validated SI input; [`report`] writes files for the command-line tool;
//! [`analysis`] runs studies over the physics (experiments, calibration);
//! [`files`] reads and writes the library's own data files (the worn-profile
//! state).
#![deny(clippy::print_stdout, clippy::print_stderr)]

pub mod analysis;
pub mod files;
pub mod fmi;
pub mod physics;
pub mod report;
pub mod scene;
pub mod solver;
