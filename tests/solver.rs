//! Tests of the time integrators against closed-form solutions and the laws they must obey.

use nalgebra::DMatrix;
use planetwear::dynamics::solver::{
    AlphaParameters, GeneralizedAlpha, GeneralizedAlphaSettings, Rk45, Rk45Settings, SecondOrderSystem,
    SolverError, StepController, TangentSystem,
};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Test systems
// ---------------------------------------------------------------------------------------------

/// m x'' + c x' + k x = f0 cos(w t).
struct Forced {
    m: [f64; 1],
    c: f64,
    k: f64,
    f0: f64,
    w: f64,
}

impl Forced {
    fn standard() -> Self {
        Self { m: [2.0], c: 0.8, k: 50.0, f0: 3.0, w: 3.7 }
    }

    fn omega(&self) -> f64 {
        (self.k / self.m[0]).sqrt()
    }

    /// Closed-form displacement and velocity at `t` from (x0, v0) at t = 0.
    fn exact(&self, x0: f64, v0: f64, t: f64) -> (f64, f64) {
        let m = self.m[0];
        let det = self.k - m * self.w * self.w;
        let amp = self.f0 / (det * det + (self.c * self.w).powi(2)).sqrt();
        let phi = (self.c * self.w).atan2(det);
        let xp = |t: f64| amp * (self.w * t - phi).cos();
        let vp = |t: f64| -amp * self.w * (self.w * t - phi).sin();
        let sigma = self.c / (2.0 * m);
        let wd = (self.k / m - sigma * sigma).sqrt();
        let a = x0 - xp(0.0);
        let b = (v0 - vp(0.0) + sigma * a) / wd;
        let e = (-sigma * t).exp();
        let (s, c) = (wd * t).sin_cos();
        let xh = e * (a * c + b * s);
        let vh = e * ((-sigma * a + wd * b) * c + (-sigma * b - wd * a) * s);
        (xh + xp(t), vh + vp(t))
    }
}

impl SecondOrderSystem for Forced {
    fn dim(&self) -> usize {
        1
    }

    fn mass(&self) -> &[f64] {
        &self.m
    }

    fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        f[0] = self.f0 * (self.w * t).cos() - self.c * v[0] - self.k * q[0];
    }
}

impl TangentSystem for Forced {
    fn jacobian(&mut self, _t: f64, _q: &[f64], _v: &[f64], k: &mut DMatrix<f64>, c: &mut DMatrix<f64>) {
        k[(0, 0)] = self.k;
        c[(0, 0)] = self.c;
    }
}

/// M q'' + C q' + K q = 0 with diagonal M.
struct Linear {
    m: Vec<f64>,
    k: DMatrix<f64>,
    c: DMatrix<f64>,
}

impl Linear {
    /// Unit masses, K = R diag(w1², w2²) Rᵀ with R a rotation by `angle`, no damping.
    fn two_modes(w1: f64, w2: f64, angle: f64) -> (Self, [[f64; 2]; 2]) {
        let (s, c) = angle.sin_cos();
        let modes = [[c, s], [-s, c]];
        let mut k = DMatrix::zeros(2, 2);
        for (r, w) in modes.iter().zip([w1, w2]) {
            for i in 0..2 {
                for j in 0..2 {
                    k[(i, j)] += w * w * r[i] * r[j];
                }
            }
        }
        (Self { m: vec![1.0, 1.0], k, c: DMatrix::zeros(2, 2) }, modes)
    }

    fn energy(&self, q: &[f64], v: &[f64]) -> f64 {
        let n = self.m.len();
        let mut e = 0.0;
        for i in 0..n {
            e += 0.5 * self.m[i] * v[i] * v[i];
            for j in 0..n {
                e += 0.5 * q[i] * self.k[(i, j)] * q[j];
            }
        }
        e
    }
}

impl SecondOrderSystem for Linear {
    fn dim(&self) -> usize {
        self.m.len()
    }

    fn mass(&self) -> &[f64] {
        &self.m
    }

    fn force(&mut self, _t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        let n = self.m.len();
        for (i, fi) in f.iter_mut().enumerate().take(n) {
            let mut s = 0.0;
            for j in 0..n {
                s += self.k[(i, j)] * q[j] + self.c[(i, j)] * v[j];
            }
            *fi = -s;
        }
    }
}

impl TangentSystem for Linear {
    fn jacobian(&mut self, _t: f64, _q: &[f64], _v: &[f64], k: &mut DMatrix<f64>, c: &mut DMatrix<f64>) {
        k.copy_from(&self.k);
        c.copy_from(&self.c);
    }
}

/// Modal energy ½(η'² + w² η²) of unit-mass mode `r`.
fn modal_energy(r: &[f64; 2], w: f64, q: &[f64], v: &[f64]) -> f64 {
    let eta = r[0] * q[0] + r[1] * q[1];
    let deta = r[0] * v[0] + r[1] * v[1];
    0.5 * (deta * deta + w * w * eta * eta)
}

/// Gap (clearance) oscillator: m x'' + c x' + k1 x + k2 (x − g)⁺ = 0; contact while x > g.
#[derive(Clone)]
struct Gap {
    m: [f64; 1],
    c: f64,
    k1: f64,
    k2: f64,
    g: f64,
}

impl Gap {
    fn standard() -> Self {
        let k1 = (2.0 * PI).powi(2);
        Self { m: [1.0], c: 0.25, k1, k2: 9.0 * k1, g: 0.5 }
    }

    /// Closed-form solution in one region from (x_s, v_s) at τ = 0: returns (x, v) at τ.
    fn region(&self, contact: bool, xs: f64, vs: f64, tau: f64) -> (f64, f64) {
        let m = self.m[0];
        let kk = if contact { self.k1 + self.k2 } else { self.k1 };
        let x_eq = if contact { self.k2 * self.g / kk } else { 0.0 };
        let sigma = self.c / (2.0 * m);
        let wd = (kk / m - sigma * sigma).sqrt();
        let a = xs - x_eq;
        let b = (vs + sigma * a) / wd;
        let e = (-sigma * tau).exp();
        let (s, c) = (wd * tau).sin_cos();
        (x_eq + e * (a * c + b * s), e * ((-sigma * a + wd * b) * c + (-sigma * b - wd * a) * s))
    }

