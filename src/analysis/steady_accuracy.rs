//! The error of the `steady` response (docs/STEADY.md, docs/ACCURACY.md): its harmonics
//! against the time-domain reference of the work-precision study ([`accuracy::reference`]),
//! at a node of its cache and in the middle of a cell, and its step outputs against the
//! time-domain simulation on speed ramps of increasing rate (where the quasi-steady
//! assumption breaks).

use std::time::Instant;

use crate::analysis::accuracy::{self, harmonic_error, AccuracyError, OperatingPoint, Protocol};
use crate::contact::ltca::SetModel;
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::simulation::{Simulation, SimulationError};
use crate::model::gear::{GearSet, MeshKind};
use crate::model::run::RunSettings;
use crate::scene::Response;

/// Mesh cycles of run-in of the reference: ten input revolutions of the example, so that
/// the reference is the periodic state the steady response computes (the work-precision
/// study's one revolution leaves a drift of up to 8e-3 at its resonant points).
pub const REFERENCE_RUN_IN_CYCLES: u32 = 340;

/// The steady cache's agreement in the ramps [-].
pub const RAMP_AGREEMENT: f64 = 5e-3;

/// Time at the ramp's first speed before it starts \[s\]: the load balance's speed
/// controller and the mesh modes settle.
pub const RAMP_SETTLE: f64 = 0.3;

/// Samples per mesh cycle on which both responses take a step's largest mesh force in the
/// ramps: the time domain's observation grid and the steady states' samples. The force
/// peaks sharply where a tooth pair enters contact; on the default 60–64 samples the two
/// grids miss that peak by different amounts, up to 0.10 of the static load at a constant
/// 2 600 rpm, a difference of the sampling and not of the response (docs/STEADY.md,
/// "Limits"). At 480 both read the peak to within 2e-4.
pub const RAMP_SAMPLES: usize = 480;

/// Why the study stopped.
#[derive(Debug, thiserror::Error)]
pub enum SteadyStudyError {
    /// The reference failed.
    #[error(transparent)]
    Reference(#[from] AccuracyError),
    /// The simulation failed.
    #[error("{point}: {source}")]
    Simulation {
        /// The operating point.
        point: String,
        /// Why.
        source: SimulationError,
    },
    /// A setting could not be used.
    #[error("{0}")]
    Settings(String),
}

/// The steady response's E_h at one operating point.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PointError {
    /// Operating point name.
    pub name: String,
    /// What it is.
    pub description: String,
    /// Input speed \[rpm\].
    pub rpm: f64,
    /// E_h at a node of the cache (the steady state itself).
    pub node: f64,
    /// E_h in the middle of a cell of the default grid (the interpolation).
    pub interpolated: f64,
    /// The cache's own estimate of the interpolation error there (NaN: none).
    pub estimate: f64,
    /// Separation fraction of planet 1's sun and ring mesh: reference, steady node.
    pub separation: [[f64; 2]; 2],
    /// CPU seconds: the reference, the steady response's first state (cold).
    pub seconds: [f64; 2],
}

fn steady_run(
    run: &RunSettings,
    change: impl FnOnce(&mut crate::model::run::RunValues),
) -> Result<RunSettings, SteadyStudyError> {
    run.with(|v| {
        v.response = Response::Steady;
        v.samples_per_mesh_cycle = 64;
        // The reference's sample grid, so that both alias the mesh force's high harmonics
        // alike (60 to 64 samples per mesh cycle alias harmonics 59 to 69 onto 1 to 6).
        v.steady.sample_phase = Protocol::default().sample_phase;
        change(v);
    })
    .map_err(|e| SteadyStudyError::Settings(e.to_string()))
}

/// Planet 1's window harmonics of a steady simulation of `set` at `speed` [rad/s].
fn steady_harmonics(
    set: &GearSet,
    run: &RunSettings,
    speed: f64,
    name: &str,
) -> Result<(Vec<crate::dynamics::spectrum::Harmonics>, [f64; 2], f64, f64), SteadyStudyError> {
    let err = |source| SteadyStudyError::Simulation { point: name.to_string(), source };
    let model = PlanetaryDynamics::new(set, SetModel::new(set))
        .map_err(|e| SteadyStudyError::Settings(e.to_string()))?;
    let started = Instant::now();
    let mut sim = Simulation::new(set, run, model, 0.0, speed).map_err(err)?;
    sim.use_steady(None).map_err(err)?;
    let seconds = started.elapsed().as_secs_f64();
    let estimate = sim.steady().map_or(f64::NAN, |e| e.blend().estimate);
    let mut harmonics = Vec::new();
    let mut separation = [0.0; 2];
    for (k, mesh) in MeshKind::ALL.into_iter().enumerate() {
        let (h, s) =
            sim.window_harmonics(mesh).ok_or_else(|| SteadyStudyError::Settings("no window".into()))?;
        harmonics.push(h);
        separation[k] = s;
    }
    Ok((harmonics, separation, estimate, seconds))
}

