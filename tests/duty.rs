//! The load duty a run produced (`dynamics::duty`) and its file (`wear::duty`).

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::duty::{input_torque_per_mesh_force, DutyBins, DutyError, LoadDuty};
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::simulation::Simulation;
use planetwear::model::gear::{GearSet, MeshKind};
use planetwear::scene::units::gpa_to_pa;
use planetwear::scene::{Fidelity, Scene};
use planetwear::wear::duty::{DutyCycle, DutyCycleError, FORMAT};

fn edges(from: f64, to: f64, bins: usize) -> Vec<f64> {
    (0..=bins).map(|k| from + (to - from) * k as f64 / bins as f64).collect()
}

#[test]
fn bins_are_half_open_with_the_last_closed_and_outside_values_are_kept() {
    let bins = DutyBins::new(vec![0.0, 10.0, 20.0], vec![0.0, 100.0]).unwrap();
    assert_eq!(bins.bin(0.0, 50.0), Some((0, 0)));
    assert_eq!(bins.bin(10.0, 50.0), Some((1, 0)), "an inner edge opens the next bin");
    assert_eq!(bins.bin(20.0, 100.0), Some((1, 0)), "the last edge closes the last bin");
    assert_eq!(bins.bin(-1e-9, 50.0), None);
    assert_eq!(bins.bin(5.0, 100.0 + 1e-9), None);
    let mut duty = LoadDuty::new(bins, 1);
    duty.record(&[5.0, 25.0], 50.0, 2.0, 0.1).unwrap();
    duty.record(&[15.0, 15.0], 150.0, 3.0, 0.1).unwrap();
    assert_eq!(duty.mesh(0, MeshKind::SunPlanet).unwrap(), &[2.0, 0.0]);
    assert_eq!(duty.outside(0, MeshKind::SunPlanet), Some(3.0));
    assert_eq!(duty.mesh(0, MeshKind::RingPlanet).unwrap(), &[0.0, 0.0]);
    assert_eq!(duty.outside(0, MeshKind::RingPlanet), Some(5.0));
    assert_eq!((duty.total_revolutions(), duty.duration()), (5.0, 0.2));
    duty.check().unwrap();
    assert_eq!(duty.mesh(1, MeshKind::SunPlanet), None, "one planet only");
}

#[test]
fn bad_edges_and_records_are_refused_by_name() {
    let refused = |t: Vec<f64>, s: Vec<f64>| DutyBins::new(t, s).unwrap_err().to_string();
    assert!(refused(vec![0.0], vec![0.0, 1.0]).starts_with("torque_edges"), "one edge");
    assert!(refused(vec![0.0, 1.0], vec![1.0, 1.0]).starts_with("speed_edges"), "not increasing");
    assert!(refused(vec![0.0, f64::NAN], vec![0.0, 1.0]).contains("finite"));
    assert!(refused(edges(0.0, 1.0, 200), edges(0.0, 1.0, 200)).contains("at most 10000 bins"));
    let mut duty = LoadDuty::new(DutyBins::new(vec![0.0, 1.0], vec![0.0, 1.0]).unwrap(), 1);
    let before = duty.clone();
    for (torques, speed, revolutions, duration) in [
        (vec![0.5, f64::NAN], 0.5, 1.0, 1.0),
        (vec![0.5, 0.5], f64::INFINITY, 1.0, 1.0),
        (vec![0.5, 0.5], 0.5, -1.0, 1.0),
        (vec![0.5, 0.5], 0.5, 1.0, f64::NAN),
    ] {
        assert!(matches!(duty.record(&torques, speed, revolutions, duration), Err(DutyError::Record { .. })));
    }
    assert_eq!(duty.record(&[0.5], 0.5, 1.0, 1.0), Err(DutyError::Mismatch("numbers of meshes")));
    assert_eq!(duty, before, "nothing recorded by a refused record");
    let other = LoadDuty::new(DutyBins::new(vec![0.0, 2.0], vec![0.0, 1.0]).unwrap(), 1);
    assert_eq!(duty.add(&other), Err(DutyError::Mismatch("bins")));
}

fn example(fidelity: Fidelity) -> (GearSet, Simulation) {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = fidelity;
    let (set, run) = s.validate_with_run().unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let sim = Simulation::new(&set, &run, model, 0.0, run.input_speed()).unwrap();
    (set, sim)
}