    /// Exact state at `t_end` from (x0, v0) at t = 0 (x0 < g), stitching the closed-form
    /// solutions of both regions; the switch times come from bracketing the sign change of
    /// x − g on a fine grid and bisecting to machine precision. Returns the state and the switch
    /// times.
    fn exact(&self, x0: f64, v0: f64, t_end: f64) -> ((f64, f64), Vec<f64>) {
        let mut switches = Vec::new();
        let (mut ts, mut xs, mut vs) = (0.0, x0, v0);
        let mut contact = x0 > self.g;
        loop {
            let kk = if contact { self.k1 + self.k2 } else { self.k1 };
            let dtau = 2.0 * PI / (kk / self.m[0]).sqrt() / 2000.0;
            let outside = |x: f64| if contact { x <= self.g } else { x > self.g };
            // Bracket the first sign change after the start of the region.
            let mut lo = 0.0;
            let mut hi = dtau;
            let mut found = false;
            while ts + lo < t_end {
                if outside(self.region(contact, xs, vs, hi).0) {
                    found = true;
                    break;
                }
                lo = hi;
                hi += dtau;
            }
            if !found || ts + lo >= t_end {
                return (self.region(contact, xs, vs, t_end - ts), switches);
            }
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if outside(self.region(contact, xs, vs, mid).0) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            let tau = 0.5 * (lo + hi);
            if ts + tau >= t_end {
                return (self.region(contact, xs, vs, t_end - ts), switches);
            }
            let (_, v) = self.region(contact, xs, vs, tau);
            ts += tau;
            xs = self.g;
            vs = v;
            contact = !contact;
            switches.push(ts);
        }
    }
}

impl SecondOrderSystem for Gap {
    fn dim(&self) -> usize {
        1
    }

    fn mass(&self) -> &[f64] {
        &self.m
    }

    fn force(&mut self, _t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        f[0] = -self.c * v[0] - self.k1 * q[0] - self.k2 * (q[0] - self.g).max(0.0);
    }

    fn events(&mut self, _t: f64, q: &[f64], _v: &[f64], out: &mut Vec<f64>) {
        out.push(q[0] - self.g);
    }
}

impl TangentSystem for Gap {
    fn jacobian(&mut self, _t: f64, q: &[f64], _v: &[f64], k: &mut DMatrix<f64>, c: &mut DMatrix<f64>) {
        k[(0, 0)] = self.k1 + if q[0] > self.g { self.k2 } else { 0.0 };
        c[(0, 0)] = self.c;
    }
}

/// Stiff hardening spring under a step-plus-harmonic load:
/// m x'' + c x' + k x + k3 x³ = F0 (1 + ½ sin 2πt).
struct Cubic {
    m: [f64; 1],
    c: f64,
    k: f64,
    k3: f64,
    f0: f64,
}

impl SecondOrderSystem for Cubic {
    fn dim(&self) -> usize {
        1
    }

    fn mass(&self) -> &[f64] {
        &self.m
    }

    fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        let x = q[0];
        f[0] =
            self.f0 * (1.0 + 0.5 * (2.0 * PI * t).sin()) - self.c * v[0] - self.k * x - self.k3 * x * x * x;
    }
}

impl TangentSystem for Cubic {
    fn jacobian(&mut self, _t: f64, q: &[f64], _v: &[f64], k: &mut DMatrix<f64>, c: &mut DMatrix<f64>) {
        k[(0, 0)] = self.k + 3.0 * self.k3 * q[0] * q[0];
        c[(0, 0)] = self.c;
    }
}

/// A unit oscillator whose force turns into NaN after `t_bad`.
struct NanAfter {
    m: [f64; 1],
    t_bad: f64,
}

impl SecondOrderSystem for NanAfter {
    fn dim(&self) -> usize {
        1
    }

    fn mass(&self) -> &[f64] {
        &self.m
    }

    fn force(&mut self, t: f64, q: &[f64], _v: &[f64], f: &mut [f64]) {
        f[0] = if t > self.t_bad { f64::NAN } else { -q[0] };
    }
}

impl TangentSystem for NanAfter {
    fn jacobian(&mut self, _t: f64, _q: &[f64], _v: &[f64], k: &mut DMatrix<f64>, _c: &mut DMatrix<f64>) {
        k[(0, 0)] = 1.0;
    }
}

/// A unit oscillator that records the times at which its force is evaluated.
struct Recorder {
    m: [f64; 1],
    times: Vec<f64>,
}

impl SecondOrderSystem for Recorder {
    fn dim(&self) -> usize {
        1
    }

    fn mass(&self) -> &[f64] {
        &self.m
    }

    fn force(&mut self, t: f64, q: &[f64], _v: &[f64], f: &mut [f64]) {
        self.times.push(t);
        f[0] = -q[0];
    }
}

impl TangentSystem for Recorder {
    fn jacobian(&mut self, _t: f64, _q: &[f64], _v: &[f64], k: &mut DMatrix<f64>, _c: &mut DMatrix<f64>) {
        k[(0, 0)] = 1.0;
    }
}

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

fn ga(settings: GeneralizedAlphaSettings) -> GeneralizedAlpha {
    GeneralizedAlpha::new(settings).expect("valid settings")
}

fn rk(settings: Rk45Settings) -> Rk45 {
    Rk45::new(settings).expect("valid settings")
}

/// Error of the forced oscillator at `t_end` after `steps` generalized-α steps, in the energy-like
/// norm sqrt(Δx² + (Δv/ω)²) [m].
fn ga_forced_error(settings: GeneralizedAlphaSettings, steps: u64, t_end: f64) -> f64 {
    let mut sys = Forced::standard();
    let (x0, v0) = (0.1, -0.2);
    let mut int = ga(settings);
    int.init(&mut sys, 0.0, &[x0], &[v0]).unwrap();
    int.advance(&mut sys, t_end, steps).unwrap();
    let (xe, ve) = sys.exact(x0, v0, t_end);
    ((int.q()[0] - xe).powi(2) + ((int.v()[0] - ve) / sys.omega()).powi(2)).sqrt()
}

// ---------------------------------------------------------------------------------------------
// 1. Linear damped, harmonically forced oscillator
// ---------------------------------------------------------------------------------------------

/// Generalized-α is second order: the error ratio under step halving is 4 (order in [1.9, 2.1])
/// for ρ∞ = 1, 0.9, 0.6, for HHT-α and for Newmark's average-acceleration rule.
#[test]
fn ga_forced_oscillator_is_second_order() {
    let t_end = 5.0;
    let cases: Vec<(String, GeneralizedAlphaSettings)> = vec![
        ("rho=1".into(), GeneralizedAlphaSettings::chung_hulbert(1.0).unwrap()),
        ("rho=0.9".into(), GeneralizedAlphaSettings::chung_hulbert(0.9).unwrap()),
        ("rho=0.6".into(), GeneralizedAlphaSettings::chung_hulbert(0.6).unwrap()),
        ("hht 0.1".into(), GeneralizedAlphaSettings::hht(0.1).unwrap()),
        ("newmark avg".into(), GeneralizedAlphaSettings::newmark_average_acceleration()),
    ];
    for (name, settings) in cases {
        let errors: Vec<f64> = [200, 400, 800].iter().map(|&n| ga_forced_error(settings, n, t_end)).collect();
        for w in errors.windows(2) {
            let order = (w[0] / w[1]).log2();
            assert!((1.9..=2.1).contains(&order), "{name}: errors {errors:?}, observed order {order}");
        }
        // The error is a truncation error well above rounding, and small in absolute terms.
        assert!(errors[2] > 1e-9 && errors[2] < 1e-3, "{name}: errors {errors:?}");
    }
}

