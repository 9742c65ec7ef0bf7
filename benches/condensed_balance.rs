//! The harmonic balance condensed onto the contact coordinates against the
//! other periodic solvers and against time marching, on the example:
//!
//! 1. One periodic state, cold start, at 3000, 6000 and 10 200 rpm on three
//!    models with ever more coordinates (torsional; the transverse–torsional
//!    example; the example on flexible planet bearings with a floating sun):
//!    shooting, the full balance, the condensed balance with every mesh, and
//!    the condensed balance with cyclic symmetry. Wall time (median of 3),
//!    Newton's unknowns, and E_h against shooting's orbit (itself within 5e-5
//!    of long time marching, tests/periodic.rs).
//! 2. The transverse–torsional example's forced response, κ = 0, 500 to
//!    15 000 rpm at 50 rpm, both directions (one thread each): continuation
//!    on the cyclic condensed balance against the marching sweep, in the
//!    same run.
//!
//! 3. `-- --held`: below about 2600 rpm the rule's H on the example exceeds
//!    `CONDENSED_MAX_HARMONICS`; E_h of the cyclic condensed orbit against
//!    shooting's at H = 128, 160, 192 and 256 (N per H as the rule's), and the wall time of one
//!    solve, at 500 to 2500 rpm: the measurement behind the constant.
//!
//! Run: `cargo bench --bench condensed_balance` (parts 1 and 2; one part only:
//! `-- --points`, `-- --forced`, `-- --held`); docs/PERFORMANCE.md records the
//! figures with the machine.

use std::time::Instant;

use planetwear::analysis::accuracy::harmonic_error;
use planetwear::analysis::condensed_branch::CondensedBranch;
use planetwear::analysis::continuation::{follow_branch, ContinuationSettings};
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::periodic::{
    highest_frequency, CondensedBalance, HarmonicBalance, HarmonicSettings, PeriodicProblem,
    ShootingSettings, Symmetry,
};
use planetwear::dynamics::response::{sweep, Direction, SteadyState};
use planetwear::dynamics::solver::SecondOrderSystem;
use planetwear::dynamics::spectrum::Harmonics;
use planetwear::scene::{Fidelity, Scene};
use rayon::prelude::*;

const RPM: f64 = std::f64::consts::PI / 30.0;

fn pick(s: &SteadyState) -> Vec<Harmonics> {
    vec![s.meshes[0].harmonics.clone(), s.meshes[1].harmonics.clone()]
}

