//! The outputs a drivetrain model reads per communication step: the
//! extremes of the mesh forces within the step, the held member's reaction
//! torque and the load balance's controller torque.
//!
//! The cases run on the example (`Scene::example_2004`) at 3000 rpm of the
//! sun with the carrier held: a mesh frequency of 1.7 kHz.

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::simulation::Simulation;
use planetwear::model::gear::{Member, MeshKind};
use planetwear::scene::{Fidelity, IntegratorKind, Scene};

const OMEGA: f64 = 3000.0 * std::f64::consts::PI / 30.0;

fn simulation(scene: &Scene) -> (Simulation, f64) {
    let (set, run) = scene.validate_with_run().unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let fm = model.mesh_frequency_per_input_speed * OMEGA;
    (Simulation::new(&set, &run, model, 0.0, OMEGA).unwrap(), fm)
}

/// The generalized-α method takes the same internal steps whatever the
/// communication step (when it is a multiple of the internal step), so one
/// run with steps of 2 mesh cycles and one with steps ten times shorter
/// pass through the same states (to rounding): the long step's extremes
/// bound every force the short steps saw at their ends, and its endpoint
/// force.
#[test]
fn the_step_extremes_bound_the_endpoint_and_every_sub_sample() {
    let mut scene = Scene::example_2004();
    scene.dynamics.integrator = IntegratorKind::GeneralizedAlpha;
    scene.dynamics.fidelity = Fidelity::Torsional;
    let (mut long, fm) = simulation(&scene);
    let (mut short, _) = simulation(&scene);
    let h = 2.0 / fm;
    println!("mesh frequency {fm:.0} Hz: {:.2} mesh cycles per communication step", fm * h);
    let scale = long.gear_set().mesh_load_per_planet();
    let tol = 1e-9 * scale;
    let (mut above, mut below) = (0.0f64, 0.0f64);
    for k in 0..5 {
        long.do_step(long.time(), h).unwrap();
        let e = long.step_extremes().clone();
        let (sun, ring) = (e.mesh(0, MeshKind::SunPlanet).unwrap(), e.mesh(0, MeshKind::RingPlanet).unwrap());
        let (mut sub_min, mut sub_max) = (f64::INFINITY, f64::NEG_INFINITY);
        for j in 0..10 {
            short.do_step(short.time(), h / 10.0).unwrap();
            let f = short.mesh_force(0, MeshKind::SunPlanet);
            sub_min = sub_min.min(f);
            sub_max = sub_max.max(f);
            if j == 9 {
                assert!((f - long.mesh_force(0, MeshKind::SunPlanet)).abs() < tol);
            }
        }
        for p in 0..long.gear_set().planet_angles().len() {
            for mesh in [MeshKind::SunPlanet, MeshKind::RingPlanet] {
                let x = e.mesh(p, mesh).unwrap();
                let end = long.mesh_force(p, mesh);
                assert!(x.min <= end && end <= x.max, "step {k} planet {p} {mesh:?}: {x:?}, endpoint {end}");
                assert!(e.any_max(mesh) >= x.max);
            }
        }
        assert!(
            sun.max >= sub_max - tol && sun.min <= sub_min + tol,
            "step {k}: {sun:?} vs sub-samples [{sub_min}, {sub_max}]",
        );
        assert!(e.any_max(MeshKind::SunPlanet) >= sun.max && e.any_max(MeshKind::RingPlanet) >= ring.max);
        let end = long.mesh_force(0, MeshKind::SunPlanet);
        above = above.max((sun.max - end) / scale);
        below = below.max((end - sun.min) / scale);
    }
    println!("peak above the endpoint up to {above:.3} F0, minimum below it up to {below:.3} F0");
}

