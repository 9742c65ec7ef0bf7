//! The deformable contact law in the dynamics (`dynamics.contact =
//! "deformable"`): the tabulated law carries no load exactly where its event
//! values say no flank touches, its energy integrates to its force, the
//! dynamic model reads it (its mesh forces are the exact joint solution's),
//! energy is conserved on it, and the scene's key is checked.

#[path = "support/energy_balance.rs"]
mod energy_balance;
#[path = "support/in_phase.rs"]
mod in_phase;
use energy_balance::energy_balance;
use in_phase::in_phase_scene;
use nalgebra::DMatrix;
use planetwear::contact::deformable::set::DeformableSet;
use planetwear::contact::ltca::SetModel;
use planetwear::contact::mesh_law::MeshContact;
use planetwear::contact::separation::MeshFlanks;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::solver::SecondOrderSystem;
use planetwear::model::gear::MeshKind;
use planetwear::scene::{ContactModel, DampingModel, Fidelity, Scene};

/// A small deterministic generator in [0, 1).
fn uniform(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// On the example's finite-element law, at 2000 random (s, δ) per mesh from
/// below the first contact of the back flank to three nominal approaches
/// beyond the drive flank's: the force is zero where both event values are
/// at most zero and carries the sign of the flank whose event is positive;
/// ∂V/∂δ of the stored energy equals the force and ∂V/∂s its partial
/// derivative (central differences, to 1e-5 of the nominal load).
#[test]
fn the_law_is_zero_where_its_events_say_and_its_energy_integrates_to_it() {
    let set = Scene::example_2004().validate().unwrap();
    let law = DeformableSet::of_gear_set(&set, &MeshFlanks::default(), &MeshFlanks::default()).unwrap();
    let load = set.mesh_load_per_planet();
    let mut seed = 7u64;
    for kind in MeshKind::ALL {
        let t = law.mesh(kind);
        let p = t.mesh.path().clone();
        let reach = t.mesh.approach_for(p.start, load).unwrap();
        let back = -t.mesh.separation.back.values.iter().cloned().fold(f64::INFINITY, f64::min);
        let (mut open, mut loaded, mut worst_v, mut worst_s) = (0, 0, 0.0_f64, 0.0_f64);
        for _ in 0..2000 {
            let s = p.start + (uniform(&mut seed) - 0.5) * 4.0 * p.base_pitch;
            let delta = back - 0.2 * reach + uniform(&mut seed) * (4.0 * reach - back);
            let f = t.force_tangents(s, delta).unwrap();
            let [drive, rear] = t.events(s, delta);
            if drive <= 0.0 && rear <= 0.0 {
                assert_eq!(f.force, 0.0, "{kind:?} s={s} δ={delta}: open by its events but F = {}", f.force);
                assert_eq!(f.approach_stiffness, 0.0);
                open += 1;
            } else {
                assert!(drive <= 0.0 || rear <= 0.0, "both flanks touch at once");
                let sign = if drive > 0.0 { 1.0 } else { -1.0 };
                assert!(sign * f.force >= 0.0, "{kind:?} s={s} δ={delta}: F = {} against its flank", f.force);
                loaded += 1;
            }
            let (hd, hs) = (1e-9, 1e-8);
            let v = |s: f64, d: f64| t.contact_energy(s, d).unwrap().0;
            let dv_dd = (v(s, delta + hd) - v(s, delta - hd)) / (2.0 * hd);
            let dv_ds = (v(s + hs, delta) - v(s - hs, delta)) / (2.0 * hs);
            let (_, vs) = t.contact_energy(s, delta).unwrap();
            worst_v = worst_v.max((dv_dd - f.force).abs() / load);
            // ∂V/∂s jumps where the touching pair changes; skip points whose difference straddles one.
            let [d1, _] = t.events(s + hs, delta);
            let [d0, _] = t.events(s - hs, delta);
            let smooth = ((d1 - drive) - (drive - d0)).abs() < 1e-3 * hs;
            if smooth {
                worst_s = worst_s.max((dv_ds - vs).abs() / load);
            }
        }
        eprintln!(
            "{kind:?}: {open} open, {loaded} loaded; |∂V/∂δ − F| ≤ {worst_v:.2e} F_nom, |∂V/∂s − V_s| ≤ {worst_s:.2e} F_nom"
        );
        assert!(open > 100 && loaded > 100, "the sample must cover both states");
        assert!(worst_v < 1e-5 && worst_s < 1e-5, "{worst_v} {worst_s}");
    }
}

/// The example with deformable contact in `fidelity`.
fn deformable(fidelity: Fidelity) -> Scene {
    let mut s = Scene::example_2004_deformable();
    s.dynamics.fidelity = fidelity;
    s
}

/// Along a steady state of the deformable example at 2750 rpm (both
/// fidelities), every mesh force the model records is the exact joint
/// solution's at the mesh's (s, δ) to the table's accuracy (1.5e-2 of the
/// nominal load, the bound of tests/deformable_contact.rs), and the tooth
/// pairs' forces add up to it.
#[test]
fn the_dynamic_model_reads_the_deformable_law() {
    for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
        let (set, run) = deformable(fidelity).validate_with_run().unwrap();
        let mut model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
        let omega = 2750.0 * std::f64::consts::PI / 30.0;
        let r = planetwear::dynamics::response::steady_state(&mut model, &set, &run, omega, None).unwrap();
        let load = set.mesh_load_per_planet();
        let n = model.dim();
        let mut f = vec![0.0; n];
        model.force(0.0, &r.end.q, &r.end.v, &mut f);
        let mut pairs = Vec::new();
        let mut worst: f64 = 0.0;
        for i in 0..model.mesh_count() {
            let (_, kind) = model.mesh_identity(i);
            let state = model.meshes[i];
            let MeshContact::Deformable(t) = model.mesh_model(kind) else {
                panic!("the pair model was read")
            };
            let exact = t.mesh.solve(state.position, state.approach).unwrap().law.force;
            worst = worst.max((state.force - exact).abs() / load);
            let total = model.mesh_model(kind).pairs(state.position, state.approach, &mut pairs).unwrap();
            let sum: f64 = pairs.iter().map(|p| p.force).sum();
            assert!((sum - total).abs() <= 1e-9 * load, "pairs {sum} against the mesh {total}");
            assert!(pairs.iter().any(|p| p.force > 0.0), "no pair loaded at the mean load");
        }
        eprintln!("{fidelity:?}: |F_model − F_exact| ≤ {worst:.2e} F_nom");
        assert!(worst < 1.5e-2, "{worst}");
    }
}

