//! A variant of the example whose planets all mesh in phase: Z_sun / n =
//! 36 / 4 and Z_ring / n = 72 / 4 are integers, so all four sun meshes (and
//! all four ring meshes) are in phase and every planet carries exactly a
//! quarter of the load at every position. Used by tests/ltca.rs, tests/wear.rs
//! and tests/wear_state.rs.

use planetwear::scene::units::mm_to_m;
use planetwear::scene::Scene;

/// The example with 36 sun and 72 ring teeth (radii and centre distance to
/// match), named "in-phase".
pub fn in_phase_scene() -> Scene {
    let mut s = Scene::example_2004();
    s.name = "in-phase".into();
    s.sun.teeth = 36;
    s.sun.tip_radius = mm_to_m(27.87);
    s.sun.root_radius = mm_to_m(24.5);
    s.sun.bore_radius = mm_to_m(13.0);
    s.ring.teeth = 72;
    s.ring.minor_radius = mm_to_m(53.225);
    s.ring.root_radius = mm_to_m(56.5);
    s.ring.rim_radius = mm_to_m(60.45);
    s.centre_distance = mm_to_m(40.5);
    s
}
