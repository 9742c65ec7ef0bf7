//! Periodic steady states by harmonic balance with alternating frequency–time
//! evaluation of the contact forces (docs/PERIODIC.md §2).
//!
//! The relative coordinates of the unknowns' space (the M-orthogonal
//! complement of the rigid motion under the torque drive, all coordinates
//! under the speed drive) are truncated Fourier series over the period T,
//!
//! y(t) = a₀ + Σ_{k=1..H} (a_k cos kνt + b_k sin kνt),  ν = 2π/T,
//!
//! in units of the static mesh deflection. The equations of motion
//! Pᵀ(M P ÿ − f(t, P y, P ẏ)) = 0 (P the map from the unknowns' space to the
//! relative coordinates) are sampled at N equally spaced times, and their
//! first 2H + 1 Fourier coefficients (a Galerkin projection computed by
//! rustfft) must vanish. Newton's method solves that system: its Jacobian is
//! the inertia −k²ν²PᵀMP of each harmonic plus the Fourier convolution of the
//! tangent stiffness and damping along the orbit, assembled from their
//! Fourier coefficients up to 2H by the product-to-sum identities (exact for
//! the sampled sums), and factorised by faer's partial-pivoting LU.
//!
//! The contact force is piecewise linear in the approach: where a tooth pair
//! enters or leaves contact it has a kink in time, and where a mesh separates
//! its damping force jumps. Harmonics beyond H are not balanced, and the
//! switches' would alias onto the kept ones through the samples: Newton first
//! solves the plain N-sample sums, then, from their root, the sums with each
//! switch located on the series and its jump and kink projected exactly
//! (module `switches`). What the truncation costs in accuracy against the
//! time integrator's located events is measured, not assumed
//! (docs/PERIODIC.md).

//!
//! The files by step: `aft` the residual and the Jacobian's tangent
//! sequences by alternating frequency–time evaluation, `jacobian` the
//! Jacobian's assembly and Newton's linear step on it, `solve` Newton's
//! runs and cold starts, `floquet` the orbit's multipliers, `arc` the
//! balance bordered for continuation, `condensed` the balance condensed on
//! the contact coordinates.

mod aft;
mod arc;
mod condensed;
mod floquet;
mod jacobian;
mod solve;

pub use arc::{refit, ArcLinear, ArcWork, ARC_CHORD_CONTRACTION, SPEED_DIFFERENCE};
pub use condensed::{
    held, CondensedArc, CondensedBalance, CondensedReport, Symmetry, CONDENSED_MAX_HARMONICS,
    CONDENSED_UNKNOWNS, SYMMETRY_TOLERANCE,
};

use rustfft::num_complex::Complex;
use serde::{Deserialize, Serialize};

use super::krylov::KRYLOV_ITERATIONS;
use super::series::{synthesize_with, Plans};
use super::switches::{series_state, Switch};
use super::{PeriodicError, PeriodicProblem};
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{mesh_responses, static_state, State, SteadyState, Work};
use crate::dynamics::rigid_frame::RigidFrame;
use crate::dynamics::solver::{SecondOrderSystem, TangentSystem};
use jacobian::Jacobian;

/// Settings of the harmonic balance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HarmonicSettings {
    /// Harmonics H of the period kept in the coordinates.
    pub harmonics: usize,
    /// Time samples N per period of the alternating frequency–time step
    /// (at least 2H + 1).
    pub samples: usize,
    /// Newton stops when its step is at most this, in units of the static
    /// mesh deflection times the size of the coefficients (at least 1), or,
    /// on the projected residual, when the distance to the root left after
    /// the step, estimated from the steps' contraction, is at most this.
    pub tolerance: f64,
    /// Largest number of Newton iterations at one speed (the example's
    /// orbits converge in 4 to 10 from a cold start; where the series cannot
    /// resolve the orbit, Newton cycles instead, see docs/PERIODIC.md §2).
    pub max_iterations: usize,
    /// The Jacobian is kept (chord iterations) while an iteration lowers the
    /// residual at least by this factor, and assembled afresh otherwise
    /// (0: every iteration).
    pub chord_contraction: f64,
}

