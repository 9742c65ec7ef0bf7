//! The turning carrier's frame: gyroscopic and centripetal terms
//! (src/model/carrier_frame.rs, src/dynamics/carrier_frame.rs) against the
//! laws they must obey: the structure of the matrices, the eigenvalues'
//! split into forward and backward whirl, the speed at which a planet's
//! backward whirl frequency reaches zero, and a time response in the carrier
//! frame against the same motion computed in the fixed frame.

use nalgebra::DMatrix;
use planetwear::analysis::modes::{natural_modes, rotating_modes, ModeClass};
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::static_state;
use planetwear::dynamics::solver::{SecondOrderSystem, TangentSystem};
use planetwear::model::carrier_frame::CarrierFrame;
use planetwear::model::gear::Member;
use planetwear::model::lumped::{Coordinate, Fidelity, LumpedSet};
use planetwear::scene::Scene;

#[path = "support/lin_parker.rs"]
mod lin_parker;

const TWO_PI: f64 = 2.0 * std::f64::consts::PI;
/// Centre distance (planet radius on the carrier) of the test sets \[m\].
const RC: f64 = 0.039;

/// The Lin & Parker (1999)-like set, sun held: the carrier turns.
fn set(n: usize, fidelity: Fidelity) -> LumpedSet {
    lin_parker::lin_parker_set(n, fidelity, Some(Member::Sun))
}

/// One planet on its bearing (k_p, m_p), nearly decoupled from the rest:
/// weak tooth meshes, a carrier with very large masses and stiff
/// translational bearings (its pin moves on its circle).
fn lone_planet(
    k_p: f64,
    m_p: f64,
    mesh: f64,
    planet_rotational_mass: f64,
    carrier_torsional: f64,
) -> LumpedSet {
    LumpedSet {
        central_mass: [1e4, 2.35, 0.4],
        central_rotational_mass: [1e9, 3.0, 0.39],
        planet_mass: m_p,
        planet_rotational_mass,
        central_bearing: [1e14, 1e8, 1e8],
        central_torsional: [carrier_torsional, 1e9, 0.0],
        planet_bearing: k_p,
        planet_bearings: Vec::new(),
        sun_mesh: mesh,
        ring_mesh: mesh,
        sun_pressure_angle: 20f64.to_radians(),
        ring_pressure_angle: 20f64.to_radians(),
        planet_angles: vec![0.0],
        held: Some(Member::Sun),
        fidelity: Fidelity::TransverseTorsional,
    }
}

#[test]
fn the_gyroscopic_matrix_is_skew_and_the_centripetal_one_the_translational_mass() {
    let s = set(4, Fidelity::TransverseTorsional);
    let t = s.carrier_frame(RC);
    let red = s.reduction();
    let d = red.dim();
    let skew = &t.gyroscopic + t.gyroscopic.transpose();
    assert_eq!(skew.amax(), 0.0, "G + Gᵀ must vanish exactly");
    assert!(t.gyroscopic.amax() > 0.0);
    let m = s.mass();
    for (i, c) in red.coordinates.iter().enumerate() {
        let translation = !matches!(c, Coordinate::U(_) | Coordinate::PlanetU(_));
        assert_eq!(t.centripetal[(i, i)], if translation { m[i] } else { 0.0 }, "{c:?}");
        for j in 0..d {
            if j != i {
                assert_eq!(t.centripetal[(i, j)], 0.0);
            }
        }
        // G: 2m [[0, −1], [1, 0]] on each body's (x, y) and (ζ, η).
        let partner = match c {
            Coordinate::X(b) => red.position(Coordinate::Y(*b)).map(|j| (j, -2.0 * m[i])),
            Coordinate::Y(b) => red.position(Coordinate::X(*b)).map(|j| (j, 2.0 * m[i])),
            Coordinate::Zeta(p) => red.position(Coordinate::Eta(*p)).map(|j| (j, -2.0 * m[i])),
            Coordinate::Eta(p) => red.position(Coordinate::Zeta(*p)).map(|j| (j, 2.0 * m[i])),
            _ => None,
        };
        for j in 0..d {
            let expected = partner.filter(|(pj, _)| *pj == j).map_or(0.0, |(_, g)| g);
            assert_eq!(t.gyroscopic[(i, j)], expected, "G[{c:?}, {:?}]", red.coordinates[j]);
        }
        // Centrifugal load m_p r_c on each ζ_n.
        let fc = if matches!(c, Coordinate::Zeta(_)) { s.planet_mass * RC } else { 0.0 };
        assert_eq!(t.centrifugal[i], fc);
    }
    // K_σ: m_p at (η_n, u_c); the torsional model (η_n = u_c) gets no term.
    let uc = red.position(Coordinate::U(Member::Carrier)).unwrap();
    for p in 0..4 {
        let eta = red.position(Coordinate::Eta(p)).unwrap();
        assert_eq!(t.preload_rotation[(eta, uc)], s.planet_mass);
    }
    assert_eq!(t.preload_rotation.iter().filter(|x| **x != 0.0).count(), 4);
    let tor = set(4, Fidelity::Torsional).carrier_frame(RC);
    assert_eq!((&tor.centripetal - &tor.preload_rotation).amax(), 0.0);
    assert_eq!(tor.gyroscopic.amax(), 0.0);
}

