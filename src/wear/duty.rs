//! The duty-cycle file: the load duty a run or a campaign produced
//! ([`crate::dynamics::duty::LoadDuty`]: per mesh, the input revolutions in
//! each bin of load torque × input speed), with the gear set it was run on
//! and the operating time it stands for, as a versioned, checksummed JSON
//! document like the worn-profile state's ([`crate::wear::state`]).
//!
//! ```text
//! { "format": "planetwear-duty-cycle", "version": 1,
//!   "checksum": "fnv1a64:<16 hex digits>",
//!   "content": {
//!     "gear_set": { "name", "fingerprint", "parameters": { … } },
//!     "source": "simulate" | "fmu" | …,
//!     "duty": { "bins": { "torque": [N·m …], "speed": [rad/s …] }, "planets": 4,
//!               "revolutions": [ per mesh (planet-major: sun–planet, ring–planet),
//!                                torque bin-major, speed bins within ],
//!               "outside": [ per mesh ], "total": <input revolutions>, "duration": <s> } } }
//! ```
//!
//! A file that is cut short, altered, of another format or version, or of
//! another gear set is refused, and the message says which.

use serde::{Deserialize, Serialize};

use crate::dynamics::duty::LoadDuty;
use crate::model::gear::GearSet;
use crate::wear::state::{
    content_checksum, describe_differences, open_document, DocumentError, GearSetPrint,
};

/// The `format` name of the document.
pub const FORMAT: &str = "planetwear-duty-cycle";
/// The document version this build writes and reads.
pub const VERSION: u64 = 1;

/// A load duty with the gear set it was produced on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DutyCycle {
    /// The gear set the duty was run on.
    pub gear_set: GearSetPrint,
    /// What produced it (`simulate`, `fmu`, a campaign's name).
    pub source: String,
    /// The revolutions per mesh and bin.
    pub duty: LoadDuty,
}

/// Why a duty-cycle file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum DutyCycleError {
    /// The text is not a readable duty-cycle document.
    #[error("not a readable duty cycle: {0}")]
    Document(String),
    /// The content is not a valid duty.
    #[error("the duty cycle's content is not valid: {0}")]
    Invalid(String),
    /// The duty was produced on another gear set.
    #[error(
        "the duty cycle belongs to gear set '{found}' (fingerprint {found_fingerprint}), not to '{expected}' \
         (fingerprint {expected_fingerprint}): its loads and revolutions are another set's: {differences}"
    )]
    GearSet {
        /// The parameters that differ, in words.
        differences: String,
        /// The duty's set.
        found: String,
        /// Its fingerprint.
        found_fingerprint: String,
        /// This set.
        expected: String,
        /// This set's fingerprint.
        expected_fingerprint: String,
    },
}

fn document_error(e: DocumentError) -> DutyCycleError {
    DutyCycleError::Document(match e {
        DocumentError::NotJson { line, column, reason } => {
            format!("not a JSON document (line {line}, column {column}): {reason}")
        }
        DocumentError::Truncated { line, column } => {
            format!("the document is truncated: it ends at line {line}, column {column} before it is complete")
        }
        DocumentError::Format { found } => format!("format is {found}, not \"{FORMAT}\""),
        DocumentError::Version { found } => {
            format!("version {found} cannot be read by this build, which reads version {VERSION}")
        }
        DocumentError::NoContent => "the document has no \"content\"".into(),
        DocumentError::Checksum { stored, computed } => format!(
            "the checksum does not match the content (stored {stored}, computed {computed}): the file was altered or corrupted"
        ),
        DocumentError::NonFinite { field } => format!("{field} is not a finite number"),
    })
}

impl DutyCycle {
    /// The duty `duty` produced on `set` by `source`.
    pub fn new(set: &GearSet, source: &str, duty: LoadDuty) -> Self {
        Self { gear_set: GearSetPrint::of(set), source: source.to_string(), duty }
    }

    /// The checksum of its content (`fnv1a64:…`), the one its document carries: the duty's
    /// fingerprint.
    pub fn fingerprint(&self) -> String {
        serde_json::to_value(self).map_or_else(|_| String::new(), |v| content_checksum(&v))
    }

    /// The JSON document; a duty that does not add up ([`LoadDuty::check`]) is refused.
    pub fn to_json(&self) -> Result<String, DutyCycleError> {
        self.duty.check().map_err(|e| DutyCycleError::Invalid(e.to_string()))?;
        let content = serde_json::to_value(self).map_err(|e| DutyCycleError::Invalid(e.to_string()))?;
        let doc = serde_json::json!({
            "format": FORMAT,
            "version": VERSION,
            "checksum": content_checksum(&content),
            "content": content,
        });
        serde_json::to_string_pretty(&doc).map_err(|e| DutyCycleError::Invalid(e.to_string()))
    }

    /// Reads a document for `set`: refuses text that is not JSON or is cut short, another
    /// format or version, a checksum mismatch, a duty that does not add up, and a duty of
    /// another gear set (by its fingerprint).
    pub fn from_json(text: &str, set: &GearSet) -> Result<Self, DutyCycleError> {
        let content = open_document(text, FORMAT, VERSION).map_err(document_error)?;
        let cycle: DutyCycle =
            serde_json::from_value(content).map_err(|e| DutyCycleError::Invalid(e.to_string()))?;
        cycle.duty.check().map_err(|e| DutyCycleError::Invalid(e.to_string()))?;
        let here = GearSetPrint::of(set);
        let differences = cycle.gear_set.differences(&here);
        if here.fingerprint != cycle.gear_set.fingerprint && !differences.is_empty() {
            return Err(DutyCycleError::GearSet {
                differences: describe_differences(&differences),
                found: cycle.gear_set.name,
                found_fingerprint: cycle.gear_set.fingerprint,
                expected: here.name,
                expected_fingerprint: here.fingerprint,
            });
        }
        if cycle.duty.planets() != set.planet_angles().len() {
            return Err(DutyCycleError::Invalid(format!(
                "{} planets' meshes, the gear set has {}",
                cycle.duty.planets(),
                set.planet_angles().len()
            )));
        }
        Ok(cycle)
    }
}

/// Writes a duty cycle to `path` atomically (nothing is written when it is refused).
pub fn write_duty_cycle(path: &std::path::Path, cycle: &DutyCycle) -> Result<(), DutyFileError> {
    let text = cycle
        .to_json()
        .map_err(|source| DutyFileError::Content { path: path.to_path_buf(), source: Box::new(source) })?;
    crate::files::check_output_size(path, crate::files::InputKind::DutyCycle, text.len())?;
    Ok(crate::files::write_durable(path, text.as_bytes())?)
}

/// Reads the duty cycle at `path` for the gear set `set` ([`DutyCycle::from_json`]).
pub fn read_duty_cycle(path: &std::path::Path, set: &GearSet) -> Result<DutyCycle, DutyFileError> {
    let bytes = crate::files::read_input(path, crate::files::InputKind::DutyCycle)?;
    DutyCycle::from_json(&String::from_utf8_lossy(&bytes), set)
        .map_err(|source| DutyFileError::Content { path: path.to_path_buf(), source: Box::new(source) })
}

/// Why a duty-cycle file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum DutyFileError {
    /// The file system refused.
    #[error("duty-cycle file {0}")]
    Io(#[from] crate::files::FileError),
    /// The content was refused.
    #[error("duty-cycle file '{}': {source}", path.display())]
    Content {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        #[source]
        source: Box<DutyCycleError>,
    },
}
