//! The packed FMU imported with the `fmi` crate (an independent importer).
//! Needs fmu/planetwear.fmu: the README's test command packs it and runs this
//! suite with `--include-ignored`.

use std::path::Path;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common};
use fmi::traits::FmiImport;
use planetwear::fmi::variables::vr;

#[test]
#[ignore = "needs fmu/planetwear.fmu: `cargo build --release && target/release/planetwear fmu pack`"]
fn the_packed_fmu_runs_under_the_fmi_crate() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/planetwear.fmu");
    assert!(path.is_file(), "{} is missing: pack the FMU first", path.display());
    let import: Fmi2Import = fmi::import::from_path(&path).expect("the fmi crate reads the FMU");
    assert_eq!(import.model_description().model_name, "planetwear");
    let mut inst = import.instantiate_cs("imported", false, false).expect("instantiate");
    Common::setup_experiment(&mut inst, None, 0.0, None).expect("setup");
    Common::enter_initialization_mode(&mut inst).expect("enter");
    Common::exit_initialization_mode(&mut inst).expect("exit");
    let h = 1e-4;
    for k in 0..50 {
        CoSimulation::do_step(&inst, k as f64 * h, h, true).expect("step");
    }
    let mut out = [0.0; 2];
    Common::get_real(&mut inst, &[vr::PLANET_1_SUN_MESH_FORCE, vr::SUN_SPEED], &mut out).expect("get");
    // The mean tooth force is 7892 N; one instant of a running mesh lies
    // within ±60 % of it (the example's mesh force swings between 0.46 and
    // 1.53 of the mean at 3000 rpm: `planetwear simulate --scene
    // example-2004 --stop 0.02 --step 1e-4`).
    assert!(out[0] > 0.4 * 7892.0 && out[0] < 1.6 * 7892.0, "{out:?}");
    assert!((out[1] / 314.159 - 1.0).abs() < 0.05, "{out:?}");
    Common::terminate(&mut inst).expect("terminate");
}

#[test]
#[ignore = "needs fmu/planetwear.fmu: `cargo build --release && target/release/planetwear fmu pack`"]
fn the_packed_fmu_ships_regression_references_that_belong_to_it() {
    use planetwear::fmi::variables::GUID;
    use planetwear::package::regression::{References, CASES, FORMAT, RESOURCE};
    use std::io::Read;

    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/planetwear.fmu");
    let file = std::fs::File::open(&path).expect("fmu/planetwear.fmu: pack the FMU first");
    let mut zip = zip::ZipArchive::new(file).expect("the FMU is a zip archive");
    let mut text = String::new();
    zip.by_name(RESOURCE).expect("the references are packed").read_to_string(&mut text).unwrap();
    let refs: References = serde_json::from_str(&text).expect("the references parse");
    assert_eq!(refs.format, FORMAT);
    assert_eq!(refs.fmu_guid, GUID);
    assert_eq!(refs.cases.len(), CASES.len());
    // The mean mesh force is the static load, 750 N·m over 4 planets at the
    // sun's base radius 25.5 mm · cos 21.3° (the mesh forces' mean over a
    // window of whole mesh cycles).
    let f0 = 750.0 / (4.0 * 0.0255 * 21.3f64.to_radians().cos());
    for case in &refs.cases {
        let state = case.parameters["wearStateFile"].as_str().expect("a wear state per case");
        assert!(zip.by_name(&format!("resources/{state}")).is_ok(), "{}: {state} is not packed", case.name);
        assert_eq!(case.values.len(), 18, "{}", case.name);
        for (name, value) in &case.values {
            let tol = case.tolerance[name];
            assert!(
                value.is_finite() && tol.is_finite() && tol > 0.0,
                "{} {name}: {value} ± {tol}",
                case.name
            );
        }
        for mesh in ["sun", "ring"] {
            let mean = case.values[&format!("window.{mesh}MeshMean")];
            assert!((mean / f0 - 1.0).abs() < 0.01, "{} {mesh}: mean {mean} N vs {f0} N", case.name);
            let f1 = case.values[&format!("window.{mesh}MeshF1")];
            let tol = case.tolerance[&format!("window.{mesh}MeshF1")];
            assert!((tol / f1 - case.budget.fraction_of_f1).abs() < 1e-12, "{}", case.name);
        }
        assert!(
            case.budget.fraction_of_f1 >= case.budget.margin * (case.budget.integrator + case.budget.drift)
        );
    }
}
