//! Gears given by gear data (ISO 21771): the formulas against closed forms
//! and published figures, every refusal on a crafted case naming its key,
//! and the example given by gear data giving the radii form's gear set and
//! figures.

use std::f64::consts::PI;

use planetwear::analysis::modes::natural_modes;
use planetwear::contact::ltca::{mesh_ltca, MeshModel, SetModel};
use planetwear::contact::separation::MeshFlanks;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::steady_state;
use planetwear::model::gear::{GearKind, GearSet, MeshKind, RootForm, ToothForm};
use planetwear::model::gear_data::{
    external_radii, minimum_profile_shift, operating_centre_distance, operating_pressure_angle, ring_radii,
    trochoid_margin,
};
use planetwear::model::mesh::PathOfContact;
use planetwear::scene::units::{deg_to_rad, m_to_mm, mm_to_m};
use planetwear::scene::{GearData, Problem, Scene};

fn form(
    kind: GearKind,
    teeth: u32,
    m_mm: f64,
    alpha_deg: f64,
    d: &planetwear::model::gear_data::DerivedRadii,
) -> ToothForm {
    ToothForm {
        kind,
        teeth,
        module: mm_to_m(m_mm),
        pressure_angle: deg_to_rad(alpha_deg),
        tooth_thickness: d.tooth_thickness,
        tip_radius: d.tip_radius,
        root_radius: d.root_radius,
        body_radius: match kind {
            GearKind::External => 0.3 * d.root_radius,
            GearKind::Internal => 1.2 * d.root_radius,
        },
        root_form: match kind {
            GearKind::External => RootForm::Hob { tip_radius: d.tool_tip_radius },
            GearKind::Internal => RootForm::Fillet { radius: d.tool_tip_radius },
        },
        chamfer: None,
        face_width: 0.02,
    }
}

fn shifted(x: f64) -> GearData {
    GearData { profile_shift: x, ..GearData::standard() }
}

/// A standard 20°, x = 0 pair on the ISO 53 profile A rack, z = 20/40, m = 2:
/// r_a = r + m, r_f = r − 1.25·m, r_b = r·cos 20°, s = π·m/2, ρ = 0.38·m,
/// and the contact ratio of the closed form
/// ε = (√(r_a1² − r_b1²) + √(r_a2² − r_b2²) − a·sin α)/(π·m·cos α) = 1.6352.
#[test]
fn standard_pair_radii_and_contact_ratio_match_the_closed_form() {
    let g1 = external_radii(20, mm_to_m(2.0), deg_to_rad(20.0), &GearData::standard());
    let g2 = external_radii(40, mm_to_m(2.0), deg_to_rad(20.0), &GearData::standard());
    let tol = 1e-12;
    assert!((m_to_mm(g1.reference_radius) - 20.0).abs() < tol);
    assert!((m_to_mm(g1.tip_radius) - 22.0).abs() < tol && (m_to_mm(g2.tip_radius) - 42.0).abs() < tol);
    assert!((m_to_mm(g1.root_radius) - 17.5).abs() < tol && (m_to_mm(g2.root_radius) - 37.5).abs() < tol);
    assert!((m_to_mm(g1.base_radius) - 20.0 * 20f64.to_radians().cos()).abs() < tol);
    assert!((m_to_mm(g1.tooth_thickness) - PI).abs() < tol);
    assert!((m_to_mm(g1.tool_tip_radius) - 0.76).abs() < tol);
    let alpha = 20f64.to_radians();
    let (rb1, rb2) = (20.0 * alpha.cos(), 40.0 * alpha.cos());
    let closed = ((22f64.powi(2) - rb1 * rb1).sqrt() + (42f64.powi(2) - rb2 * rb2).sqrt()
        - 60.0 * alpha.sin())
        / (PI * 2.0 * alpha.cos());
    assert!((closed - 1.6352).abs() < 1e-4, "closed form {closed}");
    let path = PathOfContact::between(
        &form(GearKind::External, 20, 2.0, 20.0, &g1),
        &form(GearKind::External, 40, 2.0, 20.0, &g2),
        0.060,
        MeshKind::SunPlanet,
    );
    assert!((path.nominal_contact_ratio() - closed).abs() < 1e-9);
    // The undercut limit of profile A at 20°: x_min = 1.25 − 0.38·(1 − sin 20°) − z·sin²20°/2,
    // 17 teeth need about 0.25 − 0.994 + … : the classic "17 teeth" rule with a sharp rack
    // (ρ = 0, h = 1) gives x_min = 1 − 17·sin²20°/2 = 0.0057.
    assert!(
        (minimum_profile_shift(17, 1.0, 0.0, alpha) - (1.0 - 17.0 * alpha.sin().powi(2) / 2.0)).abs() < 1e-15
    );
    assert!(minimum_profile_shift(17, 1.0, 0.0, alpha).abs() < 0.01);
}

