//! The studies of the published example: `validate`, `calibrate` and
//! `work-precision`.

use crate::*;

pub(crate) fn validate_command(
    ValidateArgs { out, quick, full, scene, compare }: ValidateArgs,
) -> Result<()> {
    use planetwear::analysis::study::validation::{headline, validate, ValidationPlan};
    let s = load_scene(&scene)?;
    let set = validated(&s)?;
    let plan = if quick { ValidationPlan::quick() } else { ValidationPlan::full() };
    let plan = if full { plan.marching() } else { plan };
    // The compared scene is loaded and checked before the long run.
    let other_scene =
        compare.as_deref().map(|c| load_scene(c).and_then(|o| validated(&o).map(|_| o))).transpose()?;
    // The two validations side by side: each leaves a core idle on its
    // sequential stretches (a run's continuation, a marching sweep).
    let (v, other) = rayon::join(
        || validate(&s, &plan).map_err(|e| anyhow::anyhow!("validation of {scene}: {e}")),
        || match (&other_scene, &compare) {
            (Some(o), Some(name)) => {
                let plan =
                    ValidationPlan { attractor_check: false, wear_resolution_check: false, ..plan.clone() };
                validate(o, &plan)
                    .map(Some)
                    .map_err(|e| anyhow::anyhow!("validation of --compare {name}: {e}"))
            }
            _ => Ok(None),
        },
    );
    let (v, other) = (v?, other?);
    let command = format!(
        "planetwear validate --out {}{}{}{}{}",
        out.display(),
        if quick { " --quick" } else { "" },
        if full { " --full" } else { "" },
        if scene == "example-2004" { String::new() } else { format!(" --scene {scene}") },
        compare.as_deref().map(|c| format!(" --compare {c}")).unwrap_or_default()
    );
    planetwear::report::validation::write_report(&v, other.as_ref(), &out, set.sun().face_width, &command)?;
    for r in &v.rows {
        outln!("{:<9} {:<11} {:<40} ours {}", r.verdict.word(), r.evidence.word(), r.id, r.ours)?;
    }
    outln!("{} ({:.0} s); report {}", headline(&v.rows), v.seconds, out.join("VALIDATION.md").display())?;
    if let Some(o) = &other {
        for r in &o.rows {
            outln!("{:<9} {:<11} {:<40} {} {}", r.verdict.word(), r.evidence.word(), r.id, o.scene, r.ours)?;
        }
        outln!("{}: {} ({:.0} s)", o.scene, headline(&o.rows), o.seconds)?;
    }
    Ok(())
}

pub(crate) fn calibrate_command(CalibrateArgs { plan, out, show_plan, json }: CalibrateArgs) -> Result<()> {
    calibrate(&plan, out.as_deref(), show_plan, json)?;
    Ok(())
}

pub(crate) fn calibrate(plan: &str, out: Option<&Path>, show_plan: bool, json: bool) -> Result<()> {
    use planetwear::analysis::study::calibrate::{calibrate, CalibrationError, PlanFile};
    let (text, dir) = match Scene::builtin_plan(plan) {
        Some(t) => (t.to_string(), PathBuf::from(".")),
        None => {
            let path = Path::new(plan);
            if !path.is_file() {
                bail!("--plan {plan}: neither a built-in scene with a calibration (example-2004, example-2004-deformable) nor a plan file");
            }
            let text = read_text(path, planetwear::files::InputKind::Plan, "--plan")?;
            (text, path.parent().map(Path::to_path_buf).unwrap_or_default())
        }
    };
    if show_plan {
        out!("{text}")?;
        return Ok(());
    }
    let file = PlanFile::from_toml(&text).with_context(|| format!("--plan {plan}"))?;
    let base_name = if Scene::builtin(&file.base).is_some() {
        file.base.clone()
    } else {
        dir.join(&file.base).to_string_lossy().into_owned()
    };
    let base = load_scene(&base_name).with_context(|| format!("base = {} in --plan {plan}", file.base))?;
    let plan_value = file.plan(&base).with_context(|| format!("--plan {plan}"))?;
    match calibrate(&plan_value) {
        Ok(done) => {
            if json {
                outln!("{}", serde_json::to_string_pretty(&done.report)?)?;
            } else {
                print_calibration(&done.report, &file.base)?;
            }
            if let Some(path) = out {
                // A scene the tool writes is one it reads back.
                let text = done.scene.to_toml();
                planetwear::files::check_output_size(path, planetwear::files::InputKind::Scene, text.len())?;
                write_atomic(path, text.as_bytes())?;
                if !json {
                    outln!("wrote the calibrated scene {} to {}", done.scene.name, path.display())?;
                }
            }
            Ok(())
        }
        Err(CalibrationError::IllPosed { why, report }) => {
            if json {
                outln!("{}", serde_json::to_string_pretty(&report)?)?;
            } else {
                print_calibration(&report, &file.base)?;
            }
            bail!("ill-posed calibration, no scene written: {why}")
        }
        Err(e) => Err(e.into()),
    }
}

