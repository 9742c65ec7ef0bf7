//! Modal analysis against closed forms and the structure Lin & Parker proved.

use planetwear::analysis::modes::{natural_modes, Mode, ModeClass};
use planetwear::model::gear::Member;
use planetwear::model::lumped::Fidelity;

#[path = "support/lin_parker.rs"]
mod lin_parker;
use lin_parker::lin_parker_set as set;

fn count(modes: &[Mode], class: ModeClass) -> usize {
    modes.iter().filter(|m| m.class == class).count()
}

#[test]
fn torsional_closed_form_with_the_carrier_held() {
    for n in [3usize, 4, 5] {
        let mut s = set(n, Fidelity::Torsional, Some(Member::Carrier));
        s.central_torsional = [0.0, 0.0, 0.0];
        let modes = natural_modes(&s);
        let two_pi = 2.0 * std::f64::consts::PI;
        // Planet modes: ω² = (k_sp + k_rp)/m_p, multiplicity n − 1.
        let wp = ((s.sun_mesh + s.ring_mesh) / s.planet_rotational_mass).sqrt() / two_pi;
        let planet: Vec<&Mode> = modes.iter().filter(|m| m.class == ModeClass::Planet).collect();
        assert_eq!(planet.len(), n - 1, "n = {n}");
        for m in &planet {
            assert!((m.frequency / wp - 1.0).abs() < 1e-9, "{} vs {wp}", m.frequency);
            assert_eq!(m.multiplicity, n - 1);
        }
        // The chain sun —(n k_sp)— planets (n m_p) —(n k_rp)— ring, free-free:
        // ω⁴ m1 m2 m3 − ω² [k1 m3 (m1 + m2) + k2 m1 (m2 + m3)] + k1 k2 (m1 + m2 + m3) = 0.
        let (m1, m2, m3) =
            (s.central_rotational_mass[2], n as f64 * s.planet_rotational_mass, s.central_rotational_mass[1]);
        let (k1, k2) = (n as f64 * s.sun_mesh, n as f64 * s.ring_mesh);
        let a = m1 * m2 * m3;
        let b = k1 * m3 * (m1 + m2) + k2 * m1 * (m2 + m3);
        let c = k1 * k2 * (m1 + m2 + m3);
        let disc = (b * b - 4.0 * a * c).sqrt();
        let roots = [((b - disc) / (2.0 * a)).sqrt() / two_pi, ((b + disc) / (2.0 * a)).sqrt() / two_pi];
        let rot: Vec<f64> =
            modes.iter().filter(|m| m.class == ModeClass::Rotational).map(|m| m.frequency).collect();
        assert_eq!(rot.len(), 2, "n = {n}: {rot:?}");
        for (f, r) in rot.iter().zip(roots) {
            assert!((f / r - 1.0).abs() < 1e-9, "{f} vs {r}");
        }
        assert_eq!(count(&modes, ModeClass::RigidBody), 1);
    }
}

#[test]
fn transverse_torsional_mode_structure_for_3_4_5_planets() {
    for n in [3usize, 4, 5] {
        // Nothing held (torsional supports only on the ring): 9 + 3n modes.
        let modes = natural_modes(&set(n, Fidelity::TransverseTorsional, None));
        assert_eq!(modes.len(), 9 + 3 * n);
        assert_eq!(count(&modes, ModeClass::Rotational) + count(&modes, ModeClass::RigidBody), 6, "n = {n}");
        assert_eq!(count(&modes, ModeClass::Translational), 12, "n = {n}");
        assert_eq!(count(&modes, ModeClass::Planet), 3 * (n - 3), "n = {n}");
        assert_eq!(count(&modes, ModeClass::Mixed), 0);
        for m in &modes {
            match m.class {
                ModeClass::Translational => assert_eq!(m.multiplicity, 2, "{m:?}"),
                ModeClass::Planet => assert_eq!(m.multiplicity, n - 3),
                ModeClass::Rotational => assert_eq!(m.multiplicity, 1),
                _ => {}
            }
        }
        // Carrier held in rotation: one rotational mode fewer.
        let held = natural_modes(&set(n, Fidelity::TransverseTorsional, Some(Member::Carrier)));
        assert_eq!(held.len(), 8 + 3 * n);
        assert_eq!(count(&held, ModeClass::Rotational) + count(&held, ModeClass::RigidBody), 5);
        assert_eq!(count(&held, ModeClass::Translational), 12);
        assert_eq!(count(&held, ModeClass::Planet), 3 * (n - 3));
    }
}

