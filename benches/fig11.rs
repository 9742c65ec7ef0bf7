//! The study's forced-response figure (Fig. 11): the example at the worn
//! states κ = 0, 2, 4, 6, 500 to 15 000 rpm in 50 rpm steps, up and down,
//! planet 1's sun–planet and ring–planet mesh forces, at the default accuracy
//! (RK 5(4) at 3e-6). Prints the wall time of the figure (model set-up of the
//! four states and the eight sweeps, on rayon's threads), then E_h of
//! docs/ACCURACY.md at a few points against long time marching (RK 5(4) at
//! 1e-10 from the static state, 300 mesh cycles of run-in, 8 measured).
//!
//! The route: `analysis::frame_sweep` (marching in the rigid-body frame one
//! mesh cycle at a time, one cycle measured once the state repeats).
//! Run: `cargo bench --bench fig11` (the study's fidelity, transverse–torsional);
//! `-- --torsional` for the torsional level; `-- --absolute` for the
//! marching sweep of `planetwear sweep` instead (absolute coordinates, with
//! `dynamics::response::Window::Periodic`; `-- --full-window` for its whole
//! two-revolution window at every point); `-- --quick` for a 500 rpm grid;
//! `-- --no-check` skips the E_h check; `-- --continuation` draws the figure
//! as the continuation's equivalent instead: each state's branches of period-1
//! orbits by pseudo-arclength continuation on the harmonic balance
//! (`analysis::continuation::BalanceBranch`), up from 500 and down from
//! 15 000 rpm at the nominal step, folds and unstable stretches included
//! (the response where no period-1 orbit is stable is not part of it); each
//! state's down run after its up run, ending where it joins the up run's
//! unbroken stretch from 500 rpm (`follow_joining`: below, the down run
//! would retrace it), the four states on rayon's threads; `-- --no-join`
//! runs the eight runs independently to their ends; `-- --continuation
//! --condensed` runs them on the harmonic balance condensed onto the contact
//! coordinates with the planets' cyclic symmetry
//! (`analysis::condensed_branch::CondensedBranch`), and with `--broken-symmetry`
//! a restart that reaches a state breaking the symmetry goes on with every mesh.
//! `-- --scene=NAME` draws it for another built-in scene on the example's
//! geometry (`example-2004`: the study's bearings and damping).
//! The wear model that makes the states runs first and is timed apart (the
//! figure starts from the states, as the study's does).
//! docs/PERFORMANCE.md records the figures.

use std::time::Instant;

use rayon::prelude::*;

use planetwear::analysis::accuracy::{harmonic_error, reference, Protocol};
use planetwear::analysis::condensed_branch::CondensedBranch;
use planetwear::analysis::continuation::{
    follow_branch, follow_joining, BalanceBranch, BifurcationKind, Branch, ContinuationSettings,
};
use planetwear::analysis::frame_sweep::{frame_sweep, FrameSweepSettings};
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::periodic::{
    CondensedBalance, HarmonicBalance, HarmonicSettings, PeriodicProblem, ShootingSettings, Symmetry,
};
use planetwear::dynamics::response::{sweep_from, Direction, Sweep, Window};
use planetwear::dynamics::solver::SecondOrderSystem;
use planetwear::model::gear::GearSet;
use planetwear::scene::units::rpm_to_rad_per_s;
use planetwear::scene::{Fidelity, Scene};

const KAPPAS: [usize; 4] = [0, 2, 4, 6];

/// Successive mesh cycles agree to this fraction of the mean tooth force at a
/// periodic point (E_h ≤ 1e-3 asks for harmonics right to about 1e-4 of it).
const PERIODIC_TOLERANCE: f64 = 1e-5;