/// The published worked example of profile-shifted spur gears (z = 12/24,
/// m = 3, α = 20°, x = 0.6/0.36): inv α_w = 0.034316, α_w = 26.0886°,
/// a_w = 56.4999 mm.
#[test]
fn inv_alpha_w_of_a_shifted_pair_matches_the_published_example() {
    let alpha = 20f64.to_radians();
    let aw = operating_pressure_angle(12, 0.6, 24, 0.36, alpha, false);
    assert!((aw.tan() - aw - 0.034316).abs() < 1e-6);
    assert!((aw.to_degrees() - 26.0886).abs() < 1e-4, "α_w {}", aw.to_degrees());
    let a = m_to_mm(operating_centre_distance(mm_to_m(3.0), 12, 0.6, 24, 0.36, alpha, false));
    assert!((a - 56.4999).abs() < 1e-4, "a_w {a}");
}

/// The inv α_w equation is the zero-backlash condition: at r_w = r_b/cos α_w
/// the tooth thicknesses of an external pair fill the working pitch, and
/// the planet's tooth fills the ring's space, whatever the shifts.
#[test]
fn the_operating_pressure_angle_closes_the_backlash_of_shifted_pairs() {
    let alpha = 20f64.to_radians();
    for (x1, x2) in [(0.5, 0.2), (-0.3, 0.45), (0.0, 0.0)] {
        let (g1, g2) = (
            external_radii(17, mm_to_m(2.0), deg_to_rad(20.0), &shifted(x1)),
            external_radii(43, mm_to_m(2.0), deg_to_rad(20.0), &shifted(x2)),
        );
        let (f1, f2) =
            (form(GearKind::External, 17, 2.0, 20.0, &g1), form(GearKind::External, 43, 2.0, 20.0, &g2));
        let aw = operating_pressure_angle(17, x1, 43, x2, alpha, false);
        let (rw1, rw2) = (f1.base_radius() / aw.cos(), f2.base_radius() / aw.cos());
        let pitch = 2.0 * PI * rw1 / 17.0;
        let gap = pitch - f1.thickness_at(rw1) - f2.thickness_at(rw2);
        assert!(gap.abs() < 1e-12, "external x = {x1}, {x2}: backlash {gap}");
        let a = operating_centre_distance(mm_to_m(2.0), 17, x1, 43, x2, alpha, false);
        assert!((rw1 + rw2 - a).abs() < 1e-12);
        // Planet 17 in ring 80.
        let (p, r) = (
            external_radii(17, mm_to_m(2.0), deg_to_rad(20.0), &shifted(x1)),
            ring_radii(80, mm_to_m(2.0), deg_to_rad(20.0), &shifted(x2)),
        );
        let (fp, fr) =
            (form(GearKind::External, 17, 2.0, 20.0, &p), form(GearKind::Internal, 80, 2.0, 20.0, &r));
        let aw = operating_pressure_angle(17, x1, 80, x2, alpha, true);
        let (rwp, rwr) = (fp.base_radius() / aw.cos(), fr.base_radius() / aw.cos());
        let ring_space = 2.0 * PI * rwr / 80.0 - fr.thickness_at(rwr);
        assert!((ring_space - fp.thickness_at(rwp)).abs() < 1e-12, "internal x = {x1}, {x2}");
        let a = operating_centre_distance(mm_to_m(2.0), 17, x1, 80, x2, alpha, true);
        assert!((rwr - rwp - a).abs() < 1e-12);
    }
}

