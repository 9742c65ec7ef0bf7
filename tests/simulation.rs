//! The time-domain simulation the FMU drives.
//!
//! The cases run on the uncalibrated reading of the example
//! (`Scene::example_2004_annulus`), whose figures they pin; the calibrated
//! example's own laws and figures: tests/calibrated_example.rs.

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::simulation::{Simulation, SimulationError};
use planetwear::dynamics::solver::SecondOrderSystem;
use planetwear::model::gear::{GearSet, Member, MeshKind};
use planetwear::model::run::RunSettings;
use planetwear::scene::{Fidelity, IntegratorKind, Scene};

const OMEGA: f64 = 3000.0 * std::f64::consts::PI / 30.0;

fn setup(fidelity: Fidelity) -> (GearSet, RunSettings, PlanetaryDynamics) {
    let mut s = Scene::example_2004_annulus();
    s.dynamics.fidelity = fidelity;
    let (set, run) = s.validate_with_run().unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    (set, run, model)
}

fn nominal_step(model: &PlanetaryDynamics, run: &RunSettings) -> f64 {
    1.0 / (model.mesh_frequency_per_input_speed * OMEGA * run.steps_per_mesh_cycle() as f64)
}

/// Generalized-α takes the same internal steps whatever the communication
/// step, so the trajectories agree to rounding. The adaptive default lands
/// only on communication points and reads the internal grid from its dense
/// output: its step sequence depends on where the communication points are,
/// and the trajectories agree to its accuracy (1e-3 of the mean tooth force).
#[test]
fn communication_steps_that_are_multiples_of_the_internal_step_give_one_trajectory() {
    for (integrator, bound) in [(IntegratorKind::GeneralizedAlpha, 1e-9), (IntegratorKind::Rk45, 1e-3)] {
        let mut s = Scene::example_2004_annulus();
        s.dynamics.fidelity = Fidelity::Torsional;
        s.dynamics.integrator = integrator;
        let (set, run) = s.validate_with_run().unwrap();
        let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
        let scale = set.mesh_load_per_planet();
        let h = nominal_step(&model, &run);
        let mut a = Simulation::new(&set, &run, model.clone(), 0.0, OMEGA).unwrap();
        let mut b = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
        let mut worst: f64 = 0.0;
        for k in 0..40 {
            a.do_step(a.time(), 10.0 * h).unwrap();
            if k % 4 == 3 {
                b.do_step(b.time(), 40.0 * h).unwrap();
                for p in 0..4 {
                    for mesh in [MeshKind::SunPlanet, MeshKind::RingPlanet] {
                        let (fa, fb) = (a.mesh_force(p, mesh), b.mesh_force(p, mesh));
                        worst = worst.max((fa - fb).abs() / scale);
                    }
                }
            }
        }
        println!("{integrator:?}: largest difference {worst:.2e} of the mean tooth force");
        assert!(worst <= bound, "{integrator:?}: {worst:e} > {bound:e}");
    }
}

#[test]
fn a_snapshot_continues_bit_identically() {
    let (set, run, model) = setup(Fidelity::TransverseTorsional);
    let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    for _ in 0..50 {
        sim.do_step(sim.time(), 2e-5).unwrap();
    }
    let snap = sim.snapshot();
    let mut first = sim.clone();
    for _ in 0..50 {
        first.do_step(first.time(), 2e-5).unwrap();
    }
    // Disturb, then restore and rerun.
    sim.set_torques(0.0, 0.0, 0.0).unwrap();
    sim.do_step(sim.time(), 1e-4).unwrap();
    sim.restore(&snap).unwrap();
    for _ in 0..50 {
        sim.do_step(sim.time(), 2e-5).unwrap();
    }
    assert_eq!(first.snapshot(), sim.snapshot());
    assert_eq!(first.mesh_force(2, MeshKind::RingPlanet), sim.mesh_force(2, MeshKind::RingPlanet));
}

