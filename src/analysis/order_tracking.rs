//! Order-tracked harmonics of planet 1's two mesh forces, sampled exactly:
//! the quantity the FMU's windowed outputs (`window.*`) estimate.
//!
//! The FMU's window ([`crate::dynamics::simulation::Simulation`]) takes a sample of
//! planet 1's sun–planet and ring–planet mesh force each time the sun mesh's
//! travel s crosses a multiple of p_b / S (p_b the sun's base pitch, S the
//! samples per mesh cycle), interpolating linearly between the points of its
//! internal grid (`stepsPerMeshCycle` per mesh cycle); over W mesh cycles the
//! S·W samples give the order spectrum of the forces (F^(1..6), F^(rms), the
//! mean, and the separation fraction, the share of samples at zero force).
//! That estimate converges like 1/n² as the grid's n points per mesh cycle
//! grow (docs/REGRESSION.md).
//!
//! Here the same samples are taken without interpolation error: the
//! adaptive Runge–Kutta 5(4) method takes its own steps, and in each step
//! every travel crossing s(t*) = m·p_b/S is found on the method's dense
//! output (the travel is a function of the coordinates) by the Illinois
//! variant of regula falsi, and the forces are evaluated at t*. The run is
//! the FMU's initial-value problem: the static deflection of the
//! mean-stiffness model at the input speed at t = 0 under the balanced
//! torques, held constant. This is a time-sampled measure's counterpart:
//! [`crate::dynamics::response::steady_state`] samples the forces at equal times, and
//! the two differ where the speed fluctuates over a mesh cycle.

use serde::{Deserialize, Serialize};

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{static_state, ResponseError, Stepper, Work};
use crate::dynamics::solver::{Rk45, SecondOrderSystem, SolverError};
use crate::dynamics::spectrum::{mesh_harmonics, separation_fraction, Harmonics};
use crate::model::gear::{GearSet, IntegratorKind};
use crate::model::run::RunSettings;
use crate::scene::units::rad_per_s_to_rpm;

/// Mesh harmonics counted in the window (F^(1..6)).
pub const HARMONICS: usize = 6;

/// The window's measures of planet 1's two meshes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WindowMeasure {
    /// Mesh cycles from the start at which the window ends.
    pub end_cycle: usize,
    /// Sun–planet mesh force: mean and harmonics 1..6 \[N\].
    pub sun: Harmonics,
    /// Fraction of the sun–planet mesh's samples at zero force.
    pub sun_separation: f64,
    /// Ring–planet mesh force: mean and harmonics 1..6 \[N\].
    pub ring: Harmonics,
    /// Fraction of the ring–planet mesh's samples at zero force.
    pub ring_separation: f64,
}

/// Result of [`order_tracked_windows`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackedRun {
    /// One window per requested end, in the order requested.
    pub windows: Vec<WindowMeasure>,
    /// Integrator work of the whole run.
    pub work: Work,
}

/// A sample: time \[s\], sun–planet and ring–planet mesh force \[N\].
type Sample = (f64, f64, f64);

/// Runs the set from the FMU's initial state at input speed `omega` [rad/s]
/// with the adaptive method of `run` (which must be RK 5(4)) and returns
/// the order-tracked windows of `window_cycles` mesh cycles at
/// `samples_per_cycle` samples each that end `ends` mesh cycles after the
/// start (each window holds the last samples whose travel crossing is not
/// later than its end, as the FMU's window at that communication point).
pub fn order_tracked_windows(
    set: &GearSet,
    run: &RunSettings,
    model: &mut PlanetaryDynamics,
    omega: f64,
    window_cycles: usize,
    samples_per_cycle: usize,
    ends: &[usize],
) -> Result<TrackedRun, ResponseError> {
    let fm = check_request(run, model, omega, (window_cycles, samples_per_cycle), ends)?;
    let period = 1.0 / fm;
    let err = |source| ResponseError::Integration { speed: omega, source };
    let (mut rk, travel_start) = fmu_start(set, run, model, omega, period)?;
    let mut sorted: Vec<usize> = ends.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let ends_at: Vec<f64> = sorted.iter().map(|e| *e as f64 * period).collect();
    // Keep only the samples the windows can need.
    let first_kept = (sorted[0] - window_cycles) as f64 * period;
    let spacing = set.sun().base_pitch() / samples_per_cycle as f64;
    let samples = track(model, &mut rk, travel_start, &ends_at, (first_kept, spacing)).map_err(err)?;
    let mut windows = Vec::with_capacity(ends.len());
    for &end in ends {
        windows.push(window_measure(&samples, end, period, (window_cycles, samples_per_cycle), omega)?);
    }
    Ok(TrackedRun { windows, work: Work::from(*rk.stats()) })
}

