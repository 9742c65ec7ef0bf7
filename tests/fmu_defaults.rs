//! The FMU's bounds and defaults against the scene's: every min/max of
//! modelDescription.xml is the instance's validation (a value just past it
//! refused, naming the variable; the bound itself not refused by that
//! rule), every start value is the built-in example the command line runs,
//! parameters → scene → parameters is the identity, a relative sceneFile is
//! looked up in the working directory before resources/, and an FMU packed
//! with a scene carries that scene, its start values and its references.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use planetwear::fmi::instance::{scene_values, Instance, DEFAULT_SCENE};
use planetwear::fmi::variables::{vr, Causality, Kind, Settable, Start, VARIABLES};
use planetwear::scene::units::{gpa_to_pa, mm_to_m, rpm_to_rad_per_s};
use planetwear::scene::Scene;

/// A fresh directory under the target directory (the tests' working
/// directory is the package root, so `relative` is its path from there).
fn scratch(name: &str) -> (PathBuf, String) {
    let relative = format!("target/test-scratch/fmu-defaults-{}-{name}", std::process::id());
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(&relative);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    (dir, relative)
}

/// The refusal of exitInitialization with one variable set, or `None`.
fn refusal(kind: Kind, vr: u32, x: f64) -> Option<String> {
    let mut i = Instance::new("bounds", None);
    i.enter_initialization();
    // The gear-data parameters are read with gearData = 1 only.
    let info = VARIABLES.iter().find(|v| v.kind == kind && v.vr == vr).unwrap();
    if info.description.contains("(gearData = 1)") {
        i.set_integer(planetwear::fmi::variables::vr::GEAR_DATA, 1).unwrap();
    }
    let set = match kind {
        Kind::Integer => i.set_integer(vr, x as i32),
        _ => i.set_real(vr, x),
    };
    match set {
        Err(e) => Some(e.message),
        Ok(()) => i.exit_initialization().err().map(|e| e.message),
    }
}

/// The reasons a refusal gives for `name`: the text after `name = value: `
/// on each line that names it, without the scene key's echo.
fn reasons(message: &str, name: &str) -> Vec<String> {
    message
        .lines()
        .filter_map(|l| {
            let l = l.trim_start_matches([' ', '-']);
            let rest = l.strip_prefix(&format!("{name} = "))?;
            let reason = rest.split_once(": ")?.1;
            Some(reason.split(" (the scene's").next().unwrap_or(reason).to_string())
        })
        .collect()
}