#[test]
fn bad_steps_and_inputs_are_refused_with_their_names() {
    let (set, run, model) = setup(Fidelity::Torsional);
    let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    let name = |e: SimulationError| match e {
        SimulationError::InvalidInput { name, .. } => name,
        other => panic!("{other}"),
    };
    assert_eq!(name(sim.do_step(1.0, 1e-4).unwrap_err()), "currentCommunicationPoint");
    assert_eq!(name(sim.do_step(0.0, 0.0).unwrap_err()), "communicationStepSize");
    assert_eq!(name(sim.do_step(0.0, f64::NAN).unwrap_err()), "communicationStepSize");
    assert_eq!(name(sim.set_torques(f64::INFINITY, 0.0, 0.0).unwrap_err()), "sunTorque");
    assert_eq!(name(sim.set_speed_reference(f64::NAN).unwrap_err()), "inputSpeedReference");
    // Nothing was changed by the refusals.
    assert_eq!(sim.time(), 0.0);
    sim.do_step(0.0, 1e-4).unwrap();
    assert!((sim.time() - 1e-4).abs() < 1e-18);
}

#[test]
fn balanced_torques_hold_the_speed_and_carry_the_mean_load() {
    let (set, run, model) = setup(Fidelity::Torsional);
    let fm = model.mesh_frequency_per_input_speed * OMEGA;
    let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    let cycle = 1.0 / fm;
    for _ in 0..40 {
        sim.do_step(sim.time(), cycle).unwrap();
    }
    let (mut sum, mut n) = (0.0, 0);
    let angle0 = sim.angle(Member::Sun);
    let t0 = sim.time();
    for _ in 0..34 {
        for _ in 0..60 {
            sim.do_step(sim.time(), cycle / 60.0).unwrap();
            sum += sim.mesh_force(0, MeshKind::SunPlanet);
            n += 1;
        }
    }
    let mean_speed = (sim.angle(Member::Sun) - angle0) / (sim.time() - t0);
    assert!((mean_speed / OMEGA - 1.0).abs() < 1e-6, "mean sun speed {mean_speed}");
    let f0 = set.mesh_load_per_planet();
    assert!(((sum / n as f64) / f0 - 1.0).abs() < 2e-3, "mean mesh force {} vs {f0}", sum / n as f64);
    assert_eq!(sim.speed(Member::Carrier), 0.0);
}

#[test]
fn an_unbalanced_torque_accelerates_the_train_at_the_rigid_body_rate() {
    // ω̇ = ΔT / J_eff, J_eff = Σ M_ii r_i² with r the rigid-body velocity
    // pattern per unit sun speed (kinetic energy ½ J_eff ω²) and ΔT the
    // sun torque in excess of the balance.
    let (set, run, model) = setup(Fidelity::Torsional);
    let r = model.rigid_velocity.clone();
    let j_eff: f64 = model.mass().iter().zip(&r).map(|(m, r)| m * r * r).sum();
    let fm = model.mesh_frequency_per_input_speed * OMEGA;
    let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    let t = set.balanced_torques();
    let extra = 50.0;
    sim.set_torques(t[0] + extra, t[1], t[2]).unwrap();
    let cycles = 68.0;
    let w0 = sim.speed(Member::Sun);
    let a0 = sim.angle(Member::Sun);
    let span = cycles / fm;
    for _ in 0..(cycles as usize) {
        sim.do_step(sim.time(), 1.0 / fm).unwrap();
    }
    // θ(t) = θ0 + ω0 t + ½ ω̇ t²: the mean acceleration from the angle
    // averages out the mesh vibration.
    let accel = 2.0 * (sim.angle(Member::Sun) - a0 - w0 * span) / (span * span);
    let expected = extra / j_eff;
    assert!((accel / expected - 1.0).abs() < 0.01, "ω̇ {accel} vs ΔT/J_eff {expected}");
}

mod outputs {
    use super::*;
    use planetwear::dynamics::response::steady_state;
    use planetwear::dynamics::simulation::Bearing;

    fn run_cycles(
        sim: &mut Simulation,
        fm: f64,
        cycles: usize,
        per_cycle: usize,
        mut each: impl FnMut(&Simulation),
    ) {
        for _ in 0..cycles * per_cycle {
            sim.do_step(sim.time(), 1.0 / fm / per_cycle as f64).unwrap();
            each(sim);
        }
    }