/// A refused request: `name` = `value`, and why.
fn invalid(name: &str, value: String, reason: &str) -> ResponseError {
    ResponseError::InvalidRequest { name: name.into(), value, reason: reason.into() }
}

/// Refuses a request the tracking cannot serve: another integrator than RK 5(4), a speed
/// that is not positive, samples per mesh cycle (`sizes`: window cycles and samples per
/// cycle) outside 16 ..= 10000, no window end or one shorter than a window, no planet.
/// The mesh frequency \[Hz\].
fn check_request(
    run: &RunSettings,
    model: &PlanetaryDynamics,
    omega: f64,
    (window_cycles, samples_per_cycle): (usize, usize),
    ends: &[usize],
) -> Result<f64, ResponseError> {
    if run.integrator() != IntegratorKind::Rk45 {
        return Err(invalid(
            "integrator",
            format!("{:?}", run.integrator()),
            "order tracking samples the adaptive method's dense output: use rk45",
        ));
    }
    let fm = model.mesh_frequency_per_input_speed * omega;
    if !(fm.is_finite() && fm > 0.0) {
        return Err(invalid(
            "input speed",
            format!("{} rpm", rad_per_s_to_rpm(omega)),
            "must be positive and finite (the travel is tracked upwards)",
        ));
    }
    if !(16..=10_000).contains(&samples_per_cycle) {
        return Err(invalid(
            "samples per mesh cycle",
            samples_per_cycle.to_string(),
            "must be between 16 and 10000 (harmonic 6 needs more than 12)",
        ));
    }
    if window_cycles == 0 || ends.is_empty() || ends.iter().any(|e| *e < window_cycles) {
        return Err(invalid(
            "window ends",
            format!("{ends:?} mesh cycles for a window of {window_cycles}"),
            "need at least one end, each at least one window long",
        ));
    }
    if model.mesh_count() < 2 {
        return Err(invalid("planets", "0".into(), "planet 1's meshes are tracked: need a planet"));
    }
    Ok(fm)
}

/// The FMU's start (`Simulation::new`): the static deflection at `omega` [rad/s] under the
/// balanced torques, the adaptive method initialized there for the mesh period `period`
/// \[s\]; with the sun mesh's travel at t = 0.
fn fmu_start(
    set: &GearSet,
    run: &RunSettings,
    model: &mut PlanetaryDynamics,
    omega: f64,
    period: f64,
) -> Result<(Box<Rk45>, f64), ResponseError> {
    let err = |source| ResponseError::Integration { speed: omega, source };
    let start = static_state(model, omega);
    let torques = set.balanced_torques();
    model.set_torques(torques[0], torques[1], torques[2]);
    model.set_drive_speed(omega);
    model.rebase_drive(&start.q);
    let mut rk = match Stepper::new(run, period).map_err(err)? {
        Stepper::Rk(r) => r,
        Stepper::Alpha(_) => {
            return Err(invalid("integrator", "generalized_alpha".into(), "use rk45"));
        }
    };
    rk.init(model, 0.0, &start.q, &start.v).map_err(err)?;
    let mut scratch = vec![0.0; model.dim()];
    let travel = travel(model, 0.0, &start.q, &start.v, &mut scratch).0;
    Ok((rk, travel))
}

/// The sun mesh's travel of planet 1 and its two mesh forces at (t, q, v).
#[inline]
fn travel(model: &mut PlanetaryDynamics, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) -> Sample {
    model.force(t, q, v, f);
    (model.meshes[0].position, model.meshes[0].force, model.meshes[1].force)
}

