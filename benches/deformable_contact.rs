//! Cost of the deformable mesh law on the built-in example: one exact solve
//! of all tooth pairs of a mesh (one LTCA position), the force table's build
//! time, one table lookup, and the pair model's `force_tangents` for
//! comparison. The bodies are the stand-in `CurveBody` (energy-method
//! compliance curve; coupled neighbours, fraction 0.3), the local term
//! Johnson's. Median of 7 rounds; the table build is timed once per round.
//!
//! Run: `cargo bench --bench deformable_contact`; docs/DEFORMABLE.md records
//! the figures with the machine.

use std::hint::black_box;
use std::time::Instant;

use planetwear::contact::deformable::law::{DeformableMesh, LocalContact};
use planetwear::contact::deformable::standin::CurveBody;
use planetwear::contact::deformable::table::{TableSpec, TabulatedMesh};
use planetwear::contact::ltca::MeshModel;
use planetwear::contact::separation::MeshFlanks;
use planetwear::model::gear::MeshKind;
use planetwear::scene::Scene;

/// Median time per call [s] of `f` over `reps` calls, in 7 rounds.
fn time(reps: usize, mut f: impl FnMut(usize) -> f64) -> f64 {
    let mut sink = 0.0;
    let mut rounds: Vec<f64> = (0..7)
        .map(|_| {
            let t = Instant::now();
            for i in 0..reps {
                sink += f(i);
            }
            t.elapsed().as_secs_f64() / reps as f64
        })
        .collect();
    rounds.sort_by(f64::total_cmp);
    assert!(black_box(sink).is_finite());
    rounds[3]
}

fn main() {
    let set = Scene::example_2004().validate().expect("the example is valid");
    let load = set.mesh_load_per_planet();
    println!(
        "mesh        solve [µs]  (linear local) [µs]  table lookup [µs]  pair model [µs]  table build [s]"
    );
    for mesh in MeshKind::ALL {
        let (g1, g2) = set.mesh_gears(mesh);
        let b1 = CurveBody::new(g1, set.material()).coupled(0.3);
        let b2 = CurveBody::new(g2, set.material()).coupled(0.3);
        let flanks = MeshFlanks::default();
        let law = DeformableMesh::new(&set, mesh, &b1, &b2, &flanks, LocalContact::Johnson).expect("law");
        let compliance = planetwear::contact::stiffness::hertz_compliance(
            set.material(),
            g1.face_width.min(g2.face_width),
        );
        let linear = DeformableMesh::new(&set, mesh, &b1, &b2, &flanks, LocalContact::Linear { compliance })
            .expect("law");
        let pair_model = MeshModel::new(&set, mesh, &flanks);
        let p = law.path().clone();
        let n = 200;
        let points: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let s = p.start + p.base_pitch * i as f64 / n as f64;
                (s, law.approach_for(s, load).expect("approach"))
            })
            .collect();
        let solve = time(2000, |i| {
            let (s, d) = points[i % n];
            law.solve(s, d).expect("solve").law.force
        });
        let solve_linear = time(2000, |i| {
            let (s, d) = points[i % n];
            linear.solve(s, d).expect("solve").law.force
        });
        let pm = time(20000, |i| {
            let (s, d) = points[i % n];
            pair_model.force_tangents(s, d).force
        });
        let mut tabulated = None;
        let mut builds: Vec<f64> = (0..7)
            .map(|_| {
                let t = Instant::now();
                tabulated = Some(TabulatedMesh::new(law.clone(), load, TableSpec::default()).expect("table"));
                t.elapsed().as_secs_f64()
            })
            .collect();
        let tabulated = tabulated.expect("built");
        builds.sort_by(f64::total_cmp);
        let lookup = time(20000, |i| {
            let (s, d) = points[i % n];
            tabulated.force_tangents(s, d).expect("lookup").force
        });
        println!(
            "{:<11} {:>10.2}  {:>19.2}  {:>17.3}  {:>15.3}  {:>15.3}",
            mesh.name(),
            solve * 1e6,
            solve_linear * 1e6,
            lookup * 1e6,
            pm * 1e6,
            builds[3]
        );
    }
    let spec = TableSpec::default();
    println!(
        "table: {} positions per base pitch × {} approaches per flank, up to {}× the nominal load's approach",
        spec.positions, spec.approaches, spec.load_factor
    );
    example_on_its_bodies();
}

/// The example on its finite-element bodies: the set-up of both meshes'
/// tables (bodies and tables, cold), and the dynamics' steady state on each
/// contact model at three speeds (model built outside the timing): wall
/// time, steps, time per step and the deformable law's ratio per step.
fn example_on_its_bodies() {
    use planetwear::contact::deformable::set::DeformableSet;
    use planetwear::contact::ltca::SetModel;
    use planetwear::dynamics::equations::PlanetaryDynamics;
    let t = Instant::now();
    let flat = MeshFlanks::default();
    let set = Scene::example_2004_deformable().validate().expect("valid");
    DeformableSet::of_gear_set(&set, &flat, &flat).expect("tables");
    println!(
        "\nexample-2004-deformable: bodies and both tables built in {:.2} s (cold)",
        t.elapsed().as_secs_f64()
    );
    println!("speed [rpm]  fidelity              pair: s, steps, µs/step   deformable: s, steps, µs/step   ratio per step");
    for fidelity in [planetwear::scene::Fidelity::Torsional, planetwear::scene::Fidelity::TransverseTorsional]
    {
        for rpm in [2750.0, 6000.0, 9000.0] {
            let mut per_step = [0.0; 2];
            let mut line = format!("{rpm:>11.0}  {:<20}", format!("{fidelity:?}"));
            for (k, mut scene) in
                [Scene::example_2004(), Scene::example_2004_deformable()].into_iter().enumerate()
            {
                scene.dynamics.fidelity = fidelity;
                let (set, run) = scene.validate_with_run().expect("valid");
                let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
                let omega = rpm * std::f64::consts::PI / 30.0;
                let mut best = f64::INFINITY;
                let mut steps = 0;
                for _ in 0..3 {
                    let mut m = model.clone();
                    let t = Instant::now();
                    let r = planetwear::dynamics::response::steady_state(&mut m, &set, &run, omega, None)
                        .expect("steady state");
                    best = best.min(t.elapsed().as_secs_f64());
                    steps = r.stats.steps;
                }
                per_step[k] = best / steps as f64;
                line += &format!("   {best:>6.3} {steps:>7} {:>6.2}", per_step[k] * 1e6);
            }
            println!("{line}   {:>6.2}", per_step[1] / per_step[0]);
        }
    }
}
