//! Stage 0, files: the one way the library touches the file system, and the
//! one hash. Every input file (scene, worn-profile state, resources of the
//! FMU) is read whole through [`read_input`], which refuses what is not a
//! regular file without blocking and bounds its size by its kind
//! ([`InputKind`]: one limit shared by the writer and the reader); an output
//! path is checked before a command computes ([`prepare_output_file`],
//! [`prepare_output_dir`]: no device, pipe, socket or directory is replaced,
//! symbolic links are followed, [`output_target`]); every output file (states, reports,
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
#[error("'{}': {error}", path.display())]
pub struct FileError {
    /// The file being read, written or renamed (for a write that failed
    /// before the rename, the temporary file).
    pub path: PathBuf,
    /// The operating system's error, or the reason the file was refused
    /// (in the message, not as a separate cause, so that it is said once).
    pub error: std::io::Error,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> FileError + '_ {
    move |error| FileError { path: path.to_path_buf(), error }
}

/// How every temporary file the project writes begins: `write_durable`
/// names it `.planetwear-tmp.<pid>.<n>.<target name><suffix>` in the
/// target's directory, and [`remove_stale_temps`] removes the ones a killed
/// process left (the Python package uses the same pattern).
pub const TEMP_PREFIX: &str = ".planetwear-tmp.";

/// Creates a fresh temporary file next to `target` whose name ends in
/// `suffix` (some writers choose the format by the extension).
fn create_temp(target: &Path, suffix: &str) -> Result<(PathBuf, File), FileError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = target.with_file_name(format!("{TEMP_PREFIX}{}.{n}.{name}{suffix}", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(error) => return Err(FileError { path: tmp, error }),
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
    let target = &output_target(target)?;
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

/// Largest scene file \[bytes\] (TOML; the example is 3 kB).
pub const MAX_SCENE_BYTES: u64 = 1 << 20;
/// Largest calibration plan file \[bytes\] (TOML, like a scene).
pub const MAX_PLAN_BYTES: u64 = 1 << 20;
/// Largest worn-profile state file \[bytes\] (JSON; the example's states
/// are 20 to 60 kB; the largest grid a scene allows, 10 000 points on 1000
/// face slices, does not fit and is refused when written).
pub const MAX_WORN_STATE_BYTES: u64 = 64 << 20;
/// Largest earlier record a command reads back \[bytes\] (the validation's
/// JSON of its previous run, which it compares with).
pub const MAX_RECORD_BYTES: u64 = 16 << 20;
/// Largest shared library `fmu pack` puts into the archive \[bytes\] (the
/// release library is about 37 MB, the stripped one 2.5 MB).
pub const MAX_LIBRARY_BYTES: u64 = 512 << 20;
/// Largest duty-cycle file \[bytes\] (JSON: at most 10 000 bins per mesh; the example's
/// four planets at that size write about 5 MB).
pub const MAX_DUTY_CYCLE_BYTES: u64 = 32 << 20;
/// Largest campaign file \[bytes\] (TOML). The Rust code reads no campaign
/// file; the Python package's reader (`planetwear_fmu.files`) holds the same
/// figure, and a test checks that the two agree.
pub const MAX_CAMPAIGN_BYTES: u64 = 1 << 20;

/// The kinds of file the project reads, each with one size limit that its
/// reader and its writer share: a file the writer would leave is one the
/// reader takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// A scene file (TOML).
    Scene,
    /// A calibration plan (TOML).
    Plan,
    /// A worn-profile state (JSON).
    WornState,
    /// A campaign file (TOML; read by the Python package).
    Campaign,
    /// A record of an earlier run that a command reads back (JSON).
    Record,
    /// The FMU's shared library, read by `fmu pack`.
    Library,
    /// A duty-cycle file (JSON: a run's load duty).
    DutyCycle,
}

impl InputKind {
    /// Largest file of this kind \[bytes\].
    pub const fn limit(self) -> u64 {
        match self {
            Self::Scene => MAX_SCENE_BYTES,
            Self::Plan => MAX_PLAN_BYTES,
            Self::WornState => MAX_WORN_STATE_BYTES,
            Self::Campaign => MAX_CAMPAIGN_BYTES,
            Self::Record => MAX_RECORD_BYTES,
            Self::Library => MAX_LIBRARY_BYTES,
            Self::DutyCycle => MAX_DUTY_CYCLE_BYTES,
        }
    }

    /// The kind's name in messages.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Scene => "scene file",
            Self::Plan => "calibration plan",
            Self::WornState => "worn-profile state file",
            Self::Campaign => "campaign file",
            Self::Record => "record of an earlier run",
            Self::Library => "shared library",
            Self::DutyCycle => "duty-cycle file",
        }
    }

    /// The limit in readable units (`1 MiB`, `64 MiB`).
    pub fn limit_text(self) -> String {
        bytes_text(self.limit())
    }
}

