//! The time-domain simulation the FMU drives.

use planetwear::physics::dynamics::PlanetaryDynamics;
use planetwear::physics::gear::{GearSet, Member, MeshKind};
use planetwear::physics::ltca::SetModel;
use planetwear::physics::simulation::{torques_of, Simulation, SimulationError};
use planetwear::scene::{Fidelity, Scene};
use planetwear::solver::SecondOrderSystem;

const OMEGA: f64 = 3000.0 * std::f64::consts::PI / 30.0;

fn setup(fidelity: Fidelity) -> (GearSet, PlanetaryDynamics) {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = fidelity;
    let set = s.validate().unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    (set, model)
}

fn nominal_step(model: &PlanetaryDynamics, set: &GearSet) -> f64 {
    1.0 / (model.mesh_frequency_per_input_speed * OMEGA * set.dynamics.steps_per_mesh_cycle as f64)
}

#[test]
fn communication_steps_that_are_multiples_of_the_internal_step_give_one_trajectory() {
    let (set, model) = setup(Fidelity::Torsional);
    let h = nominal_step(&model, &set);
    let mut a = Simulation::new(&set, model.clone(), 0.0, OMEGA).unwrap();
    let mut b = Simulation::new(&set, model, 0.0, OMEGA).unwrap();
    for k in 0..40 {
        a.do_step(a.time(), 10.0 * h).unwrap();
        if k % 4 == 3 {
            b.do_step(b.time(), 40.0 * h).unwrap();
            for p in 0..4 {
                for mesh in [MeshKind::SunPlanet, MeshKind::RingPlanet] {
                    let (fa, fb) = (a.mesh_force(p, mesh), b.mesh_force(p, mesh));
                    assert!((fa - fb).abs() <= 1e-9 * fa.abs().max(1.0), "{fa} vs {fb} at step {k}");
                }
            }
        }
    }
}

#[test]
fn a_snapshot_continues_bit_identically() {
    let (set, model) = setup(Fidelity::TransverseTorsional);
    let mut sim = Simulation::new(&set, model, 0.0, OMEGA).unwrap();
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
    let (set, model) = setup(Fidelity::Torsional);
    let mut sim = Simulation::new(&set, model, 0.0, OMEGA).unwrap();
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
    let (set, model) = setup(Fidelity::Torsional);
    let fm = model.mesh_frequency_per_input_speed * OMEGA;
    let mut sim = Simulation::new(&set, model, 0.0, OMEGA).unwrap();
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
    let (set, model) = setup(Fidelity::Torsional);
    let r = model.rigid_velocity.clone();
    let j_eff: f64 = model.mass().iter().zip(&r).map(|(m, r)| m * r * r).sum();
    let fm = model.mesh_frequency_per_input_speed * OMEGA;
    let mut sim = Simulation::new(&set, model, 0.0, OMEGA).unwrap();
    let t = torques_of(&set);
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
