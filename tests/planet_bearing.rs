//! The example's planet-bearing stiffness, derived (Palmgren, Stribeck, the
//! pin between the plates: src/model/planet_bearing.rs) and written in
//! docs/PARAMETERS.md: the document's figures are the function's.

use planetwear::model::planet_bearing::{palmgren_deflection, planet_support, NeedleBearing};
use planetwear::scene::Scene;

/// The number after `marker` on the line of docs/PARAMETERS.md that holds it.
fn documented(marker: &str) -> f64 {
    let doc = include_str!("../docs/PARAMETERS.md");
    let at = doc.find(marker).unwrap_or_else(|| panic!("docs/PARAMETERS.md has no '{marker}'"));
    let rest = &doc[at + marker.len()..];
    let number: String = rest
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | '-' | '+'))
        .collect();
    number.parse().unwrap_or_else(|e| panic!("'{marker}' is followed by '{number}': {e}"))
}

/// Law: with zero clearance the most loaded roller of a line-contact
/// bearing carries Q_max = 4.08 F_r/Z (Stribeck's number for line contact,
/// Harris & Kotzalas, Rolling Bearing Analysis), here
/// within 1 %; and Palmgren's δ = 3.84e-5 Q^0.9/l^0.8 at Q = 1000 N over
/// l = 10 mm is 3.84e-5 · 501.19/6.3096 mm = 3.050 µm (to 1e-3).
#[test]
fn stribeck_and_palmgren_give_their_published_numbers() {
    let set = Scene::example_2004().validate().unwrap();
    let s = planet_support(&set, &NeedleBearing::example_2004());
    assert!((s.stribeck_number / 4.08 - 1.0).abs() < 0.01, "Stribeck number {}", s.stribeck_number);
    let d = palmgren_deflection(1000.0, 10e-3);
    assert!((d / 3.050e-6 - 1.0).abs() < 1e-3, "Palmgren {d}");
}

/// The figures of docs/PARAMETERS.md's planet-bearing derivation are the
/// function's to 0.5 % (the document rounds to three digits), and the
/// flexible example's planet bearing is the derived stiffness to 0.5 %.
#[test]
fn the_documented_planet_bearing_stiffness_is_the_derived_one() {
    let scene = Scene::example_2004();
    let set = scene.validate().unwrap();
    let s = planet_support(&set, &NeedleBearing::example_2004());
    for (marker, value) in [
        ("bearing load F_r =", s.load),
        ("most loaded roller Q_max =", s.roller_load_max),
        ("bearing deflection δ_r =", s.bearing_deflection * 1e6),
        ("bearing tangent stiffness k_b =", s.bearing_stiffness),
        ("pin stiffness k_pin =", s.pin_stiffness),
        ("planet support k_p =", s.stiffness),
    ] {
        let doc = documented(marker);
        eprintln!("{marker} {value:.4e} (docs: {doc:e})");
        assert!((doc / value - 1.0).abs() < 5e-3, "{marker} docs {doc} against {value}");
    }
    let k = scene.supports.planet_bearing_n_per_m;
    assert!((k / s.stiffness - 1.0).abs() < 5e-3, "example's planet bearing {k} against {}", s.stiffness);
}
