//! Reference results of the FMU for regression tests of models that embed
//! it (docs/REGRESSION.md): `resources/regression/example-2004.json` in the
//! FMU, written by `planetwear fmu pack`.
//!
//! For a few speeds and worn-profile states κ of the example, the file holds
//! the values of the FMU's windowed outputs (`window.*`: F^(1..6), F^(rms),
//! mean and separation of planet 1's sun–planet and ring–planet mesh force)
//! that a run of the FMU through the stated protocol must reproduce, each
//! with its tolerance. The values are computed natively by
//! [`order_tracked_windows`] at a tight tolerance: the quantity the FMU's
//! window estimates, without the window's interpolation between internal
//! steps. The tolerance of a case, as a fraction of its F^(1), is
//!
//! ```text
//! tol = MARGIN · (INTEGRATOR_ERROR + WINDOW_INTERPOLATION_ERROR + drift)
//! ```
//!
//! rounded up to two significant digits, with `drift` the case's own
//! E_h between the protocol's window and the window one input revolution
//! earlier (how much of the start's transient is left). F^(rms) may differ by
//! √6 · tol · F^(1) (the harmonics' bound carried through the root sum of
//! squares), the mean by tol · F^(1) (the DFT's term 0), the separation
//! fraction by one sample per mesh cycle.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use crate::analysis::order_tracking::{order_tracked_windows, WindowMeasure, HARMONICS};
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::Work;
use crate::fmi::variables::GUID;
use crate::model::gear::{GearSet, IntegratorKind};
use crate::model::run::RunSettings;
use crate::scene::Scene;
use crate::wear::state::WornState;

/// Format tag of the reference file; the Python kit refuses any other.
pub const FORMAT: &str = "planetwear-regression/1";
/// Where the file lies in the FMU archive.
pub const RESOURCE: &str = "resources/regression/example-2004.json";

/// E_h of RK 5(4) at relative tolerance 3e-6, the largest over the eight
/// operating points of the work-precision study (docs/ACCURACY.md).
pub const INTEGRATOR_ERROR: f64 = 7.0e-4;
/// The window's linear interpolation between internal grid points at
/// [`STEPS_PER_MESH_CYCLE`]: the largest E_h of the FMU at the protocol's
/// setting against these references over every case and the communication
/// steps of one mesh period, 0.822 and 0.37 of it (5.11e-4, high speed, the
/// integrator's share included), rounded up (docs/REGRESSION.md,
/// scripts/regression_budget.py; tests/python/test_regression.py checks it).
pub const WINDOW_INTERPOLATION_ERROR: f64 = 6.0e-4;
/// Safety factor on the error budget: a driver with another communication
/// step puts the internal grid elsewhere relative to the samples.
pub const MARGIN: f64 = 1.5;

/// The protocol's integrator: RK 5(4) (the FMU's `integrator` = 1).
pub const PROTOCOL_RELATIVE_TOLERANCE: f64 = 3e-6;
/// Internal grid points per mesh cycle in the protocol (`stepsPerMeshCycle`).
pub const STEPS_PER_MESH_CYCLE: u32 = 1920;
/// Run-in before the window [mesh cycles]: three input revolutions.
pub const RUN_IN_CYCLES: usize = 102;
/// Window of the harmonic outputs [mesh cycles]: two input revolutions.
pub const WINDOW_CYCLES: usize = 68;
/// The earlier window that measures the drift ends this much before the
/// protocol's [mesh cycles]: one input revolution.
pub const DRIFT_CYCLES: usize = 34;
/// Relative tolerance of the references' own run.
pub const REFERENCE_RELATIVE_TOLERANCE: f64 = 1e-8;

/// The cases: (κ, input speed \[rpm\]).
pub const CASES: [(usize, f64); 8] =
    [(0, 1500.0), (0, 3000.0), (0, 5000.0), (0, 14500.0), (3, 3000.0), (3, 5000.0), (6, 3000.0), (6, 5000.0)];

/// Why the references could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    /// The example's scene or a wear state was refused.
    #[error("{0}")]
    Setup(String),
    /// A run failed.
    #[error("case {case}: {reason}")]
    Run {
        /// Case name.
        case: String,
        /// Cause.
        reason: String,
    },
    /// The start's transient is not small enough for the error budget.
    #[error("case {case}: the window still drifts by {drift:.2e} of F1 after {RUN_IN_CYCLES} mesh cycles of run-in (allowed {allowed:.1e}): lengthen the run-in")]
    Unsettled {
        /// Case name.
        case: String,
        /// E_h between the protocol's window and the earlier one.
        drift: f64,
        /// Largest drift the budget accepts.
        allowed: f64,
    },
}

