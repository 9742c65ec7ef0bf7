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

mod arc;
mod condensed;

pub use arc::{refit, ArcLinear, ArcWork, ARC_CHORD_CONTRACTION, SPEED_DIFFERENCE};
pub use condensed::{
    held, CondensedArc, CondensedBalance, CondensedReport, Symmetry, CONDENSED_MAX_HARMONICS,
    CONDENSED_UNKNOWNS, SYMMETRY_TOLERANCE,
};

use rustfft::num_complex::Complex;
use serde::{Deserialize, Serialize};

use super::krylov::{
    gmres, precondition, BandPattern, Inertia, Operator, KRYLOV_BAND, KRYLOV_ITERATIONS, KRYLOV_TOLERANCE,
};
use super::series::{analyse_with, derivative_coefficient, synthesize_with, Plans};
use super::switches::{
    add_back, add_time_terms, illinois, locate, series_state, subtract, time_gradients, time_terms,
    SeriesResidual, Switch,
};
use super::{floquet_multipliers, max_abs, Multiplier, PeriodicError, PeriodicProblem};
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{mesh_responses, static_state, State, SteadyState, Work};
use crate::dynamics::rigid_frame::RigidFrame;
use crate::dynamics::solver::{SecondOrderSystem, TangentSystem};

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

/// The distance to the root left after a Newton step of length `step`,
/// estimated from the contraction θ = step / `previous` of the steps (the
/// previous one taken whole): θ / (1 − θ) · step, the sum of the geometric
/// series of the steps still to come (the stopping rule of the simplified
/// Newton iteration, Hairer & Wanner, Solving ODEs II, IV.8). Infinite where
/// there is no previous whole step or the steps do not contract.
fn newton_remainder(previous: Option<f64>, step: f64) -> f64 {
    match previous {
        Some(p) if p > 0.0 && step < p => {
            let theta = step / p;
            theta / (1.0 - theta) * step
        }
        _ => f64::INFINITY,
    }
}

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

/// faer's LU with partial pivoting of a square matrix, factorised in place in
/// storage kept from one factorisation to the next (faer's `PartialPivLu`
/// allocates and zeroes its two factors each time: at 3000 rpm 2 × 1.5 MB
/// paged in per point). The arithmetic is faer's, the same as
/// `PartialPivLu`'s.
struct DenseLu {
    /// L below the diagonal (unit diagonal implied) and U on and above it.
    factor: faer::Mat<f64>,
    forward: Vec<usize>,
    inverse: Vec<usize>,
}

impl Default for DenseLu {
    fn default() -> Self {
        Self { factor: faer::Mat::zeros(0, 0), forward: Vec::new(), inverse: Vec::new() }
    }
}

impl DenseLu {
    /// Factorises the column-major `n` × `n` matrix `a`.
    fn factorize(&mut self, a: &[f64], n: usize) {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
        if self.factor.nrows() != n {
            self.factor = faer::Mat::zeros(n, n);
        }
        self.factor.copy_from(faer::MatRef::from_column_major_slice(a, n, n));
        self.forward.resize(n, 0);
        self.inverse.resize(n, 0);
        let par = faer::get_global_parallelism();
        let mut memory = MemBuffer::new(lu_in_place_scratch::<usize, f64>(n, n, par, Default::default()));
        lu_in_place(
            self.factor.as_mut(),
            &mut self.forward,
            &mut self.inverse,
            par,
            MemStack::new(&mut memory),
            Default::default(),
        );
    }

    /// The Newton step −J⁻¹ r.
    fn step(&self, r: &[f64]) -> Vec<f64> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::lu::partial_pivoting::solve::{solve_in_place, solve_in_place_scratch};
        let n = r.len();
        let mut x = faer::Mat::<f64>::from_fn(n, 1, |i, _| -r[i]);
        let par = faer::get_global_parallelism();
        let permutation = faer::perm::PermRef::new_checked(&self.forward, &self.inverse, n);
        let mut memory = MemBuffer::new(solve_in_place_scratch::<usize, f64>(n, 1, par));
        let lu = self.factor.as_ref();
        solve_in_place(lu, lu, permutation, x.as_mut(), par, MemStack::new(&mut memory));
        (0..n).map(|i| x[(i, 0)]).collect()
    }
}

/// The Fourier coefficients of the tangent sequences of one coordinate pair (a, b), scaled
/// to row a, p = 0 ..= 2H: the stiffness's cosine and sine sums `kc`, `ks` and the
/// damping's `cc`, `cs` (the damping's also by ν).
struct PairSpectrum {
    kc: Vec<f64>,
    ks: Vec<f64>,
    cc: Vec<f64>,
    cs: Vec<f64>,
}

/// The balance's Jacobian, the tangent and inertia terms, entry by entry into `put(row,
/// column, value)`: the entries whose harmonics lie at most `band` apart (all with band =
/// H). Each entry is put once, so the sums are those of the dense assembly whatever the
/// band. `spectra` holds the pairs (a, b) b-major.
fn assemble(
    m: usize,
    h: usize,
    band: usize,
    spectra: &[PairSpectrum],
    inertia: &Inertia<'_>,
    mut put: impl FnMut(usize, usize, f64),
) {
    for b in 0..m {
        for a in 0..m {
            pair_entries(h, band, &spectra[b * m + a], |row_block, col_block, v| {
                put(row_block * m + a, col_block * m + b, v)
            });
        }
    }
    for cc in 1..=2 * h {
        for b in 0..m {
            for a in 0..m {
                put(cc * m + a, cc * m + b, inertia.at(cc, a, b));
            }
        }
    }
}

/// The entries of one tangent pair's Fourier convolution, ∂(coefficients of τ·y + γ·ẏ)/∂(coefficients
/// of y), as `put(row block, column block, value)`: τ, γ the pair's stiffness and damping
/// sequences (`spectrum`), the entries whose harmonics lie at most `band` apart (all with band
/// = H). Blocks as in [`HarmonicOrbit::coefficients`].
fn pair_entries(h: usize, band: usize, spectrum: &PairSpectrum, mut put: impl FnMut(usize, usize, f64)) {
    let PairSpectrum { kc, ks, cc, cs } = spectrum;
    // Σ ψ_l x φ_c by the product-to-sum identities, ψ the test functions
    // (1; 2cos lθ; 2sin lθ, with the 1/N of the spectra), φ the basis functions.
    let mut add = |(r, c): (usize, usize), v: f64| put(r, c, v);
    add((0, 0), kc[0]);
    for c in 1..=h.min(band) {
        let cf = c as f64;
        // Row of the constant: (1/N) Σ x cos cθ and Σ x sin cθ; with the damping of
        // ẏ: cos → −c sin, sin → c cos.
        add((0, 2 * c - 1), kc[c] - cf * cs[c]);
        add((0, 2 * c), ks[c] + cf * cc[c]);
        // Column of the constant (no velocity).
        add((2 * c - 1, 0), 2.0 * kc[c]);
        add((2 * c, 0), 2.0 * ks[c]);
    }
    for l in 1..=h {
        for c in l.saturating_sub(band).max(1)..=(l + band).min(h) {
            let cf = c as f64;
            let d = l.abs_diff(c);
            // ks(c − l), odd in its argument.
            let sign = if c >= l { 1.0 } else { -1.0 };
            let (ka, kb, ks1, ks2) = (kc[d], kc[l + c], ks[l + c], sign * ks[d]);
            let (ca, cb, cs1, cs2) = (cc[d], cc[l + c], cs[l + c], sign * cs[d]);
            // (cos l, cos c) = A + B, (cos l, sin c) = S₁ + S₂,
            // (sin l, cos c) = S₁ − S₂, (sin l, sin c) = A − B.
            add((2 * l - 1, 2 * c - 1), ka + kb - cf * (cs1 + cs2));
            add((2 * l - 1, 2 * c), ks1 + ks2 + cf * (ca + cb));
            add((2 * l, 2 * c - 1), ks1 - ks2 - cf * (ca - cb));
            add((2 * l, 2 * c), ka - kb + cf * (cs1 - cs2));
        }
    }
}

/// The Jacobian an evaluation assembles for Newton's step: dense (column-major), with its
/// LU's storage, or as the operator GMRES takes where the unknowns exceed
/// [`DENSE_UNKNOWNS`] (none before the first evaluation).
enum Jacobian {
    Dense { matrix: Vec<f64>, lu: DenseLu },
    Operator(Option<Box<Operator>>),
}

impl Default for Jacobian {
    fn default() -> Self {
        Self::Dense { matrix: Vec::new(), lu: DenseLu::default() }
    }
}

/// The counters and the factorised Jacobian of [`HarmonicBalance::solve`]'s Newton runs.
#[derive(Default)]
struct Newton {
    evaluations: u64,
    march_steps: u64,
    iterations: usize,
    factorizations: usize,
    /// Products with the Jacobian in GMRES (none with the dense LU).
    products: usize,
    jacobian: Jacobian,
}

