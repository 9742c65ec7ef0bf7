//! The worn-profile state file: exact round trip, atomic writes, and a
//! refusal with its reason for every way a file can be wrong.

use std::sync::OnceLock;

use planetwear::contact::ltca::MeshModel;
use planetwear::geometry::profile::ProfileDeviation;
use planetwear::model::gear::{GearSet, MeshKind};
use planetwear::scene::units::{gpa_to_pa, mm_to_m};
use planetwear::scene::Scene;
use planetwear::wear::archard::{Limit, WearSettings};
use planetwear::wear::flank::Flank;
use planetwear::wear::state::{content_checksum, GearSetPrint, WornState, WornStateError};
use planetwear::wear::state::{read_worn_state, write_worn_state, StateFileError};
use planetwear::wear::stepper::WearModel;
use proptest::prelude::*;
use serde_json::Value;

#[path = "support/in_phase.rs"]
mod in_phase;

fn example() -> GearSet {
    Scene::example_2004().validate().unwrap()
}

/// The example after one update (computed once per test binary).
fn worn() -> &'static WornState {
    static STATE: OnceLock<WornState> = OnceLock::new();
    STATE.get_or_init(|| {
        let model = WearModel::new(&example(), WearSettings::default()).unwrap();
        model.step(&model.unworn(), Limit::Update).unwrap()
    })
}

fn document() -> Value {
    serde_json::from_str(&worn().to_json().unwrap()).unwrap()
}

/// Writes the checksum of an edited document's content, as a careful
/// hand edit would.
fn reseal(doc: &mut Value) {
    let sum = content_checksum(&doc["content"]);
    doc["checksum"] = Value::String(sum);
}

fn read(doc: &Value) -> Result<WornState, WornStateError> {
    WornState::from_json(&doc.to_string(), &example())
}

#[test]
fn the_document_round_trips_bit_identically() {
    let state = worn();
    let text = state.to_json().unwrap();
    let back = WornState::from_json(&text, &example()).unwrap();
    assert_eq!(&back, state);
    let bits = |s: &WornState| -> Vec<u64> {
        Flank::ALL
            .iter()
            .flat_map(|f| {
                s.flanks.get(*f).iter().flat_map(|d| d.roll.iter().chain(&d.depth)).map(|x| x.to_bits())
            })
            .collect()
    };
    assert_eq!(bits(&back), bits(state));
    assert!(text.contains("\"format\": \"planetwear-worn-profile\"") && text.contains("\"version\": 1"));
    // Reformatting is not corruption: the checksum is over the content's values.
    let compact = serde_json::to_string(&serde_json::from_str::<Value>(&text).unwrap()).unwrap();
    assert_eq!(&WornState::from_json(&compact, &example()).unwrap(), state);
}

