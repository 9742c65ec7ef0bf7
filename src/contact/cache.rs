//! On-disk cache of the separation tables, the costly part of a model's
//! set-up (about 0.5 s for the example's two meshes, against tens of
//! milliseconds for a speed point).
//!
//! Off unless a front end turns it on with [`enable`] (the command line does,
//! docs/PERFORMANCE.md "The set-up cache"); the library and the FMU never
//! touch the disk on their own. An entry is keyed by the FNV-1a hash of
//! everything [`MeshSeparation::new`] reads (the validated gear set, the mesh,
//! the flank deviations, the grid step, as exact JSON) together with the crate
//! version and a format number, and holds that key text again, so a hash
//! collision or an entry of another version is a miss, not a wrong model.
//! Entries are written atomically ([`crate::files::write_durable`]); one that
//! cannot be read or parsed is recomputed and rewritten, and a cache that
//! cannot be written is only a slower set-up. Floats are written exactly
//! (serde_json's round-trip parsing), so a cached table is bit for bit the
//! computed one.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use crate::contact::separation::{MeshFlanks, MeshSeparation};
use crate::files::hash::fnv1a64;
use crate::model::gear::{GearSet, MeshKind};

/// Bumped whenever the tables or their serialized form change: meaning, or
/// values in their last bits (2: the indexed contact search, within 2e-17 m
/// of format 1's values), so that a cached run equals an uncached one bit
/// for bit.
const FORMAT: u32 = 2;

static DIRECTORY: OnceLock<PathBuf> = OnceLock::new();

/// Turns the cache on for this process, in directory `dir` (created when
/// the first entry is written). Only the first call counts.
pub fn enable(dir: &Path) {
    let _ = DIRECTORY.set(dir.to_path_buf());
}

/// The cache directory, if the cache is on.
pub fn directory() -> Option<&'static Path> {
    DIRECTORY.get().map(PathBuf::as_path)
}

#[derive(Serialize, Deserialize)]
struct Entry {
    key: String,
    tables: MeshSeparation,
}

fn key(set: &GearSet, mesh: MeshKind, flanks: &MeshFlanks, step: f64) -> Option<String> {
    let text = serde_json::to_string(&(set, mesh, flanks, step.to_bits())).ok()?;
    Some(format!("planetwear {} format {FORMAT} {text}", env!("CARGO_PKG_VERSION")))
}

/// [`MeshSeparation::new`], read from the cache when it is on and holds the
/// entry, and written to it after computing otherwise.
pub fn separation(set: &GearSet, mesh: MeshKind, flanks: &MeshFlanks, step: f64) -> MeshSeparation {
    let (Some(dir), Some(key)) = (directory(), key(set, mesh, flanks, step)) else {
        return MeshSeparation::new(set, mesh, flanks, step);
    };
    let path = dir.join(format!("separation-{:016x}.json", fnv1a64(key.as_bytes())));
    if let Ok(bytes) = std::fs::read(&path) {
        if let Ok(entry) = serde_json::from_slice::<Entry>(&bytes) {
            if entry.key == key {
                return entry.tables;
            }
        }
    }
    let tables = MeshSeparation::new(set, mesh, flanks, step);
    let entry = Entry { key, tables };
    if let Ok(text) = serde_json::to_vec(&entry) {
        if std::fs::create_dir_all(dir).is_ok() {
            let _ = crate::files::write_durable(&path, &text);
        }
    }
    entry.tables
}
