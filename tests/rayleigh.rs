//! Rayleigh damping C = μM_v + ηK (`dynamics.damping = "rayleigh"`): a
//! mode's free decay follows ζ = μ/(2ω) + ηω/2, the mass-proportional part
//! leaves the train's free rotation alone, and the energy the damping takes
//! is ∫ vᵀCv dt.

#[path = "support/energy_balance.rs"]
mod energy_balance;
use energy_balance::energy_balance;
use nalgebra::{DMatrix, DVector};
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::solver::{
    GeneralizedAlpha, GeneralizedAlphaSettings, Rk45, Rk45Settings, SecondOrderSystem, TangentSystem,
};
use planetwear::model::gear::Damping;
use planetwear::scene::{DampingModel, Fidelity, Scene};

/// The example in the torsional model with Rayleigh damping (μ \[1/s\], η \[s\]).
fn rayleigh_scene(mu: f64, eta: f64) -> Scene {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = Fidelity::Torsional;
    s.dynamics.damping = DampingModel::Rayleigh;
    s.dynamics.rayleigh_mass_per_s = mu;
    s.dynamics.rayleigh_stiffness_s = eta;
    s
}

fn model_of(scene: &Scene) -> PlanetaryDynamics {
    let set = scene.validate().unwrap_or_else(|e| panic!("{e}"));
    PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap()
}

/// The loaded static equilibrium at rest: Newton on f(q, 0) = 0, the free
/// rotation fixed by a penalty on its mass-weighted amplitude.
fn equilibrium(model: &mut PlanetaryDynamics) -> Vec<f64> {
    let n = model.dim();
    let mr = DVector::from_iterator(n, model.mass().iter().zip(&model.rigid_velocity).map(|(m, r)| m * r));
    let mut q = planetwear::dynamics::response::static_state(model, 0.0).q;
    let zeros = vec![0.0; n];
    let (mut k, mut c) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
    let mut f = vec![0.0; n];
    for _ in 0..30 {
        model.force(0.0, &q, &zeros, &mut f);
        model.jacobian(0.0, &q, &zeros, &mut k, &mut c);
        let scale = k.diagonal().amax() / mr.norm_squared();
        let a = &k + &mr * mr.transpose() * scale;
        let dq = a.lu().solve(&DVector::from_vec(f.clone())).unwrap();
        q.iter_mut().zip(dq.iter()).for_each(|(x, d)| *x += d);
        if dq.amax() < 1e-15 {
            break;
        }
    }
    q
}

/// Right eigenvectors of the tangent stiffness at `q` (K x = λ M x) near
/// each symmetric estimate, by inverse iteration: (λ [rad²/s²], x), lowest
/// first, the free rotation left out.
fn tangent_modes(model: &mut PlanetaryDynamics, q: &[f64]) -> Vec<(f64, DVector<f64>)> {
    let n = model.dim();
    let (mut k, mut c) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
    model.jacobian(0.0, q, &vec![0.0; n], &mut k, &mut c);
    let m = DMatrix::from_diagonal(&DVector::from_vec(model.mass().to_vec()));
    let s = DMatrix::from_fn(n, n, |i, j| 0.5 * (k[(i, j)] + k[(j, i)]) / (m[(i, i)] * m[(j, j)]).sqrt());
    let eig = nalgebra::SymmetricEigen::new(s);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|a, b| eig.eigenvalues[*a].total_cmp(&eig.eigenvalues[*b]));
    order
        .into_iter()
        .skip(1)
        .map(|i| {
            let mut lambda = eig.eigenvalues[i];
            let mut x = DVector::from_fn(n, |r, _| eig.eigenvectors[(r, i)] / m[(r, r)].sqrt());
            for _ in 0..20 {
                let shifted = &k - &m * (lambda * (1.0 + 1e-9));
                x = shifted.lu().solve(&(&m * &x)).unwrap();
                x /= x.amax();
                lambda = (x.transpose() * &k * &x)[0] / (x.transpose() * &m * &x)[0];
            }
            (lambda, x)
        })
        .collect()
}

