//! The speed drive on a member other than the input: the output member
//! speed-driven (a drivetrain imposing the vehicle-side speed), torque on
//! the input member.

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::simulation::Simulation;
use planetwear::model::gear::Member;
use planetwear::scene::{Drive, Fidelity, Scene};

const RPM: f64 = std::f64::consts::PI / 30.0;

/// The example (carrier held, torque on the sun), torsional, the ring
/// speed-driven.
fn ring_driven() -> Scene {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = Fidelity::Torsional;
    s.dynamics.drive = Drive::Speed;
    s.dynamics.speed_driven_member = Some(Member::Ring);
    s
}

/// The ring turns at the kinematic ratio of the sun's speed, ω_r =
/// −(Z_s/Z_r) ω_s, and its shaft carries on average the torque that
/// balances the sun's, T_r = (Z_r/Z_s) T_s (carrier held, no losses: the
/// power T_s ω_s + T_r ω_r = 0), while the sun, driven by its torque only,
/// follows.
#[test]
fn a_speed_driven_ring_with_torque_on_the_sun_keeps_the_ratio_and_balances_the_torque() {
    let scene = ring_driven();
    let (set, run) = scene.validate_with_run().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(set.speed_driven_member(), Member::Ring);
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let omega = 3000.0 * RPM;
    let mut sim = Simulation::new(&set, &run, model, 0.0, omega).unwrap();
    let (zs, zr) = (f64::from(set.sun().teeth), f64::from(set.ring().teeth));
    let ratio = -zs / zr;
    let sun_torque = set.input_torque();
    // Settle for 0.1 s, then average over 0.1 s (170 mesh cycles): the
    // angles give the mean speeds.
    let h = 1e-3;
    let mut k = 0;
    while k < 100 {
        sim.do_step(k as f64 * h, h).unwrap();
        k += 1;
    }
    let (sun0, ring0, t0) = (sim.angle(Member::Sun), sim.angle(Member::Ring), sim.time());
    let mut torque = 0.0;
    let n = 100;
    for _ in 0..n {
        sim.do_step(k as f64 * h, h).unwrap();
        torque += sim.input_torque();
        k += 1;
    }
    let span = sim.time() - t0;
    let (ws, wr) = ((sim.angle(Member::Sun) - sun0) / span, (sim.angle(Member::Ring) - ring0) / span);
    let torque = torque / n as f64;
    let expected = sun_torque * zr / zs;
    println!(
        "ring speed-driven: mean ring speed {wr:.4} rad/s (kinematic {:.4}), sun {ws:.4} rad/s (reference {omega:.4}); \
         mean shaft torque {torque:.2} N·m vs (Z_r/Z_s)·T_s = {expected:.2} N·m",
        ratio * omega
    );
    assert!((wr / (ratio * omega) - 1.0).abs() < 1e-4, "ring {wr} vs {}", ratio * omega);
    assert!((ws / wr / (1.0 / ratio) - 1.0).abs() < 1e-4, "speed ratio {} vs {}", ws / wr, 1.0 / ratio);
    assert!((torque / expected - 1.0).abs() < 1e-3, "shaft torque {torque} vs {expected}");
}

/// The held member cannot be speed-driven, and the key applies to the
/// speed drive alone: each refusal names the key, its value and what is
/// allowed.
#[test]
fn a_held_or_misplaced_speed_driven_member_is_refused_by_its_key() {
    let mut s = ring_driven();
    s.dynamics.speed_driven_member = Some(Member::Carrier);
    let e = s.validate().unwrap_err().to_string();
    assert!(
        e.contains(
            "dynamics.speed_driven_member = carrier: the held member (carrier) cannot be speed-driven"
        ),
        "{e}"
    );
    assert!(e.contains("the input member (sun) or the output member (ring)"), "{e}");
    let mut s = ring_driven();
    s.dynamics.drive = Drive::Torque;
    let e = s.validate().unwrap_err().to_string();
    assert!(
        e.contains("dynamics.speed_driven_member = ring: applies to dynamics.drive = \"speed\" only"),
        "{e}"
    );
    let mut s = ring_driven();
    s.dynamics.load_balance = true;
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("dynamics.speed_driven_member = ring: the load balance already holds"), "{e}");
    // The key reads from and writes to a scene file; absent means the input member.
    let text = ring_driven().to_toml();
    assert!(text.contains("speed_driven_member = \"ring\""), "{text}");
    let back = Scene::from_toml(&text).unwrap();
    assert_eq!(back.dynamics.speed_driven_member, Some(Member::Ring));
    assert!(!Scene::example_2004().to_toml().contains("speed_driven_member"));
    let (set, _) = Scene::example_2004().validate_with_run().unwrap();
    assert_eq!(set.speed_driven_member(), set.input());
}
