//! The steady response at one operating point of the example, against the time-domain
//! simulation (docs/STEADY.md): the first steady state's cost (cold), the cost of 1000
//! cached steps of 1 ms, and the sun–planet mesh force's extremes and window harmonics of
//! both after 0.4 s.
//!
//! `cargo run --release --example steady_probe -- [RPM] [TORQUE FACTOR]` (3000, 1).

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::simulation::Simulation;
use planetwear::model::gear::MeshKind;
use planetwear::scene::Scene;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let rpm: f64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(3000.0);
    let factor: f64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(1.0);
    let (set, run) = Scene::example_2004_stiff_pins().validate_with_run().expect("the example is valid");
    let set = set.with_input_torque(set.input_torque() * factor).expect("a finite torque");
    let omega = rpm * std::f64::consts::PI / 30.0;
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("the example's model");
    let started = Instant::now();
    let mut steady = Simulation::new(&set, &run, model.clone(), 0.0, omega).expect("a simulation");
    steady.use_steady(None).expect("a steady state");
    println!(
        "first steady state (cold): {:.3} s at {rpm} rpm, {} N·m",
        started.elapsed().as_secs_f64(),
        set.input_torque()
    );
    let started = Instant::now();
    for k in 0..1000 {
        steady.do_step(k as f64 * 1e-3, 1e-3).expect("a cached step");
    }
    let engine = steady.steady().expect("steady");
    println!(
        "1000 cached steps of 1 ms: {:.1} µs per step ({:?})",
        started.elapsed().as_secs_f64() * 1e3,
        engine.stats()
    );
    let mut time = Simulation::new(&set, &run, model, 0.0, omega).expect("a simulation");
    let started = Instant::now();
    let (mut max, mut min) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..400 {
        time.do_step(k as f64 * 1e-3, 1e-3).expect("a time-domain step");
        if k >= 300 {
            let e = time.step_extremes().mesh(0, MeshKind::SunPlanet).expect("planet 1");
            (max, min) = (max.max(e.max), min.min(e.min));
        }
    }
    println!("time domain, 0.4 s in {:.2} s", started.elapsed().as_secs_f64());
    let e = steady.step_extremes().mesh(0, MeshKind::SunPlanet).expect("planet 1");
    println!("sun–planet force, largest: steady {:.2} N, time domain {max:.2} N", e.max);
    println!("sun–planet force, smallest: steady {:.2} N, time domain {min:.2} N", e.min);
    for (name, sim) in [("steady", &steady), ("time domain", &time)] {
        if let Some((h, s)) = sim.window_harmonics(MeshKind::SunPlanet) {
            println!(
                "{name}: mean {:.1} N, F^(rms) {:.1} N, A1..A6 {:.1?} N, separation {s}",
                h.mean, h.rms, h.amplitude
            );
        }
    }
}