/// The decay rate of the modal amplitude y(t) = xᵀM(q − q_s)/xᵀMx over its
/// positive peaks: a least-squares line through ln(peak) against time [1/s].
fn decay_rate(times: &[f64], y: &[f64]) -> f64 {
    let peaks: Vec<(f64, f64)> = (1..y.len() - 1)
        .filter(|&i| y[i] > 0.0 && y[i] >= y[i - 1] && y[i] > y[i + 1])
        .map(|i| (times[i], y[i].ln()))
        .collect();
    assert!(peaks.len() >= 10, "too few peaks: {}", peaks.len());
    let n = peaks.len() as f64;
    let (st, sy) = peaks.iter().fold((0.0, 0.0), |(a, b), (t, l)| (a + t, b + l));
    let (mt, my) = (st / n, sy / n);
    let (num, den) =
        peaks.iter().fold((0.0, 0.0), |(a, b), (t, l)| (a + (t - mt) * (l - my), b + (t - mt) * (t - mt)));
    -num / den
}

/// Free decay of one mode from the loaded equilibrium at rest, sampled
/// `per_period` times a period over `periods` periods, by the
/// generalized-α method (`implicit`, ρ∞ = 1: no numerical damping) or
/// RK 5(4): the measured damping ratio ζ = σ/ω.
fn measured_ratio(
    model: &mut PlanetaryDynamics,
    q0: &[f64],
    (lambda, x): &(f64, DVector<f64>),
    implicit: bool,
) -> f64 {
    let n = model.dim();
    let omega = lambda.sqrt();
    // An amplitude of 1e-3 of the static deflection keeps every pair in
    // contact and the tangent stiffness constant to about that fraction.
    let size = q0.iter().fold(0.0_f64, |a, v| a.max(v.abs())) * 1e-3;
    let start: Vec<f64> = q0.iter().zip(x.iter()).map(|(q, x)| q + size * x).collect();
    let zeros = vec![0.0; n];
    let (per_period, periods) = (200usize, 30usize);
    let h = 2.0 * std::f64::consts::PI / omega / per_period as f64;
    let mx: Vec<f64> = x.iter().zip(model.mass()).map(|(x, m)| x * m).collect();
    let xmx: f64 = mx.iter().zip(x.iter()).map(|(a, b)| a * b).sum();
    let modal = |q: &[f64]| mx.iter().zip(q.iter().zip(q0)).map(|(a, (q, s))| a * (q - s)).sum::<f64>() / xmx;
    let (mut times, mut y) = (vec![0.0], vec![modal(&start)]);
    if implicit {
        let mut settings = GeneralizedAlphaSettings::chung_hulbert(1.0).unwrap();
        settings.rtol = 1e-14;
        settings.atol = 1e-16;
        let mut ga = GeneralizedAlpha::new(settings).unwrap();
        ga.init(model, 0.0, &start, &zeros).unwrap();
        for k in 1..=per_period * periods {
            let t = k as f64 * h;
            ga.advance(model, t, 1).unwrap();
            times.push(t);
            y.push(modal(ga.q()));
        }
    } else {
        let settings = Rk45Settings { rtol: 1e-11, atol_q: 1e-16, atol_v: 1e-12, ..Default::default() };
        let mut rk = Rk45::new(settings).unwrap();
        rk.init(model, 0.0, &start, &zeros).unwrap();
        for k in 1..=per_period * periods {
            let t = k as f64 * h;
            rk.advance_to(model, t).unwrap();
            times.push(t);
            y.push(modal(rk.q()));
        }
    }
    decay_rate(&times, &y) / omega
}

/// Law: under C = μM_v + ηK a mode of circular frequency ω decays at
/// ζ = μ/(2ω) + ηω/2 (Chopra, Dynamics of Structures, §11.4.1).
/// μ and η from the two-frequency rule at ζ = 0.02 on the first two tangent
/// modes; the third lies between or above them and has its own ratio. Each
/// measured log decrement within ±2 % of the formula, for both integrators.
#[test]
fn a_mode_decays_at_the_rayleigh_ratio() {
    let mut model = model_of(&rayleigh_scene(0.0, 0.0));
    let q0 = equilibrium(&mut model);
    let modes = tangent_modes(&mut model, &q0);
    let (w1, w2) = (modes[0].0.sqrt(), modes.last().unwrap().0.sqrt());
    let (mu, eta) = Damping::two_frequency(0.02, w1, w2);
    let rayleigh = Damping::Rayleigh { mass: mu, stiffness: eta };
    let mut model = model_of(&rayleigh_scene(mu, eta));
    for mode in [&modes[0], &modes[1], modes.last().unwrap()] {
        let omega = mode.0.sqrt();
        let expected = rayleigh.rayleigh_ratio(omega).unwrap();
        for implicit in [true, false] {
            let zeta = measured_ratio(&mut model, &q0, mode, implicit);
            eprintln!(
                "mode {:.1} Hz, {}: ζ measured {zeta:.6}, μ/(2ω) + ηω/2 = {expected:.6} ({:+.3} %)",
                omega / (2.0 * std::f64::consts::PI),
                if implicit { "generalized-α" } else { "RK 5(4)" },
                100.0 * (zeta / expected - 1.0)
            );
            assert!((zeta / expected - 1.0).abs() < 0.02, "ζ {zeta} against {expected}");
        }
    }
}

