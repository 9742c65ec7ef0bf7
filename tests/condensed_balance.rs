//! The harmonic balance condensed onto the contact coordinates (docs/PERIODIC.md §2,
//! "Condensed onto the contact coordinates"): its orbits against long time marching on the
//! example at its transverse–torsional fidelity, unworn and worn, off resonance, near
//! resonance and where the teeth separate; its size independent of the bodies' coordinates;
//! the planets' symmetry and its refusal where the planets differ.

#[path = "support/long_marching.rs"]
mod long_marching;

use long_marching::{long_marched, planet_one, worn_states};
use planetwear::analysis::accuracy::harmonic_error;
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::periodic::{
    highest_frequency, CondensedBalance, HarmonicBalance, HarmonicSettings, PeriodicProblem,
    ShootingSettings, Symmetry,
};
use planetwear::model::gear::GearSet;
use planetwear::model::run::RunSettings;
use planetwear::scene::{Fidelity, Scene};

const RPM: f64 = std::f64::consts::PI / 30.0;

/// The scene's gear set, run settings and model with its flanks worn to state `kappa`.
fn build(scene: &Scene, kappa: usize) -> (GearSet, RunSettings, PlanetaryDynamics) {
    let (set, run) = scene.validate_with_run().unwrap_or_else(|e| panic!("{e}"));
    let contact = if kappa == 0 {
        SetModel::new(&set)
    } else {
        let state = &worn_states()[kappa];
        state.check_gear_set(&set).unwrap();
        state.set_model(&set)
    };
    let model = PlanetaryDynamics::new(&set, contact).unwrap();
    (set, run, model)
}

/// The condensed balance of `model` at `rpm` with the rule's H and N.
fn condensed(model: &PlanetaryDynamics, rpm: f64, symmetry: Symmetry) -> CondensedBalance {
    let omega = rpm * RPM;
    let problem = PeriodicProblem::new(model.clone(), ShootingSettings::default(), omega).unwrap();
    let settings =
        HarmonicSettings::for_frequency(highest_frequency(problem.model(), omega), problem.period(omega));
    CondensedBalance::new(HarmonicBalance::new(problem, settings).unwrap(), symmetry)
}

/// E_h of the cyclic condensed orbit at `rpm` against time marching at relative tolerance
/// 1e-10 from the static state, run in until two successive mesh cycles agree to 1e-10 of
/// the mean tooth force (at most 12 revolutions); also the largest |μ| and the separation.
fn against_marching(kappa: usize, rpm: f64) -> (f64, f64, f64) {
    let (set, run, model) = build(&Scene::example_2004_stiff_pins(), kappa);
    let mut cb = condensed(&model, rpm, Symmetry::Cyclic);
    let (orbit, report) = cb.solve(rpm * RPM, None).unwrap();
    let samples = cb.balance().settings().samples;
    let mu = cb.balance().floquet_multipliers(&orbit, samples).unwrap()[0].modulus();
    let solved = cb.balance().steady_state(&orbit).unwrap();
    let marched = long_marched(&set, &run, model, rpm * RPM);
    let e = harmonic_error(&planet_one(&solved), &planet_one(&marched));
    eprintln!(
        "κ = {kappa}, {rpm} rpm: E_h {e:.3e}, |μ| {mu:.4}, separation {:.4}, {:?} ({} unknowns, {} iterations, \
         symmetry residual {:?})",
        solved.meshes[0].separation, report.symmetry, report.unknowns, report.iterations, report.symmetry_residual
    );
    (e, mu, solved.meshes[0].separation)
}

#[test]
fn condensed_orbits_agree_with_long_marching_unworn() {
    // Off resonance; near the resonance of 2 f_m with the second rotational mode, on the
    // branch marching reaches; the teeth separating.
    for (rpm, separates) in [(3000.0, false), (9000.0, false), (10200.0, true)] {
        let (e, mu, separation) = against_marching(0, rpm);
        assert!(e <= 1e-3, "{rpm} rpm: E_h {e:.3e}");
        assert!(mu < 1.0, "{rpm} rpm: the orbit marching reaches is stable (|μ| {mu:.4})");
        assert_eq!(separation > 0.0, separates, "{rpm} rpm: separation {separation}");
    }
}

