//! Speed sweeps by time marching in the frame of the rigid-body motion, one
//! excitation period at a time, measured over one period once the state
//! repeats: the route of the study's forced-response figure (Fig. 11,
//! `cargo bench --bench fig11`, docs/PERFORMANCE.md).
//!
//! Each point starts from the previous speed's relative state (the elastic
//! deflections and their rates; the first from the static state) and flows
//! over one period after another ([`PeriodicProblem::residual`]: the RK 5(4)
//! flow in the relative frame, whose tolerances mean what they say for the
//! elastic motion, unlike the absolute coordinates of the marching sweep whose
//! rotation angles grow). It is marching, not Newton: it follows the attractor
//! as the sweep up or down does, jumps included. The point is periodic when
//! the change over one period, divided by 1 − ρ (ρ the change's contraction
//! from the period before, an estimate of the largest Floquet multiplier),
//! is at most the tolerance in the state scales: an estimate of the distance
//! to the periodic state, not only of the last step. It is then measured over
//! one period ([`PeriodicProblem::steady_state`]); a point that does not
//! settle within the set number of periods is measured over the next
//! `window_periods` periods instead, as the marching sweep measures its
//! window. The settling test goes on through the window: a point that
//! settles there is periodic and measured over the window's last period
//! (what a longer run-in would have measured), so only a point that never
//! settles pays for the whole window.

use serde::{Deserialize, Serialize};

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::periodic::{max_abs, PeriodicError, PeriodicOrbit, PeriodicProblem, ShootingSettings};
use crate::dynamics::response::{SteadyState, Work};
use crate::dynamics::spectrum::{mesh_harmonics, separation_fraction};

/// Settings of a sweep in the rigid-body frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameSweepSettings {
    /// The flow's tolerance and samples per mesh cycle (the other shooting
    /// settings are not used).
    pub flow: ShootingSettings,
    /// Estimated distance to the periodic state, in state scales (static
    /// mesh deflection, and that times the mesh angular frequency), at which
    /// a point counts as periodic \[1\].
    pub tolerance: f64,
    /// Largest number of periods run at one speed before the point is
    /// measured as it is.
    pub max_periods: usize,
    /// Periods measured at a point that did not settle.
    pub window_periods: usize,
}

impl Default for FrameSweepSettings {
    /// RK 5(4) at 1e-6 in the relative frame (E_h against long time
    /// marching: docs/PERFORMANCE.md), periodic at 1e-4 of the state scales,
    /// at most 34 periods of run-in and 68 measured at a point that does not
    /// settle (one and two input revolutions of the example: the study's
    /// protocol).
    fn default() -> Self {
        Self {
            flow: ShootingSettings {
                relative_tolerance: 1e-6,
                samples_per_mesh_cycle: 60,
                ..Default::default()
            },
            tolerance: 1e-4,
            max_periods: 34,
            window_periods: 68,
        }
    }
}

/// One speed of a sweep in the rigid-body frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FramePoint {
    /// The measured steady state (mesh forces over the window, harmonics).
    pub state: SteadyState,
    /// Whether the state settled to a periodic one (measured over one period).
    pub periodic: bool,
    /// Periods integrated at this speed (run-in and window).
    pub periods: usize,
}

impl FrameSweepSettings {
    /// Refuses settings that cannot work, naming the setting and the range
    /// (the flow's settings are checked by [`PeriodicProblem::new`]).
    pub fn check(&self) -> Result<(), PeriodicError> {
        let bad = |name: &str, value: f64, reason: &str| Err(PeriodicError::invalid(name, value, reason));
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return bad("frame sweep tolerance", self.tolerance, "must be positive and finite");
        }
        if self.max_periods == 0 {
            return bad("frame sweep max_periods", 0.0, "must be at least 1");
        }
        if self.window_periods == 0 {
            return bad("frame sweep window_periods", 0.0, "must be at least 1");
        }
        Ok(())
    }
}

