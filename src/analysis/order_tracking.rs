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
    let invalid = |name: &str, value: String, reason: &str| ResponseError::InvalidRequest {
        name: name.into(),
        value,
        reason: reason.into(),
    };
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
    let period = 1.0 / fm;
    let err = |source| ResponseError::Integration { speed: omega, source };
    // The FMU's start (Simulation::new): static deflection, balanced torques.
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

    let spacing = set.sun().base_pitch() / samples_per_cycle as f64;
    let n = model.dim();
    let mut scratch = vec![0.0; n];
    let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
    let mut sorted: Vec<usize> = ends.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let last_end = sorted[sorted.len() - 1] as f64 * period;
    // Keep only the samples the windows can need.
    let first_kept = (sorted[0] - window_cycles) as f64 * period;
    let mut samples: Vec<Sample> = Vec::new();
    let travel = |model: &mut PlanetaryDynamics, t: f64, q: &[f64], v: &[f64], f: &mut [f64]| {
        model.force(t, q, v, f);
        (model.meshes[0].position, model.meshes[0].force, model.meshes[1].force)
    };
    let (mut t_a, mut s_a) = (0.0, travel(model, 0.0, &start.q, &start.v, &mut scratch).0);
    let mut next_end = 0;
    while rk.time() < last_end {
        while (sorted[next_end] as f64) * period <= rk.time() {
            next_end += 1;
        }
        rk.step(model, sorted[next_end] as f64 * period).map_err(err)?;
        let t_b = rk.time();
        let (s_b, _, _) = travel(model, t_b, rk.q(), rk.v(), &mut scratch);
        if !s_b.is_finite() {
            return Err(err(SolverError::NonFiniteState { t: t_b, index: 0 }));
        }
        if t_b >= first_kept && s_b > s_a {
            let first = (s_a / spacing).floor() as i64 + 1;
            let last = (s_b / spacing).floor() as i64;
            for m in first..=last {
                let g = m as f64 * spacing;
                let sample =
                    crossing(model, &rk, (t_a, s_a - g), (t_b, s_b - g), g, &mut q, &mut v, &mut scratch)
                        .map_err(err)?;
                samples.push(sample);
            }
        }
        (t_a, s_a) = (t_b, s_b);
    }
    let mut windows = Vec::with_capacity(ends.len());
    for &end in ends {
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
        windows.push(WindowMeasure {
            end_cycle: end,
            sun: harmonics(&sun)?,
            sun_separation: separation_fraction(&sun),
            ring: harmonics(&ring)?,
            ring_separation: separation_fraction(&ring),
        });
    }
    Ok(TrackedRun { windows, work: Work::from(*rk.stats()) })
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