#[test]
fn every_bound_of_the_model_description_is_the_instance_s_own() {
    let mut checked = 0;
    for v in VARIABLES.iter().filter(|v| v.min.is_some() || v.max.is_some()) {
        assert!(matches!(v.causality, Causality::Parameter | Causality::Input), "{}", v.name);
        for (bound, outward) in [(v.min, -1.0), (v.max, 1.0)] {
            let Some(b) = bound else { continue };
            let outside = match v.kind {
                Kind::Integer => b + outward,
                _ => b + outward * if b == 0.0 { 1e-12 } else { b.abs() * 1e-9 },
            };
            let refused = refusal(v.kind, v.vr, outside)
                .unwrap_or_else(|| panic!("{} = {outside} (past its bound {b}) is accepted", v.name));
            let why = reasons(&refused, v.name);
            assert!(
                !why.is_empty(),
                "{} = {outside}: the refusal does not name the variable: {refused}",
                v.name
            );
            // At the bound (inclusive, as FMI 2.0 reads min and max) the rule
            // that refused the value past it does not fire; another rule,
            // of the set as a whole, may.
            if let Some(at) = refusal(v.kind, v.vr, b) {
                for r in reasons(&at, v.name) {
                    assert!(
                        !why.contains(&r),
                        "{} = {b} (its bound) is refused by the same rule: {r}",
                        v.name
                    );
                }
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 59, "bounds checked");
}

/// Variables whose value is not the example's by design: none may differ
/// silently.
const DIFFERENT_BY_DESIGN: [&str; 1] = ["harmonicWindowCycles"];

#[test]
fn every_start_value_is_the_built_in_example_s() {
    let example = Scene::example_2004();
    let mut values = scene_values(&example).unwrap();
    // The gear-data parameters (unused with the example's radii) start at
    // the example's gear data.
    let by_data = Scene::builtin("example-2004-gear-data").unwrap();
    for (p, v) in scene_values(&by_data).unwrap() {
        values.entry(p).or_insert(v);
    }
    let mut compared = 0;
    for p in Settable::ALL {
        let info = p.variable().info();
        match (values.get(p), info.start) {
            (Some(Start::Real(x)), Start::Real(s)) => {
                assert!((x - s).abs() <= 1e-12 * x.abs(), "{}: start {s}, the example's {x}", info.name);
                compared += 1;
            }
            (Some(Start::Integer(x)), Start::Integer(s)) => {
                assert_eq!(*x, s, "{}: start {s}, the example's {x}", info.name);
                compared += 1;
            }
            (None, Start::String(_)) => {}
            (None, _) => {
                assert!(DIFFERENT_BY_DESIGN.contains(&info.name), "{} has no scene value", info.name)
            }
            (x, s) => panic!("{}: start {s:?}, the example's {x:?}", info.name),
        }
    }
    // The strings (files, accepted differences, duty bins) have no scene value.
    let strings =
        Settable::ALL.iter().filter(|p| matches!(p.variable().info().start, Start::String(_))).count();
    assert_eq!(strings, 5);
    assert_eq!(compared, Settable::ALL.len() - strings - DIFFERENT_BY_DESIGN.len());
    // The harmonic window: one input revolution for the FMU (its outputs
    // are valid sooner), the measured window of `run` two revolutions; both
    // descriptions say so.
    let set = example.validate().unwrap();
    let cycles_per_revolution = f64::from(set.sun().teeth); // carrier held, sun driven
    let window = match planetwear::fmi::variables::Variable::HarmonicWindowCycles.info().start {
        Start::Integer(n) => f64::from(n),
        other => panic!("{other:?}"),
    };
    assert_eq!(window, cycles_per_revolution);
    assert_eq!(example.dynamics.measured_revolutions * cycles_per_revolution, 2.0 * window);
    assert!(planetwear::fmi::variables::Variable::HarmonicWindowCycles.info().description.contains("68"));
}

/// Sets every settable variable of an instance to `values`.
fn set_all(i: &mut Instance, values: &BTreeMap<Settable, Start>) {
    for (p, v) in values {
        let r = p.variable().value_reference();
        match v {
            Start::Real(x) => i.set_real(r, *x).unwrap(),
            Start::Integer(n) => i.set_integer(r, *n).unwrap(),
            other => panic!("{other:?}"),
        }
    }
}

fn assert_same(a: &BTreeMap<Settable, Start>, b: &BTreeMap<Settable, Start>) {
    assert_eq!(a.len(), b.len());
    for (p, x) in a {
        let name = p.variable().name();
        match (x, &b[p]) {
            (Start::Real(x), Start::Real(y)) => {
                assert!((x - y).abs() <= 1e-12 * x.abs().max(y.abs()), "{name}: {x} and {y}")
            }
            (x, y) => assert_eq!(x, y, "{name}"),
        }
    }
}

#[test]
fn parameters_to_scene_to_parameters_is_the_identity() {
    // A set unlike the example in every kind of value.
    let mut s = Scene::example_2004();
    s.operation.input_torque_nm = 500.0;
    s.dynamics.fidelity = planetwear::scene::Fidelity::Torsional;
    s.dynamics.integrator = planetwear::scene::IntegratorKind::GeneralizedAlpha;
    s.dynamics.steps_per_mesh_cycle = 96;
    s.dynamics.mesh_damping_ratio = 0.04;
    s.dynamics.input_speed = rpm_to_rad_per_s(2500.0);
    s.material.youngs_modulus = gpa_to_pa(210.0);
    s.supports.planet_bearing_n_per_m = 2.0e9;
    s.inertia.sun_mass_kg = Some(0.9);
    s.planets.count = 2; // (34 + 70) / 2: the assembly condition holds
    s.centre_distance = mm_to_m(39.0);
    let values = scene_values(&s).unwrap();
    let mut i = Instance::new("identity", None);
    set_all(&mut i, &values);
    let back = scene_values(&i.scene().unwrap()).unwrap();
    assert_same(&values, &back);
    // And the start values are the example through the same path.
    let start = scene_values(&Instance::new("start", None).scene().unwrap()).unwrap();
    assert_same(&start, &scene_values(&Scene::example_2004()).unwrap());
}

#[test]
fn a_relative_scene_file_is_looked_up_in_the_working_directory_before_resources() {
    let (dir, relative) = scratch("scene");
    let resources = dir.join("resources");
    std::fs::create_dir_all(resources.join(&relative)).unwrap();
    let scene = |name: &str| {
        let mut s = Scene::example_2004();
        s.name = name.into();
        s.to_toml()
    };
    // The same relative path in the working directory and in resources/.
    std::fs::write(dir.join("both.toml"), scene("working-directory")).unwrap();
    std::fs::write(resources.join(&relative).join("both.toml"), scene("resources")).unwrap();
    // A name only resources/ holds.
    std::fs::write(resources.join("only.toml"), scene("resources-only")).unwrap();
    let name_of = |file: &str| {
        let mut i = Instance::new("paths", Some(resources.clone()));
        i.set_string(vr::SCENE_FILE, file).unwrap();
        i.scene().map(|s| s.name).map_err(|e| e.message)
    };
    assert_eq!(name_of(&format!("{relative}/both.toml")).unwrap(), "working-directory");
    assert_eq!(name_of("only.toml").unwrap(), "resources-only");
    let absolute = resources.join(&relative).join("both.toml");
    assert_eq!(name_of(&absolute.display().to_string()).unwrap(), "resources");
    let missing = name_of("nowhere.toml").unwrap_err();
    assert!(missing.starts_with("sceneFile = nowhere.toml: cannot read"), "{missing}");
    std::fs::remove_dir_all(&dir).unwrap();
}

fn zip_entries(path: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    let mut out = BTreeMap::new();
    for k in 0..zip.len() {
        let mut f = zip.by_index(k).unwrap();
        let mut bytes = Vec::new();
        f.read_to_end(&mut bytes).unwrap();
        out.insert(f.name().to_string(), bytes);
    }
    out
}

/// The start attribute of `name` in a modelDescription.xml.
fn start_of(xml: &str, name: &str) -> String {
    let at = xml.find(&format!("<ScalarVariable name=\"{name}\"")).unwrap();
    let block = &xml[at..at + xml[at..].find("</ScalarVariable>").unwrap()];
    block.split(" start=\"").nth(1).unwrap().split('"').next().unwrap().to_string()
}

#[test]
fn an_fmu_packed_with_a_scene_has_it_as_its_default_with_its_own_references() {
    let (dir, _) = scratch("pack");
    let library = dir.join("libplanetwear.so");
    std::fs::write(&library, b"stands in for the library: packing copies it").unwrap();
    let mut scene = Scene::example_2004();
    scene.name = "lighter-load".into();
    scene.operation.input_torque_nm = 500.0;
    let cases = [(0, 3000.0)];
    let out = dir.join("scene.fmu");
    planetwear::package::pack::pack_scene(&library, &out, Some(&scene), &cases).unwrap();
    let files = zip_entries(&out);
    // The default scene in resources/ is the given one.
    let packed = std::str::from_utf8(&files[&format!("resources/{DEFAULT_SCENE}")]).unwrap();
    assert_eq!(Scene::from_toml(packed).unwrap(), scene);
    assert!(files.contains_key("resources/wear/default-scene/kappa-6.json"));
    // modelDescription.xml starts at it, and so does the instance.
    let xml = std::str::from_utf8(&files["modelDescription.xml"]).unwrap();
    assert_eq!(start_of(xml, "sceneFile"), DEFAULT_SCENE);
    assert_eq!(start_of(xml, "sunTorque").parse::<f64>().unwrap(), 500.0);
    let resources = dir.join("resources");
    std::fs::create_dir_all(&resources).unwrap();
    std::fs::write(resources.join(DEFAULT_SCENE), packed).unwrap();
    let mut i = Instance::new("packed", Some(resources));
    assert_eq!(i.get_string(vr::SCENE_FILE).unwrap(), DEFAULT_SCENE);
    for v in VARIABLES.iter().filter(|v| v.causality != Causality::Output) {
        let xml_start = start_of(xml, v.name);
        match v.kind {
            Kind::Real => {
                assert_eq!(xml_start.parse::<f64>().unwrap(), i.get_real(v.vr).unwrap(), "{}", v.name)
            }
            Kind::Integer => {
                assert_eq!(xml_start.parse::<i32>().unwrap(), i.get_integer(v.vr).unwrap(), "{}", v.name)
            }
            _ => assert_eq!(xml_start, i.get_string(v.vr).unwrap(), "{}", v.name),
        }
    }
    assert_eq!(i.scene().unwrap(), scene);
    // The references are the scene's: its name, its states, other values
    // than the example's at the same case.
    let refs: serde_json::Value =
        serde_json::from_slice(&files[planetwear::package::regression::RESOURCE]).unwrap();
    assert_eq!(refs["scene"], "lighter-load");
    let case = &refs["cases"][0];
    assert_eq!(case["parameters"]["wearStateFile"], "wear/default-scene/kappa-0.json");
    assert_eq!(refs["protocol"]["inputs"]["sunTorque"], 500.0);
    let states = planetwear::package::pack::example_wear_states().unwrap();
    let texts: Vec<String> = states.iter().map(|s| s.to_json().unwrap()).collect();
    let example = planetwear::package::regression::example_references(
        &texts,
        &cases,
        planetwear::package::regression::REFERENCE_RELATIVE_TOLERANCE,
    )
    .unwrap();
    let (ours, theirs) = (
        case["values"]["window.sunMeshMean"].as_f64().unwrap(),
        example.cases[0].values["window.sunMeshMean"],
    );
    // The mean mesh force scales with the torque: 500/750 of the example's.
    assert!((ours / theirs - 500.0 / 750.0).abs() < 1e-3, "{ours} against {theirs}");
    std::fs::remove_dir_all(&dir).unwrap();
}
