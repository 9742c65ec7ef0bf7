//! Hostile and careless input (docs/LIMITS.md): the one way in (regular
//! files only, one size limit per kind shared by writer and reader), the
//! safe ways out (what an output path may replace, symbolic links,
//! temporary files and completion markers), the cost of a scene checked
//! before it runs, the FMU's numerical guards, implausible wear states, and
//! the command line's checks. Each case bounds its time; the inputs that
//! could exhaust memory run under a memory limit. The FMU's held states
//! freed with their instance are checked in `hostile_fmu_states.rs` (its
//! own process, for an exact count of live bytes) and through the packed
//! FMU in tests/python/test_hostile.py.

use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use planetwear::files::{self, InputKind};
use planetwear::fmi::instance::Instance;
use planetwear::fmi::variables::vr;
use planetwear::model::gear::GearSet;
use planetwear::scene::Scene;
use planetwear::wear::state::{read_worn_state, write_worn_state, StateFileError, WornState, WornStateError};

const BIN: &str = env!("CARGO_BIN_EXE_planetwear");

/// Runs the tool under an address-space limit of 2 GB (`ulimit -v`) and
/// returns its output and wall time.
fn planetwear(args: &[&str]) -> (Output, Duration) {
    let started = Instant::now();
    let out = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2000000 && exec \"$0\" \"$@\"")
        .arg(BIN)
        .args(args)
        .output()
        .expect("runs");
    (out, started.elapsed())
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A refusal: exit code 2, within `seconds`, its message containing every
/// one of `words`.
fn refused(args: &[&str], seconds: f64, words: &[&str]) -> String {
    let (out, took) = planetwear(args);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(took.as_secs_f64() < seconds, "{args:?} took {took:?}: {err}");
    for w in words {
        assert!(err.contains(w), "{args:?}: the message does not name {w:?}: {err}");
    }
    err
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().expect("mkfifo runs").success();
    assert!(ok, "mkfifo {}", path.display());
}

fn example_text() -> String {
    Scene::example_2004().to_toml()
}

fn scene_file(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, edit(example_text())).unwrap();
    path
}

fn set_key(text: String, key: &str, value: &str) -> String {
    let mut found = false;
    let out: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with(&format!("{key} = ")) {
                found = true;
                format!("{key} = {value}")
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(found, "no key {key} in the example");
    out.join("\n") + "\n"
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .map(|t| t.lines().any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(1) == Some("0")))
        .unwrap_or(false)
}

// -- one way in ---------------------------------------------------------------

#[test]
fn a_fifo_as_scene_or_state_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    mkfifo(&fifo);
    refused(&["ltca", "--scene", s(&fifo)], 10.0, &["pipe", "named pipe (FIFO)", "scene file"]);
    refused(&["scene", "check", s(&fifo)], 10.0, &["named pipe (FIFO)"]);
    refused(
        &["modes", "--scene", "example-2004", "--wear-state", s(&fifo)],
        10.0,
        &["--wear-state", "named pipe (FIFO)", "worn-profile state file"],
    );
    // Through the library too, without opening for reading first.
    let e = files::read_input(&fifo, InputKind::Scene).unwrap_err();
    assert!(e.to_string().contains("named pipe"), "{e}");
}

#[test]
fn dev_zero_as_scene_or_state_is_refused_under_a_memory_limit() {
    refused(&["ltca", "--scene", "/dev/zero"], 10.0, &["/dev/zero", "a device", "scene file"]);
    refused(
        &["wear", "step", "--scene", "example-2004", "--state", "/dev/zero", "--out", "/tmp/never.json"],
        10.0,
        &["/dev/zero", "a device", "worn-profile state file"],
    );
    refused(&["calibrate", "--plan", "/dev/zero"], 10.0, &["/dev/zero"]);
}

#[test]
fn a_directory_as_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let e = files::read_input(dir.path(), InputKind::WornState).unwrap_err();
    assert!(e.to_string().contains("a directory"), "{e}");
}

