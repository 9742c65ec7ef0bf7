//! Steady-state response at a speed, and speed sweeps with continuation
//! (docs/MODEL.md §3).
//!
//! A run starts from a state (the previous speed's steady state, or the
//! static deflection of the mean-stiffness model), runs in for a number of
//! input revolutions, then records the mesh forces over a window of whole
//! mesh cycles at a fixed number of samples per cycle. The order spectrum of
//! each mesh force gives F^(1..6), F^(rms) and the mean; the separation
//! fraction is the share of samples with no tooth force. Continuation keeps
//! the elastic deflections and their rates and changes only the rigid-body
//! speed.

use nalgebra::DVector;
use serde::{Deserialize, Serialize};

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::solver::{
    GeneralizedAlpha, GeneralizedAlphaSettings, Rk45, Rk45Settings, SecondOrderSystem, SolverError, Stats,
};
use crate::dynamics::spectrum::{mesh_harmonics, separation_fraction, Harmonics, SpectrumError};
use crate::model::gear::{GearSet, IntegratorKind, MeshKind};
use crate::model::run::{RunSettings, RunValues};
use crate::scene::units::rad_per_s_to_rpm;

/// Integrator work of a run (a copy of the solver's counters).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Work {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps.
    pub rejected_steps: u64,
    /// Newton iterations.
    pub newton_iterations: u64,
    /// Evaluations of the force.
    pub rhs_evaluations: u64,
    /// Evaluations of the Jacobian.
    pub jacobian_evaluations: u64,
    /// Contact events located.
    pub events_located: u64,
}

impl From<Stats> for Work {
    fn from(s: Stats) -> Self {
        Self {
            steps: s.steps,
            rejected_steps: s.rejected_steps,
            newton_iterations: s.newton_iterations,
            rhs_evaluations: s.rhs_evaluations,
            jacobian_evaluations: s.jacobian_evaluations,
            events_located: s.events_located,
        }
    }
}

/// Errors of a response computation.
#[derive(Debug, thiserror::Error)]
pub enum ResponseError {
    /// The integrator failed (non-finite state, Newton divergence, step too small).
    #[error("integration failed at {} rpm: {source}", rad_per_s_to_rpm(*.speed))]
    Integration {
        /// Input speed [rad/s].
        speed: f64,
        /// The integrator's error.
        source: SolverError,
    },
    /// The spectrum could not be formed.
    #[error("spectrum at {} rpm: {source}", rad_per_s_to_rpm(*.speed))]
    Spectrum {
        /// Input speed [rad/s].
        speed: f64,
        /// Cause.
        source: SpectrumError,
    },
    /// A request that cannot be met.
    #[error("{name} = {value}: {reason}")]
    InvalidRequest {
        /// Name.
        name: String,
        /// Value.
        value: String,
        /// What is allowed.
        reason: String,
    },
}

/// State of the model at an instant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// Input speed the state belongs to [rad/s].
    pub input_speed: f64,
    /// Coordinates.
    pub q: Vec<f64>,
    /// Velocities.
    pub v: Vec<f64>,
}

/// Response measures of one mesh at one speed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshResponse {
    /// Planet index.
    pub planet: usize,
    /// Which mesh.
    pub mesh: MeshKind,
    /// Mean and harmonics 1..6 of the mesh force \[N\].
    pub harmonics: Harmonics,
    /// Fraction of the window with no tooth force.
    pub separation: f64,
    /// Largest mesh force \[N\].
    pub max_force: f64,
}

/// The response measures of every mesh of `model` from its forces `force`
/// (one sampled series per mesh, spanning `cycles` whole mesh cycles).
pub fn mesh_responses(
    model: &PlanetaryDynamics,
    force: &[Vec<f64>],
    cycles: usize,
) -> Result<Vec<MeshResponse>, SpectrumError> {
    force
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let (planet, mesh) = model.mesh_identity(i);
            Ok(MeshResponse {
                planet,
                mesh,
                harmonics: mesh_harmonics(f, cycles, 6)?,
                separation: separation_fraction(f),
                max_force: f.iter().cloned().fold(0.0, f64::max),
            })
        })
        .collect()
}

