//! The command-line tool's commands, one module per group; `src/main.rs`
//! holds the grammar (clap), the loading of scenes shared by all commands,
//! and the dispatch.

pub(crate) mod continuation;
pub(crate) mod dynamics;
pub(crate) mod fmu;
pub(crate) mod study;
pub(crate) mod wear;
