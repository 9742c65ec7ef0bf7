//! The periodic tests' reference: long time marching at tight tolerance, and the
//! example's worn states.

use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::{steady_state, SteadyState};
use planetwear::dynamics::spectrum::Harmonics;
use planetwear::model::gear::GearSet;
use planetwear::model::run::RunSettings;

/// The example's worn states κ = 0..6 (the wear model's, as the FMU ships them).
pub fn worn_states() -> &'static [planetwear::wear::state::WornState] {
    static STATES: std::sync::OnceLock<Vec<planetwear::wear::state::WornState>> = std::sync::OnceLock::new();
    STATES.get_or_init(|| planetwear::package::pack::example_wear_states().unwrap())
}

/// The steady state at `omega` [rad/s] by time marching at relative tolerance 1e-10 from
/// the static state, run in until two successive mesh cycles agree to 1e-10 of the mean
/// tooth force (at most 12 revolutions), 64 samples per mesh cycle.
pub fn long_marched(set: &GearSet, run: &RunSettings, model: PlanetaryDynamics, omega: f64) -> SteadyState {
    let long = run
        .with(|d| {
            d.relative_tolerance = 1e-10;
            d.run_in_revolutions = 12.0;
            d.steady_tolerance = 1e-10;
            d.measured_revolutions = 0.5;
            d.samples_per_mesh_cycle = 64;
        })
        .unwrap();
    let mut m = model;
    steady_state(&mut m, set, &long, omega, None).unwrap()
}

/// Planet 1's two meshes' harmonics (what E_h compares).
pub fn planet_one(s: &SteadyState) -> Vec<Harmonics> {
    vec![s.meshes[0].harmonics.clone(), s.meshes[1].harmonics.clone()]
}