#[test]
fn condensed_orbits_agree_with_long_marching_worn() {
    // κ = 6: off resonance, near the resonance wear moved to 7350 rpm, and separating at
    // 8300 rpm (the sun–planet mesh 3 %, the ring–planet 12 % of the period), every planet
    // alike.
    for (rpm, separates) in [(3000.0, false), (7350.0, false), (8300.0, true)] {
        let (e, mu, separation) = against_marching(6, rpm);
        assert!(e <= 1e-3, "κ = 6, {rpm} rpm: E_h {e:.3e}");
        assert!(mu < 1.0, "κ = 6, {rpm} rpm: |μ| {mu:.4}");
        assert_eq!(separation > 0.0, separates, "κ = 6, {rpm} rpm: separation {separation}");
    }
}

/// The cost per point does not grow with the bodies' coordinates: the torsional model, the
/// transverse–torsional example and the example with flexible planet bearings and a floating
/// sun (a sun bearing of 1 kN/m, five orders below the meshes': the sun held by its meshes) all solve for 4 contact coordinates (planet 1's two approaches and the
/// two positions), at the same H the same unknowns, while their models' coordinates differ.
#[test]
fn the_unknowns_do_not_grow_with_the_bodies_coordinates() {
    let mut torsional = Scene::example_2004_stiff_pins();
    torsional.dynamics.fidelity = Fidelity::Torsional;
    let mut floating = Scene::example_2004();
    floating.supports.sun_radial_n_per_m = 1.0e3;
    let settings = HarmonicSettings { harmonics: 48, samples: 768, ..HarmonicSettings::default() };
    let mut seen = Vec::new();
    for (name, scene) in [
        ("torsional", torsional),
        ("transverse–torsional", Scene::example_2004_stiff_pins()),
        ("flexible, floating sun", floating),
    ] {
        let (_, _, model) = build(&scene, 0);
        let omega = 6000.0 * RPM;
        let n = planetwear::dynamics::solver::SecondOrderSystem::dim(&model);
        let problem = PeriodicProblem::new(model, ShootingSettings::default(), omega).unwrap();
        let mut cb =
            CondensedBalance::new(HarmonicBalance::new(problem, settings).unwrap(), Symmetry::Cyclic);
        let (_, report) = cb.solve(omega, None).unwrap();
        eprintln!(
            "{name}: {n} coordinates, {} contact coordinates, {} unknowns",
            report.coordinates, report.unknowns
        );
        assert_eq!(report.symmetry, Symmetry::Cyclic);
        seen.push((n, report.coordinates, report.unknowns));
    }
    assert!(seen[0].0 < seen[1].0, "the models' coordinates differ: {seen:?}");
    assert!(seen.iter().all(|s| s.1 == 4 && s.2 == 4 * 97), "{seen:?}");
}

/// Planets that differ (one planet bearing softer) have no cyclic symmetry: the balance
/// asked for it finds every mesh's residual at the cyclic orbit far above the tolerance,
/// solves with every mesh, and says why; its orbit is the full condensed solve's.
#[test]
fn planets_that_differ_are_solved_with_every_mesh() {
    let mut scene = Scene::example_2004_stiff_pins();
    scene.supports.planet_bearings_n_per_m = Some(vec![3.0e10, 3.0e10, 3.0e9, 3.0e10]);
    let (_, _, model) = build(&scene, 0);
    let rpm = 6000.0;
    let mut asked = condensed(&model, rpm, Symmetry::Cyclic);
    let (orbit, report) = asked.solve(rpm * RPM, None).unwrap();
    eprintln!(
        "{:?}, symmetry residual {:?}: {:?}",
        report.symmetry, report.symmetry_residual, report.cyclic_refused
    );
    assert_eq!(report.symmetry, Symmetry::Full);
    assert!(report.symmetry_residual.unwrap() > 1e-3);
    assert!(report.cyclic_refused.is_some());
    let (full, _) = condensed(&model, rpm, Symmetry::Full).solve(rpm * RPM, None).unwrap();
    let apart =
        orbit.coefficients.iter().zip(&full.coefficients).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(apart <= 1e-6, "{apart:.3e}");
}

