//! Cost of fmi2DoStep at 3000 rpm: communication steps of one mesh cycle and
//! of 1 ms, the overhead of the FMI layer against the native `Simulation`,
//! and the real-time factor, for both fidelity levels and both integrators
//! (the default RK 5(4) at its tolerance, and generalized-α at its steps per
//! mesh cycle), and the error E_h of the default's windowed mesh-force
//! harmonics (the FMU's harmonic outputs) against a tight-tolerance run. The
//! native runs take `example-2004`, the FMU's default scene, as the FMU does.
//! Run: `cargo bench --bench fmu_step` (docs/PERFORMANCE.md records the figures).

use std::ffi::CString;
use std::time::Instant;

use fmi_sys::fmi2::*;
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::simulation::Simulation;
use planetwear::fmi::export::*;
use planetwear::fmi::variables::{vr, GUID};
use planetwear::model::gear::MeshKind;
use planetwear::scene::{Fidelity, IntegratorKind, Scene};

fn fmu_run(fidelity: i32, integrator: i32, h: f64, span: f64) -> f64 {
    let guid = CString::new(GUID).expect("no NUL");
    // SAFETY: the strings are NUL-terminated and outlive the call; no callbacks.
    let c = unsafe {
        fmi2Instantiate(
            c"bench".as_ptr(),
            fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            0,
        )
    };
    assert!(!c.is_null());
    let n = (span / h).round() as u64;
    let refs = [vr::PLANET_1_SUN_MESH_FORCE, vr::PLANET_1_RING_MESH_FORCE, vr::SUN_SPEED];
    let mut out = [0.0; 3];
    // SAFETY: `c` is live until fmi2FreeInstance, used by this thread only;
    // the value-reference and value arrays are locals of the lengths passed.
    unsafe {
        assert_eq!(fmi2SetInteger(c, &vr::FIDELITY, 1, &fidelity), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetInteger(c, &vr::INTEGRATOR, 1, &integrator), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), fmi2Status_fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2OK);
        let start = Instant::now();
        for k in 0..n {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
            assert_eq!(fmi2GetReal(c, refs.as_ptr(), 3, out.as_mut_ptr()), fmi2Status_fmi2OK);
        }
        let wall = start.elapsed().as_secs_f64();
        fmi2FreeInstance(c);
        wall / n as f64
    }
}

/// The harmonics of planet 1's two mesh forces over the window (34 mesh
/// cycles) after 34 cycles of run-in, at `rpm`, one mesh cycle per
/// communication step, RK 5(4) at relative tolerance `rtol`.
fn window_harmonics(fidelity: Fidelity, rpm: f64, rtol: f64) -> Vec<Vec<f64>> {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = fidelity;
    s.dynamics.integrator = IntegratorKind::Rk45;
    s.dynamics.simulation_relative_tolerance = rtol;
    let (set, run) = s.validate_with_run().expect("valid");
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
    let omega = rpm * std::f64::consts::PI / 30.0;
    let h = 1.0 / (model.mesh_frequency_per_input_speed * omega);
    let mut sim = Simulation::new(&set, &run, model, 0.0, omega).expect("sim");
    for k in 0..68 {
        sim.do_step(k as f64 * h, h).expect("step");
    }
    [MeshKind::SunPlanet, MeshKind::RingPlanet]
        .iter()
        .map(|m| sim.window_harmonics(*m).expect("full window").0.amplitude)
        .collect()
}

/// E_h (docs/ACCURACY.md) of the window's harmonics 1..6 at relative
/// tolerance `rtol` against the run at 1e-10: the largest error relative to
/// the reference's first harmonic, over both meshes.
fn harmonic_error(fidelity: Fidelity, rpm: f64, rtol: f64) -> f64 {
    let reference = window_harmonics(fidelity, rpm, 1e-10);
    let run = window_harmonics(fidelity, rpm, rtol);
    run.iter()
        .zip(&reference)
        .map(|(a, r)| a.iter().zip(r).map(|(x, y)| (x - y).abs() / r[0]).fold(0.0, f64::max))
        .fold(0.0, f64::max)
}

fn native_run(fidelity: Fidelity, integrator: IntegratorKind, h: f64, span: f64) -> f64 {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = fidelity;
    s.dynamics.integrator = integrator;
    let (set, run) = s.validate_with_run().expect("valid");
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
    let mut sim = Simulation::new(&set, &run, model, 0.0, 3000.0 * std::f64::consts::PI / 30.0).expect("sim");
    let n = (span / h).round() as u64;
    let start = Instant::now();
    for k in 0..n {
        sim.do_step(k as f64 * h, h).expect("step");
    }
    start.elapsed().as_secs_f64() / n as f64
}

fn main() {
    let fm = 34.0 * 3000.0 / 60.0;
    let span = 0.05;
    let d = Scene::example_2004().dynamics;
    println!("fmi2DoStep at 3000 rpm (f_m = {fm} Hz), {span} s simulated");
    let mut kinds = vec![d.integrator];
    kinds.extend(
        [IntegratorKind::Rk45, IntegratorKind::GeneralizedAlpha].into_iter().filter(|k| *k != d.integrator),
    );
    for kind in kinds {
        let (code, integrator) = match kind {
            IntegratorKind::GeneralizedAlpha => (
                0,
                format!(
                    "generalized-alpha rho_inf {} at {} steps per mesh cycle",
                    d.rho_infinity, d.steps_per_mesh_cycle
                ),
            ),
            IntegratorKind::Rk45 => {
                (1, format!("RK 5(4) at relative tolerance {:e}", d.simulation_relative_tolerance))
            }
        };
        let default = if kind == d.integrator { " (the default)" } else { "" };
        println!("integrator {code}: {integrator}{default}");
        println!(
            "  {:<22} {:>12} {:>14} {:>14} {:>12} {:>10}",
            "fidelity", "step", "FMU per step", "native/step", "overhead", "real time"
        );
        for (name, fid_code, fidelity) in [
            ("torsional", 0, Fidelity::Torsional),
            ("transverse-torsional", 1, Fidelity::TransverseTorsional),
        ] {
            for (label, h) in [("1 mesh cycle", 1.0 / fm), ("1 ms", 1e-3)] {
                let f = fmu_run(fid_code, code, h, span);
                let n = native_run(fidelity, kind, h, span);
                println!(
                    "  {name:<22} {label:>12} {:>11.1} µs {:>11.1} µs {:>11.1} % {:>9.3}×",
                    f * 1e6,
                    n * 1e6,
                    100.0 * (f / n - 1.0),
                    h / f
                );
            }
        }
    }
    println!(
        "E_h of the default (RK 5(4) at {:e}) against 1e-10: window of 34 mesh cycles after 34",
        d.simulation_relative_tolerance
    );
    for (name, fidelity) in
        [("torsional", Fidelity::Torsional), ("transverse-torsional", Fidelity::TransverseTorsional)]
    {
        for rpm in [3000.0, 8000.0] {
            println!(
                "  {name:<22} {rpm:>6} rpm  E_h {:.2e}",
                harmonic_error(fidelity, rpm, d.simulation_relative_tolerance)
            );
        }
    }
}