/// Steady-state response at one speed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SteadyState {
    /// Input speed [rad/s] (written in files in rpm, as `input_speed_rpm`).
    #[serde(rename = "input_speed_rpm", with = "crate::scene::units::rpm")]
    pub input_speed: f64,
    /// Mesh frequency \[Hz\].
    pub mesh_frequency: f64,
    /// Mean speed of the input member over the window, from its rotation [rad/s].
    pub mean_input_speed: f64,
    /// Mesh cycles in the window.
    pub cycles: usize,
    /// Sample times in the window \[s\].
    pub time: Vec<f64>,
    /// Mesh forces \[N\]: `mesh_force[mesh][sample]` (planet-major, sun then ring).
    pub mesh_force: Vec<Vec<f64>>,
    /// Measures per mesh.
    pub meshes: Vec<MeshResponse>,
    /// Integrator work for this speed.
    pub stats: Work,
    /// State at the end of the window.
    pub end: State,
}

#[derive(Clone)]
pub(crate) enum Stepper {
    Alpha(Box<GeneralizedAlpha>),
    Rk(Box<Rk45>),
}

impl Stepper {
    pub(crate) fn new(run: &RunSettings, mesh_period: f64) -> Result<Self, SolverError> {
        let d = run.values();
        Ok(match d.integrator {
            IntegratorKind::GeneralizedAlpha => {
                let mut s = GeneralizedAlphaSettings::chung_hulbert(d.rho_infinity)?;
                // Rotation coordinates grow without bound: a tight relative
                // tolerance keeps the elastic part converged to ~1e-13 m.
                s.rtol = 1e-13;
                s.atol = 1e-13;
                s.max_iterations = 25;
                s.min_step = mesh_period * 1e-6;
                Stepper::Alpha(Box::new(GeneralizedAlpha::new(s)?))
            }
            IntegratorKind::Rk45 => {
                let s = Rk45Settings {
                    rtol: d.relative_tolerance,
                    atol_q: d.relative_tolerance * 1e-6,
                    atol_v: d.relative_tolerance * 1e-3,
                    max_step: mesh_period / 4.0,
                    ..Rk45Settings::default()
                };
                Stepper::Rk(Box::new(Rk45::new(s)?))
            }
        })
    }

    pub(crate) fn init(
        &mut self,
        sys: &mut PlanetaryDynamics,
        t: f64,
        q: &[f64],
        v: &[f64],
    ) -> Result<(), SolverError> {
        match self {
            Stepper::Alpha(a) => a.init(sys, t, q, v),
            Stepper::Rk(r) => r.init(sys, t, q, v),
        }
    }

    pub(crate) fn advance(
        &mut self,
        sys: &mut PlanetaryDynamics,
        t_end: f64,
        steps: u64,
    ) -> Result<(), SolverError> {
        match self {
            Stepper::Alpha(a) => a.advance(sys, t_end, steps),
            Stepper::Rk(r) => r.advance_to(sys, t_end),
        }
    }

    /// The integrator's own extra state: generalized-α's algorithmic
    /// acceleration; the adaptive method's step controller (three numbers).
    pub(crate) fn internal(&self) -> Vec<f64> {
        match self {
            Stepper::Alpha(a) => a.a().to_vec(),
            Stepper::Rk(r) => r.controller_state().to_vec(),
        }
    }

    /// Restores a state with the integrator's extra state (see `internal`).
    pub(crate) fn restore(
        &mut self,
        sys: &mut PlanetaryDynamics,
        t: f64,
        q: &[f64],
        v: &[f64],
        internal: &[f64],
    ) -> Result<(), SolverError> {
        match self {
            Stepper::Alpha(a) if internal.len() == q.len() => a.restore(sys, t, q, v, internal),
            Stepper::Rk(r) => match <[f64; 3]>::try_from(internal) {
                Ok(controller) => r.restore(sys, t, q, v, &controller),
                Err(_) => r.init(sys, t, q, v),
            },
            _ => self.init(sys, t, q, v),
        }
    }