fn bytes_text(n: u64) -> String {
    if n >= 1 << 20 && n % (1 << 20) == 0 {
        format!("{} MiB", n >> 20)
    } else if n >= 1 << 20 {
        format!("{:.1} MiB", n as f64 / f64::from(1u32 << 20))
    } else {
        format!("{n} bytes")
    }
}

/// Opening a file with this flag never waits for a writer (a FIFO) or a
/// device; on a regular file it changes nothing.
#[cfg(target_os = "linux")]
const O_NONBLOCK: i32 = 0o4000;
#[cfg(all(unix, not(target_os = "linux")))]
const O_NONBLOCK: i32 = 0x0004;

/// What a path that is not a regular file is, for messages.
fn file_type_text(t: fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a named pipe (FIFO)"
    } else if t.is_char_device() || t.is_block_device() {
        "a device"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_symlink() {
        "a symbolic link"
    } else {
        "not a regular file"
    }
}

/// Reads a whole input file of `kind`: the one way in for every file the
/// command line and the FMU read. A path that is not a regular file (a
/// directory, a device such as `/dev/zero`, a named pipe, a socket) is
/// refused without blocking: it is looked at before it is opened, opened
/// without waiting (`O_NONBLOCK`), and the opened file is looked at again
/// (so a file swapped between the two is caught). A file larger than the
/// kind's limit ([`InputKind::limit`]) is refused before it is read, and
/// never more than the limit is read. Symbolic links are followed. Every
/// refusal names the path, the kind and the limit.
pub fn read_input(path: &Path, kind: InputKind) -> Result<Vec<u8>, FileError> {
    use std::io::{Error, ErrorKind, Read};
    use std::os::unix::fs::OpenOptionsExt;
    let not_regular = |t: fs::FileType| FileError {
        path: path.to_path_buf(),
        error: Error::new(
            ErrorKind::InvalidInput,
            format!("is {}, not a regular file: a {} must be a regular file", file_type_text(t), kind.name()),
        ),
    };
    let too_large = |size: String| FileError {
        path: path.to_path_buf(),
        error: Error::new(
            ErrorKind::InvalidData,
            format!("is {size}, larger than the {} a {} may have", kind.limit_text(), kind.name()),
        ),
    };
    let meta = fs::metadata(path).map_err(io(path))?;
    if !meta.is_file() {
        return Err(not_regular(meta.file_type()));
    }
    let file = OpenOptions::new().read(true).custom_flags(O_NONBLOCK).open(path).map_err(io(path))?;
    let meta = file.metadata().map_err(io(path))?;
    if !meta.is_file() {
        return Err(not_regular(meta.file_type()));
    }
    let limit = kind.limit();
    if meta.len() > limit {
        return Err(too_large(bytes_text(meta.len())));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io(path))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(format!("more than {}", kind.limit_text())));
    }
    Ok(bytes)
}