pub(crate) fn print_calibration(
    r: &planetwear::analysis::study::calibrate::Report,
    base: &str,
) -> Result<()> {
    outln!(
        "calibration of {} from {base}: {} iterations, {} evaluations, {} contact models, {:.1} s",
        r.name,
        r.iterations,
        r.evaluations,
        r.contact_models,
        r.seconds
    )?;
    outln!("targets:")?;
    outln!(
        "  {:<3} {:<44} {:>11} {:>8} {:>11} {:>11} {:>9}  met",
        "#",
        "measure",
        "target",
        "tol",
        "start",
        "reached",
        "residual"
    )?;
    for (i, t) in r.targets.iter().enumerate() {
        outln!(
            "  {:<3} {:<44} {:>11.4} {:>7.2}% {:>11.4} {:>11.4} {:>+8.3}%  {}",
            i + 1,
            t.target.measure.describe(),
            t.target.value,
            100.0 * t.target.tolerance,
            t.start,
            t.reached,
            100.0 * t.residual,
            if t.met { "yes" } else { "NO" }
        )?;
    }
    outln!("parameters (file units):")?;
    for (k, p) in r.parameters.iter().enumerate() {
        outln!(
            "  p{} {}: bounds [{:.4e}, {:.4e}], start {:.5e}, fitted {:.5e}, ratio {:.4}{}",
            k + 1,
            p.free.name(),
            p.free.min,
            p.free.max,
            p.start,
            p.fitted,
            p.ratio,
            p.at_bound.as_ref().map(|b| format!("  AT ITS {}", b.to_uppercase())).unwrap_or_default()
        )?;
    }
    out!("sensitivity ∂ln(target)/∂ln(parameter) at the fit:\n  {:<3}", "#")?;
    for k in 0..r.parameters.len() {
        out!(" {:>9}", format!("p{}", k + 1))?;
    }
    outln!()?;
    for (i, _) in r.targets.iter().enumerate() {
        out!("  {:<3}", i + 1)?;
        for p in &r.parameters {
            out!(" {:>+9.4}", p.sensitivity[i])?;
        }
        outln!()?;
    }
    outln!(
        "singular values of the scaled Jacobian: {}",
        r.singular_values.iter().map(|v| format!("{v:.3e}")).collect::<Vec<_>>().join(", ")
    )?;
    Ok(())
}

pub(crate) fn work_precision(out: &Path, quick: bool) -> Result<()> {
    use planetwear::analysis::accuracy::StudyPlan;
    use planetwear::model::lumped::Fidelity;
    use planetwear::report::accuracy::{
        example_points, operating_points, run_study, tables_markdown, write_study,
    };
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let (plan, mut points) = if quick {
        (StudyPlan::quick(), operating_points(Fidelity::Torsional)?)
    } else {
        (StudyPlan::full(), operating_points(Fidelity::Torsional)?)
    };
    if !quick {
        points.extend(operating_points(Fidelity::TransverseTorsional)?);
        for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
            points.extend(example_points(fidelity)?);
        }
    }
    let study = run_study(&points, &plan, None, |point, run| {
        if run == "reference checks" {
            eprintln!("{point}: reference done; running the methods");
        }
    })?;
    let context = serde_json::json!({
        "command": std::env::args().collect::<Vec<_>>().join(" "),
        "machine": planetwear::report::accuracy::machine(),
        "independent_integrator": "none in the CLI (cargo bench --bench work_precision adds DOP853)",
    });
    let files = write_study(&study, out, context)?;
    out!("{}", tables_markdown(&study))?;
    outln!("\nstudy took {:.1} s; {} files in {}", study.wall_seconds, files.len(), out.display())?;
    Ok(())
}