/// At communication steps of many mesh cycles the endpoint alone aliases the
/// mesh-frequency content: the peak within the step is never below the
/// endpoint and is above it in all but a few of the 80 mesh-steps (the
/// endpoint is the step's largest sampled point only when it falls on the
/// force's crest, about one time in the 120 points of a mesh cycle), and
/// every step spans the whole fluctuation of the mesh force.
#[test]
fn at_steps_of_many_mesh_cycles_the_peak_sees_what_the_endpoint_misses() {
    let scene = Scene::example_2004();
    let (mut sim, fm) = simulation(&scene);
    let h = 1e-3;
    assert!(fm * h > 1.5, "{} mesh cycles per step", fm * h);
    let f0 = sim.gear_set().mesh_load_per_planet();
    // Run in.
    for _ in 0..5 {
        sim.do_step(sim.time(), h).unwrap();
    }
    let mut smallest_excess = f64::INFINITY;
    let (mut checked, mut missed) = (0, 0);
    for _ in 0..10 {
        sim.do_step(sim.time(), h).unwrap();
        let e = sim.step_extremes();
        let sun = e.mesh(0, MeshKind::SunPlanet).unwrap();
        let end = sim.mesh_force(0, MeshKind::SunPlanet);
        println!(
            "t = {:.3} s: sun mesh endpoint {end:.0} N, step min {:.0} N, peak {:.0} N (all planets {:.0} N); \
             separated {}",
            sim.time(),
            sun.min,
            sun.max,
            e.any_max(MeshKind::SunPlanet),
            e.any_separated(MeshKind::SunPlanet)
        );
        println!(
            "  peak tooth-pair force: sun mesh {:.0} N, ring mesh {:.0} N",
            sun.peak_pair,
            e.mesh(0, MeshKind::RingPlanet).unwrap().peak_pair
        );
        smallest_excess = smallest_excess.min((sun.max - sun.min) / f0);
        assert!(sun.max >= end, "peak {} below endpoint {end}", sun.max);
        for p in 0..sim.gear_set().planet_angles().len() {
            for mesh in [MeshKind::SunPlanet, MeshKind::RingPlanet] {
                let x = e.mesh(p, mesh).unwrap();
                assert!(!x.separated, "no separation at the nominal load: planet {p} {mesh:?}");
                let end = sim.mesh_force(p, mesh);
                assert!(x.max >= end, "planet {p} {mesh:?}: peak {} below endpoint {end}", x.max);
                checked += 1;
                if x.max > end + 1e-9 * f0 {
                    missed += 1;
                }
                // The tooth pairs push on the drive flanks only: none
                // carries more than the whole mesh. Each step spans a
                // stretch of single-pair contact, where the pair carries
                // the mesh force, so the peak pair force reaches at least
                // the step's smallest mesh force.
                assert!(x.peak_pair <= x.max * (1.0 + 1e-12), "planet {p} {mesh:?}: {x:?}");
                assert!(x.peak_pair >= x.min, "planet {p} {mesh:?}: {x:?}");
                assert!(e.any_peak_pair(mesh) >= x.peak_pair);
            }
        }
    }
    // The example's sun-mesh force fluctuates by about a tenth of its mean
    // within each mesh cycle (double- to single-pair contact).
    assert!(smallest_excess > 0.05, "peak-to-peak within a step {smallest_excess} F0");
    assert!(missed + 3 >= checked, "the endpoint missed the step's peak in {missed} of {checked} mesh-steps");
}

/// Without load the meshes separate: the flags say so, and the step's
/// smallest mesh force is zero, or negative where the rattle has driven the
/// back flanks together within the step (which of the two the fifth step
/// shows turns on the rattle's phase, and that on the last bits of the
/// contact tables: −2520 N with today's, zero with tables that differ from
/// them by 2e-17 m).
#[test]
fn an_unloaded_set_reports_separated_meshes() {
    let mut scene = Scene::example_2004();
    scene.dynamics.fidelity = Fidelity::Torsional;
    let (mut sim, _) = simulation(&scene);
    sim.set_torques(0.0, 0.0, 0.0).unwrap();
    for _ in 0..5 {
        sim.do_step(sim.time(), 1e-3).unwrap();
    }
    let e = sim.step_extremes();
    assert!(e.any_separated(MeshKind::SunPlanet) && e.any_separated(MeshKind::RingPlanet), "{e:?}");
    let least = e.mesh(0, MeshKind::SunPlanet).unwrap().min;
    assert!(least <= 0.0, "the smallest sun-mesh force of the step {least} N");
    assert!(e.mesh(sim.gear_set().planet_angles().len(), MeshKind::SunPlanet).is_none());
}

