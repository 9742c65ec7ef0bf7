//! Work-precision of the time integrators: how accurate the steady-state
//! mesh-force harmonics are for the CPU time and work an integrator setting
//! costs (issue 6; docs/ACCURACY.md).
//!
//! # The error measure
//!
//! Every method solves the same initial-value problem: the static deflection
//! of the mean-stiffness model at the speed ([`static_state`]) at t = 0, a
//! fixed number R of mesh cycles of run-in, then a window of C whole mesh
//! cycles. The mesh forces of planet 1 (its sun–planet and ring–planet mesh)
//! are sampled S times per mesh cycle in the window, at
//!
//! ```text
//! t_k = (R + (k + φ)/S) T,   k = 0 … S·C − 1,   T the mesh period,
//! ```
//!
//! and the amplitudes A_k of mesh harmonics k = 1 … 6 follow from the DFT of
//! the samples ([`mesh_harmonics`]). The phase φ = (√5 − 1)/2 of the sample
//! grid is irrational, so no sample falls on a step end of a fixed-step
//! method (step ends are rational fractions of T) and, with probability one,
//! on no contact event; the reference run records its located contact events
//! and reports the smallest distance of a sample from one
//! ([`Reference::closest_event`]). Samples are read from each method's own
//! interpolant: the Dormand–Prince dense output for the adaptive method, the
//! cubic Hermite interpolant of the step ends (q and q̇ at both ends, fourth
//! order, above the method's second order) for generalized-α. The mesh force
//! is the elastic tooth force, a continuous function of the coordinates.
//!
//! The error of a run against the reference is
//!
//! ```text
//! E_h = max over the two meshes of max_{k=1..6} |A_k − A_k,ref| / A_1,ref.
//! ```
//!
//! The reference is the adaptive method at a tight tolerance
//! ([`StudyPlan::reference_tolerance`]), confirmed by an integrator of
//! another code ([`IndependentIntegrator`], supplied by the caller).
//!
//! # Cost
//!
//! The CPU time of a run is the thread's CPU time from the initial state to
//! the window's end, interpolation of the samples included and the force
//! evaluations of the measurement excluded (they are the same for every
//! method), the median of [`StudyPlan::repeats`] repeats. Work is counted by
//! the integrators ([`Work`]).

use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{static_state, Stepper, Work};
use crate::dynamics::rigid_frame::RigidFrame;
use crate::dynamics::solver::{Rk45, Rk45Settings, SecondOrderSystem, SolverError, TangentSystem};
use crate::dynamics::spectrum::{mesh_harmonics, separation_fraction, Harmonics, SpectrumError};
use crate::model::gear::{GearSet, IntegratorKind};
use crate::model::lumped::Fidelity;
use crate::model::run::RunSettings;
use crate::scene::units::rad_per_s_to_rpm;
use crate::scene::SceneError;

/// Number of mesh harmonics in the error measure.
pub const HARMONICS: usize = 6;

/// Errors of a work-precision computation.
#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    /// A method's setting breaks the scene's rules for run settings.
    #[error("{method}: {source}")]
    Settings {
        /// The method and setting.
        method: String,
        /// The rules it breaks.
        source: SceneError,
    },
    /// An integrator failed.
    #[error("{method} at {} rpm: {source}", rad_per_s_to_rpm(*.speed))]
    Integration {
        /// The method and setting.
        method: String,
        /// Input speed [rad/s].
        speed: f64,
        /// The integrator's error.
        source: SolverError,
    },
    /// The harmonics could not be formed from the samples.
    #[error("{method} at {} rpm: {source}", rad_per_s_to_rpm(*.speed))]
    Spectrum {
        /// The method and setting.
        method: String,
        /// Input speed [rad/s].
        speed: f64,
        /// Cause.
        source: SpectrumError,
    },
    /// The independent integrator failed.
    #[error("independent integrator {name}: {message}")]
    Independent {
        /// Its name.
        name: String,
        /// What it reported.
        message: String,
    },
    /// A parameter of the study cannot be used.
    #[error("{name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter.
        name: String,
        /// Value.
        value: String,
        /// What is allowed.
        reason: String,
    },
}

/// How every run of the study is measured (the same for all methods).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Protocol {
    /// Mesh cycles of run-in from the static state before the window.
    pub run_in_cycles: u32,
    /// Whole mesh cycles in the measured window.
    pub window_cycles: u32,
    /// Samples per mesh cycle in the window (more than 12 for six harmonics).
    pub samples_per_cycle: u32,
    /// Offset of the sample grid from the cycle boundaries, as a fraction of
    /// the sample interval, in [0, 1) \[1\].
    pub sample_phase: f64,
}

impl Default for Protocol {
    /// One input revolution of run-in (34 mesh cycles in the example), a
    /// window of 8 mesh cycles, 64 samples per cycle at phase (√5 − 1)/2.
    fn default() -> Self {
        Self {
            run_in_cycles: 34,
            window_cycles: 8,
            samples_per_cycle: 64,
            sample_phase: 0.5 * (5.0f64.sqrt() - 1.0),
        }
    }
}

