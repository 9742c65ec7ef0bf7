//! The example's full speed sweep, 500 to 15 000 rpm in 50 rpm steps, up and
//! then down, on one thread, at the default fidelity and accuracy. Prints wall
//! time, internal steps per second and ns per step per degree of freedom.
//! Run: `cargo bench --bench sweep` (add `-- --torsional` for the torsional
//! level, `-- --quick` for a 500 rpm grid); docs/PERFORMANCE.md records the figures.

use std::time::Instant;

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::{sweep, Direction};
use planetwear::dynamics::solver::SecondOrderSystem;
use planetwear::scene::Scene;

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let mut scene = Scene::example_2004_stiff_pins();
    if std::env::args().any(|a| a == "--torsional") {
        scene.dynamics.fidelity = planetwear::scene::Fidelity::Torsional;
    }
    let (set, run) = scene.validate_with_run().expect("the example is valid");
    let built = Instant::now();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
    let build_time = built.elapsed().as_secs_f64();
    let step = if quick { 500.0 } else { 50.0 };
    let n = ((15000.0 - 500.0) / step) as usize + 1;
    let up: Vec<f64> = (0..n).map(|i| 500.0 + step * i as f64).collect();
    let mut down = up.clone();
    down.reverse();
    let start = Instant::now();
    let mut steps = 0u64;
    let mut newton = 0u64;
    for (dir, grid) in [(Direction::Up, &up), (Direction::Down, &down)] {
        let mut m = model.clone();
        let grid: Vec<f64> = grid.iter().copied().map(planetwear::scene::units::rpm_to_rad_per_s).collect();
        let sw = sweep(&set, &run, &mut m, dir, &grid, &[], |_| {}).expect("sweep");
        steps += sw.points.iter().map(|p| p.stats.steps).sum::<u64>();
        newton += sw.points.iter().map(|p| p.stats.newton_iterations).sum::<u64>();
    }
    let wall = start.elapsed().as_secs_f64();
    let dof = model.dim();
    println!("sweep benchmark: example-2004, {:?}, {} speeds × 2 directions, one thread", set.fidelity(), n);
    println!("  model build (contact tables, LTCA for the mean stiffness): {build_time:.3} s");
    println!("  wall time of both sweeps: {wall:.2} s");
    println!("  internal steps: {steps} ({:.0} steps/s), Newton iterations {newton}", steps as f64 / wall);
    println!(
        "  degrees of freedom: {dof}; {:.1} ns per step per degree of freedom",
        wall * 1e9 / steps as f64 / dof as f64
    );
}
