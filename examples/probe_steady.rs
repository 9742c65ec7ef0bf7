//! Scratch probe (not committed): one steady state of the example.
use planetwear::physics::dynamics::PlanetaryDynamics;
use planetwear::physics::ltca::SetModel;
use planetwear::physics::response::steady_state;
use planetwear::scene::{Fidelity, Scene};

fn main() {
    let mut scene = Scene::example_2004();
    if std::env::args().any(|a| a == "rk") {
        scene.dynamics.integrator = planetwear::scene::IntegratorKind::Rk45;
        scene.dynamics.relative_tolerance = 1e-7;
    }
    if std::env::args().any(|a| a == "torsional") {
        scene.dynamics.fidelity = Fidelity::Torsional;
    }
    let set = scene.validate().unwrap();
    let t0 = std::time::Instant::now();
    let mut model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    println!("model built in {:?}, dim {}", t0.elapsed(), planetwear::solver::SecondOrderSystem::dim(&model));
    for rpm in [3000.0, 5000.0] {
        let t0 = std::time::Instant::now();
        let r = steady_state(&mut model, &set, rpm * std::f64::consts::PI / 30.0, None).unwrap();
        let el = t0.elapsed();
        let w = set.sun.face_width * 1e3;
        let m0 = &r.meshes[0];
        let m1 = &r.meshes[1];
        println!(
            "{rpm} rpm: {:?}, steps {}, rej {}, ev {}, newton {}, sun mesh mean {:.1} N/mm rms {:.2} sep {:.3} | ring mean {:.1} rms {:.2} sep {:.3}",
            el, r.stats.steps, r.stats.rejected_steps, r.stats.events_located, r.stats.newton_iterations,
            m0.harmonics.mean / w, m0.harmonics.rms / w, m0.separation,
            m1.harmonics.mean / w, m1.harmonics.rms / w, m1.separation
        );
    }
}