#[test]
fn the_file_is_written_atomically_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("worn.json");
    write_worn_state(&path, &worn().clone()).unwrap();
    assert_eq!(&read_worn_state(&path, &example()).unwrap(), worn());
    // Overwriting replaces the file whole; no temporary file is left behind.
    let mut unworn = WearModel::new(&example(), WearSettings::default()).unwrap().unworn();
    unworn.gear_set.name = "renamed".into();
    write_worn_state(&path, &unworn).unwrap();
    assert_eq!(read_worn_state(&path, &example()).unwrap(), unworn);
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into())
        .collect();
    assert_eq!(names, vec!["worn.json".to_string()]);
    // A state that cannot be written leaves the old file as it was.
    let mut bad = worn().clone();
    bad.flanks.sun_drive[0].depth[3] = f64::NAN;
    let before = std::fs::read(&path).unwrap();
    match write_worn_state(&path, &bad) {
        Err(StateFileError::State { source, .. }) => {
            assert_eq!(*source, WornStateError::NonFinite { field: "flanks.sun_drive[0].depth[3]".into() })
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
    assert_eq!(std::fs::read(&path).unwrap(), before);
    // A missing file and a missing directory are I/O errors naming the path.
    let missing = dir.path().join("no/such/dir/worn.json");
    let e = read_worn_state(&missing, &example()).unwrap_err();
    assert!(matches!(e, StateFileError::Io { .. }) && e.to_string().contains("no/such/dir"), "{e}");
    assert!(matches!(write_worn_state(&missing, worn()), Err(StateFileError::Io { .. })));
}

#[test]
fn text_that_is_not_json_or_is_cut_short_is_refused() {
    let set = example();
    assert!(matches!(WornState::from_json("hello", &set), Err(WornStateError::NotJson { line: 1, .. })));
    let text = worn().to_json().unwrap();
    for cut in [1, text.len() / 3, text.len() - 2] {
        match WornState::from_json(&text[..cut], &set) {
            Err(e @ WornStateError::Truncated { .. }) => assert!(e.to_string().contains("truncated")),
            other => panic!("cut at {cut}: {other:?}"),
        }
    }
    // A number beyond f64 is not a finite value.
    let text = text.replacen("\"kappa\": 1", "\"kappa\": 1e999", 1);
    assert!(matches!(WornState::from_json(&text, &set), Err(WornStateError::NonFinite { .. })));
}

#[test]
fn another_format_or_version_is_refused() {
    let mut doc = document();
    doc["format"] = Value::String("planetwear-fmu-state".into());
    let e = read(&doc).unwrap_err();
    assert_eq!(
        e,
        WornStateError::Format {
            found: "\"planetwear-fmu-state\"".into(),
            expected: "planetwear-worn-profile"
        }
    );
    let mut doc = document();
    doc.as_object_mut().unwrap().remove("format");
    assert!(matches!(read(&doc), Err(WornStateError::Format { found, .. }) if found == "absent"));
    let mut doc = document();
    doc["version"] = Value::from(2);
    let e = read(&doc).unwrap_err();
    assert_eq!(e, WornStateError::Version { found: "2".into(), supported: 1 });
    assert!(e.to_string().contains("version 2") && e.to_string().contains("reads version 1"), "{e}");
}

#[test]
fn an_altered_value_fails_the_checksum() {
    let mut doc = document();
    doc["content"]["flanks"]["sun_drive"][0]["depth"][5] = Value::from(1.0e-6);
    match read(&doc) {
        Err(e @ WornStateError::Checksum { .. }) => assert!(e.to_string().contains("altered"), "{e}"),
        other => panic!("{other:?}"),
    }
    let mut doc = document();
    doc["content"]["kappa"] = Value::from(0);
    assert!(matches!(read(&doc), Err(WornStateError::Checksum { .. })));
    let mut doc = document();
    doc["checksum"] = Value::String("fnv1a64:0000000000000000".into());
    assert!(matches!(read(&doc), Err(WornStateError::Checksum { .. })));
}

#[test]
fn a_state_of_another_gear_set_is_refused_with_what_differs() {
    let text = worn().to_json().unwrap();
    let other = in_phase::in_phase_scene().validate().unwrap();
    match WornState::from_json(&text, &other) {
        Err(e @ WornStateError::Foreign { .. }) => {
            let m = e.to_string();
            assert!(m.contains("'example-2004'") && m.contains("'in-phase'"), "{m}");
            assert!(
                m.contains("ring.teeth is 70 in the state and 72 here") && m.contains("and 3 more"),
                "{m}"
            );
            let WornStateError::Foreign { differences, .. } = e else { unreachable!() };
            let teeth = differences.iter().find(|d| d.name == "sun.teeth").unwrap();
            assert_eq!((teeth.state, teeth.expected), (Some(34.0), Some(36.0)));
            assert_eq!(differences.len(), 9, "{differences:?}");
        }
        other => panic!("{other:?}"),
    }
    // The name and the operating point are not the gear set: the same
    // geometry under another name and torque reads the state.
    let mut same = Scene::example_2004();
    same.name = "example-2004 at half load".into();
    same.operation.input_torque_nm = 375.0;
    let same = same.validate().unwrap();
    assert_eq!(GearSetPrint::of(&same).fingerprint, GearSetPrint::of(&example()).fingerprint);
    assert!(WornState::from_json(&text, &same).is_ok());
    // A material change is another gear set for wear (Hertz).
    let mut soft = Scene::example_2004();
    soft.material.youngs_modulus = gpa_to_pa(110.0);
    let soft = soft.validate().unwrap();
    let e = WornState::from_json(&text, &soft).unwrap_err();
    assert!(e.to_string().contains("material.youngs_modulus"), "{e}");
}

#[test]
fn non_finite_negative_and_misshapen_values_are_refused_by_name() {
    let edit = |f: &dyn Fn(&mut Value)| {
        let mut doc = document();
        f(&mut doc["content"]);
        reseal(&mut doc);
        read(&doc)
    };
    // serde_json writes a non-finite float as null.
    assert_eq!(
        edit(&|c| c["flanks"]["sun_drive"][0]["depth"][3] = Value::Null).unwrap_err(),
        WornStateError::NonFinite { field: "flanks.sun_drive[0].depth[3]".into() }
    );
    assert_eq!(
        edit(&|c| c["revolutions"] = Value::Null).unwrap_err(),
        WornStateError::NonFinite { field: "revolutions".into() }
    );
    match edit(&|c| c["flanks"]["planet_sun_side"][0]["depth"][7] = Value::from(-1e-6)) {
        Err(e @ WornStateError::Negative { .. }) => {
            assert!(e.to_string().contains("flanks.planet_sun_side[0].depth[7]"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        edit(&|c| c["cycles"]["sun"] = Value::from(-3.0)),
        Err(WornStateError::Negative { field, .. }) if field == "cycles.sun"
    ));
    match edit(&|c| {
        c["flanks"]["ring_drive"][0]["depth"].as_array_mut().unwrap().pop();
    }) {
        Err(e @ WornStateError::GridShape { .. }) => {
            assert!(
                e.to_string().contains("flanks.ring_drive[0]") && e.to_string().contains("same length"),
                "{e}"
            )
        }
        other => panic!("{other:?}"),
    }
    match edit(&|c| c["flanks"]["sun_drive"][0]["roll"][10] = c["flanks"]["sun_drive"][0]["roll"][9].clone())
    {
        Err(e @ WornStateError::GridShape { .. }) => {
            assert!(
                e.to_string().contains("flanks.sun_drive[0].roll[10]") && e.to_string().contains("increase")
            )
        }
        other => panic!("{other:?}"),
    }
    match edit(&|c| {
        let extra = c["flanks"]["sun_coast"][0].clone();
        c["flanks"]["sun_coast"].as_array_mut().unwrap().push(extra);
    }) {
        Err(e @ WornStateError::GridShape { .. }) => assert!(e.to_string().contains("face slices"), "{e}"),
        other => panic!("{other:?}"),
    }
    assert!(matches!(edit(&|c| c["kappa"] = Value::from(3)), Err(WornStateError::Inconsistent { .. })));
    assert!(matches!(
        edit(&|c| c["revolutions"] = Value::from(1.0)),
        Err(WornStateError::Inconsistent { reason }) if reason.contains("add up")
    ));
    assert!(matches!(
        edit(&|c| {
            c.as_object_mut().unwrap().remove("history");
        }),
        Err(WornStateError::Malformed { reason }) if reason.contains("history")
    ));
}

#[test]
fn the_state_gives_each_mesh_its_four_flanks() {
    // The planet's sun-side flank is gear 2's drive flank of the sun mesh
    // and gear 1's back flank of the ring mesh; its ring-side flank the
    // other way round.
    let s = worn();
    let (sp, rp) = s.mesh_flanks();
    assert_eq!((sp.len(), rp.len()), (1, 1));
    assert_eq!(sp[0].gear1_drive, s.flanks.sun_drive[0]);
    assert_eq!(sp[0].gear1_back, s.flanks.sun_coast[0]);
    assert_eq!(sp[0].gear2_drive, s.flanks.planet_sun_side[0]);
    assert_eq!(sp[0].gear2_back, s.flanks.planet_ring_side[0]);
    assert_eq!(rp[0].gear1_drive, s.flanks.planet_ring_side[0]);
    assert_eq!(rp[0].gear1_back, s.flanks.planet_sun_side[0]);
    assert_eq!(rp[0].gear2_drive, s.flanks.ring_drive[0]);
    assert_eq!(rp[0].gear2_back, s.flanks.ring_coast[0]);
    // Loaded into the contact model, a uniform 3 µm on the sun's drive flank
    // raises the sun mesh's unloaded separation by 3 µm on the path.
    let set = example();
    let mut uniform = WearModel::new(&set, WearSettings::default()).unwrap().unworn();
    for d in &mut uniform.flanks.sun_drive[0].depth {
        *d = 3e-6;
    }
    let worn_model = uniform.set_model(&set);
    let fresh = MeshModel::new(&set, MeshKind::SunPlanet, &Default::default());
    let p = fresh.path().clone();
    for i in 1..10 {
        let s = p.start + (p.end - p.start) * i as f64 / 10.0;
        let dg = worn_model.sun_planet.separation.drive.at(s) - fresh.separation.drive.at(s);
        assert!((dg - 3e-6).abs() < 2e-8, "separation change {dg} at {s}");
    }
    assert_eq!(uniform.face_slices(), 1);
    assert!(uniform.flanks.get(Flank::SunDrive)[0] != ProfileDeviation::none());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn any_finite_depths_round_trip_bit_identically(
        depths in prop::collection::vec(
            prop_oneof![0.0f64..1e-4, (0u64..1u64 << 52).prop_map(f64::from_bits), 1e-30f64..1e30],
            50,
        ),
        ring_cycles in 0.0f64..1e9,
    ) {
        let set = example();
        let model = WearModel::new(&set, WearSettings::default()).unwrap();
        let mut s = model.unworn();
        s.flanks.planet_sun_side[0].depth = depths.clone();
        s.revolutions = 0.0;
        s.cycles.ring = ring_cycles;
        // The document's round trip: every check but the gear set's (depths
        // beyond a quarter of the tooth are refused for a set, docs/LIMITS.md).
        let back = WornState::from_json_any_set(&s.to_json().unwrap()).unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        prop_assert_eq!(bits(&back.flanks.planet_sun_side[0].depth), bits(&depths));
        prop_assert_eq!(back.cycles.ring.to_bits(), ring_cycles.to_bits());
        prop_assert_eq!(back, s);
    }
}

#[test]
fn a_set_entered_in_other_units_is_the_same_set() {
    // The FMU's parameters carry the example in SI units converted from the
    // scene's degrees and millimetres: rounding in the last bits must not make
    // the example's own worn states foreign, while a real change still does.
    let mut scene = planetwear::scene::Scene::example_2004();
    let set = scene.validate().unwrap();
    let state = planetwear::wear::state::WornState::unworn(&set, 10, 1);
    scene.planet.pressure_angle *= 1.0 + 1e-15;
    scene.ring.tooth_thickness *= 1.0 + 2e-16;
    let rounded = scene.validate().unwrap();
    assert_ne!(
        planetwear::wear::state::GearSetPrint::of(&rounded).fingerprint,
        state.gear_set.fingerprint,
        "the test must exercise a different fingerprint"
    );
    state.check_gear_set(&rounded).expect("the same set in other units");
    scene.ring.tooth_thickness *= 1.0 + 1e-6;
    let changed = scene.validate().unwrap();
    let e = state.check_gear_set(&changed).unwrap_err().to_string();
    assert!(e.contains("ring.tooth_thickness"), "{e}");
}

#[test]
fn a_state_file_moves_the_unloaded_separation_and_the_static_te_of_the_dynamic_model() {
    // A uniform 4 µm on the sun's drive flank and 1 µm on the planet's
    // sun-side flank, written as a state file and read back the way the CLI
    // (--wear-state) and the FMU (wearStateFile) read it: the sun–planet
    // mesh's unloaded separation rises by 5 µm along the whole path, and the
    // static transmission error under the example's load by 5 µm, in the
    // dynamic model's contact tables.
    use planetwear::contact::ltca::SetModel;
    use planetwear::dynamics::equations::PlanetaryDynamics;
    use planetwear::dynamics::simulation::Simulation;
    use planetwear::model::gear::MeshKind;
    let (set, run) = planetwear::scene::Scene::example_2004().validate_with_run().unwrap();
    let mut state = planetwear::wear::state::WornState::unworn(&set, 50, 1);
    for d in &mut state.flanks.sun_drive {
        d.depth.iter_mut().for_each(|x| *x = 4e-6);
    }
    for d in &mut state.flanks.planet_sun_side {
        d.depth.iter_mut().for_each(|x| *x = 1e-6);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("uniform.json");
    planetwear::wear::state::write_worn_state(&path, &state).unwrap();
    let read = planetwear::wear::state::read_worn_state(&path, &set).unwrap();
    let (worn, fresh) = (read.set_model(&set), SetModel::new(&set));
    let p = fresh.sun_planet.path().clone();
    let load = set.mesh_load_per_planet();
    let mut worst_te: f64 = 0.0;
    for i in 0..40 {
        let s = p.start + (p.end - p.start) * (f64::from(i) + 0.5) / 40.0;
        let dg = worn.sun_planet.separation.drive.at(s) - fresh.sun_planet.separation.drive.at(s);
        assert!((dg - 5e-6).abs() < 0.02e-6, "separation moved by {dg} at {s}");
        let dte = worn.sun_planet.approach_for(s, load) - fresh.sun_planet.approach_for(s, load);
        worst_te = worst_te.max((dte - 5e-6).abs());
    }
    // Within 3 % (0.15 µm; measured 0.113 µm): where the load passes between pairs the tip-corner
    // contacts (chamfers carry no deviation) of the neighbouring pairs take a little more or less load.
    eprintln!("largest static-TE deviation from 5 µm: {worst_te:e} m");
    assert!(worst_te < 0.15e-6, "static TE moved by 5 µm ± {worst_te}");
    // The same through the simulation's static-TE output (FMU output
    // planet[1].sunStaticTransmissionError).
    let omega = 3000.0 * std::f64::consts::PI / 30.0;
    let a = Simulation::new(&set, &run, PlanetaryDynamics::new(&set, worn).unwrap(), 0.0, omega).unwrap();
    let b = Simulation::new(&set, &run, PlanetaryDynamics::new(&set, fresh).unwrap(), 0.0, omega).unwrap();
    let dte = a.static_transmission_error(0, MeshKind::SunPlanet)
        - b.static_transmission_error(0, MeshKind::SunPlanet);
    assert!((dte - 5e-6).abs() < 0.05e-6, "simulation static TE moved by {dte}");
    // The ring–planet mesh is untouched.
    let dr = a.static_transmission_error(0, MeshKind::RingPlanet)
        - b.static_transmission_error(0, MeshKind::RingPlanet);
    assert!(dr.abs() < 1e-12, "{dr}");
}

/// The example with another Young's modulus: same geometry, other material.
fn other_material() -> GearSet {
    let mut s = Scene::example_2004();
    s.material.youngs_modulus = gpa_to_pa(210.0);
    s.validate().unwrap()
}

#[test]
fn a_state_of_another_material_is_refused_unless_accepted_and_then_recorded() {
    use planetwear::wear::state::StateDifference;
    let text = worn().to_json().unwrap();
    let set = other_material();
    let refused = WornState::from_json(&text, &set).unwrap_err().to_string();
    assert!(
        refused.contains("material.youngs_modulus is 207000000000 in the state and 210000000000 here"),
        "{refused}"
    );
    assert!(
        refused.contains("differences of kind material only: they may be accepted explicitly"),
        "{refused}"
    );
    // Accepting another kind is not enough.
    assert!(WornState::from_json_accepting(&text, &set, &[StateDifference::MeshStiffness]).is_err());
    let (state, accepted) =
        WornState::from_json_accepting(&text, &set, &[StateDifference::Material]).unwrap();
    assert_eq!(accepted.len(), 1);
    assert_eq!(accepted[0].name, "material.youngs_modulus");
    assert_eq!(state.accepted_differences, vec![StateDifference::Material]);
    // The accepted state belongs to the new set, keeps its wear, and says
    // what was accepted in its document; read again it needs no acceptance.
    assert_eq!(state.gear_set, GearSetPrint::of(&set));
    assert_eq!(state.flanks, worn().flanks);
    let written = state.to_json().unwrap();
    let doc: Value = serde_json::from_str(&written).unwrap();
    assert_eq!(doc["content"]["accepted_differences"], serde_json::json!(["material"]));
    assert_eq!(WornState::from_json(&written, &set).unwrap(), state);
    // A state with nothing accepted writes no such key (older readers and
    // checksums are unchanged).
    assert!(!text.contains("accepted_differences"));
    // A step from the accepted state keeps the record.
    let model = WearModel::new(&set, WearSettings::default()).unwrap();
    let next = model.step(&state, Limit::Update).unwrap();
    assert_eq!(next.accepted_differences, vec![StateDifference::Material]);
}

#[test]
fn a_geometry_difference_is_refused_even_with_every_acceptance() {
    use planetwear::wear::state::StateDifference;
    let text = worn().to_json().unwrap();
    let mut s = Scene::example_2004();
    s.material.youngs_modulus = gpa_to_pa(210.0);
    s.sun.face_width = mm_to_m(28.0);
    s.planet.face_width = mm_to_m(28.0);
    s.ring.face_width = mm_to_m(28.0);
    let set = s.validate().unwrap();
    let e = WornState::from_json_accepting(&text, &set, &StateDifference::ALL).unwrap_err().to_string();
    assert!(e.contains("sun.face_width is 0.03 in the state and 0.028 here"), "{e}");
    assert!(e.contains("material.youngs_modulus"), "{e}");
    assert!(e.contains("(a geometry difference, here planet.face_width, ring.face_width, sun.face_width, is never accepted)"), "{e}");
    // Nor can the geometry be named, and the load is never refused.
    let geometry = StateDifference::parse_list("material,geometry").unwrap_err();
    assert!(geometry.contains("'geometry' is not a difference that can be accepted: allowed are material, mesh_stiffness (the geometry is never accepted"), "{geometry}");
    let load = StateDifference::parse_list("load").unwrap_err();
    assert!(load.contains("the operating point is not part of a state's gear set"), "{load}");
    assert_eq!(
        StateDifference::parse_list(" mesh_stiffness, material ,material").unwrap(),
        vec![StateDifference::Material, StateDifference::MeshStiffness]
    );
    assert_eq!(StateDifference::parse_list("").unwrap(), vec![]);
    // The load is not in the print: a state is read at any torque.
    let mut heavier = Scene::example_2004();
    heavier.operation.input_torque_nm = 1500.0;
    assert!(WornState::from_json(&text, &heavier.validate().unwrap()).is_ok());
}
