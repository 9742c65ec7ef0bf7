//! The `steady` response (docs/STEADY.md): the rigid-body rotation follows Newton's law at
//! the step, the tooth outputs are the periodic steady state's (against the time-domain
//! simulation run to its steady state), the cache answers repeated steps without solving,
//! and a snapshot restores exactly.

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::simulation::Simulation;
use planetwear::model::gear::{GearSet, Member, MeshKind};
use planetwear::model::run::RunSettings;
use planetwear::scene::{Drive, Response, Scene};

const RPM: f64 = std::f64::consts::PI / 30.0;

fn example(change: impl FnOnce(&mut Scene)) -> (GearSet, RunSettings) {
    steady_scene(Scene::example_2004(), change)
}

/// The stiff-pin reading (`example-2004-stiff-pins`), whose worn teeth rattle at light
/// load (on the example's flexible bearings that node settles).
fn stiff_pins(change: impl FnOnce(&mut Scene)) -> (GearSet, RunSettings) {
    steady_scene(Scene::example_2004_stiff_pins(), change)
}

fn steady_scene(mut scene: Scene, change: impl FnOnce(&mut Scene)) -> (GearSet, RunSettings) {
    scene.dynamics.response = Response::Steady;
    change(&mut scene);
    scene.validate_with_run().unwrap()
}

fn steady(set: &GearSet, run: &RunSettings, speed: f64) -> Simulation {
    let model = PlanetaryDynamics::new(set, SetModel::new(set)).unwrap();
    let mut sim = Simulation::new(set, run, model, 0.0, speed).unwrap();
    sim.use_steady(None).unwrap();
    sim
}

/// At 3000 rpm and the scene's torque the step outputs are the periodic state's: the
/// time-domain simulation after 0.3 s of run-in gives the same largest, smallest and mean
/// mesh force over its steps within 0.5 % of the static mesh load. On the cache's defaults
/// 3000 rpm is the midpoint of a coarsest cell's 2900–3100 rpm edge, across the response's
/// peak at 2950 rpm: the estimate at that midpoint (6.0 % of the static load) halves the
/// cell, where an estimate at the centre alone (3.1 %) let it interpolate the edge's
/// corners, 6.0 % low (docs/STEADY.md, "The cache").
#[test]
fn the_outputs_are_the_time_domain_steady_state() {
    let (set, run) = example(|_| {});
    let omega = 3000.0 * RPM;
    let mut s = steady(&set, &run, omega);
    s.do_step(0.0, 1e-3).unwrap();
    let e = s.step_extremes().mesh(0, MeshKind::SunPlanet).unwrap();
    let mean = s.step_extremes().mean(0, MeshKind::SunPlanet).unwrap();
    let (time_set, time_run) = example(|sc| sc.dynamics.response = Response::Time);
    let model = PlanetaryDynamics::new(&time_set, SetModel::new(&time_set)).unwrap();
    let mut m = Simulation::new(&time_set, &time_run, model, 0.0, omega).unwrap();
    let (mut max, mut min, mut sum) = (f64::NEG_INFINITY, f64::INFINITY, 0.0);
    let steps = 340;
    for k in 0..steps {
        m.do_step(k as f64 * 1e-3, 1e-3).unwrap();
        if k >= 300 {
            let x = m.step_extremes().mesh(0, MeshKind::SunPlanet).unwrap();
            max = max.max(x.max);
            min = min.min(x.min);
            sum += m.step_extremes().mean(0, MeshKind::SunPlanet).unwrap();
        }
    }
    let load = set.mesh_load_per_planet();
    let time_mean = sum / 40.0;
    for (what, a, b) in [("largest", e.max, max), ("smallest", e.min, min), ("mean", mean, time_mean)] {
        assert!((a - b).abs() <= 5e-3 * load, "{what} sun–planet force: steady {a} N, time domain {b} N");
    }
    // The mean balances the input torque: n F r_b = T.
    assert!((mean - load).abs() <= 2e-3 * load, "mean {mean} N against the static load {load} N");
}

