//! Periodic steady states by shooting, with their Floquet multipliers
//! (docs/PERIODIC.md).
//!
//! The tooth-by-tooth model is autonomous under the torque drive and
//! periodic in time under the speed drive; in both cases the equations of
//! motion, written in coordinates relative to the rigid-body motion
//! q = q_e + r ω t (r the rigid velocity pattern per rad/s of input speed),
//! repeat after the excitation period T: every mesh's force law is a
//! function of its pair position, which advances by one base pitch per mesh
//! cycle on every mesh alike, so T is one mesh cycle whatever the planet
//! spacing ([`excitation_period`] confirms it on the model itself and takes
//! the least multiple of the mesh cycle for which the equations repeat).
//!
//! A periodic steady state is a zero of G(x) = φ_T(x) − x, with x the
//! relative state (q_e, v_e) at t = 0 and φ_T the flow over one period,
//! computed by the adaptive Runge–Kutta 5(4) method with located contact
//! events in the relative frame. Under the torque drive the rigid-body
//! rotation is free: its momentum rᵀM v is conserved (the external torques
//! balance, the meshes and bearings do no work along r), so the rigid
//! angle advances exactly at ω and the relative state is restricted to the
//! M-orthogonal complement of r (rᵀM q_e = 0, which also fixes the phase of
//! the orbit to the mesh, and rᵀM v_e = 0); the input member's coordinate is
//! the one eliminated. Under the speed drive the shaft ties the input to the
//! source and all coordinates take part.
//!
//! Newton's method with a backtracking line search solves G = 0; its
//! Jacobian is M − I with M the monodromy matrix ([`MonodromyMethod`]):
//! by default from the variational equations integrated with the flow, one
//! augmented flow (`variational`); or with columns that are forward
//! differences of the flow, one flow per unknown (the contact force is
//! piecewise smooth: the integrator locates every contact switch, so the
//! flow is differentiable between switches and the differences follow the
//! switching times, the jump of the mesh damping force when a mesh
//! separates included, which the variational equations take as a saltation
//! term).
//! The eigenvalues of M (faer's non-symmetric eigensolver) are the Floquet
//! multipliers; the orbit is stable when all lie inside the unit circle.

mod harmonic;
mod krylov;
mod series;
mod switches;
mod variational;

pub use harmonic::{
    held, highest_frequency, refit, ArcLinear, ArcWork, CondensedArc, CondensedBalance, CondensedReport,
    HarmonicBalance, HarmonicOrbit, HarmonicSettings, Symmetry, ARC_CHORD_CONTRACTION,
    CONDENSED_MAX_HARMONICS, CONDENSED_UNKNOWNS, DENSE_UNKNOWNS, HANDOVER_STEP, HARMONICS_PER_MODE_ORDER,
    MAX_RULE_HARMONICS, MAX_UNKNOWNS, MIN_HARMONICS, NEIGHBOUR_OFFSETS, SAMPLES_PER_HARMONIC,
    SCAN_INTERVALS_PER_STEP, SPECTRAL_TAIL, SPEED_DIFFERENCE, STALLED_ITERATIONS, SYMMETRY_TOLERANCE,
};
pub use krylov::{KRYLOV_BAND, KRYLOV_ITERATIONS, KRYLOV_TOLERANCE};

use faer::linalg::solvers::Solve;
use serde::{Deserialize, Serialize};

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{mesh_responses, static_state, State, SteadyState, Work};
use crate::dynamics::rigid_frame::RigidFrame;
use crate::dynamics::solver::{Rk45, Rk45Settings, SecondOrderSystem, SolverError};
use crate::dynamics::spectrum::SpectrumError;
use variational::Variational;

/// How far above the Newton tolerance an iterate may stop when Newton stalls.
///
/// G(z) = φ_T(z) − z is computed by an adaptive integrator: where z moves, the
/// step sequence changes, so G is rough at the level of the flow's accumulated
/// local errors. At the default flow tolerance (1e-7) that roughness is the
/// size of the default Newton tolerance (1e-5 of the state scales): on the
/// torsional example, moving z by 1e-9 changes G by up to 1.9e-5 at 500 rpm,
/// 1.7e-5 at 2000 rpm and 3.9e-5 at 8000 rpm, and Newton stalled at 1.0e-5 to
/// 2.7e-5 near 630 rpm. An iteration that no longer halves G there has
/// reached the flow's noise, not a failure: the iterate is accepted when G
/// is at most this factor times the tolerance, and Newton fails as before
/// above it.
pub const NOISE_FLOOR_FACTOR: f64 = 10.0;

/// Whether Newton has converged at the unknowns `z` with a residual whose
/// largest component is `norm` ([`max_abs`]), having been `previous` one
/// iteration before (infinite at the first): G at most `tolerance` times the
/// size of z (at least 1), or, at the flow's noise floor, an iteration that
/// no longer halved G and G at most [`NOISE_FLOOR_FACTOR`] times that.
pub fn newton_converged(norm: f64, z: &[f64], previous: f64, tolerance: f64) -> bool {
    let size = max_abs(z).max(1.0);
    norm <= tolerance * size || (norm > 0.5 * previous && norm <= NOISE_FLOOR_FACTOR * tolerance * size)
}