/// At Ω_c = 0 the first-order eigenproblem gives the natural frequencies of
/// the symmetric one (to 1e-10 of the highest); the free rotation stays a
/// zero-frequency mode at speed.
#[test]
fn at_rest_the_gyroscopic_eigenproblem_gives_the_natural_frequencies() {
    let s = set(4, Fidelity::TransverseTorsional);
    let modes = natural_modes(&s);
    let whirl = rotating_modes(&s, 0.0, RC);
    let scale = modes.last().unwrap().frequency;
    let mut elastic: Vec<f64> = whirl.iter().map(|w| w.frequency).filter(|f| *f > 1e-6 * scale).collect();
    elastic.sort_by(f64::total_cmp);
    let expected: Vec<f64> =
        modes.iter().filter(|m| m.class != ModeClass::RigidBody).map(|m| m.frequency).collect();
    assert_eq!(elastic.len(), expected.len(), "{elastic:?}\nvs {expected:?}");
    for (a, b) in elastic.iter().zip(&expected) {
        assert!((a - b).abs() <= 1e-10 * scale, "{a} vs {b}");
    }
    // With the ring free as well, the set turns freely about the held sun
    // (one zero-frequency mode at rest): it stays a free motion at speed.
    let mut free = s.clone();
    free.central_torsional = [0.0; 3];
    assert_eq!(natural_modes(&free).iter().filter(|m| m.class == ModeClass::RigidBody).count(), 1);
    let at_speed = rotating_modes(&free, 300.0, RC);
    let lowest = at_speed.iter().map(|w| w.frequency.abs().max(w.growth_rate.abs())).fold(f64::MAX, f64::min);
    assert!(lowest < 1e-5 * scale, "the rigid rotation must stay a free motion at speed: {lowest}");
    assert!(
        at_speed.iter().all(|w| w.growth_rate.abs() < 1e-6 * scale * TWO_PI),
        "no divergence at 300 rad/s"
    );
}

/// First-order perturbation of a degenerate pair (φ₁, φ₂ mass-normalized)
/// of M q̈ + Ω G q̇ + K q = 0: ω = ω₀ ± Ω |φ₁ᵀ G φ₂| / 2, a forward and a
/// backward whirl whose split grows linearly with Ω (Cooley & Parker 2012).
#[test]
fn degenerate_translational_pairs_split_into_forward_and_backward_whirl() {
    let s = set(4, Fidelity::TransverseTorsional);
    let modes = natural_modes(&s);
    let g = s.carrier_frame(RC).gyroscopic;
    let mut pairs = 0;
    let mut i = 0;
    while i + 1 < modes.len() {
        let (a, b) = (&modes[i], &modes[i + 1]);
        if a.class == ModeClass::Translational && a.multiplicity == 2 {
            let f0 = a.frequency;
            let (p1, p2) = (
                DMatrix::from_column_slice(a.shape.len(), 1, &a.shape),
                DMatrix::from_column_slice(b.shape.len(), 1, &b.shape),
            );
            let coupling = (p1.transpose() * &g * p2)[(0, 0)].abs();
            let omega0 = TWO_PI * f0;
            let mut splits = Vec::new();
            for eps in [1e-3, 2e-3] {
                let w = eps * omega0;
                let predicted = w * coupling / TWO_PI;
                let near: Vec<f64> = rotating_modes(&s, w, RC)
                    .iter()
                    .map(|m| m.frequency)
                    .filter(|f| (f - f0).abs() < 0.2 * predicted.max(1e-9) + 2.0 * predicted)
                    .collect();
                assert_eq!(near.len(), 2, "pair at {f0} Hz, Ω = {w}: {near:?}");
                let split = (near[1] - near[0]).abs();
                println!(
                    "pair {f0:.2} Hz, Ω_c = {w:.3} rad/s: split {split:.6} Hz, predicted {predicted:.6} Hz, mean shift {:.2e} Hz",
                    0.5 * (near[0] + near[1]) - f0
                );
                assert!((split / predicted - 1.0).abs() < 1e-2, "split {split} vs predicted {predicted}");
                // Mean of the two stays at ω₀ to first order.
                assert!((0.5 * (near[0] + near[1]) - f0).abs() < 1e-2 * predicted);
                splits.push(split);
            }
            // Linear in Ω at small speed.
            assert!((splits[1] / splits[0] - 2.0).abs() < 1e-2, "{splits:?}");
            pairs += 1;
            i += 2;
        } else {
            i += 1;
        }
    }
    assert!(pairs >= 3, "the set has 3 degenerate translational pairs, found {pairs}");
}