/// Under the torque drive the rigid-body rotation takes the unbalanced torque: after t the
/// input speed has changed by ΔT t / J (J the train's inertia referred to the input), and
/// the meshes carry the input torque less the input member's own J_in α.
#[test]
fn the_rotation_follows_the_unbalanced_torque() {
    let (set, run) = example(|_| {});
    let omega = 3000.0 * RPM;
    let mut s = steady(&set, &run, omega);
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let (j, j_in) = (model.rigid_inertia(), model.input_member_inertia());
    let [sun, ring, carrier] = set.balanced_torques();
    let extra = 20.0;
    s.set_torques(sun + extra, ring, carrier).unwrap();
    let steps = 50;
    for k in 0..steps {
        s.do_step(k as f64 * 1e-3, 1e-3).unwrap();
    }
    let (_, speed) = s.steady().unwrap().rotation();
    let expected = omega + extra / j * steps as f64 * 1e-3;
    assert!(
        (speed - expected).abs() <= 1e-9 * expected,
        "speed {speed} rad/s, Newton's law {expected} rad/s"
    );
    let load = s.steady().unwrap().load_torque();
    let alpha = extra / j;
    assert!((load - (sun + extra - j_in * alpha)).abs() <= 1e-9 * sun, "mesh load {load} N·m");
}

/// Under the speed drive the rotation follows the reference and the input torque is what
/// holds the output's torque: the balanced input torque at a constant speed.
#[test]
fn the_speed_drive_follows_the_reference() {
    let (set, run) = example(|sc| sc.dynamics.drive = Drive::Speed);
    let omega = 3000.0 * RPM;
    let mut s = steady(&set, &run, omega);
    s.do_step(0.0, 1e-3).unwrap();
    let torque = s.input_torque();
    assert!((torque - set.input_torque()).abs() <= 1e-9 * set.input_torque(), "input torque {torque} N·m");
    s.set_speed_reference(3100.0 * RPM).unwrap();
    s.do_step(1e-3, 1e-3).unwrap();
    let (_, speed) = s.steady().unwrap().rotation();
    assert_eq!(speed, 3100.0 * RPM);
    assert!(s.input_torque() > set.input_torque(), "accelerating takes more torque: {}", s.input_torque());
}

/// Steps at one speed and torque are cache hits: no steady state is solved and no error
/// estimated after the first step's, and the outputs do not change from step to step.
#[test]
fn repeated_steps_are_cache_hits() {
    let (set, run) = example(|_| {});
    let mut s = steady(&set, &run, 3000.0 * RPM);
    s.do_step(0.0, 1e-3).unwrap();
    let solved = s.steady().unwrap().stats().solved;
    let estimated = s.steady().unwrap().stats().estimated;
    assert!(estimated > 0, "the first request estimates its cells' errors");
    let first = s.step_extremes().clone();
    for k in 1..200 {
        s.do_step(k as f64 * 1e-3, 1e-3).unwrap();
    }
    assert_eq!(s.steady().unwrap().stats().solved, solved);
    assert_eq!(s.steady().unwrap().stats().estimated, estimated);
    assert_eq!(s.step_extremes(), &first);
    assert_eq!(s.steady().unwrap().stats().requests, 201);
}

/// A snapshot taken mid-run and restored continues exactly as the run without the restore.
#[test]
fn a_restored_snapshot_continues_exactly() {
    let (set, run) = example(|_| {});
    let mut s = steady(&set, &run, 3000.0 * RPM);
    let [sun, ring, carrier] = set.balanced_torques();
    s.set_torques(sun + 5.0, ring, carrier).unwrap();
    for k in 0..20 {
        s.do_step(k as f64 * 1e-3, 1e-3).unwrap();
    }
    let snap = s.snapshot();
    let mut forces = Vec::new();
    for k in 20..40 {
        s.do_step(k as f64 * 1e-3, 1e-3).unwrap();
        forces.push((s.mesh_force(0, MeshKind::SunPlanet), s.speed(Member::Sun)));
    }
    s.restore(&snap).unwrap();
    for (k, expected) in (20..40).zip(&forces) {
        s.do_step(k as f64 * 1e-3, 1e-3).unwrap();
        let got = (s.mesh_force(0, MeshKind::SunPlanet), s.speed(Member::Sun));
        assert!(
            (got.0 - expected.0).abs() <= 1e-6 * expected.0.abs(),
            "t = {k} ms: {got:?} against {expected:?}"
        );
        assert!(
            (got.1 - expected.1).abs() <= 1e-9 * expected.1.abs(),
            "t = {k} ms: {got:?} against {expected:?}"
        );
    }
}

