//! Every validation rule has a test that checks its message names the
//! parameter and says what is allowed.

use planetwear::scene::units::{deg_to_rad, mm_to_m};
use planetwear::scene::{ChamferSpec, Scene, SceneError};

fn problems(scene: &Scene) -> Vec<String> {
    match scene.validate() {
        Ok(_) => panic!("scene should be invalid"),
        Err(e) => {
            let all = e.to_string();
            assert!(all.starts_with("invalid scene"), "{all}");
            e.problems().iter().map(|p| p.to_string()).collect()
        }
    }
}

fn expect(scene: &Scene, name: &str, words: &str) {
    let list = problems(scene);
    assert!(
        list.iter().any(|p| p.starts_with(name) && p.contains(words)),
        "expected a problem on {name} saying '{words}', got {list:#?}"
    );
}

fn ex() -> Scene {
    Scene::example_2004()
}

#[test]
fn non_positive_sizes() {
    let mut s = ex();
    s.sun.module = mm_to_m(0.0);
    s.planet.face_width = mm_to_m(-3.0);
    s.ring.rim_radius = mm_to_m(f64::NAN);
    expect(&s, "sun.module_mm", "greater than zero");
    expect(&s, "planet.face_width_mm", "greater than zero");
    expect(&s, "ring.rim_radius_mm", "greater than zero");
}

#[test]
fn tip_radius_below_base_radius() {
    let mut s = ex();
    s.sun.tip_radius = mm_to_m(23.5);
    s.sun.root_radius = mm_to_m(22.0);
    s.sun.tip_chamfer = Some(ChamferSpec::new(0.0, deg_to_rad(45.0)));
    expect(&s, "sun.tip_radius_mm", "must exceed the base radius 23.758");
    let mut s = ex();
    s.ring.minor_radius = mm_to_m(48.0);
    expect(&s, "ring.minor_radius_mm", "must exceed the ring's base radius");
}

#[test]
fn radii_out_of_order() {
    let mut s = ex();
    s.planet.bore_radius = mm_to_m(12.0);
    expect(&s, "planet.bore_radius_mm", "below the root radius");
    let mut s = ex();
    s.ring.root_radius = mm_to_m(51.0);
    expect(&s, "ring.root_radius_mm", "exceed the minor radius");
}

#[test]
fn pointed_teeth() {
    let mut s = ex();
    s.planet.tooth_thickness = mm_to_m(1.0);
    s.ring.tooth_thickness = mm_to_m(1.0);
    expect(&s, "planet.tip_radius_mm", "pointed");
}

#[test]
fn contact_ratio_below_one() {
    let mut s = ex();
    s.sun.tip_radius = mm_to_m(25.6);
    s.planet.tip_radius = mm_to_m(14.0);
    s.sun.tip_chamfer = Some(ChamferSpec::new(mm_to_m(0.02), deg_to_rad(45.0)));
    s.planet.tip_chamfer = Some(ChamferSpec::new(mm_to_m(0.02), deg_to_rad(45.0)));
    expect(&s, "sun.tip_radius_mm", "contact ratio must be at least 1");
}

#[test]
fn negative_backlash() {
    let mut s = ex();
    s.sun.tooth_thickness = mm_to_m(2.3);
    expect(&s, "sun.tooth_thickness_mm", "negative backlash");
}

#[test]
fn tip_root_interference_and_root_clearance() {
    let mut s = ex();
    s.sun.root_radius = mm_to_m(24.0);
    expect(&s, "planet.tip_radius_mm", "must clear the sun root circle");
    let mut s = ex();
    s.ring.minor_radius = mm_to_m(51.0);
    expect(&s, "ring.minor_radius_mm", "tip/root interference in the ring_planet mesh");
}

#[test]
fn assembly_condition_and_overlapping_planets() {
    let mut s = ex();
    s.planets.angles = Some([0.0, 91.0, 180.0, 270.0].map(deg_to_rad).to_vec());
    expect(&s, "planets.angles_deg[1]", "multiples of 360°/(Z_sun + Z_ring)");
    let mut s = ex();
    s.planets.count = 8;
    expect(&s, "planets.count", "neighbouring planets collide");
    let mut s = ex();
    s.planets.angles = Some([0.0, 90.0].map(deg_to_rad).to_vec());
    expect(&s, "planets.angles_deg", "exactly planets.count = 4");
}

#[test]
fn chamfer_limits() {
    let mut s = ex();
    s.sun.tip_chamfer = Some(ChamferSpec::new(mm_to_m(1.0), deg_to_rad(45.0)));
    expect(&s, "sun.tip_chamfer.height_mm", "below half the addendum");
    let mut s = ex();
    s.planet.tip_chamfer = Some(ChamferSpec::new(mm_to_m(0.1), deg_to_rad(95.0)));
    expect(&s, "planet.tip_chamfer.angle_deg", "strictly between 0 and 90");
}

#[test]
fn material_operation_and_modules() {
    let mut s = ex();
    s.material.poisson_ratio = 0.6;
    expect(&s, "material.poisson_ratio", "strictly between 0 and 0.5");
    let mut s = ex();
    s.operation.input = s.operation.held;
    expect(&s, "operation.input", "must differ from the held member (carrier)");
    let mut s = ex();
    s.planet.module = mm_to_m(1.25);
    expect(&s, "planet.module_mm", "sun's base pitch");
    let mut s = ex();
    s.centre_distance = mm_to_m(30.0);
    expect(&s, "centre_distance_mm", "must exceed the sum of sun and planet base radii");
}

#[test]
fn every_problem_is_reported_at_once() {
    let mut s = ex();
    s.sun.module = mm_to_m(0.0);
    s.planet.module = mm_to_m(-1.0);
    s.material.density_kg_per_m3 = 0.0;
    assert!(problems(&s).len() >= 3);
}

#[test]
fn syntax_errors_name_the_line_and_unknown_keys_are_refused() {
    let text = ex().to_toml().replace("teeth = 34", "teeth = \"many\"");
    let e = Scene::from_toml(&text).unwrap_err();
    assert!(matches!(e, SceneError::Syntax { .. }));
    assert!(e.to_string().contains("line"), "{e}");
    let text = ex().to_toml().replace("teeth = 34", "teeth = 34\ntooth_count = 34");
    let e = Scene::from_toml(&text).unwrap_err();
    assert!(e.to_string().contains("tooth_count"), "{e}");
}

#[test]
fn the_example_round_trips_through_toml() {
    let s = ex();
    let back = Scene::from_toml(&s.to_toml()).unwrap();
    assert_eq!(s, back);
    assert!(back.validate().is_ok());
}