/// Over whole mesh cycles at steady speed the sun's torque balance makes every mesh's mean
/// force balance the input torque (n F̄ r_b = T; the ring mesh's equals the sun mesh's by the
/// planet's balance), and the revolutions are the input angle turned.
#[test]
fn a_run_s_duty_holds_the_input_torque_on_every_mesh_and_its_revolutions() {
    let (set, mut sim) = example(Fidelity::Torsional);
    let torque = set.input_torque().abs();
    let bins = DutyBins::new(edges(0.5 * torque, 1.5 * torque, 200), edges(0.0, 2000.0, 4)).unwrap();
    let omega = sim.speed(set.input());
    let cycle = 1.0
        / (omega
            * planetwear::dynamics::equations::PlanetaryDynamics::new(&set, SetModel::new(&set))
                .unwrap()
                .mesh_frequency_per_input_speed);
    // A run-in of 100 mesh cycles, then 100 steps of 4 mesh cycles each recorded.
    sim.do_step(0.0, 100.0 * cycle).unwrap();
    assert!(sim.duty().is_none(), "no duty unless asked for");
    sim.record_duty(bins);
    let start = sim.angle(set.input());
    for _ in 0..100 {
        sim.do_step(sim.time(), 4.0 * cycle).unwrap();
    }
    let duty = sim.duty().unwrap().clone();
    let turned = (sim.angle(set.input()) - start) / std::f64::consts::TAU;
    assert!(
        (duty.total_revolutions() - turned).abs() <= 1e-9 * turned,
        "{} {turned}",
        duty.total_revolutions()
    );
    let steady = omega * 400.0 * cycle / std::f64::consts::TAU;
    assert!((turned - steady).abs() <= 1e-2 * steady, "turned {turned} at steady speed {steady}");
    let (nt, ns) = duty.bins().shape();
    let t_edges = duty.bins().torque_edges().to_vec();
    let mut worst: f64 = 0.0;
    for p in 0..set.planet_angles().len() {
        for kind in MeshKind::ALL {
            let counts = duty.mesh(p, kind).unwrap();
            assert_eq!(duty.outside(p, kind), Some(0.0), "planet {p} {kind:?} outside the bins");
            let mut weighted = 0.0;
            for i in 0..nt {
                let r: f64 = counts[i * ns..(i + 1) * ns].iter().sum();
                weighted += r * 0.5 * (t_edges[i] + t_edges[i + 1]);
            }
            let mean = weighted / duty.total_revolutions();
            worst = worst.max((mean - torque).abs() / torque);
            assert!(
                (mean - torque).abs() <= 0.02 * torque,
                "planet {} {kind:?}: mean load torque {mean:.2} N·m against the input torque {torque} N·m",
                p + 1
            );
        }
    }
    println!("largest deviation of a mesh's mean load torque from the input torque: {:.3} %", 100.0 * worst);
    assert!(input_torque_per_mesh_force(&set) > 0.0);
}

#[test]
fn a_duty_cycle_file_reads_back_and_refuses_what_it_is_not() {
    let (set, mut sim) = example(Fidelity::Torsional);
    let torque = set.input_torque().abs();
    let bins = DutyBins::new(edges(0.0, 2.0 * torque, 11), edges(0.0, 1000.0, 11)).unwrap();
    sim.record_duty(bins);
    for _ in 0..5 {
        sim.do_step(sim.time(), 1e-3).unwrap();
    }
    let cycle = DutyCycle::new(&set, "simulate", sim.duty().unwrap().clone());
    let text = cycle.to_json().unwrap();
    assert_eq!(DutyCycle::from_json(&text, &set).unwrap(), cycle);

    let refused = |text: &str| DutyCycle::from_json(text, &set).unwrap_err().to_string();
    assert!(refused(&text[..text.len() / 2]).contains("truncated"));
    assert!(refused(&text.replacen(FORMAT, "planetwear-worn-profile", 1)).contains("format is"));
    assert!(refused(&text.replacen("\"version\": 1", "\"version\": 2", 1)).contains("version 2"));
    let altered = text.replacen("\"simulate\"", "\"simulatE\"", 1);
    assert!(refused(&altered).contains("checksum"));

    let mut other = Scene::example_2004();
    other.material.youngs_modulus = gpa_to_pa(210.0);
    let other = other.validate().unwrap();
    let message = DutyCycle::from_json(&text, &other).unwrap_err();
    assert!(matches!(message, DutyCycleError::GearSet { .. }), "{message}");
    assert!(message.to_string().contains("fingerprint"));
}