impl Default for HarmonicSettings {
    fn default() -> Self {
        Self { harmonics: 32, samples: 512, tolerance: 1e-7, max_iterations: 15, chord_contraction: 0.05 }
    }
}

/// Harmonics kept per highest natural frequency in the period: H is at
/// least this times f_hi T (f_hi the highest natural frequency of the
/// linearized model at the static state, T the period). Measured on the
/// torsional example (docs/PERIODIC.md §2): the planets' own modes ring at
/// every contact switch, and with fewer harmonics than about 2.5 times their
/// order in the period E_h exceeds 1e-3 (1500 rpm: 8.8e-4 at 2.6 times,
/// 500 rpm: 1.3e-3 at 1.3 times).
pub const HARMONICS_PER_MODE_ORDER: f64 = 2.5;

/// The fewest harmonics [`HarmonicSettings::for_speed`] keeps: where the
/// teeth separate the damping force jumps and the orbit needs them whatever
/// the modes (torsional example, 10 200 rpm: E_h 1.1e-3 with 24, 5.5e-4 with
/// 32; 13 000 rpm: 7.8e-4 with 24, 7.6e-4 with 32).
pub const MIN_HARMONICS: usize = 32;

/// The most harmonics [`HarmonicSettings::for_speed`] keeps, whatever the
/// rule asks: the transverse–torsional example's 19 coordinates then take
/// 19 × 1025 = 19 475 unknowns, within [`MAX_UNKNOWNS`]. The rule's factor was
/// measured on the torsional planets' modes; the transverse–torsional model's
/// highest modes (98–113 kHz) ask for more than its orbits need below about
/// 1000 rpm, where the cap holds H. Measured there against shooting's orbit
/// (docs/PERIODIC.md §2): 500 rpm, the rule's 1002 held at 512, E_h 7.6e-6;
/// 800 rpm, 626 held at 512, E_h 1.0e-6 (1000 rpm, the rule's 501, 7.6e-7).
/// The torsional example's rule reaches the cap only below about 210 rpm
/// (100 rpm: the rule's 1078 held at 512, E_h 1.6e-4 against shooting's orbit).
/// Where it holds, the command line says so ([`HarmonicSettings::rule_harmonics`]).
pub const MAX_RULE_HARMONICS: usize = 512;

/// Most unknowns m(2H + 1) the harmonic balance takes. Beyond
/// [`DENSE_UNKNOWNS`] its memory is the tangent sequences, 2m²N values, and
/// GMRES's basis, at most [`KRYLOV_ITERATIONS`] vectors of the unknowns: at
/// this bound with the transverse–torsional example's 19 coordinates (H =
/// 525, N = 8400, 19 969 unknowns) 48 MB and 32 MB. The example needs 6365
/// at 3000 rpm.
pub const MAX_UNKNOWNS: usize = 20_000;

/// Most unknowns the harmonic balance solves with the dense LU of its
/// Jacobian; beyond, GMRES on the Jacobian as an operator (module `krylov`).
/// Measured on the torsional example (docs/PERIODIC.md §2), one solve each
/// way: the dense LU faster at 545 unknowns (2000 rpm), the two alike at 725
/// (1500 rpm), GMRES 1.1 to 1.3 times faster at 835 (1300 rpm), 2.6 times at
/// 1085 (1000 rpm) and 7.5 times at 2165 (500 rpm).
pub const DENSE_UNKNOWNS: usize = 750;

/// Intervals of the switches' search per step of the Floquet multipliers'
/// exponentials ([`HarmonicBalance::floquet_multipliers`]): with the steps cut
/// at the contact switches, the frozen tangents' error is smooth, and four
/// (4H steps) keep the largest |μ| within 4.5e-4 of shooting's on the
/// torsional example where the orbit meets E_h ≤ 1e-3 (every 500 rpm, 1000 to
/// 15 000 rpm; 1.4e-3 with eight), at less than half the cost of one step per
/// interval (docs/PERIODIC.md §2).
pub const SCAN_INTERVALS_PER_STEP: usize = 4;

