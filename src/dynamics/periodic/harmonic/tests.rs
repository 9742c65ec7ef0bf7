//! The balance's unit tests: the harmonics rule, the projection, the
//! Jacobian against differences of the residual, Newton's stopping rule, the
//! multipliers from the solve's crossings, the operator against the dense
//! Jacobian, synthesis and analysis.

use super::jacobian::{newton_remainder, project, Jacobian};
use super::*;
use crate::contact::ltca::SetModel;
use crate::dynamics::periodic::ShootingSettings;
use crate::dynamics::periodic::{max_abs, Multiplier};
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
    balance_of(Scene::example_2004(), harmonics, samples, rpm)
}

/// [`balance`] on a given scene (torsional).
fn balance_of(mut scene: Scene, harmonics: usize, samples: usize, rpm: f64) -> (HarmonicBalance, f64) {
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
    jacobian_is_the_derivative(balance(8, 128, 3000.0));
}

/// The same under Rayleigh damping (the example on its derived planet
/// bearings): the tangent carries the damping force's change with the
/// approach and the position, η δ̇ ∂K_t/∂δ and η δ̇ ∂K_t/∂s (without them
/// the product was off by 2.4e-5 of its size).
#[test]
fn the_jacobian_is_the_derivative_of_the_residual_under_rayleigh_damping() {
    jacobian_is_the_derivative(balance_of(Scene::example_2004(), 8, 128, 3000.0));
}

/// Central differences along three directions agree with the Jacobian's
/// product to 1e-6 of the product.
fn jacobian_is_the_derivative((mut hb, omega): (HarmonicBalance, f64)) {
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
    assert!(with < 0.6 * without, "median difference {with:.2e} with the time terms, {without:.2e} without");
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

/// An orbit of `m` coordinates whose harmonic k has amplitude `amplitude(k)` in each.
fn orbit_with(h: usize, m: usize, amplitude: impl Fn(usize) -> f64) -> HarmonicOrbit {
    let mut coefficients = vec![0.0; m * (2 * h + 1)];
    for k in 1..=h {
        for c in 0..m {
            // Split between cosine and sine: the share reads the amplitude.
            coefficients[(2 * k - 1) * m + c] = 0.6 * amplitude(k);
            coefficients[2 * k * m + c] = 0.8 * amplitude(k);
        }
    }
    coefficients[0] = 5.0;
    HarmonicOrbit::of_coefficients(100.0, (1e-3, 1), h, coefficients)
}

/// The band share is the root-sum-square of the band's amplitudes over that of all of them
/// (the mean left out): with amplitudes 2^-k, harmonics 3 and 4 of 1..=4 hold
/// sqrt((4^-3 + 4^-4) / Σ 4^-k). The count doubles where the top quarter holds more than
/// SPECTRAL_TAIL, halves where the quarter below H/2 holds less than half of it, and stays
/// in between.
#[test]
fn the_spectrum_asks_for_harmonics_by_its_top_quarter() {
    let orbit = orbit_with(4, 3, |k| 0.5_f64.powi(k as i32));
    let all: f64 = (1..=4).map(|k| 0.25_f64.powi(k)).sum();
    let expected = ((0.25_f64.powi(3) + 0.25_f64.powi(4)) / all).sqrt();
    assert!((orbit.band_share(2, 4) - expected).abs() < 1e-14, "{}", orbit.band_share(2, 4));
    assert!((orbit.band_share(0, 4) - 1.0).abs() < 1e-14);
    // Geometric decay by r per harmonic: the top quarter of 64 holds about r^48 of the whole.
    let h = 64;
    let asked = |r: f64| orbit_with(h, 2, |k| r.powi(k as i32)).spectral_harmonics();
    let share = |r: f64| orbit_with(h, 2, |k| r.powi(k as i32)).band_share(3 * h / 4, h);
    assert!(share(0.9) > SPECTRAL_TAIL && asked(0.9) == 2 * h, "{}", share(0.9));
    assert!(share(0.5) < 0.5 * SPECTRAL_TAIL && asked(0.5) == h / 2);
    // Between: the top quarter within the tail, the quarter below H/2 not within half of it.
    let r = 0.8;
    assert!(share(r) <= SPECTRAL_TAIL, "{}", share(r));
    assert!(orbit_with(h, 2, |k| r.powi(k as i32)).band_share(3 * h / 8, h / 2) >= 0.5 * SPECTRAL_TAIL);
    assert_eq!(asked(r), h);
    // Never below MIN_HARMONICS.
    assert_eq!(orbit_with(MIN_HARMONICS, 2, |k| 0.1_f64.powi(k as i32)).spectral_harmonics(), MIN_HARMONICS);
}
