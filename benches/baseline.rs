//! One speed point of the torsional example against a baseline model run
//! side by side: a mesh-level torsional model in SciPy (RK45, 3 input
//! revolutions, written as a researcher would), given by path in the
//! environment variable `PLANETWEAR_BASELINE` and run with the interpreter in
//! `PLANETWEAR_PYTHON` (default `python3`); without `PLANETWEAR_BASELINE` only
//! our figures are printed.
//!
//! Ours, at the default accuracy (RK 5(4) at 3e-6; run-in of at most one input
//! revolution, two revolutions measured, so at most 3 revolutions as the
//! baseline integrates):
//! - `planetwear run` as a process, start to finish (scene file, model set-up,
//!   the point, the report);
//! - the point in-process from the static state, the model built once;
//! - the point inside a speed sweep (2500–3500 rpm in 50 rpm steps), per point;
//! - both again by the Fig. 11 route (`analysis::frame_sweep`: marching in the
//!   rigid-body frame one period at a time, one period measured once settled).
//!
//! and E_h of the point (docs/ACCURACY.md) against long time marching (RK 5(4)
//! at 1e-10, 300 mesh cycles of run-in). Medians of 3 runs.
//! Run: `PLANETWEAR_BASELINE=path/to/script.py cargo bench --bench baseline`.
//! docs/PERFORMANCE.md records the figures.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use planetwear::analysis::accuracy::{harmonic_error, reference, Protocol};
use planetwear::analysis::frame_sweep::{frame_sweep, FrameSweepSettings};
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::{steady_state, sweep, Direction};
use planetwear::scene::units::rpm_to_rad_per_s;
use planetwear::scene::{Fidelity, Scene};

const ROUNDS: usize = 3;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median process wall time and the time the script reports for its integration.
fn baseline(python: &str, script: &str, rpm: f64) -> Option<(f64, f64)> {
    let mut wall = Vec::new();
    let mut inner = Vec::new();
    for _ in 0..ROUNDS {
        let start = Instant::now();
        let out = Command::new(python).arg(script).arg(format!("{rpm}")).output().ok()?;
        wall.push(start.elapsed().as_secs_f64());
        if !out.status.success() {
            eprintln!("baseline failed: {}", String::from_utf8_lossy(&out.stderr));
            return None;
        }
        // "… 1.50 s wall for 3 input revolutions …"
        let text = String::from_utf8_lossy(&out.stdout);
        let seconds = text.split(" s wall").next()?.rsplit(' ').next()?.parse::<f64>().ok()?;
        inner.push(seconds);
    }
    Some((median(wall), median(inner)))
}