/// The plain sums' Newton run ends, and the run on the projected residual
/// starts, once its step is at most this times the size of the coefficients
/// (the step is taken, its residual not evaluated): the plain root is only
/// the projected run's start, 2e-4 to 1.2e-3 of the coefficients from its
/// root off the separating speeds. Measured on the torsional example every
/// 50 rpm from 1000 to 15 000 rpm, cold starts (docs/PERIODIC.md §2): 16 %
/// fewer force evaluations than converging the plain run to the tolerance,
/// and 262 speeds converged against 259 (1e-3: 13 % fewer, 261; 3e-2:
/// 15 %, 262; 1e-1: 13 %, 262).
pub const HANDOVER_STEP: f64 = 1e-2;

/// Relative offsets of the speeds whose orbits, each found as a cold start is (from its
/// static state, else its march), a cold start takes as its start, in this order, where
/// neither the static state nor the march's period leads Newton to a root
/// ([`HarmonicBalance::solve`]). Measured on the torsional example's 50 rpm grids
/// (docs/PERIODIC.md §2): the four speeds that failed converge, κ = 0 at 9600 rpm from
/// 0.5 % above, κ = 6 at 8150 rpm from 2 % above, 8200 rpm from 1 % above and 11 500 rpm
/// from 0.5 % above (8150 and 8200 rpm after the closer offsets failed).
pub const NEIGHBOUR_OFFSETS: [f64; 6] = [0.005, -0.005, 0.01, -0.01, 0.02, -0.02];

/// Successive Newton iterations that do not halve the residual after which
/// the harmonic balance gives up (they cycle, see [`HarmonicBalance::solve`]).
pub const STALLED_ITERATIONS: usize = 4;

/// Samples per kept harmonic: the contact force's kinks alias onto the kept
/// harmonics through the samples (3000 rpm, H = 32: E_h 8.1e-4 with 8 samples
/// per harmonic, 2.6e-4 with 16). With the contact switches projected exactly
/// (module `switches`) 8 reach E_h ≤ 1e-3 at most speeds, but not all (5300
/// rpm: 2.8e-3; 4.7e-4 with 10), and Newton converges at fewer speeds where
/// the teeth separate (docs/PERIODIC.md §2).
pub const SAMPLES_PER_HARMONIC: usize = 16;

/// The plain sums' run ([`HANDOVER_STEP`]) takes half the samples when that
/// leaves at least this many per harmonic: its root is only the projected
/// run's start, which the full samples then correct. Measured on the
/// torsional example every 50 rpm from 1000 to 15 000 rpm, cold starts
/// (docs/PERIODIC.md §2): 20 % fewer force evaluations (1 437 316 →
/// 1 155 390), the same 262 speeds converged and the same orbits (E_h
/// within 1e-7, the largest |μ| to six digits); the solve starts again on
/// the full samples where the run from the half-sample start fails (8350,
/// 9800 and 12 100 rpm), and that work is counted.
pub const PLAIN_SAMPLES_PER_HARMONIC: usize = 8;

impl HarmonicSettings {
    /// The settings for the period at `omega` [rad/s] of `problem`:
    /// H = max([`MIN_HARMONICS`], ⌈[`HARMONICS_PER_MODE_ORDER`] · f_hi T⌉), at
    /// most [`MAX_RULE_HARMONICS`], and N = [`SAMPLES_PER_HARMONIC`] · H samples.
    pub fn for_speed(problem: &PeriodicProblem, omega: f64) -> Self {
        Self::for_frequency(highest_frequency(problem.model(), omega), problem.period(omega))
    }

    /// [`Self::for_speed`] with the highest natural frequency `highest` \[Hz\]
    /// given, for the period `period` \[s\].
    pub fn for_frequency(highest: f64, period: f64) -> Self {
        let h = Self::rule_harmonics(highest, period).min(MAX_RULE_HARMONICS);
        Self { harmonics: h, samples: SAMPLES_PER_HARMONIC * h, ..Self::default() }
    }

    /// The harmonics the rule asks for the highest natural frequency
    /// `highest` \[Hz\] and the period `period` \[s\], before
    /// [`MAX_RULE_HARMONICS`] holds them: max([`MIN_HARMONICS`],
    /// ⌈[`HARMONICS_PER_MODE_ORDER`] · f_hi T⌉).
    pub fn rule_harmonics(highest: f64, period: f64) -> usize {
        ((HARMONICS_PER_MODE_ORDER * highest * period).ceil() as usize).max(MIN_HARMONICS)
    }