/// Law: the mass-proportional part acts on the motion relative to the
/// train's rigid-body rotation only, so an unloaded train turning at
/// 3000 rpm keeps its rigid-body speed rᵀMv/rᵀMr to 1e-9 over 10 ms with
/// μ = 2000 /s (a drag μMv on the whole velocity would slow it by
/// e^(−μt) = e^(−20)), in both fidelities.
#[test]
fn the_free_rotation_is_not_braked() {
    for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
        let mut s = rayleigh_scene(2000.0, 1e-7);
        s.dynamics.fidelity = fidelity;
        s.operation.input_torque_nm = 0.0;
        let mut model = model_of(&s);
        let omega = 3000.0 * std::f64::consts::PI / 30.0;
        let n = model.dim();
        let r = model.rigid_velocity.clone();
        let rmr: f64 = model.mass().iter().zip(&r).map(|(m, r)| m * r * r).sum();
        let speed =
            |v: &[f64], m: &[f64]| m.iter().zip(&r).zip(v).map(|((m, r), v)| m * r * v).sum::<f64>() / rmr;
        let mut settings = GeneralizedAlphaSettings::chung_hulbert(0.9).unwrap();
        settings.rtol = 1e-13;
        let mut ga = GeneralizedAlpha::new(settings).unwrap();
        let v0 = model.rigid_velocity_at(omega);
        ga.init(&mut model, 0.0, &vec![0.0; n], &v0).unwrap();
        ga.advance(&mut model, 0.01, 20000).unwrap();
        let end = speed(ga.v(), model.mass());
        eprintln!("{fidelity:?}: rigid-body speed after 10 ms {:.12} of the start", end / omega);
        assert!((end / omega - 1.0).abs() < 1e-9, "{fidelity:?}: speed ratio {}", end / omega);
    }
}

/// Law: with damping the energy balance reads E(t) − E(0) = W_ext + W_s −
/// ∫ vᵀCv dt (W_s the work of the time-varying stiffness, as in
/// tests/dynamics.rs), the dissipated power vᵀCv = −vᵀ(f(q, v) − f(q, 0))
/// in the torsional model (no velocity-dependent force but the damping).
/// Over five mesh cycles at 3000 rpm it closes to 1e-3 of the contact
/// energy, and the dissipated energy is more than ten times the balance's
/// error (leaving it out would break the balance).
#[test]
fn the_energy_balance_holds_with_rayleigh_damping() {
    let mut model = model_of(&rayleigh_scene(500.0, 2e-7));
    energy_balance(&mut model, 3000.0, 4000, 5).assert_closes();
}

/// The flexible example's Rayleigh coefficients are the two-frequency
/// rule's at its `dynamics.mesh_damping_ratio` on its first two rotational
/// modes (to the five digits the scene writes: 1e-4).
#[test]
fn the_examples_coefficients_follow_the_two_frequency_rule() {
    let scene = Scene::example_2004();
    let model = model_of(&scene);
    let modes = planetwear::analysis::modes::natural_modes(&model.lumped);
    let rule = planetwear::analysis::modes::rayleigh_rule(&modes, scene.dynamics.mesh_damping_ratio).unwrap();
    eprintln!("{rule:?}");
    assert_eq!(scene.dynamics.damping, DampingModel::Rayleigh);
    let (mu, eta) = (scene.dynamics.rayleigh_mass_per_s, scene.dynamics.rayleigh_stiffness_s);
    assert!((mu / rule.mass_per_s - 1.0).abs() < 1e-4, "μ {mu} against {}", rule.mass_per_s);
    assert!((eta / rule.stiffness_s - 1.0).abs() < 1e-4, "η {eta} against {}", rule.stiffness_s);
}