/// Continuation on the cyclic condensed balance follows the example's transverse–torsional
/// branch over its first fold (8235 rpm) as continuation by shooting does: the same fold
/// within 1 rpm, each point's largest multiplier the whole model's.
#[test]
fn continuation_on_the_condensed_balance_finds_shootings_fold() {
    use planetwear::analysis::condensed_branch::CondensedBranch;
    use planetwear::analysis::continuation::{
        continue_branch, follow_branch, BifurcationKind, ContinuationSettings,
    };
    let (_, _, model) = build(&Scene::example_2004_stiff_pins(), 0);
    let settings = ContinuationSettings::new(8000.0 * RPM, 8500.0 * RPM, 50.0 * RPM);
    let folds = |b: &planetwear::analysis::continuation::Branch| -> Vec<f64> {
        b.bifurcations.iter().filter(|f| f.kind == BifurcationKind::Fold).map(|f| f.speed / RPM).collect()
    };
    let problem = PeriodicProblem::new(model.clone(), ShootingSettings::default(), 8000.0 * RPM).unwrap();
    let hb = HarmonicBalance::new(problem.clone(), HarmonicSettings::default()).unwrap();
    let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
    let condensed = follow_branch(&mut CondensedBranch::new(&mut cb), &settings, |_| {}).unwrap();
    let mut shooting_problem = problem;
    let shot = continue_branch(&mut shooting_problem, &settings, |_| {}).unwrap();
    let (a, b) = (folds(&condensed), folds(&shot));
    eprintln!(
        "folds: condensed {a:?} ({} points), shooting {b:?} ({} points)",
        condensed.points.len(),
        shot.points.len()
    );
    assert!(!a.is_empty() && !b.is_empty(), "a fold near 8235 rpm: condensed {a:?}, shooting {b:?}");
    assert!((a[0] - b[0]).abs() <= 1.0, "condensed {a:?} against shooting {b:?}");
}

/// The torsional example worn to state `kappa`, its cyclic condensed balance solved at
/// 3000 rpm, and that orbit's contact coordinates.
fn torsional_point_at_3000(kappa: usize) -> (PlanetaryDynamics, CondensedBalance, Vec<f64>) {
    let mut scene = Scene::example_2004_stiff_pins();
    scene.dynamics.fidelity = Fidelity::Torsional;
    let (_, _, model) = build(&scene, kappa);
    let mut cyclic = condensed(&model, 3000.0, Symmetry::Cyclic);
    let (orbit, _) = cyclic.solve(3000.0 * RPM, None).unwrap();
    let from = cyclic.coordinates_of(&orbit).unwrap();
    (model, cyclic, from)
}

