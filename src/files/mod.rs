//! Stage 0, files: the one way the library touches the file system, and the
//! one hash. Every input file (scene, worn-profile state, resources of the
//! FMU) is read whole through [`read_input`], which bounds its size and
//! refuses what is not a regular file; every output file (states, reports,
//! plots, the FMU archive) is written through [`write_durable`] or
//! [`write_durable_with`]: a temporary file in the same directory, flushed to
//! disk and renamed over the target, so a reader sees the old file or the new
//! one, never a part. The file formats themselves belong to their stages
//! (the scene to [`crate::scene`], the worn-profile state to
//! [`crate::wear::state`], the simulation state to
//! [`crate::dynamics::state_format`]).
//!
//! May import: nothing of the crate.

pub mod hash;

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A file that could not be read or written, with the operating system's
/// reason.
#[derive(Debug, thiserror::Error)]
#[error("'{}': {source}", path.display())]
pub struct FileError {
    /// The file being read, written or renamed (for a write that failed
    /// before the rename, the temporary file).
    pub path: PathBuf,
    /// The operating system's error.
    #[source]
    pub source: std::io::Error,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> FileError + '_ {
    move |source| FileError { path: path.to_path_buf(), source }
}

/// Creates a fresh temporary file next to `target` whose name ends in
/// `suffix` (some writers choose the format by the extension).
fn create_temp(target: &Path, suffix: &str) -> Result<(PathBuf, File), FileError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = target.with_file_name(format!(".{name}.tmp-{}-{n}{suffix}", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(source) => return Err(FileError { path: tmp, source }),
        }
    }
}

/// Writes `bytes` to `target` atomically: a fresh temporary file next to it,
/// `fsync`, rename, then `fsync` of the directory so the rename is durable.
pub fn write_durable(target: &Path, bytes: &[u8]) -> Result<(), FileError> {
    write_durable_with(target, "", |tmp| {
        OpenOptions::new()
            .write(true)
            .truncate(true)
            .open(tmp)
            .and_then(|mut file| file.write_all(bytes))
            .map_err(io(tmp))
    })
}

/// Like [`write_durable`] for a writer that needs a path: `render` writes
/// the temporary file (whose name ends in `suffix`, e.g. `.png` for a
/// library that picks the image format by the extension), which is then
/// flushed to disk and renamed to `target`. On any failure the temporary
/// file is removed and `target` is untouched.
pub fn write_durable_with<E>(
    target: &Path,
    suffix: &str,
    render: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E>
where
    E: From<FileError>,
{
    let (tmp, file) = create_temp(target, suffix)?;
    drop(file);
    let result = render(&tmp).and_then(|()| {
        File::open(&tmp)
            .and_then(|f| f.sync_all())
            .map_err(io(&tmp))
            .and_then(|()| fs::rename(&tmp, target).map_err(io(target)))
            .map_err(E::from)
    });
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

/// Largest input file the library reads \[bytes\]: a scene or a worn-profile
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