/// A state saved and restored carries the duty recorded up to it, through the serialized
/// format too, so that a step taken again after a restore is not counted twice.
#[test]
fn a_restored_state_carries_the_duty_recorded_up_to_it() {
    use planetwear::dynamics::state_format::{decode, encode};
    let (set, mut sim) = example(Fidelity::Torsional);
    let torque = set.input_torque().abs();
    sim.record_duty(DutyBins::new(edges(0.0, 2.0 * torque, 11), edges(0.0, 1000.0, 11)).unwrap());
    for _ in 0..3 {
        sim.do_step(sim.time(), 1e-3).unwrap();
    }
    let saved = decode(&encode(&sim.snapshot(), "print"), "print").unwrap();
    let at_save = sim.duty().unwrap().clone();
    sim.do_step(sim.time(), 1e-3).unwrap();
    let once = sim.duty().unwrap().clone();
    sim.restore(&saved).unwrap();
    assert_eq!(sim.duty().unwrap(), &at_save);
    sim.do_step(sim.time(), 1e-3).unwrap();
    assert_eq!(sim.duty().unwrap(), &once, "the step again, counted once");
    let mut other = saved.clone();
    other.duty.pop();
    assert!(sim.restore(&other).is_err(), "a duty of other bins is refused");
}

mod wear_by_duty {
    use super::*;
    use planetwear::wear::archard::{Stop, WearSettings};
    use planetwear::wear::duty_wear::DutyWear;
    use planetwear::wear::flank::Flank;
    use planetwear::wear::state::WornState;
    use planetwear::wear::stepper::WearModel;

    /// A duty of `revolutions` per torque (every mesh alike), 10 s long, on 4 planets.
    fn duty_at(set: &GearSet, torque_edges: Vec<f64>, revolutions: &[(f64, f64)]) -> DutyCycle {
        let bins = DutyBins::new(torque_edges, vec![0.0, 1000.0]).unwrap();
        let mut duty = LoadDuty::new(bins, set.planet_angles().len());
        for &(torque, r) in revolutions {
            duty.record(
                &vec![torque; 2 * set.planet_angles().len()],
                300.0,
                r,
                10.0 / revolutions.len() as f64,
            )
            .unwrap();
        }
        DutyCycle::new(set, "test", duty)
    }

    fn set() -> GearSet {
        Scene::example_2004().validate().unwrap()
    }

    fn largest_difference(a: &WornState, b: &WornState) -> f64 {
        let mut worst: f64 = 0.0;
        for flank in Flank::ALL {
            for (x, y) in a.flanks.get(flank).iter().zip(b.flanks.get(flank)) {
                for (p, q) in x.depth.iter().zip(&y.depth) {
                    worst = worst.max((p - q).abs());
                }
            }
        }
        worst
    }

    /// One bin whose mid torque is the scene's: the duty wears as the scene's own load does
    /// over the same revolutions (the mixture of one bin is that bin's wear).
    #[test]
    fn a_duty_at_the_scene_s_torque_wears_as_the_scene_does() {
        let set = set();
        let torque = set.input_torque();
        let cycle = duty_at(&set, vec![0.5 * torque, 1.5 * torque], &[(torque, 1.0e6)]);
        let settings = WearSettings::for_set(&set);
        let wear = DutyWear::new(&set, None, &settings, &cycle).unwrap();
        let model = WearModel::new(&set, settings).unwrap();
        let unworn = model.unworn();
        let by_duty = wear.advance(&unworn, 5.0).unwrap();
        let by_scene = model.run(&unworn, Stop::Revolutions(5.0e6)).unwrap();
        assert_eq!((by_duty.kappa, by_duty.revolutions), (by_scene.kappa, by_scene.revolutions));
        let depth = by_scene.deepest().depth;
        let diff = largest_difference(&by_duty, &by_scene);
        println!("κ {}, deepest {:.3} µm, largest difference {:.2e} m", by_duty.kappa, depth * 1e6, diff);
        assert!(diff <= 1e-12 * depth, "{diff:e} against {depth:e}");
        // The state records the duty: its fingerprint (the file's checksum), passes and time.
        let record = &by_duty.duty_cycles[0];
        assert_eq!(record.checksum, cycle.fingerprint());
        let doc: serde_json::Value = serde_json::from_str(&cycle.to_json().unwrap()).unwrap();
        assert_eq!(doc["checksum"], record.checksum.as_str());
        assert_eq!((record.passes, record.operating_time, record.kappa), (5.0, 50.0, (0, by_duty.kappa)));
        assert_eq!(by_duty.operating_time, 50.0);
        let back = WornState::from_json(&by_duty.to_json().unwrap(), &set).unwrap();
        assert_eq!(back, by_duty);
    }