/// A restart of the continuation whose march reaches a state that breaks the planets' symmetry
/// goes on along the symmetric branch (`CondensedBalance::solve_on_branch`): from a cyclic
/// branch point's coordinates, a balance that had given up the symmetry (here one built with
/// every mesh) solves with the cyclic unknowns again and finds the cyclic orbit at the next
/// speed, the one a cold cyclic solve finds there, within Newton's tolerance (the settings'
/// 1e-7, relative to the coefficients) of each other.
#[test]
fn a_restart_goes_on_along_the_symmetric_branch() {
    let (model, mut cyclic, from) = torsional_point_at_3000(4);
    let (next, _) = cyclic.solve(3050.0 * RPM, None).unwrap();
    let expected = cyclic.coordinates_of(&next).unwrap();
    let mut every = condensed(&model, 3000.0, Symmetry::Full);
    every.solve(3000.0 * RPM, None).unwrap();
    let x = every.solve_on_branch(3050.0 * RPM, Symmetry::Cyclic, &from).unwrap();
    assert_eq!(every.symmetry(), Symmetry::Cyclic);
    assert_eq!(x.len(), expected.len(), "the cyclic unknowns");
    let size = expected.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let apart = x.iter().zip(&expected).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    eprintln!("{} unknowns, {apart:.3e} apart of {size:.3e}", x.len());
    let tolerance = every.balance().settings().tolerance;
    assert!(apart <= tolerance * size, "{apart:.3e} apart of {size:.3e} (tolerance {tolerance:e})");
}

/// A restart takes the run's coefficients at the H of the run's last fit, while an earlier
/// try of the same restart may have fitted the balance to another speed's H: each try brings
/// them to the balance's H first, and what it returns has the balance's unknowns (two tries
/// at speeds whose rule gives different H, each from the coefficients at 3000 rpm).
#[test]
fn a_restart_takes_coefficients_of_another_h() {
    use planetwear::analysis::condensed_branch::CondensedBranch;
    use planetwear::analysis::continuation::BranchSolver;
    use planetwear::dynamics::response::Work;
    let (_, mut cb, from) = torsional_point_at_3000(0);
    let mut lengths = vec![from.len()];
    let mut branch = CondensedBranch::new(&mut cb);
    let (mut work, mut flows) = (Work::default(), 0);
    for rpm in [1500.0, 3050.0] {
        let x = branch.restart(rpm * RPM, &from, &mut work, &mut flows).expect("a periodic state");
        lengths.push(x.len());
    }
    eprintln!("unknowns: at 3000 rpm, then after the restarts at 1500 and 3050 rpm: {lengths:?}");
    assert_ne!(lengths[1], lengths[0], "the rule's H at 1500 rpm differs from 3000 rpm's");
    assert_eq!(lengths[2], lengths[0], "back at the H of 3050 rpm, 3000 rpm's");
    assert_eq!(lengths[2], cb.unknowns());
}

/// Off the folds each continuation step is corrected at its predicted speed (the speed's row
/// instead of the arclength's, `analysis::continuation`): on the example's transverse–torsional
/// branch from 6000 to 7000 rpm, clear of folds, every step (one unit of arclength there)
/// changes the speed by exactly the tangent's share of it at the point before (to 1e-9 of a
/// nominal step; the pseudo-arclength corrector moves the speed off the prediction), and
/// every point is a periodic state of the balance there.
#[test]
fn off_the_folds_the_points_lie_at_the_predicted_speeds() {
    use planetwear::analysis::condensed_branch::CondensedBranch;
    use planetwear::analysis::continuation::{follow_branch, ContinuationSettings};
    let (_, _, model) = build(&Scene::example_2004_stiff_pins(), 0);
    let step = 50.0 * RPM;
    let settings = ContinuationSettings::new(6000.0 * RPM, 7000.0 * RPM, step);
    let problem = PeriodicProblem::new(model, ShootingSettings::default(), 6000.0 * RPM).unwrap();
    let hb = HarmonicBalance::new(problem, HarmonicSettings::default()).unwrap();
    let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
    let branch = follow_branch(&mut CondensedBranch::new(&mut cb), &settings, |_| {}).unwrap();
    assert!(branch.bifurcations.is_empty() && branch.gaps.is_empty(), "{:?}", branch.bifurcations);
    let points = &branch.points;
    assert!(points.len() >= 20, "{} points", points.len());
    // The last step lands on the last speed instead.
    for pair in points[..points.len() - 1].windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let off = (b.orbit.speed - a.orbit.speed - a.speed_slope).abs() / step;
        assert!(off <= 1e-9, "{} rpm: {off:.2e} of a step off the prediction", b.orbit.speed / RPM);
    }
    for p in points {
        assert!(p.orbit.residual <= 1e-6, "{} rpm: residual {}", p.orbit.speed / RPM, p.orbit.residual);
    }
}

