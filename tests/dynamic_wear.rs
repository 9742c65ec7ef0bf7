//! Wear driven by the tooth loads of a dynamic run: the low-speed limit, the
//! resonant speed of the example, the load balance of a passage, and the
//! option's bookkeeping.
//!
//! The cases run on the uncalibrated reading of the example
//! (`Scene::example_2004_annulus`), whose figures they pin; the calibrated
//! example's own laws and figures: tests/calibrated_example.rs.

use planetwear::model::gear::{GearSet, MeshKind};
use planetwear::model::mesh::PathOfContact;
use planetwear::model::run::RunSettings;
use planetwear::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use planetwear::scene::{Fidelity, Scene};
use planetwear::wear::archard::{CycleWear, Limit, PressureSource, WearError, WearSettings};
use planetwear::wear::compare::{compare_sources, SourceComparison};
use planetwear::wear::flank::Flank;
use planetwear::wear::stepper::dynamic_cycle;
use planetwear::wear::stepper::WearModel;

fn example() -> GearSet {
    Scene::example_2004_annulus().validate().unwrap()
}

/// The example with the torsional dynamic model: its statics hold the
/// central members on their axes, as the quasi-static LTCA does.
fn torsional() -> GearSet {
    let mut s = Scene::example_2004_annulus();
    s.dynamics.fidelity = Fidelity::Torsional;
    s.validate().unwrap()
}

/// The run settings of the example's dynamic runs.
fn run_settings() -> RunSettings {
    Scene::example_2004_annulus().validate_with_run().unwrap().1
}

fn model(set: &GearSet) -> WearModel {
    WearModel::with_run(set, &run_settings(), WearSettings::for_set(set)).unwrap()
}

fn max_wear(c: &CycleWear, flank: Flank) -> f64 {
    c.flank(flank, 0).unwrap().max_wear().0
}

/// Line load [N/mm] of a force [N] on the example's face width.
fn per_mm(set: &GearSet, force: f64) -> f64 {
    force / (set.sun().face_width.min(set.planet().face_width) * 1e3)
}

fn print(c: &SourceComparison) {
    for f in &c.flanks {
        println!(
            "{} rpm {}: quasi-static {:.4e} m at {:.2}°, dynamic {:.4e} m at {:.2}°, ratio {:.4}, largest difference {:.2} %",
            rad_per_s_to_rpm(c.speed),
            f.flank.name(),
            f.quasi_static_max,
            f.quasi_static_max_roll.to_degrees(),
            f.dynamic_max,
            f.dynamic_max_roll.to_degrees(),
            f.ratio,
            100.0 * f.largest_difference
        );
    }
}

#[test]
fn in_the_low_speed_limit_the_dynamic_loads_give_the_quasi_static_wear() {
    // 100 rpm: f_m = 56.7 Hz, two orders of magnitude below the torsional
    // model's first mode; the steady state is the statics of the model, which
    // for the torsional level is the whole-set LTCA's (central members on
    // their axes). Measured: largest pointwise difference 0.7 % (sun) and
    // 0.9 % (planet) of the quasi-static maximum, maxima at the same grid
    // point, largest pair load 287.6 vs 287.5 N/mm.
    let set = torsional();
    let wear = model(&set);
    let c = compare_sources(&wear, &wear.unworn(), rpm_to_rad_per_s(100.0)).unwrap();
    print(&c);
    for flank in [Flank::SunDrive, Flank::PlanetSunSide] {
        let f = c.flank(flank).unwrap();
        assert!(f.largest_difference < 0.03, "{}: {} of the maximum", flank.name(), f.largest_difference);
        assert!((f.ratio - 1.0).abs() < 0.03, "{}: ratio {}", flank.name(), f.ratio);
        assert_eq!(f.dynamic_max_roll, f.quasi_static_max_roll, "{}", flank.name());
    }
    let m = c.mesh(MeshKind::SunPlanet).unwrap();
    println!(
        "largest pair load: dynamic {} N, quasi-static {} N",
        m.dynamic_max_pair_load, m.quasi_static_max_pair_load
    );
    assert!(
        (m.dynamic_max_pair_load / m.quasi_static_max_pair_load - 1.0).abs() < 0.01,
        "largest pair load dynamic {} N vs quasi-static {} N",
        m.dynamic_max_pair_load,
        m.quasi_static_max_pair_load
    );
}