/// A planet on an isotropic bearing seen from the carrier whirls at
/// |√(k/m) ± Ω_c|: the backward whirl's frequency falls to zero at
/// Ω_c = √(k_p/m_p) (the onset of divergence).
#[test]
fn a_planets_backward_whirl_reaches_zero_frequency_at_the_closed_form_speed() {
    let (k_p, m_p) = (1e7, 0.5);
    // Rotation of the planet stiff against its meshes through a tiny
    // rotational mass (its mode far above), the carrier held in rotation by
    // a stiff torsional support: the planet's translations are what moves.
    let s = lone_planet(k_p, m_p, 1e3, 1e-6, 1e12);
    let wn = (k_p / m_p).sqrt();
    let lowest = |w: f64| rotating_modes(&s, w, RC).iter().map(|m| m.frequency).fold(f64::MAX, f64::min);
    // Golden-section search of the lowest frequency's zero on [0.8, 1.2]·ω_n.
    let (mut lo, mut hi) = (0.8 * wn, 1.2 * wn);
    let r = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..80 {
        let (x1, x2) = (hi - r * (hi - lo), lo + r * (hi - lo));
        if lowest(x1) < lowest(x2) {
            hi = x2;
        } else {
            lo = x1;
        }
    }
    let found = 0.5 * (lo + hi);
    println!(
        "divergence speed: found {found:.4} rad/s, closed form √(k/m) = {wn:.4} rad/s, rel. diff {:.2e}; lowest frequency there {:.3e} Hz",
        found / wn - 1.0,
        lowest(found)
    );
    assert!((found / wn - 1.0).abs() < 1e-3, "{found} vs {wn}");
    assert!(lowest(found) < 1e-3 * wn / TWO_PI);
    // Below it the backward whirl is at ω_n − Ω_c.
    let w = 0.5 * wn;
    let f = rotating_modes(&s, w, RC);
    let backward = (wn - w) / TWO_PI;
    let forward = (wn + w) / TWO_PI;
    for target in [backward, forward] {
        let nearest = f.iter().map(|m| (m.frequency - target).abs()).fold(f64::MAX, f64::min);
        assert!(nearest < 1e-3 * target, "no whirl at {target} Hz: {f:?}");
    }
}

/// Integrates M q̈ = −K q + f_frame(q, q̇) (the dynamics' own carrier-frame
/// forces) by classical Runge–Kutta 4.
fn integrate(
    m: &[f64],
    k: &DMatrix<f64>,
    frame: Option<&CarrierFrame>,
    (q0, v0): (&[f64], &[f64]),
    dt: f64,
    steps: usize,
    mut record: impl FnMut(f64, &[f64]),
) {
    let d = m.len();
    let accel = |q: &[f64], v: &[f64]| -> Vec<f64> {
        let mut f: Vec<f64> = (0..d).map(|i| -(0..d).map(|j| k[(i, j)] * q[j]).sum::<f64>()).collect();
        if let Some(fr) = frame {
            fr.add_force(q, v, &mut f);
        }
        f.iter().zip(m).map(|(f, m)| f / m).collect()
    };
    let (mut q, mut v) = (q0.to_vec(), v0.to_vec());
    let add =
        |x: &[f64], y: &[f64], h: f64| -> Vec<f64> { x.iter().zip(y).map(|(a, b)| a + h * b).collect() };
    record(0.0, &q);
    for s in 0..steps {
        let a1 = accel(&q, &v);
        let (q2, v2) = (add(&q, &v, dt / 2.0), add(&v, &a1, dt / 2.0));
        let a2 = accel(&q2, &v2);
        let (q3, v3) = (add(&q, &v2, dt / 2.0), add(&v, &a2, dt / 2.0));
        let a3 = accel(&q3, &v3);
        let (q4, v4) = (add(&q, &v3, dt), add(&v, &a3, dt));
        let a4 = accel(&q4, &v4);
        for i in 0..d {
            q[i] += dt / 6.0 * (v[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i]);
            v[i] += dt / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i]);
        }
        record((s + 1) as f64 * dt, &q);
    }
}