    /// Refuses settings that cannot work, naming the setting and the range.
    pub fn check(&self) -> Result<(), PeriodicError> {
        let bad = |name: &str, value: f64, reason: &str| Err(PeriodicError::invalid(name, value, reason));
        if !(1..=2048).contains(&self.harmonics) {
            return bad("harmonics", self.harmonics as f64, "must lie in 1 ..= 2048");
        }
        if self.samples < 2 * self.harmonics + 1 || self.samples > 1 << 16 {
            return bad("harmonic-balance samples", self.samples as f64, "must lie in 2H + 1 ..= 65536");
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return bad("harmonic-balance tolerance", self.tolerance, "must be positive and finite");
        }
        if self.max_iterations == 0 {
            return bad("harmonic-balance iterations", 0.0, "must be at least 1");
        }
        Ok(())
    }
}

/// Refuses settings whose unknowns for `m` coordinates exceed [`MAX_UNKNOWNS`].
fn check_unknowns(m: usize, settings: &HarmonicSettings) -> Result<(), PeriodicError> {
    let unknowns = m * (2 * settings.harmonics + 1);
    if unknowns <= MAX_UNKNOWNS {
        return Ok(());
    }
    let megabytes = 8e-6 * (2 * m * m * settings.samples + KRYLOV_ITERATIONS * unknowns) as f64;
    Err(PeriodicError::InvalidRequest {
        name: "harmonics".into(),
        value: settings.harmonics.to_string(),
        reason: format!(
            "{m} coordinates × (2H + 1) = {unknowns} unknowns, more than the {MAX_UNKNOWNS} the harmonic \
             balance takes (its tangent sequences and GMRES basis would hold {megabytes:.0} MB); shooting \
             or time marching solve this point"
        ),
    })
}

/// A periodic steady state by harmonic balance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HarmonicOrbit {
    /// Input speed [rad/s].
    pub speed: f64,
    /// Period \[s\] (a whole number of mesh cycles).
    pub period: f64,
    /// Mesh cycles in the period.
    pub cycles: usize,
    /// Harmonics H of the period kept.
    pub harmonics: usize,
    /// Fourier coefficients of the unknowns' coordinates in units of the
    /// static mesh deflection: block c (of m values, one per coordinate) is
    /// a₀ for c = 0, a_k for c = 2k − 1 and b_k for c = 2k.
    pub coefficients: Vec<f64>,
    /// Newton iterations.
    pub iterations: usize,
    /// Largest scaled residual coefficient at the last evaluation, before the
    /// last Newton step, which is below the tolerance or leaves an estimated
    /// remainder below it (accelerations in units of the static deflection
    /// times ν²).
    pub residual: f64,
    /// Largest component of the last Newton step.
    pub last_step: f64,
    /// Jacobians assembled and factorised (dense: the whole LU; beyond
    /// [`DENSE_UNKNOWNS`]: the LU of the band GMRES preconditions with).
    pub factorizations: usize,
    /// Products of the Jacobian with a vector in GMRES (zero where the dense
    /// LU solved the steps).
    #[serde(default)]
    pub products: usize,
    /// Force evaluations (one per sample and residual, and the march's where
    /// a cold start started again from it).
    pub force_evaluations: u64,
    /// Accepted integrator steps of the march a stalled cold start started again from
    /// ([`HarmonicBalance::solve`]; 0 when none).
    #[serde(default)]
    pub march_steps: u64,
    /// The neighbouring speed [rad/s] whose orbit the solve started from where neither the
    /// static state nor the march's period led Newton to a root ([`NEIGHBOUR_OFFSETS`]);
    /// `None` otherwise.
    #[serde(default)]
    pub neighbour: Option<f64>,
    /// Where tooth pairs start or stop touching as located at the last
    /// residual evaluation, at most the last Newton step (within the
    /// tolerance) from these coefficients: time in the period \[s\] and the
    /// model's event index of each sign change, in the order found. The
    /// multipliers' search starts from them ([`HarmonicBalance::floquet_multipliers`]).
    #[serde(default)]
    pub crossings: Vec<(f64, usize)>,
}