/// How a run of the FMU must be made to be compared with the references.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Protocol {
    /// What the protocol does, in words.
    pub description: String,
    /// FMU parameters set before initialization (name → value).
    pub parameters: BTreeMap<String, serde_json::Value>,
    /// FMU inputs held constant for the whole run (name → value).
    pub inputs: BTreeMap<String, f64>,
    /// Start time \[s\].
    pub start_time: f64,
    /// Communication step [mesh cycles] (doStep of one mesh period of the case's speed).
    pub communication_step_cycles: usize,
    /// Mesh cycles before the window.
    pub run_in_cycles: usize,
    /// Mesh cycles in the window (`harmonicWindowCycles`).
    pub window_cycles: usize,
    /// doStep calls in all: run-in plus window.
    pub total_cycles: usize,
}

/// How the reference values themselves were computed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceMethod {
    /// In words.
    pub description: String,
    /// Integrator.
    pub integrator: String,
    /// Its relative tolerance.
    pub relative_tolerance: f64,
}

/// The tolerance of a case and where it comes from (fractions of F^(1)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Budget {
    /// The integrator's error at the protocol's setting (docs/ACCURACY.md).
    pub integrator: f64,
    /// The window's interpolation error at the protocol's steps per mesh cycle.
    pub window_interpolation: f64,
    /// E_h between the case's window and the window one revolution earlier.
    pub drift: f64,
    /// Safety factor.
    pub margin: f64,
    /// The tolerance of each harmonic and of the mean, as a fraction of the mesh's F^(1).
    pub fraction_of_f1: f64,
}

/// One reference case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Case {
    /// Name, e.g. `kappa-0/3000rpm`.
    pub name: String,
    /// Worn-profile state: wear updates applied.
    pub kappa: usize,
    /// Input (sun) speed \[rpm\].
    pub speed_rpm: f64,
    /// Mesh frequency \[Hz\].
    pub mesh_frequency_hz: f64,
    /// The communication step: one mesh period \[s\].
    pub communication_step_s: f64,
    /// FMU parameters of this case (name → value), on top of the protocol's.
    pub parameters: BTreeMap<String, serde_json::Value>,
    /// Reference values of the FMU's outputs (name → value, in the outputs' units: N, or 1 for separation).
    pub values: BTreeMap<String, f64>,
    /// Largest allowed |measured − reference| per output (same units).
    pub tolerance: BTreeMap<String, f64>,
    /// Where the tolerance comes from.
    pub budget: Budget,
    /// Integrator work of the reference run.
    pub work: Work,
}

/// The reference file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct References {
    /// [`FORMAT`].
    pub format: String,
    /// The FMU's GUID (its variable interface) the references belong to.
    pub fmu_guid: String,
    /// planetwear version (the FMU's modelDescription `version`).
    pub planetwear_version: String,
    /// The scene: the FMU's default parameters.
    pub scene: String,
    /// The run every case follows.
    pub protocol: Protocol,
    /// How the values were computed.
    pub reference: ReferenceMethod,
    /// The cases.
    pub cases: Vec<Case>,
}

impl References {
    /// Pretty JSON text.
    pub fn to_json(&self) -> Result<String, ReferenceError> {
        serde_json::to_string_pretty(self).map_err(|e| ReferenceError::Setup(e.to_string()))
    }
}

/// Rounds up to two significant digits.
fn round_up(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return x;
    }
    let scale = 10f64.powf(x.log10().floor() - 1.0);
    (x / scale - 1e-9).ceil() * scale
}

/// The output names of one mesh's quantities.
fn outputs(mesh: &str) -> Vec<String> {
    let mut names: Vec<String> = (1..=HARMONICS).map(|k| format!("window.{mesh}MeshF{k}")).collect();
    names.push(format!("window.{mesh}MeshFrms"));
    names.push(format!("window.{mesh}MeshMean"));
    names.push(format!("window.{mesh}Separation"));
    names
}

fn put(
    values: &mut BTreeMap<String, f64>,
    tolerance: &mut BTreeMap<String, f64>,
    mesh: &str,
    w: &WindowMeasure,
    fraction: f64,
    samples_per_cycle: usize,
) {
    let (h, sep) = if mesh == "sun" { (&w.sun, w.sun_separation) } else { (&w.ring, w.ring_separation) };
    let f1 = h.amplitude[0];
    let names = outputs(mesh);
    for (k, a) in h.amplitude.iter().enumerate() {
        values.insert(names[k].clone(), *a);
        tolerance.insert(names[k].clone(), fraction * f1);
    }
    values.insert(names[HARMONICS].clone(), h.rms);
    tolerance.insert(names[HARMONICS].clone(), (HARMONICS as f64).sqrt() * fraction * f1);
    values.insert(names[HARMONICS + 1].clone(), h.mean);
    tolerance.insert(names[HARMONICS + 1].clone(), fraction * f1);
    values.insert(names[HARMONICS + 2].clone(), sep);
    tolerance.insert(names[HARMONICS + 2].clone(), 1.0 / samples_per_cycle as f64);
}