    #[test]
    fn the_windowed_harmonics_match_the_steady_state_analysis() {
        let (set, run, model) = setup(Fidelity::TransverseTorsional);
        let fm = model.mesh_frequency_per_input_speed * OMEGA;
        let reference = steady_state(&mut model.clone(), &set, &run, OMEGA, None).unwrap();
        let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
        sim.set_window(34, 60).unwrap();
        // Communication steps of 2.5 mesh cycles: longer than a cycle.
        for _ in 0..60 {
            sim.do_step(sim.time(), 2.5 / fm).unwrap();
        }
        assert_eq!(sim.window_cycles(), 34);
        for (mesh, index) in [(MeshKind::SunPlanet, 0), (MeshKind::RingPlanet, 1)] {
            let (h, sep) = sim.window_harmonics(mesh).unwrap();
            let r = &reference.meshes[index].harmonics;
            assert!((h.rms / r.rms - 1.0).abs() < 0.01, "{mesh:?} F(rms) {} vs {}", h.rms, r.rms);
            assert!((h.mean / r.mean - 1.0).abs() < 1e-3);
            assert_eq!(sep, 0.0);
        }
    }

    #[test]
    fn the_tracked_pair_meshes_once_per_sun_revolution_for_the_loaded_contact_ratio() {
        let (set, run, model) = setup(Fidelity::TransverseTorsional);
        let fm = model.mesh_frequency_per_input_speed * OMEGA;
        let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
        let (mut loaded, mut total, mut peak) = (0usize, 0usize, 0.0f64);
        run_cycles(&mut sim, fm, 34, 60, |s| {
            let f = s.tracked_pair_force(MeshKind::SunPlanet);
            total += 1;
            if f > 0.0 {
                loaded += 1;
                peak = peak.max(f);
            }
            let n = s.pairs_in_contact(0, MeshKind::SunPlanet);
            assert!((1..=2).contains(&n), "pairs in contact {n}");
        });
        // One revolution of the sun relative to the carrier is 34 mesh cycles;
        // the pair is loaded for the loaded contact ratio (≈1.47) of them.
        let duty = loaded as f64 / total as f64;
        assert!((duty * 34.0 - 1.47).abs() < 0.15, "tracked pair loaded for {:.3} mesh cycles", duty * 34.0);
        let f0 = set.mesh_load_per_planet();
        assert!(peak > 0.8 * f0 && peak < 1.6 * f0, "peak {peak} vs F0 {f0}");
    }

    #[test]
    fn static_te_and_bearing_forces_agree_with_the_quasi_static_analysis() {
        let (set, run, model) = setup(Fidelity::TransverseTorsional);
        let fm = model.mesh_frequency_per_input_speed * OMEGA;
        let alpha = set.operating_pressure_angle(MeshKind::SunPlanet);
        let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
        run_cycles(&mut sim, fm, 20, 10, |_| {});
        let (mut te, mut bearing, mut n) = (0.0, 0.0, 0.0);
        run_cycles(&mut sim, fm, 4, 60, |s| {
            te += s.static_transmission_error(0, MeshKind::SunPlanet);
            bearing += s.bearing_force(Bearing::Planet(0));
            n += 1.0;
        });
        // The LTCA's mean static TE of the sun–planet mesh: 17.601 µm.
        assert!((te / n * 1e6 / 17.601 - 1.0).abs() < 0.01, "mean static TE {} µm", te / n * 1e6);
        // A planet's bearing carries its two mesh forces: tangential parts
        // add (2·F0·cos α_w), radial parts nearly cancel.
        let expected = 2.0 * set.mesh_load_per_planet() * alpha.cos();
        assert!((bearing / n / expected - 1.0).abs() < 0.03, "planet bearing {} vs {expected}", bearing / n);
        assert_eq!(sim.bearing_force(Bearing::Planet(7)), 0.0);
    }
}

fn speed_steps_setup() -> (GearSet, RunSettings, PlanetaryDynamics) {
    let mut s = Scene::example_2004_annulus();
    s.dynamics.drive = planetwear::scene::Drive::SpeedSteps;
    let (set, run) = s.validate_with_run().unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    (set, run, model)
}

