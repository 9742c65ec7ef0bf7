//! The dense linear algebra of the model, nalgebra (the library's solver)
//! against faer, on the project's own matrices: the symmetric modal problem
//! M^-1/2 K M^-1/2 of `analysis::modes` (the calibration solves it hundreds
//! of times per fit) and an LU solve of a Newton-like matrix of the same
//! size (generalized-α's dense path). The sets: the built-in example's
//! lumped model (transverse–torsional and torsional) and the lumped
//! benchmark scene with 3 to 64 planets. Each row also checks that both
//! libraries give the same eigenvalues (largest relative difference).
//! faer runs sequentially (`Par::Seq`), as the library's callers do.
//!
//! Run: `cargo bench --bench linear_algebra`; docs/PERFORMANCE.md records
//! the figures and the decision drawn from them.

use std::time::Instant;

use faer::linalg::solvers::Solve;
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use planetwear::analysis::modes::modal_matrix;
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::scene::lumped::LumpedScene;
use planetwear::scene::{Fidelity, Scene};

/// Median time per call [s] of `f` over `reps` calls, in 7 rounds.
fn time(reps: usize, mut f: impl FnMut() -> f64) -> f64 {
    let mut sink = 0.0;
    let mut rounds: Vec<f64> = (0..7)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..reps {
                sink += f();
            }
            t.elapsed().as_secs_f64() / reps as f64
        })
        .collect();
    rounds.sort_by(f64::total_cmp);
    assert!(sink.is_finite());
    rounds[3]
}

fn row(name: &str, a: &DMatrix<f64>) {
    let n = a.nrows();
    let reps = (200_000 / (n * n)).clamp(3, 2000);
    let fa = faer::Mat::<f64>::from_fn(n, n, |i, j| a[(i, j)]);
    // The same eigenvalues from both (sorted), relative to the largest.
    let mut en: Vec<f64> = SymmetricEigen::new(a.clone()).eigenvalues.iter().copied().collect();
    let ef = fa.self_adjoint_eigen(faer::Side::Lower).expect("faer eigendecomposition");
    let mut ef: Vec<f64> = (0..n).map(|i| ef.S()[i]).collect();
    en.sort_by(f64::total_cmp);
    ef.sort_by(f64::total_cmp);
    let scale = en.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = en.iter().zip(&ef).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale;
    let eig_n = time(reps, || SymmetricEigen::new(a.clone()).eigenvalues[0]);
    let eig_f = time(reps, || fa.self_adjoint_eigen(faer::Side::Lower).map(|e| e.S()[0]).unwrap_or(f64::NAN));
    // A Newton-like matrix: I + h² A (well conditioned, unsymmetric pivoting
    // as in the dense generalized-α path).
    let h2 = 1.0 / scale;
    let j = DMatrix::from_fn(n, n, |r, c| if r == c { 1.0 } else { 0.0 } + h2 * a[(r, c)]);
    let fj = faer::Mat::<f64>::from_fn(n, n, |r, c| j[(r, c)]);
    let b = DVector::from_fn(n, |i, _| 1.0 + i as f64);
    let fb = faer::Mat::<f64>::from_fn(n, 1, |i, _| 1.0 + i as f64);
    let lu_n = time(reps, || j.clone().lu().solve(&b).map_or(f64::NAN, |x| x[0]));
    let lu_f = time(reps, || fj.partial_piv_lu().solve(&fb)[(0, 0)]);
    println!(
        "| {name} | {n} | {:.1} | {:.1} | {:.2} | {:.2} | {:.2} | {:.2} | {diff:.1e} |",
        eig_n * 1e6,
        eig_f * 1e6,
        eig_f / eig_n,
        lu_n * 1e6,
        lu_f * 1e6,
        lu_f / lu_n,
    );
}

fn main() {
    faer::set_global_parallelism(faer::Par::Seq);
    println!("| set | n | eig nalgebra [µs] | eig faer [µs] | faer/nalgebra | LU+solve nalgebra [µs] | LU+solve faer [µs] | faer/nalgebra | eigenvalues differ |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
        let mut scene = Scene::example_2004_stiff_pins();
        scene.dynamics.fidelity = fidelity;
        let set = scene.validate().expect("the example is valid");
        let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
        let name = format!(
            "example-2004-stiff-pins, {}",
            if fidelity == Fidelity::Torsional { "torsional" } else { "transverse–torsional" }
        );
        row(&name, &modal_matrix(&model.lumped));
    }
    for planets in [3u32, 8, 16, 32, 64] {
        let mut scene = LumpedScene::lumped_benchmark();
        scene.lumped.planet.count = planets;
        // The scene's own rule allows at most 32 planets; the matrix of 64
        // shows where the trend goes.
        let set = if planets <= 32 {
            scene.validate().expect("valid lumped scene")
        } else {
            scene.lumped.planet.count = 32;
            let mut s = scene.validate().expect("valid lumped scene");
            s.planet_angles = (0..planets)
                .map(|i| 2.0 * std::f64::consts::PI * f64::from(i) / f64::from(planets))
                .collect();
            s
        };
        row(&format!("lumped-benchmark, {planets} planets"), &modal_matrix(&set));
    }
}