    /// The system's forces changed at the current state (new external
    /// torques): the adaptive method re-evaluates the derivative it carries
    /// from its last stage (first-same-as-last), keeping its step
    /// controller; generalized-α needs nothing (its force at the step start
    /// enters the scheme as the old load).
    pub(crate) fn forces_changed(&mut self, sys: &mut PlanetaryDynamics) -> Result<(), SolverError> {
        match self {
            Stepper::Alpha(_) => Ok(()),
            Stepper::Rk(r) => {
                let (t, q, v, c) = (r.time(), r.q().to_vec(), r.v().to_vec(), r.controller_state());
                r.restore(sys, t, &q, &v, &c)
            }
        }
    }

    /// Time of the last accepted step \[s\].
    pub(crate) fn time(&self) -> f64 {
        match self {
            Stepper::Alpha(a) => a.time(),
            Stepper::Rk(r) => r.time(),
        }
    }

    pub(crate) fn state(&self) -> (&[f64], &[f64]) {
        match self {
            Stepper::Alpha(a) => (a.q(), a.v()),
            Stepper::Rk(r) => (r.q(), r.v()),
        }
    }

    pub(crate) fn stats(&self) -> Work {
        match self {
            Stepper::Alpha(a) => Work::from(*a.stats()),
            Stepper::Rk(r) => Work::from(*r.stats()),
        }
    }
}

/// The static deflection of the mean-stiffness model under the external
/// loads, with the free rigid-body rotation pinned by a penalty along it.
pub fn static_state(model: &PlanetaryDynamics, input_speed: f64) -> State {
    let n = model.dim();
    let mut k = model.lumped.stiffness();
    let r = DVector::from_vec(model.rigid_velocity.clone());
    let m = DVector::from_vec(model.mass().to_vec());
    let mr = m.component_mul(&r);
    let scale = k.diagonal().max().max(1.0) / mr.norm_squared().max(f64::MIN_POSITIVE);
    k += &mr * mr.transpose() * scale;
    let mut f = vec![0.0; n];
    let zeros = vec![0.0; n];
    model.external_force(&mut f);
    let q = k.lu().solve(&DVector::from_vec(f)).map(|x| x.as_slice().to_vec()).unwrap_or(zeros);
    State { input_speed, q, v: model.rigid_velocity_at(input_speed) }
}

/// Steady-state response at input speed `omega` [rad/s], continuing from
/// `start` when given, run and sampled as `run` sets.
pub fn steady_state(
    model: &mut PlanetaryDynamics,
    set: &GearSet,
    run: &RunSettings,
    omega: f64,
    start: Option<&State>,
) -> Result<SteadyState, ResponseError> {
    steady_state_observed(model, set, run, omega, start, |_, _| {})
}

/// [`steady_state`], calling `observe(k, model)` at every sample k of the
/// window (k = 0 .. cycles × samples per mesh cycle) with the model's mesh
/// states ([`PlanetaryDynamics::meshes`]: each mesh's reference position and
/// approach) evaluated at that sample, so a caller can read more than the
/// mesh forces (the wear model reads each tooth pair's load).
pub fn steady_state_observed(
    model: &mut PlanetaryDynamics,
    set: &GearSet,
    run: &RunSettings,
    omega: f64,
    start: Option<&State>,
    observe: impl FnMut(usize, &PlanetaryDynamics),
) -> Result<SteadyState, ResponseError> {
    steady_state_windowed(model, set, run, omega, start, Window::Fixed, observe)
}