/// The orbit's own spectrum asks for more harmonics where its top quarter of harmonics
/// (above 3H/4) holds more than this share of its oscillation (root-sum-square over every
/// coordinate, relative to that of harmonics 1 to H; [`HarmonicOrbit::spectral_harmonics`]).
/// The mode rule ([`HARMONICS_PER_MODE_ORDER`]) follows the highest natural frequency, but a
/// narrow force peak at a contact switch asks for more where the modes are soft (the
/// example's flexible planet bearings). Measured on the condensed balance against long
/// marching on `example-2004`, κ = 0 and 6, every 1000 rpm, H = 32, 64 and 128
/// (docs/PERIODIC.md §3): where E_h exceeds 1e-3 the top quarter holds 6.6e-4 or more
/// (κ = 6, 2000 rpm, H = 64: E_h 1.5e-3; κ = 0, 5000 rpm, H = 32: 2.3e-3), and at 2.9e-4
/// or less E_h is at most 8.8e-4. The share alone does not decide (a stiff model's high
/// modes ring in it without harm), so the continuation checks such a point at 2H.
pub const SPECTRAL_TAIL: f64 = 2e-4;

impl HarmonicOrbit {
    /// The orbit of `coefficients` (H = `harmonics`) at `speed` [rad/s], its `period` \[s\]
    /// of `cycles` mesh cycles, with no solve's work recorded.
    pub fn of_coefficients(
        speed: f64,
        (period, cycles): (f64, usize),
        harmonics: usize,
        coefficients: Vec<f64>,
    ) -> Self {
        Self {
            speed,
            period,
            cycles,
            harmonics,
            coefficients,
            iterations: 0,
            residual: 0.0,
            last_step: 0.0,
            factorizations: 0,
            products: 0,
            force_evaluations: 0,
            march_steps: 0,
            neighbour: None,
            crossings: Vec::new(),
        }
    }

    /// The root-sum-square of the coefficients of harmonics `lo + 1 ..= hi` over every
    /// coordinate, relative to that of harmonics 1 to H (0 for an orbit without
    /// oscillation).
    pub fn band_share(&self, lo: usize, hi: usize) -> f64 {
        let h = self.harmonics;
        let m = self.coefficients.len() / (2 * h + 1);
        let power = |k: usize| -> f64 {
            let (a, b) = ((2 * k - 1) * m, 2 * k * m);
            (0..m).map(|c| self.coefficients[a + c].powi(2) + self.coefficients[b + c].powi(2)).sum()
        };
        let all: f64 = (1..=h).map(power).sum();
        if all <= 0.0 {
            return 0.0;
        }
        ((lo + 1..=hi.min(h)).map(power).sum::<f64>() / all).sqrt()
    }

    /// The harmonics the orbit's spectrum asks: 2H where its top quarter
    /// ([`Self::band_share`] above 3H/4) holds more than [`SPECTRAL_TAIL`]; H/2 (at least
    /// [`MIN_HARMONICS`]) where the quarter H/2 would keep on top, 3H/8 to H/2, holds less
    /// than half of it (the margin keeps a count from going back and forth); H otherwise.
    pub fn spectral_harmonics(&self) -> usize {
        let h = self.harmonics;
        if self.band_share(3 * h / 4, h) > SPECTRAL_TAIL {
            2 * h
        } else if h / 2 >= MIN_HARMONICS && self.band_share(3 * h / 8, h / 2) < 0.5 * SPECTRAL_TAIL {
            h / 2
        } else {
            h
        }
    }
}