/// E_h of the steady response at `point`, against the reference at relative tolerance
/// `tolerance` after [`REFERENCE_RUN_IN_CYCLES`] mesh cycles.
pub fn point_error(point: &OperatingPoint, tolerance: f64) -> Result<PointError, SteadyStudyError> {
    let protocol = Protocol { run_in_cycles: REFERENCE_RUN_IN_CYCLES, ..Protocol::default() };
    let model = PlanetaryDynamics::new(&point.set, SetModel::new(&point.set))
        .map_err(|e| SteadyStudyError::Settings(e.to_string()))?;
    let started = Instant::now();
    let reference = accuracy::reference(&model, point.speed, &protocol, tolerance)?;
    let reference_seconds = started.elapsed().as_secs_f64();
    let torque = point.set.input_torque().abs();
    // A node: the grid's speed origin at the point, its torque a whole number of nodes.
    let at_node = steady_run(&point.run, |v| v.steady.speed_floor = point.speed)?;
    let (node, separation, _, seconds) = steady_harmonics(&point.set, &at_node, point.speed, &point.name)?;
    // The middle of a finest cell of the default grid's spacing: half a finest step off a
    // node in speed and in torque.
    let defaults = point.run.values().steady;
    let finest = f64::from(1u32 << defaults.refinements);
    let (speed_step, nodes) =
        (defaults.speed_step, (torque / (defaults.torque_step / finest)).round().max(1.0));
    let mid = steady_run(&point.run, |v| {
        v.steady.speed_floor = point.speed - 0.5 * speed_step / finest;
        v.steady.torque_step = torque / (nodes + 0.5) * finest;
    })?;
    let (interpolated, _, estimate, _) = steady_harmonics(&point.set, &mid, point.speed, &point.name)?;
    let r = &reference.measured;
    Ok(PointError {
        name: point.name.clone(),
        description: point.description.clone(),
        rpm: crate::scene::units::rad_per_s_to_rpm(point.speed),
        node: harmonic_error(&node, &r.harmonics),
        interpolated: harmonic_error(&interpolated, &r.harmonics),
        estimate,
        separation: [[r.separation[0], r.separation[1]], separation],
        seconds: [reference_seconds, seconds],
    })
}

/// The steady response against the time-domain simulation on one speed ramp.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RampError {
    /// Ramp duration \[s\].
    pub seconds: f64,
    /// Speed change per mesh cycle over the speed, at the ramp's mean speed [-].
    pub relative_change_per_cycle: f64,
    /// The largest difference of planet 1's sun–planet largest mesh force over a step
    /// between the two, over the static mesh load [-].
    pub max_force_error: f64,
    /// The same, the mean over the ramp's steps [-].
    pub mean_force_error: f64,
}

/// Ramps of the input speed reference from `from` to `to` [rad/s] over each duration of
/// `durations` \[s\] at communication step `step` \[s\], under the torque drive with the load
/// balance, after [`RAMP_SETTLE`] at `from`: the steady response (its cache held to
/// [`RAMP_AGREEMENT`], so that the difference is the quasi-steady assumption's, not the
/// interpolation's) against the time-domain simulation (the set's run settings), both
/// observed on [`RAMP_SAMPLES`] per mesh cycle (so that it is not the sampling's either).
pub fn ramp_errors(
    set: &GearSet,
    run: &RunSettings,
    (from, to): (f64, f64),
    durations: &[f64],
    step: f64,
) -> Result<Vec<RampError>, SteadyStudyError> {
    let steady = steady_run(run, |v| {
        v.steady.agreement = RAMP_AGREEMENT;
        v.steady.refinements = 5;
        v.samples_per_mesh_cycle = RAMP_SAMPLES;
    })?;
    let time = run
        .with(|v| v.steps_per_mesh_cycle = RAMP_SAMPLES)
        .map_err(|e| SteadyStudyError::Settings(e.to_string()))?;
    let load = set.mesh_load_per_planet();
    let mesh_frequency_per_input_speed = PlanetaryDynamics::new(set, SetModel::new(set))
        .map_err(|e| SteadyStudyError::Settings(e.to_string()))?
        .mesh_frequency_per_input_speed;
    let mut out = Vec::new();
    for &duration in durations {
        let mut peaks = [Vec::new(), Vec::new()];
        for (k, run) in [&time, &steady].into_iter().enumerate() {
            let err =
                |source| SteadyStudyError::Simulation { point: format!("ramp of {duration} s"), source };
            let model = PlanetaryDynamics::new(set, SetModel::new(set))
                .map_err(|e| SteadyStudyError::Settings(e.to_string()))?;
            let mut sim = Simulation::new(set, run, model, 0.0, from).map_err(err)?;
            if k == 1 {
                sim.use_steady(None).map_err(err)?;
            }
            let settle = (RAMP_SETTLE / step).round() as usize;
            let steps = (duration / step).round().max(1.0) as usize;
            for i in 0..settle + steps {
                let t = i as f64 * step;
                let f = (i.saturating_sub(settle) + 1) as f64 / steps as f64;
                sim.set_speed_reference(if i < settle { from } else { from + f.min(1.0) * (to - from) })
                    .map_err(err)?;
                sim.do_step(t, step).map_err(err)?;
                if i >= settle {
                    peaks[k]
                        .push(sim.step_extremes().mesh(0, MeshKind::SunPlanet).map_or(f64::NAN, |e| e.max));
                }
            }
        }
        let errors: Vec<f64> = peaks[0].iter().zip(&peaks[1]).map(|(a, b)| (a - b).abs() / load).collect();
        let mean_speed = 0.5 * (from + to);
        let fm = mesh_frequency_per_input_speed * mean_speed.abs();
        out.push(RampError {
            seconds: duration,
            relative_change_per_cycle: (to - from).abs() / duration / fm / mean_speed,
            max_force_error: errors.iter().copied().fold(0.0, f64::max),
            mean_force_error: errors.iter().sum::<f64>() / errors.len().max(1) as f64,
        });
    }
    Ok(out)
}
