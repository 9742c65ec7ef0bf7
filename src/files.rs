//! The library's own data files, read and written whole: the worn-profile
//! state ([`crate::physics::wear_state`]). The physics turns a state into
//! text and back; this shell, shared by the command-line tool and the FMU,
//! does the file system. A file is written to a temporary file in the same
//! directory, flushed to disk and renamed over the target, so a reader sees
//! the old file or the new one, never a part.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::physics::gear::GearSet;
use crate::physics::wear_state::{WornState, WornStateError};

/// Why a worn-profile state file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum StateFileError {
    /// The file system refused.
    #[error("worn-profile state file '{}': {source}", path.display())]
    Io {
        /// The file being read, written or renamed.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The file was read but its content was refused.
    #[error("worn-profile state file '{}': {source}", path.display())]
    State {
        /// The file.
        path: PathBuf,
        /// Why it was refused.
        #[source]
        source: Box<WornStateError>,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> StateFileError + '_ {
    move |source| StateFileError::Io { path: path.to_path_buf(), source }
}

/// Writes `bytes` to `target` atomically: a fresh temporary file next to it,
/// `fsync`, rename, then `fsync` of the directory so the rename is durable.
pub fn write_durable(target: &Path, bytes: &[u8]) -> Result<(), StateFileError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let (tmp, mut file) = loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = target.with_file_name(format!(".{name}.tmp-{}-{n}", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(f) => break (tmp, f),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(source) => return Err(StateFileError::Io { path: tmp, source }),
        }
    };
    let result = file
        .write_all(bytes)
        .and_then(|()| file.sync_all())
        .map_err(io(&tmp))
        .and_then(|()| fs::rename(&tmp, target).map_err(io(target)));
    drop(file);
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
        return result;
    }
    // Make the rename itself durable; a directory that cannot be opened for
    // syncing (some file systems) leaves the file written all the same.
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if let Ok(d) = File::open(&dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Writes a worn-profile state to `path` (atomically). A state with a
/// non-finite or negative value or a malformed grid is refused and nothing
/// is written.
pub fn write_worn_state(path: &Path, state: &WornState) -> Result<(), StateFileError> {
    let text = state
        .to_json()
        .map_err(|source| StateFileError::State { path: path.to_path_buf(), source: Box::new(source) })?;
    write_durable(path, text.as_bytes())
}

/// Largest input file the library reads [bytes]: a scene or a worn-profile
/// state is kilobytes to a few megabytes.
pub const MAX_INPUT_BYTES: u64 = 64 << 20;

/// Reads a whole input file, refusing what is not a regular file (a
/// directory, a device such as `/dev/zero`, a pipe, which would block or
/// never end) and a file larger than [`MAX_INPUT_BYTES`].
pub fn read_input(path: &Path) -> std::io::Result<Vec<u8>> {
    use std::io::{Error, ErrorKind, Read};
    let not_regular =
        || Error::new(ErrorKind::InvalidInput, "not a regular file (a directory, a device or a pipe)");
    // Checked before opening: opening a pipe for reading blocks until a
    // writer comes.
    if !fs::metadata(path)?.is_file() {
        return Err(not_regular());
    }
    let file = File::open(path)?;
    if !file.metadata()?.is_file() {
        return Err(not_regular());
    }
    let mut bytes = Vec::new();
    file.take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(Error::new(
            ErrorKind::InvalidData,
            format!("larger than {} MiB: not a scene or state file", MAX_INPUT_BYTES >> 20),
        ));
    }
    Ok(bytes)
}

/// Reads the worn-profile state at `path` for the gear set `set`, with every
/// check of [`WornState::from_json`] (through [`read_input`]).
pub fn read_worn_state(path: &Path, set: &GearSet) -> Result<WornState, StateFileError> {
    let bytes = read_input(path).map_err(io(path))?;
    let text = String::from_utf8_lossy(&bytes);
    WornState::from_json(&text, set)
        .map_err(|source| StateFileError::State { path: path.to_path_buf(), source: Box::new(source) })
}