/// `planetwear steady-accuracy`: the steady response's E_h at the work-precision study's
/// operating points (at a node and mid-cell of its cache) and its error on speed ramps;
/// prints the tables and writes DIR/steady_accuracy.md and .json.
pub(crate) fn steady_accuracy(out: &Path, quick: bool) -> Result<()> {
    use planetwear::analysis::steady_accuracy::{point_error, ramp_errors};
    use planetwear::model::lumped::Fidelity;
    use planetwear::report::accuracy::operating_points;
    use planetwear::scene::units::rpm_to_rad_per_s;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mut points = operating_points(Fidelity::Torsional)?;
    if !quick {
        points.extend(operating_points(Fidelity::TransverseTorsional)?);
    }
    let started = std::time::Instant::now();
    let mut md = String::from(
        "| operating point | rpm | E_h at a node | E_h mid-cell | cache's estimate | separation sun, ring (reference) | \
         separation sun, ring (steady) | reference CPU s | steady first state s |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut rows = Vec::new();
    for p in &points {
        let e = point_error(p, 1e-9)?;
        let line = format!(
            "| {} | {:.0} | {:.1e} | {:.1e} | {} | {:.1} %, {:.1} % | {:.1} %, {:.1} % | {:.1} | {:.2} |",
            e.name,
            e.rpm,
            e.node,
            e.interpolated,
            if e.estimate.is_finite() { format!("{:.1e}", e.estimate) } else { "–".into() },
            100.0 * e.separation[0][0],
            100.0 * e.separation[0][1],
            100.0 * e.separation[1][0],
            100.0 * e.separation[1][1],
            e.seconds[0],
            e.seconds[1]
        );
        outln!("{line}")?;
        md.push_str(&line);
        md.push('\n');
        rows.push(e);
    }
    let mut ramps = Vec::new();
    if !quick {
        let scene = planetwear::scene::Scene::example_2004_stiff_pins();
        let mut balanced = scene.clone();
        balanced.dynamics.load_balance = true;
        let (set, run) = balanced.validate_with_run()?;
        let from_to = (rpm_to_rad_per_s(2000.0), rpm_to_rad_per_s(4000.0));
        ramps = ramp_errors(&set, &run, from_to, &[2.0, 0.5, 0.1, 0.02], 1e-3)?;
        md.push_str(
            "\n| ramp 2000 → 4000 rpm over | speed change per mesh cycle | largest error of F_max | mean error of F_max |\n|---|---|---|---|\n",
        );
        for r in &ramps {
            let line = format!(
                "| {} s | {:.1e} | {:.3} | {:.3} |",
                r.seconds, r.relative_change_per_cycle, r.max_force_error, r.mean_force_error
            );
            outln!("{line}")?;
            md.push_str(&line);
            md.push('\n');
        }
    }
    let wall = started.elapsed().as_secs_f64();
    md.push_str(&format!(
        "\n`planetwear steady-accuracy{}`: {wall:.0} s.\n",
        if quick { " --quick" } else { "" }
    ));
    outln!("{wall:.0} s")?;
    write_atomic(&out.join("steady_accuracy.md"), md.as_bytes())?;
    let json = serde_json::json!({ "points": rows, "ramps": ramps, "wall_seconds": wall });
    write_atomic(&out.join("steady_accuracy.json"), serde_json::to_string_pretty(&json)?.as_bytes())?;
    Ok(())
}