impl Newton {
    /// Factorises the Jacobian of the last evaluation: the dense one's LU (the operator's
    /// evaluation factorised its band).
    fn factorize(&mut self, size: usize) {
        if let Jacobian::Dense { matrix, lu } = &mut self.jacobian {
            lu.factorize(matrix, size);
        }
        self.factorizations += 1;
    }

    /// The Newton step −J⁻¹ r.
    fn step(&mut self, r: &[f64]) -> Vec<f64> {
        match &self.jacobian {
            Jacobian::Dense { lu, .. } => lu.step(r),
            // No evaluation has set the operator: no step (Newton stops on it).
            Jacobian::Operator(None) => vec![f64::NAN; r.len()],
            Jacobian::Operator(Some(op)) => {
                let rhs: Vec<f64> = r.iter().map(|v| -v).collect();
                let (x, report) = gmres(
                    |v, out| op.apply(v, out),
                    |v| precondition(&op.lu, v),
                    &rhs,
                    KRYLOV_TOLERANCE,
                    KRYLOV_ITERATIONS,
                );
                self.products += report.products;
                x
            }
        }
    }
}

/// PᵀXP into `out` (m × m, column-major) for the n × n matrix `x` and P
/// (n × m, column-major); `xp` (n × m) receives XP.
fn project(p: &[f64], x: &nalgebra::DMatrix<f64>, m: usize, xp: &mut [f64], out: &mut [f64]) {
    let n = x.nrows();
    let x = x.as_slice();
    // Column b of XP as the sum of X's columns weighted by P's column b, in the
    // order of the former dot products and from their start, −0 (the same rounding).
    for (xp_b, p_b) in xp.chunks_exact_mut(n).zip(p.chunks_exact(n)).take(m) {
        xp_b.fill(-0.0);
        for (x_l, &w) in x.chunks_exact(n).zip(p_b) {
            for (o, &v) in xp_b.iter_mut().zip(x_l) {
                *o += v * w;
            }
        }
    }
    for (out_b, xp_b) in out.chunks_exact_mut(m).zip(xp.chunks_exact(n)) {
        for (o, p_a) in out_b.iter_mut().zip(p.chunks_exact(n)) {
            *o = p_a.iter().zip(xp_b).map(|(a, b)| a * b).sum();
        }
    }
}

/// An instant on a harmonic-balance orbit where a whole mesh separates or
/// touches again, so that its damping force jumps.
#[derive(Clone, Copy, Debug)]
struct DampingSwitch {
    /// Time in the period \[s\].
    time: f64,
    /// The mesh.
    mesh: usize,
    /// Whether it touches after the instant.
    on: bool,
    /// The event (tooth pair and flank) whose value crosses zero there.
    event: usize,
}

/// The monodromy of the balance's variational equations, built interval by
/// interval ([`HarmonicBalance::floquet_multipliers`]): Φ in the balanced
/// state (y, ẏ/w) of the unknowns' coordinates.
struct Propagation<'o> {
    orbit: &'o HarmonicOrbit,
    p: &'o [f64],
    q_scale: f64,
    m: usize,
    n: usize,
    /// (PᵀMP)⁻¹.
    mass_inverse: nalgebra::DMatrix<f64>,
    /// Φ, 2m × 2m column-major, from the identity.
    phi: Vec<f64>,
    /// w: the balancing scale, the square root of the size of the first
    /// interval's stiffness block.
    scale: Option<f64>,
    q: Vec<f64>,
    v: Vec<f64>,
    y: Vec<f64>,
    yd: Vec<f64>,
    kt: nalgebra::DMatrix<f64>,
    ct: nalgebra::DMatrix<f64>,
    kp: Vec<f64>,
    reduced: Vec<f64>,
    lower: Vec<f64>,
    x: Vec<f64>,
    ax: Vec<f64>,
    exponential: Vec<f64>,
    events: Vec<f64>,
}

/// out = a b for s × s column-major matrices.
fn multiply(s: usize, a: &[f64], b: &[f64], out: &mut [f64]) {
    faer::linalg::matmul::matmul(
        faer::MatMut::from_column_major_slice_mut(out, s, s),
        faer::Accum::Replace,
        faer::MatRef::from_column_major_slice(a, s, s),
        faer::MatRef::from_column_major_slice(b, s, s),
        1.0,
        faer::Par::Seq,
    );
}

impl<'o> Propagation<'o> {
    fn new(
        orbit: &'o HarmonicOrbit,
        p: &'o [f64],
        q_scale: f64,
        (m, n): (usize, usize),
        mass_inverse: nalgebra::DMatrix<f64>,
    ) -> Self {
        let s = 2 * m;
        let mut phi = vec![0.0; s * s];
        (0..s).for_each(|i| phi[i + s * i] = 1.0);
        Self {
            orbit,
            p,
            q_scale,
            m,
            n,
            mass_inverse,
            phi,
            scale: None,
            q: vec![0.0; n],
            v: vec![0.0; n],
            y: vec![0.0; m],
            yd: vec![0.0; m],
            kt: nalgebra::DMatrix::zeros(n, n),
            ct: nalgebra::DMatrix::zeros(n, n),
            kp: vec![0.0; n * m],
            reduced: vec![0.0; m * m],
            lower: vec![0.0; m * s],
            x: vec![0.0; s * s],
            ax: vec![0.0; s * s],
            exponential: vec![0.0; s * s],
            events: Vec::new(),
        }
    }

    /// The orbit's relative state at `t` into `q`, `v`.
    fn state_at(&mut self, t: f64) {
        let (orbit, p, q_scale) = (self.orbit, self.p, self.q_scale);
        let nu = 2.0 * std::f64::consts::PI / orbit.period;
        series_state(
            &orbit.coefficients,
            nu,
            p,
            q_scale,
            t,
            (&mut self.y, &mut self.yd, None),
            (&mut self.q, &mut self.v),
        );
    }

    /// Φ ← exp(length · A(t_mid)) Φ, A = [0 wI; G/w D] with K and C taken at
    /// `t_mid` on the orbit.
    fn advance(&mut self, frame: &mut RigidFrame<'_>, t_mid: f64, length: f64) {
        let m = self.m;
        let s = 2 * m;
        self.state_at(t_mid);
        frame.jacobian(t_mid, &self.q, &self.v, &mut self.kt, &mut self.ct);
        // The lower blocks of A = [0 I; G D]: G = −(PᵀMP)⁻¹PᵀKP, D = −(PᵀMP)⁻¹PᵀCP.
        let (p, kp, reduced, mass_inverse) = (self.p, &mut self.kp, &mut self.reduced, &self.mass_inverse);
        let mut lower_block = |mat: &nalgebra::DMatrix<f64>| {
            project(p, mat, m, kp, reduced);
            -(mass_inverse * nalgebra::DMatrix::from_column_slice(m, m, reduced))
        };
        let (g, d) = (lower_block(&self.kt), lower_block(&self.ct));
        // In the balanced state (y, ẏ/w), w² the size of G, A = [0 wI; G/w D] has a norm
        // of the order of its largest frequency; the multipliers are the same.
        let w = *self.scale.get_or_insert_with(|| {
            (0..m)
                .fold(0.0_f64, |acc, a| acc.max((0..m).map(|b| g[(a, b)].abs()).sum::<f64>()))
                .sqrt()
                .max(1.0)
        });
        // The lower block row [G/w D], column-major m × 2m.
        let lower = &mut self.lower;
        for b in 0..m {
            for a in 0..m {
                lower[a + m * b] = g[(a, b)] / w;
                lower[a + m * (m + b)] = d[(a, b)];
            }
        }
        let norm = (0..m).fold(w, |acc, a| acc.max((0..s).map(|b| lower[a + m * b].abs()).sum::<f64>()));
        // Scaling and squaring: exp(hA) = exp(hA/2^j)^(2^j) with ‖hA‖/2^j ≤ ½.
        let squarings = if length * norm <= 0.5 { 0 } else { (2.0 * length * norm).log2().ceil() as i32 };
        let hs = length / 2f64.powi(squarings);
        // The Taylor degree whose first omitted term (h‖A‖)^(p+1)/(p+1)! is below 1e-11.
        let (mut degree, mut term) = (1usize, hs * norm);
        while term > 1e-11 && degree < 20 {
            degree += 1;
            term *= hs * norm / degree as f64;
        }
        let taylor = |base: &[f64], x: &mut [f64], ax: &mut [f64]| {
            // Σ_{k ≤ p} (hA)^k/k! B by Horner: X = B + (h/k) A X, k = p … 1.
            x.copy_from_slice(base);
            for k in (1..=degree).rev() {
                let f = hs / k as f64;
                // A X: its upper rows w X's lower rows, its lower rows [G/w D] X.
                for col in 0..s {
                    let c = &x[col * s..][..s];
                    for a in 0..m {
                        ax[col * s + a] = w * c[m + a];
                    }
                }
                faer::linalg::matmul::matmul(
                    faer::MatMut::from_column_major_slice_with_stride_mut(&mut ax[m..], m, s, s),
                    faer::Accum::Replace,
                    faer::MatRef::from_column_major_slice(lower, m, s),
                    faer::MatRef::from_column_major_slice(x, s, s),
                    1.0,
                    faer::Par::Seq,
                );
                for ((xi, bi), ai) in x.iter_mut().zip(base).zip(ax.iter()) {
                    *xi = bi + f * ai;
                }
            }
        };
        let (phi, x, ax, e) = (&mut self.phi, &mut self.x, &mut self.ax, &mut self.exponential);
        if squarings == 0 {
            taylor(phi, x, ax);
            phi.copy_from_slice(x);
            return;
        }
        // E = exp(hA/2^j) from the identity, squared j times, then Φ ← E Φ.
        e.iter_mut().for_each(|v| *v = 0.0);
        (0..s).for_each(|i| e[i + s * i] = 1.0);
        taylor(e, x, ax);
        for _ in 0..squarings {
            multiply(s, x, x, ax);
            x.copy_from_slice(ax);
        }
        multiply(s, x, phi, ax);
        phi.copy_from_slice(ax);
    }