/// The adaptive Dormand–Prince integrator meets its tolerance (global error below 10 rtol relative to
/// the response amplitude) and its work grows as the tolerance tightens.
#[test]
fn rk45_forced_oscillator_meets_tolerance() {
    let t_end = 5.0;
    let (x0, v0) = (0.1, -0.2);
    let mut previous_rhs = 0;
    for rtol in [1e-5, 1e-7, 1e-9, 1e-11] {
        let mut sys = Forced::standard();
        let settings = Rk45Settings { rtol, atol_q: rtol * 1e-3, atol_v: rtol * 1e-3, ..Default::default() };
        let mut int = rk(settings);
        int.init(&mut sys, 0.0, &[x0], &[v0]).unwrap();
        int.advance_to(&mut sys, t_end).unwrap();
        assert_eq!(int.time(), t_end);
        let (xe, ve) = sys.exact(x0, v0, t_end);
        // Amplitude scale of the response [m]: initial and steady-state amplitudes.
        let scale = 0.1_f64.max(ve.abs() / sys.omega()).max(xe.abs());
        let err = ((int.q()[0] - xe).powi(2) + ((int.v()[0] - ve) / sys.omega()).powi(2)).sqrt() / scale;
        assert!(err < 10.0 * rtol, "rtol {rtol}: relative error {err}");
        let rhs = int.stats().rhs_evaluations;
        assert!(rhs > previous_rhs, "rtol {rtol}: rhs {rhs} not above {previous_rhs}");
        previous_rhs = rhs;
    }
}

/// The standard controller also meets the tolerance.
#[test]
fn rk45_standard_controller_meets_tolerance() {
    let (x0, v0) = (0.1, -0.2);
    let rtol = 1e-8;
    let mut sys = Forced::standard();
    let settings = Rk45Settings {
        rtol,
        atol_q: 1e-12,
        atol_v: 1e-12,
        controller: StepController::Standard,
        ..Default::default()
    };
    let mut int = rk(settings);
    int.init(&mut sys, 0.0, &[x0], &[v0]).unwrap();
    int.advance_to(&mut sys, 5.0).unwrap();
    let (xe, _) = sys.exact(x0, v0, 5.0);
    assert!((int.q()[0] - xe).abs() < 10.0 * rtol * 0.1, "error {}", (int.q()[0] - xe).abs());
}

/// The continuous extension is of order 4: its local error at the middle of one step scales as h⁵.
#[test]
fn rk45_dense_output_local_error_is_fifth_power_of_h() {
    let (x0, v0) = (0.1, -0.2);
    let mut errs = Vec::new();
    for h in [0.2, 0.1, 0.05] {
        let mut sys = Forced::standard();
        let settings =
            Rk45Settings { rtol: 0.5, atol_q: 1.0, atol_v: 1.0, initial_step: Some(h), ..Default::default() };
        let mut int = rk(settings);
        int.init(&mut sys, 0.0, &[x0], &[v0]).unwrap();
        int.advance_to(&mut sys, h).unwrap();
        assert_eq!(int.stats().steps, 1);
        let (mut q, mut v) = ([0.0], [0.0]);
        int.dense_at(0.5 * h, &mut q, &mut v).unwrap();
        let (xe, ve) = sys.exact(x0, v0, 0.5 * h);
        errs.push(((q[0] - xe).powi(2) + ((v[0] - ve) / sys.omega()).powi(2)).sqrt());
        // Outside the last step dense output is refused.
        assert!(matches!(int.dense_at(1.5 * h, &mut q, &mut v), Err(SolverError::TimeOutOfRange { .. })));
    }
    for w in errs.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!((4.5..=5.6).contains(&order), "errors {errs:?}, local order {order}");
    }
}

// ---------------------------------------------------------------------------------------------
// 2. Undamped 2-DOF linear system: energy, numerical dissipation, instability
// ---------------------------------------------------------------------------------------------

const W_LOW: f64 = 1.0;
const W_HIGH: f64 = 1000.0;
const H_2DOF: f64 = 0.05;

/// Maximum relative energy error of generalized-α over `steps` steps of the undamped 2-DOF system.
fn energy_drift(settings: GeneralizedAlphaSettings, steps: u64) -> f64 {
    let (mut sys, _) = Linear::two_modes(W_LOW, W_HIGH, 0.6);
    let (q0, v0) = ([1.0, 0.5], [0.3, -20.0]);
    let e0 = sys.energy(&q0, &v0);
    let mut int = ga(settings);
    int.init(&mut sys, 0.0, &q0, &v0).unwrap();
    let mut drift: f64 = 0.0;
    for k in 1..=steps {
        int.advance(&mut sys, k as f64 * H_2DOF, 1).unwrap();
        drift = drift.max((sys.energy(int.q(), int.v()) - e0).abs() / e0);
    }
    drift
}

/// Generalized-α with ρ∞ = 1 (and Newmark's average-acceleration rule, its equivalent) conserves
/// the energy of an undamped linear system to rounding level over 10⁴ steps although the high mode
/// is under-resolved (ω h = 50). Rounding level here: each step forms q from terms (ω h)²/4 ≈ 625
/// times larger than q, so the bound is ε (ω h)² N^{1/2} ≈ 5.5e-11 for a random walk and
/// ε (ω h)² N ≈ 5.5e-9 for a systematic drift; the test demands 1e-9. The same measurement with
/// ρ∞ = 0.95 sees the dissipation (> 1 % energy lost).
#[test]
fn ga_rho_one_conserves_energy() {
    let steps = 10_000;
    let drift = energy_drift(GeneralizedAlphaSettings::chung_hulbert(1.0).unwrap(), steps);
    assert!(drift < 1e-9, "rho=1: max relative energy drift {drift}");
    let drift_nm = energy_drift(GeneralizedAlphaSettings::newmark_average_acceleration(), steps);
    assert!(drift_nm < 1e-9, "Newmark: max relative energy drift {drift_nm}");
    let loss = energy_drift(GeneralizedAlphaSettings::chung_hulbert(0.95).unwrap(), steps);
    assert!(loss > 0.01, "rho=0.95: relative energy change {loss}");
}