/// How long the measured window of a steady state is.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "window", rename_all = "snake_case")]
pub enum Window {
    /// The run settings' measured revolutions, always (the default).
    #[default]
    Fixed,
    /// `cycles` mesh cycles when the run-in reaches a state periodic in one
    /// mesh cycle: the mesh forces at three successive cycle boundaries
    /// agree to `tolerance` of the mean tooth force (the run settings' own
    /// test also compares the approach rates, which carry the integrator's
    /// error in the absolute velocities and rarely settle below 1e-5 at the
    /// default tolerance), the run settings' window otherwise. The
    /// mesh-order harmonics of a signal with the mesh period are the same
    /// over one mesh cycle as over many, so this only cuts the cost of a
    /// periodic point; a point whose run-in did not settle keeps the whole
    /// window.
    Periodic {
        /// Mesh cycles measured at a periodic point (at least 1).
        cycles: usize,
        /// Agreement of successive cycles, as a fraction of the mean tooth
        /// force \[1\].
        tolerance: f64,
    },
}

/// [`steady_state_observed`] with the window chosen by `window`.
pub fn steady_state_windowed(
    model: &mut PlanetaryDynamics,
    set: &GearSet,
    run: &RunSettings,
    omega: f64,
    start: Option<&State>,
    window: Window,
    mut observe: impl FnMut(usize, &PlanetaryDynamics),
) -> Result<SteadyState, ResponseError> {
    let fm = model.mesh_frequency_per_input_speed * omega.abs();
    if !(fm.is_finite() && fm > 0.0) {
        return Err(ResponseError::InvalidRequest {
            name: "input speed".into(),
            value: format!("{} rpm", rad_per_s_to_rpm(omega)),
            reason: "must be non-zero and finite: the steady state is measured over mesh cycles".into(),
        });
    }
    let schedule = Schedule::new(model, run.values(), fm);
    let err = |source| ResponseError::Integration { speed: omega, source };
    let (q0, v0) = initial_state(model, omega, start);
    model.set_drive_speed(omega);
    model.rebase_drive(&q0);
    let mut stepper = Stepper::new(run, schedule.period).map_err(err)?;
    stepper.init(model, 0.0, &q0, &v0).map_err(err)?;
    let (t_run, cycles) = run_in(model, &mut stepper, set, run.values(), &schedule, window).map_err(err)?;
    let input_start = stepper.state().0[model.input_index];
    let t_end = t_run + cycles as f64 * schedule.period;
    let (time, force) =
        sample_window(model, &mut stepper, &schedule, (t_run, cycles), &mut observe).map_err(err)?;
    // Close the window so the end state is one full cycle set later.
    if stepper.time() < t_end {
        stepper.advance(model, t_end, schedule.steps_per_sample).map_err(err)?;
    }
    let (q, v) = stepper.state();
    let end = State { input_speed: omega, q: q.to_vec(), v: v.to_vec() };
    let mean_input_speed = (end.q[model.input_index] - input_start) / (t_end - t_run) / model.input_lever;
    let meshes = mesh_responses(model, &force, cycles)
        .map_err(|source| ResponseError::Spectrum { speed: omega, source })?;
    Ok(SteadyState {
        input_speed: omega,
        mesh_frequency: fm,
        mean_input_speed,
        cycles,
        time,
        mesh_force: force,
        meshes,
        stats: stepper.stats(),
        end,
    })
}

/// The time grid of a steady state at mesh frequency `fm` \[Hz\] under the run settings:
/// the mesh period, the run-in and the window in mesh cycles, and the samples.
struct Schedule {
    /// The mesh period \[s\].
    period: f64,
    /// Most mesh cycles of run-in.
    run_in_cycles: u64,
    /// Mesh cycles of the run settings' window.
    cycles: usize,
    /// Samples per mesh cycle.
    samples: usize,
    /// Fixed steps per mesh cycle, and per sample.
    steps_per_mesh_cycle: u64,
    steps_per_sample: u64,
}

