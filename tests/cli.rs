//! The command-line tool as a user runs it.

use std::process::Command;

fn planetwear(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_planetwear")).args(args).output().expect("runs")
}

#[test]
fn scene_show_prints_an_editable_file_that_validates() {
    let out = planetwear(&["scene", "show", "example-2004"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("teeth = 34") && text.contains("centre_distance_mm = 39.0"), "{text}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("edited.toml");
    std::fs::write(&path, text.replace("input_torque_nm = 750.0", "input_torque_nm = 300.0")).unwrap();
    let out = planetwear(&["ltca", "--scene", path.to_str().unwrap(), "--json", "--samples", "40"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(doc["input_torque"], 300.0);
}

#[test]
fn ltca_json_has_the_documented_keys_in_si_units() {
    let out = planetwear(&["ltca", "--scene", "example-2004", "--json", "--samples", "60"]);
    assert!(out.status.success());
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let meshes = doc["meshes"].as_array().unwrap();
    assert_eq!(meshes.len(), 2);
    for m in meshes {
        for key in
            ["contact_ratio_nominal", "contact_ratio_loaded", "peak_hertz_pressure", "max_hertz_half_width"]
        {
            assert!(m[key].as_f64().unwrap() > 0.0, "{key}");
        }
        for key in ["mesh_stiffness_nominal", "mesh_stiffness_loaded", "static_transmission_error"] {
            for stat in ["mean", "peak_to_peak", "min", "max"] {
                assert!(m[key][stat].is_number(), "{key}.{stat}");
            }
        }
        // SI: a mesh stiffness of some 1e8..1e9 N/m, a base pitch of 4.39e-3 m.
        let k = m["mesh_stiffness_nominal"]["mean"].as_f64().unwrap();
        assert!(k > 1e8 && k < 2e9, "{k}");
        assert!((m["base_pitch"].as_f64().unwrap() - 4.3905e-3).abs() < 1e-7);
    }
    let shares = doc["planets"]["mean_load"].as_array().unwrap();
    assert_eq!(shares.len(), 4);
}

#[test]
fn plots_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = planetwear(&[
        "ltca",
        "--scene",
        "example-2004",
        "--samples",
        "40",
        "--plots",
        dir.path().to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for stem in [
        "sun_planet_mesh_stiffness",
        "ring_planet_transmission_error",
        "sun_planet_pair_load",
        "planet_load_sharing",
    ] {
        for ext in ["svg", "png"] {
            let p = dir.path().join(format!("{stem}.{ext}"));
            assert!(std::fs::metadata(&p).map(|m| m.len() > 1000).unwrap_or(false), "{}", p.display());
        }
    }
}

#[test]
fn bad_input_gets_a_clear_error() {
    let out = planetwear(&["ltca", "--scene", "no-such-scene"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("neither a built-in scene (example-2004, example-2004-annulus, example-2004-gear-data, example-2004-stiff-pins, example-2004-deformable) nor an existing file"),
        "{err}"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    let text = planetwear::scene::Scene::example_2004().to_toml().replace("count = 4", "count = 3");
    std::fs::write(&path, text.replace("centre_distance_mm = 39.0", "centre_distance_mm = -1.0")).unwrap();
    let out = planetwear(&["ltca", "--scene", path.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("centre_distance_mm = -1: must be a finite number greater than zero"), "{err}");
    let out = planetwear(&["ltca", "--scene", "example-2004", "--torque=0"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--torque"));
}

#[test]
fn modes_of_the_example_have_lin_parker_structure() {
    let out = planetwear(&["modes", "--scene", "example-2004", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let modes = doc["modes"].as_array().unwrap();
    assert_eq!(modes.len(), 20);
    let count = |c: &str| modes.iter().filter(|m| m["class"] == c).count();
    assert_eq!(count("rigid_body"), 1);
    assert_eq!(count("rotational"), 4);
    assert_eq!(count("translational"), 12);
    assert_eq!(count("planet"), 3);
    let out = planetwear(&["modes", "--scene", "lumped-benchmark"]);
    assert!(out.status.success());
}

#[test]
fn a_small_sweep_writes_its_tables_plots_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let out = planetwear(&[
        "sweep",
        "--scene",
        "example-2004-annulus",
        "--from",
        "4900",
        "--to",
        "5100",
        "--step",
        "100",
        "--out",
        d,
        "--histories",
        "5000",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in [
        "sweep_up.csv",
        "sweep_down.csv",
        "sweep.json",
        "forced_response_sun_planet.png",
        "time_history_5000rpm.svg",
    ] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    let csv = std::fs::read_to_string(dir.path().join("sweep_up.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4, "{csv}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("sweep.json")).unwrap()).unwrap();
    // The peak at 5000 rpm: the second harmonic meets the first rotational
    // mode of the uncalibrated reading (14.3 kHz).
    let peaks = summary["peaks"].as_array().unwrap();
    assert!(peaks
        .iter()
        .any(|p| p["speed_rpm"] == 5000.0 && p["harmonic"] == 2 && p["family"] == "rotational"));
    let bad = planetwear(&[
        "sweep",
        "--scene",
        "example-2004",
        "--from",
        "500",
        "--to",
        "600",
        "--step",
        "0",
        "--out",
        d,
    ]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--step"));
}

/// `work-precision --quick`: the reduced study writes its charts, CSV,
/// tables and JSON, and picks a default that meets 1e-3 at every point.
#[test]
fn work_precision_quick_writes_the_study_and_a_default() {
    let dir = tempfile::tempdir().unwrap();
    let out = planetwear(&["work-precision", "--quick", "--out", dir.path().to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in ["work_precision.csv", "work_precision_tables.md", "work_precision.json"] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    assert!(dir.path().join("off_resonance_torsional_error_vs_time.png").exists());
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("work_precision.json")).unwrap()).unwrap();
    let points = doc["study"]["points"].as_array().unwrap();
    assert_eq!(points.len(), 4);
    let overall = &doc["study"]["defaults"][0];
    assert_eq!(overall["family"], "all");
    assert!(overall["method"].is_object(), "no setting met 1e-3 everywhere: {overall}");
    assert_eq!(overall["errors"].as_array().unwrap().len(), 4);
    for (_, e) in overall["errors"].as_array().unwrap().iter().map(|p| (p[0].clone(), p[1].as_f64().unwrap()))
    {
        assert!(e <= 1e-3, "{overall}");
    }
}

/// Each cause of an error is said once: a truncated wear-state file gives
/// its reason once, not once per error layer that repeats its source.
#[test]
fn an_error_names_each_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state.json");
    let out = planetwear(&["wear", "step", "--scene", "example-2004", "--out", state.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read(&state).unwrap();
    let cut = dir.path().join("cut.json");
    std::fs::write(&cut, &text[..text.len() / 2]).unwrap();
    let out = planetwear(&["ltca", "--scene", "example-2004", "--wear-state", cut.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.matches("the document is truncated").count(), 1, "{err}");
    assert!(err.starts_with("error: --wear-state "), "{err}");
}

/// Runs the tool with its standard output a pipe whose reader takes `lines`
/// lines and closes it (at once for none); returns the lines read and the
/// tool's status and standard error.
fn with_a_closed_pipe(args: &[&str], lines: usize) -> (Vec<String>, std::process::Output) {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_planetwear"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let mut reader = BufReader::new(child.stdout.take().unwrap());
    let mut read = Vec::new();
    for _ in 0..lines {
        let mut line = String::new();
        reader.read_line(&mut line).unwrap();
        read.push(line);
    }
    // The reader, dropped here, closes the pipe.
    drop(reader);
    (read, child.wait_with_output().unwrap())
}

/// The tool ended as a Unix filter whose reader went away: status 0 and
/// nothing said (no panic of a failed print, no error, no signal).
fn assert_ended_quietly(args: &[&str], out: &std::process::Output) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe") && !err.contains("error"),
        "{args:?}: {err}"
    );
    assert!(out.status.success(), "{args:?}: status {:?}; {err}", out.status);
}

/// A reader that closes the pipe early ends the tool quietly, as any Unix
/// filter: `simulate` writes thousands of JSON lines, and its next line after
/// the reader has gone ends the run with status 0 and nothing on stderr.
#[test]
fn a_closed_pipe_ends_the_tool_quietly() {
    let args = ["simulate", "--scene", "example-2004", "--stop", "0.05", "--step", "1e-5"];
    let (read, out) = with_a_closed_pipe(&args, 1);
    assert!(read[0].starts_with('{'), "{}", read[0]);
    assert_ended_quietly(&args, &out);
}

/// The tables and documents other commands print end as quietly: `modes`
/// with its reader gone before the table's first line (the modes take
/// milliseconds; the pipe is closed as soon as the tool starts), and `fmu
/// xml`, whose 80 kB are more than the pipe holds, after one line read.
#[test]
fn a_closed_pipe_ends_a_table_or_a_document_quietly() {
    for (args, lines) in [
        (&["modes", "--scene", "example-2004"][..], 0),
        (&["fmu", "xml"][..], 1),
        (&["scene", "show", "example-2004"][..], 0),
    ] {
        let (read, out) = with_a_closed_pipe(args, lines);
        assert!(read.iter().all(|l| !l.is_empty()), "{args:?}: {read:?}");
        assert_ended_quietly(args, &out);
    }
}

/// Any other failure to write standard output (here a full device) is an
/// error naming standard output, with the failing status 2.
#[test]
fn a_failed_write_to_standard_output_is_an_error() {
    let full = std::path::Path::new("/dev/full");
    if !full.exists() {
        return;
    }
    for args in
        [&["scene", "show", "example-2004"][..], &["modes", "--scene", "example-2004"], &["fmu", "xml"]]
    {
        let out = Command::new(env!("CARGO_BIN_EXE_planetwear"))
            .args(args)
            .stdout(std::fs::OpenOptions::new().write(true).open(full).unwrap())
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.starts_with("error: writing to standard output: No space left on device"),
            "{args:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

/// A speed no gear set of this kind runs at is said on stderr before the
/// run (the figures of docs/FMU.md, "Messages"); the example's own speed
/// warns of nothing.
#[test]
fn run_warns_of_an_overspeed_and_not_of_the_example() {
    let out = planetwear(&["run", "--scene", "example-2004", "--speed", "1e9"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(
            "warning: overspeed: the sun–planet pitch-line velocity is 2.6704e6 m/s (sun 1.000000e9 rpm"
        ),
        "{err}"
    );
    assert!(err.contains("above the limit of 40 m/s"), "{err}");
    let out = planetwear(&["run", "--scene", "example-2004"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        !String::from_utf8_lossy(&out.stderr).contains("warning"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A ring–planet mesh whose ring tip carries the contact past the planet's
/// base-circle tangent point (involute interference) is refused by `scene
/// check`, naming the key; before the rule it passed and `ltca` reported
/// 4432 MPa and a mean transmission error of −101 µm (docs/GEAR_DATA.md).
#[test]
fn scene_check_refuses_an_interfering_internal_mesh() {
    let text = planetwear::scene::Scene::example_2004()
        .to_toml()
        .replace("minor_radius_mm = 51.725", "minor_radius_mm = 50.6")
        .replace("root_radius_mm = 11.875", "root_radius_mm = 11.5")
        .replace(
            "hob_tip_radius_mm = 0.2\nface_width_mm = 30.0\n\n[planet.tip_chamfer]",
            "hob_tip_radius_mm = 0.6\nface_width_mm = 30.0\n\n[planet.tip_chamfer]",
        );
    assert!(text.contains("hob_tip_radius_mm = 0.6"), "{text}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("interfering.toml");
    std::fs::write(&path, text).unwrap();
    let out = planetwear(&["scene", "check", path.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("ring.minor_radius_mm = 50.6: involute interference in the ring_planet mesh"),
        "{err}"
    );
    // The example given by gear data passes.
    let out = planetwear(&["scene", "check", "example-2004-gear-data"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// `--accept-state-difference material`: a state of another material is
/// refused without it, taken with a warning line with it, and the state
/// `wear step` writes records what was accepted.
#[test]
fn wear_step_accepts_another_material_only_when_asked_and_records_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let out = planetwear(&["scene", "show", "example-2004"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("youngs_modulus_gpa = 207.0"), "{text}");
    std::fs::write(
        path("steel.toml"),
        text.replace("youngs_modulus_gpa = 207.0", "youngs_modulus_gpa = 210.0"),
    )
    .unwrap();
    let first = planetwear(&[
        "wear",
        "step",
        "--scene",
        "example-2004",
        "--out",
        &path("a.json"),
        "--revolutions",
        "1",
    ]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let step = |accept: &[&str]| {
        let (scene, state, out) = (path("steel.toml"), path("a.json"), path("b.json"));
        let mut args = vec!["wear", "step", "--scene", &scene, "--state", &state, "--out", &out];
        args.extend(["--revolutions", "1"]);
        args.extend(accept);
        planetwear(&args)
    };
    let refused = step(&[]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert!(
        err.contains("--state")
            && err.contains("material.youngs_modulus is 207000000000 in the state and 210000000000 here"),
        "{err}"
    );
    assert!(!dir.path().join("b.json").exists());
    let taken = step(&["--accept-state-difference", "material"]);
    let err = String::from_utf8_lossy(&taken.stderr);
    assert!(taken.status.success(), "{err}");
    assert!(
        err.contains("warning: --state ")
            && err.contains(
                "accepted a worn-profile state whose gear set differs in material: material.youngs_modulus"
            )
            && err.contains("(--accept-state-difference material)"),
        "{err}"
    );
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(path("b.json")).unwrap()).unwrap();
    assert_eq!(doc["content"]["accepted_differences"], serde_json::json!(["material"]));
    let bad = step(&["--accept-state-difference", "geometry"]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains(
            "--accept-state-difference geometry: 'geometry' is not a difference that can be accepted"
        ),
        "{err}"
    );
}