/// With ρ∞ = 0.6 the under-resolved mode (ω h = 50) is damped out while the resolved mode
/// (ω h = 0.05) keeps its amplitude within 1 % over 200 s (32 periods).
#[test]
fn ga_rho_06_damps_high_mode_keeps_low_mode() {
    let (mut sys, modes) = Linear::two_modes(W_LOW, W_HIGH, 0.6);
    let (q0, v0) = ([1.0, 0.5], [0.3, -20.0]);
    let mut int = ga(GeneralizedAlphaSettings::chung_hulbert(0.6).unwrap());
    int.init(&mut sys, 0.0, &q0, &v0).unwrap();
    let e_low0 = modal_energy(&modes[0], W_LOW, &q0, &v0);
    let e_high0 = modal_energy(&modes[1], W_HIGH, &q0, &v0);
    let steps = 4000;
    int.advance(&mut sys, steps as f64 * H_2DOF, steps).unwrap();
    let e_low = modal_energy(&modes[0], W_LOW, int.q(), int.v());
    let e_high = modal_energy(&modes[1], W_HIGH, int.q(), int.v());
    let amp_low = (e_low / e_low0).sqrt();
    let amp_high = (e_high / e_high0).sqrt();
    assert!((amp_low - 1.0).abs() < 0.01, "low-mode amplitude ratio {amp_low}");
    assert!(amp_high < 1e-12, "high-mode amplitude ratio {amp_high}");
}

/// Plain Newmark with γ = 1/2, β = 0 (central difference) is unstable for ω h > 2: the
/// under-resolved mode grows by the factor |λ| = (ω²h² − 2 + √((ω²h² − 2)² − 4))/2 per step and the
/// run ends in an error, while generalized-α (ρ∞ = 0.6) on the same system and step never gains
/// energy.
#[test]
fn newmark_central_difference_blows_up_where_ga_is_bounded() {
    let (mut sys, modes) = Linear::two_modes(W_LOW, W_HIGH, 0.6);
    let (q0, v0) = ([1.0, 0.5], [0.3, -20.0]);
    let e0 = sys.energy(&q0, &v0);
    let wh2 = (W_HIGH * H_2DOF).powi(2);
    let lambda = (wh2 - 2.0 + ((wh2 - 2.0).powi(2) - 4.0).sqrt()) / 2.0;

    let mut cd = ga(GeneralizedAlphaSettings::newmark(0.5, 0.0).unwrap());
    cd.init(&mut sys, 0.0, &q0, &v0).unwrap();
    let mut eta_prev = 0.0;
    let mut ratio = 0.0;
    for k in 1..=30u64 {
        cd.advance(&mut sys, k as f64 * H_2DOF, 1).unwrap();
        let eta = modes[1][0] * cd.q()[0] + modes[1][1] * cd.q()[1];
        ratio = (eta / eta_prev).abs();
        eta_prev = eta;
    }
    assert!((ratio / lambda - 1.0).abs() < 1e-6, "growth factor {ratio}, theory {lambda}");
    let e30 = sys.energy(cd.q(), cd.v());
    assert!(e30 > 1e150 * e0, "energy ratio after 30 steps {}", e30 / e0);
    // Continuing overflows: the integrator reports an error instead of returning non-finite values.
    let r = cd.advance(&mut sys, 200.0 * H_2DOF, 170);
    assert!(
        matches!(r, Err(SolverError::NonFiniteState { .. }) | Err(SolverError::NonFiniteForce { .. })),
        "{r:?}"
    );
    assert!(cd.q().iter().chain(cd.v()).all(|x| x.is_finite()));

    // Generalized-α on the same system and step: the first steps may overshoot (a known transient
    // of α-methods for ω h ≫ 1), but the energy stays bounded and decays to the low-mode energy.
    let mut stable = ga(GeneralizedAlphaSettings::chung_hulbert(0.6).unwrap());
    stable.init(&mut sys, 0.0, &q0, &v0).unwrap();
    let mut e_max: f64 = 0.0;
    for k in 1..=2000u64 {
        stable.advance(&mut sys, k as f64 * H_2DOF, 1).unwrap();
        e_max = e_max.max(sys.energy(stable.q(), stable.v()));
    }
    let e_low0 = modal_energy(&modes[0], W_LOW, &q0, &v0);
    let e_end = sys.energy(stable.q(), stable.v());
    assert!(e_max < 10.0 * e0, "generalized-alpha energy peak ratio {}", e_max / e0);
    assert!((e_end / e_low0 - 1.0).abs() < 0.02, "final energy / low-mode energy {}", e_end / e_low0);
}

/// The spectral radius of the amplification at ω h = 10⁶ equals ρ∞ for Chung–Hulbert's parameters,
/// (1 − α)/(1 + α) for HHT-α and 1 for the average-acceleration rule (within 1 %).
#[test]
fn ga_spectral_radius_at_infinity() {
    let w = 1e6;
    let cases = [
        (AlphaParameters::chung_hulbert(0.9).unwrap(), 0.9),
        (AlphaParameters::chung_hulbert(0.6).unwrap(), 0.6),
        (AlphaParameters::chung_hulbert(0.3).unwrap(), 0.3),
        (AlphaParameters::hht(0.1).unwrap(), 0.9 / 1.1),
        (AlphaParameters::hht(0.3).unwrap(), 0.7 / 1.3),
        (AlphaParameters::newmark_average_acceleration(), 1.0),
    ];
    for (p, rho) in cases {
        let mut sys = Linear { m: vec![1.0], k: DMatrix::from_element(1, 1, w * w), c: DMatrix::zeros(1, 1) };
        let mut int = ga(GeneralizedAlphaSettings::new(p));
        int.init(&mut sys, 0.0, &[1.0], &[0.0]).unwrap();
        let norm = |int: &GeneralizedAlpha| (w * int.q()[0]).hypot(int.v()[0]);
        let mut amps = Vec::new();
        for k in 1..=400u64 {
            int.advance(&mut sys, k as f64, 1).unwrap();
            if k == 200 || k == 400 {
                amps.push(norm(&int));
            }
        }
        let measured = (amps[1] / amps[0]).powf(1.0 / 200.0);
        assert!((measured / rho - 1.0).abs() < 0.01, "{p:?}: measured {measured}, expected {rho}");
    }
}

// ---------------------------------------------------------------------------------------------
// 3. Piecewise-linear gap oscillator
// ---------------------------------------------------------------------------------------------

const GAP_T_END: f64 = 3.3;
const GAP_X0: f64 = 0.0;
const GAP_V0: f64 = 2.0 * PI;