/// A coast (negative) load: the periodic solvers find no orbit on the coast flanks, the
/// settled march is the steady state; its mean mesh force balances the torque (−F_static
/// within 1 %: the mean of 60 samples per mesh cycle aliases the force's harmonics 60, 120,
/// … into it; measured 0.5 %).
#[test]
fn a_coast_load_is_the_settled_march() {
    let (set, run) = example(|sc| sc.operation.input_torque_nm = -150.0);
    let mut s = steady(&set, &run, 3000.0 * RPM);
    s.do_step(0.0, 1e-3).unwrap();
    let mean = s.step_extremes().mean(0, MeshKind::SunPlanet).unwrap();
    let load = set.mesh_load_per_planet();
    assert!((mean + load).abs() <= 1e-2 * load, "mean {mean} N against −{load} N");
    assert!(s.steady().unwrap().stats().marched >= 1);
}

/// Bad settings are refused by name.
#[test]
fn bad_settings_are_refused_by_name() {
    let mut scene = Scene::example_2004();
    scene.dynamics.response = Response::Steady;
    scene.operation.input_torque_nm = 0.0;
    let e = scene.validate_with_run().unwrap_err().to_string();
    assert!(e.contains("dynamics.steady_torque_step_nm"), "{e}");
    scene.dynamics.steady_torque_step_nm = Some(100.0);
    scene.dynamics.steady_agreement = 0.0;
    scene.dynamics.steady_refinements = 9;
    let e = scene.validate_with_run().unwrap_err().to_string();
    assert!(e.contains("dynamics.steady_agreement") && e.contains("dynamics.steady_refinements"), "{e}");
    // A time response does not need the torque step (a set without input torque).
    scene.dynamics.steady_agreement = 0.05;
    scene.dynamics.steady_refinements = 3;
    scene.dynamics.steady_torque_step_nm = None;
    scene.dynamics.response = Response::Time;
    scene.validate_with_run().unwrap();
    // The speed drive on the output member is a time-domain drive.
    let (set, run) = example(|sc| {
        sc.dynamics.drive = Drive::Speed;
        sc.dynamics.speed_driven_member = Some(Member::Ring);
    });
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let mut sim = Simulation::new(&set, &run, model, 0.0, 3000.0 * RPM).unwrap();
    let e = sim.use_steady(None).unwrap_err().to_string();
    assert!(e.contains("speed_driven_member"), "{e}");
    // A non-finite torque is refused before the step.
    let mut s = steady(&example(|_| {}).0, &example(|_| {}).1, 3000.0 * RPM);
    let e = s.set_torques(f64::NAN, 0.0, 0.0).unwrap_err().to_string();
    assert!(e.contains("sunTorque"), "{e}");
}

/// The same steps give the same outputs, bit for bit, in every run: each new cache solves
/// its nodes by continuation from the same neighbours (20 steps of 1 ms from 3000 rpm under
/// the scene's torque, which accelerates the set across several speed nodes, run four
/// times with four caches).
#[test]
fn the_same_steps_give_the_same_outputs_bit_for_bit() {
    let (set, run) = example(|_| {});
    let record = || {
        let mut s = steady(&set, &run, 3000.0 * RPM);
        let mut out = Vec::new();
        for k in 0..20 {
            s.do_step(k as f64 * 1e-3, 1e-3).unwrap();
            for p in 0..set.planet_angles().len() {
                for m in [MeshKind::SunPlanet, MeshKind::RingPlanet] {
                    let e = s.step_extremes().mesh(p, m).unwrap();
                    out.extend([e.max.to_bits(), e.min.to_bits(), s.mesh_force(p, m).to_bits()]);
                }
            }
            out.push(s.speed(Member::Sun).to_bits());
        }
        (out, s.steady().map(|g| g.stats().solved))
    };
    let first = record();
    assert!(first.1.is_some_and(|n| n >= 4), "too few nodes solved to compare: {:?}", first.1);
    for run in 1..4 {
        assert!(record() == first, "run {run} differs from the first");
    }
}

/// The example's model on its shipped worn state κ = `kappa`.
fn worn_model(kappa: usize) -> (GearSet, PlanetaryDynamics) {
    let (set, _) = stiff_pins(|_| {});
    let worn = &planetwear::package::pack::example_wear_states().unwrap()[kappa];
    let model = PlanetaryDynamics::new(&set, worn.set_model(&set)).unwrap();
    (set, model)
}