/// Settings of the shooting method.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShootingSettings {
    /// Relative tolerance of the Runge–Kutta 5(4) flow in the relative frame
    /// (absolute tolerances: this fraction of the state scales).
    pub relative_tolerance: f64,
    /// Newton stops when the largest component of G, in units of the state
    /// scales (static mesh deflection, and that deflection times the mesh
    /// angular frequency at the reference speed), is at most this; or, when
    /// an iteration no longer halves G, once G is at most
    /// [`NOISE_FLOOR_FACTOR`] times this (see there).
    pub newton_tolerance: f64,
    /// Largest number of Newton iterations at one speed.
    pub max_newton_iterations: usize,
    /// Forward-difference step of the monodromy columns, in state-scale units.
    pub difference_step: f64,
    /// Samples per mesh cycle of the orbit's recorded mesh forces.
    pub samples_per_mesh_cycle: usize,
    /// Periods run from the static state before Newton starts (a cold start).
    pub run_in_periods: usize,
    /// How the monodromy matrix is computed.
    #[serde(default)]
    pub monodromy: MonodromyMethod,
}

/// How [`PeriodicProblem::linearize`] computes the monodromy matrix.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MonodromyMethod {
    /// The variational equations M Ẍ = −K X − C Ẋ integrated with the flow
    /// in one augmented flow (the module `variational`), with the saltation
    /// term of the mesh damping's jump where a whole mesh separates or
    /// touches again.
    #[default]
    Variational,
    /// Forward differences of the flow, one flow per unknown, with the step
    /// [`ShootingSettings::difference_step`].
    Differences,
}

impl Default for ShootingSettings {
    fn default() -> Self {
        Self {
            relative_tolerance: 1e-7,
            newton_tolerance: 1e-5,
            max_newton_iterations: 20,
            difference_step: 1e-3,
            samples_per_mesh_cycle: 64,
            run_in_periods: 4,
            monodromy: MonodromyMethod::Variational,
        }
    }
}

impl ShootingSettings {
    /// Refuses settings that cannot work, naming the setting and the range.
    pub fn check(&self) -> Result<(), PeriodicError> {
        let bad = |name: &str, value: f64, reason: &str| Err(PeriodicError::invalid(name, value, reason));
        let t = self.relative_tolerance;
        if !(t.is_finite() && (1e-13..=1e-3).contains(&t)) {
            return bad("shooting relative tolerance", t, "must lie in 1e-13 ..= 1e-3");
        }
        if !(self.newton_tolerance.is_finite() && self.newton_tolerance > 0.0) {
            return bad("shooting Newton tolerance", self.newton_tolerance, "must be positive and finite");
        }
        if self.max_newton_iterations == 0 {
            return bad("shooting Newton iterations", 0.0, "must be at least 1");
        }
        if !(self.difference_step.is_finite() && self.difference_step > 0.0 && self.difference_step < 1.0) {
            return bad("shooting difference step", self.difference_step, "must lie in (0, 1)");
        }
        if self.samples_per_mesh_cycle < 16 {
            return bad("samples per mesh cycle", self.samples_per_mesh_cycle as f64, "must be at least 16");
        }
        Ok(())
    }
}

/// Errors of the periodic-steady-state solver.
#[derive(Debug, thiserror::Error)]
pub enum PeriodicError {
    /// The integrator failed.
    #[error("integration failed at {speed} rad/s: {source}")]
    Integration {
        /// Input speed [rad/s].
        speed: f64,
        /// The integrator's error.
        source: SolverError,
    },
    /// Newton's method did not reach the tolerance.
    #[error("no periodic state found at {speed} rad/s: residual {residual:.3e} after {iterations} Newton iterations")]
    NotConverged {
        /// Input speed [rad/s].
        speed: f64,
        /// Newton iterations made.
        iterations: usize,
        /// Largest scaled residual component left.
        residual: f64,
    },
    /// The equations do not repeat after any tried multiple of the mesh cycle.
    #[error("the equations of motion do not repeat within {cycles} mesh cycles (largest force change {change:.3e} of the largest force)")]
    NotPeriodic {
        /// Mesh cycles tried.
        cycles: usize,
        /// Relative change of the forces after that many cycles.
        change: f64,
    },
    /// The mesh-force spectrum could not be formed.
    #[error("spectrum at {speed} rad/s: {source}")]
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

impl PeriodicError {
    /// A setting that cannot work: its name, its value and what is allowed.
    pub fn invalid(name: &str, value: f64, reason: &str) -> Self {
        PeriodicError::InvalidRequest { name: name.into(), value: value.to_string(), reason: reason.into() }
    }
}

/// A Floquet multiplier (real and imaginary part).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Multiplier {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Multiplier {
    /// Modulus |μ|.
    pub fn modulus(&self) -> f64 {
        self.re.hypot(self.im)
    }

    /// Whether μ is real (imaginary part below 1e-8 of the modulus, or 1e-10).
    pub fn is_real(&self) -> bool {
        self.im.abs() <= 1e-8 * self.modulus().max(1e-2)
    }
}