/// Dormand–Prince with event location reproduces the stitched closed-form solution to 1e-8
/// relative, locates every contact switch once and at the exact time.
#[test]
fn rk45_gap_oscillator_matches_stitched_solution() {
    let sys0 = Gap::standard();
    let ((xe, ve), switches) = sys0.exact(GAP_X0, GAP_V0, GAP_T_END);
    assert!(switches.len() >= 4, "switches {switches:?}");
    let mut sys = sys0.clone();
    let settings =
        Rk45Settings { rtol: 1e-11, atol_q: 1e-13, atol_v: 1e-12, record_events: true, ..Default::default() };
    let mut int = rk(settings);
    int.init(&mut sys, 0.0, &[GAP_X0], &[GAP_V0]).unwrap();
    int.advance_to(&mut sys, GAP_T_END).unwrap();
    let ex = (int.q()[0] - xe).abs() / 1.0;
    let ev = (int.v()[0] - ve).abs() / GAP_V0;
    assert!(ex < 1e-8 && ev < 1e-8, "relative errors x {ex}, v {ev}");
    assert_eq!(int.stats().events_located, switches.len() as u64);
    let events = int.located_events();
    assert_eq!(events.len(), switches.len());
    for (k, (e, ts)) in events.iter().zip(&switches).enumerate() {
        assert!((e.t - ts).abs() < 1e-8, "switch {k}: located {}, exact {ts}", e.t);
        assert_eq!(e.rising, k % 2 == 0, "switch {k} direction");
        assert_eq!(e.index, 0);
    }
    // Steps that straddle a switch are what the error test rejects; with the switches located (and
    // rejected steps re-aimed at them) far fewer steps are rejected than without event functions.
    struct Blind(Gap);
    impl SecondOrderSystem for Blind {
        fn dim(&self) -> usize {
            1
        }

        fn mass(&self) -> &[f64] {
            &self.0.m
        }

        fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
            self.0.force(t, q, v, f);
        }
    }

    impl TangentSystem for Blind {
        fn jacobian(&mut self, t: f64, q: &[f64], v: &[f64], k: &mut DMatrix<f64>, c: &mut DMatrix<f64>) {
            self.0.jacobian(t, q, v, k, c);
        }
    }
    let mut blind = Blind(sys0.clone());
    let mut plain = rk(settings);
    plain.init(&mut blind, 0.0, &[GAP_X0], &[GAP_V0]).unwrap();
    plain.advance_to(&mut blind, GAP_T_END).unwrap();
    assert!(
        2 * int.stats().rejected_steps < plain.stats().rejected_steps,
        "rejected with events {}, without {}",
        int.stats().rejected_steps,
        plain.stats().rejected_steps
    );
}

/// x'' = −a where x > 0 and +b where x ≤ 0 (unit mass): the force jumps by a + b where x crosses
/// 0, as a Rayleigh damping force η K δ̇ does where a tooth pair enters contact. From x = 1 at rest
/// the motion is parabolic arcs: x reaches 0 after √(2/a) at −√(2a), returns after 2√(2a)/b and
/// is back at 1, at rest, after the period T = 2√(2/a) + 2√(2a)/b.
struct Bang {
    m: [f64; 1],
    a: f64,
    b: f64,
}

impl SecondOrderSystem for Bang {
    fn dim(&self) -> usize {
        1
    }

    fn mass(&self) -> &[f64] {
        &self.m
    }

    fn force(&mut self, _t: f64, q: &[f64], _v: &[f64], f: &mut [f64]) {
        f[0] = if q[0] > 0.0 { -self.a } else { self.b };
    }

    fn events(&mut self, _t: f64, q: &[f64], _v: &[f64], out: &mut Vec<f64>) {
        out.push(q[0]);
    }
}

/// A force that jumps at a located switch: the error after five periods (back at (1, 0) exactly)
/// falls with the tolerance down to 1e-13 with switches hopped, every crossing located once. The
/// retaken step that
/// lands on a crossing's far side takes its last stages past the jump, an error of order
/// h · jump that the embedded estimate sees about eight times smaller, so the global error is
/// 500 to 5000 times the tolerance here (measured), not the few times of a smooth force.
#[test]
fn rk45_force_jump_at_a_switch_converges_with_the_tolerance() {
    let (a, b): (f64, f64) = (3.0, 5.0);
    let period = 2.0 * (2.0 / a).sqrt() + 2.0 * (2.0 * a).sqrt() / b;
    let mut last = f64::INFINITY;
    for rtol in [1e-6, 1e-8, 1e-10, 1e-13] {
        let mut sys = Bang { m: [1.0], a, b };
        let settings = Rk45Settings {
            rtol,
            atol_q: rtol * 1e-2,
            atol_v: rtol * 1e-2,
            hop_switches: true,
            ..Default::default()
        };
        let mut int = rk(settings);
        int.init(&mut sys, 0.0, &[1.0], &[0.0]).unwrap();
        int.advance_to(&mut sys, 5.0 * period).unwrap_or_else(|e| panic!("rtol {rtol}: {e}"));
        let error = (int.q()[0] - 1.0).abs().max(int.v()[0].abs() / (2.0 * a).sqrt());
        assert!(error < 1e4 * rtol, "rtol {rtol}: error {error}");
        assert!(error < 0.1 * last, "rtol {rtol}: error {error} after {last}");
        last = error;
        assert_eq!(int.stats().events_located, 10, "rtol {rtol}");
    }
}

/// The event count is independent of how `advance_to` is chunked, and dense output between calls
/// stays consistent.
#[test]
fn rk45_gap_events_independent_of_output_grid() {
    let sys0 = Gap::standard();
    let (_, switches) = sys0.exact(GAP_X0, GAP_V0, GAP_T_END);
    let mut sys = sys0.clone();
    let mut int = rk(Rk45Settings { rtol: 1e-9, atol_q: 1e-12, atol_v: 1e-12, ..Default::default() });
    int.init(&mut sys, 0.0, &[GAP_X0], &[GAP_V0]).unwrap();
    for k in 1..=330 {
        let t = if k == 330 { GAP_T_END } else { k as f64 * 0.01 };
        int.advance_to(&mut sys, t).unwrap();
        assert_eq!(int.time(), t);
    }
    assert_eq!(int.stats().events_located, switches.len() as u64);
}