/// The highest natural frequency \[Hz\] of the model linearized at its
/// static state at `omega` [rad/s] (tangent stiffness symmetrized, damping
/// left out).
pub fn highest_frequency(model: &PlanetaryDynamics, omega: f64) -> f64 {
    let mut model = model.clone();
    let n = model.dim();
    let s = static_state(&model, omega);
    model.set_drive_speed(omega);
    let (mut k, mut c) = (nalgebra::DMatrix::zeros(n, n), nalgebra::DMatrix::zeros(n, n));
    model.jacobian(0.0, &s.q, &s.v, &mut k, &mut c);
    let mass = model.mass().to_vec();
    let a =
        nalgebra::DMatrix::from_fn(n, n, |i, j| 0.5 * (k[(i, j)] + k[(j, i)]) / (mass[i] * mass[j]).sqrt());
    let largest = a.symmetric_eigenvalues().iter().cloned().fold(0.0, f64::max);
    largest.sqrt() / (2.0 * std::f64::consts::PI)
}

/// The plans of the settings' samples and, where the plain run takes half of them, of those.
fn plans_of(settings: &HarmonicSettings) -> (Plans, Option<Plans>) {
    let half = settings.samples / 2;
    let coarse = settings.samples % 2 == 0 && half >= PLAIN_SAMPLES_PER_HARMONIC * settings.harmonics;
    (Plans::new(settings.samples), coarse.then(|| Plans::new(half)))
}
/// The harmonic balance of one [`PeriodicProblem`].
pub struct HarmonicBalance {
    problem: PeriodicProblem,
    settings: HarmonicSettings,
    /// Unknowns' coordinates per time m, model coordinates n.
    m: usize,
    n: usize,
    /// P, n × m column-major: relative coordinates of the unknowns' coordinates.
    p: Vec<f64>,
    /// PᵀMP, m × m column-major.
    reduced_mass: Vec<f64>,
    /// FFT plans of the settings' N samples and, when the plain run takes
    /// them ([`PLAIN_SAMPLES_PER_HARMONIC`]), of N/2.
    full: Plans,
    half: Option<Plans>,
    /// The samples the next evaluations take: N, or N/2 during the plain run.
    samples: usize,
    /// The highest natural frequency \[Hz\] once computed ([`Self::settings_for_speed`]).
    highest: Option<f64>,
    /// Kept from one solve to the next, so that a point does not page in its
    /// Jacobian (about 1.5 MB at 3000 rpm), tangent sequences and LU afresh.
    jacobian: Jacobian,
    tangents: Vec<f64>,
    /// Most unknowns solved with the dense LU ([`DENSE_UNKNOWNS`]).
    dense_unknowns: usize,
    /// The crossings of the last evaluation with the switches projected.
    crossings: Vec<(f64, usize)>,
    /// The last evaluation, when it projected the switches: a Jacobian asked for
    /// at the same point next ([`Self::newton`]'s fresh Jacobian after an
    /// iteration that contracted too little) takes its residual and switches
    /// instead of locating them again.
    projected: Option<Projected>,
    /// Counts the continuation's linearizations, the last of which the
    /// Jacobian is (module `arc`).
    arc_generation: u64,
}

/// A projected residual evaluation kept for the Jacobian at the same point.
struct Projected {
    omega: f64,
    x: Vec<f64>,
    residual: Vec<f64>,
    switches: Vec<Switch>,
}

impl HarmonicBalance {
    /// The harmonic balance of `problem`'s model.
    pub fn new(problem: PeriodicProblem, settings: HarmonicSettings) -> Result<Self, PeriodicError> {
        settings.check()?;
        let n = problem.model.dim();
        let m = problem.unknowns() / 2;
        check_unknowns(m, &settings)?;
        let mut p = vec![0.0; n * m];
        match problem.eliminated {
            Some(k) => {
                let w = &problem.weights;
                for (j, i) in (0..n).filter(|i| *i != k).enumerate() {
                    p[i + n * j] = 1.0;
                    p[k + n * j] = -w[i] / w[k];
                }
            }
            None => (0..n).for_each(|i| p[i + n * i] = 1.0),
        }
        let mass = problem.model.mass().to_vec();
        let mut reduced_mass = vec![0.0; m * m];
        for a in 0..m {
            for b in 0..m {
                reduced_mass[a + m * b] = (0..n).map(|i| p[i + n * a] * mass[i] * p[i + n * b]).sum();
            }
        }
        let (full, half) = plans_of(&settings);
        Ok(Self {
            problem,
            settings,
            m,
            n,
            p,
            reduced_mass,
            full,
            half,
            samples: settings.samples,
            highest: None,
            jacobian: Jacobian::default(),
            dense_unknowns: DENSE_UNKNOWNS,
            tangents: Vec::new(),
            crossings: Vec::new(),
            projected: None,
            arc_generation: 0,
        })
    }