/// A planet on its bearing spring, the carrier turning at Ω_c: its motion
/// in the carrier frame (the model's coordinates with the frame's forces)
/// equals the motion computed in the fixed frame (the pin on its circle, the
/// planet pulled by the spring, closed form) turned into the carrier's axes.
#[test]
fn the_carrier_frame_response_matches_the_fixed_frame_one() {
    let (k_p, m_p) = (1e7, 0.5);
    let s = lone_planet(k_p, m_p, 1e-3, 0.61, 0.0);
    let red = s.reduction();
    let d = red.dim();
    let wn = (k_p / m_p).sqrt();
    let omega = 0.3 * wn;
    let uc = red.position(Coordinate::U(Member::Carrier)).unwrap();
    let zeta = red.position(Coordinate::Zeta(0)).unwrap();
    let eta = red.position(Coordinate::Eta(0)).unwrap();
    // Rigid velocities per rad/s of the carrier (the input here).
    let mut rigid = vec![0.0; d];
    rigid[uc] = RC;
    rigid[eta] = RC;
    let mut frame = CarrierFrame::new(&s, RC, &rigid, 1.0).expect("a turning carrier has frame terms");
    frame.set_input_speed(omega);
    assert_eq!(frame.speed(), omega);
    assert!(
        (frame.planet_centrifugal_force() - m_p * omega * omega * RC).abs()
            < 1e-12 * m_p * omega * omega * RC
    );
    // Initial state: the planet 10 µm out radially and 3 µm ahead on its
    // arm, moving relative to the carrier at (0.02, −0.01) m/s.
    let (z0, e0, zd0, ed0) = (1e-5, 3e-6, 0.02, -0.01);
    let mut q0 = vec![0.0; d];
    q0[zeta] = z0;
    q0[eta] = e0;
    let mut v0: Vec<f64> = rigid.iter().map(|r| r * omega).collect();
    v0[zeta] += zd0;
    v0[eta] += ed0;
    // Fixed frame: e = X − P, m ë = −k e + m Ω² P, P = r_c (cos Ωt, sin Ωt).
    let c = m_p * omega * omega / (k_p - m_p * omega * omega);
    let e_init = [z0, e0];
    let edot_init = [zd0 - omega * e0, ed0 + omega * z0];
    let (a, b) =
        ([e_init[0] - c * RC, e_init[1]], [(edot_init[0]) / wn, (edot_init[1] - c * RC * omega) / wn]);
    let fixed = |t: f64| -> [f64; 2] {
        let (cw, sw) = ((wn * t).cos(), (wn * t).sin());
        let (co, so) = ((omega * t).cos(), (omega * t).sin());
        let e = [a[0] * cw + b[0] * sw + c * RC * co, a[1] * cw + b[1] * sw + c * RC * so];
        // Into the carrier's axes, turned by Ωt.
        [co * e[0] + so * e[1], -so * e[0] + co * e[1]]
    };
    let m = s.mass();
    let k = s.stiffness();
    let period = TWO_PI / wn;
    let steps = 4000;
    let dt = 5.0 * period / steps as f64;
    let (mut err, mut size, mut err_without) = (0.0f64, 0.0f64, 0.0f64);
    integrate(&m, &k, Some(&frame), (&q0, &v0), dt, steps, |t, q| {
        let r = fixed(t);
        let model = [q[zeta], q[eta] - q[uc]];
        err = err.max((model[0] - r[0]).abs()).max((model[1] - r[1]).abs());
        size = size.max(r[0].abs()).max(r[1].abs());
    });
    integrate(&m, &k, None, (&q0, &v0), dt, steps, |t, q| {
        let r = fixed(t);
        err_without = err_without.max((q[zeta] - r[0]).abs()).max((q[eta] - q[uc] - r[1]).abs());
    });
    println!(
        "carrier frame vs fixed frame over 5 periods, Ω_c = 0.3 ω_n: max deviation {err:.3e} m of {size:.3e} m ({:.2e}); without the frame terms {err_without:.3e} m",
        err / size
    );
    assert!(err < 1e-6 * size, "carrier-frame response off by {err} m (of {size} m)");
    assert!(err_without > 0.1 * size, "the frame terms must matter at this speed");
}