/// The low-rank Jacobian (the Woodbury solves of generalized-α and the
/// periodic solvers) assembles to the dense one under Rayleigh damping: the
/// meshes' damping η ∂F/∂δ enters both alike (to 1e-12 of the largest
/// entry), along a steady state of the flexible example at 9750 rpm where
/// the teeth separate, in both fidelities.
#[test]
fn the_low_rank_jacobian_carries_the_rayleigh_damping() {
    for fidelity in [Fidelity::TransverseTorsional, Fidelity::Torsional] {
        let mut s = Scene::example_2004();
        s.dynamics.fidelity = fidelity;
        let (set, run) = s.validate_with_run().unwrap();
        let mut model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
        let omega = 9750.0 * std::f64::consts::PI / 30.0;
        let r = planetwear::dynamics::response::steady_state(&mut model.clone(), &set, &run, omega, None)
            .unwrap();
        let structure = model.low_rank_jacobian().expect("the dynamic model gives its structure");
        let n = model.dim();
        let mut coefficients = vec![Default::default(); structure.terms.len()];
        let mut damped = 0;
        for shift in 0..16 {
            let mut q = r.end.q.clone();
            for (qi, vi) in q.iter_mut().zip(&r.end.v) {
                *qi += vi * shift as f64 * 2e-6;
            }
            let (mut k, mut c) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
            model.jacobian(0.0, &q, &r.end.v, &mut k, &mut c);
            model.jacobian_coefficients(0.0, &q, &r.end.v, &mut coefficients);
            damped += coefficients.iter().filter(|c| c.damping > 0.0).count();
            let (k2, c2) = structure.assemble(&coefficients);
            assert!(
                (&k - &k2).amax() <= 1e-12 * k.amax(),
                "{fidelity:?}: K differs by {}",
                (&k - &k2).amax()
            );
            assert!(
                (&c - &c2).amax() <= 1e-12 * c.amax(),
                "{fidelity:?}: C differs by {}",
                (&c - &c2).amax()
            );
        }
        assert!(damped > 0, "no mesh carried Rayleigh damping");
    }
}

/// The scene's rules: negative or non-finite coefficients, and
/// coefficients under the ratio model, are each refused with a problem
/// naming the key.
#[test]
fn the_rayleigh_keys_are_checked() {
    let mut s = rayleigh_scene(-1.0, f64::NAN);
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("dynamics.rayleigh_mass_per_s") && e.contains("at least 0"), "{e}");
    assert!(e.contains("dynamics.rayleigh_stiffness_s"), "{e}");
    s.dynamics.damping = DampingModel::Ratio;
    s.dynamics.rayleigh_mass_per_s = 100.0;
    s.dynamics.rayleigh_stiffness_s = 0.0;
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("dynamics.rayleigh_mass_per_s") && e.contains("\"rayleigh\""), "{e}");
    // The file form: keys under [dynamics], read back as written.
    let text = Scene::example_2004().to_toml();
    let back = Scene::from_toml(&text).unwrap();
    assert_eq!(back.dynamics, Scene::example_2004().dynamics);
    assert_eq!(back.value_at("dynamics.rayleigh_stiffness_s").unwrap(), 5.0301e-7);
}

