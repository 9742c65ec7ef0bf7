//! The work-precision study (docs/ACCURACY.md) with the independent
//! confirmation of each reference by DOP853 of the `differential-equations`
//! crate. Run: `cargo bench --bench work_precision -- --out DIR` (default
//! target/work-precision; `--quick` for the reduced grid). Writes the same
//! files as `planetwear work-precision --out DIR` and prints the tables.

#[path = "../tests/support/independent.rs"]
mod independent;

use std::path::PathBuf;

use planetwear::analysis::accuracy::{IndependentIntegrator, StudyPlan};
use planetwear::model::lumped::Fidelity;
use planetwear::report::accuracy::{
    example_points, machine, operating_points, run_study, tables_markdown, write_study,
};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map_or_else(|| PathBuf::from("target/work-precision"), PathBuf::from);
    std::fs::create_dir_all(&out).expect("output directory");
    let plan = if quick { StudyPlan::quick() } else { StudyPlan::full() };
    let mut points = operating_points(Fidelity::Torsional).expect("operating points");
    if !quick {
        points.extend(operating_points(Fidelity::TransverseTorsional).expect("operating points"));
        for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
            points.extend(example_points(fidelity).expect("operating points"));
        }
    }
    let dop = independent::Dop853 { rtol: if quick { 1e-11 } else { 1e-12 } };
    let independent: &dyn IndependentIntegrator = &dop;
    let study = run_study(&points, &plan, Some(independent), |point, run| {
        if run == "independent" {
            eprintln!("{point}: reference confirmed; running the methods");
        }
    })
    .expect("study");
    let context = serde_json::json!({
        "command": format!(
            "cargo bench --bench work_precision -- {}",
            args[1..].iter().filter(|a| *a != "--bench").cloned().collect::<Vec<_>>().join(" ")
        ),
        "machine": machine(),
        "independent_integrator": dop.name(),
    });
    let files = write_study(&study, &out, context).expect("files");
    print!("{}", tables_markdown(&study));
    println!("\nstudy took {:.1} s; {} files in {}", study.wall_seconds, files.len(), out.display());
}