/// One `step` at a time takes the same steps as `advance_to` (bit-identical state, events and work),
/// and the dense output of each step reaches back to the previous step's end.
#[test]
fn rk45_single_steps_equal_advance_to() {
    let sys0 = Gap::standard();
    let settings = Rk45Settings { rtol: 1e-8, atol_q: 1e-12, atol_v: 1e-12, ..Default::default() };
    let mut whole_sys = sys0.clone();
    let mut whole = rk(settings);
    whole.init(&mut whole_sys, 0.0, &[GAP_X0], &[GAP_V0]).unwrap();
    whole.advance_to(&mut whole_sys, GAP_T_END).unwrap();
    let mut sys = sys0.clone();
    let mut single = rk(settings);
    single.init(&mut sys, 0.0, &[GAP_X0], &[GAP_V0]).unwrap();
    let mut calls = 0u64;
    let (mut q, mut v) = ([0.0], [0.0]);
    while single.time() < GAP_T_END {
        let before = single.time();
        single.step(&mut sys, GAP_T_END).unwrap();
        calls += 1;
        let (t0, t1) = single.last_step().unwrap();
        assert_eq!((t0, t1), (before, single.time()), "one accepted step per call");
        single.dense_at(t0, &mut q, &mut v).unwrap();
    }
    assert_eq!(calls, whole.stats().steps);
    assert_eq!(single.q(), whole.q());
    assert_eq!(single.v(), whole.v());
    assert_eq!(single.stats(), whole.stats());
    assert!(whole.stats().events_located >= 4);
    // At t_max a step does nothing.
    single.step(&mut sys, GAP_T_END).unwrap();
    assert_eq!(single.stats(), whole.stats());
}

/// Generalized-α converges to the stitched solution of the gap oscillator with order at least 1.
#[test]
fn ga_gap_oscillator_converges() {
    let sys0 = Gap::standard();
    let ((xe, ve), _) = sys0.exact(GAP_X0, GAP_V0, GAP_T_END);
    let w1 = sys0.k1.sqrt();
    let mut errors = Vec::new();
    for steps in [4000u64, 8000, 16000] {
        let mut sys = sys0.clone();
        let mut int = ga(GeneralizedAlphaSettings::chung_hulbert(0.9).unwrap());
        int.init(&mut sys, 0.0, &[GAP_X0], &[GAP_V0]).unwrap();
        int.advance(&mut sys, GAP_T_END, steps).unwrap();
        errors.push(((int.q()[0] - xe).powi(2) + ((int.v()[0] - ve) / w1).powi(2)).sqrt());
    }
    for w in errors.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!(order >= 1.0, "errors {errors:?}, observed order {order}");
    }
    assert!(errors[2] < 1e-4, "errors {errors:?}");
}

// ---------------------------------------------------------------------------------------------
// 4. Failure handling
// ---------------------------------------------------------------------------------------------

fn cubic() -> Cubic {
    // Static deflection ≈ (F0/k3)^(1/3) = 0.01 m, tangent frequency there ≈ 1.7e3 rad/s,
    // damping near critical.
    Cubic { m: [1.0], c: 3500.0, k: 1e4, k3: 1e10, f0: 1e4 }
}

/// A sudden load on a very stiff cubic spring makes Newton fail on the coarse step (ω h ≈ 17, a
/// predictor 25 times the answer); the step is halved, and the run still matches a tight
/// Dormand–Prince reference. Without halving room the same run fails with `NewtonDiverged`.
#[test]
fn ga_newton_failure_halves_step_and_matches_reference() {
    let t_end = 1.0;
    let mut sys = cubic();
    let mut reference = rk(Rk45Settings { rtol: 1e-11, atol_q: 1e-15, atol_v: 1e-13, ..Default::default() });
    reference.init(&mut sys, 0.0, &[0.0], &[0.0]).unwrap();
    reference.advance_to(&mut sys, t_end).unwrap();
    let x_ref = reference.q()[0];

    let settings = GeneralizedAlphaSettings {
        max_iterations: 6,
        ..GeneralizedAlphaSettings::chung_hulbert(0.8).unwrap()
    };
    let mut int = ga(settings);
    int.init(&mut sys, 0.0, &[0.0], &[0.0]).unwrap();
    int.advance(&mut sys, t_end, 100).unwrap();
    assert_eq!(int.time(), t_end);
    assert!(int.stats().rejected_steps > 0, "{:?}", int.stats());
    assert!(int.stats().steps > 100, "{:?}", int.stats());
    let rel = (int.q()[0] - x_ref).abs() / x_ref.abs();
    assert!(rel < 1e-4, "x = {}, reference {x_ref}, relative error {rel}", int.q()[0]);

    let mut strict = ga(GeneralizedAlphaSettings { min_step: 0.01, ..settings });
    strict.init(&mut sys, 0.0, &[0.0], &[0.0]).unwrap();
    let r = strict.advance(&mut sys, t_end, 100);
    match r {
        Err(SolverError::NewtonDiverged { t, step, iterations }) => {
            assert_eq!(t, 0.0);
            assert_eq!(step, 0.01);
            assert_eq!(iterations, 6);
        }
        other => panic!("expected NewtonDiverged, got {other:?}"),
    }
    assert_eq!(strict.time(), 0.0);
}

/// A force that turns non-finite makes both integrators return an error naming the time, and
/// leaves them at the last finite state.
#[test]
fn non_finite_force_is_an_error_not_nan() {
    let mut sys = NanAfter { m: [1.0], t_bad: 0.5 };
    let mut int = ga(GeneralizedAlphaSettings::default());
    int.init(&mut sys, 0.0, &[1.0], &[0.0]).unwrap();
    match int.advance(&mut sys, 1.0, 100) {
        Err(SolverError::NonFiniteForce { t, index }) => {
            assert!(t > 0.5 && t <= 0.51, "t = {t}");
            assert_eq!(index, 0);
        }
        other => panic!("expected NonFiniteForce, got {other:?}"),
    }
    assert_eq!(int.time(), 0.5);
    assert!((int.q()[0] - 0.5f64.cos()).abs() < 1e-4 && int.q()[0].is_finite());

    let mut rk = rk(Rk45Settings::default());
    rk.init(&mut sys, 0.0, &[1.0], &[0.0]).unwrap();
    match rk.advance_to(&mut sys, 1.0) {
        Err(SolverError::NonFiniteForce { t, index }) => {
            assert!(t > 0.5 && t < 0.6, "t = {t}");
            assert_eq!(index, 0);
        }
        other => panic!("expected NonFiniteForce, got {other:?}"),
    }
    assert!(rk.time() <= 0.5 && rk.time() > 0.4, "t = {}", rk.time());
    assert!((rk.q()[0] - rk.time().cos()).abs() < 1e-6);
}

