//! Why a study of the published example could not be computed: the error
//! of the stage that failed, with where in the study it failed.

use crate::analysis::continuation::ContinuationError;
use crate::dynamics::equations::DynamicsError;
use crate::dynamics::periodic::PeriodicError;
use crate::dynamics::response::ResponseError;
use crate::dynamics::spectrum::SpectrumError;
use crate::scene::SceneError;
use crate::wear::archard::WearError;

/// Why a study of the published example (validation, wear effect) failed.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The scene (or a variant of it) is not valid.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The dynamic model could not be built.
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    /// The wear model failed.
    #[error(transparent)]
    Wear(#[from] WearError),
    /// A time-domain response failed.
    #[error(transparent)]
    Response(#[from] ResponseError),
    /// A periodic state could not be found.
    #[error(transparent)]
    Periodic(#[from] PeriodicError),
    /// A spectrum could not be taken.
    #[error(transparent)]
    Spectrum(#[from] SpectrumError),
    /// A continuation failed.
    #[error(transparent)]
    Continuation(#[from] ContinuationError),
    /// A result lacks what the study reads from it.
    #[error("{0}")]
    Incomplete(&'static str),
    /// One of the above, where in the study it happened (a speed, a variant).
    #[error("{at}: {source}")]
    At {
        /// Where: "3000 rpm", "spot check at 8500.0 rpm", a variant's key.
        at: String,
        /// What failed.
        #[source]
        source: Box<StudyError>,
    },
}

impl StudyError {
    /// This error, said to have happened at `at`.
    pub fn at(self, at: impl Into<String>) -> Self {
        StudyError::At { at: at.into(), source: Box::new(self) }
    }
}