impl Protocol {
    fn check(&self) -> Result<(), AccuracyError> {
        let bad = |name: &str, value: String, reason: &str| {
            Err(AccuracyError::InvalidParameter { name: name.into(), value, reason: reason.into() })
        };
        if self.window_cycles == 0 {
            return bad("window_cycles", "0".into(), "the window needs at least one mesh cycle");
        }
        if (self.samples_per_cycle as usize) <= 2 * HARMONICS {
            return bad(
                "samples_per_cycle",
                self.samples_per_cycle.to_string(),
                "more than 12 samples per mesh cycle are needed for six harmonics",
            );
        }
        if !(0.0..1.0).contains(&self.sample_phase) {
            return bad("sample_phase", self.sample_phase.to_string(), "must lie in [0, 1)");
        }
        Ok(())
    }

    /// Sample times of the window for mesh period `period` \[s\].
    pub fn sample_times(&self, period: f64) -> Vec<f64> {
        let s = f64::from(self.samples_per_cycle);
        let r = f64::from(self.run_in_cycles);
        (0..self.samples_per_cycle * self.window_cycles)
            .map(|k| (r + (f64::from(k) + self.sample_phase) / s) * period)
            .collect()
    }

    /// End time of a run for mesh period `period` \[s\].
    pub fn end_time(&self, period: f64) -> f64 {
        f64::from(self.run_in_cycles + self.window_cycles) * period
    }
}

/// An integrator setting of the study.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "integrator", rename_all = "snake_case")]
pub enum Method {
    /// Generalized-α (Chung–Hulbert) with a fixed number of steps per mesh cycle.
    GeneralizedAlpha {
        /// Spectral radius at infinite frequency \[1\].
        rho_infinity: f64,
        /// Steps per mesh cycle.
        steps_per_mesh_cycle: u32,
    },
    /// Adaptive Dormand–Prince 5(4) with contact events.
    Rk45 {
        /// Relative tolerance \[1\].
        relative_tolerance: f64,
    },
}

impl Method {
    /// The family a setting belongs to (one curve of the study), e.g.
    /// "generalized-α ρ∞ = 0.9" or "RK 5(4)".
    pub fn family(&self) -> String {
        match self {
            Method::GeneralizedAlpha { rho_infinity, .. } => format!("generalized-α ρ∞ = {rho_infinity}"),
            Method::Rk45 { .. } => "RK 5(4)".into(),
        }
    }

    /// The setting within its family, e.g. "120 steps/cycle" or "rtol 1e-6".
    pub fn setting(&self) -> String {
        match self {
            Method::GeneralizedAlpha { steps_per_mesh_cycle, .. } => {
                format!("{steps_per_mesh_cycle} steps/cycle")
            }
            Method::Rk45 { relative_tolerance } => format!("rtol {}", short(*relative_tolerance)),
        }
    }

    /// Family and setting.
    pub fn label(&self) -> String {
        format!("{}, {}", self.family(), self.setting())
    }

    /// The run settings with this method as their integrator setting (the
    /// rest unchanged); a setting outside the scene's rules is refused.
    pub fn apply(&self, run: &RunSettings) -> Result<RunSettings, SceneError> {
        run.with(|d| match *self {
            Method::GeneralizedAlpha { rho_infinity, steps_per_mesh_cycle } => {
                d.integrator = IntegratorKind::GeneralizedAlpha;
                d.rho_infinity = rho_infinity;
                d.steps_per_mesh_cycle = steps_per_mesh_cycle as usize;
            }
            Method::Rk45 { relative_tolerance } => {
                d.integrator = IntegratorKind::Rk45;
                d.relative_tolerance = relative_tolerance;
            }
        })
    }
}

/// A tolerance in short scientific notation: 1e-6, 3e-6, 2.5e-7.
fn short(x: f64) -> String {
    let s = format!("{x:.1e}");
    s.replace(".0e", "e")
}

/// The mesh-force harmonics of one run and what it cost.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Measured {
    /// Harmonics of the sun–planet and the ring–planet mesh force of planet 1 \[N\].
    pub harmonics: Vec<Harmonics>,
    /// Fraction of the window's samples with no tooth force, per mesh \[1\].
    pub separation: Vec<f64>,
    /// Integrator work.
    pub work: Work,
    /// CPU time of the run (median of the repeats) \[s\].
    pub cpu_seconds: f64,
}

/// The study's reference solution at one operating point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Reference {
    /// Relative tolerance of the adaptive method \[1\].
    pub tolerance: f64,
    /// Its harmonics and cost.
    pub measured: Measured,
    /// Smallest distance between a sample time and a located contact event,
    /// as a fraction of the sample interval \[1\].
    pub closest_event: f64,
    /// Contact events located in the window.
    pub events_in_window: usize,
    /// Their times \[s\].
    #[serde(skip)]
    pub window_events: Vec<f64>,
}