#[test]
fn each_kind_of_file_has_one_limit_named_in_its_refusal() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.toml");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(files::MAX_SCENE_BYTES + 1).unwrap();
    let e = files::read_input(&big, InputKind::Scene).unwrap_err().to_string();
    assert!(e.contains("big.toml") && e.contains("1 MiB") && e.contains("scene file"), "{e}");
    // The same size is well within a state file's limit.
    assert_eq!(
        files::read_input(&big, InputKind::WornState).unwrap().len() as u64,
        files::MAX_SCENE_BYTES + 1
    );
    refused(&["scene", "check", s(&big)], 10.0, &["big.toml", "1 MiB"]);
    f.set_len(files::MAX_WORN_STATE_BYTES + 1).unwrap();
    let e = files::read_input(&big, InputKind::WornState).unwrap_err().to_string();
    assert!(e.contains("64 MiB") && e.contains("worn-profile state file"), "{e}");
    assert_eq!(InputKind::Campaign.limit(), files::MAX_CAMPAIGN_BYTES);
}

/// The worn state of `set` with `points` grid points on `slices` face
/// slices, and its document's size.
fn grid_state(set: &GearSet, points: usize, slices: usize) -> (WornState, usize) {
    let state = WornState::unworn(set, points, slices);
    let n = state.to_json().unwrap().len();
    (state, n)
}

#[test]
fn a_state_of_the_largest_allowed_size_is_written_and_read_back_and_one_larger_is_not_written() {
    let set = Scene::example_2004().validate().unwrap();
    // The document grows by the same bytes per face slice: find the most
    // slices of 10 000 points that fit.
    let (_, one) = grid_state(&set, 10_000, 1);
    let (_, two) = grid_state(&set, 10_000, 2);
    let per_slice = two - one;
    let limit = files::MAX_WORN_STATE_BYTES as usize;
    let slices = (limit - (one - per_slice)) / per_slice;
    let (largest, size) = grid_state(&set, 10_000, slices);
    assert!(size <= limit && size + per_slice > limit, "{size} bytes with {slices} slices");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("largest.json");
    write_worn_state(&path, &largest).unwrap();
    assert_eq!(std::fs::metadata(&path).unwrap().len() as usize, size);
    let back = read_worn_state(&path, &set).unwrap();
    assert!(back == largest, "the largest state read back differs");
    // One slice more: refused by the writer with the limit, nothing written.
    let (larger, _) = grid_state(&set, 10_000, slices + 1);
    let over = dir.path().join("over.json");
    let e = write_worn_state(&over, &larger).unwrap_err();
    assert!(matches!(e, StateFileError::Io(_)), "{e}");
    let text = e.to_string();
    assert!(text.contains("64 MiB") && text.contains("over.json"), "{text}");
    assert!(!over.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "a temporary file was left");
}

// -- safe ways out --------------------------------------------------------------