#[test]
fn at_the_resonant_speed_the_dynamic_loads_wear_the_flanks_more() {
    // 5000 rpm: 2×f_m on the 5693 Hz rotational mode of the example
    // (transverse–torsional). Measured: F(rms) of the sun mesh 94.6 N/mm
    // against a mean of 263.1 N/mm; largest pair load 345.7 N/mm dynamic
    // against 287.5 N/mm quasi-static (1.20×); largest wear per cycle 1.051×
    // (sun) and 1.050× (planet) the quasi-static one, and 1.232× and 1.179×
    // the same model's at 100 rpm (whose floating sun shares the load more
    // evenly than the LTCA's fixed axes: 0.853× and 0.890× the quasi-static).
    let set = example();
    let wear = model(&set);
    let state = wear.unworn();
    let c = compare_sources(&wear, &state, rpm_to_rad_per_s(5000.0)).unwrap();
    print(&c);
    let m = c.mesh(MeshKind::SunPlanet).unwrap();
    let (mean, rms) = (per_mm(&set, m.mean_mesh_force), per_mm(&set, m.rms_mesh_force));
    assert!(
        (85.0..105.0).contains(&rms) && (mean - 263.1).abs() < 1.0,
        "F(rms) {rms} N/mm, mean {mean} N/mm"
    );
    assert!(
        m.dynamic_max_pair_load > 1.15 * m.quasi_static_max_pair_load,
        "largest pair load dynamic {} N vs quasi-static {} N",
        m.dynamic_max_pair_load,
        m.quasi_static_max_pair_load
    );
    let (slow, _) = dynamic_cycle(&wear, &state, rpm_to_rad_per_s(100.0)).unwrap();
    let (off, _) = dynamic_cycle(&wear, &state, rpm_to_rad_per_s(3000.0)).unwrap();
    for flank in [Flank::SunDrive, Flank::PlanetSunSide] {
        let f = c.flank(flank).unwrap();
        assert!(f.ratio > 1.02, "{}: dynamic/quasi-static {}", flank.name(), f.ratio);
        let resonant = f.dynamic_max / max_wear(&slow, flank);
        assert!(resonant > 1.10, "{}: 5000 rpm / 100 rpm {resonant}", flank.name());
        // Off resonance (3000 rpm) the dynamics adds little to the model's
        // low-speed wear: measured 0.997× (sun), 1.016× (planet).
        let off_ratio = max_wear(&off, flank) / max_wear(&slow, flank);
        assert!((off_ratio - 1.0).abs() < 0.03, "{}: 3000 rpm / 100 rpm {off_ratio}", flank.name());
    }
}

/// ∫ f ds by the trapezoid over the positions [N·m].
fn integral(position: &[f64], load: &[f64]) -> f64 {
    position.windows(2).zip(load.windows(2)).map(|(x, y)| 0.5 * (y[0] + y[1]) * (x[1] - x[0])).sum()
}

#[test]
fn a_pair_carries_the_mean_mesh_force_times_the_base_pitch() {
    // In a steady state that repeats every mesh cycle, F(s) = Σ_k f(s + k p_b),
    // so ∫ f ds over a pair's passage = p_b × the mean mesh force. Checked on
    // the recorded profiles and on the R + 1 positions the wear reads, at the
    // resonant speed, and on the quasi-static passage (mean planet load F).
    let set = example();
    let wear = model(&set);
    let state = wear.unworn();
    let (cycle, loads) = dynamic_cycle(&wear, &state, rpm_to_rad_per_s(5000.0)).unwrap();
    let pb = PathOfContact::new(&set, MeshKind::SunPlanet).base_pitch;
    let passage = cycle.mesh(MeshKind::SunPlanet).unwrap();
    for (p, profile) in loads.of(MeshKind::SunPlanet).enumerate() {
        let expected = pb * profile.mean_mesh_force;
        let recorded = profile.load_integral();
        let read = integral(&passage.position, &passage.pair_load[p]);
        println!("planet {p}: p_b F̄ = {expected:.6e}, recorded {recorded:.6e}, read {read:.6e} N·m");
        assert!((recorded / expected - 1.0).abs() < 2e-3, "planet {p}: {recorded} vs {expected}");
        assert!((read / expected - 1.0).abs() < 5e-3, "planet {p}: {read} vs {expected}");
    }
    let quasi = wear.cycle(&state).unwrap();
    let passage = quasi.mesh(MeshKind::SunPlanet).unwrap();
    let expected = pb * set.mesh_load_per_planet();
    for (p, load) in passage.pair_load.iter().enumerate() {
        let read = integral(&passage.position, load);
        println!("quasi-static planet {p}: p_b F = {expected:.6e}, read {read:.6e} N·m");
        assert!((read / expected - 1.0).abs() < 5e-3, "planet {p}: {read} vs {expected}");
    }
}