/// E_h between two windows: max over the meshes of max_k |ΔA_k| / A_1 of the first.
pub fn window_error(a: &WindowMeasure, b: &WindowMeasure) -> f64 {
    [(&a.sun, &b.sun), (&a.ring, &b.ring)]
        .iter()
        .map(|(x, y)| {
            x.amplitude.iter().zip(&y.amplitude).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max)
                / x.amplitude[0]
        })
        .fold(0.0, f64::max)
}

/// Computes the references of `cases` ((κ, rpm)) of the example, with
/// `states` the JSON texts of its worn-profile states κ = 0, 1, … as the FMU
/// ships them (`wear/example-2004/kappa-<κ>.json`), at relative tolerance
/// `rtol`; the cases run in parallel.
pub fn example_references(
    states: &[String],
    cases: &[(usize, f64)],
    rtol: f64,
) -> Result<References, ReferenceError> {
    scene_references(&Scene::example_2004(), "wear/example-2004", states, cases, rtol)
}

/// Computes the references of `cases` ((κ, rpm)) of `scene`, the default
/// set of the FMU they ship in, with `states` the JSON texts of its
/// worn-profile states κ = 0, 1, … as the FMU ships them in
/// `resources/<state_dir>/kappa-<κ>.json`, at relative tolerance `rtol`; the
/// cases run in parallel.
pub fn scene_references(
    scene: &Scene,
    state_dir: &str,
    states: &[String],
    cases: &[(usize, f64)],
    rtol: f64,
) -> Result<References, ReferenceError> {
    if !(rtol.is_finite() && rtol > 0.0 && rtol <= 1e-6) {
        return Err(ReferenceError::Setup(format!(
            "relative tolerance {rtol}: the references need a tight setting, at most 1e-6"
        )));
    }
    let mut scene = scene.clone();
    scene.dynamics.integrator = IntegratorKind::Rk45;
    scene.dynamics.relative_tolerance = rtol;
    let (set, run_settings) = scene.validate_with_run().map_err(|e| ReferenceError::Setup(e.to_string()))?;
    let samples = run_settings.samples_per_mesh_cycle();
    let computed: Vec<Case> = cases
        .par_iter()
        .map(|&case| reference_case((&set, &run_settings), (state_dir, states), case))
        .collect::<Result<_, _>>()?;
    Ok(References {
        format: FORMAT.into(),
        fmu_guid: GUID.into(),
        planetwear_version: env!("CARGO_PKG_VERSION").into(),
        scene: set.name().to_string(),
        protocol: protocol(&set, samples),
        reference: ReferenceMethod {
            description: "The same initial-value problem (balanced torques), integrated by RK 5(4) at a tight \
                          tolerance; each sample taken at the exact crossing of the sun mesh's travel with the \
                          window's grid on the dense output (no interpolation between grid points): the value \
                          the FMU's window converges to as stepsPerMeshCycle grows."
                .into(),
            integrator: "rk45".into(),
            relative_tolerance: rtol,
        },
        cases: computed,
    })
}

