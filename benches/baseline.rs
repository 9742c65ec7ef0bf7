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
//!   rigid-body frame one period at a time, one period measured once settled);
//! - and by harmonic balance (`dynamics::periodic::HarmonicBalance`, H and N
//!   by `HarmonicSettings::for_speed`): the point from a cold start, the point
//!   with its Floquet multipliers from the tangents along its own series
//!   (`HarmonicBalance::floquet_multipliers`), the point refined by shooting's
//!   Newton from the balance's state (the flow's accuracy, and shooting's
//!   multipliers), and per point of the sweep, without and with each point's
//!   multipliers, each point starting from the one before (H and N by the
//!   rule at each speed; a point where Newton does not converge from there
//!   starts again cold, and one that does not converge from either is taken
//!   by the route; both are counted).
//!
//! and E_h of the point (docs/ACCURACY.md) against long time marching (RK 5(4)
//! at 1e-10, 300 mesh cycles of run-in). Medians of 3 runs (of 11 for the
//! harmonic balance, whose points take milliseconds).
//!
//! The balance's point with its multipliers is also timed *paired*: in each of
//! [`PAIRED_ROUNDS`] rounds the baseline runs once and our point (the median of
//! 11) right after it, and the round's ratio is the one of those two; the
//! median of the rounds' ratios is printed with their range. This machine's
//! speed drifts by up to 1.7x over tens of seconds, and a ratio of two
//! timings taken a minute apart carries that drift; two taken within a second
//! of each other do not.
//! Run: `PLANETWEAR_BASELINE=path/to/script.py cargo bench --bench baseline`.
//! docs/PERFORMANCE.md records the figures.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use planetwear::analysis::accuracy::{harmonic_error, reference, Protocol};
use planetwear::analysis::frame_sweep::{frame_sweep, FrameSweepSettings};
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::periodic::{HarmonicBalance, HarmonicSettings, PeriodicProblem, ShootingSettings};
use planetwear::dynamics::response::{steady_state, sweep, Direction};
use planetwear::scene::units::rpm_to_rad_per_s;
use planetwear::scene::{Fidelity, Scene};

const ROUNDS: usize = 3;

/// Rounds of the harmonic balance's timings, a few milliseconds each: the
/// median of more of them than of the route's, which this machine's noise
/// moves by more than the medians of three settle (2026-11-27: the cold
/// point at 8000 rpm measured 8.4 ms in one run and 12.8 ms in the next).
const BALANCE_ROUNDS: usize = 11;

/// Rounds of the paired timing (the baseline once, then our point).
const PAIRED_ROUNDS: usize = 5;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One run of the baseline: the process's wall time and the time the script
/// reports for its integration.
fn baseline_once(python: &str, script: &str, rpm: f64) -> Option<(f64, f64)> {
    let start = Instant::now();
    let out = Command::new(python).arg(script).arg(format!("{rpm}")).output().ok()?;
    let wall = start.elapsed().as_secs_f64();
    if !out.status.success() {
        eprintln!("baseline failed: {}", String::from_utf8_lossy(&out.stderr));
        return None;
    }
    // "… 1.50 s wall for 3 input revolutions …"
    let text = String::from_utf8_lossy(&out.stdout);
    let seconds = text.split(" s wall").next()?.rsplit(' ').next()?.parse::<f64>().ok()?;
    Some((wall, seconds))
}

/// Median process wall time and the time the script reports for its integration.
fn baseline(python: &str, script: &str, rpm: f64) -> Option<(f64, f64)> {
    let runs = (0..ROUNDS).map(|_| baseline_once(python, script, rpm)).collect::<Option<Vec<_>>>()?;
    Some((median(runs.iter().map(|r| r.0).collect()), median(runs.iter().map(|r| r.1).collect())))
}