#[test]
fn the_source_is_an_option_of_the_wear_model() {
    let set = example();
    // A speed that cannot be run is refused, naming the setting.
    for bad in [0.0, -100.0, f64::NAN] {
        let settings = WearSettings {
            source: PressureSource::Dynamic { speed: rpm_to_rad_per_s(bad) },
            ..WearSettings::default()
        };
        match WearModel::new(&set, settings) {
            Err(WearError::InvalidSetting { name, .. }) => assert_eq!(name, "source.speed_rpm"),
            other => panic!("{bad} rpm: {other:?}"),
        }
        let wear = model(&set);
        let err = wear
            .cycle_with(&wear.unworn(), PressureSource::Dynamic { speed: rpm_to_rad_per_s(bad) })
            .unwrap_err();
        assert!(err.to_string().contains("source.speed_rpm"), "{err}");
    }
    // The default source is the quasi-static one, and an explicit choice of it
    // gives the same cycle.
    let wear = model(&set);
    let state = wear.unworn();
    let a = wear.cycle(&state).unwrap();
    let b = wear.cycle_with(&state, PressureSource::QuasiStatic).unwrap();
    assert_eq!(a.source, PressureSource::QuasiStatic);
    assert_eq!(a, b);
    // The settings' source drives `cycle` and `step`: an update from the
    // dynamic loads reaches the update depth on its limiting flank, as a
    // quasi-static one does.
    let source = PressureSource::Dynamic { speed: rpm_to_rad_per_s(5000.0) };
    let settings = WearSettings { source, ..WearSettings::for_set(&set) };
    // The dynamic loads need run settings: a model without them refuses the
    // source at once, and a quasi-static model refuses a dynamic cycle.
    assert!(matches!(WearModel::new(&set, settings), Err(WearError::NoRunSettings)));
    let quasi_static = WearModel::new(&set, WearSettings::for_set(&set)).unwrap();
    assert!(matches!(quasi_static.cycle_with(&state, source), Err(WearError::NoRunSettings)));
    let dynamic = WearModel::with_run(&set, &run_settings(), settings).unwrap();
    let c = dynamic.cycle(&state).unwrap();
    assert_eq!(c.source, source);
    let next = dynamic.step(&state, Limit::Update).unwrap();
    let same = wear.step_with(&state, Limit::Update, source).unwrap();
    assert_eq!(next, same);
    let record = &next.history[0];
    let top = record.new_wear.iter().map(|e| e.depth).fold(0.0, f64::max);
    assert!((top / dynamic.settings().update_depth - 1.0).abs() < 1e-9, "{top}");
    // The dynamic cycle's wear per cycle is what it applied: revolutions ×
    // cycles per revolution × wear per cycle at the deepest point.
    let sun = c.flank(Flank::SunDrive, 0).unwrap().max_wear().0;
    let expected = record.revolutions * dynamic.cycles_per_revolution().sun * sun;
    assert!((next.deepest_on(Flank::SunDrive).depth / expected - 1.0).abs() < 1e-9);
}

#[test]
fn the_dynamic_source_is_written_and_read_in_rpm_as_before() {
    // Held in rad/s, the source keeps its file form: `speed_rpm` in rpm. A
    // document written before the core moved to SI reads to the same speed
    // and is written back unchanged.
    let old = r#"{"kind":"dynamic","speed_rpm":3000.0}"#;
    let source: PressureSource = serde_json::from_str(old).unwrap();
    assert_eq!(source, PressureSource::Dynamic { speed: rpm_to_rad_per_s(3000.0) });
    assert_eq!(serde_json::to_string(&source).unwrap(), old);
    let mut settings = serde_json::to_value(WearSettings::default()).unwrap();
    settings["source"] = serde_json::json!({ "kind": "dynamic", "speed_rpm": 4250.5 });
    let read: WearSettings = serde_json::from_value(settings).unwrap();
    assert_eq!(read.source, PressureSource::Dynamic { speed: rpm_to_rad_per_s(4250.5) });
    let written = serde_json::to_value(read).unwrap();
    assert_eq!(written["source"]["speed_rpm"], serde_json::json!(4250.5));
    assert_eq!(PressureSource::QuasiStatic, serde_json::from_str(r#"{"kind":"quasi_static"}"#).unwrap());
}
