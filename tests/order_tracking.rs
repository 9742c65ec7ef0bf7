//! Order-tracked harmonics (src/analysis/order_tracking.rs), the measure of
//! the regression references: the FMU's window (Simulation) converges to it
//! as the internal grid points per mesh cycle grow, at the second order of
//! its linear interpolation between them.
//!
//! The cases run on the uncalibrated reading of the example
//! (`Scene::example_2004_annulus`), whose figures they pin; the calibrated
//! example's own laws and figures: tests/calibrated_example.rs.

use planetwear::analysis::order_tracking::{order_tracked_windows, WindowMeasure};
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::ResponseError;
use planetwear::dynamics::simulation::Simulation;
use planetwear::model::gear::{IntegratorKind, MeshKind};
use planetwear::package::regression::window_error;
use planetwear::scene::{Fidelity, Scene};

const OMEGA: f64 = 3000.0 * std::f64::consts::PI / 30.0;
const WINDOW: usize = 8;
const END: usize = 20;
const SAMPLES: usize = 60;

fn scene(rtol: f64, steps: u32) -> Scene {
    let mut s = Scene::example_2004_annulus();
    s.dynamics.fidelity = Fidelity::Torsional;
    s.dynamics.integrator = IntegratorKind::Rk45;
    s.dynamics.relative_tolerance = rtol;
    s.dynamics.simulation_relative_tolerance = rtol;
    s.dynamics.steps_per_mesh_cycle = steps;
    s
}

/// The FMU's window after END mesh cycles of doStep of one mesh period.
fn fmu_window(steps: u32) -> WindowMeasure {
    let (set, run) = scene(1e-9, steps).validate_with_run().unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let period = 1.0 / (model.mesh_frequency_per_input_speed * OMEGA);
    let mut sim = Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap();
    sim.set_window(WINDOW, SAMPLES).unwrap();
    for k in 0..END {
        sim.do_step(k as f64 * period, period).unwrap();
    }
    let (sun, sun_separation) = sim.window_harmonics(MeshKind::SunPlanet).unwrap();
    let (ring, ring_separation) = sim.window_harmonics(MeshKind::RingPlanet).unwrap();
    WindowMeasure { end_cycle: END, sun, sun_separation, ring, ring_separation }
}

#[test]
fn the_fmu_window_converges_to_the_order_tracked_harmonics_at_second_order() {
    let (set, run) = scene(1e-10, 120).validate_with_run().unwrap();
    let mut model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let reference = order_tracked_windows(&set, &run, &mut model, OMEGA, WINDOW, SAMPLES, &[END]).unwrap();
    let exact = &reference.windows[0];
    // The mean mesh force is the static load: 750 N·m over 4 planets at the
    // sun's base radius.
    let f0 = 750.0 / (4.0 * set.sun().base_radius());
    assert!((exact.sun.mean / f0 - 1.0).abs() < 2e-3, "{} vs {f0}", exact.sun.mean);
    let errors: Vec<f64> = [240, 480, 960].iter().map(|s| window_error(exact, &fmu_window(*s))).collect();
    let shown: Vec<String> = errors.iter().map(|e| format!("{e:.2e}")).collect();
    println!("E_h of the FMU window at 240, 480, 960 steps per mesh cycle: {}", shown.join(", "));
    // Observed order over a quadrupling of the steps: 2 for a linear
    // interpolation of a smooth force; the kinks of the force at contact
    // switches make single halvings irregular.
    let order = (errors[0] / errors[2]).ln() / 4f64.ln();
    println!("observed order {order:.2}");
    assert!((1.5..=2.7).contains(&order), "{errors:?}: order {order}");
    assert!(errors[1] < errors[0] && errors[2] < errors[1], "{errors:?}");
    assert!(errors[2] < 1e-4, "{errors:?}");
}

#[test]
fn a_generalized_alpha_setting_or_a_window_longer_than_the_run_is_refused() {
    let mut s = scene(1e-8, 120);
    s.dynamics.integrator = IntegratorKind::GeneralizedAlpha;
    let (set, run) = s.validate_with_run().unwrap();
    let mut model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let e = order_tracked_windows(&set, &run, &mut model, OMEGA, WINDOW, SAMPLES, &[END]).unwrap_err();
    assert!(matches!(&e, ResponseError::InvalidRequest { name, .. } if name == "integrator"), "{e}");
    let (set, run) = scene(1e-8, 120).validate_with_run().unwrap();
    let e = order_tracked_windows(&set, &run, &mut model, OMEGA, 30, SAMPLES, &[END]).unwrap_err();
    assert!(e.to_string().contains("window ends"), "{e}");
    let e = order_tracked_windows(&set, &run, &mut model, -OMEGA, WINDOW, SAMPLES, &[END]).unwrap_err();
    assert!(e.to_string().contains("input speed"), "{e}");
}