/// The reference of one case (κ, rpm) of the gear set under its run settings (`setup`),
/// its worn-profile state from `states` as the FMU ships them in `state_dir`: the
/// order-tracked window after the run-in, refused where the window still drifts; its
/// values and tolerances from the error budget.
fn reference_case(
    (set, run_settings): (&GearSet, &RunSettings),
    (state_dir, states): (&str, &[String]),
    (kappa, rpm): (usize, f64),
) -> Result<Case, ReferenceError> {
    let samples = run_settings.samples_per_mesh_cycle();
    let allowed_drift = 0.25 * (INTEGRATOR_ERROR + WINDOW_INTERPOLATION_ERROR);
    let name = format!("kappa-{kappa}/{rpm:.0}rpm");
    let run_error = |reason: String| ReferenceError::Run { case: name.clone(), reason };
    let text = states.get(kappa).ok_or_else(|| {
        run_error(format!("κ = {kappa}: only states 0..{} are shipped", states.len().saturating_sub(1)))
    })?;
    let state = WornState::from_json(text, set).map_err(|e| run_error(e.to_string()))?;
    let mut model =
        PlanetaryDynamics::new(set, state.set_model(set)).map_err(|e| run_error(e.to_string()))?;
    let omega = crate::scene::units::rpm_to_rad_per_s(rpm);
    let end = RUN_IN_CYCLES + WINDOW_CYCLES;
    let run = order_tracked_windows(
        set,
        run_settings,
        &mut model,
        omega,
        WINDOW_CYCLES,
        samples,
        &[end, end - DRIFT_CYCLES],
    )
    .map_err(|e| run_error(e.to_string()))?;
    let (window, later) = (&run.windows[0], &run.windows[1]);
    let drift = window_error(window, later);
    if drift > allowed_drift {
        return Err(ReferenceError::Unsettled { case: name, drift, allowed: allowed_drift });
    }
    let fraction = round_up(MARGIN * (INTEGRATOR_ERROR + WINDOW_INTERPOLATION_ERROR + drift));
    let (mut values, mut tolerance) = (BTreeMap::new(), BTreeMap::new());
    for mesh in ["sun", "ring"] {
        put(&mut values, &mut tolerance, mesh, window, fraction, samples);
    }
    let fm = model.mesh_frequency_per_input_speed * omega;
    let mut parameters = BTreeMap::new();
    parameters.insert("initialSpeed".to_string(), omega.into());
    parameters.insert("wearStateFile".to_string(), format!("{state_dir}/kappa-{kappa}.json").into());
    Ok(Case {
        name,
        kappa,
        speed_rpm: rpm,
        mesh_frequency_hz: fm,
        communication_step_s: 1.0 / fm,
        parameters,
        values,
        tolerance,
        budget: Budget {
            integrator: INTEGRATOR_ERROR,
            window_interpolation: WINDOW_INTERPOLATION_ERROR,
            drift,
            margin: MARGIN,
            fraction_of_f1: fraction,
        },
        work: run.work,
    })
}

/// The protocol the references hold for the FMU with the default `set`: its parameters
/// (`samples` per mesh cycle), the inputs at the set's balanced torques, and the steps.
fn protocol(set: &GearSet, samples: usize) -> Protocol {
    let mut parameters = BTreeMap::new();
    parameters.insert("driveMode".to_string(), 0.into());
    parameters.insert("integrator".to_string(), 1.into());
    parameters.insert("relativeTolerance".to_string(), PROTOCOL_RELATIVE_TOLERANCE.into());
    parameters.insert("stepsPerMeshCycle".to_string(), STEPS_PER_MESH_CYCLE.into());
    parameters.insert("samplesPerMeshCycle".to_string(), samples.into());
    parameters.insert("harmonicWindowCycles".to_string(), WINDOW_CYCLES.into());
    // The set's balanced torques: the FMU's start values of the inputs for
    // its default set (crate::fmi::instance::scene_values).
    let mut inputs = BTreeMap::new();
    for (name, torque) in ["sunTorque", "ringTorque", "carrierTorque"].into_iter().zip(set.balanced_torques())
    {
        inputs.insert(name.to_string(), torque);
    }
    Protocol {
        description: format!(
            "The FMU with its default parameters (the {} set) and the protocol's and the case's \
             parameters, instantiated, set up at t = 0 and initialized (the set starts from the static \
             deflection at initialSpeed); the inputs held at the values given; doStep of one mesh period \
             of the case's speed, {} times ({RUN_IN_CYCLES} cycles of run-in, then the {WINDOW_CYCLES}-cycle \
             window); then the window.* outputs are read.",
            set.name(),
            RUN_IN_CYCLES + WINDOW_CYCLES
        ),
        parameters,
        inputs,
        start_time: 0.0,
        communication_step_cycles: 1,
        run_in_cycles: RUN_IN_CYCLES,
        window_cycles: WINDOW_CYCLES,
        total_cycles: RUN_IN_CYCLES + WINDOW_CYCLES,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_up_keeps_two_significant_digits_and_never_rounds_down() {
        assert_eq!(round_up(1.95e-3), 2.0e-3);
        assert_eq!(round_up(1.9e-3), 1.9e-3);
        assert!(round_up(1.901e-3) >= 1.901e-3);
        assert!((round_up(1.901e-3) - 2.0e-3).abs() < 1e-15);
        for x in [3.3e-4, 7.77e-3, 0.123, 12.3] {
            let r = round_up(x);
            assert!(r >= x * (1.0 - 1e-12) && r <= x * 1.1, "{x} -> {r}");
        }
    }
}