/// Means over whole mesh cycles of the member torques: sun, ring, carrier
/// (the input torques, or for the held member its reaction).
fn mean_member_torques(scene: &Scene) -> ([f64; 3], [f64; 3]) {
    let (mut sim, fm) = simulation(scene);
    let applied = sim.gear_set().balanced_torques();
    let held = sim.gear_set().held();
    // Run in, then average over 34 mesh cycles at 97 samples each (a whole
    // fraction of the mesh cycle would alias the mesh vibration into the
    // mean).
    for _ in 0..40 {
        sim.do_step(sim.time(), 1.0 / fm).unwrap();
    }
    let mut mean = [0.0; 3];
    let n = 34 * 97;
    for _ in 0..n {
        sim.do_step(sim.time(), 1.0 / fm / 97.0).unwrap();
        let r = sim.reaction_torque();
        for (k, m) in [Member::Sun, Member::Ring, Member::Carrier].into_iter().enumerate() {
            mean[k] += if m == held { r } else { applied[k] } / n as f64;
        }
    }
    (mean, applied)
}

/// In a steady state the three members' torques balance on average, the
/// held member's reaction included: sum ≈ 0 to 1e-3 of the largest
/// torque, over 34 mesh cycles, for every held member and both fidelities.
#[test]
fn the_reaction_torque_balances_the_member_torques() {
    for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
        for (held, input) in
            [(Member::Carrier, Member::Sun), (Member::Ring, Member::Sun), (Member::Sun, Member::Carrier)]
        {
            let mut scene = Scene::example_2004();
            scene.dynamics.fidelity = fidelity;
            scene.operation.held = held;
            scene.operation.input = input;
            let (mean, applied) = mean_member_torques(&scene);
            let largest = mean.iter().fold(0.0f64, |a, t| a.max(t.abs()));
            let sum: f64 = mean.iter().sum();
            println!(
                "{fidelity:?}, {held:?} held: mean torques sun, ring, carrier {mean:.2?} N·m; sum {sum:.3e}"
            );
            assert!(sum.abs() < 1e-3 * largest, "{fidelity:?} {held:?}: sum {sum} of {mean:?}");
            if held == Member::Carrier {
                let expected = -(applied[0] + applied[1]);
                assert!((mean[2] / expected - 1.0).abs() < 1e-3, "reaction {} vs {expected}", mean[2]);
            }
        }
    }
}

