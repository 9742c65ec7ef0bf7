//! Stability on stiff and extreme cases (issue 6): each case asserts that the
//! response is finite and bounded and, where a reference exists, that it
//! converges under refinement or obeys a law; impossible requests end in a
//! clear error, never in NaN or a hang.
//!
//! The cases run on the uncalibrated reading of the example
//! (`Scene::example_2004_annulus`), whose figures they pin; the calibrated
//! example's own laws and figures: tests/calibrated_example.rs.

use planetwear::contact::ltca::SetModel;
use planetwear::contact::separation::MeshFlanks;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::{static_state, steady_state, SteadyState};
use planetwear::dynamics::simulation::Simulation;
use planetwear::dynamics::solver::{
    GeneralizedAlpha, GeneralizedAlphaSettings, Rk45, Rk45Settings, SecondOrderSystem,
};
use planetwear::geometry::profile::ProfileDeviation;
use planetwear::model::gear::{GearSet, Member, MeshKind};
use planetwear::model::run::RunSettings;
use planetwear::scene::{Fidelity, IntegratorKind, Scene};

const RPM: f64 = std::f64::consts::PI / 30.0;

fn build(scene: &Scene) -> (GearSet, RunSettings, PlanetaryDynamics) {
    let (set, run) = scene.validate_with_run().unwrap_or_else(|e| panic!("{e}"));
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    (set, run, model)
}

/// Largest |mesh force| over the window [N].
fn peak(r: &SteadyState) -> f64 {
    r.mesh_force.iter().flatten().fold(0.0f64, |m, f| m.max(f.abs()))
}

fn finite(r: &SteadyState) -> bool {
    r.mesh_force.iter().flatten().all(|f| f.is_finite())
        && r.end.q.iter().chain(&r.end.v).all(|x| x.is_finite())
}

/// Largest difference of the harmonics 1..6 of every mesh between two runs,
/// relative to the largest first harmonic.
fn harmonic_difference(a: &SteadyState, b: &SteadyState) -> f64 {
    let scale = a.meshes.iter().map(|m| m.harmonics.amplitude[0]).fold(0.0f64, f64::max);
    let mut worst: f64 = 0.0;
    for (ma, mb) in a.meshes.iter().zip(&b.meshes) {
        for (x, y) in ma.harmonics.amplitude.iter().zip(&mb.harmonics.amplitude) {
            worst = worst.max((x - y).abs());
        }
    }
    worst / scale
}

/// Steady states by generalized-α at 120, 240 and 480 steps per mesh cycle; returns the
/// differences 120→240 and 240→480 (E_h form) and the finest run.
fn refine(scene: &Scene, rpm: f64) -> (f64, f64, SteadyState) {
    let mut runs = Vec::new();
    for steps in [120, 240, 480] {
        let mut s = scene.clone();
        // Refinement of the fixed-step method (the adaptive default refines by tolerance).
        s.dynamics.integrator = IntegratorKind::GeneralizedAlpha;
        s.dynamics.steps_per_mesh_cycle = steps;
        let (set, run, mut model) = build(&s);
        let r =
            steady_state(&mut model, &set, &run, rpm * RPM, None).unwrap_or_else(|e| panic!("{steps}: {e}"));
        assert!(finite(&r), "non-finite response at {steps} steps per mesh cycle");
        runs.push(r);
    }
    let d1 = harmonic_difference(&runs[0], &runs[1]);
    let d2 = harmonic_difference(&runs[1], &runs[2]);
    (d1, d2, runs.pop().unwrap())
}

#[test]
fn very_soft_planet_bearings_against_stiff_meshes_stay_finite_and_converge() {
    // Planet bearings 3e5 N/m, a thousandth of the default and 5000 times
    // softer than a mesh: widely separated time scales (the stiff case).
    let mut s = Scene::example_2004_annulus();
    s.supports.planet_bearing_n_per_m = 3.0e5;
    let (d1, d2, r) = refine(&s, 3000.0);
    eprintln!("soft planet bearings: E_h 120→240 {d1:.2e}, 240→480 {d2:.2e}, peak {:.0} N", peak(&r));
    assert!(d2 < d1 && d2 < 2e-2, "no convergence under refinement: {d1:e}, {d2:e}");
    let f0 = r.meshes[0].harmonics.mean;
    assert!(peak(&r) < 5.0 * f0, "peak {} against mean {f0}", peak(&r));
}