    /// The model's event values at `t` on the orbit into `events`.
    fn events_at(&mut self, frame: &mut RigidFrame<'_>, t: f64) {
        self.state_at(t);
        frame.events(t, &self.q, &self.v, &mut self.events);
    }

    /// The largest event value of each mesh at `t` on the orbit, with the
    /// event that gives it (a mesh touches where its largest value is
    /// positive).
    fn mesh_events(&mut self, frame: &mut RigidFrame<'_>, t: f64) -> Vec<(f64, usize)> {
        self.events_at(frame, t);
        let model = frame.model();
        let mut largest = vec![(f64::NEG_INFINITY, usize::MAX); model.mesh_count()];
        for (e, &g) in self.events.iter().enumerate() {
            if let Some(i) = model.event_mesh(e) {
                if g > largest[i].0 {
                    largest[i] = (g, e);
                }
            }
        }
        largest
    }

    /// Event `e`'s value at `t` on the orbit.
    fn event_value(&mut self, frame: &mut RigidFrame<'_>, t: f64, e: usize) -> f64 {
        self.events_at(frame, t);
        self.events[e]
    }

    /// The instants in the period where the tangents jump: a tooth pair
    /// starts or stops touching where its event value changes sign between
    /// the ends of one of the `intervals` intervals of length `h`, each located
    /// by [`Self::switch_at`]. Two changes of one event within one interval
    /// cancel and are not seen.
    fn switches(
        &mut self,
        frame: &mut RigidFrame<'_>,
        h: f64,
        intervals: usize,
    ) -> (Vec<f64>, Vec<DampingSwitch>) {
        let (mut pairs, mut switches) = (Vec::new(), Vec::new());
        self.events_at(frame, 0.0);
        let mut values_before = self.events.clone();
        let mut values_after = Vec::new();
        for j in 0..intervals {
            let (a, b) = (j as f64 * h, (j + 1) as f64 * h);
            self.events_at(frame, b);
            values_after.clone_from(&self.events);
            for (e, (&ga, &gb)) in values_before.iter().zip(&values_after).enumerate() {
                if (ga > 0.0) != (gb > 0.0) {
                    self.switch_at(frame, e, [(a, ga), (b, gb)], h, (&mut pairs, &mut switches));
                }
            }
            std::mem::swap(&mut values_before, &mut values_after);
        }
        (pairs, switches)
    }

    /// The instants of [`Self::switches`] found from `seeds`, the crossings the
    /// solve located (time, event) a Newton step of at most the tolerance
    /// away: each event's sign change is bracketed within 1e-4 of an interval
    /// `h` of its seed (1e-2 if not there) and located by [`Self::switch_at`].
    /// `None` (search the whole period) where a seed's sign change is in
    /// neither bracket.
    fn seeded_switches(
        &mut self,
        frame: &mut RigidFrame<'_>,
        h: f64,
        seeds: &[(f64, usize)],
    ) -> Option<(Vec<f64>, Vec<DampingSwitch>)> {
        let period = self.orbit.period;
        let (mut pairs, mut switches) = (Vec::with_capacity(seeds.len()), Vec::new());
        for &(seed, e) in seeds {
            let bracket = [1e-4 * h, 1e-2 * h].into_iter().find_map(|w| {
                let (a, b) = ((seed - w).max(0.0), (seed + w).min(period));
                let (ga, gb) = (self.event_value(frame, a, e), self.event_value(frame, b, e));
                ((ga > 0.0) != (gb > 0.0)).then_some([(a, ga), (b, gb)])
            })?;
            self.switch_at(frame, e, bracket, h, (&mut pairs, &mut switches));
        }
        Some((pairs, switches))
    }

    /// The sign change of event `e` inside `bracket` (times and the event's
    /// values, of opposite signs), located by the Illinois method to 1e-12 of
    /// `h` in at most 100 evaluations, into `pairs`; where the event's mesh
    /// separates or touches there (its largest event value changes sign across
    /// the located bracket) a damping switch at the same instant into
    /// `switches`, once per mesh and instant.
    fn switch_at(
        &mut self,
        frame: &mut RigidFrame<'_>,
        e: usize,
        bracket: [(f64, f64); 2],
        h: f64,
        (pairs, switches): (&mut Vec<f64>, &mut Vec<DampingSwitch>),
    ) {
        let [(ta, _), (tb, _)] = illinois(|t| self.event_value(frame, t, e), bracket, 1e-12 * h, 100);
        let time = 0.5 * (ta + tb);
        pairs.push(time);
        let Some(i) = frame.model().event_mesh(e) else { return };
        let (was, is) = (self.mesh_events(frame, ta)[i], self.mesh_events(frame, tb)[i]);
        if (was.0 > 0.0) != (is.0 > 0.0)
            && !switches.iter().any(|s| s.mesh == i && (s.time - time).abs() <= 1e-9 * h)
        {
            switches.push(DampingSwitch { time, mesh: i, on: is.0 > 0.0, event: is.1 });
        }
    }