/// The example with the ring held and the sun driving: the carrier turns at
/// ω_in Z_s/(Z_s + Z_r).
fn ring_held() -> (planetwear::model::gear::GearSet, PlanetaryDynamics) {
    let mut s = Scene::example_2004();
    s.operation.held = Member::Ring;
    s.operation.input = Member::Sun;
    let set = s.validate().unwrap_or_else(|e| panic!("{e}"));
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    (set, model)
}

/// The dynamic model takes the carrier's kinematic speed as the frame's
/// speed and carries the planets' centrifugal load m_p Ω_c² r_c; a held
/// carrier has none.
#[test]
fn the_dynamic_model_turns_its_frame_at_the_carriers_kinematic_speed() {
    let (set, mut model) = ring_held();
    assert_eq!(model.carrier_frame_speed(), 0.0);
    let omega = 3000.0 * std::f64::consts::PI / 30.0;
    model.set_drive_speed(omega);
    let (zs, zr) = (f64::from(set.sun().teeth), f64::from(set.ring().teeth));
    let wc = omega * zs / (zs + zr);
    assert!(
        (model.carrier_frame_speed() / wc - 1.0).abs() < 1e-12,
        "{} vs {wc}",
        model.carrier_frame_speed()
    );
    let load = set.bodies().planet.mass * wc * wc * set.centre_distance();
    assert!((model.planet_centrifugal_force() / load - 1.0).abs() < 1e-12);
    println!("ring held, sun at 3000 rpm: Ω_c = {wc:.3} rad/s, planet centrifugal load {load:.3} N");
    let set = Scene::example_2004().validate().unwrap();
    let mut held = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    held.set_drive_speed(omega);
    assert_eq!((held.carrier_frame_speed(), held.planet_centrifugal_force()), (0.0, 0.0));
}

/// The Jacobian with the frame's terms is the derivative of the force
/// (central differences), and the low-rank structure assembles to it.
#[test]
fn the_jacobian_holds_the_frame_terms() {
    let (_, mut model) = ring_held();
    let omega = 3000.0 * std::f64::consts::PI / 30.0;
    model.set_drive_speed(omega);
    let n = model.dim();
    let start = static_state(&model, omega);
    let (q, v) = (start.q, start.v);
    let (mut k, mut c) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
    model.jacobian(0.0, &q, &v, &mut k, &mut c);
    let structure = model.low_rank_jacobian().unwrap();
    let mut coefficients = vec![Default::default(); structure.terms.len()];
    model.jacobian_coefficients(0.0, &q, &v, &mut coefficients);
    let (k2, c2) = structure.assemble(&coefficients);
    assert!((&k - &k2).amax() <= 1e-12 * k.amax());
    assert!((&c - &c2).amax() <= 1e-12 * c.amax());
    let force = |m: &mut PlanetaryDynamics, q: &[f64], v: &[f64]| {
        let mut f = vec![0.0; n];
        m.force(0.0, q, v, &mut f);
        f
    };
    // Velocity columns: the force is linear in v within a contact state.
    let h = 1e-4;
    for j in 0..n {
        let (mut vp, mut vm) = (v.clone(), v.clone());
        vp[j] += h;
        vm[j] -= h;
        let (fp, fm) = (force(&mut model, &q, &vp), force(&mut model, &q, &vm));
        for i in 0..n {
            let d = -(fp[i] - fm[i]) / (2.0 * h);
            assert!((d - c[(i, j)]).abs() <= 1e-6 * c.amax(), "C[{i},{j}] {} vs {d}", c[(i, j)]);
        }
    }
    // The frame's own part: C − C(Ω_c = 0) is Ω_c G, skew.
    let mut rest = model.clone();
    rest.set_drive_speed(0.0);
    let (mut k0, mut c0) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
    rest.jacobian(0.0, &q, &v, &mut k0, &mut c0);
    let g = &c - &c0;
    assert!(g.amax() > 0.0);
    assert!((&g + g.transpose()).amax() <= 1e-12 * g.amax());
    let wc = model.carrier_frame_speed();
    let dk = &k - &k0;
    let m_p = model.lumped.planet_mass;
    let red = model.reduction.clone();
    let zeta = red.position(Coordinate::Zeta(0)).unwrap();
    assert!(
        (dk[(zeta, zeta)] / (-m_p * wc * wc) - 1.0).abs() < 1e-9,
        "{} vs {}",
        dk[(zeta, zeta)],
        -m_p * wc * wc
    );
}