/// The handbooks' rule for unshifted 20° internal gears of standard
/// proportions: trochoid interference unless the tooth counts differ by
/// more than about 9 (the margin changes sign between 8 and 9).
#[test]
fn trochoid_interference_follows_the_teeth_difference_rule() {
    for zp in [34u32, 40, 60] {
        let margin = |d: u32| {
            let zr = zp + d;
            let p = external_radii(zp, mm_to_m(1.0), deg_to_rad(20.0), &GearData::standard());
            let r = ring_radii(zr, mm_to_m(1.0), deg_to_rad(20.0), &GearData::standard());
            let (fp, fr) =
                (form(GearKind::External, zp, 1.0, 20.0, &p), form(GearKind::Internal, zr, 1.0, 20.0, &r));
            trochoid_margin(&fp, &fr, f64::from(d) / 2.0 * 1e-3).unwrap()
        };
        assert!(margin(7) < 0.0 && margin(6) < margin(7), "z_p {zp}");
        assert!(margin(10) > 0.0 && margin(12) > margin(10), "z_p {zp}");
    }
}

fn problems(scene: &Scene) -> Vec<Problem> {
    match scene.validate() {
        Ok(_) => Vec::new(),
        Err(e) => e.problems().to_vec(),
    }
}

fn expect(scene: &Scene, key: &str, words: &str) -> Problem {
    let all = problems(scene);
    all.iter()
        .find(|p| p.name == key && p.reason.contains(words))
        .cloned()
        .unwrap_or_else(|| panic!("no problem '{key}' with '{words}' in {all:#?}"))
}

fn gear_data_example() -> Scene {
    Scene::example_2004_gear_data()
}

#[test]
fn gear_data_out_of_range_is_named_by_its_key() {
    let mut s = gear_data_example();
    s.sun.gear_data.as_mut().unwrap().addendum_factor = -1.0;
    s.planet.gear_data.as_mut().unwrap().tooth_thickness_allowance = mm_to_m(0.05);
    s.ring.gear_data.as_mut().unwrap().tool_tip_radius_factor = f64::NAN;
    let all = problems(&s);
    for key in [
        "sun.gear_data.addendum_factor",
        "planet.gear_data.tooth_thickness_allowance_mm",
        "ring.gear_data.tool_tip_radius_factor",
    ] {
        assert!(all.iter().any(|p| p.name == key), "{key} missing in {all:#?}");
    }
}

#[test]
fn undercut_is_refused_with_the_minimum_profile_shift() {
    let mut s = gear_data_example();
    s.planet.gear_data.as_mut().unwrap().profile_shift = 0.0;
    s.ring.gear_data.as_mut().unwrap().profile_shift = 0.0;
    s.sun.gear_data.as_mut().unwrap().profile_shift = 0.0;
    // 18 teeth at 21.3° with h_fP* = 1.375, ρ_fP* = 0.2/1.5:
    // x_min = 1.375 − 0.1333·(1 − 0.36325) − 9·0.13195 = 0.1025.
    let p = expect(&s, "planet.gear_data.profile_shift", "undercut");
    assert!(p.reason.contains("x_min") && p.reason.contains("= 0.1025"), "{p}");
    // The radii form: the same rule on the root radius.
    let mut s = Scene::example_2004();
    s.planet.root_radius = mm_to_m(11.5);
    expect(&s, "planet.root_radius_mm", "undercut");
}

#[test]
fn a_too_thin_tip_is_refused() {
    let mut s = gear_data_example();
    s.planet.gear_data.as_mut().unwrap().tip_diameter = Some(mm_to_m(31.6));
    let p = expect(&s, "planet.gear_data.tip_diameter_mm", "too thin");
    assert!(p.reason.contains("0.2·m = 0.3000 mm"), "{p}");
    assert!(p.value.contains("planet.tip_radius_mm = 15.8"), "{p}");
}

#[test]
fn a_contact_ratio_below_one_is_refused_in_both_meshes() {
    let mut s = gear_data_example();
    s.planet.gear_data.as_mut().unwrap().addendum_factor = 0.4;
    s.sun.gear_data.as_mut().unwrap().tip_diameter = Some(mm_to_m(52.0));
    s.ring.gear_data.as_mut().unwrap().tip_diameter = Some(mm_to_m(104.0));
    let all = problems(&s);
    assert!(
        all.iter().any(|p| p.name == "sun.gear_data.tip_diameter_mm"
            && p.reason.contains("sun_planet mesh's contact ratio must be at least 1")),
        "{all:#?}"
    );
    assert!(
        all.iter().any(|p| p.name == "planet.gear_data.addendum_factor"
            && p.reason.contains("ring_planet mesh's contact ratio must be at least 1")),
        "{all:#?}"
    );
}