    /// Half the revolutions at 0.5 T and half at 1.5 T: each flank wears per revolution the
    /// mean of the two loads' wear (Archard's law summed over the duty), more than at 0.5 T
    /// and less than at 1.5 T.
    #[test]
    fn a_split_duty_wears_the_mean_of_its_loads() {
        let set = set();
        let t = set.input_torque();
        let settings = WearSettings::for_set(&set);
        let unworn = WearModel::new(&set, settings).unwrap().unworn();
        let rate = |cycle: &DutyCycle| {
            let c = DutyWear::new(&set, None, &settings, cycle).unwrap().cycle(&unworn).unwrap();
            c.flank(Flank::SunDrive, 0).unwrap().wear_per_cycle.iter().cloned().fold(0.0, f64::max)
        };
        let edges = vec![0.25 * t, 0.75 * t, 1.25 * t, 1.75 * t];
        let low = rate(&duty_at(&set, edges.clone(), &[(0.5 * t, 1e6)]));
        let high = rate(&duty_at(&set, edges.clone(), &[(1.5 * t, 1e6)]));
        let split = rate(&duty_at(&set, edges, &[(0.5 * t, 1e6), (1.5 * t, 1e6)]));
        println!(
            "largest sun wear per cycle: {low:.4e} (0.5 T), {high:.4e} (1.5 T), {split:.4e} (half each)"
        );
        assert!(low < split && split < high);
        // The maxima of the two may lie at different points: the mixture's is at most their mean.
        assert!(split <= 0.5 * (low + high) * (1.0 + 1e-12));
    }

    #[test]
    fn coast_bins_and_empty_duties_are_refused() {
        let set = set();
        let settings = WearSettings::for_set(&set);
        let coast = duty_at(&set, vec![-100.0, 0.0, 100.0], &[(-50.0, 1e3)]);
        let e = DutyWear::new(&set, None, &settings, &coast).err().unwrap().to_string();
        assert!(e.contains("positive load torque"), "{e}");
        let empty = DutyCycle::new(
            &set,
            "test",
            LoadDuty::new(DutyBins::new(vec![0.0, 1.0], vec![0.0, 1.0]).unwrap(), 4),
        );
        let e = DutyWear::new(&set, None, &settings, &empty).err().unwrap().to_string();
        assert!(e.contains("revolutions"), "{e}");
    }

    /// With dynamic loads, a one-bin duty whose mid torque and mid speed are the scene's wears
    /// per cycle exactly as the scene's own dynamic source at that speed does.
    #[test]
    fn a_dynamic_duty_at_one_operating_point_wears_as_the_dynamic_source_there() {
        use planetwear::wear::archard::PressureSource;
        let (set, run) = Scene::example_2004().validate_with_run().unwrap();
        let (torque, omega) = (set.input_torque(), run.input_speed());
        let bins = DutyBins::new(vec![0.5 * torque, 1.5 * torque], vec![0.5 * omega, 1.5 * omega]).unwrap();
        let mut duty = LoadDuty::new(bins, set.planet_angles().len());
        duty.record(&vec![torque; 2 * set.planet_angles().len()], omega, 1e3, 1.0).unwrap();
        let cycle = DutyCycle::new(&set, "test", duty);
        let mut settings = WearSettings::for_set(&set);
        settings.source = PressureSource::Dynamic { speed: omega };
        let wear = DutyWear::new(&set, Some(&run), &settings, &cycle).unwrap();
        assert_eq!(wear.bins(), 1);
        let model = WearModel::with_run(&set, &run, settings).unwrap();
        let unworn = model.unworn();
        let (by_duty, by_scene) = (wear.cycle(&unworn).unwrap(), model.cycle(&unworn).unwrap());
        let a = &by_duty.flank(Flank::SunDrive, 0).unwrap().wear_per_cycle;
        let b = &by_scene.flank(Flank::SunDrive, 0).unwrap().wear_per_cycle;
        let top = b.iter().cloned().fold(0.0, f64::max);
        let diff = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        println!("dynamic: largest sun wear per cycle {top:.4e} m, largest difference {diff:.2e} m");
        assert!(top > 0.0 && diff <= 1e-12 * top, "{diff:e} against {top:e}");
    }
}
