//! Laws of the loaded tooth contact analysis that hold for every load and position.

use std::sync::OnceLock;

use planetwear::contact::ltca::MeshModel;
use planetwear::contact::separation::MeshFlanks;
use planetwear::model::gear::{GearSet, MeshKind};
use planetwear::scene::Scene;
use proptest::prelude::*;

fn models() -> &'static (GearSet, MeshModel, MeshModel) {
    static M: OnceLock<(GearSet, MeshModel, MeshModel)> = OnceLock::new();
    M.get_or_init(|| {
        let set = Scene::example_2004().validate().unwrap();
        let sp = MeshModel::new(&set, MeshKind::SunPlanet, &MeshFlanks::default());
        let rp = MeshModel::new(&set, MeshKind::RingPlanet, &MeshFlanks::default());
        (set, sp, rp)
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn pair_loads_add_up_and_never_pull(load_per_mm in 1.0f64..3000.0, phase in 0.0f64..1.0, ring in any::<bool>()) {
        let (set, sp, rp) = models();
        let m = if ring { rp } else { sp };
        let p = m.path();
        let s = p.start + phase * p.base_pitch;
        let w = load_per_mm * set.sun().face_width * 1e3;
        let d = m.approach_for(s, w);
        let mut pairs = Vec::new();
        let (f, k) = m.force(s, d, Some(&mut pairs));
        prop_assert!((f / w - 1.0).abs() < 1e-9);
        prop_assert!(k > 0.0);
        // Drive-flank contact only pushes.
        prop_assert!(pairs.iter().all(|c| c.force >= 0.0));
        // More load, more approach (the mesh is a stiffening spring).
        let d2 = m.approach_for(s, 1.1 * w);
        prop_assert!(d2 > d);
        // Contact only closes as the approach grows (a convex force law): the
        // secant slope between two loads never exceeds the tangent stiffness at
        // the larger one.
        let (_, k2) = m.force(s, d2, None);
        prop_assert!((0.1 * w) / (d2 - d) <= k2 * (1.0 + 1e-9));
    }

    /// The dynamic model's two force evaluations (with and without event
    /// values) say what the pair-by-pair contact says: the mesh force, and
    /// as the peak tooth-pair force the largest pair force in magnitude, on
    /// the drive flank (positive approach) and the back flank (negative).
    #[test]
    fn the_hot_path_peak_pair_force_is_the_largest_pair_force(
        load_per_mm in 0.0f64..3000.0, phase in -2.0f64..2.0, ring in any::<bool>(), back in any::<bool>(),
    ) {
        let (set, sp, rp) = models();
        let m = if ring { rp } else { sp };
        let p = m.path();
        let s = p.start + phase * p.base_pitch;
        let w = load_per_mm * set.sun().face_width * 1e3;
        // Beyond the example's backlash (about 0.25 mm) the back flanks touch.
        let d = if back { -m.approach_for(s, w) - 3e-4 } else { m.approach_for(s, w) };
        let mut pairs = Vec::new();
        let (f, k) = m.force(s, d, Some(&mut pairs));
        let peak = pairs.iter().map(|c| c.force.abs()).fold(0.0, f64::max);
        let mut events = vec![0.0; 2 * m.event_slots()];
        for law in [m.force_tangents(s, d), m.force_with_derivatives(s, d, &mut events)] {
            let scale = f.abs().max(1.0);
            prop_assert!((law.force - f).abs() <= 1e-9 * scale, "{law:?} vs force {f}");
            prop_assert!((law.approach_stiffness - k).abs() <= 1e-9 * k.max(1.0));
            prop_assert!((law.peak_pair_force - peak).abs() <= 1e-9 * scale, "{law:?} vs peak {peak}");
            // On one flank the pairs push the same way: none carries more
            // than all of them.
            prop_assert!(law.peak_pair_force <= f.abs() + 1e-9 * scale);
        }
    }
}
