//! Stage 6, wear: Archard wear of the tooth flanks. The wear law over a
//! mesh cycle (quasi-static or dynamic tooth loads), the wear stepper that
//! advances the worn-profile state κ, and the state itself.
//!
//! May import: every earlier stage ([`crate::files`], [`crate::scene`],
//! [`crate::model`], [`crate::geometry`], [`crate::contact`],
//! [`crate::dynamics`]).
//!
//! Inside the stage, in import order (a file imports only those above it):
//!
//! - [`flank`]: the six physical flanks, tooth cycles, roll angles of a
//!   contact point, the active profile.
//! - [`state`]: the worn-profile state, its fingerprint and file format.
//! - [`duty`]: the duty-cycle file (a run's load duty and its gear set).
//! - [`archard`]: the wear law: settings, Hertzian bands, sliding, the wear
//!   of one cycle, errors.
//! - [`dynamic`]: tooth-pair loads recorded from a dynamic steady state.
//! - [`stepper`]: the wear model of a gear set and its updates κ → κ + 1.
//! - [`duty_wear`]: the wear of a duty cycle's load bins, summed.
//! - [`compare`]: quasi-static against dynamic wear loads.

pub mod archard;
pub mod compare;
pub mod duty;
pub mod duty_wear;
pub mod dynamic;
pub mod flank;
pub mod state;
pub mod stepper;