    /// [`HarmonicSettings::for_speed`] at `omega` [rad/s], the highest natural
    /// frequency computed once (at the first call's speed: it hardly moves
    /// with speed) and kept.
    pub fn settings_for_speed(&mut self, omega: f64) -> HarmonicSettings {
        HarmonicSettings::for_frequency(self.highest_frequency(omega), self.problem.period(omega))
    }

    /// The highest natural frequency \[Hz\], computed at the first call's
    /// `omega` [rad/s] and kept.
    fn highest_frequency(&mut self, omega: f64) -> f64 {
        *self.highest.get_or_insert_with(|| highest_frequency(self.problem.model(), omega))
    }

    /// [`HarmonicSettings::rule_harmonics`] at `omega` [rad/s], with the
    /// highest natural frequency [`Self::settings_for_speed`] keeps: more than
    /// the settings' H where [`MAX_RULE_HARMONICS`] holds them.
    pub fn rule_harmonics(&mut self, omega: f64) -> usize {
        HarmonicSettings::rule_harmonics(self.highest_frequency(omega), self.problem.period(omega))
    }

    /// Changes the settings (harmonics, samples) for the next solves.
    pub fn set_settings(&mut self, settings: HarmonicSettings) -> Result<(), PeriodicError> {
        settings.check()?;
        check_unknowns(self.m, &settings)?;
        if settings.samples != self.settings.samples || settings.harmonics != self.settings.harmonics {
            (self.full, self.half) = plans_of(&settings);
        }
        self.settings = settings;
        self.samples = settings.samples;
        Ok(())
    }

    /// The settings.
    pub fn settings(&self) -> &HarmonicSettings {
        &self.settings
    }

    /// The shooting problem this balance works on.
    pub fn problem(&self) -> &PeriodicProblem {
        &self.problem
    }

    /// Number of unknowns m(2H + 1).
    pub fn unknowns(&self) -> usize {
        self.m * (2 * self.settings.harmonics + 1)
    }

    /// The coefficients of a cold start at `omega`: the static deflection of
    /// the mean-stiffness model as the constant term, no harmonics.
    pub fn cold_start(&self, omega: f64) -> Vec<f64> {
        let s = static_state(&self.problem.model, omega);
        let z = self.problem.reduce(&s.q, &vec![0.0; self.n]);
        let mut x = vec![0.0; self.unknowns()];
        x[..self.m].copy_from_slice(&z[..self.m]);
        x
    }

    /// The plans of the samples in use.
    fn plans(&self) -> &Plans {
        match &self.half {
            Some(half) if self.samples != self.settings.samples => half,
            _ => &self.full,
        }
    }

    /// Samples of a coordinate's series: `coefficient(c)` gives its entry of
    /// coefficient block c, `out` receives the N values y(t_j).
    fn synthesize(&self, coefficient: impl Fn(usize) -> f64, buffer: &mut [Complex<f64>], out: &mut [f64]) {
        synthesize_with(self.plans(), self.settings.harmonics, coefficient, buffer, out);
    }

    /// The orbit's relative state at t = 0 as the shooting problem's unknowns.
    pub fn initial_unknowns(&self, orbit: &HarmonicOrbit) -> Vec<f64> {
        self.unknowns_of(&orbit.coefficients, orbit.period)
    }

    /// The relative state at t = 0 of the coefficients `coefficients` (of any number of
    /// harmonics) of a series of period `period` \[s\], as the shooting problem's unknowns.
    fn unknowns_of(&self, coefficients: &[f64], period: f64) -> Vec<f64> {
        let m = self.m;
        let harmonics = (coefficients.len() / m - 1) / 2;
        let nu = 2.0 * std::f64::consts::PI / period;
        let ratio = self.problem.q_scale / self.problem.v_scale;
        let mut z = vec![0.0; 2 * m];
        for a in 0..m {
            let x = |c: usize| coefficients[c * m + a];
            z[a] = x(0) + (1..=harmonics).map(|k| x(2 * k - 1)).sum::<f64>();
            z[m + a] = ratio * (1..=harmonics).map(|k| k as f64 * nu * x(2 * k)).sum::<f64>();
        }
        z
    }