/// Sweeps `model` over `speeds` [rad/s], in the given order.
pub fn frame_sweep(
    model: &PlanetaryDynamics,
    speeds: &[f64],
    settings: &FrameSweepSettings,
) -> Result<Vec<FramePoint>, PeriodicError> {
    settings.check()?;
    let mut points = Vec::with_capacity(speeds.len());
    // The relative state (q_e, v_e) carried from one speed to the next.
    let mut carried: Option<(Vec<f64>, Vec<f64>)> = None;
    for &omega in speeds {
        let mut problem = PeriodicProblem::new(model.clone(), settings.flow, omega)?;
        let mut work = Work::default();
        let mut z = match &carried {
            Some((q, v)) => problem.reduce(q, v),
            None => problem.cold_start(omega, &mut work)?,
        };
        let mut periods = 0;
        let mut settling = Settling::new(settings.tolerance);
        let mut periodic = false;
        while periods < settings.max_periods {
            let r = problem.residual(omega, &z, &mut work)?;
            periods += 1;
            for (zi, ri) in z.iter_mut().zip(&r) {
                *zi += ri;
            }
            if settling.settled(max_abs(&r), &z) {
                periodic = true;
                break;
            }
        }
        let (period, cycles) = (problem.period(omega), problem.cycles());
        let orbit = |z: Vec<f64>, work: Work, flows: usize| PeriodicOrbit {
            speed: omega,
            period,
            cycles,
            z,
            residual: 0.0,
            newton_iterations: 0,
            multipliers: Vec::new(),
            flows,
            work,
        };
        let state = if periodic {
            let o = orbit(z.clone(), work, periods);
            let s = problem.steady_state(&o)?;
            periods += 1;
            z = reduce_end(&problem, &s, omega);
            s
        } else {
            // The last `window_periods` periods, one after another.
            let mut force: Vec<Vec<f64>> = Vec::new();
            let mut time = Vec::new();
            let mut last = None;
            let mut settled = None;
            for k in 0..settings.window_periods.max(1) {
                let o = orbit(z.clone(), work, periods);
                let s = problem.steady_state(&o)?;
                periods += 1;
                work = s.stats;
                let end = reduce_end(&problem, &s, omega);
                let change = end.iter().zip(&z).fold(0.0_f64, |a, (e, z)| a.max((e - z).abs()));
                z = end;
                if settling.settled(change, &z) {
                    // Settled inside the window: the period just measured is the periodic state.
                    settled = Some(s);
                    break;
                }
                let offset = k as f64 * o.period;
                time.extend(s.time.iter().map(|t| t + offset));
                if force.is_empty() {
                    force = vec![Vec::new(); s.mesh_force.len()];
                }
                for (f, g) in force.iter_mut().zip(&s.mesh_force) {
                    f.extend_from_slice(g);
                }
                last = Some(s);
            }
            if let Some(s) = settled {
                periodic = true;
                s
            } else {
                measured_window(&problem, omega, settings, last, time, force)?
            }
        };
        carried = Some(problem.expand(&z));
        let mut state = state;
        state.time = Vec::new();
        state.mesh_force = Vec::new();
        points.push(FramePoint { state, periodic, periods });
    }
    Ok(points)
}

/// The unknowns at the end of a measured period (its absolute end state
/// taken back to the relative frame at t = T).
fn reduce_end(problem: &PeriodicProblem, s: &SteadyState, omega: f64) -> Vec<f64> {
    let rigid = problem.model().rigid_velocity_at(omega);
    let t = problem.period(omega);
    let q: Vec<f64> = s.end.q.iter().zip(&rigid).map(|(q, r)| q - r * t).collect();
    let v: Vec<f64> = s.end.v.iter().zip(&rigid).map(|(v, r)| v - r).collect();
    problem.reduce(&q, &v)
}

/// The state of a point that did not settle, measured over the whole window:
/// `last` is the window's last period, `time` and `force` the window's
/// samples, one period after another.
fn measured_window(
    problem: &PeriodicProblem,
    omega: f64,
    settings: &FrameSweepSettings,
    last: Option<SteadyState>,
    time: Vec<f64>,
    force: Vec<Vec<f64>>,
) -> Result<SteadyState, PeriodicError> {
    let mut s = last.expect("at least one period");
    let cycles = problem.cycles() * settings.window_periods.max(1);
    for (m, f) in s.meshes.iter_mut().zip(&force) {
        m.harmonics = mesh_harmonics(f, cycles, 6)
            .map_err(|source| PeriodicError::Spectrum { speed: omega, source })?;
        m.separation = separation_fraction(f);
        m.max_force = f.iter().cloned().fold(0.0, f64::max);
    }
    s.cycles = cycles;
    s.time = time;
    s.mesh_force = force;
    Ok(s)
}

/// The settling test of a point: the change over one period divided by
/// 1 − ρ, ρ the contraction of that change from the period before (at most
/// 0.99), at most `tolerance` times the state's size (at least 1, in state
/// scales), once two successive changes are known.
struct Settling {
    tolerance: f64,
    previous: Option<f64>,
    changes: usize,
}

impl Settling {
    fn new(tolerance: f64) -> Self {
        Self { tolerance, previous: None, changes: 0 }
    }

    /// Takes the change of the period that ended in `z`; whether the point is settled.
    fn settled(&mut self, change: f64, z: &[f64]) -> bool {
        let rho = self.previous.map_or(0.5, |p| if p > 0.0 { (change / p).min(0.99) } else { 0.0 });
        self.previous = Some(change);
        self.changes += 1;
        let size = z.iter().fold(1.0_f64, |a, x| a.max(x.abs()));
        self.changes >= 2 && change / (1.0 - rho) <= self.tolerance * size
    }
}