/// A periodic steady state: its initial relative state, its Floquet
/// multipliers and the work spent on it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PeriodicOrbit {
    /// Input speed [rad/s].
    pub speed: f64,
    /// Period \[s\] (a whole number of mesh cycles).
    pub period: f64,
    /// Mesh cycles in the period.
    pub cycles: usize,
    /// The unknowns at t = 0 (scaled relative state, see [`PeriodicProblem::expand`]).
    pub z: Vec<f64>,
    /// Largest scaled residual component at the solution.
    pub residual: f64,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Floquet multipliers, largest modulus first (empty when not computed).
    pub multipliers: Vec<Multiplier>,
    /// Flows over one period integrated for this orbit (residuals, line
    /// search, monodromy columns).
    pub flows: usize,
    /// Integrator work for this orbit.
    pub work: Work,
}

impl PeriodicOrbit {
    /// Largest |μ| (0 when the multipliers were not computed).
    pub fn largest_multiplier(&self) -> f64 {
        self.multipliers.first().map_or(0.0, Multiplier::modulus)
    }

    /// An orbit of one mesh cycle at `speed` [rad/s] and `period` \[s\] with
    /// nothing else known: no unknowns, no multipliers, no work (for the
    /// tests of what reads orbits).
    #[cfg(test)]
    pub(crate) fn bare(speed: f64, period: f64) -> Self {
        PeriodicOrbit {
            speed,
            period,
            cycles: 1,
            z: vec![],
            residual: 0.0,
            newton_iterations: 0,
            multipliers: vec![],
            flows: 0,
            work: Work::default(),
        }
    }

    /// All multipliers inside the unit circle ([`all_inside_unit_circle`]):
    /// false for an orbit whose multipliers are not known.
    pub fn is_stable(&self) -> bool {
        all_inside_unit_circle(&self.multipliers)
    }
}

/// Whether a periodic orbit with these Floquet multipliers is stable: there
/// are some, and every one lies inside the unit circle. An empty list is
/// "not known", which is never reported as stable.
pub fn all_inside_unit_circle(multipliers: &[Multiplier]) -> bool {
    !multipliers.is_empty() && multipliers.iter().all(|m| m.modulus() < 1.0)
}

/// The monodromy matrix and the derivative of G with respect to the speed at
/// a state (both in scaled units; column-major dense matrix of size m × m).
#[derive(Clone, Debug)]
pub struct Linearization {
    /// Number of unknowns m.
    pub dim: usize,
    /// Monodromy matrix ∂φ_T/∂z, `monodromy[i + m j]`.
    pub monodromy: Vec<f64>,
    /// ∂G/∂ω (per rad/s).
    pub speed_derivative: Vec<f64>,
    /// G at the state.
    pub residual: Vec<f64>,
}

/// What a sampled flow does at each sample: time, the relative coordinates
/// q_e, and the model evaluated there.
type Observer<'a> = dyn FnMut(f64, &[f64], &[f64], &PlanetaryDynamics) + 'a;

/// Mesh cycles (1, 2, …, up to 12) after which the equations of motion in
/// the relative frame repeat at speed `omega` [rad/s]: the least common
/// period of all meshes' excitation. Checked on the model's forces at three
/// states and times; an error when none of the tried multiples repeats.
pub fn excitation_period(model: &mut PlanetaryDynamics, omega: f64) -> Result<usize, PeriodicError> {
    let fm = model.mesh_frequency_per_input_speed * omega.abs();
    if !(fm.is_finite() && fm > 0.0) {
        return Err(PeriodicError::InvalidRequest {
            name: "input speed".into(),
            value: format!("{omega} rad/s"),
            reason: "must be non-zero and finite: the period is a whole number of mesh cycles".into(),
        });
    }
    let mesh_period = 1.0 / fm;
    let n = model.dim();
    model.set_drive_speed(omega);
    let s = static_state(model, omega);
    let rigid = model.rigid_velocity_at(omega);
    let mut frame = RigidFrame::new(model, rigid);
    let ve = vec![0.0; n];
    let mut worst = f64::INFINITY;
    for cycles in 1..=12usize {
        let period = cycles as f64 * mesh_period;
        let mut change: f64 = 0.0;
        for (k, t) in [0.0, 0.37, 0.81].iter().enumerate() {
            let t = t * mesh_period;
            // Three distinct elastic states: the static one and two scaled copies.
            let qe: Vec<f64> = s.q.iter().map(|x| x * (1.0 + 0.3 * k as f64)).collect();
            let (mut f0, mut f1) = (vec![0.0; n], vec![0.0; n]);
            frame.force(t, &qe, &ve, &mut f0);
            frame.force(t + period, &qe, &ve, &mut f1);
            let scale = f0.iter().fold(0.0_f64, |a, x| a.max(x.abs())).max(f64::MIN_POSITIVE);
            let d = f0.iter().zip(&f1).fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
            change = change.max(d / scale);
        }
        if change <= 1e-9 {
            return Ok(cycles);
        }
        worst = worst.min(change);
    }
    Err(PeriodicError::NotPeriodic { cycles: 12, change: worst })
}

/// The periodic-steady-state problem of one model: the unknowns, their
/// scales, the flow and its derivatives, Newton's method and the orbit's
/// measures.
#[derive(Clone, Debug)]
pub struct PeriodicProblem {
    model: PlanetaryDynamics,
    settings: ShootingSettings,
    /// The coordinate eliminated by rᵀM q_e = 0 (torque drive), if any.
    eliminated: Option<usize>,
    /// M r.
    weights: Vec<f64>,
    q_scale: f64,
    v_scale: f64,
    cycles: usize,
}