#[test]
fn a_speed_step_moves_the_rigid_body_speed_and_keeps_the_elastic_state() {
    let (set, run, model) = speed_steps_setup();
    let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    let h = 1.0 / (34.0 * OMEGA / (2.0 * std::f64::consts::PI));
    for _ in 0..20 {
        sim.do_step(sim.time(), h).unwrap();
    }
    let before = sim.snapshot();
    let (ws, wr) = (sim.speed(Member::Sun), sim.speed(Member::Ring));
    let te: Vec<f64> = (0..4).map(|p| sim.transmission_error(p, MeshKind::SunPlanet)).collect();
    sim.set_speed_reference(2.0 * OMEGA).unwrap();
    let after = sim.snapshot();
    // Deflections unchanged; the speeds moved by the rigid-body pattern (Willis).
    assert_eq!(before.q, after.q);
    assert!((sim.speed(Member::Sun) - ws - OMEGA).abs() < 1e-9 * OMEGA, "sun {}", sim.speed(Member::Sun));
    let ratio = -f64::from(set.sun().teeth) / f64::from(set.ring().teeth);
    assert!((sim.speed(Member::Ring) - wr - ratio * OMEGA).abs() < 1e-9 * OMEGA);
    for (p, te0) in te.iter().enumerate() {
        assert_eq!(sim.transmission_error(p, MeshKind::SunPlanet), *te0);
    }
    // The same reference again is no step; zero is refused with its name.
    sim.set_speed_reference(2.0 * OMEGA).unwrap();
    assert_eq!(sim.snapshot().v, after.v);
    let e = sim.set_speed_reference(0.0).unwrap_err().to_string();
    assert!(e.contains("inputSpeedReference") && e.contains("non-zero"), "{e}");
    // After the step the set runs at the new speed, and the internal step follows it.
    for _ in 0..40 {
        sim.do_step(sim.time(), h / 2.0).unwrap();
    }
    let mean_sun = sim.speed(Member::Sun);
    assert!((mean_sun / (2.0 * OMEGA) - 1.0).abs() < 0.01, "sun speed {mean_sun}");
}

/// Steps both simulations ten times by `h` and asserts bit-identical states.
fn assert_same_continuation(a: &mut Simulation, b: &mut Simulation, h: f64) {
    for _ in 0..10 {
        a.do_step(a.time(), h).unwrap();
        b.do_step(b.time(), h).unwrap();
    }
    assert_eq!(a.snapshot(), b.snapshot());
}

#[test]
fn a_snapshot_after_speed_steps_continues_bit_identically() {
    let (set, run, model) = speed_steps_setup();
    let mut a = Simulation::new(&set, &run, model.clone(), 0.0, OMEGA).unwrap();
    let h = 2e-4;
    for k in 0..10 {
        a.set_speed_reference(OMEGA * (1.0 + 0.1 * f64::from(k))).unwrap();
        a.do_step(a.time(), h).unwrap();
    }
    let snap = a.snapshot();
    let mut b = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    b.restore(&snap).unwrap();
    assert_same_continuation(&mut a, &mut b, h);
}

/// A torque change reaches the adaptive default at once: the run continues
/// exactly as a run restored at that instant with the new torques (before
/// the fix it stepped on with the derivative of the old torques it carried
/// from its last stage).
#[test]
fn a_torque_change_continues_as_a_restart_with_the_new_torques() {
    let (set, run, model) = speed_steps_setup();
    assert_eq!(run.integrator(), planetwear::scene::IntegratorKind::Rk45);
    let mut a = Simulation::new(&set, &run, model.clone(), 0.0, OMEGA).unwrap();
    let h = 1e-4;
    for _ in 0..10 {
        a.do_step(a.time(), h).unwrap();
    }
    let t = set.balanced_torques();
    let (sun, ring) = (1.2 * t[0], 1.2 * t[1]);
    a.set_torques(sun, ring, t[2]).unwrap();
    let snap = a.snapshot();
    let mut b = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    b.set_torques(sun, ring, t[2]).unwrap();
    b.restore(&snap).unwrap();
    assert_same_continuation(&mut a, &mut b, h);
}