fn main() {
    let mut scene = Scene::example_2004_stiff_pins();
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
    let mut balance_rows = Vec::new();
    let mut condensed_rows = Vec::new();
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
        let once = || baseline_once(&python, script.as_deref()?, rpm).map(|(_, integration)| integration);
        balance_rows.push(balance_row(&model, omega, &grid, &r.measured.harmonics, bi, &once));
        condensed_rows.push(condensed_row(&model, omega, &r.measured.harmonics, bi));
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
    println!();
    println!("the same points by harmonic balance (dynamics::periodic::HarmonicBalance, H and N by HarmonicSettings::for_speed):");
    println!("| rpm | H | N | baseline integration [s] | ours point, cold [s] | with its multipliers [s] | refined by shooting, with its multipliers [s] | ours per point in a sweep [s] | in a sweep with multipliers [s] | cold-point ratio | ratio with its multipliers | paired ratio with its multipliers, median of 5 (range) | ratio refined by shooting | in-sweep ratio | in-sweep ratio with multipliers | E_h ours | E_h refined | largest |μ| ours | largest |μ| shooting | sweep points restarted cold, of them by the route |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for row in &balance_rows {
        println!("{row}");
    }
    println!();
    println!("the same points by the harmonic balance condensed onto the contact coordinates, cyclic symmetry (dynamics::periodic::CondensedBalance), median of {BALANCE_ROUNDS}:");
    println!("| rpm | H | baseline integration [s] | ours point, cold [s] | with its multipliers [s] | cold-point ratio | ratio with its multipliers | E_h ours | largest |μ| |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for row in &condensed_rows {
        println!("{row}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The condensed balance's row of one speed: the point from a cold start and
/// the point with the whole model's Floquet multipliers (on
/// `MULTIPLIER_INTERVALS_PER_HARMONIC` intervals per harmonic, as its
/// continuation takes them), E_h against `reference`, and the ratios to the
/// baseline's integration time `base`.
fn condensed_row(
    model: &PlanetaryDynamics,
    omega: f64,
    reference: &[planetwear::dynamics::spectrum::Harmonics],
    base: f64,
) -> String {
    use planetwear::analysis::condensed_branch::MULTIPLIER_INTERVALS_PER_HARMONIC;
    use planetwear::dynamics::periodic::{CondensedBalance, Symmetry};
    let shooting_settings = ShootingSettings { samples_per_mesh_cycle: 60, ..ShootingSettings::default() };
    let problem = PeriodicProblem::new(model.clone(), shooting_settings, omega).expect("problem");
    let settings = HarmonicSettings::for_speed(&problem, omega);
    let hb = HarmonicBalance::new(problem, settings).expect("balance");
    let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
    // One solve untimed (the first touch of the receptances' pages).
    cb.solve(omega, None).expect("condensed point");
    let mut orbit = None;
    let cold = median(
        (0..BALANCE_ROUNDS)
            .map(|_| {
                let start = Instant::now();
                orbit = Some(cb.solve(omega, None).expect("condensed point").0);
                start.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let orbit = orbit.expect("ran");
    let harmonics = cb.balance().settings().harmonics;
    let intervals = MULTIPLIER_INTERVALS_PER_HARMONIC * harmonics;
    let mut mu = 0.0;
    let with = median(
        (0..BALANCE_ROUNDS)
            .map(|_| {
                let start = Instant::now();
                let (o, _) = cb.solve(omega, None).expect("condensed point");
                mu = cb.balance().floquet_multipliers(&o, intervals).expect("multipliers")[0].modulus();
                start.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let ours: Vec<_> = cb.balance().steady_state(&orbit).expect("measure").meshes[..2]
        .iter()
        .map(|m| m.harmonics.clone())
        .collect();
    let e = harmonic_error(&ours, reference);
    format!(
        "| {:.0} | {harmonics} | {base:.3} | {cold:.4} | {with:.4} | {:.1} | {:.1} | {e:.1e} | {mu:.4} |",
        omega * 30.0 / std::f64::consts::PI,
        base / cold,
        base / with
    )
}

/// The harmonic-balance row of one speed: the cold point, the point with its
/// multipliers, the per-point time of the sweep `grid` (each point from the
/// one before, H and N by the rule at each speed), E_h of both points against
/// `reference`, the ratios to the baseline's integration time `base`, and the
/// paired ratio of the point with its multipliers (`baseline_once` runs the
/// baseline once and gives its integration time; none without a baseline).
fn balance_row(
    model: &PlanetaryDynamics,
    omega: f64,
    grid: &[f64],
    reference: &[planetwear::dynamics::spectrum::Harmonics],
    base: f64,
    baseline_once: &dyn Fn() -> Option<f64>,
) -> String {
    // The reference's 60 samples per mesh cycle: the measured harmonics alias the force's
    // kinks by the sample count.
    let shooting_settings = ShootingSettings { samples_per_mesh_cycle: 60, ..ShootingSettings::default() };
    let problem = PeriodicProblem::new(model.clone(), shooting_settings, omega).expect("problem");
    let settings = HarmonicSettings::for_speed(&problem, omega);
    let mut hb = HarmonicBalance::new(problem.clone(), settings).expect("balance");
    // One solve untimed: the process's first touch of the Jacobian's pages (about 1 MB) is
    // set-up, not the point's work (the medians of 3 above include their first runs).
    hb.solve(omega, None).expect("balance point");
    let mut orbit = None;
    let cold = median(
        (0..BALANCE_ROUNDS)
            .map(|_| {
                let start = Instant::now();
                orbit = Some(hb.solve(omega, None).expect("balance point"));
                start.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let orbit = orbit.expect("ran");
    let pick = |s: &planetwear::dynamics::response::SteadyState| -> Vec<_> {
        s.meshes[..2].iter().map(|m| m.harmonics.clone()).collect()
    };
    let e_balance = harmonic_error(&pick(&hb.steady_state(&orbit).expect("measure")), reference);
    let mut own_mu = 0.0;
    // The point with its own multipliers, the median of BALANCE_ROUNDS.
    let mut with_own_multipliers = |hb: &mut HarmonicBalance| {
        median(
            (0..BALANCE_ROUNDS)
                .map(|_| {
                    let start = Instant::now();
                    let balanced = hb.solve(omega, None).expect("balance point");
                    let mu = hb.floquet_multipliers(&balanced, settings.samples).expect("multipliers");
                    own_mu = mu[0].modulus();
                    start.elapsed().as_secs_f64()
                })
                .collect(),
        )
    };
    let own = with_own_multipliers(&mut hb);
    // Paired: the baseline once, then our point with its multipliers.
    let mut paired: Vec<f64> = Vec::new();
    for _ in 0..PAIRED_ROUNDS {
        let Some(theirs) = baseline_once() else { break };
        paired.push(theirs / with_own_multipliers(&mut hb));
    }
    let paired = if paired.is_empty() {
        "no baseline".to_string()
    } else {
        let (low, high) = paired.iter().fold((f64::INFINITY, 0.0_f64), |(l, h), r| (l.min(*r), h.max(*r)));
        format!("{:.1} ({low:.1} to {high:.1})", median(paired))
    };
    let mut shot = None;
    let mut shooting = problem.clone();
    let with_multipliers = median(
        (0..BALANCE_ROUNDS)
            .map(|_| {
                let start = Instant::now();
                let balanced = hb.solve(omega, None).expect("balance point");
                let z0 = hb.initial_unknowns(&balanced);
                shot = Some(shooting.solve(omega, Some(&z0)).expect("refined point"));
                start.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let shot = shot.expect("ran");
    let e_shot = harmonic_error(&pick(&shooting.steady_state(&shot).expect("measure")), reference);
    let sweep_problem =
        PeriodicProblem::new(model.clone(), ShootingSettings::default(), grid[0]).expect("problem");
    let sweep_settings = HarmonicSettings::for_speed(&sweep_problem, grid[0]);
    let mut sweep_hb = HarmonicBalance::new(sweep_problem, sweep_settings).expect("balance");
    let (mut restarted, mut failed) = (0, 0);
    // Per point of the sweep, with or without each point's own multipliers.
    let mut in_sweep = |multipliers: bool| {
        median(
            (0..BALANCE_ROUNDS)
                .map(|_| {
                    let start = Instant::now();
                    let mut guess: Option<Vec<f64>> = None;
                    (restarted, failed) = (0, 0);
                    for w in grid {
                        let at = sweep_hb.settings_for_speed(*w);
                        sweep_hb.set_settings(at).expect("settings");
                        // Past a fold the branch the guess lies on ends: a cold start then.
                        let solved = sweep_hb.solve(*w, guess.as_deref()).or_else(|_| {
                            restarted += 1;
                            sweep_hb.solve(*w, None)
                        });
                        match solved {
                            Ok(o) => {
                                if multipliers {
                                    sweep_hb.floquet_multipliers(&o, at.samples).expect("multipliers");
                                }
                                guess = Some(o.coefficients)
                            }
                            // Where Newton does not converge from either, the point comes
                            // from the route.
                            Err(_) => {
                                failed += 1;
                                frame_sweep(model, &[*w], &FrameSweepSettings::default())
                                    .expect("route point");
                            }
                        }
                    }
                    start.elapsed().as_secs_f64() / grid.len() as f64
                })
                .collect(),
        )
    };
    let (in_sweep_own, in_sweep) = (in_sweep(true), in_sweep(false));
    let rpm = omega * 30.0 / std::f64::consts::PI;
    format!(
        "| {rpm:.0} | {} | {} | {base:.3} | {cold:.4} | {own:.4} | {with_multipliers:.4} | {in_sweep:.4} | {in_sweep_own:.4} | {:.1} | {:.1} | {paired} | {:.1} | {:.1} | {:.1} | {e_balance:.1e} | {e_shot:.1e} | {own_mu:.4} | {:.4} | {restarted}, {failed} of {} |",
        settings.harmonics,
        settings.samples,
        base / cold,
        base / own,
        base / with_multipliers,
        base / in_sweep,
        base / in_sweep_own,
        shot.largest_multiplier(),
        grid.len()
    )
}