/// What an independent integrator returns: the state at each requested time
/// and its work.
#[derive(Clone, Debug, PartialEq)]
pub struct IndependentSolution {
    /// Coordinates at each time [m or rad per coordinate].
    pub q: Vec<Vec<f64>>,
    /// Velocities at each time [m/s or rad/s per coordinate].
    pub v: Vec<Vec<f64>>,
    /// Accepted steps.
    pub steps: u64,
    /// Evaluations of the right-hand side.
    pub rhs_evaluations: u64,
}

/// An integrator from another code, used to confirm the reference: it solves
/// M q̈ = f(t, q, q̇) from (0, q0, v0) and returns the state at the given
/// increasing times (by its own dense output).
pub trait IndependentIntegrator {
    /// Name, method and tolerance, for the report.
    fn name(&self) -> String;
    /// Integrates `sys` and returns the states at `times` \[s\].
    fn solve(
        &self,
        sys: &mut dyn SecondOrderSystem,
        q0: &[f64],
        v0: &[f64],
        times: &[f64],
    ) -> Result<IndependentSolution, String>;
}

/// Agreement of the independent integrator with the reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Agreement {
    /// The independent integrator.
    pub name: String,
    /// E_h between it and the reference \[1\].
    pub error: f64,
    /// Its accepted steps.
    pub steps: u64,
    /// Its right-hand-side evaluations.
    pub rhs_evaluations: u64,
    /// Its CPU time \[s\].
    pub cpu_seconds: f64,
}

/// The thread's CPU time, or the wall clock where the system has no
/// per-thread CPU clock.
#[derive(Clone, Copy)]
enum Clock {
    Cpu(Duration),
    Wall(Instant),
}

impl Clock {
    fn now() -> Self {
        match cpu_time::ThreadTime::try_now() {
            Ok(t) => Clock::Cpu(t.as_duration()),
            Err(_) => Clock::Wall(Instant::now()),
        }
    }

    fn seconds_since(&self) -> f64 {
        match (self, Clock::now()) {
            (Clock::Cpu(a), Clock::Cpu(b)) => b.saturating_sub(*a).as_secs_f64(),
            (Clock::Wall(a), _) => a.elapsed().as_secs_f64(),
            (Clock::Cpu(_), Clock::Wall(_)) => f64::NAN,
        }
    }
}

/// The samples of one run.
struct Samples {
    q: Vec<Vec<f64>>,
    v: Vec<Vec<f64>>,
    work: Work,
    cpu_seconds: f64,
    events: Vec<f64>,
}

/// Runs one stepper on `sys` from (0, q0, v0) to the window's end, sampling
/// its interpolant at the protocol's sample times.
fn integrate<S: TangentSystem>(
    sys: &mut S,
    mut stepper: Stepper,
    steps_per_cycle: u32,
    period: f64,
    protocol: &Protocol,
    q0: &[f64],
    v0: &[f64],
) -> Result<Samples, SolverError> {
    let times = protocol.sample_times(period);
    let t_end = protocol.end_time(period);
    let n = q0.len();
    let mut qs = Vec::with_capacity(times.len());
    let mut vs = Vec::with_capacity(times.len());
    let clock = Clock::now();
    let mut next = 0;
    match &mut stepper {
        Stepper::Alpha(a) => {
            a.init(sys, 0.0, q0, v0)?;
            let total =
                u64::from(steps_per_cycle) * u64::from(protocol.run_in_cycles + protocol.window_cycles);
            let h_nominal = period / f64::from(steps_per_cycle);
            let (mut t0, mut q_a, mut v_a) = (0.0, q0.to_vec(), v0.to_vec());
            for j in 1..=total {
                let tb = if j == total { t_end } else { j as f64 * h_nominal };
                a.advance(sys, tb, 1)?;
                let (q_b, v_b) = (a.q(), a.v());
                while next < times.len() && times[next] <= tb {
                    let (q, v) = hermite(t0, tb, &q_a, &v_a, q_b, v_b, times[next]);
                    qs.push(q);
                    vs.push(v);
                    next += 1;
                }
                t0 = tb;
                q_a.copy_from_slice(q_b);
                v_a.copy_from_slice(v_b);
            }
        }
        Stepper::Rk(r) => {
            r.init(sys, 0.0, q0, v0)?;
            while r.time() < t_end {
                r.step(sys, t_end)?;
                while next < times.len() && times[next] <= r.time() {
                    let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
                    r.dense_at(times[next], &mut q, &mut v)?;
                    qs.push(q);
                    vs.push(v);
                    next += 1;
                }
            }
        }
    }
    let cpu_seconds = clock.seconds_since();
    let events = match &stepper {
        Stepper::Rk(r) => r.located_events().iter().map(|e| e.t).collect(),
        Stepper::Alpha(_) => Vec::new(),
    };
    Ok(Samples { q: qs, v: vs, work: stepper.stats(), cpu_seconds, events })
}

/// Frame states back to absolute ones.
fn to_absolute(rigid: &[f64], times: &[f64], q: &mut [Vec<f64>], v: &mut [Vec<f64>]) {
    for ((t, q), v) in times.iter().zip(q.iter_mut()).zip(v.iter_mut()) {
        for (i, r) in rigid.iter().enumerate() {
            q[i] += r * t;
            v[i] += r;
        }
    }
}