/// Energy is conserved on the deformable law, as on the pair model
/// (tests/rayleigh.rs): the torsional example with Rayleigh damping,
/// generalized-α at 4000 steps per mesh cycle over five cycles at 3000 rpm;
/// kinetic + support + contact energy changes by the work of the external
/// forces and of the time-varying law, less what the damping took, to 1e-3
/// of the contact energy.
#[test]
fn the_energy_balance_holds_on_the_deformable_law() {
    let mut s = deformable(Fidelity::Torsional);
    s.dynamics.damping = DampingModel::Rayleigh;
    s.dynamics.rayleigh_mass_per_s = 500.0;
    s.dynamics.rayleigh_stiffness_s = 2e-7;
    let set = s.validate().unwrap();
    let mut model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    energy_balance(&mut model, 3000.0, 4000, 5).assert_closes();
}

/// `dynamics.contact`: the stiffness scales are refused with it (naming the
/// key), it is written to and read from the file only when not the pair
/// model, an unknown law is refused, and the built-in
/// `example-2004-deformable` differs from `example-2004` in the law, the
/// calibration's three fitted values and the Rayleigh rule's coefficients only.
#[test]
fn the_scene_key_is_checked_and_read_back() {
    // The stiffness scales correct the pair model only.
    let mut s = Scene::example_2004_deformable();
    s.mesh_stiffness.sun_planet_scale = 1.1;
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("mesh_stiffness.sun_planet_scale") && e.contains("\"pair\""), "{e}");
    // The file form: `contact = "deformable"` under [dynamics], written only when not the default.
    let text = Scene::example_2004_deformable().to_toml();
    assert!(text.contains("contact = \"deformable\""), "{text}");
    assert!(!Scene::example_2004().to_toml().contains("contact ="));
    let back = Scene::from_toml(&text).unwrap();
    assert_eq!(back.dynamics.contact, ContactModel::Deformable);
    let bad = text.replace("contact = \"deformable\"", "contact = \"rigid\"");
    let e = Scene::from_toml(&bad).unwrap_err().to_string();
    assert!(e.contains("contact") && e.contains("deformable"), "{e}");
    // Only the contact law, the three values its calibration fits and the Rayleigh
    // coefficients of its own modes' rule differ from the example.
    let mut same = Scene::example_2004_deformable();
    let example = Scene::example_2004();
    same.name = example.name.clone();
    same.dynamics.contact = ContactModel::Pair;
    same.sun.tip_chamfer = example.sun.tip_chamfer;
    same.planet.tip_chamfer = example.planet.tip_chamfer;
    same.inertia = example.inertia;
    same.dynamics.rayleigh_mass_per_s = example.dynamics.rayleigh_mass_per_s;
    same.dynamics.rayleigh_stiffness_s = example.dynamics.rayleigh_stiffness_s;
    assert_eq!(same, example);
}

