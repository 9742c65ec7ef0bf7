//! Stage 7, analysis: studies over the physics. Natural frequencies and
//! modes, order tracking, the integrators' accuracy against run time, and
//! experiments that vary a scene and compare what the model gives. This stage
//! writes no files; the command line and the reports present its results.
//!
//! May import: every earlier stage ([`crate::files`] to [`crate::wear`]).
//!
//! - [`accuracy`]: work-precision of the integrators.
//! - [`condensed_branch`]: the continuation's solver on the harmonic balance
//!   condensed onto the contact coordinates.
//! - [`continuation`]: pseudo-arclength continuation of periodic steady
//!   states in speed, with stability, folds and period doublings.
//! - [`frame_sweep`]: speed sweeps by time marching in the rigid-body frame,
//!   one period at a time, measured over one period once the state repeats.
//! - [`modes`]: natural frequencies and mode shapes, with mode classes.
//! - [`order_tracking`]: order spectra of a run-up or time history.
//! - [`plausibility`]: the thresholds and checks of a run's warnings
//!   (overspeed, run-away, separation, contact pressure) for FMU and CLI.
//! - [`study`]: the published example's study: calibration, resonance
//!   peaks, validation against the study's claims, and the wear effect.

pub mod accuracy;
pub mod condensed_branch;
pub mod continuation;
pub mod frame_sweep;
pub mod modes;
pub mod order_tracking;
pub mod plausibility;
pub mod steady_accuracy;
pub mod study;