#[test]
fn a_device_node_as_output_is_refused_before_any_computation() {
    if !is_root() {
        eprintln!("note: not root, so no device node can be made: the device-node case is skipped");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let node = dir.path().join("full");
    // The character device 1,7 is /dev/full.
    let ok = Command::new("mknod").arg(&node).args(["c", "1", "7"]).status().unwrap().success();
    assert!(ok, "mknod");
    refused(&["wear", "step", "--scene", "example-2004", "--out", s(&node)], 5.0, &["--out", "a device"]);
    refused(&["fmu", "xml", "--out", s(&node)], 5.0, &["a device"]);
    assert!(std::fs::symlink_metadata(&node).unwrap().file_type().is_char_device(), "the node was replaced");
    let e = files::write_durable(&node, b"x").unwrap_err();
    assert!(e.to_string().contains("a device"), "{e}");
    assert!(std::fs::symlink_metadata(&node).unwrap().file_type().is_char_device());
}

#[test]
fn a_fifo_a_socket_or_a_directory_as_output_file_is_refused_before_any_computation() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    mkfifo(&fifo);
    refused(&["wear", "step", "--scene", "example-2004", "--out", s(&fifo)], 5.0, &["named pipe"]);
    let sock = dir.path().join("sock");
    let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
    refused(&["ltca", "--scene", "example-2004", "--out", s(&sock)], 5.0, &["a socket"]);
    let sub = dir.path().join("adir");
    std::fs::create_dir(&sub).unwrap();
    refused(&["wear", "step", "--scene", "example-2004", "--out", s(&sub)], 5.0, &["--out", "a directory"]);
    // A file where a directory is expected.
    let file = dir.path().join("file");
    std::fs::write(&file, "mine").unwrap();
    refused(
        &[
            "sweep",
            "--scene",
            "example-2004",
            "--from",
            "1000",
            "--to",
            "2000",
            "--step",
            "500",
            "--out",
            s(&file),
        ],
        5.0,
        &["--out", "output directory must be a directory"],
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
}

#[test]
fn a_symbolic_link_as_output_is_followed_and_a_dangling_one_refused() {
    let dir = tempfile::tempdir().unwrap();
    let real = dir.path().join("real.xml");
    std::fs::write(&real, "old").unwrap();
    let link = dir.path().join("link.xml");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    let (out, _) = planetwear(&["fmu", "xml", "--out", s(&link)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link was replaced");
    assert!(std::fs::read_to_string(&real).unwrap().contains("fmiModelDescription"));
    // The library's writer follows it the same way.
    files::write_durable(&link, b"through the link").unwrap();
    assert_eq!(std::fs::read_to_string(&real).unwrap(), "through the link");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    let dangling = dir.path().join("dangling.xml");
    std::os::unix::fs::symlink(dir.path().join("nowhere"), &dangling).unwrap();
    refused(&["fmu", "xml", "--out", s(&dangling)], 5.0, &["symbolic link", "does not exist"]);
}

/// Temporary files in `dir` (the project's pattern).
fn temps(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(files::TEMP_PREFIX))
        .collect()
}

/// The id of a process that has ended.
fn dead_pid() -> u32 {
    let mut child = Command::new("true").spawn().unwrap();
    let pid = child.id();
    child.wait().unwrap();
    pid
}

#[test]
fn a_killed_run_followed_by_a_rerun_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ltca");
    let (o, s_out) = (out.clone(), out.join("ltca.json"));
    // A run killed while it works (whatever it was writing then is left).
    let mut child = Command::new(BIN)
        .args(["ltca", "--scene", "example-2004", "--samples", "40", "--plots", s(&o), "--out", s(&s_out)])
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(400));
    let _ = child.kill();
    child.wait().unwrap();
    std::fs::create_dir_all(&out).unwrap();
    // What a kill during a write leaves, of an ended process; a file of
    // another name and a temporary file of a running process stay.
    let dead = dead_pid();
    for name in [
        format!("{}{dead}.0.sun.png.png", files::TEMP_PREFIX),
        format!("{}{dead}.7.ltca.json", files::TEMP_PREFIX),
    ] {
        std::fs::write(out.join(name), "partial").unwrap();
    }
    let live = format!("{}{}.0.other.json", files::TEMP_PREFIX, std::process::id());
    std::fs::write(out.join(&live), "in use").unwrap();
    std::fs::write(out.join(".not-ours.tmp"), "foreign").unwrap();
    let (rerun, _) = planetwear(&[
        "ltca",
        "--scene",
        "example-2004",
        "--samples",
        "40",
        "--plots",
        s(&out),
        "--out",
        s(&s_out),
    ]);
    assert!(rerun.status.success(), "{}", stderr(&rerun));
    assert_eq!(temps(&out), vec![live], "only the running process's temporary file stays");
    assert!(out.join(".not-ours.tmp").exists(), "a file of another pattern was removed");
    assert!(s_out.exists());
}

