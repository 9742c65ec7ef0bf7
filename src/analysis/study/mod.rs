//! The studies of the published example (part of stage 7, analysis):
//! experiments that vary a scene and compare what the model gives with what
//! the study reports. They use the analyses of the parent module (modes)
//! and every earlier stage; nothing outside the front ends uses them.
//!
//! - [`calibrate`]: scene parameters fitted to target natural frequencies
//!   and double-contact shares.
//! - [`error`]: why a study failed ([`StudyError`]).
//! - [`peaks`]: resonance peaks of a sweep and the mode behind each.
//! - [`validation`]: every claim of the study beside ours, with tolerance
//!   and verdict, and the published benchmarks.
//! - [`wear_effect`]: the cause of the wear effect on the dynamic loads,
//!   one modelling factor at a time.

pub mod calibrate;
pub mod error;
pub mod peaks;
pub mod validation;
pub mod wear_effect;

pub use error::StudyError;