/// An unstable explicit coupling (a motor droop of 20 N·m·s/rad on the sun,
/// held over 0.1 ms communication steps against about 1.1e-3 kg·m² of
/// train) makes the speed run away. The adaptive default would follow it
/// with ever shorter steps; its work budget per communication step ends the
/// run instead, with the reason, the time reached and finite outputs —
/// within a bounded number of steps, never a hang.
#[test]
fn a_run_away_coupling_ends_in_a_refused_step_not_a_hang() {
    let (set, run, model) = setup(Fidelity::TransverseTorsional);
    assert_eq!(run.integrator(), IntegratorKind::Rk45);
    let [t_sun, t_ring, t_carrier] = set.balanced_torques();
    let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    let h = 1e-4;
    let mut failure = None;
    for k in 0..400 {
        let w = sim.speed(Member::Sun);
        assert!(w.is_finite());
        sim.set_torques(t_sun + 20.0 * (OMEGA - w), t_ring, t_carrier).unwrap();
        if let Err(e) = sim.do_step(sim.time(), h) {
            failure = Some((k, e));
            break;
        }
    }
    let (k, e) = failure.expect("the run-away coupling was expected to end in a refused step");
    println!("refused at communication step {k}: {e}");
    assert!(k < 100, "refused only at step {k}");
    match &e {
        SimulationError::WorkBudget { budget, speed, nominal_speed, reached, t, .. } => {
            assert!(speed.abs() > 10.0 * nominal_speed, "{speed} vs {nominal_speed}");
            assert!(*budget > 0 && reached >= t && *reached < t + h);
            assert_eq!(sim.time(), *reached);
        }
        other => panic!("expected the work budget, got {other}"),
    }
    assert!(e.to_string().contains("force evaluations"), "{e}");
    for p in 0..4 {
        assert!(sim.mesh_force(p, MeshKind::SunPlanet).is_finite());
    }
}

/// Planet 1's two mesh forces' harmonics 1..6 over the simulation's window
/// (its last 34 mesh cycles) after `steps` communication steps of `h` \[s\]
/// (`None`: one mesh cycle) at `rpm`, RK 5(4) at simulation relative
/// tolerance `rtol`.
fn window_after(fidelity: Fidelity, rpm: f64, h: Option<f64>, cycles: usize, rtol: f64) -> Vec<Vec<f64>> {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = fidelity;
    s.dynamics.integrator = IntegratorKind::Rk45;
    s.dynamics.simulation_relative_tolerance = rtol;
    let (set, run) = s.validate_with_run().unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let omega = rpm * std::f64::consts::PI / 30.0;
    let period = 1.0 / (model.mesh_frequency_per_input_speed * omega);
    let mut sim = Simulation::new(&set, &run, model, 0.0, omega).unwrap();
    let h = h.unwrap_or(period);
    let n = (cycles as f64 * period / h - 1e-9).ceil() as usize;
    for k in 0..n {
        sim.do_step(k as f64 * h, h).unwrap();
    }
    [MeshKind::SunPlanet, MeshKind::RingPlanet]
        .iter()
        .map(|m| sim.window_harmonics(*m).expect("a full window").0.amplitude)
        .collect()
}

/// E_h (docs/ACCURACY.md): the largest error of harmonics 1..6 over both
/// meshes, relative to each mesh's first harmonic of the reference.
fn harmonic_error(run: &[Vec<f64>], reference: &[Vec<f64>]) -> f64 {
    run.iter()
        .zip(reference)
        .map(|(a, r)| a.iter().zip(r).map(|(x, y)| (x - y).abs() / r[0]).fold(0.0, f64::max))
        .fold(0.0, f64::max)
}