#[test]
fn temporary_files_carry_the_pattern_and_a_failed_write_leaves_none() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("x.png");
    let r: Result<(), files::FileError> = files::write_durable_with(&target, ".png", |tmp| {
        let name = tmp.file_name().unwrap().to_string_lossy().into_owned();
        assert!(name.starts_with(files::TEMP_PREFIX) && name.ends_with("x.png.png"), "{name}");
        Err(files::FileError { path: tmp.to_path_buf(), error: std::io::Error::other("render failed") })
    });
    assert!(r.is_err());
    assert!(temps(dir.path()).is_empty() && !target.exists());
    // Stale ones of an ended process go; the function touches nothing else.
    let stale = dir.path().join(format!("{}{}.3.y.json", files::TEMP_PREFIX, dead_pid()));
    std::fs::write(&stale, "").unwrap();
    std::fs::write(dir.path().join("y.json"), "").unwrap();
    assert_eq!(files::remove_stale_temps(dir.path()), 1);
    assert!(!stale.exists() && dir.path().join("y.json").exists());
}

#[test]
fn wear_run_writes_its_completion_marker_last() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("wear");
    std::fs::create_dir_all(&out).unwrap();
    // A marker of an earlier run does not survive a run that fails to finish.
    std::fs::write(out.join("summary.json"), "{}").unwrap();
    let (o, _) = planetwear(&["wear", "run", "--scene", "example-2004", "--to-kappa", "0", "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let marker = std::fs::metadata(out.join("summary.json")).unwrap().modified().unwrap();
    let mut checked = 0;
    for e in std::fs::read_dir(out.join("plots")).unwrap().flatten() {
        let t = e.metadata().unwrap().modified().unwrap();
        assert!(t <= marker, "{} is newer than summary.json", e.path().display());
        checked += 1;
    }
    assert!(checked > 0, "no plots written");
    assert!(std::fs::read_to_string(out.join("summary.json")).unwrap().len() > 2);
}

// -- cost-aware validation ----------------------------------------------------------

#[test]
fn a_valid_looking_scene_whose_run_would_exceed_the_budget_is_refused_by_check_and_run() {
    let dir = tempfile::tempdir().unwrap();
    let big = scene_file(dir.path(), "big.toml", |t| set_key(t, "measured_revolutions", "1e9"));
    let words = ["dynamics.measured_revolutions", "TiB", "budget", "internal steps"];
    refused(&["scene", "check", s(&big)], 10.0, &words);
    refused(&["run", "--scene", s(&big)], 10.0, &words);
    let long = scene_file(dir.path(), "long.toml", |t| set_key(t, "run_in_revolutions", "1e7"));
    refused(&["scene", "check", s(&long)], 10.0, &["dynamics.run_in_revolutions", "internal steps", "2e8"]);
    // The example is far inside the budgets, and check says what it costs.
    let (o, _) = planetwear(&["scene", "check", "example-2004"]);
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success() && text.contains("internal steps") && text.contains("budget"), "{text}");
    // The library refuses it in validation, so the FMU does too.
    let mut scene = Scene::example_2004();
    scene.dynamics.measured_revolutions = 1e9;
    let e = scene.validate().unwrap_err().to_string();
    assert!(e.contains("dynamics.measured_revolutions"), "{e}");
}

#[test]
fn an_ltca_over_its_budget_is_refused_by_check_and_by_every_command() {
    // 1e5 positions per mesh cycle on 1000 face slices: each value is in
    // its range, but one LTCA would take most of an hour (and a dynamic run
    // on such a face once divided by zero).
    let dir = tempfile::tempdir().unwrap();
    let fine = scene_file(dir.path(), "fine.toml", |t| {
        set_key(set_key(t, "positions_per_mesh_cycle", "100000"), "face_slices", "1000")
    });
    for cmd in
        [&["scene", "check", s(&fine)][..], &["ltca", "--scene", s(&fine)], &["run", "--scene", s(&fine)]]
    {
        refused(cmd, 10.0, &["analysis.positions_per_mesh_cycle × analysis.face_slices", "1.000e8", "1e7"]);
    }
}