fn main() {
    let arg = |name: &str| std::env::args().any(|a| a == name);
    let name = std::env::args().find_map(|a| a.strip_prefix("--scene=").map(str::to_string));
    let mut scene = match name.as_deref() {
        None => Scene::example_2004(),
        Some(n) => Scene::builtin(n).unwrap_or_else(|| panic!("--scene={n}: not a built-in scene")),
    };
    if arg("--torsional") {
        scene.dynamics.fidelity = Fidelity::Torsional;
    }
    println!("scene {}", scene.name);
    let window = if arg("--full-window") {
        Window::Fixed
    } else {
        Window::Periodic { cycles: 1, tolerance: PERIODIC_TOLERANCE }
    };
    let step = if arg("--quick") { 500.0 } else { 50.0 };
    let window =
        match std::env::args().find_map(|a| a.strip_prefix("--periodic-tolerance=").map(str::to_string)) {
            Some(t) if window != Window::Fixed => {
                Window::Periodic { cycles: 1, tolerance: t.parse().expect("a number") }
            }
            _ => window,
        };
    let (set, run) = scene.validate_with_run().expect("the example is valid");
    if arg("--continuation") {
        continuation(
            &set,
            step,
            arg("--no-check"),
            !arg("--no-join"),
            (arg("--condensed"), arg("--broken-symmetry")),
        );
        return;
    }

    let wear_start = Instant::now();
    let states = planetwear::package::pack::example_wear_states().expect("the example's wear run");
    let wear_time = wear_start.elapsed().as_secs_f64();

    let n = ((15000.0 - 500.0) / step) as usize + 1;
    let up: Vec<f64> = (0..n).map(|i| rpm_to_rad_per_s(500.0 + step * i as f64)).collect();
    let mut down = up.clone();
    down.reverse();

    let start = Instant::now();
    let cpu_start = cpu_time::ProcessTime::now();
    let models: Vec<PlanetaryDynamics> = KAPPAS
        .par_iter()
        .map(|&k| PlanetaryDynamics::new(&set, states[k].set_model(&set)).expect("model"))
        .collect();
    let built = start.elapsed().as_secs_f64();
    let tasks: Vec<(usize, Direction)> =
        (0..KAPPAS.len()).flat_map(|i| [(i, Direction::Up), (i, Direction::Down)]).collect();
    let frame = !arg("--absolute");
    let settings = FrameSweepSettings::default();
    let sweeps: Vec<(usize, Sweep)> = tasks
        .par_iter()
        .map(|&(i, dir)| {
            let grid = if dir == Direction::Up { &up } else { &down };
            if frame {
                let points = frame_sweep(&models[i], grid, &settings).expect("sweep");
                let periodic = points.iter().filter(|p| p.periodic).count();
                let points = points.into_iter().map(|p| p.state).collect();
                eprintln!("  κ = {} {dir:?}: {periodic} periodic points", KAPPAS[i]);
                (i, Sweep { direction: dir, points })
            } else {
                let mut m = models[i].clone();
                (i, sweep_from(&set, &run, &mut m, dir, grid, &[], window, None, |_| {}).expect("sweep"))
            }
        })
        .collect();
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_start.elapsed().as_secs_f64();

    let points: usize = sweeps.iter().map(|(_, s)| s.points.len()).sum();
    let steps: u64 = sweeps.iter().flat_map(|(_, s)| &s.points).map(|p| p.stats.steps).sum();
    let short = sweeps.iter().flat_map(|(_, s)| &s.points).filter(|p| p.cycles == 1).count();
    let route = if frame {
        format!("marching in the rigid-body frame, {settings:?}")
    } else {
        format!("marching in absolute coordinates (the sweep's RK 5(4) at 3e-6), window {window:?}")
    };
    println!(
        "Fig. 11: {:?}, κ = {KAPPAS:?}, {n} speeds × 2 directions, {} threads, {route}",
        set.fidelity(),
        rayon::current_num_threads()
    );
    println!("  wear model to κ = 6 (not part of the figure): {wear_time:.2} s");
    println!("  model set-up of the four states (contact tables, LTCA mean stiffness): {built:.2} s");
    println!("  WALL TIME of the figure (set-up and eight sweeps): {wall:.2} s (CPU time of this process {cpu:.2} s)");
    println!(
        "  {points} points ({short} periodic, measured over one mesh cycle), {steps} steps, {:.0} ns CPU per step per DOF (set-up included)",
        cpu * 1e9 / steps as f64 / models[0].dim() as f64,
    );
    if arg("--no-check") {
        return;
    }
    // E_h at points away from the jumps, on the up sweep, against long time marching on
    // the same sample grid (60 per cycle at the cycle boundaries, as the sweep samples).
    let protocol =
        Protocol { run_in_cycles: 300, window_cycles: 8, samples_per_cycle: 60, sample_phase: 0.0 };
    let checks: Vec<(usize, f64)> = vec![(0, 3000.0), (3, 3000.0), (0, 6500.0), (3, 14000.0)];
    let errors: Vec<(usize, f64, f64)> = checks
        .par_iter()
        .map(|&(i, rpm)| {
            let omega = rpm_to_rad_per_s(rpm);
            let up_sweep =
                &sweeps.iter().find(|(j, s)| *j == i && s.direction == Direction::Up).expect("up").1;
            let point = up_sweep
                .points
                .iter()
                .find(|p| (p.input_speed - omega).abs() < 1e-9 * omega)
                .expect("the check speed is on the grid");
            let r = reference(&models[i], omega, &protocol, 1e-10).expect("reference");
            let ours: Vec<_> = point.meshes[..2].iter().map(|m| m.harmonics.clone()).collect();
            (KAPPAS[i], rpm, harmonic_error(&ours, &r.measured.harmonics))
        })
        .collect();
    let mut largest: f64 = 0.0;
    for (k, rpm, e) in &errors {
        println!("  E_h at κ = {k}, {rpm:.0} rpm (up sweep): {e:.2e}");
        largest = largest.max(*e);
    }
    println!("  LARGEST E_h of the checked points: {largest:.2e} (target ≤ 1e-3)");
}