/// A scene file named by `sceneFile` brings its damping model, coefficients
/// and planet bearings into the FMU: the instance's scene keeps the file's
/// (the FMU's damping parameters act on it only where the importer sets them).
#[test]
fn a_scene_file_brings_rayleigh_damping_into_the_fmu() {
    use planetwear::fmi::instance::Instance;
    use planetwear::fmi::variables::vr;
    let dir = std::env::temp_dir().join(format!("planetwear-rayleigh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The stiff-pin reading: its ratio model and stiff pins replace the
    // FMU's start values (the example's Rayleigh damping and needle bearings).
    let path = dir.join("stiff-pins.toml");
    std::fs::write(&path, Scene::example_2004_stiff_pins().to_toml()).unwrap();
    let mut i = Instance::new("ratio", None);
    i.set_string(vr::SCENE_FILE, &path.display().to_string()).unwrap();
    let scene = i.scene().map_err(|e| e.message).unwrap();
    let stiff = Scene::example_2004_stiff_pins();
    assert_eq!(scene.dynamics.damping, DampingModel::Ratio);
    assert_eq!((scene.dynamics.rayleigh_mass_per_s, scene.dynamics.rayleigh_stiffness_s), (0.0, 0.0));
    assert_eq!(scene.dynamics.mesh_damping_ratio, stiff.dynamics.mesh_damping_ratio);
    assert_eq!(scene.supports.planet_bearing_n_per_m, stiff.supports.planet_bearing_n_per_m);
    // A file with Rayleigh damping and another rule's coefficients keeps them.
    let mut rayleigh = Scene::example_2004_stiff_pins();
    rayleigh.dynamics.damping = DampingModel::Rayleigh;
    rayleigh.dynamics.rayleigh_mass_per_s = 1723.4;
    rayleigh.dynamics.rayleigh_stiffness_s = 1.9384e-7;
    let path = dir.join("rayleigh.toml");
    std::fs::write(&path, rayleigh.to_toml()).unwrap();
    let mut i = Instance::new("rayleigh", None);
    i.set_string(vr::SCENE_FILE, &path.display().to_string()).unwrap();
    let scene = i.scene().map_err(|e| e.message).unwrap();
    assert_eq!(scene.dynamics.damping, DampingModel::Rayleigh);
    assert_eq!(
        (scene.dynamics.rayleigh_mass_per_s, scene.dynamics.rayleigh_stiffness_s),
        (1723.4, 1.9384e-7)
    );
    assert_eq!(scene.supports.planet_bearing_n_per_m, 3.0e10);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The FMU's own damping parameters: the built-in example's start values
/// are its Rayleigh damping (`dampingModel = 1`, the example's
/// coefficients); `dampingModel = 1` with the importer's coefficients gives
/// those; at 0 the coefficients are not read and the scene carries none; any other code, and a
/// negative coefficient under either model, are each refused naming the
/// parameter and what is allowed.
#[test]
fn the_fmu_parameters_choose_the_damping_model() {
    use planetwear::fmi::instance::Instance;
    use planetwear::fmi::variables::vr;
    let i = Instance::new("damping", None);
    let scene = i.scene().map_err(|e| e.message).unwrap();
    let example = Scene::example_2004().dynamics;
    assert_eq!(scene.dynamics.damping, example.damping);
    assert_eq!(scene.dynamics.damping, DampingModel::Rayleigh);
    assert_eq!(
        (scene.dynamics.rayleigh_mass_per_s, scene.dynamics.rayleigh_stiffness_s),
        (example.rayleigh_mass_per_s, example.rayleigh_stiffness_s)
    );

    let mut i = Instance::new("rayleigh", None);
    i.set_integer(vr::DAMPING_MODEL, 1).unwrap();
    i.set_real(vr::RAYLEIGH_MASS_COEFFICIENT, 250.0).unwrap();
    i.set_real(vr::RAYLEIGH_STIFFNESS_COEFFICIENT, 1.5e-7).unwrap();
    let scene = i.scene().map_err(|e| e.message).unwrap();
    assert_eq!(scene.dynamics.damping, DampingModel::Rayleigh);
    assert_eq!((scene.dynamics.rayleigh_mass_per_s, scene.dynamics.rayleigh_stiffness_s), (250.0, 1.5e-7));
    // The ratio model: the coefficients are not read.
    i.set_integer(vr::DAMPING_MODEL, 0).unwrap();
    let scene = i.scene().map_err(|e| e.message).unwrap();
    assert_eq!(scene.dynamics.damping, DampingModel::Ratio);
    assert_eq!((scene.dynamics.rayleigh_mass_per_s, scene.dynamics.rayleigh_stiffness_s), (0.0, 0.0));

    let mut i = Instance::new("bad", None);
    i.set_integer(vr::DAMPING_MODEL, 2).unwrap();
    let e = i.scene().map(|_| ()).map_err(|e| e.message).unwrap_err();
    assert!(e.contains("dampingModel = 2") && e.contains("1 (Rayleigh)"), "{e}");
    // A negative coefficient is refused when the model is built, under
    // either model (it is checked even where it is not read).
    for model in [1, 0] {
        let mut i = Instance::new("negative", None);
        i.enter_initialization();
        i.set_integer(vr::DAMPING_MODEL, model).unwrap();
        i.set_real(vr::RAYLEIGH_STIFFNESS_COEFFICIENT, -1e-7).unwrap();
        let e = i.exit_initialization().map_err(|e| e.message).unwrap_err();
        assert!(e.contains("rayleighStiffnessCoefficient = -0.0000001") && e.contains("at least 0"), "{e}");
    }
}