#[test]
fn a_sweep_over_its_step_budget_is_refused_before_it_writes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    // 72 501 speeds both ways at about 8e4 internal steps each.
    refused(
        &[
            "sweep",
            "--scene",
            "example-2004",
            "--from",
            "500",
            "--to",
            "15000",
            "--step",
            "0.2",
            "--out",
            s(&out),
        ],
        10.0,
        &["72501 speeds × 2 directions", "internal steps", "1e10"],
    );
    assert!(!out.exists(), "the refused sweep created its output directory");
}

#[test]
fn a_grid_whose_state_file_would_exceed_its_limit_is_a_warning_of_check() {
    let dir = tempfile::tempdir().unwrap();
    let fine = scene_file(dir.path(), "fine.toml", |t| {
        set_key(set_key(t, "profile_points", "10000"), "face_slices", "100")
    });
    let (o, _) = planetwear(&["scene", "check", s(&fine)]);
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        text.contains("warning") && text.contains("analysis.profile_points") && text.contains("64"),
        "{text}"
    );
}

#[test]
fn simulate_refuses_a_run_of_more_communication_points_than_it_may_print() {
    refused(
        &["simulate", "--scene", "example-2004", "--stop", "1e300", "--step", "1e-3"],
        10.0,
        &["--step", "communication points"],
    );
}

// -- numerical guards of the FMU -------------------------------------------------

/// An FMU instance of the example after initialization.
fn initialized() -> Instance {
    let mut i = Instance::new("hostile", None);
    i.setup_experiment(0.0, None).unwrap();
    i.enter_initialization();
    i.exit_initialization().unwrap();
    i
}

#[test]
fn an_overflowing_torque_is_discarded_at_once_with_the_figure() {
    let mut i = initialized();
    i.do_step(0.0, 1e-4).unwrap();
    for torque in [1e300, 1e20, 1e9] {
        let mut j = initialized();
        j.set_real(vr::SUN_TORQUE, torque).unwrap();
        let started = Instant::now();
        let e = j.do_step(0.0, 1e-4).unwrap_err();
        let took = started.elapsed();
        assert_eq!(e.status, planetwear::fmi::instance::Status::Discard, "{torque}: {}", e.message);
        assert!(took < Duration::from_millis(200), "{torque}: took {took:?}");
        assert!(e.message.contains("sunTorque") && e.message.contains("rad/s"), "{}", e.message);
        // Nothing further is stepped on the refused state.
        assert!(j.do_step(1e-4, 1e-4).is_err());
    }
    // A step that would need more internal steps than one may take is
    // refused before it starts, with the figure.
    let started = Instant::now();
    let e = i.do_step(1e-4, 1e6).unwrap_err();
    assert!(started.elapsed() < Duration::from_millis(200));
    assert!(e.message.contains("internal steps"), "{}", e.message);
    assert!(e.message.contains("take steps of at most"), "{}", e.message);
    assert_eq!(e.status, planetwear::fmi::instance::Status::Discard, "{}", e.message);
}

// -- plausibility of wear states -------------------------------------------------------

#[test]
fn absurd_wear_depths_are_refused_with_the_figure() {
    let set = Scene::example_2004().validate().unwrap();
    let dir = tempfile::tempdir().unwrap();
    for depth in [1e-3, 1.0, 1e300] {
        let mut state = WornState::unworn(&set, 20, 1);
        for d in state.flanks.sun_drive[0].depth.iter_mut() {
            *d = depth;
        }
        let path = dir.path().join(format!("deep-{depth:e}.json"));
        // Set-free checks pass: the document is well formed.
        write_worn_state(&path, &state).unwrap();
        match read_worn_state(&path, &set) {
            Err(StateFileError::State { source, .. }) => {
                let WornStateError::Implausible { field, depth: d, limit, .. } = *source else {
                    panic!("{depth}: refused for another reason: {source}")
                };
                assert_eq!(field, "flanks.sun_drive[0].depth[0]");
                assert_eq!(d, depth);
                assert!(limit < 1e-3 && limit > 1e-4, "{limit}");
            }
            other => panic!("{depth}: {other:?}"),
        }
        refused(
            &["modes", "--scene", "example-2004", "--wear-state", s(&path)],
            20.0,
            &["flanks.sun_drive[0].depth[0]", "tooth thickness", "not a plausible worn state"],
        );
    }
    // A depth within the limit is taken.
    let (limit, _) = WornState::plausible_depth(&set, planetwear::wear::flank::Gear::Sun);
    let mut state = WornState::unworn(&set, 20, 1);
    state.flanks.sun_drive[0].depth[3] = 0.9 * limit;
    let path = dir.path().join("deep-but-plausible.json");
    write_worn_state(&path, &state).unwrap();
    read_worn_state(&path, &set).unwrap();
}