impl Schedule {
    fn new(model: &PlanetaryDynamics, d: &RunValues, fm: f64) -> Self {
        let cycles_per_rev = model.mesh_frequency_per_input_speed * 2.0 * std::f64::consts::PI;
        let samples = d.samples_per_mesh_cycle;
        Self {
            period: 1.0 / fm,
            run_in_cycles: (d.run_in_revolutions * cycles_per_rev).ceil() as u64,
            cycles: ((d.measured_revolutions * cycles_per_rev).round() as usize).max(1),
            samples,
            steps_per_mesh_cycle: d.steps_per_mesh_cycle as u64,
            steps_per_sample: (d.steps_per_mesh_cycle as u64).div_ceil(samples as u64).max(1),
        }
    }
}

/// The state a steady state at `omega` [rad/s] starts from: `start` with its rigid-body
/// speed changed to `omega`, or the static deflection.
fn initial_state(model: &PlanetaryDynamics, omega: f64, start: Option<&State>) -> (Vec<f64>, Vec<f64>) {
    match start {
        Some(s) => {
            let dv = omega - s.input_speed;
            let v: Vec<f64> = s.v.iter().zip(&model.rigid_velocity).map(|(v, r)| v + r * dv).collect();
            (s.q.clone(), v)
        }
        None => {
            let s = static_state(model, omega);
            (s.q, s.v)
        }
    }
}

/// Run-in, one mesh cycle at a time. The excitation repeats every mesh cycle, so the
/// steady state does too: the run-in ends once the mesh forces and their rates (scaled to
/// forces by the mean stiffness over a mesh period) at two successive cycle boundaries
/// agree to `steady_tolerance` of the mean tooth force, or after the set number of
/// revolutions (a response that is not periodic in one mesh cycle, such as a subharmonic
/// one, runs the whole run-in). The time the run-in ended, and the window's mesh cycles:
/// the run settings', or the periodic window's where `window` asks for it and the forces
/// settled.
fn run_in(
    model: &mut PlanetaryDynamics,
    stepper: &mut Stepper,
    set: &GearSet,
    d: &RunValues,
    schedule: &Schedule,
    window: Window,
) -> Result<(f64, usize), SolverError> {
    let period = schedule.period;
    let mut cycles = schedule.cycles;
    let mut scratch = vec![0.0; model.dim()];
    let tolerance = d.steady_tolerance * set.mesh_load_per_planet().max(f64::MIN_POSITIVE);
    let rate_scale =
        model.lumped.sun_mesh.max(model.lumped.ring_mesh) * period / (2.0 * std::f64::consts::PI);
    let mut previous: Option<Vec<f64>> = None;
    let mut agreeing = 0;
    let mut forces_agreeing = 0;
    let mut t_run = 0.0;
    for c in 1..=schedule.run_in_cycles {
        t_run = c as f64 * period;
        stepper.advance(model, t_run, schedule.steps_per_mesh_cycle)?;
        if d.steady_tolerance <= 0.0 {
            continue;
        }
        let (q, v) = stepper.state();
        model.force(t_run, q, v, &mut scratch);
        let signature: Vec<f64> =
            model.meshes.iter().flat_map(|m| [m.force, m.approach_rate * rate_scale]).collect();
        if let Some(p) = &previous {
            let change = p.iter().zip(&signature).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            agreeing = if change <= tolerance { agreeing + 1 } else { 0 };
            if let Window::Periodic { tolerance: periodic, .. } = window {
                let forces =
                    p.iter().zip(&signature).step_by(2).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                let limit = periodic * set.mesh_load_per_planet().max(f64::MIN_POSITIVE);
                forces_agreeing = if forces <= limit { forces_agreeing + 1 } else { 0 };
            }
        }
        previous = Some(signature);
        if forces_agreeing >= 2 && c >= 4 {
            if let Window::Periodic { cycles: short, .. } = window {
                cycles = cycles.min(short.max(1));
            }
            break;
        }
        if agreeing >= 2 && c >= 4 {
            break;
        }
    }
    Ok((t_run, cycles))
}