    /// The orbit's state relative to its rigid-body motion (the frame's q_e, q̇_e: the absolute
    /// state at time t is q_e + r t, q̇_e + r with r the rigid-body velocity at the orbit's
    /// speed) at `samples` equally spaced times over its period from t = 0 (offset by
    /// `phase` of the sample interval), sample-major (`samples` × coordinates each).
    pub fn frame_samples(&self, orbit: &HarmonicOrbit, samples: usize, phase: f64) -> (Vec<f64>, Vec<f64>) {
        let (m, n) = (self.m, self.n);
        let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
        let (mut y, mut yd) = (vec![0.0; m], vec![0.0; m]);
        let nu = 2.0 * std::f64::consts::PI / orbit.period;
        let (mut qs, mut vs) = (Vec::with_capacity(samples * n), Vec::with_capacity(samples * n));
        for j in 0..samples {
            let t = orbit.period * (j as f64 + phase) / samples as f64;
            let q_scale = self.problem.q_scale;
            series_state(
                &orbit.coefficients,
                nu,
                &self.p,
                q_scale,
                t,
                (&mut y, &mut yd, None),
                (&mut q, &mut v),
            );
            qs.extend_from_slice(&q);
            vs.extend_from_slice(&v);
        }
        (qs, vs)
    }

    /// The orbit's mesh forces over one period at the shooting settings'
    /// samples per mesh cycle, and their measures, as a [`SteadyState`].
    pub fn steady_state(&mut self, orbit: &HarmonicOrbit) -> Result<SteadyState, PeriodicError> {
        let omega = orbit.speed;
        let (m, n) = (self.m, self.n);
        let samples = self.problem.settings.samples_per_mesh_cycle * orbit.cycles;
        let q_scale = self.problem.q_scale;
        let n_mesh = self.problem.model.mesh_count();
        let mut time = Vec::with_capacity(samples);
        let mut force = vec![Vec::with_capacity(samples); n_mesh];
        self.problem.model.set_drive_speed(omega);
        let rigid = self.problem.model.rigid_velocity_at(omega);
        let p = &self.p;
        let mut frame = RigidFrame::new(&mut self.problem.model, rigid.clone());
        let (mut q, mut v, mut f) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let (mut y, mut yd) = (vec![0.0; m], vec![0.0; m]);
        let nu = 2.0 * std::f64::consts::PI / orbit.period;
        for j in 0..samples {
            let t = orbit.period * j as f64 / samples as f64;
            series_state(&orbit.coefficients, nu, p, q_scale, t, (&mut y, &mut yd, None), (&mut q, &mut v));
            frame.force(t, &q, &v, &mut f);
            time.push(t);
            for (i, s) in frame.model().meshes.iter().enumerate() {
                force[i].push(s.force);
            }
        }
        let model: &PlanetaryDynamics = &self.problem.model;
        let meshes = mesh_responses(model, &force, orbit.cycles)
            .map_err(|source| PeriodicError::Spectrum { speed: omega, source })?;
        let z = self.initial_unknowns(orbit);
        let (qe, ve) = self.problem.expand(&z);
        let q = qe.iter().zip(&rigid).map(|(q, r)| q + r * orbit.period).collect();
        let v = ve.iter().zip(&rigid).map(|(v, r)| v + r).collect();
        Ok(SteadyState {
            input_speed: omega,
            mesh_frequency: model.mesh_frequency_per_input_speed * omega.abs(),
            mean_input_speed: omega,
            cycles: orbit.cycles,
            time,
            mesh_force: force,
            meshes,
            stats: Work {
                steps: orbit.march_steps,
                newton_iterations: orbit.iterations as u64,
                rhs_evaluations: orbit.force_evaluations,
                ..Work::default()
            },
            end: State { input_speed: omega, q, v },
        })
    }
}

#[cfg(test)]
mod tests;