#[test]
fn equally_spaced_planets_must_fit_and_must_not_collide() {
    let mut s = Scene::example_2004();
    s.planets.count = 3;
    let p = expect(&s, "planets.count", "(Z_sun + Z_ring)/N is an integer");
    assert!(p.reason.contains("(34 + 70)/3"), "{p}");
    let mut s = gear_data_example();
    s.planets.count = 8; // 104/8 = 13 assembles, but centres 29.85 mm apart
    let p = expect(&s, "planets.count", "neighbouring planets collide");
    assert!(p.reason.contains("29.8493") && p.reason.contains("31.2500"), "{p}");
}

#[test]
fn the_centre_distance_must_be_the_one_the_profile_shifts_give() {
    let mut s = gear_data_example();
    s.centre_distance = mm_to_m(39.5);
    let p = expect(&s, "centre_distance_mm", "a_w = 39.0000 mm");
    assert!(p.reason.contains("inv α_w"), "{p}");
    let mut s = gear_data_example();
    s.ring.gear_data.as_mut().unwrap().profile_shift = 0.5;
    let p = expect(&s, "ring.gear_data.profile_shift", "ring–planet mesh runs at a_w");
    assert!(p.reason.contains("x_ring = 0.2917 gives it"), "{p}");
}

/// The ring's tip (minor circle) carrying the contact past the planet's
/// base-circle tangent point: involute interference of the internal mesh.
/// Before this rule the set passed and the LTCA gave a mean transmission
/// error of −101 µm and 4432 MPa (the contact outside the involutes).
#[test]
fn an_interfering_internal_mesh_is_refused() {
    let mut s = Scene::example_2004();
    s.ring.minor_radius = mm_to_m(50.6);
    s.planet.root_radius = mm_to_m(11.5);
    s.planet.hob_tip_radius = mm_to_m(0.6);
    let all = problems(&s);
    assert_eq!(all.len(), 1, "{all:#?}");
    let p = expect(&s, "ring.minor_radius_mm", "involute interference in the ring_planet mesh");
    assert!(p.reason.contains("1.2130 mm past the planet's base-circle tangent point"), "{p}");
    // In gear data: the ring's minor diameter.
    let mut s = gear_data_example();
    s.ring.gear_data.as_mut().unwrap().tip_diameter = Some(mm_to_m(101.2));
    s.planet.gear_data.as_mut().unwrap().root_diameter = Some(mm_to_m(23.0));
    s.planet.gear_data.as_mut().unwrap().tool_tip_radius_factor = 0.4;
    expect(&s, "ring.gear_data.tip_diameter_mm", "involute interference in the ring_planet mesh");
}

#[test]
fn radii_and_gear_data_together_are_refused() {
    let text = Scene::example_2004_gear_data().to_toml().replace("[sun]\n", "[sun]\ntip_radius_mm = 26.37\n");
    let err = Scene::from_toml(&text).unwrap_err().to_string();
    assert!(err.contains("tip_radius_mm given together with gear_data"), "{err}");
    let text = Scene::example_2004().to_toml().replace("tip_radius_mm = 26.37\n", "");
    let err = Scene::from_toml(&text).unwrap_err().to_string();
    assert!(err.contains("missing field tip_radius_mm"), "{err}");
    // Set beside gear data through the API.
    let mut s = gear_data_example();
    s.sun.tip_radius = mm_to_m(26.37);
    expect(&s, "sun.tip_radius_mm", "given by its gear data");
}

#[test]
fn both_forms_read_back_unchanged() {
    for s in [Scene::example_2004(), Scene::example_2004_gear_data()] {
        let text = s.to_toml();
        assert_eq!(Scene::from_toml(&text).unwrap(), s);
        assert_eq!(text.contains("gear_data"), s.sun.gear_data.is_some());
    }
    // A key of the gear data is a scene key (calibration, FMU).
    let s = gear_data_example();
    assert_eq!(s.value_at("planet.gear_data.profile_shift").unwrap(), 7.0 / 24.0);
    assert!(s.value_at("planet.tip_radius_mm").is_err());
    let t = s.with_value("sun.gear_data.tip_diameter_mm", 52.7).unwrap();
    assert_eq!(t.sun.gear_data.unwrap().tip_diameter, Some(mm_to_m(52.7)));
}

