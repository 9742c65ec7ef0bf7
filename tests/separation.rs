//! Unloaded separation from the 2-D flank outlines.

use planetwear::contact::separation::{MeshFlanks, MeshSeparation};
use planetwear::geometry::profile::{FlankOutline, ProfileDeviation};
use planetwear::model::gear::{GearSet, MeshKind};
use planetwear::scene::Scene;

fn example() -> GearSet {
    Scene::example_2004().validate().expect("valid")
}

#[test]
fn perfect_involutes_touch_along_the_whole_path_and_back_flanks_sit_one_backlash_away() {
    let set = example();
    for mesh in MeshKind::ALL {
        let sep = MeshSeparation::new(&set, mesh, &MeshFlanks::default(), 5e-6);
        let p = &sep.path;
        let inner = (p.start + 0.02e-3, p.end - 0.02e-3);
        let mut worst_d: f64 = 0.0;
        let mut worst_b: f64 = 0.0;
        for s in sep.drive.positions().filter(|s| *s > inner.0 && *s < inner.1) {
            worst_d = worst_d.max(sep.drive.at(s).abs());
        }
        let back_inner = (sep.back_range.0 + 0.02e-3, sep.back_range.1 - 0.02e-3);
        for s in sep.back.positions().filter(|s| *s > back_inner.0 && *s < back_inner.1) {
            worst_b = worst_b.max((sep.back.at(s) - sep.normal_backlash).abs());
        }
        eprintln!(
            "{mesh:?}: drive |g| max {worst_d:e}, back |g - jn| max {worst_b:e}, jn {}",
            sep.normal_backlash
        );
        // Polyline chords of the 400-point involute sag by ~1e-9 m.
        assert!(worst_d < 2e-8, "{mesh:?} drive separation on the path {worst_d}");
        assert!(worst_b < 2e-8, "{mesh:?} back separation on the path {worst_b}");
        // Outside the path the chamfered tip corner leaves a gap that grows.
        let before = sep.drive.at(p.start - 0.3e-3);
        let after = sep.drive.at(p.end + 0.3e-3);
        eprintln!("  0.3 mm before start {before:e}, after end {after:e}");
        assert!(before > 1e-7 && after > 1e-7);
        assert!(sep.drive.at(p.start - 0.6e-3) > before);
    }
}

#[test]
fn fillet_joins_the_involute_at_the_form_radius() {
    let set = example();
    for g in [&set.sun(), &set.planet(), &set.ring()] {
        let o = FlankOutline::new(g, &ProfileDeviation::none());
        eprintln!(
            "form radius {:.5} mm (analytic {:.5}), root half angle {:.5}",
            o.form_radius * 1e3,
            g.form_radius() * 1e3,
            o.root_half_angle
        );
        assert!((o.form_radius - g.form_radius()).abs() < 2e-6, "{} vs {}", o.form_radius, g.form_radius());
    }
}

/// A profile deviation removes material: on the sun (external) and on the
/// ring (internal) alike, a uniform deviation e makes the tooth thinner, its
/// half-thickness at a mid-involute radius smaller by e / cos of the angle
/// between the flank normal and the tooth's cross direction (to 2 % of e),
/// never thicker.
#[test]
fn a_deviation_thins_the_tooth_of_an_external_and_an_internal_gear() {
    use planetwear::geometry::profile::{involute_normal, FlankOutline, ProfileDeviation};
    let set = planetwear::scene::Scene::example_2004().validate().unwrap();
    let e = 10e-6;
    for form in [set.sun(), set.ring()] {
        let rb = form.base_radius();
        let r = 0.5 * (form.root_radius.max(rb) + form.tip_radius);
        let r = if r < rb { rb * 1.01 } else { r };
        let xi = (r * r - rb * rb).sqrt() / rb;
        let worn = ProfileDeviation::new(vec![0.0, 2.0], vec![e, e]);
        let new = FlankOutline::new(form, &ProfileDeviation::none());
        let old = FlankOutline::new(form, &worn);
        // The half-thickness is read at the centreline coordinate of the
        // unworn involute point at this roll angle.
        let phi = form.involute_half_angle(r);
        let x = r * phi.cos();
        let thinner = new.half_thickness_at(x) - old.half_thickness_at(x);
        let n = involute_normal(form, xi);
        // A shift e along the normal moves the flank by e/|n_y| across the tooth.
        let expected = e / n[1].abs();
        eprintln!("{:?}: thinner by {thinner:.4e} m, e/|n_y| = {expected:.4e} m", form.kind);
        assert!(thinner > 0.0, "{:?}: the worn tooth is thicker by {:.3e} m", form.kind, -thinner);
        assert!(
            (thinner - expected).abs() < 0.02 * e,
            "{:?}: thinner by {thinner:.3e} m, expected {expected:.3e}",
            form.kind
        );
    }
}