// -- the command line's checks match the core's ----------------------------------------

#[test]
fn the_ltca_torque_check_names_the_key_the_user_wrote_and_scene_check_reports_it() {
    let dir = tempfile::tempdir().unwrap();
    let neg = scene_file(dir.path(), "neg.toml", |t| set_key(t, "input_torque_nm", "-750.0"));
    let err = refused(&["ltca", "--scene", s(&neg)], 10.0, &["operation.input_torque_nm", "-750"]);
    assert!(!err.contains("--torque"), "names a flag not passed: {err}");
    let err = refused(&["ltca", "--scene", "example-2004", "--torque=-5"], 10.0, &["--torque", "-5"]);
    assert!(!err.contains("operation.input_torque_nm"), "{err}");
    let (o, _) = planetwear(&["scene", "check", s(&neg)]);
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success());
    assert!(text.contains("`ltca` will refuse it") && text.contains("operation.input_torque_nm"), "{text}");
}

#[test]
fn a_sweep_from_above_to_is_refused_as_documented() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    refused(
        &[
            "sweep",
            "--scene",
            "example-2004",
            "--from",
            "3000",
            "--to",
            "1000",
            "--step",
            "1000",
            "--out",
            s(&out),
        ],
        10.0,
        &["--from 3000", "--to 1000", "--direction"],
    );
}

#[test]
fn wear_step_says_a_revolutions_request_cannot_be_met_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    // A coarse grid keeps the one wear cycle short.
    let cheap = scene_file(dir.path(), "cheap.toml", |t| {
        set_key(set_key(t, "positions_per_mesh_cycle", "8"), "profile_points", "10")
    });
    let out = dir.path().join("state.json");
    refused(
        &["wear", "step", "--scene", s(&cheap), "--revolutions", "1e300", "--out", s(&out)],
        120.0,
        &["--revolutions 1e300", "cannot be met", "update depth"],
    );
    assert!(!out.exists());
}

/// The wear model's total-depth limit keeps every state it writes readable:
/// a limit deeper than a quarter of the wearing gear's tooth is refused
/// with the figure, one inside it is accepted.
#[test]
fn a_total_wear_limit_deeper_than_plausible_is_refused() {
    use planetwear::wear::archard::{WearError, WearSettings};
    use planetwear::wear::stepper::WearModel;
    let set = Scene::example_2004().validate().unwrap();
    let (sun_limit, _) = WornState::plausible_depth(&set, planetwear::wear::flank::Gear::Sun);
    let too_deep = WearSettings { total_depth: 0.9e-3, ..WearSettings::default() };
    match WearModel::new(&set, too_deep) {
        Err(e @ WearError::TotalDepthImplausible { .. }) => {
            let m = e.to_string();
            assert!(m.contains("total_depth = 9e-4 m") && m.contains("sun"), "{m}");
            assert!(m.contains(&format!("{sun_limit:e} m")), "{m}");
        }
        other => panic!("expected the refusal, got {:?}", other.map(|_| ())),
    }
    let inside = WearSettings { total_depth: 0.9 * sun_limit, ..WearSettings::default() };
    assert!(WearModel::new(&set, inside).is_ok());
}