impl PeriodicProblem {
    /// The problem of `model`, with state scales taken at the reference speed
    /// `reference_speed` [rad/s] (the static mesh deflection, and that times
    /// the mesh angular frequency for velocities).
    pub fn new(
        mut model: PlanetaryDynamics,
        settings: ShootingSettings,
        reference_speed: f64,
    ) -> Result<Self, PeriodicError> {
        settings.check()?;
        let cycles = excitation_period(&mut model, reference_speed)?;
        let n = model.dim();
        let s = static_state(&model, reference_speed);
        // The speed drive's source is placed once, at the static state.
        model.rebase_drive(&s.q);
        let free = model.drive_state().is_empty();
        let weights: Vec<f64> = model.mass().iter().zip(&model.rigid_velocity).map(|(m, r)| m * r).collect();
        let eliminated = free.then_some(model.input_index);
        let mut f = vec![0.0; n];
        model.force(0.0, &s.q, &model.rigid_velocity_at(reference_speed), &mut f);
        let deflection = model.meshes.iter().fold(0.0_f64, |a, m| a.max(m.approach.abs()));
        let q_scale = if deflection > 0.0 { deflection } else { 1e-6 };
        let fm = model.mesh_frequency_per_input_speed * reference_speed.abs();
        let v_scale = q_scale * 2.0 * std::f64::consts::PI * fm;
        Ok(Self { model, settings, eliminated, weights, q_scale, v_scale, cycles })
    }

    /// The settings.
    pub fn settings(&self) -> &ShootingSettings {
        &self.settings
    }

    /// The model.
    pub fn model(&self) -> &PlanetaryDynamics {
        &self.model
    }

    /// Number of unknowns: 2(n − 1) under the torque drive, 2n under the speed drive.
    pub fn unknowns(&self) -> usize {
        let n = self.model.dim();
        if self.eliminated.is_some() {
            2 * (n - 1)
        } else {
            2 * n
        }
    }

    /// What one unit of each unknown is in SI units: the position scale
    /// (the static mesh deflection) for the coordinates, the velocity scale
    /// (that times the mesh angular frequency at the reference speed) for
    /// their rates. Two problems built at different reference speeds scale
    /// the velocities differently.
    pub fn unknown_scales(&self) -> Vec<f64> {
        let half = self.unknowns() / 2;
        let mut s = vec![self.q_scale; half];
        s.extend(std::iter::repeat_n(self.v_scale, half));
        s
    }

    /// Period \[s\] at speed `omega` [rad/s].
    pub fn period(&self, omega: f64) -> f64 {
        self.cycles as f64 / (self.model.mesh_frequency_per_input_speed * omega.abs())
    }

    /// Relative coordinates and velocities (q_e, v_e) of the unknowns z.
    pub fn expand(&self, z: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = self.model.dim();
        let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
        match self.eliminated {
            Some(k) => {
                for (j, i) in (0..n).filter(|i| *i != k).enumerate() {
                    q[i] = z[j] * self.q_scale;
                    v[i] = z[n - 1 + j] * self.v_scale;
                }
                let w = &self.weights;
                q[k] = -(0..n).filter(|i| *i != k).map(|i| w[i] * q[i]).sum::<f64>() / w[k];
                v[k] = -(0..n).filter(|i| *i != k).map(|i| w[i] * v[i]).sum::<f64>() / w[k];
            }
            None => {
                for i in 0..n {
                    q[i] = z[i] * self.q_scale;
                    v[i] = z[n + i] * self.v_scale;
                }
            }
        }
        (q, v)
    }

    /// The unknowns of a relative state (the inverse of [`Self::expand`] on
    /// the complement; the eliminated coordinate is dropped).
    pub fn reduce(&self, q: &[f64], v: &[f64]) -> Vec<f64> {
        let n = self.model.dim();
        let keep: Vec<usize> = (0..n).filter(|i| Some(*i) != self.eliminated).collect();
        let mut z: Vec<f64> = keep.iter().map(|i| q[*i] / self.q_scale).collect();
        z.extend(keep.iter().map(|i| v[*i] / self.v_scale));
        z
    }

    fn integrator(&self, period: f64) -> Result<Rk45, SolverError> {
        Rk45::new(self.integrator_settings(period))
    }

    /// The flow's RK 5(4) settings over a period of `period` \[s\].
    fn integrator_settings(&self, period: f64) -> Rk45Settings {
        let rtol = self.settings.relative_tolerance;
        Rk45Settings {
            rtol,
            atol_q: rtol * self.q_scale,
            atol_v: rtol * self.v_scale,
            max_step: period / 16.0,
            ..Rk45Settings::default()
        }
    }