#[test]
fn planet_mode_frequencies_do_not_depend_on_the_number_of_planets() {
    let planet_freqs = |n: usize, f: Fidelity| -> Vec<f64> {
        let mut v: Vec<f64> = natural_modes(&set(n, f, Some(Member::Carrier)))
            .iter()
            .filter(|m| m.class == ModeClass::Planet)
            .map(|m| m.frequency)
            .collect();
        v.dedup_by(|a, b| (*a / *b - 1.0).abs() < 1e-6);
        v
    };
    let t4 = planet_freqs(4, Fidelity::TransverseTorsional);
    let t5 = planet_freqs(5, Fidelity::TransverseTorsional);
    let t6 = planet_freqs(6, Fidelity::TransverseTorsional);
    assert_eq!(t4.len(), 3);
    for (a, b) in t4.iter().zip(&t5).chain(t4.iter().zip(&t6)) {
        assert!((a / b - 1.0).abs() < 1e-9, "{a} vs {b}");
    }
    let r3 = planet_freqs(3, Fidelity::Torsional);
    let r5 = planet_freqs(5, Fidelity::Torsional);
    assert!((r3[0] / r5[0] - 1.0).abs() < 1e-9);
}

/// Above `FAER_FROM` rows the modal problem is solved by faer: the same
/// natural frequencies as nalgebra's solver to 1e-12 of the largest, every
/// mode an eigenvector (K φ = ω² M φ to 1e-9 of ‖K‖·‖φ‖), and Lin & Parker's
/// structure for 12 planets (n = 3·(3 + 12) = 45 > FAER_FROM) intact.
#[test]
fn large_sets_solved_by_faer_keep_the_frequencies_and_the_mode_structure() {
    use planetwear::analysis::modes::{modal_matrix, symmetric_eigen, FAER_FROM};
    let s = set(12, Fidelity::TransverseTorsional, None);
    let (m, k) = (s.mass(), s.stiffness());
    let n = m.len();
    assert!(n >= FAER_FROM, "n = {n} must take the faer path");
    let modes = natural_modes(&s);
    // Frequencies against nalgebra's symmetric QR on the same matrix.
    let a = modal_matrix(&s);
    let mut reference: Vec<f64> =
        nalgebra::SymmetricEigen::new(a.clone()).eigenvalues.iter().copied().collect();
    reference.sort_by(f64::total_cmp);
    let largest = reference.iter().fold(0.0f64, |x, y| x.max(y.abs()));
    let (mut ours, _) = symmetric_eigen(a);
    ours.sort_by(f64::total_cmp);
    for (x, y) in ours.iter().zip(&reference) {
        assert!((x - y).abs() <= 1e-12 * largest, "eigenvalue {x} against nalgebra's {y}");
    }
    // Every mode satisfies K φ = ω² M φ.
    let k_norm = k.norm();
    for mode in &modes {
        let w2 = (2.0 * std::f64::consts::PI * mode.frequency).powi(2);
        let phi = nalgebra::DVector::from_column_slice(&mode.shape);
        let r = &k * &phi - nalgebra::DVector::from_fn(n, |i, _| w2 * m[i] * phi[i]);
        assert!(r.norm() <= 1e-9 * k_norm * phi.norm(), "residual {} at {} Hz", r.norm(), mode.frequency);
    }
    // Lin & Parker: one rigid-body mode (nothing held), N − 3 = 9 planet
    // modes per planet-mode frequency group (three groups), rotational and
    // translational modes, no mixed ones for equally spaced planets.
    assert_eq!(count(&modes, ModeClass::RigidBody), 1);
    assert_eq!(count(&modes, ModeClass::Planet), 3 * 9);
    assert_eq!(count(&modes, ModeClass::Mixed), 0);
    assert!(count(&modes, ModeClass::Rotational) > 0 && count(&modes, ModeClass::Translational) > 0);
}