/// A restart whose march breaks the planets' symmetry goes on with every mesh where the run
/// follows broken symmetry (`CondensedBranch::follow_broken_symmetry`): the example at its
/// fidelity, κ = 0, restarted at 11 463 rpm from its cyclic orbit at 11 400 rpm (the up run's
/// symmetric branch, which turns back at its fold at 11 413 rpm), where the marching sweeps
/// load one planet's sun–planet mesh about three times the others'. With the option the
/// balance holds every mesh and the restart's orbit lies more than 5 % of its largest
/// coefficient from the symmetry (a mesh's approach against its delayed copy); without it the
/// restart stays on the cyclic unknowns.
#[test]
fn a_restart_that_breaks_the_symmetry_goes_on_with_every_mesh() {
    use planetwear::analysis::condensed_branch::CondensedBranch;
    use planetwear::analysis::continuation::BranchSolver;
    use planetwear::dynamics::response::Work;
    let (_, _, model) = build(&Scene::example_2004_stiff_pins(), 0);
    let mut cyclic = condensed(&model, 11400.0, Symmetry::Cyclic);
    let (orbit, _) = cyclic.solve(11400.0 * RPM, None).unwrap();
    let from = cyclic.coordinates_of(&orbit).unwrap();
    let omega = 11463.0 * RPM;
    for follow in [false, true] {
        let mut cb = condensed(&model, 11400.0, Symmetry::Cyclic);
        cb.solve(11400.0 * RPM, None).unwrap();
        let mut branch = CondensedBranch::new(&mut cb);
        branch.follow_broken_symmetry(follow);
        let (mut work, mut flows) = (Work::default(), 0);
        let x = branch.restart(omega, &from, &mut work, &mut flows).expect("a restart state");
        assert_eq!(branch.broken_restarts(), usize::from(follow));
        if follow {
            assert_eq!(cb.symmetry(), Symmetry::Full);
            let broken = cb.asymmetry(omega, &x).unwrap();
            eprintln!("with every mesh: {} unknowns, {broken:.3} from the symmetry", x.len());
            assert!(broken > 0.05, "{broken}");
        } else {
            assert_eq!(cb.symmetry(), Symmetry::Cyclic);
            assert_eq!(x.len(), 4 * (2 * cb.balance().settings().harmonics + 1));
        }
    }
}