/// Invalid settings and arguments are errors, not panics.
#[test]
fn invalid_input_is_rejected() {
    assert!(matches!(
        AlphaParameters::chung_hulbert(1.5),
        Err(SolverError::InvalidSetting { name: "rho_inf", .. })
    ));
    assert!(matches!(AlphaParameters::chung_hulbert(f64::NAN), Err(SolverError::InvalidSetting { .. })));
    assert!(matches!(AlphaParameters::hht(0.5), Err(SolverError::InvalidSetting { name: "alpha", .. })));
    assert!(matches!(
        AlphaParameters::newmark(0.5, -0.1),
        Err(SolverError::InvalidSetting { name: "beta", .. })
    ));
    let bad = GeneralizedAlphaSettings { min_step: 0.0, ..Default::default() };
    assert!(matches!(GeneralizedAlpha::new(bad), Err(SolverError::InvalidSetting { name: "min_step", .. })));
    assert!(matches!(
        Rk45::new(Rk45Settings { rtol: -1.0, ..Default::default() }),
        Err(SolverError::InvalidSetting { name: "rtol", .. })
    ));

    let mut sys = Forced::standard();
    let mut int = ga(GeneralizedAlphaSettings::default());
    assert_eq!(int.advance(&mut sys, 1.0, 10), Err(SolverError::NotInitialized));
    assert!(matches!(
        int.init(&mut sys, 0.0, &[0.0, 1.0], &[0.0]),
        Err(SolverError::DimensionMismatch { name: "q", expected: 1, found: 2 })
    ));
    assert!(matches!(int.init(&mut sys, 0.0, &[f64::NAN], &[0.0]), Err(SolverError::NonFiniteState { .. })));
    int.init(&mut sys, 1.0, &[0.0], &[0.0]).unwrap();
    assert!(matches!(
        int.advance(&mut sys, 0.5, 10),
        Err(SolverError::InvalidArgument { name: "t_end", .. })
    ));
    assert!(matches!(int.advance(&mut sys, 2.0, 0), Err(SolverError::InvalidArgument { name: "steps", .. })));
    assert_eq!(int.advance(&mut sys, 1.0, 0), Ok(()));

    let mut bad_mass = Forced { m: [0.0], ..Forced::standard() };
    assert!(matches!(
        int.init(&mut bad_mass, 0.0, &[0.0], &[0.0]),
        Err(SolverError::InvalidMass { index: 0, .. })
    ));

    let mut r = rk(Rk45Settings::default());
    assert_eq!(r.advance_to(&mut sys, 1.0), Err(SolverError::NotInitialized));
    r.init(&mut sys, 0.0, &[0.0], &[0.0]).unwrap();
    assert!(matches!(r.advance_to(&mut sys, -1.0), Err(SolverError::InvalidArgument { .. })));
}

// ---------------------------------------------------------------------------------------------
// 5. Time from integer step counts
// ---------------------------------------------------------------------------------------------

/// After 10⁶ tiny steps the time equals t_end bitwise, where accumulating h would not.
#[test]
fn ga_time_after_a_million_steps_is_exact() {
    let (t0, t_end, steps) = (0.1, 0.3, 1_000_000u64);
    let h = (t_end - t0) / steps as f64;
    let mut naive = t0;
    for _ in 0..steps {
        naive += h;
    }
    assert_ne!(naive, t_end, "the control case must show drift");
    let mut sys = Forced::standard();
    let mut int = ga(GeneralizedAlphaSettings::default());
    int.init(&mut sys, t0, &[0.1], &[0.0]).unwrap();
    int.advance(&mut sys, t_end, steps).unwrap();
    assert_eq!(int.time().to_bits(), t_end.to_bits());
    assert_eq!(int.stats().steps, steps);
    assert_eq!(int.stats().rejected_steps, 0);
}

/// The k-th step ends at t0 + (t_end − t0)·k/steps exactly, with the last one at t_end.
#[test]
fn ga_step_times_follow_the_integer_formula() {
    let (t0, t_end, steps) = (0.1, 1.3, 7u64);
    let mut sys = Recorder { m: [1.0], times: Vec::new() };
    let mut int = ga(GeneralizedAlphaSettings::default());
    int.init(&mut sys, t0, &[1.0], &[0.0]).unwrap();
    sys.times.clear();
    int.advance(&mut sys, t_end, steps).unwrap();
    let expected: Vec<f64> = (1..=steps)
        .map(|k| if k == steps { t_end } else { t0 + (t_end - t0) * k as f64 / steps as f64 })
        .collect();
    let mut distinct = sys.times.clone();
    distinct.dedup();
    assert_eq!(distinct, expected);
    assert_eq!(int.time(), t_end);
}

/// The work counters count and reset.
#[test]
fn stats_count_and_reset() {
    let mut sys = Forced::standard();
    let mut int = ga(GeneralizedAlphaSettings::default());
    int.init(&mut sys, 0.0, &[0.1], &[0.0]).unwrap();
    int.advance(&mut sys, 1.0, 50).unwrap();
    let s = *int.stats();
    assert_eq!(s.steps, 50);
    // A linear system converges after one correction: two force evaluations per step.
    assert_eq!(s.newton_iterations, 50);
    assert_eq!(s.jacobian_evaluations, 50);
    assert_eq!(s.lu_factorizations, 50);
    assert_eq!(s.rhs_evaluations, 1 + 100);
    int.reset_stats();
    assert_eq!(*int.stats(), Default::default());

    let mut r = rk(Rk45Settings::default());
    r.init(&mut sys, 0.0, &[0.1], &[0.0]).unwrap();
    r.advance_to(&mut sys, 1.0).unwrap();
    let s = *r.stats();
    // One evaluation at init, one for the starting step size, six per attempted step (FSAL).
    assert_eq!(s.rhs_evaluations, 2 + 6 * (s.steps + s.rejected_steps));
}

/// Two identical, uncoupled gap oscillators switch at the same instants (like in-phase planets):
/// every crossing of both event functions is located and counted once, at the exact time.
#[test]
fn rk45_simultaneous_events_are_all_counted() {
    struct Twin(Gap, [f64; 2]);
    impl SecondOrderSystem for Twin {
        fn dim(&self) -> usize {
            2
        }

        fn mass(&self) -> &[f64] {
            &self.1
        }

        fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
            for i in 0..2 {
                self.0.force(t, &q[i..=i], &v[i..=i], &mut f[i..=i]);
            }
        }

        fn events(&mut self, _t: f64, q: &[f64], _v: &[f64], out: &mut Vec<f64>) {
            out.extend(q.iter().map(|x| x - self.0.g));
        }
    }

    impl TangentSystem for Twin {
        fn jacobian(&mut self, _t: f64, q: &[f64], _v: &[f64], k: &mut DMatrix<f64>, c: &mut DMatrix<f64>) {
            for i in 0..2 {
                k[(i, i)] = self.0.k1 + if q[i] > self.0.g { self.0.k2 } else { 0.0 };
                c[(i, i)] = self.0.c;
            }
        }
    }
    let gap = Gap::standard();
    let ((xe, _), switches) = gap.exact(GAP_X0, GAP_V0, GAP_T_END);
    let mut sys = Twin(gap, [1.0, 1.0]);
    let settings =
        Rk45Settings { rtol: 1e-11, atol_q: 1e-13, atol_v: 1e-12, record_events: true, ..Default::default() };
    let mut int = rk(settings);
    int.init(&mut sys, 0.0, &[GAP_X0; 2], &[GAP_V0; 2]).unwrap();
    int.advance_to(&mut sys, GAP_T_END).unwrap();
    assert_eq!(int.stats().events_located, 2 * switches.len() as u64);
    let events = int.take_located_events();
    for (k, pair) in events.chunks(2).enumerate() {
        let mut idx = [pair[0].index, pair[1].index];
        idx.sort_unstable();
        assert_eq!(idx, [0, 1], "switch {k}");
        for e in pair {
            assert!((e.t - switches[k]).abs() < 1e-8, "switch {k}: {} vs {}", e.t, switches[k]);
        }
    }
    assert!(int.located_events().is_empty());
    assert!((int.q()[0] - xe).abs() < 1e-8 && int.q()[0] == int.q()[1]);
}