/// The steady states of input torque `torque` [N·m] of `model`, set up at `rpm`, and the
/// static mesh load per planet at that torque \[N\].
fn torque_level(
    set: &GearSet,
    model: &PlanetaryDynamics,
    torque: f64,
    rpm: f64,
) -> (planetwear::dynamics::steady::point::TorqueLevel, f64) {
    let unit = set.with_input_torque(1.0).unwrap();
    let load = unit.mesh_load_per_planet() * torque;
    let torques = unit.balanced_torques().map(|t| t * torque);
    let level = planetwear::dynamics::steady::point::TorqueLevel::new(
        model,
        (torque, load),
        torques,
        rpm * RPM,
        (60, 0.0),
    )
    .unwrap();
    (level, load)
}

/// A node where the worn teeth rattle (the stiff-pin reading at κ = 6, 550 rpm, 37.5 N·m: light load
/// at low speed) costs at most the march budget: its marches, together, stop within
/// `MARCH_STEPS` integrator steps and one period more, it is marked as not settled, and its
/// outputs are finite. (Before the budget, this node marched 220 periods, 1.4 M steps,
/// and then tried shooting from the unsettled state: 19 s.)
#[test]
fn a_rattling_node_keeps_to_the_march_budget() {
    use planetwear::dynamics::steady::point::{MARCH_SETTLED, MARCH_STEPS};
    let (set, model) = worn_model(6);
    let (mut level, _) = torque_level(&set, &model, 37.5, 550.0);
    let omega = 550.0 * RPM;
    let point = level.solve(omega, None).unwrap();
    // One period at 550 rpm takes about 6 000 steps on the worn flanks.
    let period_steps = 20_000;
    assert!(
        point.work.steps <= MARCH_STEPS + period_steps,
        "{} steps against a budget of {MARCH_STEPS}",
        point.work.steps
    );
    assert!(
        point.settled > MARCH_SETTLED,
        "the node settled ({}): it does not test the budget",
        point.settled
    );
    assert!(point.meshes.iter().all(|m| m.max.is_finite() && m.min.is_finite() && m.mean.is_finite()));
}

/// A node whose march does not integrate from its neighbour's state marches from the static
/// state instead (the worn example at κ = 4 and 18.75 N·m: from the state at 4 800 rpm,
/// reached from 4 775 rpm, RK 5(4) stalls at t = 6e-11 s at 4 825 rpm; the node failed
/// with "the march failed" before, as one did in the FMU's step on the drive cycle).
#[test]
fn a_march_that_stalls_from_its_neighbour_starts_from_the_static_state() {
    use planetwear::dynamics::steady::point::Found;
    let (set, model) = worn_model(4);
    // The chain of nodes a cycle solved, each level set up at its speed.
    let mut near = None;
    for rpm in [4775.0, 4800.0, 4825.0] {
        let (mut level, _) = torque_level(&set, &model, 18.75, rpm);
        near = Some(level.solve(rpm * RPM, near.as_ref()).unwrap());
    }
    let point = near.unwrap();
    assert_eq!(point.found, Found::Marched);
    assert!(point.meshes.iter().all(|m| m.max.is_finite() && m.mean.is_finite()));
}

/// The steady state keeps only orbits that are motions of the gear set: over any bounded
/// steady motion the mean mesh forces carry the torques. On the worn example at κ = 4,
/// 5 275 rpm and 18.75 N·m, Newton on the balance from the static state converges to a
/// root whose mean mesh forces are 8.7e18 times the static load; the node is then the
/// march's. Law checked: every mesh's mean force within 10 times the static load (a
/// rattling planet's was 0.2–2.2 times it).
#[test]
fn an_orbit_whose_mean_forces_do_not_carry_the_torque_is_not_kept() {
    let (set, model) = worn_model(4);
    let (mut level, load) = torque_level(&set, &model, 18.75, 5275.0);
    let omega = 5275.0 * RPM;
    let point = level.solve(omega, None).unwrap();
    for (k, m) in point.meshes.iter().enumerate() {
        assert!(m.mean.abs() <= 10.0 * load, "mesh {k}: mean {} N against a static load of {load} N", m.mean);
    }
}