fn main() {
    let mut scene = Scene::example_2004();
    scene.dynamics.fidelity = Fidelity::Torsional;
    let (set, run) = scene.validate_with_run().expect("the example is valid");
    let dir = std::env::temp_dir().join(format!("planetwear-baseline-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let scene_file: PathBuf = dir.join("torsional.toml");
    planetwear::files::write_durable(&scene_file, scene.to_toml().as_bytes()).expect("scene file");

    let built = Instant::now();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
    let build = built.elapsed().as_secs_f64();
    println!(
        "one speed point, example-2004 torsional, RK 5(4) at 3e-6; model set-up in-process {build:.3} s"
    );

    let script = std::env::var("PLANETWEAR_BASELINE").ok();
    let python = std::env::var("PLANETWEAR_PYTHON").unwrap_or_else(|_| "python3".into());
    if script.is_none() {
        println!("PLANETWEAR_BASELINE is not set: the baseline is skipped, our figures only");
    }
    println!(
        "| rpm | baseline process [s] | baseline integration [s] | ours process [s] | ours point, cold [s] | ours per point in a sweep [s] | process ratio | cold-point ratio | in-sweep ratio | E_h ours |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut frame_rows = Vec::new();
    for rpm in [3000.0, 8000.0] {
        let omega = rpm_to_rad_per_s(rpm);
        let base = script.as_deref().and_then(|s| baseline(&python, s, rpm));
        let process = median(
            (0..ROUNDS)
                .map(|_| {
                    let start = Instant::now();
                    let out = Command::new(env!("CARGO_BIN_EXE_planetwear"))
                        .args(["run", "--scene"])
                        .arg(&scene_file)
                        .args(["--speed", &format!("{rpm}")])
                        .output()
                        .expect("planetwear run");
                    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
                    start.elapsed().as_secs_f64()
                })
                .collect(),
        );
        let mut point = None;
        let cold = median(
            (0..ROUNDS)
                .map(|_| {
                    let mut m = model.clone();
                    let start = Instant::now();
                    point = Some(steady_state(&mut m, &set, &run, omega, None).expect("point"));
                    start.elapsed().as_secs_f64()
                })
                .collect(),
        );
        let grid: Vec<f64> = (0..21).map(|i| rpm_to_rad_per_s(rpm - 500.0 + 50.0 * f64::from(i))).collect();
        let in_sweep = median(
            (0..ROUNDS)
                .map(|_| {
                    let mut m = model.clone();
                    let start = Instant::now();
                    sweep(&set, &run, &mut m, Direction::Up, &grid, &[], |_| {}).expect("sweep");
                    start.elapsed().as_secs_f64() / grid.len() as f64
                })
                .collect(),
        );
        let protocol =
            Protocol { run_in_cycles: 300, window_cycles: 8, samples_per_cycle: 60, sample_phase: 0.0 };
        let r = reference(&model, omega, &protocol, 1e-10).expect("reference");
        let ours: Vec<_> = point.expect("ran").meshes[..2].iter().map(|m| m.harmonics.clone()).collect();
        let e_h = harmonic_error(&ours, &r.measured.harmonics);
        let (bw, bi) = base.map_or((f64::NAN, f64::NAN), |b| b);
        for rtol in [1e-6, 1e-5] {
            let mut settings = FrameSweepSettings::default();
            settings.flow.relative_tolerance = rtol;
            // The Fig. 11 route: marching in the rigid-body frame, one period at a time.
            let mut frame_point = None;
            let frame_cold = median(
                (0..ROUNDS)
                    .map(|_| {
                        let start = Instant::now();
                        frame_point =
                            Some(frame_sweep(&model, &[omega], &settings).expect("point").remove(0));
                        start.elapsed().as_secs_f64()
                    })
                    .collect(),
            );
            let frame_in_sweep = median(
                (0..ROUNDS)
                    .map(|_| {
                        let start = Instant::now();
                        frame_sweep(&model, &grid, &settings).expect("sweep");
                        start.elapsed().as_secs_f64() / grid.len() as f64
                    })
                    .collect(),
            );
            let frame: Vec<_> =
                frame_point.expect("ran").state.meshes[..2].iter().map(|m| m.harmonics.clone()).collect();
            let e_frame = harmonic_error(&frame, &r.measured.harmonics);
            frame_rows.push(format!(
                "| {rpm:.0} | {rtol:.0e} | {bi:.3} | {frame_cold:.4} | {frame_in_sweep:.4} | {:.1} | {:.1} | {e_frame:.1e} |",
                bi / frame_cold,
                bi / frame_in_sweep
            ));
        }
        println!(
            "| {rpm:.0} | {bw:.3} | {bi:.3} | {process:.3} | {cold:.4} | {in_sweep:.4} | {:.1} | {:.1} | {:.1} | {e_h:.1e} |",
            bw / process,
            bi / cold,
            bi / in_sweep
        );
    }
    println!();
    println!(
        "the same points by marching in the rigid-body frame (analysis::frame_sweep, the Fig. 11 route):"
    );
    println!("| rpm | flow rtol | baseline integration [s] | ours point, cold [s] | ours per point in a sweep [s] | cold-point ratio | in-sweep ratio | E_h ours |");
    println!("|---|---|---|---|---|---|---|---|");
    for row in &frame_rows {
        println!("{row}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
