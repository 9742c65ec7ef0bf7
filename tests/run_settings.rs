//! The run settings are a value apart from the gear set, built and changed
//! only through the scene's rules for them: every problem named by its scene
//! key, all at once, the same rule whichever way the value comes in.

use planetwear::model::run::RunSettings;
use planetwear::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use planetwear::scene::{Fidelity, IntegratorKind, Problem, Scene, SceneError};

fn problems(e: SceneError) -> Vec<Problem> {
    match e {
        SceneError::Invalid { problems } => problems,
        other => panic!("expected a list of problems, got {other}"),
    }
}

fn keys(e: SceneError) -> Vec<String> {
    problems(e).into_iter().map(|p| p.name).collect()
}

fn example_run() -> RunSettings {
    Scene::example_2004().validate_with_run().expect("the example is valid").1
}

#[test]
fn the_scene_gives_the_gear_set_and_its_run_settings_in_si() {
    let scene = Scene::example_2004();
    let (set, run) = scene.validate_with_run().unwrap();
    assert_eq!(set, scene.validate().unwrap());
    let d = &scene.dynamics;
    assert_eq!(run.input_speed(), d.input_speed);
    assert_eq!(run.integrator(), d.integrator);
    assert_eq!(run.relative_tolerance(), d.relative_tolerance);
    assert_eq!(run.simulation_relative_tolerance(), d.simulation_relative_tolerance);
    assert_eq!(run.samples_per_mesh_cycle(), d.samples_per_mesh_cycle as usize);
    assert_eq!(run.steps_per_mesh_cycle(), d.steps_per_mesh_cycle as usize);
    // The terms of the equations of motion are the gear set's.
    assert_eq!(set.fidelity(), d.fidelity);
    assert_eq!(set.mesh_damping_ratio(), d.mesh_damping_ratio);
    assert_eq!(set.drive(), d.drive);
    assert_eq!(set.shaft_stiffness(), d.shaft_stiffness_nm_per_rad);
}

#[test]
fn a_change_of_the_run_settings_is_checked_and_names_every_key_at_once() {
    let run = example_run();
    let e = run
        .with(|d| {
            d.relative_tolerance = 1e-17;
            d.samples_per_mesh_cycle = 2;
            d.input_speed = f64::NAN;
            d.measured_revolutions = 0.0;
        })
        .unwrap_err();
    let found = keys(e);
    for key in [
        "dynamics.relative_tolerance",
        "dynamics.samples_per_mesh_cycle",
        "dynamics.input_speed_rpm",
        "dynamics.measured_revolutions",
    ] {
        assert!(found.iter().any(|k| k == key), "{key} not among {found:?}");
    }
    assert_eq!(found.len(), 4, "{found:?}");
    // A change within the rules gives new settings and leaves the old ones.
    let tight = run
        .with(|d| {
            d.integrator = IntegratorKind::Rk45;
            d.relative_tolerance = 1e-10;
        })
        .unwrap();
    assert_eq!(tight.relative_tolerance(), 1e-10);
    assert_eq!(run.relative_tolerance(), example_run().relative_tolerance());
    assert_eq!(tight.samples_per_mesh_cycle(), run.samples_per_mesh_cycle());
    // The one constructor refuses what the change refuses.
    let mut values = *run.values();
    values.steps_per_mesh_cycle = 3;
    assert_eq!(keys(RunSettings::new(values).unwrap_err()), ["dynamics.steps_per_mesh_cycle"]);
    values.steps_per_mesh_cycle = 4;
    assert_eq!(RunSettings::new(values).unwrap().steps_per_mesh_cycle(), 4);
}

#[test]
fn the_scene_lists_run_setting_and_model_problems_together() {
    let mut s = Scene::example_2004();
    s.dynamics.relative_tolerance = 0.5;
    s.dynamics.mesh_damping_ratio = 1.5;
    s.sun.teeth = 3;
    let found = keys(s.validate_with_run().unwrap_err());
    for key in ["dynamics.relative_tolerance", "dynamics.mesh_damping_ratio", "sun.teeth"] {
        assert!(found.iter().any(|k| k == key), "{key} not among {found:?}");
    }
    // `validate` alone checks the run settings too: a scene is valid only
    // with all its keys.
    let mut s = Scene::example_2004();
    s.dynamics.rho_infinity = 2.0;
    assert_eq!(keys(s.validate().unwrap_err()), ["dynamics.rho_infinity"]);
}

#[test]
fn the_input_speed_rule_is_the_same_from_the_scene_and_from_a_change() {
    let run = example_run();
    for (rpm, ok) in [(1.0e6, true), (-1.0e6, true), (0.0, true), (2.0e6, false), (f64::INFINITY, false)] {
        let mut s = Scene::example_2004();
        s.dynamics.input_speed = rpm_to_rad_per_s(rpm);
        let from_scene = s.validate_with_run();
        let from_change = run.with(|d| d.input_speed = rpm_to_rad_per_s(rpm));
        assert_eq!(from_scene.is_ok(), ok, "{rpm} rpm from the scene");
        assert_eq!(from_change.is_ok(), ok, "{rpm} rpm as a change");
        if !ok {
            let (a, b) = (problems(from_scene.unwrap_err()), problems(from_change.unwrap_err()));
            assert_eq!(a.len(), 1);
            assert_eq!(b.len(), 1);
            assert_eq!((&a[0].name, &a[0].reason), (&b[0].name, &b[0].reason));
            assert_eq!(a[0].name, "dynamics.input_speed_rpm");
            // Shown in rpm, the key's unit: as written, or converted back.
            assert_eq!(a[0].value, rpm.to_string());
            assert_eq!(b[0].value, rad_per_s_to_rpm(rpm_to_rad_per_s(rpm)).to_string());
        }
    }
}

#[test]
fn studies_change_the_fidelity_through_the_scene_not_the_run_settings() {
    // Fidelity is a term of the equations: another fidelity is another gear
    // set, built from its scene, with the same run settings.
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = Fidelity::Torsional;
    let (torsional, run_t) = s.validate_with_run().unwrap();
    let (full, run_f) = Scene::example_2004().validate_with_run().unwrap();
    assert_eq!(torsional.fidelity(), Fidelity::Torsional);
    assert_eq!(full.fidelity(), Fidelity::TransverseTorsional);
    assert_eq!(run_t, run_f);
    assert_eq!(torsional.bodies(), full.bodies());
}

/// The simulation's own tolerance (the FMU's `relativeTolerance`) is checked
/// by the rule of `relative_tolerance` and named by its own key; it is apart
/// from the marching sweep's.
#[test]
fn the_simulation_tolerance_is_checked_under_its_own_key() {
    for bad in [1e-17, 0.5, f64::NAN, f64::INFINITY, 0.0] {
        let mut s = Scene::example_2004();
        s.dynamics.simulation_relative_tolerance = bad;
        let p = problems(s.validate_with_run().unwrap_err());
        assert_eq!(p.len(), 1, "{p:?}");
        assert_eq!(p[0].name, "dynamics.simulation_relative_tolerance");
        assert!(p[0].to_string().contains("1e-14"), "{}", p[0]);
    }
    let run = example_run();
    let changed = run.with(|d| d.simulation_relative_tolerance = 1e-9).unwrap();
    assert_eq!(changed.simulation_relative_tolerance(), 1e-9);
    assert_eq!(changed.relative_tolerance(), run.relative_tolerance());
}