/// Refuses to write `len` bytes as a file of `kind` that the reader would
/// refuse ([`read_input`]): the writer and the reader share one limit.
pub fn check_output_size(path: &Path, kind: InputKind, len: usize) -> Result<(), FileError> {
    if len as u64 <= kind.limit() {
        return Ok(());
    }
    Err(FileError {
        path: path.to_path_buf(),
        error: std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "not written: {} would be larger than the {} a {} may have (the reader refuses it){}",
                bytes_text(len as u64),
                kind.limit_text(),
                kind.name(),
                match kind {
                    InputKind::WornState => "; use fewer grid points or face slices",
                    _ => "",
                }
            ),
        ),
    })
}

/// The file an output path names, with the policy for what is already
/// there: a symbolic link is followed (the file it points to is written and
/// the link stays; a link to nothing is refused), and an existing path that
/// is not a regular file (a directory, a device, a named pipe, a socket) is
/// refused, so no write replaces what is not the project's own file.
pub fn output_target(path: &Path) -> Result<PathBuf, FileError> {
    use std::io::{Error, ErrorKind};
    let refuse =
        |why: String| FileError { path: path.to_path_buf(), error: Error::new(ErrorKind::InvalidInput, why) };
    let target = match fs::symlink_metadata(path) {
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(path.to_path_buf()),
        Err(e) => return Err(io(path)(e)),
        Ok(m) if m.file_type().is_symlink() => match fs::canonicalize(path) {
            Ok(t) => t,
            Err(_) => {
                let to = fs::read_link(path).map(|t| t.display().to_string()).unwrap_or_default();
                return Err(refuse(format!(
                    "is a symbolic link to {to}, which does not exist: give the file's own path"
                )));
            }
        },
        Ok(_) => path.to_path_buf(),
    };
    let meta = fs::metadata(&target).map_err(io(&target))?;
    if !meta.is_file() {
        return Err(refuse(format!(
            "is {}: an output file may only replace a regular file; give a file path",
            file_type_text(meta.file_type())
        )));
    }
    Ok(target)
}

/// Checks an output file before any computation ([`output_target`]'s
/// policy; its directory, when it exists, must be a directory) and removes
/// the temporary files a killed run left in that directory
/// ([`remove_stale_temps`]).
pub fn prepare_output_file(path: &Path) -> Result<(), FileError> {
    let target = output_target(path)?;
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if let Ok(m) = fs::metadata(&dir) {
        if !m.is_dir() {
            return Err(FileError {
                path: dir,
                error: std::io::Error::new(std::io::ErrorKind::InvalidInput, "is not a directory"),
            });
        }
        remove_stale_temps(&dir);
    }
    Ok(())
}

/// Checks an output directory before any computation: a path that exists
/// must be a directory (a link to one is followed), and the temporary files
/// a killed run left in it are removed ([`remove_stale_temps`]). A
/// directory that does not exist yet is left for the command to create.
pub fn prepare_output_dir(dir: &Path) -> Result<(), FileError> {
    match fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(m) => {
            return Err(FileError {
                path: dir.to_path_buf(),
                error: std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("is {}: an output directory must be a directory", file_type_text(m.file_type())),
                ),
            })
        }
        Err(_) => return Ok(()),
    }
    remove_stale_temps(dir);
    Ok(())
}

/// Removes from `dir` the temporary files ([`TEMP_PREFIX`]) of processes
/// that no longer run (a run killed while it wrote), and nothing else: a
/// file of another name, or of a process still running (by its id in
/// `/proc`), stays. Returns how many it removed; a directory it cannot list
/// removes nothing.
pub fn remove_stale_temps(dir: &Path) -> usize {
    let proc_fs = Path::new("/proc/self").exists();
    let me = std::process::id();
    let Ok(entries) = fs::read_dir(dir) else { return 0 };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(TEMP_PREFIX)) else { continue };
        let Some(pid) = rest.split('.').next().and_then(|p| p.parse::<u32>().ok()) else { continue };
        let alive = pid == me || !proc_fs || Path::new("/proc").join(pid.to_string()).exists();
        let regular = entry.file_type().map(|t| t.is_file()).unwrap_or(false);
        if !alive && regular && fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}