/// A system without degrees of freedom is integrated trivially by both integrators.
#[test]
fn zero_dimensional_system_is_harmless() {
    struct Empty;
    impl SecondOrderSystem for Empty {
        fn dim(&self) -> usize {
            0
        }

        fn mass(&self) -> &[f64] {
            &[]
        }

        fn force(&mut self, _t: f64, _q: &[f64], _v: &[f64], _f: &mut [f64]) {}
    }

    impl TangentSystem for Empty {
        fn jacobian(
            &mut self,
            _t: f64,
            _q: &[f64],
            _v: &[f64],
            _k: &mut DMatrix<f64>,
            _c: &mut DMatrix<f64>,
        ) {
        }
    }
    let mut int = ga(GeneralizedAlphaSettings::default());
    int.init(&mut Empty, 0.0, &[], &[]).unwrap();
    int.advance(&mut Empty, 1.0, 10).unwrap();
    assert_eq!(int.time(), 1.0);
    let mut r = rk(Rk45Settings::default());
    r.init(&mut Empty, 0.0, &[], &[]).unwrap();
    r.advance_to(&mut Empty, 1.0).unwrap();
    assert_eq!(r.time(), 1.0);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// For any start, span and step count the generalized-α run ends on t_end bitwise after exactly
    /// `steps` steps, and the Dormand–Prince run lands on t_end bitwise.
    #[test]
    fn both_integrators_land_exactly_on_t_end(t0 in -1e3f64..1e3, span in 1e-3f64..1e2, steps in 1u64..3000) {
        let t_end = t0 + span;
        let mut sys = Forced::standard();
        let mut int = ga(GeneralizedAlphaSettings::default());
        int.init(&mut sys, t0, &[0.1], &[0.0]).unwrap();
        int.advance(&mut sys, t_end, steps).unwrap();
        proptest::prop_assert_eq!(int.time().to_bits(), t_end.to_bits());
        proptest::prop_assert_eq!(int.stats().steps, steps);
        let mut r = rk(Rk45Settings { rtol: 1e-6, atol_q: 1e-9, atol_v: 1e-9, ..Default::default() });
        r.init(&mut sys, t0, &[0.1], &[0.0]).unwrap();
        r.advance_to(&mut sys, t0 + 0.5 * span.min(2.0)).unwrap();
        proptest::prop_assert_eq!(r.time().to_bits(), (t0 + 0.5 * span.min(2.0)).to_bits());
    }
}

/// A unit oscillator against a damped stop at x = g: the stop's damping force c₂·v switches on
/// with the contact, so the force jumps at the event (as a mesh's damping does when the mesh
/// loses or regains its last tooth pair).
struct DampedStop {
    m: [f64; 1],
    k1: f64,
    k2: f64,
    c2: f64,
    g: f64,
}

impl SecondOrderSystem for DampedStop {
    fn dim(&self) -> usize {
        1
    }

    fn mass(&self) -> &[f64] {
        &self.m
    }

    fn force(&mut self, _t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        let contact = q[0] > self.g;
        f[0] = -self.k1 * q[0] - if contact { self.k2 * (q[0] - self.g) + self.c2 * v[0] } else { 0.0 };
    }

    fn events(&mut self, _t: f64, q: &[f64], _v: &[f64], out: &mut Vec<f64>) {
        out.push(q[0] - self.g);
    }
}

/// Intervals that end just past a located event where the force jumps: the retake that lands
/// on the event may fail the error test while the step across it passes, and the integrator
/// must then shorten the step instead of alternating between the two for ever (a mesh losing
/// contact near the end of an excitation period hung the sweep in the rigid-body frame this
/// way; before the mend the first of these intervals to do so was rtol 1e-4, v0 = 0.6·2π, just
/// past the first event). Every end time from
/// 1e-14 to 1e-2 of the event's time past each of the first four events is reached in fewer
/// than 1000 attempted steps.
#[test]
fn rk45_ends_just_past_a_force_jump_without_cycling() {
    let k1 = (2.0 * PI).powi(2);
    let stop = DampedStop { m: [1.0], k1, k2: 3.0 * k1, c2: 5.0, g: 0.5 };
    for rtol in [1e-4, 1e-6] {
        let settings = Rk45Settings {
            rtol,
            atol_q: 1e-3 * rtol,
            atol_v: 1e-3 * rtol,
            record_events: true,
            max_steps: 20_000,
            ..Default::default()
        };
        for speed in 6..=10 {
            let v0 = 2.0 * PI * 0.1 * f64::from(speed);
            let mut sys = DampedStop { ..stop };
            let mut probe = rk(settings);
            probe.init(&mut sys, 0.0, &[0.0], &[v0]).unwrap();
            probe.advance_to(&mut sys, 2.0).unwrap();
            let events: Vec<f64> = probe.located_events().iter().take(4).map(|e| e.t).collect();
            assert_eq!(events.len(), 4, "the stop is touched and left twice");
            for t_event in events {
                for j in 0..=48 {
                    let t_end = t_event * (1.0 + 10f64.powf(-14.0 + f64::from(j) / 4.0));
                    let mut sys = DampedStop { ..stop };
                    let mut int = rk(settings);
                    int.init(&mut sys, 0.0, &[0.0], &[v0]).unwrap();
                    if let Err(e) = int.advance_to(&mut sys, t_end) {
                        panic!("rtol {rtol:e}, v0 {v0}, end {t_end:e} (event at {t_event:e}): {e}");
                    }
                    let attempts = int.stats().steps + int.stats().rejected_steps;
                    assert!(attempts < 1000, "rtol {rtol:e}, v0 {v0}, end {t_end:e}: {:?}", int.stats());
                    assert_eq!(int.time(), t_end);
                }
            }
        }
    }
}