/// A model built on the deformable law has a different tangent stiffness
/// than on the pair model at the same state: its Jacobian reads the law.
#[test]
fn the_tangent_stiffness_comes_from_the_law() {
    use planetwear::dynamics::solver::TangentSystem;
    let (pair_set, deformable_set) = (
        Scene::example_2004().validate().unwrap(),
        deformable(Fidelity::TransverseTorsional).validate().unwrap(),
    );
    let mut a = PlanetaryDynamics::new(&pair_set, SetModel::new(&pair_set)).unwrap();
    let mut b = PlanetaryDynamics::new(&deformable_set, SetModel::new(&deformable_set)).unwrap();
    let q = planetwear::dynamics::response::static_state(&a, 0.0).q;
    let n = a.dim();
    let v = vec![0.0; n];
    let (mut ka, mut kb, mut c) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n), DMatrix::zeros(n, n));
    a.jacobian(0.0, &q, &v, &mut ka, &mut c);
    b.jacobian(0.0, &q, &v, &mut kb, &mut c);
    let diff = (&ka - &kb).amax() / ka.amax();
    eprintln!("largest tangent stiffness difference {diff:.3} of the largest entry");
    assert!(diff > 1e-3, "the deformable model's tangents equal the pair model's");
}

/// The pair loads of one quasi-static wear cycle: the pair loads at a position.
fn pair_loads(scene: Scene) -> (f64, Vec<f64>, Vec<f64>) {
    use planetwear::wear::archard::WearSettings;
    use planetwear::wear::state::WornState;
    use planetwear::wear::stepper::WearModel;
    let set = scene.validate().unwrap();
    let settings = WearSettings::for_set(&set);
    let state = WornState::unworn(&set, settings.profile_points, settings.face_slices);
    let cycle = WearModel::new(&set, settings).unwrap().cycle(&state).unwrap();
    let sun = cycle.meshes.iter().find(|m| m.mesh == MeshKind::SunPlanet).unwrap();
    let pb = planetwear::model::mesh::PathOfContact::new(&set, MeshKind::SunPlanet).base_pitch;
    (pb, sun.position.clone(), sun.pair_load[0].clone())
}

/// The quasi-static wear runs on the deformable law: on the in-phase
/// variant (every planet carries a quarter of the load at every position,
/// tests/support/in_phase.rs) the pairs one base pitch apart along planet
/// 1's sun–planet passage add up to the nominal mesh load (to 1.5 %: the
/// grid's linear interpolation over the steep onset of a pair's load on
/// Johnson's term gives up to 1.2 % at four positions, 0.5 % elsewhere;
/// away from the passage's ends, where the loads jump: the tip corners
/// carry none), and the pair loads
/// differ from the pair model's on the same gear set (by more than 0.5 % of
/// the mesh load somewhere).
#[test]
fn the_quasi_static_wear_reads_the_deformable_split() {
    let mut on_pairs = in_phase_scene();
    let mut deformable = in_phase_scene();
    deformable.dynamics.contact = ContactModel::Deformable;
    on_pairs.dynamics.contact = ContactModel::Pair;
    let load = on_pairs.validate().unwrap().mesh_load_per_planet();
    let (pb, pos, pair) = pair_loads(on_pairs);
    let (_, pos_d, loads) = pair_loads(deformable);
    let at = |x: &[f64], y: &[f64], s: f64| -> f64 {
        if s < x[0] || s > x[x.len() - 1] {
            return 0.0;
        }
        let i = x.partition_point(|v| *v <= s).clamp(1, x.len() - 1);
        let t = (s - x[i - 1]) / (x[i] - x[i - 1]);
        y[i - 1] + t * (y[i] - y[i - 1])
    };
    let h = pos_d[1] - pos_d[0];
    let ends = [pos_d[0], pos_d[pos_d.len() - 1]];
    let (mut differs, mut worst, mut read): (f64, f64, usize) = (0.0, 0.0, 0);
    for (r, s) in pos_d.iter().enumerate() {
        differs = differs.max((loads[r] - at(&pos, &pair, *s)).abs() / load);
        if (-2..=2).any(|k| ends.iter().any(|e| (s + f64::from(k) * pb - e).abs() < 3.0 * h)) {
            continue;
        }
        let total = (-2..=2).map(|k| at(&pos_d, &loads, s + f64::from(k) * pb)).sum::<f64>();
        worst = worst.max((total / load - 1.0).abs());
        read += 1;
    }
    eprintln!(
        "pair loads differ from the pair model's by up to {differs:.4} of the mesh load; the pairs sharing \
         it add up to it within {worst:.2e} ({read} positions)"
    );
    assert!(read > 50);
    assert!(differs > 5e-3, "the deformable split was not read");
    assert!(worst < 1.5e-2, "{worst}");
}