/// With the load balance an unbalanced input torque does not run away: the
/// controller on the output member holds the speed, and its torque
/// converges to the kinematic balance T_out = −i·T_in (i = ω_in/ω_out, from
/// the mean speeds). Without it the same torque accelerates the set.
///
/// The speeds are means over windows of 17 mesh cycles (10 ms; from the
/// angles), and the torque a mean over 34 mesh cycles at 97 samples each:
/// the instantaneous values carry the mesh vibration, and samples at a
/// whole fraction of the mesh cycle alias it.
#[test]
fn the_load_balance_holds_the_speed_of_an_unbalanced_input() {
    let mut scene = Scene::example_2004();
    scene.dynamics.fidelity = Fidelity::Torsional;
    let t_in = 1.5 * scene.operation.input_torque_nm;
    let window = 10e-3;
    for balance in [false, true] {
        scene.dynamics.load_balance = balance;
        let (mut sim, fm) = simulation(&scene);
        let ring = sim.gear_set().balanced_torques()[1];
        sim.set_torques(t_in, ring, 0.0).unwrap();
        let mut band = (f64::INFINITY, f64::NEG_INFINITY);
        let mut settled = band;
        for k in 0..20 {
            let a0 = sim.angle(Member::Sun);
            sim.do_step(sim.time(), window).unwrap();
            let w = (sim.angle(Member::Sun) - a0) / window;
            band = (band.0.min(w), band.1.max(w));
            if k >= 10 {
                settled = (settled.0.min(w), settled.1.max(w));
            }
            if balance && k % 4 == 3 {
                println!("t = {:.2} s: mean sun speed {w:.3} rad/s over the last 10 ms", sim.time());
            }
        }
        if !balance {
            println!("without load balance: mean sun speed up to {:.1} rad/s in 0.2 s", band.1);
            assert_eq!(sim.balancing_torque(), 0.0);
            assert!(band.1 > 2.0 * OMEGA);
            continue;
        }
        println!(
            "with load balance: mean sun speed within [{:.3}, {:.3}] rad/s over 0.2 s, \
             [{:.4}, {:.4}] rad/s after 0.1 s (reference {OMEGA:.4})",
            band.0, band.1, settled.0, settled.1
        );
        assert!(band.0 > 0.9 * OMEGA && band.1 < 1.5 * OMEGA, "speed band {band:?}");
        assert!(settled.0 > 0.999 * OMEGA && settled.1 < 1.001 * OMEGA, "settled band {settled:?}");
        let (s0, r0, t0) = (sim.angle(Member::Sun), sim.angle(Member::Ring), sim.time());
        let (mut mean, n) = (0.0, 34 * 97);
        for _ in 0..n {
            sim.do_step(sim.time(), 1.0 / fm / 97.0).unwrap();
            mean += sim.balancing_torque() / n as f64;
        }
        let span = sim.time() - t0;
        let (ws, wr) = ((sim.angle(Member::Sun) - s0) / span, (sim.angle(Member::Ring) - r0) / span);
        let expected = -(ws / wr) * t_in;
        println!(
            "mean balancing torque {mean:.2} N·m vs −i·T_in {expected:.2} N·m (i = {:.5}); \
             mean speeds sun {ws:.4}, ring {wr:.4} rad/s",
            ws / wr
        );
        assert!((mean / expected - 1.0).abs() < 1e-3, "balancing torque {mean} vs {expected}");
        // The ring's own torque input is the controller's to replace.
        sim.set_torques(t_in, 0.0, 0.0).unwrap();
        let a0 = sim.angle(Member::Sun);
        sim.do_step(sim.time(), window).unwrap();
        let w = (sim.angle(Member::Sun) - a0) / window;
        assert!((w / OMEGA - 1.0).abs() < 1e-3, "after the ring torque input changed: {w}");
    }
}

/// The load balance's source is part of a snapshot: a restored run
/// continues bit-identically, through a change of the speed reference.
#[test]
fn a_snapshot_with_the_load_balance_continues_bit_identically() {
    let mut scene = Scene::example_2004();
    scene.dynamics.fidelity = Fidelity::Torsional;
    scene.dynamics.load_balance = true;
    let (mut sim, _) = simulation(&scene);
    sim.set_torques(1.2 * scene.operation.input_torque_nm, 0.0, 0.0).unwrap();
    for _ in 0..5 {
        sim.do_step(sim.time(), 1e-3).unwrap();
    }
    sim.set_speed_reference(0.9 * OMEGA).unwrap();
    sim.do_step(sim.time(), 1e-3).unwrap();
    let snap = sim.snapshot();
    let mut first = sim.clone();
    for _ in 0..5 {
        first.do_step(first.time(), 1e-3).unwrap();
    }
    sim.set_speed_reference(OMEGA).unwrap();
    sim.do_step(sim.time(), 1e-3).unwrap();
    sim.restore(&snap).unwrap();
    for _ in 0..5 {
        sim.do_step(sim.time(), 1e-3).unwrap();
    }
    assert_eq!(first.snapshot(), sim.snapshot());
    assert_eq!(first.balancing_torque(), sim.balancing_torque());
    assert_eq!(first.step_extremes(), sim.step_extremes());
}