#[test]
fn thirty_thousand_rpm_stays_bounded_and_converges() {
    let (d1, d2, r) = refine(&Scene::example_2004_annulus(), 30000.0);
    eprintln!("30000 rpm: E_h 120→240 {d1:.2e}, 240→480 {d2:.2e}, peak {:.0} N", peak(&r));
    assert!(d2 < d1, "no convergence under refinement: {d1:e}, {d2:e}");
    let (set, _, _) = build(&Scene::example_2004_annulus());
    // The mean tooth force still balances the torque at 30 000 rpm.
    let f = set.mesh_load_per_planet();
    assert!((r.meshes[0].harmonics.mean / f - 1.0).abs() < 0.02, "{} vs {f}", r.meshes[0].harmonics.mean);
    assert!(peak(&r) < 10.0 * f);
}

#[test]
fn reversed_torque_loads_the_back_flanks_and_mirrors_the_mean_load() {
    let mut s = Scene::example_2004_annulus();
    s.operation.input_torque_nm = -750.0;
    let (set, run, mut model) = build(&s);
    let r = steady_state(&mut model, &set, &run, 3000.0 * RPM, None).unwrap();
    assert!(finite(&r));
    let f = 750.0 / (4.0 * set.sun().base_radius());
    for m in &r.meshes {
        assert!((m.harmonics.mean / -f - 1.0).abs() < 0.01, "mean {} against {}", m.harmonics.mean, -f);
    }
    assert!(
        r.mesh_force.iter().flatten().all(|x| *x <= 1e-9),
        "a drive flank carried load under reversed torque"
    );
}

#[test]
fn zero_torque_rattle_across_the_backlash_stays_bounded_and_loses_energy() {
    // No load, the sun kicked by 50 rad/s against the train: the teeth fly
    // across the backlash and hit drive and back flanks in turn.
    let mut s = Scene::example_2004_annulus();
    s.operation.input_torque_nm = 0.0;
    s.dynamics.fidelity = Fidelity::Torsional;
    let (set, _, mut model) = build(&s);
    let omega = 3000.0 * RPM;
    let start = static_state(&model, omega);
    let mut v = start.v.clone();
    v[model.input_index] += 50.0 * model.input_lever;
    let fm = model.mesh_frequency_per_input_speed * omega;
    let mut ga = GeneralizedAlpha::new(GeneralizedAlphaSettings::chung_hulbert(0.9).unwrap()).unwrap();
    ga.init(&mut model, 0.0, &start.q, &v).unwrap();
    let energy = |m: &PlanetaryDynamics, q: &[f64], v: &[f64]| {
        let rigid = m.rigid_velocity_at(omega);
        let (_, s, c, _) = m.energy(0.0, q, v);
        // Kinetic energy of the motion relative to the rigid-body rotation.
        let rel: f64 =
            m.mass().iter().zip(v).zip(&rigid).map(|((m, v), r)| 0.5 * m * (v - r) * (v - r)).sum();
        rel + s + c
    };
    let e0 = energy(&model, ga.q(), ga.v());
    let (mut drive, mut back, mut worst) = (0usize, 0usize, 0.0f64);
    let mut f = vec![0.0; model.dim()];
    for k in 1..=200u32 * 120 {
        ga.advance(&mut model, f64::from(k) / fm / 120.0, 1).unwrap();
        model.force(ga.time(), ga.q(), ga.v(), &mut f);
        for m in &model.meshes {
            assert!(m.force.is_finite());
            drive += usize::from(m.force > 0.0);
            back += usize::from(m.force < 0.0);
            worst = worst.max(m.force.abs());
        }
    }
    let e1 = energy(&model, ga.q(), ga.v());
    eprintln!("rattle: drive-flank {drive}, back-flank {back} mesh samples; energy {e0:.3e} → {e1:.3e} J");
    assert!(drive > 0 && back > 0, "no rattle: drive {drive}, back {back}");
    assert!(e1 < e0, "the damped rattle gained energy: {e0} → {e1}");
    let _ = set;
}