/// Cubic Hermite interpolation of (q, v) at `t` between (t0, qa, va) and
/// (t1, qb, vb); the velocity is the interpolant's derivative.
fn hermite(t0: f64, t1: f64, qa: &[f64], va: &[f64], qb: &[f64], vb: &[f64], t: f64) -> (Vec<f64>, Vec<f64>) {
    let h = t1 - t0;
    let s = (t - t0) / h;
    let (s2, s3) = (s * s, s * s * s);
    let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2);
    let (d00, d10, d01, d11) =
        (6.0 * s2 - 6.0 * s, 3.0 * s2 - 4.0 * s + 1.0, -6.0 * s2 + 6.0 * s, 3.0 * s2 - 2.0 * s);
    let q = (0..qa.len()).map(|i| h00 * qa[i] + h10 * h * va[i] + h01 * qb[i] + h11 * h * vb[i]).collect();
    let v = (0..qa.len()).map(|i| (d00 * qa[i] + d01 * qb[i]) / h + d10 * va[i] + d11 * vb[i]).collect();
    (q, v)
}

/// The index of a mesh's samples among the model's meshes: planet 1's sun–planet and ring–planet mesh.
const MEASURED_MESHES: [usize; 2] = [0, 1];

/// Harmonics and separation of the measured meshes from sampled states.
fn harmonics_of(
    model: &mut PlanetaryDynamics,
    times: &[f64],
    q: &[Vec<f64>],
    v: &[Vec<f64>],
    cycles: u32,
) -> Result<(Vec<Harmonics>, Vec<f64>), SpectrumError> {
    let mut scratch = vec![0.0; model.dim()];
    let mut force = vec![Vec::with_capacity(times.len()); MEASURED_MESHES.len()];
    for ((t, q), v) in times.iter().zip(q).zip(v) {
        model.force(*t, q, v, &mut scratch);
        for (f, m) in force.iter_mut().zip(MEASURED_MESHES) {
            f.push(model.meshes[m].force);
        }
    }
    let mut harmonics = Vec::with_capacity(force.len());
    for f in &force {
        harmonics.push(mesh_harmonics(f, cycles as usize, HARMONICS)?);
    }
    Ok((harmonics, force.iter().map(separation_fraction).collect()))
}

/// The mesh period at input speed `speed` [rad/s] \[s\].
pub fn mesh_period(model: &PlanetaryDynamics, speed: f64) -> f64 {
    1.0 / (model.mesh_frequency_per_input_speed * speed.abs())
}

/// The static initial state at `omega` [rad/s], with the speed drive (if any) set up for it.
fn initial_state(model: &mut PlanetaryDynamics, omega: f64) -> (Vec<f64>, Vec<f64>) {
    let s = static_state(model, omega);
    model.set_drive_speed(omega);
    model.rebase_drive(&s.q);
    (s.q, s.v)
}

fn check_speed(speed: f64) -> Result<(), AccuracyError> {
    if speed.is_finite() && speed > 0.0 {
        Ok(())
    } else {
        Err(AccuracyError::InvalidParameter {
            name: "speed_rpm".into(),
            value: rad_per_s_to_rpm(speed).to_string(),
            reason: "the input speed must be positive and finite".into(),
        })
    }
}

/// One setting at one operating point: harmonics from the first run, CPU
/// time the median of `repeats` runs (at least one).
pub fn measure(
    model: &PlanetaryDynamics,
    run: &RunSettings,
    speed: f64,
    method: &Method,
    protocol: &Protocol,
    repeats: usize,
) -> Result<Measured, AccuracyError> {
    protocol.check()?;
    check_speed(speed)?;
    let period = mesh_period(model, speed);
    let label = method.label();
    let configured =
        method.apply(run).map_err(|source| AccuracyError::Settings { method: label.clone(), source })?;
    let err = |source| AccuracyError::Integration { method: label.clone(), speed, source };
    let steps = match method {
        Method::GeneralizedAlpha { steps_per_mesh_cycle, .. } => (*steps_per_mesh_cycle).max(1),
        Method::Rk45 { .. } => 1,
    };
    let mut times = Vec::with_capacity(repeats.max(1));
    let mut first: Option<Samples> = None;
    let mut m = model.clone();
    for _ in 0..repeats.max(1) {
        m.clone_from(model);
        let (q0, v0) = initial_state(&mut m, speed);
        let stepper = Stepper::new(&configured, period).map_err(err)?;
        let samples = integrate(&mut m, stepper, steps, period, protocol, &q0, &v0).map_err(err)?;
        times.push(samples.cpu_seconds);
        first.get_or_insert(samples);
    }
    // `first` is set by the loop, which runs at least once.
    let samples = first.ok_or_else(|| AccuracyError::InvalidParameter {
        name: "repeats".into(),
        value: repeats.to_string(),
        reason: "at least one run is needed".into(),
    })?;
    let (harmonics, separation) =
        harmonics_of(&mut m, &protocol.sample_times(period), &samples.q, &samples.v, protocol.window_cycles)
            .map_err(|source| AccuracyError::Spectrum { method: label.clone(), speed, source })?;
    Ok(Measured { harmonics, separation, work: samples.work, cpu_seconds: median(&mut times) })
}