/// The run to the last of the window ends `ends_at` \[s\] (increasing; each step ends no
/// later than the next end), from the sun mesh's travel `travel_start` at t = 0: every
/// travel crossing of a multiple of `spacing` inside a step ending at or after
/// `first_kept` \[s\], located on the dense output, as a sample.
fn track(
    model: &mut PlanetaryDynamics,
    rk: &mut Rk45,
    travel_start: f64,
    ends_at: &[f64],
    (first_kept, spacing): (f64, f64),
) -> Result<Vec<Sample>, SolverError> {
    let n = model.dim();
    let mut scratch = vec![0.0; n];
    let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
    let last_end = ends_at[ends_at.len() - 1];
    let mut samples: Vec<Sample> = Vec::new();
    let (mut t_a, mut s_a) = (0.0, travel_start);
    let mut next_end = 0;
    while rk.time() < last_end {
        while ends_at[next_end] <= rk.time() {
            next_end += 1;
        }
        rk.step(model, ends_at[next_end])?;
        let t_b = rk.time();
        let (s_b, _, _) = travel(model, t_b, rk.q(), rk.v(), &mut scratch);
        if !s_b.is_finite() {
            return Err(SolverError::NonFiniteState { t: t_b, index: 0 });
        }
        if t_b >= first_kept && s_b > s_a {
            let first = (s_a / spacing).floor() as i64 + 1;
            let last = (s_b / spacing).floor() as i64;
            for m in first..=last {
                let g = m as f64 * spacing;
                let sample =
                    crossing(model, rk, (t_a, s_a - g), (t_b, s_b - g), g, &mut q, &mut v, &mut scratch)?;
                samples.push(sample);
            }
        }
        (t_a, s_a) = (t_b, s_b);
    }
    Ok(samples)
}

/// The measures of the window of `sizes` (mesh cycles, samples per cycle) that ends
/// `end` mesh cycles (of `period` \[s\]) after the start: its last samples no later than
/// the end.
fn window_measure(
    samples: &[Sample],
    end: usize,
    period: f64,
    (window_cycles, samples_per_cycle): (usize, usize),
    omega: f64,
) -> Result<WindowMeasure, ResponseError> {
    let t_end = end as f64 * period;
    let count = samples.partition_point(|s| s.0 <= t_end);
    let needed = window_cycles * samples_per_cycle;
    if count < needed {
        return Err(invalid(
            "window ends",
            format!("{end} mesh cycles"),
            "the travel did not cover the window (the set does not turn at the input speed)",
        ));
    }
    let window = &samples[count - needed..count];
    let sun: Vec<f64> = window.iter().map(|s| s.1).collect();
    let ring: Vec<f64> = window.iter().map(|s| s.2).collect();
    let harmonics = |f: &[f64]| {
        mesh_harmonics(f, window_cycles, HARMONICS)
            .map_err(|source| ResponseError::Spectrum { speed: omega, source })
    };
    Ok(WindowMeasure {
        end_cycle: end,
        sun: harmonics(&sun)?,
        sun_separation: separation_fraction(&sun),
        ring: harmonics(&ring)?,
        ring_separation: separation_fraction(&ring),
    })
}

/// The sample at the travel crossing s(t*) = `g` inside the last accepted
/// step: regula falsi (Illinois) on the dense output, bracketed by the step
/// ends `a` and `b` as (time, travel − g).
#[allow(clippy::too_many_arguments)]
fn crossing(
    model: &mut PlanetaryDynamics,
    rk: &Rk45,
    a: (f64, f64),
    b: (f64, f64),
    g: f64,
    q: &mut [f64],
    v: &mut [f64],
    scratch: &mut [f64],
) -> Result<Sample, SolverError> {
    let ((mut ta, mut fa), (mut tb, mut fb)) = (a, b);
    // Travel is resolved to a few units in the last place of its magnitude.
    let tolerance = 8.0 * f64::EPSILON * g.abs().max(1e-3);
    let mut side = 0i8;
    let mut t = tb;
    for _ in 0..60 {
        t = if fb != fa { tb - fb * (tb - ta) / (fb - fa) } else { 0.5 * (ta + tb) };
        if !(t > ta.min(tb) && t < ta.max(tb)) {
            t = 0.5 * (ta + tb);
        }
        rk.dense_at(t, q, v)?;
        model.force(t, q, v, scratch);
        let f = model.meshes[0].position - g;
        if f.abs() <= tolerance || (tb - ta).abs() <= 4.0 * f64::EPSILON * tb.abs() {
            break;
        }
        if (f > 0.0) == (fb > 0.0) {
            (tb, fb) = (t, f);
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        } else {
            (ta, fa) = (t, f);
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        }
    }
    let m = &model.meshes;
    Ok((t, m[0].force, m[1].force))
}