/// The torsional example without any physical damping (mesh and bearings)
/// at 3000 rpm, from the static state, integrated by generalized-α with
/// spectral radius `rho` at `steps` per mesh cycle over `cycles` mesh cycles.
/// Returns the largest tooth force over the mean tooth force, and the largest
/// and smallest energy-balance residual E − E0 − W (W: work of the external
/// torques and of the time-varying stiffness) over the largest contact energy.
fn undamped_run(rho: f64, steps: u64, cycles: u64) -> (f64, f64, f64) {
    let mut s = Scene::example_2004_annulus();
    s.dynamics.fidelity = Fidelity::Torsional;
    s.dynamics.mesh_damping_ratio = 0.0;
    s.supports.bearing_damping_ratio = 0.0;
    let (set, _, mut model) = build(&s);
    let omega = 3000.0 * RPM;
    let start = static_state(&model, omega);
    let fm = model.mesh_frequency_per_input_speed * omega;
    let mut settings = GeneralizedAlphaSettings::chung_hulbert(rho).unwrap();
    settings.rtol = 1e-13;
    settings.atol = 1e-14;
    let mut ga = GeneralizedAlpha::new(settings).unwrap();
    ga.init(&mut model, 0.0, &start.q, &start.v).unwrap();
    let h = 1.0 / fm / steps as f64;
    let energy = |m: &PlanetaryDynamics, t: f64, q: &[f64], v: &[f64]| {
        let (k, s, c, p) = m.energy(t, q, v);
        (k + s + c, p + m.external_power(v), c)
    };
    let (e0, mut p_prev, _) = energy(&model, 0.0, ga.q(), ga.v());
    let (mut work, mut gain, mut loss, mut scale, mut fmax) = (0.0, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut f = vec![0.0; model.dim()];
    for k in 1..=cycles * steps {
        let t = k as f64 * h;
        ga.advance(&mut model, t, 1).unwrap();
        let (e, p, c) = energy(&model, t, ga.q(), ga.v());
        work += 0.5 * h * (p + p_prev);
        p_prev = p;
        scale = scale.max(c);
        gain = gain.max(e - e0 - work);
        loss = loss.min(e - e0 - work);
        model.force(t, ga.q(), ga.v(), &mut f);
        fmax = fmax.max(model.meshes.iter().map(|m| m.force.abs()).fold(0.0, f64::max));
    }
    let f0 = set.mesh_load_per_planet();
    (fmax / f0, gain / scale, loss / scale)
}

#[test]
fn undamped_over_two_thousand_mesh_cycles_generalized_alpha_never_gains_energy_where_newmark_does() {
    // Without physical damping the teeth rattle: the initial transient never
    // decays and pairs separate and re-engage every cycle. An independent
    // reference (Dormand–Prince 5(4) with located contact events, rtol 1e-9)
    // keeps the largest tooth force between 1.6 and 3.3 times the mean over
    // the 2000 cycles (docs/ACCURACY.md).
    //
    // Generalized-α at the default ρ∞ = 0.9 and 120 steps per mesh cycle:
    // bounded (measured 2.60·F), and its energy balance shows no gain beyond
    // 1e-3 of the contact energy (measured 1.4e-4): its numerical dissipation
    // removes energy (the residual falls to −3.8 contact energies), never adds it.
    let (fmax, gain, loss) = undamped_run(0.9, 120, 2000);
    eprintln!("ρ∞ = 0.9, 120 steps: largest force {fmax:.2}·F, energy gain {gain:.1e}, loss {loss:.1e} of the contact energy");
    assert!(fmax < 3.5, "the force grew to {fmax}·F");
    assert!(gain < 1e-3, "numerical energy gain {gain} of the contact energy");
    // Newmark's average-acceleration rule (ρ∞ = 1, no numerical dissipation)
    // on the same case, even at 480 steps per mesh cycle: a contact switch
    // inside a step breaks the rule's energy conservation, and the energy
    // balance shows a gain the dissipative rule never shows (measured 1.6e-2
    // of the contact energy, 100 times generalized-α's). Asserted on the gain,
    // the law, not on the largest force: how far an undamped rattle grows is
    // chaotic (the same run reached 27.9·F and, after the ring fillet's fix
    // moved the ring tooth's stiffness by 0.07 %, 5.6·F).
    let (fmax_n, gain_n, _) = undamped_run(1.0, 480, 2000);
    eprintln!("ρ∞ = 1 (Newmark), 480 steps: largest force {fmax_n:.2}·F, energy gain {gain_n:.1e} of the contact energy");
    assert!(fmax_n.is_finite(), "Newmark's run diverged");
    assert!(gain_n > 1e-3, "Newmark gained no energy at the switches: {gain_n} of the contact energy");
    assert!(gain_n > 10.0 * gain, "Newmark's gain {gain_n} not above generalized-α's {gain}");
}

/// The undamped torsional case of [`undamped_run`] with the default
/// integrator (RK 5(4) at the scene's relative tolerance, configured as the
/// steady-state analysis configures it), sampled from its dense output at
/// `samples` points per mesh cycle (the work of the torques and of the
/// time-varying stiffness is the trapezoidal integral of the power over them).
/// Returns, at the end of each of `checkpoints` (mesh cycles, ascending), the
/// largest tooth force so far over the mean tooth force and the largest
/// |E − E0 − W| so far over the largest contact energy.
fn undamped_default_run(samples: u64, checkpoints: &[u64]) -> Vec<(f64, f64)> {
    let cycles = *checkpoints.last().unwrap();
    let mut s = Scene::example_2004_annulus();
    s.dynamics.fidelity = Fidelity::Torsional;
    s.dynamics.mesh_damping_ratio = 0.0;
    s.supports.bearing_damping_ratio = 0.0;
    let (set, run, mut model) = build(&s);
    assert_eq!(run.integrator(), IntegratorKind::Rk45);
    let omega = 3000.0 * RPM;
    let start = static_state(&model, omega);
    let period = 1.0 / (model.mesh_frequency_per_input_speed * omega);
    let rtol = run.relative_tolerance();
    let settings = Rk45Settings {
        rtol,
        atol_q: rtol * 1e-6,
        atol_v: rtol * 1e-3,
        max_step: period / 4.0,
        ..Rk45Settings::default()
    };
    let mut rk = Rk45::new(settings).unwrap();
    rk.init(&mut model, 0.0, &start.q, &start.v).unwrap();
    let energy = |m: &PlanetaryDynamics, t: f64, q: &[f64], v: &[f64]| {
        let (k, s, c, p) = m.energy(t, q, v);
        (k + s + c, p + m.external_power(v), c)
    };
    let (e0, mut p_prev, _) = energy(&model, 0.0, rk.q(), rk.v());
    let (mut work, mut worst, mut scale, mut fmax) = (0.0, 0.0f64, 0.0f64, 0.0f64);
    let n = model.dim();
    let (mut q, mut v, mut f) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let h = period / samples as f64;
    let t_end = (cycles * samples) as f64 * h;
    let mut out = Vec::new();
    for k in 1..=cycles * samples {
        let t = k as f64 * h;
        while rk.time() < t {
            rk.step(&mut model, t_end).unwrap();
        }
        rk.dense_at(t, &mut q, &mut v).unwrap();
        let (e, p, c) = energy(&model, t, &q, &v);
        work += 0.5 * h * (p + p_prev);
        p_prev = p;
        scale = scale.max(c);
        worst = worst.max((e - e0 - work).abs());
        model.force(t, &q, &v, &mut f);
        assert!(f.iter().all(|x| x.is_finite()), "non-finite force at t = {t}");
        fmax = fmax.max(model.meshes.iter().map(|m| m.force.abs()).fold(0.0, f64::max));
        if k % samples == 0 && checkpoints.contains(&(k / samples)) {
            out.push((fmax / set.mesh_load_per_planet(), worst / scale));
        }
    }
    out
}

#[test]
fn undamped_over_two_thousand_mesh_cycles_the_default_closes_the_energy_balance() {
    // The default integrator (explicit, not energy-conserving) is checked
    // against the energy balance E − E0 − W = 0, W the work of the torques
    // and of the time-varying stiffness, over the undamped rattle of the test
    // above. Over the first 200 mesh cycles it follows the reference: largest
    // tooth force within the reference's band (1.6 to 3.3 times the mean;
    // measured 2.45) and |E − E0 − W| below 3e-2 of the contact energy
    // (measured 1.9e-2, of which about 0.7e-2 is the trapezoidal quadrature
    // of W over 480 samples per cycle). Over 2000 cycles the balance still
    // closes to 1e-1 (measured 7.7e-3 of the largest contact energy), while
    // the largest force is chaotic: 6.3, 15.7 and 35.9 times the mean in runs
    // whose single trajectories differed by about 1e-7 (a change of the
    // rejected-step handling; the ring fillet's fix). With the balance closed
    // the energy of that growth is the work W the time-varying stiffness does
    // on the rattle; the integrator's error moves which chaotic trajectory is
    // followed, not the balance. So the 2000-cycle assertion is the balance,
    // and the force only has to stay finite. Long undamped runs
    // call for generalized-α (dissipative: it never gains energy) or a
    // tighter tolerance (docs/ACCURACY.md).
    let runs = undamped_default_run(480, &[200, 2000]);
    let ((f200, r200), (f2000, r2000)) = (runs[0], runs[1]);
    eprintln!("RK 5(4) default, undamped: 200 cycles: largest force {f200:.2}·F, |E − E0 − W| ≤ {r200:.2e}; 2000 cycles: {f2000:.2}·F, {r2000:.2e} of the contact energy");
    assert!((1.6..3.3).contains(&f200), "largest force {f200}·F in 200 cycles");
    assert!(r200 < 3e-2, "energy balance residual {r200} in 200 cycles");
    assert!(f2000.is_finite(), "largest force {f2000}·F in 2000 cycles");
    assert!(r2000 < 1e-1, "energy balance residual {r2000} in 2000 cycles");
}

#[test]
fn a_step_in_input_torque_settles_to_the_new_load() {
    let (set, run, model) = build(&Scene::example_2004_annulus());
    let omega = 3000.0 * RPM;
    let mut sim = Simulation::new(&set, &run, model, 0.0, omega).unwrap();
    let fm = sim_mesh_frequency(&set, omega);
    let h = 1.0 / fm;
    for _ in 0..10 {
        sim.do_step(sim.time(), h).unwrap();
    }
    // Double the torques on the sun and the (balancing) ring at once.
    let t = set.balanced_torques();
    sim.set_torques(2.0 * t[0], 2.0 * t[1], 2.0 * t[2]).unwrap();
    let f_new = 2.0 * set.mesh_load_per_planet();
    let mut peak: f64 = 0.0;
    let mut late = Vec::new();
    for cycle in 0..300 {
        for _ in 0..10 {
            sim.do_step(sim.time(), h / 10.0).unwrap();
            let f = sim.mesh_force(0, MeshKind::SunPlanet);
            assert!(f.is_finite());
            peak = peak.max(f);
            if cycle >= 200 {
                late.push(f);
            }
        }
    }
    let mean = late.iter().sum::<f64>() / late.len() as f64;
    eprintln!("torque step: peak {:.3}·F_new, mean after 200 cycles {:.4}·F_new", peak / f_new, mean / f_new);
    assert!((mean / f_new - 1.0).abs() < 0.02, "mean {mean} against {f_new}");
    // A linear step response overshoots by at most 100 %; the mesh excitation adds a little.
    assert!(peak < 2.3 * f_new, "peak {peak} against {f_new}");
    assert!((sim.speed(Member::Sun) / omega - 1.0).abs() < 0.01);
}

fn sim_mesh_frequency(set: &GearSet, omega: f64) -> f64 {
    f64::from(set.sun().teeth) * omega / (2.0 * std::f64::consts::PI)
}

#[test]
fn fifty_micrometres_of_wear_and_pairs_that_never_touch() {
    // The sun's dedendum worn 50 µm deep at the start of active profile,
    // tapering to nothing at the pitch point; the pairs in the deepest zone
    // never touch under the example's load, and the rest carry it.
    let (set0, run0, _) = build(&Scene::example_2004_annulus());
    let sp = SetModel::new(&set0);
    let path = sp.sun_planet.path().clone();
    let roll_start = path.start / set0.sun().base_radius();
    let roll_pitch = path.tangency_distance * set0.sun().base_radius()
        / (set0.sun().base_radius() + set0.planet().base_radius())
        / set0.sun().base_radius();
    let worn = ProfileDeviation::new(vec![roll_start, roll_pitch], vec![50e-6, 0.0]);
    let flanks = MeshFlanks { gear1_drive: worn, ..MeshFlanks::default() };
    let model_set = SetModel::with_flanks(&set0, &[flanks], &[MeshFlanks::default()]);
    // Static check: at the start of contact a pair under the full mesh load does not touch.
    let load = set0.mesh_load_per_planet();
    let (_, ks) =
        model_set.sun_planet.force(path.start, model_set.sun_planet.approach_for(path.start, load), None);
    assert!(ks > 0.0);
    let first_pair = model_set.sun_planet.pair_force(path.start + 1e-6, 20e-6);
    assert_eq!(first_pair, 0.0, "a pair 50 µm deep touched under 20 µm of approach");
    let mut model = PlanetaryDynamics::new(&set0, model_set).unwrap();
    let r = steady_state(&mut model, &set0, &run0, 3000.0 * RPM, None).unwrap();
    assert!(finite(&r));
    assert!((r.meshes[0].harmonics.mean / load - 1.0).abs() < 0.01);
    eprintln!(
        "50 µm wear: sun-mesh F(rms) {:.1} N (unworn example at 3000 rpm: see tests/dynamics.rs), peak {:.2}·F",
        r.meshes[0].harmonics.rms,
        peak(&r) / load
    );
    assert!(peak(&r) < 4.0 * load);
}

/// The example scaled by `f` in every length; torque ∝ f³ (same contact
/// stress), bearing stiffness ∝ f, speed ∝ 1/f (same frequency ratios).
fn scaled(f: f64) -> Scene {
    let mut s = Scene::example_2004_annulus();
    for g in [&mut s.sun, &mut s.planet] {
        g.module *= f;
        g.tooth_thickness *= f;
        g.tip_radius *= f;
        g.root_radius *= f;
        g.bore_radius *= f;
        g.hob_tip_radius *= f;
        g.face_width *= f;
    }
    let r = &mut s.ring;
    r.module *= f;
    r.tooth_thickness *= f;
    r.minor_radius *= f;
    r.root_radius *= f;
    r.rim_radius *= f;
    r.fillet_radius *= f;
    r.face_width *= f;
    s.centre_distance *= f;
    s.operation.input_torque_nm *= f * f * f;
    let b = &mut s.supports;
    b.sun_radial_n_per_m *= f;
    b.ring_radial_n_per_m *= f;
    b.carrier_radial_n_per_m *= f;
    b.planet_bearing_n_per_m *= f;
    s
}

#[test]
fn very_small_and_very_large_gear_sets_obey_dynamic_similarity() {
    // Module 0.15 mm and 15 mm against the example's 1.5 mm: with lengths
    // × f, torque × f³, bearings × f and speed × 1/f the equations are the
    // same in scaled variables, so the tooth force over f² must be the same.
    let mut reference = None;
    for f in [1.0, 0.1, 10.0] {
        let s = scaled(f);
        let (set, run, mut model) = build(&s);
        let r = steady_state(&mut model, &set, &run, 5000.0 / f * RPM, None)
            .unwrap_or_else(|e| panic!("f = {f}: {e}"));
        assert!(finite(&r), "f = {f}");
        let m = &r.meshes[0].harmonics;
        let scaled_h: Vec<f64> =
            std::iter::once(m.mean).chain(m.amplitude.iter().copied()).map(|x| x / (f * f)).collect();
        eprintln!("f = {f}: mean {:.2} N, F(rms) {:.2} N (over f²)", scaled_h[0], m.rms / (f * f));
        match &reference {
            None => reference = Some(scaled_h),
            Some(r0) => {
                for (a, b) in scaled_h.iter().zip(r0) {
                    assert!((a - b).abs() < 1e-3 * r0[0], "f = {f}: {a} against {b}");
                }
            }
        }
    }
}

#[test]
fn a_tolerance_double_precision_cannot_meet_is_refused_before_any_work() {
    // RK 5(4) asked for a relative tolerance below what double precision can
    // deliver would reject steps forever: the scene is refused up front with
    // the parameter's name and its admissible range.
    let mut s = Scene::example_2004_annulus();
    s.dynamics.integrator = IntegratorKind::Rk45;
    s.dynamics.relative_tolerance = 1e-17;
    let msg = s.validate().expect_err("1e-17 cannot be met").to_string();
    assert!(msg.contains("dynamics.relative_tolerance") && msg.contains("1e-14"), "{msg}");
}