/// The FMU's default (the example as the FMU runs it, RK 5(4) at its
/// default tolerance, absolute tolerances scaled to the static mesh
/// deflection) at 3000 rpm, 68 mesh cycles of one communication step each:
/// its windowed harmonics are within E_h ≤ 1e-3 of the same simulation at
/// relative tolerance 1e-10, at both fidelity levels (docs/PERFORMANCE.md:
/// 7.3e-5 torsional, 3.5e-5 transverse–torsional).
#[test]
fn the_default_s_windowed_harmonics_are_within_1e_3_of_a_tight_run_at_3000_rpm() {
    let default_rtol = Scene::example_2004().dynamics.simulation_relative_tolerance;
    for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
        let reference = window_after(fidelity, 3000.0, None, 68, 1e-10);
        let run = window_after(fidelity, 3000.0, None, 68, default_rtol);
        let e_h = harmonic_error(&run, &reference);
        println!("{fidelity:?}: E_h {e_h:.2e}");
        assert!(e_h <= 1e-3, "{fidelity:?}: E_h {e_h:e} > 1e-3");
    }
}

/// The FMU's default tolerance holds E_h ≤ 1e-3 against a run at 1e-9 at
/// 8000 rpm, torsional, after many communication steps (1 ms each, some
/// 1100 mesh cycles, a quarter of a second): the error weight's relative
/// part is measured from the rigid-body motion of each communication step,
/// so its allowance does not grow with the angle turned. Measured from zero
/// (before 2026-11-26), the rotations' allowance rtol·|q| grew through the
/// run, and the FMU's window at the former default 3e-6 had E_h 2.1e-3 at
/// this speed (docs/PERFORMANCE.md).
#[test]
fn the_default_holds_e_h_1e_3_at_8000_rpm_torsional_over_a_long_run() {
    let default_rtol = Scene::example_2004().dynamics.simulation_relative_tolerance;
    let cycles = 1100;
    let (reference, run) = std::thread::scope(|s| {
        let reference = s.spawn(|| window_after(Fidelity::Torsional, 8000.0, Some(1e-3), cycles, 1e-9));
        let run = window_after(Fidelity::Torsional, 8000.0, Some(1e-3), cycles, default_rtol);
        (reference.join().unwrap(), run)
    });
    let e_h = harmonic_error(&run, &reference);
    println!("torsional, 8000 rpm, {cycles} mesh cycles: E_h {e_h:.2e} at {default_rtol:e}");
    assert!(e_h <= 1e-3, "E_h {e_h:e} > 1e-3");
}

/// The window's separation fraction read alone (what the FMU's check reads at every
/// step, without the spectrum) is the one `window_harmonics` gives, to the bit, at every
/// step of a run whose teeth separate (a twentieth of the example's torque at 10 000 rpm,
/// torsional), and neither gives one before the window is full.
#[test]
fn the_window_separation_alone_is_the_harmonics_one() {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = Fidelity::Torsional;
    let (set, run) = s.validate_with_run().unwrap();
    let set = set.with_input_torque(set.input_torque() / 20.0).unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let omega = 10_000.0 * std::f64::consts::PI / 30.0;
    let fm = model.mesh_frequency_per_input_speed * omega;
    let mut sim = Simulation::new(&set, &run, model, 0.0, omega).unwrap();
    sim.set_window(8, 60).unwrap();
    let (mut compared, mut separated) = (0, 0);
    for _ in 0..40 {
        sim.do_step(sim.time(), 0.5 / fm).unwrap();
        for mesh in MeshKind::ALL {
            let alone = sim.window_separation(mesh);
            let with = sim.window_harmonics(mesh).map(|(_, s)| s);
            assert_eq!(alone.map(f64::to_bits), with.map(f64::to_bits), "{mesh:?} at t = {}", sim.time());
            if let Some(f) = alone {
                compared += 1;
                separated += usize::from(f > 0.0);
            }
        }
        // Read alone first and after the spectrum was taken: both paths compared.
        let _ = sim.window_harmonics(MeshKind::SunPlanet);
        assert_eq!(
            sim.window_separation(MeshKind::SunPlanet).map(f64::to_bits),
            sim.window_harmonics(MeshKind::SunPlanet).map(|(_, s)| s.to_bits())
        );
    }
    assert!(compared > 20 && separated > 0, "{compared} readings, {separated} with separation");
}