    /// The flow over one period from unknowns `z` at speed `omega`: the
    /// unknowns at t = T; adds the integrator's work to `work`. `sample`
    /// receives (t, absolute q, absolute v, model) at `samples` equally spaced
    /// times t_k = kT/samples, k = 0 .. samples − 1, when given.
    fn flow(
        &mut self,
        omega: f64,
        z: &[f64],
        work: &mut Work,
        mut sample: Option<(usize, &mut Observer<'_>)>,
    ) -> Result<Vec<f64>, PeriodicError> {
        let period = self.period(omega);
        let err = |source| PeriodicError::Integration { speed: omega, source };
        let (qe, ve) = self.expand(z);
        let n = qe.len();
        let mut rk = self.integrator(period).map_err(err)?;
        self.model.set_drive_speed(omega);
        let rigid = self.model.rigid_velocity_at(omega);
        let mut frame = RigidFrame::new(&mut self.model, rigid);
        rk.init(&mut frame, 0.0, &qe, &ve).map_err(err)?;
        match &mut sample {
            Some((samples, observe)) => {
                let (mut q, mut v, mut f) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                for k in 0..*samples {
                    let t = period * k as f64 / *samples as f64;
                    while rk.time() < t {
                        rk.step(&mut frame, period).map_err(err)?;
                    }
                    rk.dense_at(t, &mut q, &mut v).map_err(err)?;
                    frame.force(t, &q, &v, &mut f);
                    if let Some(i) = f.iter().position(|x| !x.is_finite()) {
                        return Err(err(SolverError::NonFiniteState { t, index: i }));
                    }
                    observe(t, &q, &v, frame.model());
                }
                rk.advance_to(&mut frame, period).map_err(err)?;
            }
            None => rk.advance_to(&mut frame, period).map_err(err)?,
        }
        let s = Work::from(*rk.stats());
        work.steps += s.steps;
        work.rejected_steps += s.rejected_steps;
        work.rhs_evaluations += s.rhs_evaluations;
        work.events_located += s.events_located;
        Ok(self.reduce(rk.q(), rk.v()))
    }

    /// G(z) = φ_T(z) − z at speed `omega`.
    pub fn residual(&mut self, omega: f64, z: &[f64], work: &mut Work) -> Result<Vec<f64>, PeriodicError> {
        let end = self.flow(omega, z, work, None)?;
        Ok(end.iter().zip(z).map(|(a, b)| a - b).collect())
    }

    /// Flows one linearization costs with the settings' monodromy method:
    /// m + 2 by differences (the base flow, one per unknown, one in speed),
    /// 2 by the variational equations (the augmented flow, whose steps cost
    /// more, and one in speed).
    pub fn linearization_flows(&self) -> usize {
        match self.settings.monodromy {
            MonodromyMethod::Variational => 2,
            MonodromyMethod::Differences => self.unknowns() + 2,
        }
    }

    /// The monodromy matrix ([`MonodromyMethod`]) and ∂G/∂ω (a forward
    /// difference in speed) at `z`.
    pub fn linearize(
        &mut self,
        omega: f64,
        z: &[f64],
        work: &mut Work,
    ) -> Result<Linearization, PeriodicError> {
        self.linearize_with(omega, z, work, true)
    }

    /// [`Self::linearize`]; without the flow in speed (∂G/∂ω left empty)
    /// when `speed` is false.
    fn linearize_with(
        &mut self,
        omega: f64,
        z: &[f64],
        work: &mut Work,
        speed: bool,
    ) -> Result<Linearization, PeriodicError> {
        let m = z.len();
        let (base, monodromy) = match self.settings.monodromy {
            MonodromyMethod::Variational => self.variational_flow(omega, z, work)?,
            MonodromyMethod::Differences => {
                let h = self.settings.difference_step;
                let base = self.flow(omega, z, work, None)?;
                let mut monodromy = vec![0.0; m * m];
                let mut zp = z.to_vec();
                for j in 0..m {
                    zp[j] = z[j] + h;
                    let end = self.flow(omega, &zp, work, None)?;
                    zp[j] = z[j];
                    for i in 0..m {
                        monodromy[i + m * j] = (end[i] - base[i]) / h;
                    }
                }
                (base, monodromy)
            }
        };
        let speed_derivative = if speed {
            let dw = omega.abs() * self.settings.difference_step.sqrt().max(1e-6) * 1e-2;
            let end = self.flow(omega + dw, z, work, None)?;
            end.iter().zip(&base).map(|(a, b)| (a - b) / dw).collect()
        } else {
            Vec::new()
        };
        let residual = base.iter().zip(z).map(|(a, b)| a - b).collect();
        Ok(Linearization { dim: m, monodromy, speed_derivative, residual })
    }

    /// The flow over one period from `z` with its derivative: the end
    /// unknowns and the monodromy matrix (column-major m × m), from the
    /// variational equations integrated with the flow (the module
    /// `variational`), each column started at the relative state of one
    /// unknown's unit change.
    fn variational_flow(
        &mut self,
        omega: f64,
        z: &[f64],
        work: &mut Work,
    ) -> Result<(Vec<f64>, Vec<f64>), PeriodicError> {
        let period = self.period(omega);
        let err = |source| PeriodicError::Integration { speed: omega, source };
        let m = z.len();
        let (q0, v0) = self.expand(z);
        let n = q0.len();
        let mut unit = vec![0.0; m];
        let units: Vec<(Vec<f64>, Vec<f64>)> = (0..m)
            .map(|j| {
                unit[j] = 1.0;
                let column = self.expand(&unit);
                unit[j] = 0.0;
                column
            })
            .collect();
        // Every column enters the step control: a column starts as a unit
        // change of one coordinate and so carries every mode of the set,
        // the fastest included, which the orbit itself hardly excites.
        let settings = Rk45Settings { record_events: true, ..self.integrator_settings(period) };
        let mut rk = Rk45::new(settings).map_err(err)?;
        self.model.set_drive_speed(omega);
        let rigid = self.model.rigid_velocity_at(omega);
        let mut frame = RigidFrame::new(&mut self.model, rigid);
        let Some(mut system) = Variational::new(&mut frame, m) else {
            return Err(PeriodicError::InvalidRequest {
                name: "shooting monodromy".into(),
                value: "variational".into(),
                reason: "the model gives no tangent structure; use differences".into(),
            });
        };
        let (qa, va) = system.initial_state(&q0, &v0, &units);
        rk.init(&mut system, 0.0, &qa, &va).map_err(err)?;
        // Step by step: where a located event changes whether a mesh touches,
        // its damping force jumps and the columns take the jump's saltation.
        let mut touching = system.touching(0.0, &qa, &va);
        while rk.time() < period {
            rk.step(&mut system, period).map_err(err)?;
            let events = rk.take_located_events();
            if events.is_empty() {
                continue;
            }
            let t = rk.time();
            let (q, mut v) = (rk.q().to_vec(), rk.v().to_vec());
            let now = system.touching(t, &q, &v);
            // Under Rayleigh damping every pair switch is a jump of the
            // damping force, not only a mesh's contact starting or ending.
            if now != touching || system.rayleigh_meshes() {
                let steps = (1e-6 * period, self.q_scale);
                if system.saltation(t, &q, &mut v, (&touching, &now), &events, steps) {
                    let controller = rk.controller_state();
                    rk.restore(&mut system, t, &q, &v, &controller).map_err(err)?;
                }
                touching = now;
            }
        }
        let columns: Vec<(Vec<f64>, Vec<f64>)> = (0..m).map(|j| system.column(rk.q(), rk.v(), j)).collect();
        let s = Work::from(*rk.stats());
        work.steps += s.steps;
        work.rejected_steps += s.rejected_steps;
        work.rhs_evaluations += s.rhs_evaluations;
        work.events_located += s.events_located;
        let end = self.reduce(&rk.q()[..n], &rk.v()[..n]);
        let mut monodromy = Vec::with_capacity(m * m);
        for (x, y) in &columns {
            monodromy.extend(self.reduce(x, y));
        }
        Ok((end, monodromy))
    }

    /// The unknowns of the static deflection of the mean-stiffness model at `omega`
    /// [rad/s], at rest relative to the rigid-body motion (a cold start before its run-in).
    pub fn static_start(&self, omega: f64) -> Vec<f64> {
        let s = static_state(&self.model, omega);
        let n = s.q.len();
        // Project onto the unknowns' space: drop the rigid part of q.
        self.reduce(&s.q, &vec![0.0; n])
    }

    /// The unknowns of a cold start at `omega`: the static deflection of the
    /// mean-stiffness model, run for the settings' run-in periods.
    pub fn cold_start(&mut self, omega: f64, work: &mut Work) -> Result<Vec<f64>, PeriodicError> {
        let mut z = self.static_start(omega);
        for _ in 0..self.settings.run_in_periods {
            z = self.flow(omega, &z, work, None)?;
        }
        Ok(z)
    }

    /// The unknowns' coordinates (the first half of z: the relative
    /// coordinates over the static deflection scale) at `samples` equally
    /// spaced times of one period's flow from `z`, sample-major; `work` counts
    /// the flow.
    fn sampled_flow(
        &mut self,
        omega: f64,
        z: &[f64],
        samples: usize,
        work: &mut Work,
    ) -> Result<Vec<f64>, PeriodicError> {
        let n = self.model.dim();
        let mut relative = Vec::with_capacity(samples * n);
        let mut observe = |_: f64, q: &[f64], _: &[f64], _: &PlanetaryDynamics| relative.extend_from_slice(q);
        self.flow(omega, z, work, Some((samples, &mut observe)))?;
        let zeros = vec![0.0; n];
        Ok(relative
            .chunks(n)
            .flat_map(|q| {
                let z = self.reduce(q, &zeros);
                z[..z.len() / 2].to_vec()
            })
            .collect())
    }

    /// One period's flow from the unknowns `z` at `omega` [rad/s] sampled at `samples`
    /// equally spaced times: the coordinates and velocities relative to the rigid-body
    /// motion (sample-major), and each mesh's force and largest tooth-pair force at each
    /// sample (mesh-major); `work` counts the flow. The unknowns at the period's end
    /// come back last.
    #[allow(clippy::type_complexity)]
    pub fn sampled_period(
        &mut self,
        omega: f64,
        z: &[f64],
        samples: usize,
        work: &mut Work,
    ) -> Result<(Vec<f64>, Vec<f64>, Vec<Vec<(f64, f64)>>, Vec<f64>), PeriodicError> {
        let n = self.model.dim();
        let meshes = self.model.mesh_count();
        let (mut qs, mut vs) = (Vec::with_capacity(samples * n), Vec::with_capacity(samples * n));
        let mut forces = vec![Vec::with_capacity(samples); meshes];
        let mut observe = |_: f64, q: &[f64], v: &[f64], model: &PlanetaryDynamics| {
            qs.extend_from_slice(q);
            vs.extend_from_slice(v);
            for (f, m) in forces.iter_mut().zip(&model.meshes) {
                f.push((m.force, m.peak_pair_force));
            }
        };
        let end = self.flow(omega, z, work, Some((samples, &mut observe)))?;
        Ok((qs, vs, forces, end))
    }

    /// The periodic state at `omega` [rad/s] by Newton's method with a
    /// backtracking line search from `guess` (a cold start when `None`),
    /// with its Floquet multipliers.
    pub fn solve(&mut self, omega: f64, guess: Option<&[f64]>) -> Result<PeriodicOrbit, PeriodicError> {
        self.solve_with(omega, guess, false).map(|(orbit, _)| orbit)
    }

    /// [`Self::solve`], also returning the linearization at the solution
    /// (monodromy, ∂G/∂ω), which continuation needs for its tangent.
    pub fn solve_linearized(
        &mut self,
        omega: f64,
        guess: Option<&[f64]>,
    ) -> Result<(PeriodicOrbit, Linearization), PeriodicError> {
        self.solve_with(omega, guess, true)
    }

    /// Newton's method; the linearizations carry ∂G/∂ω when `speed` is true.
    fn solve_with(
        &mut self,
        omega: f64,
        guess: Option<&[f64]>,
        speed: bool,
    ) -> Result<(PeriodicOrbit, Linearization), PeriodicError> {
        let flows_per_linearization = self.linearization_flows() - usize::from(!speed);
        let mut work = Work::default();
        let mut flows = 0usize;
        let mut z = match guess {
            Some(g) => g.to_vec(),
            None => {
                flows += self.settings.run_in_periods;
                self.cold_start(omega, &mut work)?
            }
        };
        let m = z.len();
        let tol = self.settings.newton_tolerance;
        let mut lin = self.linearize_with(omega, &z, &mut work, speed)?;
        flows += flows_per_linearization;
        let mut lin_at = z.clone();
        let mut r = lin.residual.clone();
        let mut iterations = 0;
        let mut previous = f64::INFINITY;
        loop {
            let norm = max_abs(&r);
            if newton_converged(norm, &z, previous, tol) {
                break;
            }
            previous = norm;
            if iterations >= self.settings.max_newton_iterations {
                return Err(PeriodicError::NotConverged { speed: omega, iterations, residual: norm });
            }
            iterations += 1;
            let step = newton_step(&lin.monodromy, m, &r);
            let mut alpha = 1.0;
            let (mut z_new, mut r_new);
            loop {
                z_new = z.iter().zip(&step).map(|(a, d)| a + alpha * d).collect::<Vec<f64>>();
                r_new = self.residual(omega, &z_new, &mut work)?;
                flows += 1;
                if max_abs(&r_new) < (1.0 - 1e-4 * alpha) * norm || alpha < 1.0 / 64.0 {
                    break;
                }
                alpha *= 0.5;
            }
            let contraction = max_abs(&r_new) / norm;
            z = z_new;
            r = r_new;
            // Chord iterations while they contract well; a fresh monodromy otherwise.
            if contraction > 0.25 && max_abs(&r) > tol * max_abs(&z).max(1.0) {
                lin = self.linearize_with(omega, &z, &mut work, speed)?;
                flows += flows_per_linearization;
                lin_at = z.clone();
                r = lin.residual.clone();
            }
        }
        // The multipliers at the solution: the last monodromy unless Newton moved far from it.
        let moved = lin_at.iter().zip(&z).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        if moved > 1e-3 {
            lin = self.linearize_with(omega, &z, &mut work, speed)?;
            flows += flows_per_linearization;
        }
        let multipliers = floquet_multipliers(&lin.monodromy, m)?;
        let orbit = PeriodicOrbit {
            speed: omega,
            period: self.period(omega),
            cycles: self.cycles,
            z,
            residual: max_abs(&r),
            newton_iterations: iterations,
            multipliers,
            flows,
            work,
        };
        Ok((orbit, lin))
    }

    /// Mesh cycles in one period of the excitation.
    pub fn cycles(&self) -> usize {
        self.cycles
    }

    /// The orbit's mesh forces over one period and their measures, as a
    /// [`SteadyState`] (one window of `cycles` mesh cycles; the end state is
    /// the absolute state at t = T).
    pub fn steady_state(&mut self, orbit: &PeriodicOrbit) -> Result<SteadyState, PeriodicError> {
        let omega = orbit.speed;
        let samples = self.settings.samples_per_mesh_cycle * orbit.cycles;
        let n_mesh = self.model.mesh_count();
        let mut time = Vec::with_capacity(samples);
        let mut force = vec![Vec::with_capacity(samples); n_mesh];
        let mut work = orbit.work;
        let mut observe = |t: f64, _: &[f64], _: &[f64], m: &PlanetaryDynamics| {
            time.push(t);
            for (i, s) in m.meshes.iter().enumerate() {
                force[i].push(s.force);
            }
        };
        let end = self.flow(omega, &orbit.z, &mut work, Some((samples, &mut observe)))?;
        let (qe, ve) = self.expand(&end);
        let rigid = self.model.rigid_velocity_at(omega);
        let q = qe.iter().zip(&rigid).map(|(q, r)| q + r * orbit.period).collect();
        let v = ve.iter().zip(&rigid).map(|(v, r)| v + r).collect();
        let meshes = mesh_responses(&self.model, &force, orbit.cycles)
            .map_err(|source| PeriodicError::Spectrum { speed: omega, source })?;
        Ok(SteadyState {
            input_speed: omega,
            mesh_frequency: self.model.mesh_frequency_per_input_speed * omega.abs(),
            mean_input_speed: omega,
            cycles: orbit.cycles,
            time,
            mesh_force: force,
            meshes,
            stats: work,
            end: State { input_speed: omega, q, v },
        })
    }
}

/// The largest absolute value of `x` (0 when empty; NaN entries are passed over).
pub fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |a, b| a.max(b.abs()))
}