/// The window of `cycles` mesh cycles from `t_run`, sampled at the schedule's samples per
/// cycle: the times and each mesh's force, `observe(k, model)` called at every sample k
/// with the model evaluated there.
fn sample_window(
    model: &mut PlanetaryDynamics,
    stepper: &mut Stepper,
    schedule: &Schedule,
    (t_run, cycles): (f64, usize),
    observe: &mut impl FnMut(usize, &PlanetaryDynamics),
) -> Result<(Vec<f64>, Vec<Vec<f64>>), SolverError> {
    let (period, samples) = (schedule.period, schedule.samples);
    let total = cycles * samples;
    let mut time = Vec::with_capacity(total);
    let mut force = vec![Vec::with_capacity(total); model.mesh_count()];
    let t_end = t_run + cycles as f64 * period;
    let n = model.dim();
    let mut scratch = vec![0.0; n];
    let (mut q_dense, mut v_dense) = (vec![0.0; n], vec![0.0; n]);
    for k in 0..total {
        let t = t_run + (k as f64) * period / samples as f64;
        let (q, v): (&[f64], &[f64]) = match &mut *stepper {
            // The adaptive method takes its own steps and the samples come
            // from its dense output (docs/ACCURACY.md measures it so).
            Stepper::Rk(r) if k > 0 => {
                while r.time() < t {
                    r.step(model, t_end)?;
                }
                r.dense_at(t, &mut q_dense, &mut v_dense)?;
                (&q_dense, &v_dense)
            }
            _ => {
                if k > 0 {
                    stepper.advance(model, t, schedule.steps_per_sample)?;
                }
                stepper.state()
            }
        };
        model.force(t, q, v, &mut scratch);
        if let Some(i) = scratch.iter().position(|x| !x.is_finite()) {
            return Err(SolverError::NonFiniteState { t, index: i });
        }
        time.push(t);
        for (m, state) in model.meshes.iter().enumerate() {
            force[m].push(state.force);
        }
        observe(k, model);
    }
    Ok((time, force))
}

/// A sweep's direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// Increasing speed.
    Up,
    /// Decreasing speed.
    Down,
}

/// Result of a sweep: one steady state per speed, in the order run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sweep {
    /// Direction.
    pub direction: Direction,
    /// Steady states (without time histories, which are dropped to save memory).
    pub points: Vec<SteadyState>,
}

/// Runs a continuation sweep over the input speeds `speeds` [rad/s] (in the
/// given order); calls `progress` after every point. Time histories are kept
/// only for the speeds listed in `keep_histories` [rad/s].
pub fn sweep(
    set: &GearSet,
    run: &RunSettings,
    model: &mut PlanetaryDynamics,
    direction: Direction,
    speeds: &[f64],
    keep_histories: &[f64],
    progress: impl FnMut(usize),
) -> Result<Sweep, ResponseError> {
    sweep_from(set, run, model, direction, speeds, keep_histories, Window::Fixed, None, progress)
}

/// [`sweep`] with the window of every point chosen by `window`, and the
/// first point started from `start` (a state of another sweep at a
/// neighbouring speed, to run a stretch of that sweep again entering it as
/// the sweep did) or, with `None`, from the static deflection.
#[allow(clippy::too_many_arguments)]
pub fn sweep_from(
    set: &GearSet,
    run: &RunSettings,
    model: &mut PlanetaryDynamics,
    direction: Direction,
    speeds: &[f64],
    keep_histories: &[f64],
    window: Window,
    start: Option<&State>,
    mut progress: impl FnMut(usize),
) -> Result<Sweep, ResponseError> {
    let mut points = Vec::with_capacity(speeds.len());
    let mut state: Option<State> = start.cloned();
    for (i, omega) in speeds.iter().enumerate() {
        let mut ss = steady_state_windowed(model, set, run, *omega, state.as_ref(), window, |_, _| {})?;
        state = Some(ss.end.clone());
        if !keep_histories.iter().any(|k| (k - omega).abs() <= 1e-9 * omega.abs().max(1.0)) {
            ss.time = Vec::new();
            ss.mesh_force = Vec::new();
        }
        points.push(ss);
        progress(i + 1);
    }
    Ok(Sweep { direction, points })
}