/// The reference at one operating point: the adaptive method at relative
/// tolerance `tolerance` (absolute tolerances 1e-6 m and 1e-3 m/s per unit
/// of it) in the rigid-body frame (`RigidFrame`), contact events recorded
/// to check that no sample sits on one.
pub fn reference(
    model: &PlanetaryDynamics,
    speed: f64,
    protocol: &Protocol,
    tolerance: f64,
) -> Result<Reference, AccuracyError> {
    protocol.check()?;
    check_speed(speed)?;
    let period = mesh_period(model, speed);
    let label = format!("reference RK 5(4) rtol {tolerance:e}");
    let err = |source| AccuracyError::Integration { method: label.clone(), speed, source };
    let settings = Rk45Settings {
        rtol: tolerance,
        atol_q: tolerance * 1e-6,
        atol_v: tolerance * 1e-3,
        max_step: period / 4.0,
        max_steps: u64::MAX,
        record_events: true,
        // Rayleigh's η K_t δ̇ jumps at every pair switch; at 1e-13 a step straddling a jump
        // passes only as it shrinks towards the time's rounding.
        hop_switches: true,
        ..Rk45Settings::default()
    };
    let mut m = model.clone();
    let (q0, v0) = initial_state(&mut m, speed);
    let rigid = m.rigid_velocity_at(speed);
    let ve0: Vec<f64> = v0.iter().zip(&rigid).map(|(v, r)| v - r).collect();
    let stepper = Stepper::Rk(Box::new(Rk45::new(settings).map_err(err)?));
    let mut frame = RigidFrame::new(&mut m, rigid.clone());
    let mut samples = integrate(&mut frame, stepper, 1, period, protocol, &q0, &ve0).map_err(err)?;
    let times = protocol.sample_times(period);
    to_absolute(&rigid, &times, &mut samples.q, &mut samples.v);
    let (harmonics, separation) =
        harmonics_of(&mut m, &times, &samples.q, &samples.v, protocol.window_cycles)
            .map_err(|source| AccuracyError::Spectrum { method: label.clone(), speed, source })?;
    let interval = period / f64::from(protocol.samples_per_cycle);
    let window_start = f64::from(protocol.run_in_cycles) * period;
    let in_window: Vec<f64> = samples.events.iter().copied().filter(|t| *t >= window_start).collect();
    let closest = in_window
        .iter()
        .map(|te| times.iter().map(|t| (t - te).abs()).fold(f64::INFINITY, f64::min))
        .fold(f64::INFINITY, f64::min);
    Ok(Reference {
        tolerance,
        measured: Measured { harmonics, separation, work: samples.work, cpu_seconds: samples.cpu_seconds },
        closest_event: closest / interval,
        events_in_window: in_window.len(),
        window_events: in_window,
    })
}

/// The sample phase farthest from the contact events of a window starting
/// at `window_start` \[s\]: the events folded onto one sample interval
/// `interval` \[s\], the middle of the widest gap between them. With no events,
/// the golden-ratio phase of [`Protocol::default`].
pub fn clear_phase(events: &[f64], window_start: f64, interval: f64) -> f64 {
    let mut x: Vec<f64> = events.iter().map(|t| ((t - window_start) / interval).rem_euclid(1.0)).collect();
    if x.is_empty() {
        return Protocol::default().sample_phase;
    }
    x.sort_by(f64::total_cmp);
    // The gap that wraps from the last event to the first one plus a whole interval.
    let mut best = (x[0] + 1.0 - x[x.len() - 1], x[x.len() - 1]);
    for w in x.windows(2) {
        if w[1] - w[0] > best.0 {
            best = (w[1] - w[0], w[0]);
        }
    }
    (best.1 + 0.5 * best.0).rem_euclid(1.0)
}

/// Runs an independent integrator on the same problem (in the same
/// rigid-body frame as the reference) and compares it with the reference.
pub fn confirm(
    model: &PlanetaryDynamics,
    speed: f64,
    protocol: &Protocol,
    reference: &Reference,
    independent: &dyn IndependentIntegrator,
) -> Result<Agreement, AccuracyError> {
    protocol.check()?;
    check_speed(speed)?;
    let period = mesh_period(model, speed);
    let name = independent.name();
    let mut m = model.clone();
    let (q0, v0) = initial_state(&mut m, speed);
    let rigid = m.rigid_velocity_at(speed);
    let ve0: Vec<f64> = v0.iter().zip(&rigid).map(|(v, r)| v - r).collect();
    let times = protocol.sample_times(period);
    let clock = Clock::now();
    let mut frame = RigidFrame::new(&mut m, rigid.clone());
    let solution = independent
        .solve(&mut frame, &q0, &ve0, &times)
        .map_err(|message| AccuracyError::Independent { name: name.clone(), message })?;
    let cpu_seconds = clock.seconds_since();
    if solution.q.len() != times.len() || solution.v.len() != times.len() {
        return Err(AccuracyError::Independent {
            name,
            message: format!("returned {} states for {} times", solution.q.len(), times.len()),
        });
    }
    let (mut q, mut v) = (solution.q, solution.v);
    to_absolute(&rigid, &times, &mut q, &mut v);
    let (harmonics, _) = harmonics_of(&mut m, &times, &q, &v, protocol.window_cycles)
        .map_err(|source| AccuracyError::Spectrum { method: name.clone(), speed, source })?;
    Ok(Agreement {
        error: harmonic_error(&harmonics, &reference.measured.harmonics),
        name,
        steps: solution.steps,
        rhs_evaluations: solution.rhs_evaluations,
        cpu_seconds,
    })
}

