//! Stage 5, dynamics: the nonlinear tooth-by-tooth equations of motion, the
//! time integrators, the time-domain simulation the FMU steps, the periodic
//! steady state at one speed and its measures (mean, harmonics, rms, tooth
//! separation), and the serialized simulation state.
//!
//! The harmonic measures of a steady state ([`spectrum`]) live here rather
//! than in analysis because the wear stage drives wear by the loads of a
//! dynamic steady state.
//!
//! May import: [`crate::files`], [`crate::scene`], [`crate::model`],
//! [`crate::geometry`], [`crate::contact`].
//!
//! - [`duty`]: the load duty a run produced (revolutions per torque × speed bin, per mesh).
//! - [`equations`]: the equations of motion of the planetary set.
//! - [`solver`]: generalized-α and RK45 integrators behind one trait.
//! - [`simulation`]: the time-domain run from given initial conditions.
//! - [`response`]: the steady state at one speed and its measures.
//! - [`periodic`]: periodic steady states by shooting, Floquet multipliers.
//! - [`spectrum`]: mesh-force harmonics and separation share.
//! - [`state_format`]: the serialized simulation state (FMU states).

pub mod duty;
pub mod equations;
pub mod periodic;
pub mod response;
pub mod rigid_frame;
pub mod simulation;
pub mod solver;
pub mod spectrum;
pub mod state_format;
pub mod steady;