/// The figure as the continuation's equivalent: per wear state an up run
/// (500 → 15 000 rpm) and a down run (15 000 → 500 rpm) of pseudo-arclength
/// continuation on the harmonic balance at the nominal step `step` [rpm]
/// (with `join`, each down run after its state's up run, ending where it
/// joins that run's unbroken stretch; without, the eight runs independent),
/// on rayon's threads; then E_h of the up runs' points nearest the check
/// speeds against long time marching at those points' speeds.
fn continuation(set: &GearSet, step: f64, no_check: bool, join: bool, (condensed, broken): (bool, bool)) {
    let wear_start = Instant::now();
    let states = planetwear::package::pack::example_wear_states().expect("the example's wear run");
    let wear_time = wear_start.elapsed().as_secs_f64();
    // The samples of the route's check (60 per mesh cycle): the harmonics of a kinked force
    // depend on the sample grid through aliasing.
    let shooting = ShootingSettings { samples_per_mesh_cycle: 60, ..ShootingSettings::default() };
    let start = Instant::now();
    let cpu_start = cpu_time::ProcessTime::now();
    let models: Vec<PlanetaryDynamics> = KAPPAS
        .par_iter()
        .map(|&k| PlanetaryDynamics::new(set, states[k].set_model(set)).expect("model"))
        .collect();
    let built = start.elapsed().as_secs_f64();
    let one = |i: usize, a: f64, b: f64, other: Option<&Branch>| {
        let t0 = Instant::now();
        let problem =
            PeriodicProblem::new(models[i].clone(), shooting, rpm_to_rad_per_s(a)).expect("problem");
        let mut hb = HarmonicBalance::new(problem, HarmonicSettings::default()).expect("balance");
        let settings =
            ContinuationSettings::new(rpm_to_rad_per_s(a), rpm_to_rad_per_s(b), rpm_to_rad_per_s(step));
        let (branch, orbits) = if condensed {
            let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
            let mut solver = CondensedBranch::new(&mut cb);
            solver.follow_broken_symmetry(broken);
            let branch = match other {
                Some(o) => follow_joining(&mut solver, &settings, o, |_| {}),
                None => follow_branch(&mut solver, &settings, |_| {}),
            }
            .expect("continuation");
            eprintln!(
                "  κ = {} {a:.0} → {b:.0} rpm: {} points checked at twice their harmonics, {} kept them",
                KAPPAS[i],
                solver.spectral_checks(),
                solver.spectral_resolves()
            );
            let orbits = std::mem::take(&mut solver.orbits);
            hb = cb.into_balance();
            (branch, orbits)
        } else {
            let mut solver = BalanceBranch::new(&mut hb);
            let branch = match other {
                Some(o) => follow_joining(&mut solver, &settings, o, |_| {}),
                None => follow_branch(&mut solver, &settings, |_| {}),
            }
            .expect("continuation");
            (branch, std::mem::take(&mut solver.orbits))
        };
        let folds = branch.bifurcations.iter().filter(|b| b.kind == BifurcationKind::Fold).count();
        let unstable = branch.points.iter().filter(|p| !p.stable).count();
        eprintln!(
            "  κ = {} {a:.0} → {b:.0} rpm: {} points ({unstable} unstable), {folds} folds, {} gaps, {:.2} s; {}",
            KAPPAS[i],
            branch.points.len(),
            branch.gaps.len(),
            t0.elapsed().as_secs_f64(),
            branch.ended
        );
        (i, a < b, branch, orbits, hb)
    };
    let runs: Vec<_> = if join {
        (0..KAPPAS.len())
            .into_par_iter()
            .flat_map_iter(|i| {
                let up = one(i, 500.0, 15000.0, None);
                let down = one(i, 15000.0, 500.0, Some(&up.2));
                [up, down]
            })
            .collect()
    } else {
        let tasks: Vec<(usize, f64, f64)> =
            (0..KAPPAS.len()).flat_map(|i| [(i, 500.0, 15000.0), (i, 15000.0, 500.0)]).collect();
        tasks.par_iter().map(|&(i, a, b)| one(i, a, b, None)).collect()
    };
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_start.elapsed().as_secs_f64();
    let points: usize = runs.iter().map(|r| r.2.points.len()).sum();
    let evaluations: u64 = runs.iter().map(|r| r.2.work.rhs_evaluations).sum();
    println!(
        "Fig. 11 as the continuation's equivalent: {:?}, κ = {KAPPAS:?}, 500–15 000 rpm up and down, \
         nominal step {step} rpm, {}, {} threads, {}",
        set.fidelity(),
        match (condensed, broken) {
            (true, true) => "harmonic balance condensed onto the contact coordinates, cyclic symmetry, symmetry-broken branches with every mesh",
            (true, false) => "harmonic balance condensed onto the contact coordinates, cyclic symmetry",
            _ => "harmonic balance",
        },
        rayon::current_num_threads(),
        if join { "each down run joining its up run" } else { "the eight runs independent" }
    );
    println!("  wear model to κ = 6 (not part of the figure): {wear_time:.2} s");
    println!("  model set-up of the four states: {built:.2} s");
    println!("  WALL TIME of the figure (set-up and eight runs): {wall:.2} s (CPU time of this process {cpu:.2} s)");
    println!("  {points} branch points, {evaluations} force evaluations");
    if no_check {
        return;
    }
    let protocol =
        Protocol { run_in_cycles: 300, window_cycles: 8, samples_per_cycle: 60, sample_phase: 0.0 };
    let checks: Vec<(usize, f64)> = vec![(0, 3000.0), (3, 3000.0), (0, 6500.0), (3, 14000.0)];
    let mut runs = runs;
    let mut largest: f64 = 0.0;
    for (i, rpm) in checks {
        let omega = rpm_to_rad_per_s(rpm);
        let run = runs.iter_mut().find(|r| r.0 == i && r.1).expect("the up run");
        let (k, _) = run
            .2
            .points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.stable)
            .min_by(|a, b| (a.1.orbit.speed - omega).abs().total_cmp(&(b.1.orbit.speed - omega).abs()))
            .expect("a stable point");
        let orbit = run.3[k].clone();
        let state = run.4.steady_state(&orbit).expect("forces");
        let r = reference(&models[i], orbit.speed, &protocol, 1e-10).expect("reference");
        let ours: Vec<_> = state.meshes[..2].iter().map(|m| m.harmonics.clone()).collect();
        let e = harmonic_error(&ours, &r.measured.harmonics);
        println!(
            "  E_h at κ = {}, {:.1} rpm (the up run's stable point nearest {rpm:.0} rpm): {e:.2e}",
            KAPPAS[i],
            orbit.speed * 30.0 / std::f64::consts::PI
        );
        largest = largest.max(e);
    }
    println!("  LARGEST E_h of the checked points: {largest:.2e} (target ≤ 1e-3)");
}