/// Largest difference between the tooth forms of two sets \[m\].
fn form_difference(a: &GearSet, b: &GearSet) -> f64 {
    let pairs = [(a.sun(), b.sun()), (a.planet(), b.planet()), (a.ring(), b.ring())];
    let mut worst: f64 = 0.0;
    for (f, g) in pairs {
        assert_eq!((f.teeth, f.kind, f.chamfer), (g.teeth, g.kind, g.chamfer));
        let (rf, rg) = match (f.root_form, g.root_form) {
            (RootForm::Hob { tip_radius: x }, RootForm::Hob { tip_radius: y }) => (x, y),
            (RootForm::Fillet { radius: x }, RootForm::Fillet { radius: y }) => (x, y),
            other => panic!("root forms differ: {other:?}"),
        };
        for (x, y) in [
            (f.tooth_thickness, g.tooth_thickness),
            (f.tip_radius, g.tip_radius),
            (f.root_radius, g.root_radius),
            (f.body_radius, g.body_radius),
            (f.module, g.module),
            (f.face_width, g.face_width),
            (rf, rg),
        ] {
            worst = worst.max((x - y).abs());
        }
        assert_eq!(f.pressure_angle, g.pressure_angle);
    }
    worst.max((a.centre_distance() - b.centre_distance()).abs())
}

/// The example given by gear data is the example: radii within 1 nm, and
/// the same natural frequencies, LTCA stiffness and transmission error to
/// 1e-8 relative and steady-state mesh forces to the integrator's tolerance
/// (the radii differ by rounding of the allowances only, below 1e-10 mm).
#[test]
fn the_example_from_its_gear_data_reproduces_the_radii_form() {
    let (radii, run) = Scene::example_2004().validate_with_run().unwrap();
    let (data, run_d) = Scene::example_2004_gear_data().validate_with_run().unwrap();
    let d = form_difference(&radii, &data);
    assert!(d < 1e-12, "largest radius difference {d} m");

    let close = |x: f64, y: f64, what: &str| {
        assert!((x - y).abs() <= 1e-8 * x.abs().max(y.abs()).max(1e-30), "{what}: {x} vs {y}");
    };
    let mut m_r = PlanetaryDynamics::new(&radii, SetModel::new(&radii)).unwrap();
    let mut m_d = PlanetaryDynamics::new(&data, SetModel::new(&data)).unwrap();
    let (f_r, f_d) = (natural_modes(&m_r.lumped), natural_modes(&m_d.lumped));
    assert_eq!(f_r.len(), f_d.len());
    for (a, b) in f_r.iter().zip(&f_d) {
        // A rigid-body mode's frequency is zero up to round-off (of the
        // order of 1e-3 Hz against modes of kHz), which no relative
        // tolerance compares.
        if a.frequency.abs().max(b.frequency.abs()) < 1e-2 {
            continue;
        }
        close(a.frequency, b.frequency, "natural frequency");
    }
    for mesh in MeshKind::ALL {
        let w = radii.input_torque() / radii.sun().base_radius() / 4.0;
        let a = mesh_ltca(&radii, &MeshModel::new(&radii, mesh, &MeshFlanks::default()), w, 60);
        let b = mesh_ltca(&data, &MeshModel::new(&data, mesh, &MeshFlanks::default()), w, 60);
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        close(mean(&a.mesh_stiffness_loaded), mean(&b.mesh_stiffness_loaded), "loaded mesh stiffness");
        close(mean(&a.transmission_error), mean(&b.transmission_error), "static transmission error");
    }
    let omega = 3000.0 * PI / 30.0;
    let a = steady_state(&mut m_r, &radii, &run, omega, None).unwrap();
    let b = steady_state(&mut m_d, &data, &run_d, omega, None).unwrap();
    // The steady states come from the adaptive integrator, whose step
    // decisions turn a difference of 1e-13 in the radii into one of the order
    // of its tolerance (3e-6): the mean and F^(rms) agree within 3e-6 of the
    // mean force (measured on the example's flexible planet bearings: 3.9e-8
    // of the mean for the mean, 1.2e-7 for F^(rms)).
    for (x, y) in a.meshes.iter().zip(&b.meshes) {
        let bound = 3e-6 * x.harmonics.mean.abs();
        assert!((x.harmonics.mean - y.harmonics.mean).abs() <= bound, "mean mesh force");
        assert!((x.harmonics.rms - y.harmonics.rms).abs() <= bound, "rms mesh force");
    }
}
