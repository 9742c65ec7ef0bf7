//! Reports for the command-line tool: JSON documents and plots. This is the
//! shell around the physics: it converts to the field's units only where a
//! person reads (plots), and writes every file atomically.

pub mod accuracy;
pub mod continuation;
pub mod ltca;
pub mod plot;
pub mod sweep;
pub mod validation;
pub mod wear;
pub mod wear_effect;

pub use plot::write_atomic;