/// The Newton step of G: solves (M − I) d = −r with faer's partial-pivoting LU.
fn newton_step(monodromy: &[f64], m: usize, r: &[f64]) -> Vec<f64> {
    let a = faer::Mat::<f64>::from_fn(m, m, |i, j| monodromy[i + m * j] - if i == j { 1.0 } else { 0.0 });
    let b = faer::Mat::<f64>::from_fn(m, 1, |i, _| -r[i]);
    let x = a.partial_piv_lu().solve(&b);
    (0..m).map(|i| x[(i, 0)]).collect()
}

/// Solves the square system `a x = b` (column-major `a`, size m) with
/// faer's partial-pivoting LU.
pub fn solve_dense(a: &[f64], m: usize, b: &[f64]) -> Vec<f64> {
    let fa = faer::Mat::<f64>::from_fn(m, m, |i, j| a[i + m * j]);
    let fb = faer::Mat::<f64>::from_fn(m, 1, |i, _| b[i]);
    let x = fa.partial_piv_lu().solve(&fb);
    (0..m).map(|i| x[(i, 0)]).collect()
}

/// The eigenvalues of the monodromy matrix (faer's non-symmetric
/// eigensolver), largest modulus first. A monodromy with an entry that is not
/// finite, or one the eigensolver does not converge on, is an error: an
/// orbit never goes on without its multipliers.
pub fn floquet_multipliers(monodromy: &[f64], m: usize) -> Result<Vec<Multiplier>, PeriodicError> {
    if monodromy.len() != m * m {
        return Err(PeriodicError::invalid(
            "monodromy matrix length",
            monodromy.len() as f64,
            &format!("must be m × m = {} for m = {m}", m * m),
        ));
    }
    if let Some(bad) = monodromy.iter().find(|x| !x.is_finite()) {
        return Err(PeriodicError::invalid("monodromy matrix entry", *bad, "must be finite"));
    }
    let a = faer::Mat::<f64>::from_fn(m, m, |i, j| monodromy[i + m * j]);
    let values = a.eigenvalues().map_err(|e| PeriodicError::InvalidRequest {
        name: "monodromy matrix".into(),
        value: format!("{m} × {m}"),
        reason: format!("its eigenvalues (the Floquet multipliers) could not be computed: {e:?}"),
    })?;
    let mut mu: Vec<Multiplier> = values.iter().map(|c| Multiplier { re: c.re, im: c.im }).collect();
    if let Some(bad) = mu.iter().find(|x| !x.modulus().is_finite()) {
        return Err(PeriodicError::invalid("Floquet multiplier", bad.modulus(), "must be finite"));
    }
    mu.sort_by(|a, b| b.modulus().total_cmp(&a.modulus()));
    Ok(mu)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn multipliers_of_a_known_matrix() {
        // A rotation by 0.3 rad scaled by 0.9, and a real 1.2: |μ| = 1.2, 0.9, 0.9.
        let (c, s) = (0.9 * 0.3f64.cos(), 0.9 * 0.3f64.sin());
        let a = [c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.2];
        let mu = floquet_multipliers(&a, 3).unwrap();
        assert!((mu[0].re - 1.2).abs() < 1e-12 && mu[0].is_real());
        assert!((mu[1].modulus() - 0.9).abs() < 1e-12 && !mu[1].is_real());
        assert!((mu[1].im.abs() - s).abs() < 1e-12);
        let x = solve_dense(&a, 3, &[1.0, 0.0, 2.4]);
        assert!((x[2] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_monodromy_that_is_not_finite_is_an_error_naming_it() {
        let mut a = [0.5, 0.0, 0.0, 0.5];
        a[2] = f64::NAN;
        let e = floquet_multipliers(&a, 2).unwrap_err().to_string();
        assert!(e.contains("monodromy matrix entry") && e.contains("finite"), "{e}");
        a[2] = f64::INFINITY;
        assert!(floquet_multipliers(&a, 2).is_err());
        let e = floquet_multipliers(&[1.0; 3], 2).unwrap_err().to_string();
        assert!(e.contains("monodromy matrix length") && e.contains("m × m = 4"), "{e}");
    }

    #[test]
    fn an_orbit_is_stable_only_with_every_multiplier_known_and_inside() {
        let mu = |re: f64, im: f64| Multiplier { re, im };
        assert!(all_inside_unit_circle(&[mu(0.9, 0.0), mu(0.3, 0.4)]));
        assert!(!all_inside_unit_circle(&[]), "no multipliers: not known, never stable");
        assert!(!all_inside_unit_circle(&[mu(0.6, 0.8)]), "on the circle");
        assert!(
            !all_inside_unit_circle(&[mu(0.1, 0.0), mu(-1.2, 0.0)]),
            "unsorted list, an outside one last"
        );
        assert!(!all_inside_unit_circle(&[mu(f64::NAN, 0.0)]));
        assert!(!PeriodicOrbit::bare(1.0, 1.0).is_stable());
    }
}