    /// Φ ← S Φ for the saltation S of `switch`: in physical coordinates
    /// δv⁺ = δv⁻ + M⁻¹Δf (∂h/∂q · δq)/ḣ (Δf the jump of the generalized
    /// forces, h the crossing event's value), here in the unknowns'
    /// coordinates, δẏ⁺ = δẏ⁻ + (PᵀMP)⁻¹PᵀΔf (∂h/∂q · P δy)/ḣ, and in the
    /// balanced state divided by w. ∂h/∂q · P and ḣ are central
    /// differences (along each column of P, and along the series in time).
    fn saltation(&mut self, frame: &mut RigidFrame<'_>, switch: &DampingSwitch) {
        let (m, n) = (self.m, self.n);
        let s = 2 * m;
        let t = switch.time;
        let tau = 1e-6 * self.orbit.period;
        let value = |walk: &mut Self, frame: &mut RigidFrame<'_>, t: f64, q: &[f64], v: &[f64]| {
            frame.events(t, q, v, &mut walk.events);
            walk.events[switch.event]
        };
        let ahead = self.event_value(frame, t + tau, switch.event);
        let behind = self.event_value(frame, t - tau, switch.event);
        let rate = (ahead - behind) / (2.0 * tau);
        if !(rate.is_finite() && rate != 0.0) {
            return;
        }
        self.state_at(t);
        let (q0, v0) = (self.q.clone(), self.v.clone());
        // ∂h/∂q · P, column by column.
        let mut slope = vec![0.0; m];
        let mut qp = q0.clone();
        for (b, out) in slope.iter_mut().enumerate() {
            let column = &self.p[n * b..][..n];
            let size = column.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
            if size == 0.0 {
                continue;
            }
            let eps = 1e-6 * self.q_scale / size;
            for k in 0..n {
                qp[k] = q0[k] + eps * column[k];
            }
            let plus = value(self, frame, t, &qp, &v0);
            for k in 0..n {
                qp[k] = q0[k] - eps * column[k];
            }
            let minus = value(self, frame, t, &qp, &v0);
            *out = (plus - minus) / (2.0 * eps);
        }
        // The jump at the switch's own state: the mesh's approach rate of this evaluation.
        frame.events(t, &q0, &v0, &mut self.events);
        let mut jump = vec![0.0; n];
        frame.model().add_damping_switch(switch.mesh, switch.on, &mut jump);
        let projected: Vec<f64> = (0..m).map(|a| (0..n).map(|i| self.p[i + n * a] * jump[i]).sum()).collect();
        let w = self.scale.unwrap_or(1.0);
        let kick: Vec<f64> = (0..m)
            .map(|a| (0..m).map(|b| self.mass_inverse[(a, b)] * projected[b]).sum::<f64>() / (w * rate))
            .collect();
        for col in 0..s {
            let c = &mut self.phi[col * s..][..s];
            let dot: f64 = slope.iter().zip(&c[..m]).map(|(g, y)| g * y).sum();
            for (a, k) in kick.iter().enumerate() {
                c[m + a] += k * dot;
            }
        }
    }
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

    /// The samples of y, ẏ, ÿ (units: static deflection, per second, per
    /// second squared), each N × m sample-major, from the coefficients `x`.
    fn samples_of(&self, x: &[f64], nu: f64) -> [Vec<f64>; 3] {
        let (m, ns) = (self.m, self.samples);
        let mut buffer = vec![Complex::new(0.0, 0.0); ns];
        let mut column = vec![0.0; ns];
        let mut out = [vec![0.0; ns * m], vec![0.0; ns * m], vec![0.0; ns * m]];
        for a in 0..m {
            for (d, o) in out.iter_mut().enumerate() {
                self.synthesize(
                    |c| {
                        let k = c.div_ceil(2) as f64;
                        match (d, c) {
                            (0, _) => x[c * m + a],
                            (1, c) => derivative_coefficient(|c| x[c * m + a], c, nu),
                            (_, 0) => 0.0,
                            _ => -k * k * nu * nu * x[c * m + a],
                        }
                    },
                    &mut buffer,
                    &mut column,
                );
                for (j, y) in column.iter().enumerate() {
                    o[j * m + a] = *y;
                }
            }
        }
        out
    }

    /// Fourier coefficients (blocks as in [`HarmonicOrbit::coefficients`]) of
    /// N samples `values` of one quantity.
    fn analyse(&self, values: &[f64], buffer: &mut [Complex<f64>], out: &mut [f64]) {
        analyse_with(self.plans(), self.settings.harmonics, values, buffer, out);
    }

    /// Fourier coefficients of the unknowns' m coordinates (blocks as in
    /// [`HarmonicOrbit::coefficients`]) from N samples of each, sample-major.
    fn analyse_samples(&self, values: &[f64]) -> Vec<f64> {
        let (m, ns) = (self.m, self.samples);
        let mut out = vec![0.0; m * (2 * self.settings.harmonics + 1)];
        let mut buffer = vec![Complex::new(0.0, 0.0); ns];
        let mut coefficients = vec![0.0; 2 * self.settings.harmonics + 1];
        let mut column = vec![0.0; ns];
        for a in 0..m {
            for j in 0..ns {
                column[j] = values[j * m + a];
            }
            self.analyse(&column, &mut buffer, &mut coefficients);
            for (c, value) in coefficients.iter().enumerate() {
                out[c * m + a] = *value;
            }
        }
        out
    }

    /// The spectra of the tangent sequences `tangents` (as [`Self::evaluate`] fills them),
    /// the pairs (a, b) b-major, scaled to the rows `row`, at ν = `nu`.
    fn tangent_spectra(&self, tangents: &[f64], row: &[f64], nu: f64) -> Vec<PairSpectrum> {
        let (m, ns, h) = (self.m, self.samples, self.settings.harmonics);
        let q_scale = self.problem.q_scale;
        let top = 2 * h + 1;
        let mut spectrum = vec![Complex::new(0.0, 0.0); ns];
        let mut out = Vec::with_capacity(m * m);
        for b in 0..m {
            for a in 0..m {
                let (mut cosine, mut sine) =
                    ([vec![0.0; top], vec![0.0; top]], [vec![0.0; top], vec![0.0; top]]);
                for kind in 0..2 {
                    let seq = &tangents[((kind * m + b) * m + a) * ns..][..ns];
                    for (z, v) in spectrum.iter_mut().zip(seq) {
                        *z = Complex::new(*v, 0.0);
                    }
                    self.plans().forward(&mut spectrum);
                    let scale = q_scale * row[a] * if kind == 1 { nu } else { 1.0 } / ns as f64;
                    for pp in 0..top {
                        let z = spectrum[pp % ns];
                        cosine[kind][pp] = z.re * scale;
                        sine[kind][pp] = -z.im * scale;
                    }
                }
                let [kc, cc] = cosine;
                let [ks, cs] = sine;
                out.push(PairSpectrum { kc, ks, cc, cs });
            }
        }
        out
    }

    /// The scaled residual coefficients at `x`, and, when `jacobian` is
    /// given, its Jacobian of the plain N-sample sums (column-major, unknowns
    /// × unknowns). With `switches` the contact switches are located and
    /// their jumps and kinks projected exactly (module `switches`).
    fn evaluate(
        &mut self,
        omega: f64,
        x: &[f64],
        jacobian: Option<&mut Jacobian>,
        evaluations: &mut u64,
        switches: bool,
    ) -> Result<Vec<f64>, PeriodicError> {
        let (m, n, ns, h) = (self.m, self.n, self.samples, self.settings.harmonics);
        // The Jacobian at the point the last projected evaluation took: its residual and
        // switches as they are, the samples only for the tangents.
        let kept = self.projected.take().filter(|k| {
            switches && jacobian.is_some() && ns == self.settings.samples && k.omega == omega && k.x == x
        });
        let period = self.problem.period(omega);
        let nu = 2.0 * std::f64::consts::PI / period;
        let q_scale = self.problem.q_scale;
        let [y, yd, ydd] = self.samples_of(x, nu);
        // Row scale: accelerations in units of the static deflection times ν².
        let row: Vec<f64> =
            (0..m).map(|a| 1.0 / (self.reduced_mass[a + m * a] * nu * nu * q_scale)).collect();
        self.problem.model.set_drive_speed(omega);
        let rigid = self.problem.model.rigid_velocity_at(omega);
        let p = &self.p;
        let mut frame = RigidFrame::new(&mut self.problem.model, rigid);
        let (mut q, mut v, mut f, mut r) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; ns * m]);
        let want_jacobian = jacobian.is_some();
        let mut kt = nalgebra::DMatrix::<f64>::zeros(n, n);
        let mut ct = nalgebra::DMatrix::<f64>::zeros(n, n);
        // Tangent sequences, (a, b) pair-major, N samples each: stiffness then damping.
        let mut tangents = std::mem::take(&mut self.tangents);
        if want_jacobian {
            tangents.resize(2 * m * m * ns, 0.0);
        }
        let (mut kp, mut reduced) = (vec![0.0; n * m], vec![0.0; m * m]);
        let mut force = vec![0.0; n];
        // With `switches`: the event values at the N samples and at t = T, sample-major.
        let mut events = Vec::new();
        let mut sample_events = Vec::new();
        for j in 0..ns {
            let t = period * j as f64 / ns as f64;
            for i in 0..n {
                let (mut qi, mut vi, mut ai) = (0.0, 0.0, 0.0);
                for a in 0..m {
                    let pia = p[i + n * a];
                    qi += pia * y[j * m + a];
                    vi += pia * yd[j * m + a];
                    ai += pia * ydd[j * m + a];
                }
                q[i] = qi * q_scale;
                v[i] = vi * q_scale;
                f[i] = frame.mass()[i] * ai * q_scale;
            }
            if switches {
                // Before the force: the model keeps the evaluation, and the force (or the
                // tangents) reuses it.
                frame.events(t, &q, &v, &mut sample_events);
                *evaluations += 1;
            }
            // With the residual kept, only the tangents below: through the same pass as the
            // residual's evaluation (the law with the event values, not used then), so that
            // the Jacobian is the one assembled afresh.
            if kept.is_none() {
                if switches {
                    events.extend_from_slice(&sample_events);
                } else {
                    *evaluations += 1;
                }
                frame.force(t, &q, &v, &mut force);
                if let Some(i) = force.iter().position(|x| !x.is_finite()) {
                    return Err(PeriodicError::invalid(
                        "harmonic-balance iterate",
                        force[i],
                        "gives a non-finite force: the iterate diverged",
                    ));
                }
                for i in 0..n {
                    f[i] -= force[i];
                }
                for a in 0..m {
                    r[j * m + a] = row[a] * (0..n).map(|i| p[i + n * a] * f[i]).sum::<f64>();
                }
            }
            if want_jacobian {
                frame.jacobian(t, &q, &v, &mut kt, &mut ct);
                for (s, mat) in [&kt, &ct].into_iter().enumerate() {
                    project(p, mat, m, &mut kp, &mut reduced);
                    for b in 0..m {
                        for a in 0..m {
                            tangents[((s * m + b) * m + a) * ns + j] = reduced[a + m * b];
                        }
                    }
                }
            }
        }
        let size = m * (2 * h + 1);
        let (found, residual) = if let Some(k) = kept {
            let mut found = k.switches;
            let mut series = SeriesResidual::new(p, &row, x, nu, q_scale);
            time_gradients(&mut series, &mut frame, &mut found, evaluations);
            (found, k.residual)
        } else {
            let found = if switches {
                let mut series = SeriesResidual::new(p, &row, x, nu, q_scale);
                series.events(&mut frame, period, &mut sample_events);
                events.extend_from_slice(&sample_events);
                let mut crossings = std::mem::take(&mut self.crossings);
                crossings.clear();
                let found = locate(
                    &mut series,
                    &mut frame,
                    &events,
                    sample_events.len(),
                    period / ns as f64,
                    want_jacobian,
                    evaluations,
                    &mut crossings,
                );
                self.crossings = crossings;
                let found = found?;
                subtract(&found, period, &mut r);
                found
            } else {
                Vec::new()
            };
            let mut residual = self.analyse_samples(&r);
            add_back(&found, nu, h, &mut residual);
            (found, residual)
        };
        if let Some(jacobian) = jacobian {
            // (1/N) Σ_j x_j cos pθ_j and (1/N) Σ_j x_j sin pθ_j, p = 0 ..= 2H (mod N), of the
            // stiffness (index 0) and damping (index 1) sequence of each pair (a, b), scaled
            // to row a (the damping also by ν: ẏ of cos cνt is −cν sin cνt).
            let spectra = self.tangent_spectra(&tangents, &row, nu);
            let inertia = Inertia { mass: &self.reduced_mass, row: &row, nu, q_scale };
            match jacobian {
                Jacobian::Dense { matrix: jac, .. } => {
                    jac.clear();
                    jac.resize(size * size, 0.0);
                    assemble(m, h, h, &spectra, &inertia, |r, c, v| jac[r + size * c] += v);
                    add_time_terms(&found, period, h, jac);
                }
                Jacobian::Operator(slot) => {
                    // The last operator's pattern and storage where they fit.
                    let (pattern, mut band, mut kept) = match slot.take() {
                        Some(op) if op.pattern.is(m, h, KRYLOV_BAND) => {
                            let op = *op;
                            (op.pattern, op.band, op.tangents)
                        }
                        _ => (BandPattern::new(m, h, KRYLOV_BAND)?, Vec::new(), Vec::new()),
                    };
                    band.clear();
                    band.resize(pattern.len(), 0.0);
                    assemble(m, h, pattern.band(), &spectra, &inertia, |r, c, v| {
                        if let Some(i) = pattern.index(r, c) {
                            band[i] += v;
                        }
                    });
                    let terms = time_terms(&found, period, h);
                    for (u, v) in &terms {
                        for (c, column) in v.iter().enumerate() {
                            let (lo, hi) = pattern.rows(c);
                            for (r, w) in u.iter().enumerate().take(hi).skip(lo) {
                                if let Some(i) = pattern.index(r, c) {
                                    band[i] += column * w;
                                }
                            }
                        }
                    }
                    let lu = pattern.factorize(&band)?;
                    // The tangents move into the operator; the balance keeps the last
                    // operator's storage for the next evaluation, which overwrites it whole.
                    std::mem::swap(&mut kept, &mut tangents);
                    *slot = Some(Box::new(Operator {
                        m,
                        harmonics: h,
                        plans: self.plans().share(),
                        nu,
                        q_scale,
                        mass: self.reduced_mass.clone(),
                        row: row.clone(),
                        tangents: kept,
                        terms,
                        pattern,
                        band,
                        lu,
                    }));
                }
            }
        }
        self.tangents = tangents;
        if switches {
            self.projected =
                Some(Projected { omega, x: x.to_vec(), residual: residual.clone(), switches: found });
        }
        Ok(residual)
    }

    /// The periodic state at `omega` [rad/s] by Newton's method with a
    /// backtracking line search from the coefficients `guess` (a cold start
    /// when `None`: the static state, where Newton fails from there the march's
    /// period after the shooting problem's run-in, and where that fails too the
    /// orbits of neighbouring speeds ([`NEIGHBOUR_OFFSETS`]); a guess with
    /// another number of harmonics gives its common harmonics).
    pub fn solve(&mut self, omega: f64, guess: Option<&[f64]>) -> Result<HarmonicOrbit, PeriodicError> {
        let mut newton = Newton::default();
        let x = match guess {
            // Another H's coefficients: the common harmonics, the rest zero.
            Some(g) if g.len() % self.m == 0 && (g.len() / self.m) % 2 == 1 => {
                refit(g, self.unknowns(), false)
            }
            Some(g) => {
                return Err(PeriodicError::invalid(
                    "harmonic-balance guess",
                    g.len() as f64,
                    "must hold m(2H' + 1) coefficients for some H' (m coordinates)",
                ))
            }
            None => return self.solve_cold(omega, &mut newton),
        };
        self.attempt(omega, x, &mut newton)
    }

    /// [`Self::solve`] without a guess: [`Self::cold_attempt`] at `omega`, and where that
    /// fails, from the orbits of neighbouring speeds. Both starts fail at a few speeds where
    /// the orbit lies far from the static state and the march does not approach it (κ = 0,
    /// 9600 rpm: the period-1 orbit unstable, the march quasi-periodic): then from the orbit
    /// of a neighbouring speed, found as this one would be, as a sweep's warm start
    /// ([`NEIGHBOUR_OFFSETS`]). The error is the static start's at `omega`.
    fn solve_cold(&mut self, omega: f64, newton: &mut Newton) -> Result<HarmonicOrbit, PeriodicError> {
        let solved = self.cold_attempt(omega, newton);
        if solved.is_ok() {
            return solved;
        }
        for offset in NEIGHBOUR_OFFSETS {
            let near = omega * (1.0 + offset);
            let Ok(neighbour) = self.cold_attempt(near, newton) else { continue };
            if let Ok(orbit) = self.attempt(omega, neighbour.coefficients, newton) {
                return Ok(HarmonicOrbit { neighbour: Some(near), ..orbit });
            }
        }
        solved
    }

    /// [`Self::attempt`] from the static state ([`Self::cold_start`]) and, where that fails,
    /// from the march's period. Newton from the static state can stall where the response
    /// lies far from it (4100 rpm on the torsional example: a fourth-harmonic resonance,
    /// the ring teeth separating; residual 3 after 10 iterations). Then from the state the
    /// march reaches after the shooting problem's run-in, as its own cold start does, its
    /// next period sampled and analysed into coefficients (the counts hold all attempts;
    /// the error is the static start's).
    fn cold_attempt(&mut self, omega: f64, newton: &mut Newton) -> Result<HarmonicOrbit, PeriodicError> {
        let solved = self.attempt(omega, self.cold_start(omega), newton);
        if solved.is_ok() {
            return solved;
        }
        match self.marched_start(omega, newton) {
            Ok(x) => self.attempt(omega, x, newton).or(solved),
            Err(_) => solved,
        }
    }

    /// [`Self::run`] from `x`: the plain run on half the samples where the settings allow
    /// it ([`PLAIN_SAMPLES_PER_HARMONIC`]); where that solve fails, the whole solve again
    /// on the full samples.
    fn attempt(
        &mut self,
        omega: f64,
        x: Vec<f64>,
        newton: &mut Newton,
    ) -> Result<HarmonicOrbit, PeriodicError> {
        if self.half.is_some() {
            if let Ok(orbit) = self.run(omega, x.clone(), true, newton) {
                return Ok(orbit);
            }
        }
        self.run(omega, x, false, newton)
    }

    /// The coefficients of the period the march from the static state reaches after the
    /// shooting problem's run-in periods ([`PeriodicProblem::cold_start`]): that period
    /// sampled at the settings' N and analysed. `newton` counts the flows' steps and force
    /// evaluations.
    fn marched_start(&mut self, omega: f64, newton: &mut Newton) -> Result<Vec<f64>, PeriodicError> {
        let mut work = Work::default();
        let z = self.problem.cold_start(omega, &mut work)?;
        let ns = self.settings.samples;
        let coordinates = self.problem.sampled_flow(omega, &z, ns, &mut work)?;
        newton.evaluations += work.rhs_evaluations;
        newton.march_steps += work.steps;
        self.samples = ns;
        Ok(self.analyse_samples(&coordinates))
    }

    /// The kept Jacobian's storage, taken from the balance, in the form a system of
    /// `unknowns` takes (the storage of the other form is dropped): the dense LU's up to
    /// [`DENSE_UNKNOWNS`], the operator's beyond.
    fn take_jacobian(&mut self, unknowns: usize) -> Jacobian {
        let jacobian = std::mem::take(&mut self.jacobian);
        let krylov = unknowns > self.dense_unknowns;
        if krylov == matches!(jacobian, Jacobian::Operator(_)) {
            jacobian
        } else if krylov {
            Jacobian::Operator(None)
        } else {
            Jacobian::default()
        }
    }

    /// [`Self::solve`] from the coefficients `x`, its plain run on N/2 samples when
    /// `half`; `newton` counts the work and keeps the Jacobian's storage (taken from the
    /// balance and handed back to it).
    fn run(
        &mut self,
        omega: f64,
        x: Vec<f64>,
        half: bool,
        newton: &mut Newton,
    ) -> Result<HarmonicOrbit, PeriodicError> {
        newton.jacobian = self.take_jacobian(x.len());
        // Near the root of the plain sums first (to [`HANDOVER_STEP`]); then, from there, the
        // root with the contact switches' jumps and kinks projected exactly on the full N
        // samples (module `switches`), which lies 2e-4 to 1.2e-3 of the coefficients from the
        // plain root off the separating speeds of the torsional example, more where the teeth
        // separate: each evaluation of that residual costs more.
        // The second run starts on the plain sums' factorised Jacobian; a Jacobian it takes
        // afresh holds the jumps' time terms.
        if half {
            self.samples = self.settings.samples / 2;
        }
        let plain = (|| {
            let r = self.evaluate(omega, &x, Some(&mut newton.jacobian), &mut newton.evaluations, false)?;
            newton.factorize(x.len());
            self.newton(omega, x, r, false, newton)
        })();
        self.samples = self.settings.samples;
        let projected = plain.and_then(|(x, _, _)| {
            let r = self.evaluate(omega, &x, None, &mut newton.evaluations, true)?;
            self.newton(omega, x, r, true, newton)
        });
        self.jacobian = std::mem::take(&mut newton.jacobian);
        let (x, r, last_step) = projected?;
        Ok(HarmonicOrbit {
            speed: omega,
            period: self.problem.period(omega),
            cycles: self.problem.cycles,
            harmonics: self.settings.harmonics,
            coefficients: x,
            iterations: newton.iterations,
            residual: max_abs(&r),
            last_step,
            factorizations: newton.factorizations,
            products: newton.products,
            force_evaluations: newton.evaluations,
            march_steps: newton.march_steps,
            neighbour: None,
            crossings: self.crossings.clone(),
        })
    }

    /// Newton's method with a backtracking line search from `x`, whose residual
    /// is `r`, on the residual with or without the contact switches projected
    /// (`switches`); chord iterations on `newton`'s factorised Jacobian while
    /// they contract well. The root, its residual and the last step.
    fn newton(
        &mut self,
        omega: f64,
        mut x: Vec<f64>,
        mut r: Vec<f64>,
        switches: bool,
        newton: &mut Newton,
    ) -> Result<(Vec<f64>, Vec<f64>, f64), PeriodicError> {
        let (mut stalled, mut iterations) = (0, 0);
        // The length of the last step taken whole (no line search), for the contraction.
        let mut whole: Option<f64> = None;
        loop {
            let norm = max_abs(&r);
            let step = newton.step(&r);
            let last_step = max_abs(&step);
            if !last_step.is_finite() {
                return Err(PeriodicError::NotConverged {
                    speed: omega,
                    iterations: newton.iterations,
                    residual: norm,
                });
            }
            // A step below the tolerance is taken whole and ends the run, without the
            // residual after it; the plain sums' run hands over at HANDOVER_STEP. On the
            // projected residual, so does a step after which the distance to the root,
            // estimated from the contraction θ of the steps (θ / (1 − θ) times this one,
            // [`newton_remainder`]), is at most the tolerance.
            let tolerance =
                if switches { self.settings.tolerance } else { self.settings.tolerance.max(HANDOVER_STEP) };
            let allowed = tolerance * max_abs(&x).max(1.0);
            let remainder = if switches { newton_remainder(whole, last_step) } else { f64::INFINITY };
            if last_step <= allowed || remainder <= allowed {
                newton.iterations += 1;
                x.iter_mut().zip(&step).for_each(|(a, d)| *a += d);
                return Ok((x, r, last_step));
            }
            iterations += 1;
            newton.iterations += 1;
            let mut alpha = 1.0;
            let (mut x_new, mut r_new);
            loop {
                x_new = x.iter().zip(&step).map(|(a, d)| a + alpha * d).collect::<Vec<f64>>();
                r_new = self.evaluate(omega, &x_new, None, &mut newton.evaluations, switches)?;
                if max_abs(&r_new) < (1.0 - 1e-4 * alpha) * norm || alpha < 1.0 / 64.0 {
                    break;
                }
                alpha *= 0.5;
            }
            x = x_new;
            whole = (alpha == 1.0).then_some(last_step);
            let contraction = max_abs(&r_new) / norm;
            r = r_new;
            if alpha * last_step <= self.settings.tolerance * max_abs(&x).max(1.0) {
                return Ok((x, r, last_step));
            }
            // Newton converges by a factor 10 or more per iteration here; iterations that
            // no longer halve the residual cycle between contact patterns the series cannot
            // settle (docs/PERIODIC.md §2) and do not converge.
            stalled = if contraction > 0.5 { stalled + 1 } else { 0 };
            if iterations >= self.settings.max_iterations || stalled >= STALLED_ITERATIONS {
                return Err(PeriodicError::NotConverged {
                    speed: omega,
                    iterations: newton.iterations,
                    residual: max_abs(&r),
                });
            }
            // Chord iterations while they contract well; a fresh Jacobian otherwise.
            if contraction > self.settings.chord_contraction {
                r =
                    self.evaluate(omega, &x, Some(&mut newton.jacobian), &mut newton.evaluations, switches)?;
                newton.factorize(x.len());
            }
        }
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

    /// Floquet multipliers of `orbit`, largest modulus first: the eigenvalues
    /// of the monodromy of the variational equations along the orbit in the
    /// unknowns' coordinates (the free rotation excluded, as in shooting),
    /// PᵀMP δÿ + PᵀCP δẏ + PᵀKP δy = 0 (K, C the tangent stiffness and
    /// damping). The contact switches are found on `intervals` equal
    /// intervals of the period: where a tooth pair starts or stops touching
    /// its tangents jump, and where a whole mesh does its damping force jumps
    /// (sign changes of the event values between the intervals' ends, located
    /// on the series to 1e-12 of an interval). The period is advanced in
    /// `intervals` / [`SCAN_INTERVALS_PER_STEP`] equal steps, each cut at the
    /// switches inside it, with K and C frozen at the middle of each piece and
    /// the piece's exponential taken by scaling and squaring of its Taylor
    /// series (to the degree whose first omitted term is below 1e-11); at a
    /// mesh's switch the columns take the damping jump's saltation term, as
    /// shooting's variational flow does. No flow is integrated. The error
    /// against shooting's variational monodromy is measured
    /// (docs/PERIODIC.md §2).
    pub fn floquet_multipliers(
        &mut self,
        orbit: &HarmonicOrbit,
        intervals: usize,
    ) -> Result<Vec<Multiplier>, PeriodicError> {
        if intervals == 0 {
            return Err(PeriodicError::invalid("multiplier intervals", 0.0, "must be at least 1"));
        }
        let omega = orbit.speed;
        let (m, n) = (self.m, self.n);
        let mass_inverse = nalgebra::DMatrix::from_column_slice(m, m, &self.reduced_mass)
            .try_inverse()
            .ok_or_else(|| PeriodicError::invalid("reduced mass", 0.0, "must be invertible"))?;
        self.problem.model.set_drive_speed(omega);
        let rigid = self.problem.model.rigid_velocity_at(omega);
        let mut frame = RigidFrame::new(&mut self.problem.model, rigid);
        let mut walk = Propagation::new(orbit, &self.p, self.problem.q_scale, (m, n), mass_inverse);
        // From the crossings the solve located where it has them; the whole period searched
        // otherwise, or where one of them is not found again.
        let h_scan = orbit.period / intervals as f64;
        let seeded = if orbit.crossings.is_empty() {
            None
        } else {
            walk.seeded_switches(&mut frame, h_scan, &orbit.crossings)
        };
        let (mut pairs, mut switches) = match seeded {
            Some(found) => found,
            None => walk.switches(&mut frame, h_scan, intervals),
        };
        pairs.sort_by(f64::total_cmp);
        switches.sort_by(|x, y| x.time.total_cmp(&y.time));
        // Every step is cut where a pair's tangents jump; where a whole mesh touches or
        // separates the columns also take the damping's saltation.
        let mut cuts: Vec<(f64, Option<&DampingSwitch>)> = pairs.iter().map(|t| (*t, None)).collect();
        cuts.extend(switches.iter().map(|s| (s.time, Some(s))));
        cuts.sort_by(|x, y| x.0.total_cmp(&y.0));
        let steps = (intervals / SCAN_INTERVALS_PER_STEP).max(1);
        let h = orbit.period / steps as f64;
        let mut next = 0;
        for j in 0..steps {
            let end = (j + 1) as f64 * h;
            // A step without a switch is advanced whole, its midpoint and length written as
            // (j + ½)h and h rather than from its ends (which round differently).
            if cuts.get(next).is_none_or(|c| c.0 > end) {
                walk.advance(&mut frame, (j as f64 + 0.5) * h, h);
                continue;
            }
            let mut from = j as f64 * h;
            while let Some(&(time, damping)) = cuts.get(next).filter(|c| c.0 <= end) {
                if time > from {
                    walk.advance(&mut frame, 0.5 * (from + time), time - from);
                    from = time;
                }
                if let Some(switch) = damping {
                    walk.saltation(&mut frame, switch);
                }
                next += 1;
            }
            if end > from {
                walk.advance(&mut frame, 0.5 * (from + end), end - from);
            }
        }
        floquet_multipliers(&walk.phi, 2 * m)
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
mod tests {
    use super::*;
    use crate::contact::ltca::SetModel;
    use crate::dynamics::periodic::ShootingSettings;
    use crate::scene::{Fidelity, Scene};

    /// The rule's H grows with the highest mode's order in the period, at
    /// least MIN_HARMONICS; the settings keep it up to MAX_RULE_HARMONICS and
    /// hold it there, with 16 samples per harmonic kept.
    #[test]
    fn the_rules_harmonics_follow_the_modes_order_up_to_the_cap() {
        let (highest, period) = (20_000.0, 1e-3);
        assert_eq!(HarmonicSettings::rule_harmonics(highest, period), 50);
        assert_eq!(HarmonicSettings::rule_harmonics(highest, 0.5 * period), 25_usize.max(MIN_HARMONICS));
        let held = HarmonicSettings::for_frequency(highest, 20.0 * period);
        assert_eq!(HarmonicSettings::rule_harmonics(highest, 20.0 * period), 1000);
        assert_eq!(
            (held.harmonics, held.samples),
            (MAX_RULE_HARMONICS, SAMPLES_PER_HARMONIC * MAX_RULE_HARMONICS)
        );
        let kept = HarmonicSettings::for_frequency(highest, 4.0 * period);
        assert_eq!((kept.harmonics, kept.samples), (200, 200 * SAMPLES_PER_HARMONIC));
    }

    #[test]
    fn the_projection_is_p_transposed_x_p_summed_as_dot_products() {
        // PᵀXP of a 6 × 6 X and a 6 × 5 P, entries of mixed signs and sizes (zeros
        // included, as in the tangents), against the triple sums in the order of the
        // former dot products: equal to the last bit, so that the balance's Jacobian
        // does not change with the loop's form.
        let (n, m) = (6, 5);
        let value = |k: usize| {
            let v = ((k * 7919) % 104_729) as f64 / 104_729.0 - 0.5;
            if k % 5 == 0 {
                0.0
            } else {
                v * 10f64.powi((k % 7) as i32 - 3)
            }
        };
        let x = nalgebra::DMatrix::from_fn(n, n, |i, l| value(3 + i + n * l));
        let p: Vec<f64> = (0..n * m).map(|k| value(101 + k)).collect();
        let (mut xp, mut out) = (vec![0.0; n * m], vec![0.0; m * m]);
        project(&p, &x, m, &mut xp, &mut out);
        for b in 0..m {
            let column: Vec<f64> = (0..n).map(|i| (0..n).map(|l| x[(i, l)] * p[l + n * b]).sum()).collect();
            for a in 0..m {
                let expected: f64 = (0..n).map(|i| p[i + n * a] * column[i]).sum();
                assert_eq!(
                    out[a + m * b].to_bits(),
                    expected.to_bits(),
                    "({a}, {b}): {} against {expected}",
                    out[a + m * b]
                );
            }
        }
    }

    fn balance(harmonics: usize, samples: usize, rpm: f64) -> (HarmonicBalance, f64) {
        let mut scene = Scene::example_2004();
        scene.dynamics.fidelity = Fidelity::Torsional;
        let set = scene.validate().unwrap();
        let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
        let omega = rpm * std::f64::consts::PI / 30.0;
        let problem = PeriodicProblem::new(model, ShootingSettings::default(), omega).unwrap();
        let settings = HarmonicSettings { harmonics, samples, ..HarmonicSettings::default() };
        (HarmonicBalance::new(problem, settings).unwrap(), omega)
    }

    /// The Jacobian assembled from the Fourier coefficients of the tangents
    /// (product-to-sum identities) is the derivative of the residual: central
    /// differences along three directions agree to 1e-6 of the product.
    #[test]
    fn the_jacobian_is_the_derivative_of_the_residual() {
        let (mut hb, omega) = balance(8, 128, 3000.0);
        let size = hb.unknowns();
        let mut x = hb.cold_start(omega);
        // A state with every harmonic present, away from the static one.
        for (i, v) in x.iter_mut().enumerate().skip(hb.m) {
            *v += 0.02 * ((i as f64) * 0.7).sin();
        }
        let mut jac = Jacobian::default();
        hb.evaluate(omega, &x, Some(&mut jac), &mut 0, false).unwrap();
        let jac = dense(jac);
        for k in 0..3 {
            let d = direction(size, k);
            let jd = times(&jac, &d);
            let scale = max_abs(&jd);
            let worst = off(&difference(&mut hb, omega, &x, &d, 1e-7, false), &jd);
            assert!(worst <= 1e-6 * scale, "direction {k}: difference {worst:.3e} of {scale:.3e}");
        }
    }

    /// The remainder after a step of a geometrically contracting sequence is
    /// the sum of the steps still to come; without a previous step, or where
    /// the steps grow, there is no estimate.
    #[test]
    fn the_newton_remainder_sums_the_steps_to_come() {
        for theta in [1e-3_f64, 0.1, 0.5, 0.9] {
            let (previous, step) = (2.0e-3, 2.0e-3 * theta);
            let to_come: f64 = (1..2000).map(|k| step * theta.powi(k)).sum();
            let estimate = newton_remainder(Some(previous), step);
            assert!(
                (estimate - to_come).abs() <= 1e-12 * to_come,
                "θ = {theta}: {estimate:e} against {to_come:e}"
            );
        }
        assert_eq!(newton_remainder(None, 1e-9), f64::INFINITY);
        assert_eq!(newton_remainder(Some(1e-9), 1e-9), f64::INFINITY);
        assert_eq!(newton_remainder(Some(1e-9), 2e-9), f64::INFINITY);
    }

    /// Newton stopped by the estimated remainder lies within the tolerance of
    /// the root: the same point solved on to a step of 1e-12 moves no
    /// coefficient by more than the tolerance times their size, at 3000 and
    /// 8000 rpm (where the rule stops one residual evaluation earlier than a
    /// step below the tolerance would).
    #[test]
    fn newton_stopped_by_its_remainder_lies_within_the_tolerance_of_the_root() {
        for rpm in [3000.0, 8000.0] {
            let (mut hb, omega) = balance(32, 512, rpm);
            let orbit = hb.solve(omega, None).unwrap();
            let tolerance = hb.settings().tolerance * max_abs(&orbit.coefficients).max(1.0);
            let tight = HarmonicSettings { tolerance: 1e-12, ..*hb.settings() };
            hb.set_settings(tight).unwrap();
            let root = hb.solve(omega, Some(&orbit.coefficients)).unwrap();
            let moved = off(&root.coefficients, &orbit.coefficients);
            assert!(moved <= tolerance, "{rpm} rpm: moved {moved:.3e}, tolerance {tolerance:.3e}");
        }
    }

    /// The Jacobian at the point of the last projected evaluation, which takes
    /// that evaluation's residual and switches, is the one assembled afresh,
    /// bit for bit, with the same residual, where the teeth separate (10 200
    /// rpm) and where they do not (3000 rpm).
    #[test]
    fn the_jacobian_at_the_last_projected_point_is_the_one_assembled_afresh() {
        for rpm in [3000.0, 10200.0] {
            let (mut hb, omega) = balance(32, 512, rpm);
            let x = hb.solve(omega, None).unwrap().coefficients;
            let r = hb.evaluate(omega, &x, None, &mut 0, true).unwrap();
            let (mut kept, mut evaluations) = (Jacobian::default(), 0);
            let r_kept = hb.evaluate(omega, &x, Some(&mut kept), &mut evaluations, true).unwrap();
            assert_eq!(r_kept, r, "{rpm} rpm: the residual kept");
            hb.projected = None;
            let (mut fresh, mut afresh) = (Jacobian::default(), 0);
            let r_fresh = hb.evaluate(omega, &x, Some(&mut fresh), &mut afresh, true).unwrap();
            // One law evaluation per sample and the switches' time gradients, no search.
            assert!(evaluations < afresh, "{rpm} rpm: {evaluations} evaluations kept, {afresh} afresh");
            assert_eq!(r_fresh, r, "{rpm} rpm: the residual afresh");
            let (kept, fresh) = (dense(kept), dense(fresh));
            assert!(kept == fresh, "{rpm} rpm: the Jacobians differ by {:.3e}", off(&kept, &fresh));
        }
    }

    /// The multipliers found from the solve's crossings are those of the
    /// search over the whole period (measured: within 1e-9 over the 50 rpm
    /// grid), also where the meshes separate and touch again and the damping
    /// switches come from the crossings (10 200 rpm: the sun–planet teeth
    /// apart for 4.7 % of the cycle); and seeds that point nowhere near the
    /// crossings give the whole period's search.
    #[test]
    fn the_multipliers_from_the_crossings_are_those_of_the_whole_search() {
        for rpm in [3000.0, 10200.0] {
            let (mut hb, omega) = balance(32, 512, rpm);
            let orbit = hb.solve(omega, None).unwrap();
            assert!(orbit.crossings.len() >= 12, "{rpm} rpm: {} crossings", orbit.crossings.len());
            let largest = |mu: Vec<Multiplier>| mu[0].modulus();
            let seeded = largest(hb.floquet_multipliers(&orbit, 512).unwrap());
            let searched = HarmonicOrbit { crossings: Vec::new(), ..orbit.clone() };
            let whole = largest(hb.floquet_multipliers(&searched, 512).unwrap());
            assert!((seeded - whole).abs() <= 1e-8, "{rpm} rpm: {seeded} against {whole}");
            let astray: Vec<(f64, usize)> =
                orbit.crossings.iter().map(|&(t, e)| ((t + 0.3 * orbit.period) % orbit.period, e)).collect();
            let astray = HarmonicOrbit { crossings: astray, ..orbit.clone() };
            let fallback = largest(hb.floquet_multipliers(&astray, 512).unwrap());
            assert_eq!(fallback, whole, "{rpm} rpm: seeds astray give the whole search");
        }
    }

    /// The Jacobian as an operator is the dense Jacobian: its products with
    /// three directions agree to 1e-12 of their size, with the switches'
    /// time terms (10 200 rpm, the teeth separating) and on the plain sums
    /// (3000 rpm); and its band holds the dense Jacobian's entries there.
    #[test]
    fn the_jacobian_as_an_operator_is_the_dense_jacobian() {
        for (rpm, switches) in [(10200.0, true), (3000.0, false)] {
            let (mut hb, omega) = balance(32, 512, rpm);
            let size = hb.unknowns();
            let x = hb.solve(omega, None).unwrap().coefficients;
            let mut full = Jacobian::default();
            hb.evaluate(omega, &x, Some(&mut full), &mut 0, switches).unwrap();
            let full = dense(full);
            let mut operator = Jacobian::Operator(None);
            hb.evaluate(omega, &x, Some(&mut operator), &mut 0, switches).unwrap();
            let Jacobian::Operator(Some(op)) = operator else { panic!("the evaluation sets the operator") };
            assert!(!switches || !op.terms.is_empty(), "{rpm} rpm: no time terms");
            for k in 0..3 {
                let d = direction(size, k);
                let expected = times(&full, &d);
                let mut product = vec![0.0; size];
                op.apply(&d, &mut product);
                let scale = max_abs(&expected);
                let worst = off(&product, &expected);
                assert!(worst <= 1e-12 * scale, "{rpm} rpm, direction {k}: {worst:.3e} of {scale:.3e}");
            }
            let pattern = &op.pattern;
            let mut band = 0.0_f64;
            for c in 0..size {
                let (lo, hi) = pattern.rows(c);
                for r in lo..hi {
                    band = band.max((op.band[pattern.index(r, c).unwrap()] - full[r + size * c]).abs());
                }
            }
            assert!(band <= 1e-12 * max_abs(&full), "{rpm} rpm: the band off by {band:.3e}");
        }
    }

    /// GMRES on the operator finds the orbit the dense LU finds: the same
    /// point solved both ways (1000 rpm, H = 108, 1085 unknowns) agrees to
    /// the Newton tolerance, the operator's run counting its products.
    #[test]
    fn gmres_on_the_operator_finds_the_dense_lus_orbit() {
        let (mut hb, omega) = balance(32, 512, 1000.0);
        let settings = hb.settings_for_speed(omega);
        hb.set_settings(settings).unwrap();
        assert_eq!(hb.unknowns(), 1085);
        hb.dense_unknowns = usize::MAX;
        let by_lu = hb.solve(omega, None).unwrap();
        hb.dense_unknowns = 0;
        let by_gmres = hb.solve(omega, None).unwrap();
        assert_eq!(by_lu.products, 0);
        assert!(by_gmres.products > 0);
        let tolerance = 10.0 * settings.tolerance * max_abs(&by_lu.coefficients).max(1.0);
        let moved = off(&by_gmres.coefficients, &by_lu.coefficients);
        assert!(moved <= tolerance, "off by {moved:.3e}, tolerance {tolerance:.3e}");
    }

    /// The dense Jacobian's entries.
    fn dense(jacobian: Jacobian) -> Vec<f64> {
        match jacobian {
            Jacobian::Dense { matrix, .. } => matrix,
            Jacobian::Operator(_) => panic!("a dense Jacobian was asked for"),
        }
    }

    /// The test direction `k` of `size` unknowns.
    fn direction(size: usize, k: usize) -> Vec<f64> {
        (0..size).map(|i| ((i * (k + 2)) as f64 * 1.3).cos()).collect()
    }

    /// The column-major square matrix `jac` times `d`.
    fn times(jac: &[f64], d: &[f64]) -> Vec<f64> {
        let size = d.len();
        (0..size).map(|i| (0..size).map(|j| jac[i + size * j] * d[j]).sum()).collect()
    }

    /// The central difference of the residual (with or without the
    /// `switches`) at `x` along `d`, step `eps`.
    fn difference(
        hb: &mut HarmonicBalance,
        omega: f64,
        x: &[f64],
        d: &[f64],
        eps: f64,
        switches: bool,
    ) -> Vec<f64> {
        let plus: Vec<f64> = x.iter().zip(d).map(|(a, b)| a + eps * b).collect();
        let minus: Vec<f64> = x.iter().zip(d).map(|(a, b)| a - eps * b).collect();
        let rp = hb.evaluate(omega, &plus, None, &mut 0, switches).unwrap();
        let rm = hb.evaluate(omega, &minus, None, &mut 0, switches).unwrap();
        rp.iter().zip(&rm).map(|(p, m)| (p - m) / (2.0 * eps)).collect()
    }

    /// The largest difference between two vectors.
    fn off(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)
    }

    /// With the contact switches projected, the Jacobian (the plain sums'
    /// and the jumps' time terms) is closer to the derivative of the projected
    /// residual where the teeth separate (10 200 rpm) than the plain sums'
    /// alone. How close depends on where the switches fall between the
    /// samples, so the test takes six sample counts (480 to 560) and three
    /// directions each: every central difference agrees with the Jacobian to
    /// 2e-4 of the product (measured 1.0e-5 to 1.4e-4; the plain sums' 8.5e-5
    /// to 2.3e-4), and the median difference is less than 0.6 of the plain
    /// sums' (measured 5.2e-5 against 1.2e-4: 0.42). A single sample count
    /// does not decide it: at 512 the three directions gave 4.2e-5, 6.5e-5
    /// and 3.0e-5 with separation tables that differ from today's by 2e-17 m,
    /// and 7.3e-5, 1.3e-4 and 1.0e-4 with today's. A pair that grazes between
    /// two samples makes the residual jump (at a step of 1e-5 in one
    /// direction, 1e-6 in another): the smallest difference of three steps
    /// counts.
    #[test]
    fn the_jacobian_with_the_switches_is_the_derivative_of_their_residual() {
        let (mut with_terms, mut plain_sums) = (Vec::new(), Vec::new());
        for samples in [480, 500, 512, 520, 540, 560] {
            let (mut hb, omega) = balance(32, samples, 10200.0);
            let size = hb.unknowns();
            let x = hb.solve(omega, None).unwrap().coefficients;
            let (mut jac, mut plain) = (Jacobian::default(), Jacobian::default());
            hb.evaluate(omega, &x, Some(&mut jac), &mut 0, true).unwrap();
            hb.evaluate(omega, &x, Some(&mut plain), &mut 0, false).unwrap();
            let (jac, plain) = (dense(jac), dense(plain));
            for k in 0..3 {
                let d = direction(size, k);
                let (jd, pd) = (times(&jac, &d), times(&plain, &d));
                let scale = max_abs(&jd);
                // The smallest difference of three steps: a grazing jump lies between at most some.
                let (mut with, mut without) = (f64::INFINITY, f64::INFINITY);
                for eps in [1e-7, 1e-6, 1e-4] {
                    let dr = difference(&mut hb, omega, &x, &d, eps, true);
                    if off(&dr, &jd) < with {
                        (with, without) = (off(&dr, &jd), off(&dr, &pd));
                    }
                }
                assert!(with <= 2e-4 * scale, "{samples} samples, direction {k}: {with:.3e} of {scale:.3e}");
                with_terms.push(with / scale);
                plain_sums.push(without / scale);
            }
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            0.5 * (v[v.len() / 2 - 1] + v[v.len() / 2])
        };
        let (with, without) = (median(&mut with_terms), median(&mut plain_sums));
        assert!(
            with < 0.6 * without,
            "median difference {with:.2e} with the time terms, {without:.2e} without"
        );
    }

    /// A constant-only series gives constant samples, and the analysis of the
    /// samples of a series returns its coefficients.
    #[test]
    fn synthesis_and_analysis_are_inverse() {
        let (hb, _) = balance(8, 40, 3000.0);
        let coefficients: Vec<f64> = (0..17).map(|c| 0.1 * c as f64 - 0.5).collect();
        let mut buffer = vec![Complex::new(0.0, 0.0); 40];
        let mut samples = vec![0.0; 40];
        hb.synthesize(|c| coefficients[c], &mut buffer, &mut samples);
        // y(t_j) directly from the series.
        for (j, y) in samples.iter().enumerate() {
            let theta = 2.0 * std::f64::consts::PI * j as f64 / 40.0;
            let direct = coefficients[0]
                + (1..=8)
                    .map(|k| {
                        coefficients[2 * k - 1] * (k as f64 * theta).cos()
                            + coefficients[2 * k] * (k as f64 * theta).sin()
                    })
                    .sum::<f64>();
            assert!((y - direct).abs() < 1e-12, "sample {j}: {y} against {direct}");
        }
        let mut back = vec![0.0; 17];
        hb.analyse(&samples, &mut buffer, &mut back);
        for (a, b) in back.iter().zip(&coefficients) {
            assert!((a - b).abs() < 1e-12);
        }
    }
}