/// E_h = max over meshes of max_k |A_k − A_k,ref| / A_1,ref \[1\].
pub fn harmonic_error(run: &[Harmonics], reference: &[Harmonics]) -> f64 {
    run.iter()
        .zip(reference)
        .map(|(h, r)| {
            let scale = r.amplitude.first().copied().unwrap_or(0.0);
            h.amplitude.iter().zip(&r.amplitude).map(|(a, b)| (a - b).abs() / scale).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// An operating point of the study: a validated gear set (its fidelity and
/// damping included), the run settings the methods are varied from, and a
/// speed.
#[derive(Clone, Debug)]
pub struct OperatingPoint {
    /// Short name (file names).
    pub name: String,
    /// What it is and why it is in the study.
    pub description: String,
    /// The gear set.
    pub set: GearSet,
    /// The run settings each method changes.
    pub run: RunSettings,
    /// Input speed [rad/s].
    pub speed: f64,
}

/// The grid of the study.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StudyPlan {
    /// How every run is measured.
    pub protocol: Protocol,
    /// Repeats per setting for the median CPU time.
    pub repeats: usize,
    /// Relative tolerance of the reference \[1\].
    pub reference_tolerance: f64,
    /// Generalized-α spectral radii \[1\].
    pub rho_infinity: Vec<f64>,
    /// Generalized-α steps per mesh cycle.
    pub steps_per_mesh_cycle: Vec<u32>,
    /// Adaptive method's relative tolerances \[1\].
    pub relative_tolerances: Vec<f64>,
}

impl StudyPlan {
    /// The full grid: ρ∞ = 1, 0.9, 0.6 at 16 … 1024 steps per mesh cycle
    /// (powers of two, and the multiples of 60 from 120 to 600 that the
    /// steady-state analysis can run), RK 5(4) at 1e-3, 3e-4, … 1e-10, three
    /// repeats, reference at 1e-13.
    pub fn full() -> Self {
        let mut steps = vec![16, 32, 64, 120, 128, 180, 240, 256, 300, 360, 420, 480, 512, 600, 1024];
        steps.sort_unstable();
        Self {
            protocol: Protocol::default(),
            repeats: 3,
            reference_tolerance: 1e-13,
            rho_infinity: vec![1.0, 0.9, 0.6],
            steps_per_mesh_cycle: steps,
            relative_tolerances: (3..=10)
                .flat_map(|e| [10f64.powi(-e), 3.0 * 10f64.powi(-e - 1)])
                .filter(|t| *t >= 1e-10)
                .collect(),
        }
    }

    /// A reduced grid the test command can afford: ρ∞ = 0.9 at 16 … 256
    /// steps, RK 5(4) at 1e-3 … 1e-7, one repeat, a window of 4 mesh cycles
    /// after the full revolution of run-in (a shorter run-in leaves the
    /// lightly damped points of the example in their transient).
    pub fn quick() -> Self {
        Self {
            protocol: Protocol { run_in_cycles: 34, window_cycles: 4, ..Protocol::default() },
            repeats: 1,
            reference_tolerance: 1e-11,
            rho_infinity: vec![0.9],
            steps_per_mesh_cycle: vec![16, 32, 64, 128, 256],
            relative_tolerances: (3..=7).map(|e| 10f64.powi(-e)).collect(),
        }
    }

    /// Every method of the grid, family by family.
    pub fn methods(&self) -> Vec<Method> {
        let mut out = Vec::new();
        for rho in &self.rho_infinity {
            for n in &self.steps_per_mesh_cycle {
                out.push(Method::GeneralizedAlpha { rho_infinity: *rho, steps_per_mesh_cycle: *n });
            }
        }
        for tol in &self.relative_tolerances {
            out.push(Method::Rk45 { relative_tolerance: *tol });
        }
        out
    }
}

/// One setting's result at one operating point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SettingResult {
    /// The setting.
    pub method: Method,
    /// E_h against the reference \[1\]; `None` when the run failed.
    pub error: Option<f64>,
    /// Its harmonics, cost and work; `None` when the run failed.
    pub measured: Option<Measured>,
    /// Why the run failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// The study at one operating point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointResult {
    /// Short name.
    pub name: String,
    /// Description.
    pub description: String,
    /// Fidelity level.
    pub fidelity: Fidelity,
    /// Input speed [rad/s] (written in rpm, as `speed_rpm`).
    #[serde(rename = "speed_rpm", with = "crate::scene::units::rpm")]
    pub speed: f64,
    /// Mesh frequency \[Hz\].
    pub mesh_frequency: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// The measurement (with this point's sample phase).
    pub protocol: Protocol,
    /// The reference.
    pub reference: Reference,
    /// E_h of the adaptive method at 10× the reference tolerance against the reference \[1\].
    pub self_check: f64,
    /// E_h between the reference's window and the window one run-in later:
    /// how periodic (steady) the response is \[1\].
    pub drift: f64,
    /// The independent confirmation, if one was run.
    pub independent: Option<Agreement>,
    /// Every setting.
    pub settings: Vec<SettingResult>,
}

/// Runs the study at one operating point: the contact events of a probe
/// run (tolerance 1e-8) place the sample grid between them
/// ([`clear_phase`]); then the reference, its self-check at 10× its
/// tolerance, the periodicity check (the window one run-in later), the
/// independent confirmation (when given) and every method of the plan.
/// `progress` is called after each run with its label.
pub fn study_point(
    point: &OperatingPoint,
    plan: &StudyPlan,
    independent: Option<&dyn IndependentIntegrator>,
    mut progress: impl FnMut(&str),
) -> Result<PointResult, AccuracyError> {
    let model =
        PlanetaryDynamics::new(&point.set, crate::contact::ltca::SetModel::new(&point.set)).map_err(|e| {
            AccuracyError::InvalidParameter {
                name: "operating point".into(),
                value: point.name.clone(),
                reason: e.to_string(),
            }
        })?;
    let speed = point.speed;
    check_speed(speed)?;
    let period = mesh_period(&model, speed);
    let probe = reference(&model, speed, &plan.protocol, 1e-8)?;
    let interval = period / f64::from(plan.protocol.samples_per_cycle);
    let window_start = f64::from(plan.protocol.run_in_cycles) * period;
    let protocol =
        Protocol { sample_phase: clear_phase(&probe.window_events, window_start, interval), ..plan.protocol };
    let tol = plan.reference_tolerance;
    let reference = reference(&model, speed, &protocol, tol)?;
    progress("reference");
    let looser = self::reference(&model, speed, &protocol, 10.0 * tol)?;
    let self_check = harmonic_error(&looser.measured.harmonics, &reference.measured.harmonics);
    let later_protocol = Protocol { run_in_cycles: 2 * protocol.run_in_cycles, ..protocol };
    let later = self::reference(&model, speed, &later_protocol, tol)?;
    let drift = harmonic_error(&later.measured.harmonics, &reference.measured.harmonics);
    progress("reference checks");
    let independent = match independent {
        Some(ind) => {
            let a = confirm(&model, speed, &protocol, &reference, ind)?;
            progress("independent");
            Some(a)
        }
        None => None,
    };
    let mut settings = Vec::new();
    for method in plan.methods() {
        let result = match measure(&model, &point.run, speed, &method, &protocol, plan.repeats) {
            Ok(m) => SettingResult {
                method,
                error: Some(harmonic_error(&m.harmonics, &reference.measured.harmonics)),
                measured: Some(m),
                failure: None,
            },
            Err(e) => SettingResult { method, error: None, measured: None, failure: Some(e.to_string()) },
        };
        progress(&method.label());
        settings.push(result);
    }
    Ok(PointResult {
        name: point.name.clone(),
        description: point.description.clone(),
        fidelity: point.set.fidelity(),
        speed,
        mesh_frequency: 1.0 / period,
        dof: model.dim(),
        protocol,
        reference,
        self_check,
        drift,
        independent,
        settings,
    })
}

impl PointResult {
    /// How far the reference can be trusted: the larger of its self-check
    /// and its disagreement with the independent integrator \[1\].
    pub fn resolution(&self) -> f64 {
        self.independent.as_ref().map_or(self.self_check, |a| a.error.max(self.self_check))
    }

    /// Errors below this are not reported: 100 × [`Self::resolution`], so
    /// that every reported error is at least 100 times the reference's \[1\].
    pub fn floor(&self) -> f64 {
        100.0 * self.resolution()
    }

    /// The settings of one family, in the plan's order.
    pub fn family(&self, family: &str) -> Vec<&SettingResult> {
        self.settings.iter().filter(|s| s.method.family() == family).collect()
    }

    /// The families, in the plan's order.
    pub fn families(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for s in &self.settings {
            let f = s.method.family();
            if !out.contains(&f) {
                out.push(f);
            }
        }
        out
    }
}

/// Observed order of a family: the least-squares slope of −log E_h against
/// log(steps) over its settings whose error lies in [`floor`, 1e-2], where
/// `floor` keeps the reference's own error out. `None` with fewer than two
/// such settings.
pub fn observed_order(results: &[&SettingResult], floor: f64) -> Option<f64> {
    let pts: Vec<(f64, f64)> = results
        .iter()
        .filter_map(|r| {
            let e = r.error?;
            let steps = r.measured.as_ref()?.work.steps;
            (e >= floor && e <= 1e-2 && steps > 0).then(|| ((steps as f64).ln(), e.ln()))
        })
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| -sxy / sxx)
}

