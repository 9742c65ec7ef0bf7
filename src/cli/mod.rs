//! The command-line tool's commands, one module per group; `src/main.rs`
//! holds the grammar (clap), the loading of scenes shared by all commands,
//! and the dispatch.
//!
//! Everything the tool prints on standard output goes through [`out!`] and
//! [`outln!`], which return the write's error instead of panicking as
//! `print!` does: a reader that has closed the pipe (`planetwear simulate … |
//! head`) ends the command with [`StdoutClosed`], which `main` turns into a
//! quiet exit with status 0; any other failure (a full disk under a
//! redirected standard output) is an error naming standard output.

/// As `print!`, to standard output; yields `anyhow::Result<()>` (see the
/// module's documentation).
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::write_stdout(format_args!($($arg)*))
    };
}

/// As `println!`, to standard output; yields `anyhow::Result<()>` (see the
/// module's documentation).
macro_rules! outln {
    () => {
        $crate::cli::write_stdout(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub(crate) use {out, outln};

pub(crate) mod continuation;
pub(crate) mod dynamics;
pub(crate) mod fmu;
pub(crate) mod study;
pub(crate) mod wear;

use std::io::Write;

/// The reader of standard output has closed it: the command stops, and the
/// tool ends quietly with status 0, as a Unix filter does.
#[derive(Debug)]
pub(crate) struct StdoutClosed;

impl std::fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("standard output closed by its reader")
    }
}

impl std::error::Error for StdoutClosed {}

/// Writes `args` to standard output (line-buffered, as `print!`).
pub(crate) fn write_stdout(args: std::fmt::Arguments<'_>) -> anyhow::Result<()> {
    std::io::stdout().write_fmt(args).map_err(stdout_error)
}

/// Flushes what standard output still holds (a last line without its
/// newline), so that its failure is reported too.
pub(crate) fn flush_stdout() -> anyhow::Result<()> {
    std::io::stdout().flush().map_err(stdout_error)
}

fn stdout_error(e: std::io::Error) -> anyhow::Error {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        StdoutClosed.into()
    } else {
        anyhow::Error::new(e).context("writing to standard output")
    }
}

/// Whether `e` stops the tool because standard output was closed.
pub(crate) fn stdout_closed(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.is::<StdoutClosed>())
}
