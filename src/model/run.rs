//! The run settings, SI: how one run of a gear set's equations of motion is
//! integrated and sampled, and the input speed of a single run.
//!
//! They are not part of the [`GearSet`](crate::model::gear::GearSet): the set
//! is the dynamic system (geometry, bodies, supports, and every term of its
//! equations of motion: fidelity, mesh damping, drive, shaft stiffness), the
//! run settings are one way of running it. The same set is run with other
//! settings (the work-precision study's integrators, a tight reference
//! tolerance, the dynamic wear's finer sampling, the FMU's step settings)
//! without being built again; the input speed belongs here too because it
//! is an operating point, not a property of the system (steady states and
//! sweeps take theirs as an argument, this one is the default of a single
//! run).
//!
//! A [`RunSettings`] is built only by checking a [`RunValues`] against the
//! scene's rules for them ([`RunSettings::new`] or
//! [`crate::scene::Scene::validate_with_run`], both in
//! [`crate::model::build`]), each problem named by its scene key, so holding
//! one means it passed them; a changed one is made by
//! [`RunSettings::with`], which checks again.

use serde::Serialize;

use crate::scene::{IntegratorKind, Response};

/// The values of the run settings, SI, not yet checked: what a caller fills
/// in or changes before [`RunSettings::new`] or [`RunSettings::with`] checks
/// them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RunValues {
    /// Input member speed of a single run [rad/s].
    pub input_speed: f64,
    /// Integrator.
    pub integrator: IntegratorKind,
    /// Generalized-α spectral radius at infinity [-].
    pub rho_infinity: f64,
    /// Generalized-α steps per mesh cycle.
    pub steps_per_mesh_cycle: usize,
    /// Adaptive method's relative tolerance [-].
    pub relative_tolerance: f64,
    /// Adaptive method's relative tolerance in the time-domain simulation
    /// (the FMU, `planetwear simulate`), whose error weight measures the
    /// state from the rigid-body motion [-].
    pub simulation_relative_tolerance: f64,
    /// Longest run-in [input revolutions].
    pub run_in_revolutions: f64,
    /// The run-in ends early once two successive mesh cycles agree to this
    /// fraction of the mean tooth force (0: always run the whole run-in).
    pub steady_tolerance: f64,
    /// Measured window [input revolutions].
    pub measured_revolutions: f64,
    /// Output samples per mesh cycle.
    pub samples_per_mesh_cycle: usize,
    /// How a time-domain run computes its tooth outputs.
    pub response: Response,
    /// The steady response's cache.
    pub steady: SteadyValues,
}

/// The steady response's cache grid (docs/STEADY.md), SI.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SteadyValues {
    /// Node spacing of input speed on the coarsest grid [rad/s].
    pub speed_step: f64,
    /// Node spacing of input torque on the coarsest grid [N·m].
    pub torque_step: f64,
    /// Lowest input speed solved [rad/s].
    pub speed_floor: f64,
    /// Largest interpolation error of a cell, of the static mesh load [-].
    pub agreement: f64,
    /// Halvings of a cell.
    pub refinements: u32,
    /// Offset of the output samples from the period's start, a fraction of the sample
    /// interval in [0, 1) (0 in a scene; the accuracy study sets its reference's).
    pub sample_phase: f64,
}

/// Checked run settings, SI (see the module documentation). Its values are
/// read through [`RunSettings::values`] or the accessors; it cannot be
/// deserialized or changed in place.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RunSettings {
    pub(in crate::model) values: RunValues,
}

impl RunSettings {
    /// The checked values.
    pub fn values(&self) -> &RunValues {
        &self.values
    }

    /// Input member speed of a single run [rad/s].
    pub fn input_speed(&self) -> f64 {
        self.values.input_speed
    }

    /// Integrator.
    pub fn integrator(&self) -> IntegratorKind {
        self.values.integrator
    }

    /// Generalized-α spectral radius at infinity [-].
    pub fn rho_infinity(&self) -> f64 {
        self.values.rho_infinity
    }

    /// Generalized-α steps per mesh cycle.
    pub fn steps_per_mesh_cycle(&self) -> usize {
        self.values.steps_per_mesh_cycle
    }

    /// Adaptive method's relative tolerance [-].
    pub fn relative_tolerance(&self) -> f64 {
        self.values.relative_tolerance
    }

    /// Adaptive method's relative tolerance in the time-domain simulation
    /// (the FMU, `planetwear simulate`), whose error weight measures the
    /// state from the rigid-body motion [-].
    pub fn simulation_relative_tolerance(&self) -> f64 {
        self.values.simulation_relative_tolerance
    }

    /// Longest run-in [input revolutions].
    pub fn run_in_revolutions(&self) -> f64 {
        self.values.run_in_revolutions
    }

    /// Fraction of the mean tooth force to which two successive mesh cycles
    /// must agree to end the run-in early (0: the whole run-in) [-].
    pub fn steady_tolerance(&self) -> f64 {
        self.values.steady_tolerance
    }

    /// Measured window [input revolutions].
    pub fn measured_revolutions(&self) -> f64 {
        self.values.measured_revolutions
    }

    /// Output samples per mesh cycle.
    pub fn samples_per_mesh_cycle(&self) -> usize {
        self.values.samples_per_mesh_cycle
    }

    /// How a time-domain run computes its tooth outputs.
    pub fn response(&self) -> Response {
        self.values.response
    }

    /// The steady response's cache grid.
    pub fn steady(&self) -> &SteadyValues {
        &self.values.steady
    }
}