/// Where the rule's harmonics fall short, the branch point's own spectrum asks for more
/// (`CondensedBranch`, `HarmonicOrbit::spectral_harmonics`): on the study's flexible planet
/// bearings (`example-2004`) at 3000 rpm the rule's H (40, following the modes)
/// leaves E_h above 1e-3 against long marching (a narrow force peak at a contact switch),
/// and the continuation's points from 2975 to 3025 rpm, checked at twice their harmonics,
/// all lie within 1e-3 of marching.
#[test]
fn the_branch_takes_the_harmonics_its_spectrum_asks() {
    use planetwear::analysis::condensed_branch::CondensedBranch;
    use planetwear::analysis::continuation::{follow_branch, ContinuationSettings};
    let scene = Scene::example_2004();
    let (set, run, model) = build(&scene, 0);
    let mut rule = condensed(&model, 3000.0, Symmetry::Cyclic);
    let (orbit, _) = rule.solve(3000.0 * RPM, None).unwrap();
    let solved = rule.balance().steady_state(&orbit).unwrap();
    let at_rule = harmonic_error(
        &planet_one(&solved),
        &planet_one(&long_marched(&set, &run, model.clone(), 3000.0 * RPM)),
    );
    eprintln!("the rule's H {} at 3000 rpm: E_h {at_rule:.2e}", orbit.harmonics);
    assert!(at_rule > 1e-3, "the rule's harmonics suffice here (E_h {at_rule:.2e}): the test shows nothing");
    let mut cb = condensed(&model, 2975.0, Symmetry::Cyclic);
    let settings = ContinuationSettings::new(2975.0 * RPM, 3025.0 * RPM, 50.0 * RPM);
    let mut branch = CondensedBranch::new(&mut cb);
    let found = follow_branch(&mut branch, &settings, |_| {}).unwrap();
    let (checks, kept) = (branch.spectral_checks(), branch.spectral_resolves());
    let orbits = std::mem::take(&mut branch.orbits);
    eprintln!("{checks} checks, {kept} points kept at more harmonics");
    for (point, orbit) in found.points.iter().zip(&orbits) {
        let solved = cb.balance().steady_state(orbit).unwrap();
        let marched = long_marched(&set, &run, model.clone(), point.orbit.speed);
        let e = harmonic_error(&planet_one(&solved), &planet_one(&marched));
        eprintln!("{:.1} rpm, H {}: E_h {e:.2e}", point.orbit.speed / RPM, orbit.harmonics);
        assert!(e <= 1e-3, "{:.1} rpm: E_h {e:.2e}", point.orbit.speed / RPM);
    }
    assert!(checks >= 1 && kept >= 1, "{checks} checks, {kept} points kept at more harmonics");
}

/// A reading compared with another must share its sample grid: on the study's flexible
/// planet bearings (`example-2004`) the sun–planet force has a narrow peak at a
/// contact switch, and its sampled harmonics depend on the grid. The condensed balance's
/// orbit at 2700 rpm (twice the rule's harmonics, as its spectrum asks), sampled at the
/// scene's 240 per mesh cycle, reads F^(rms) within 1e-3 of marching from its state (the
/// marching reading's grid); sampled at 60, the same orbit reads more than 1e-2 away
/// (docs/ACCURACY.md, "Samples per mesh cycle").
#[test]
fn an_orbit_and_marching_agree_on_one_sample_grid() {
    use planetwear::dynamics::response::steady_state;
    let (set, run, model) = build(&Scene::example_2004(), 0);
    let omega = 2700.0 * RPM;
    let samples = run.samples_per_mesh_cycle();
    let reading = |per_cycle: usize| {
        let shooting = ShootingSettings { samples_per_mesh_cycle: per_cycle, ..ShootingSettings::default() };
        let problem = PeriodicProblem::new(model.clone(), shooting, omega).unwrap();
        // Twice the rule's harmonics, as the orbit's spectrum asks here.
        let rule =
            HarmonicSettings::for_frequency(highest_frequency(problem.model(), omega), problem.period(omega));
        let settings = HarmonicSettings { harmonics: 2 * rule.harmonics, samples: 2 * rule.samples, ..rule };
        let mut cb =
            CondensedBalance::new(HarmonicBalance::new(problem, settings).unwrap(), Symmetry::Cyclic);
        let (orbit, _) = cb.solve(omega, None).unwrap();
        cb.balance().steady_state(&orbit).unwrap()
    };
    let on_grid = reading(samples);
    let mut m = model.clone();
    let marched = steady_state(&mut m, &set, &run, omega, Some(&on_grid.end)).unwrap();
    let rms = |s: &planetwear::dynamics::response::SteadyState| s.meshes[0].harmonics.rms;
    let same = (rms(&on_grid) - rms(&marched)).abs() / rms(&marched);
    let other = (rms(&reading(60)) - rms(&marched)).abs() / rms(&marched);
    eprintln!("F^(rms) against marching from the orbit: {same:.2e} on {samples} samples, {other:.2e} on 60");
    assert_eq!(samples, 240);
    assert!(same <= 1e-3, "{same:.2e}");
    assert!(other > 1e-2, "{other:.2e}: the grid no longer matters here, and the test shows nothing");
}
