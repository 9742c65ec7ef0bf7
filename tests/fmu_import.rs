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
    // The mean tooth force is 7892 N; one instant of a running mesh lies within ±30 % of it.
    assert!(out[0] > 0.7 * 7892.0 && out[0] < 1.3 * 7892.0, "{out:?}");
    assert!((out[1] / 314.159 - 1.0).abs() < 0.05, "{out:?}");
    Common::terminate(&mut inst).expect("terminate");
}