/// CPU time a family needs to reach `target` error: the cheapest setting
/// that reaches it, its time interpolated log-log with the next cheaper
/// setting (which does not). `None` if no setting reaches it.
pub fn time_to_reach(results: &[&SettingResult], target: f64) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = results
        .iter()
        .filter_map(|r| Some((r.measured.as_ref()?.cpu_seconds, r.error?)))
        .filter(|(t, e)| t.is_finite() && *t > 0.0 && e.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let i = pts.iter().position(|(_, e)| *e <= target)?;
    if i == 0 {
        return Some(pts[0].0);
    }
    let ((t0, e0), (t1, e1)) = (pts[i - 1], pts[i]);
    if e1 <= 0.0 || e0 <= e1 {
        return Some(t1);
    }
    let w = (e0.ln() - target.ln()) / (e0.ln() - e1.ln());
    Some((t0.ln() + w * (t1.ln() - t0.ln())).exp())
}

/// The default chosen from a study: among the settings that reach E_h ≤
/// `target` at every operating point, the one with the least total CPU time
/// over the points. Returns the method and its total time \[s\].
pub fn cheapest_meeting(points: &[PointResult], target: f64) -> Option<(Method, f64)> {
    let first = points.first()?;
    let mut best: Option<(Method, f64)> = None;
    for s in &first.settings {
        let mut total = 0.0;
        let mut ok = true;
        for p in points {
            match p.settings.iter().find(|r| r.method == s.method) {
                Some(SettingResult { error: Some(e), measured: Some(m), .. }) if *e <= target => {
                    total += m.cpu_seconds;
                }
                _ => {
                    ok = false;
                    break;
                }
            }
        }
        if ok && best.as_ref().is_none_or(|b| total < b.1) {
            best = Some((s.method, total));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_is_exact_for_cubics() {
        // q(t) = 1 + 2t − t² + 0.5t³ on [0.2, 0.7].
        let q = |t: f64| 1.0 + 2.0 * t - t * t + 0.5 * t * t * t;
        let v = |t: f64| 2.0 - 2.0 * t + 1.5 * t * t;
        let (t0, t1) = (0.2, 0.7);
        for t in [0.2, 0.33, 0.5, 0.69, 0.7] {
            let (qi, vi) = hermite(t0, t1, &[q(t0)], &[v(t0)], &[q(t1)], &[v(t1)], t);
            assert!((qi[0] - q(t)).abs() < 1e-14, "q at {t}");
            assert!((vi[0] - v(t)).abs() < 1e-13, "v at {t}");
        }
    }

    #[test]
    fn sample_grid_spans_whole_cycles_off_the_step_grid() {
        let p = Protocol::default();
        let t = p.sample_times(1.0);
        assert_eq!(t.len(), (p.samples_per_cycle * p.window_cycles) as usize);
        let spacing = 1.0 / f64::from(p.samples_per_cycle);
        assert!((t[1] - t[0] - spacing).abs() < 1e-12);
        // The window covers exactly C cycles: one more sample would start the next.
        assert!((t[t.len() - 1] + spacing - t[0] - f64::from(p.window_cycles)).abs() < 1e-9);
        // No sample on a step end of 1024 steps per cycle.
        for x in &t {
            let r = x * 1024.0;
            assert!((r - r.round()).abs() > 1e-3, "sample {x} on the step grid");
        }
    }

    #[test]
    fn error_measure_is_relative_to_the_first_harmonic() {
        let h = |a: [f64; 6]| Harmonics { mean: 0.0, amplitude: a.to_vec(), rms: 0.0 };
        let r = vec![h([10.0, 1.0, 0.0, 0.0, 0.0, 0.0]), h([20.0, 0.0, 0.0, 0.0, 0.0, 0.0])];
        let run = vec![h([10.1, 1.0, 0.0, 0.0, 0.0, 0.0]), h([20.0, 0.0, 0.0, 0.0, 0.0, 0.5])];
        // Mesh 1: 0.1/10 = 0.01; mesh 2: 0.5/20 = 0.025.
        assert!((harmonic_error(&run, &r) - 0.025).abs() < 1e-15);
    }

    #[test]
    fn time_to_reach_interpolates_log_log() {
        let mk = |t: f64, e: f64| SettingResult {
            method: Method::Rk45 { relative_tolerance: e },
            error: Some(e),
            measured: Some(Measured {
                harmonics: Vec::new(),
                separation: Vec::new(),
                work: Work::default(),
                cpu_seconds: t,
            }),
            failure: None,
        };
        let a = [mk(1.0, 1e-2), mk(4.0, 1e-4), mk(8.0, 1e-6)];
        let refs: Vec<&SettingResult> = a.iter().collect();
        // 1e-3 lies halfway in log between 1e-2 and 1e-4: time sqrt(1·4) = 2.
        assert!((time_to_reach(&refs, 1e-3).unwrap() - 2.0).abs() < 1e-12);
        assert_eq!(time_to_reach(&refs, 1e-2), Some(1.0));
        assert_eq!(time_to_reach(&refs, 1e-7), None);
    }
}