/// A worn state whose flanks differ across the face cannot run on the
/// transverse deformable law: the dynamic model refuses it with a message
/// naming `dynamics.contact`, and builds the same state with uniform flanks.
#[test]
fn flanks_that_differ_across_the_face_are_refused() {
    use planetwear::geometry::profile::ProfileDeviation;
    let set = Scene::example_2004_deformable().validate().unwrap();
    let worn = MeshFlanks {
        gear1_drive: ProfileDeviation {
            roll: vec![0.2, 0.5],
            depth: vec![2e-6, 1e-6],
            ..ProfileDeviation::none()
        },
        ..MeshFlanks::default()
    };
    let uneven =
        SetModel::with_flanks(&set, &[worn.clone(), MeshFlanks::default()], &vec![MeshFlanks::default(); 2]);
    let e = PlanetaryDynamics::new(&set, uneven).expect_err("refused").to_string();
    assert!(e.contains("dynamics.contact") && e.contains("face"), "{e}");
    let even = SetModel::with_flanks(&set, &[worn.clone(), worn], &vec![MeshFlanks::default(); 2]);
    assert!(PlanetaryDynamics::new(&set, even).is_ok());
}

/// The tabulated law's derivatives of its tangent stiffness (what Rayleigh
/// damping's tangent reads) are those of its interpolated stiffness: at 400
/// positions over a cycle of each mesh, under the nominal approach and 1.5
/// times it (inside the table), ∂K_t/∂δ and ∂K_t/∂s equal the central
/// differences of `force_tangents`' stiffness (1e-5 of the approach, 10 nm)
/// to 1e-4 of the largest of each met, wherever the one-sided differences
/// agree to 1e-3 (no cell border within the step).
#[test]
fn the_tabulated_laws_stiffness_derivatives_are_its_interpolants() {
    let set = Scene::example_2004().validate().unwrap();
    let law = DeformableSet::of_gear_set(&set, &MeshFlanks::default(), &MeshFlanks::default()).unwrap();
    let load = set.mesh_load_per_planet();
    for kind in MeshKind::ALL {
        let t = law.mesh(kind);
        let p = t.mesh.path().clone();
        let reach = t.mesh.approach_for(p.start, load).unwrap();
        let k = |s: f64, d: f64| t.force_tangents(s, d).unwrap().approach_stiffness;
        let (mut smooth, mut largest, mut worst) = (0, [0.0_f64; 2], [0.0_f64; 2]);
        for j in 0..400 {
            for delta in [reach, 1.5 * reach] {
                let s = p.start + p.base_pitch * (j as f64 + 0.37) / 400.0;
                let (hs, hd) = (1e-8, 1e-5 * reach);
                let k0 = k(s, delta);
                let sides = [
                    [(k0 - k(s, delta - hd)) / hd, (k(s, delta + hd) - k0) / hd],
                    [(k0 - k(s - hs, delta)) / hs, (k(s + hs, delta) - k0) / hs],
                ];
                if sides.iter().any(|[a, b]| (a - b).abs() > 1e-3 * a.abs().max(b.abs())) {
                    continue;
                }
                smooth += 1;
                let (d_delta, d_s) = t.stiffness_derivatives(s, delta).unwrap().expect("inside the table");
                for (i, exact) in [d_delta, d_s].into_iter().enumerate() {
                    largest[i] = largest[i].max(exact.abs());
                    worst[i] = worst[i].max((exact - 0.5 * (sides[i][0] + sides[i][1])).abs());
                }
            }
        }
        eprintln!(
            "{kind:?}: {smooth} smooth points; ∂K/∂δ ≤ {:.3e} N/m², off ≤ {:.2e}; ∂K/∂s ≤ {:.3e} N/m², off ≤ {:.2e}",
            largest[0], worst[0], largest[1], worst[1]
        );
        assert!(smooth > 600, "{kind:?}: only {smooth} of 800 points away from a cell border");
        for i in 0..2 {
            assert!(
                largest[i] > 0.0 && worst[i] <= 1e-4 * largest[i],
                "{kind:?} derivative {i}: {worst:?} of {largest:?}"
            );
        }
    }
}
