//! Geometry of the example against docs/MODEL.md §1 and docs/FORMULAS.md.

use planetwear::model::gear::MeshKind;
use planetwear::model::mesh::PathOfContact;
use planetwear::scene::Scene;

fn example() -> planetwear::model::gear::GearSet {
    Scene::example_2004().validate().expect("the example is valid")
}

#[test]
fn sun_pitch_point_roll_angle_is_22_34_deg() {
    let set = example();
    let path = PathOfContact::new(&set, MeshKind::SunPlanet);
    let xi = path.roll_1(path.pitch_point()).to_degrees();
    assert!((xi - 22.34).abs() < 0.005, "pitch-point roll angle {xi} deg");
}

#[test]
fn base_pitch_is_4_3905_mm() {
    let set = example();
    for g in [&set.sun(), &set.planet(), &set.ring()] {
        assert!((g.base_pitch() * 1e3 - 4.3905).abs() < 5e-5, "{}", g.base_pitch());
    }
}

#[test]
fn base_radii_match_model_md() {
    let set = example();
    for (g, rb) in [(&set.sun(), 23.758), (&set.planet(), 12.578), (&set.ring(), 48.914)] {
        assert!((g.base_radius() * 1e3 - rb).abs() < 5e-4, "{} vs {rb}", g.base_radius() * 1e3);
    }
}

#[test]
fn nominal_contact_ratios_follow_from_the_radii() {
    let set = example();
    let sp = PathOfContact::new(&set, MeshKind::SunPlanet);
    let rp = PathOfContact::new(&set, MeshKind::RingPlanet);
    // Closed forms of docs/FORMULAS.md evaluated by hand with the given radii:
    // sun–planet (sqrt(26.37²−rb_s²) − (39 sin α − sqrt(15.25²−rb_p²))) / p_b = 1.3436,
    // ring–planet (sqrt(15.25²−rb_p²) − sqrt(51.725²−rb_r²) + 39 sin α) / p_b = 1.3598.
    assert!((sp.nominal_contact_ratio() - 1.3436).abs() < 2e-3, "{}", sp.nominal_contact_ratio());
    assert!((rp.nominal_contact_ratio() - 1.3598).abs() < 2e-3, "{}", rp.nominal_contact_ratio());
    // Sun active profile from ~13.4° to ~27.6° of roll (docs/MODEL.md §1).
    assert!((sp.roll_1(sp.start_sharp).to_degrees() - 13.4).abs() < 0.05);
    assert!((sp.roll_1(sp.end_sharp).to_degrees() - 27.6).abs() < 0.05);
    // The chamfer shortens the path on the involutes.
    assert!(sp.involute_contact_ratio() < sp.nominal_contact_ratio());
}

#[test]
fn backlash_matches_model_md() {
    let set = example();
    let j_sp = set.circumferential_backlash(MeshKind::SunPlanet) * 1e3;
    let j_rp = set.circumferential_backlash(MeshKind::RingPlanet) * 1e3;
    assert!((j_sp - 0.232).abs() < 5e-4, "{j_sp}");
    assert!((j_rp - 0.243).abs() < 5e-4, "{j_rp}");
}

#[test]
fn every_root_has_clearance() {
    let set = example();
    for mesh in MeshKind::ALL {
        let path = PathOfContact::new(&set, mesh);
        for (c, tip, root) in path.root_clearances() {
            // Hand values: 0.755, 0.750, 0.750, 0.850 mm.
            assert!(c > 0.7e-3 && c < 0.9e-3, "{tip} tip vs {root} root: {c}");
        }
        let (r1, r2) = path.active_profile_start_radii();
        let (g1, g2) = set.mesh_gears(mesh);
        assert!(r1 > g1.form_radius(), "{mesh:?} gear 1 start of active profile below form radius");
        match mesh {
            MeshKind::SunPlanet => assert!(r2 > g2.form_radius()),
            MeshKind::RingPlanet => assert!(r2 < g2.form_radius()),
        }
    }
}