/// Median wall time [s] of three runs of `f`, and its last result.
fn timed<T>(mut f: impl FnMut() -> T) -> (f64, T) {
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..3 {
        let t = Instant::now();
        last = Some(f());
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    (times[1], last.expect("three runs"))
}

fn scenes() -> Vec<(&'static str, Scene)> {
    let mut torsional = Scene::example_2004_stiff_pins();
    torsional.dynamics.fidelity = Fidelity::Torsional;
    // A floating sun: a sun bearing five orders below the meshes' stiffness.
    let mut floating = Scene::example_2004();
    floating.supports.sun_radial_n_per_m = 1.0e3;
    vec![
        ("torsional", torsional),
        ("transverse–torsional (example-2004-stiff-pins)", Scene::example_2004_stiff_pins()),
        ("flexible planet bearings, floating sun", floating),
    ]
}

fn points() {
    println!("| model (coordinates) | rpm | method | unknowns | wall [ms] | E_h against shooting |");
    println!("|---|---|---|---|---|---|");
    for (name, scene) in scenes() {
        let set = scene.validate().expect("valid scene");
        let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
        let n = model.dim();
        for rpm in [3000.0, 6000.0, 10200.0] {
            let omega = rpm * RPM;
            let problem =
                PeriodicProblem::new(model.clone(), ShootingSettings::default(), omega).expect("problem");
            let (t, (orbit, reference)) = timed(|| {
                let mut p = problem.clone();
                let orbit = p.solve(omega, None).expect("shooting");
                let state = p.steady_state(&orbit).expect("state");
                (orbit, state)
            });
            let row = |method: &str, unknowns: usize, t: f64, e: Option<f64>| {
                let e = e.map_or("—".to_string(), |e| format!("{e:.1e}"));
                println!("| {name} ({n}) | {rpm} | {method} | {unknowns} | {:.1} | {e} |", 1e3 * t);
            };
            row("shooting", orbit.z.len(), t, None);
            let settings = HarmonicSettings::for_frequency(
                highest_frequency(problem.model(), omega),
                problem.period(omega),
            );
            let (t, full) = timed(|| {
                let mut hb = HarmonicBalance::new(problem.clone(), settings).expect("balance");
                let orbit = hb.solve(omega, None).ok()?;
                let state = hb.steady_state(&orbit).ok()?;
                Some((hb.unknowns(), state))
            });
            match full {
                Some((unknowns, state)) => {
                    row("full balance", unknowns, t, Some(harmonic_error(&pick(&state), &pick(&reference))))
                }
                None => row("full balance: no convergence", 0, t, None),
            }
            for (label, symmetry) in
                [("condensed, every mesh", Symmetry::Full), ("condensed, cyclic", Symmetry::Cyclic)]
            {
                let (t, solved) = timed(|| {
                    let hb = HarmonicBalance::new(problem.clone(), settings).expect("balance");
                    let mut cb = CondensedBalance::new(hb, symmetry);
                    let (orbit, report) = cb.solve(omega, None).ok()?;
                    let state = cb.balance().steady_state(&orbit).ok()?;
                    Some((report.unknowns, state))
                });
                match solved {
                    Some((unknowns, state)) => {
                        row(label, unknowns, t, Some(harmonic_error(&pick(&state), &pick(&reference))))
                    }
                    None => row(&format!("{label}: no convergence from the static state"), 0, t, None),
                }
            }
        }
    }
}

fn forced_response() {
    let scene = Scene::example_2004_stiff_pins();
    let (set, run) = scene.validate_with_run().expect("valid scene");
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
    let (from, to, step) = (500.0, 15000.0, 50.0);
    let started = Instant::now();
    let branches: Vec<(usize, f64)> = [(from, to), (to, from)]
        .par_iter()
        .map(|&(a, b)| {
            let t = Instant::now();
            let problem =
                PeriodicProblem::new(model.clone(), ShootingSettings::default(), a * RPM).expect("problem");
            let hb = HarmonicBalance::new(problem, HarmonicSettings::default()).expect("balance");
            let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
            let settings = ContinuationSettings::new(a * RPM, b * RPM, step * RPM);
            let branch =
                follow_branch(&mut CondensedBranch::new(&mut cb), &settings, |_| {}).expect("branch");
            (branch.points.len(), t.elapsed().as_secs_f64())
        })
        .collect();
    let continuation = started.elapsed().as_secs_f64();
    let n = ((to - from) / step).round() as usize + 1;
    let speeds: Vec<f64> = (0..n).map(|i| (from + step * i as f64) * RPM).collect();
    let started = Instant::now();
    let marched: Vec<usize> = [Direction::Up, Direction::Down]
        .par_iter()
        .map(|&d| {
            let mut m = model.clone();
            let mut s = speeds.clone();
            if d == Direction::Down {
                s.reverse();
            }
            sweep(&set, &run, &mut m, d, &s, &[], |_| {}).expect("sweep").points.len()
        })
        .collect();
    let marching = started.elapsed().as_secs_f64();
    println!();
    println!(
        "forced response, example-2004-stiff-pins, κ = 0, {from}–{to} rpm at {step} rpm, both directions:"
    );
    println!(
        "  continuation on the cyclic condensed balance: {continuation:.1} s wall ({} and {} points; {:.1} and {:.1} s)",
        branches[0].0, branches[1].0, branches[0].1, branches[1].1
    );
    println!("  marching sweep: {marching:.1} s wall ({} and {} speeds)", marched[0], marched[1]);
    println!("  ratio: {:.2}", marching / continuation);
}

/// E_h against shooting and wall time of the cyclic condensed balance at held H (part 3).
fn held_harmonics() {
    let scene = Scene::example_2004_stiff_pins();
    let set = scene.validate().expect("valid scene");
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
    let held = [128, 160, 192, 256];
    println!("| rpm | the rule's H | {} |", held.map(|h| format!("H = {h}: E_h, wall [ms]")).join(" | "));
    println!("|---|---|{}", "---|".repeat(held.len()));
    for rpm in [500.0, 1000.0, 1500.0, 2000.0, 2500.0] {
        let omega = rpm * RPM;
        let mut problem =
            PeriodicProblem::new(model.clone(), ShootingSettings::default(), omega).expect("problem");
        let orbit = problem.solve(omega, None).expect("shooting");
        let reference = problem.steady_state(&orbit).expect("state");
        let rule =
            HarmonicSettings::for_frequency(highest_frequency(problem.model(), omega), problem.period(omega));
        let cells: Vec<String> = held
            .iter()
            .map(|&h| {
                let settings =
                    HarmonicSettings { harmonics: h, samples: rule.samples / rule.harmonics * h, ..rule };
                let (t, state) = timed(|| {
                    let hb = HarmonicBalance::new(problem.clone(), settings).expect("balance");
                    let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
                    let (orbit, _) = cb.solve(omega, None).ok()?;
                    cb.balance().steady_state(&orbit).ok()
                });
                match state {
                    Some(state) => {
                        format!("{:.1e}, {:.0}", harmonic_error(&pick(&state), &pick(&reference)), 1e3 * t)
                    }
                    None => "no convergence".to_string(),
                }
            })
            .collect();
        println!("| {rpm} | {} | {} |", rule.harmonics, cells.join(" | "));
    }
}

fn main() {
    if std::env::args().any(|a| a == "--held") {
        held_harmonics();
        return;
    }
    if std::env::args().any(|a| a == "--forced") {
        forced_response();
        return;
    }
    let only_points = std::env::args().any(|a| a == "--points");
    points();
    if !only_points {
        forced_response();
    }
}
