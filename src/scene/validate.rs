//! What is wrong with a scene: each broken rule as a [`Problem`] naming the
//! parameter by its key in the scene file, its value and what is allowed.
//! The rules themselves are checked where the model is built from the
//! scene ([`crate::model::build`]).

use std::fmt;

use super::{units, ChamferSpec};

/// One broken rule of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// The parameter, as its key path in the scene file (`sun.tip_radius_mm`).
    pub name: String,
    /// The offending value, as written or derived.
    pub value: String,
    /// What is allowed, and why.
    pub reason: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} = {}: {}", self.name, self.value, self.reason)
    }
}

/// Why a scene cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The text is not a well-formed scene file.
    #[error("scene file is not valid TOML for a scene: {message}")]
    Syntax {
        /// The parser's message, with line and column.
        message: String,
    },
    /// One or more parameters break a rule.
    #[error("invalid scene:\n{}", .problems.iter().map(|p| format!("  - {p}")).collect::<Vec<_>>().join("\n"))]
    Invalid {
        /// Every problem found.
        problems: Vec<Problem>,
    },
}

impl SceneError {
    /// The problems of an invalid scene (empty for a syntax error).
    pub fn problems(&self) -> &[Problem] {
        match self {
            SceneError::Invalid { problems } => problems,
            SceneError::Syntax { .. } => &[],
        }
    }
}

/// Default tip chamfer of sun and planet of module `module` \[m\]
/// (docs/PARAMETERS.md): 0.1·m radial height at 45° to the tip circle, a
/// common edge break for hobbed and shaved automotive gears. The height is
/// the tenth of the module as the file writes it (in mm), so that a scene
/// with its defaults written out shows it as written.
pub fn default_chamfer(module: f64) -> ChamferSpec {
    ChamferSpec::new(units::mm_to_m(0.1 * units::m_to_mm(module)), units::deg_to_rad(45.0))
}
