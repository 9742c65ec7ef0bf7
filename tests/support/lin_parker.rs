//! A benchmark-like lumped set in the style of Lin & Parker (1999), Table 1
//! orders of magnitude: the laws tests/modes.rs and tests/rotating_carrier.rs
//! check hold for any values.

use planetwear::model::gear::Member;
use planetwear::model::lumped::{Fidelity, LumpedSet};

/// `n` equally spaced planets at the fidelity `fidelity`, member `held` held.
pub fn lin_parker_set(n: usize, fidelity: Fidelity, held: Option<Member>) -> LumpedSet {
    LumpedSet {
        central_mass: [5.43, 2.35, 0.4],
        central_rotational_mass: [6.29, 3.0, 0.39],
        planet_mass: 0.66,
        planet_rotational_mass: 0.61,
        central_bearing: [1e8, 1e8, 1e8],
        central_torsional: [0.0, 1e9, 0.0],
        planet_bearing: 1e8,
        planet_bearings: Vec::new(),
        sun_mesh: 5e8,
        ring_mesh: 5e8,
        sun_pressure_angle: 24.6f64.to_radians(),
        ring_pressure_angle: 24.6f64.to_radians(),
        planet_angles: (0..n).map(|i| 2.0 * std::f64::consts::PI * i as f64 / n as f64).collect(),
        held,
        fidelity,
    }
}
