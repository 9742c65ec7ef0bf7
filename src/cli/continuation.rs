//! `planetwear sweep --method continuation`: periodic steady states by
//! shooting, followed in speed by pseudo-arclength continuation
//! (docs/PERIODIC.md); the CSV and charts of the marching sweep plus
//! stability, branch segment and Floquet multipliers.

use planetwear::analysis::continuation::{continue_branch, BifurcationKind, ContinuationSettings, GapKind};
use planetwear::dynamics::periodic::{PeriodicProblem, ShootingSettings};
use planetwear::report::continuation::{continuation_csv, write_continuation_response};

use crate::*;

use planetwear::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};

pub(crate) fn sweep_continuation(
    SweepArgs {
        scene,
        wear_state,
        accept_state_difference,
        from,
        to,
        step,
        direction,
        out,
        histories,
        json,
        max_back,
        ..
    }: SweepArgs,
) -> Result<()> {
    let set = validated(&load_scene(&scene)?)?;
    // The grid check of the marching sweep: the same rules for the same flags.
    speed_grid(from, to, step)?;
    if step > to - from {
        bail!(
            "--step {step} rpm: a continuation's nominal step must be at most the speed range \
             (--from {from} to --to {to} rpm)"
        );
    }
    if !matches!(direction.as_str(), "up" | "down" | "both") {
        bail!("--direction {direction}: allowed are up, down, both");
    }
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let model = PlanetaryDynamics::new(
        &set,
        contact_model(&set, wear_state.as_deref(), accept_state_difference.as_deref())?,
    )?;
    let started = std::time::Instant::now();
    let mut problem = PeriodicProblem::new(model, ShootingSettings::default(), rpm_to_rad_per_s(from))?;
    let mut settings =
        ContinuationSettings::new(rpm_to_rad_per_s(from), rpm_to_rad_per_s(to), rpm_to_rad_per_s(step));
    if let Some(back) = max_back {
        if !(back.is_finite() && back > 0.0) {
            bail!("--max-back {back} rpm: must be a positive, finite speed");
        }
        settings.max_back = back / step;
    }
    let bar = progress_bar(((to - from).abs() / step).ceil() as u64 + 1);
    let branch = continue_branch(&mut problem, &settings, |p| {
        bar.set_position(((rad_per_s_to_rpm(p.orbit.speed) - from).abs() / step) as u64);
    })?;
    bar.finish_and_clear();
    let mut states = Vec::with_capacity(branch.points.len());
    for p in &branch.points {
        states.push(problem.steady_state(&p.orbit)?);
    }
    let wall = started.elapsed().as_secs_f64();
    let width_mm = set.sun().face_width * 1e3;
    let mut files = Vec::new();
    let path = out.join("sweep_continuation.csv");
    write_csv(&path, &continuation_csv(&branch, &states, width_mm))?;
    files.push(path);
    for s in states
        .iter()
        .filter(|s| histories.iter().any(|h| (h - rad_per_s_to_rpm(s.input_speed)).abs() <= 0.5 * step))
    {
        files.extend(write_steady_state(s, &set, &out)?);
    }
    files.extend(write_continuation_response(&branch, &states, &set, &out)?);
    let bifurcations: Vec<_> = branch
        .bifurcations
        .iter()
        .map(|b| {
            serde_json::json!({
                "kind": b.kind,
                "speed_rpm": rad_per_s_to_rpm(b.speed),
                "between_rpm": [rad_per_s_to_rpm(branch.points[b.between.0].orbit.speed), rad_per_s_to_rpm(branch.points[b.between.1].orbit.speed)],
                "multipliers": [b.multipliers.0, b.multipliers.1],
            })
        })
        .collect();
    let gaps: Vec<_> = branch
        .gaps
        .iter()
        .map(|g| {
            serde_json::json!({
                "kind": g.kind,
                "from_rpm": rad_per_s_to_rpm(g.from),
                "to_rpm": rad_per_s_to_rpm(g.to),
            })
        })
        .collect();
    let unstable: Vec<[f64; 2]> = unstable_ranges(&branch);
    let summary = serde_json::json!({
        "scene": set.name(),
        "method": "continuation",
        "points": branch.points.len(),
        "ended": branch.ended,
        "wall_time_s": wall,
        "flows": branch.flows,
        "internal_steps": branch.work.steps,
        "bifurcations": bifurcations,
        "gaps": gaps,
        "unstable_rpm": unstable,
        "files": files,
    });
    write_atomic(&out.join("sweep.json"), serde_json::to_string_pretty(&summary)?.as_bytes())?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&summary)?)?;
    } else {
        outln!(
            "continued {} periodic states from {from} to {to} rpm in {wall:.2} s ({} flows over one period, {} steps); {}; {} files in {}",
            branch.points.len(),
            branch.flows,
            branch.work.steps,
            branch.ended,
            files.len(),
            out.display()
        )?;
        for b in &branch.bifurcations {
            let kind = match b.kind {
                BifurcationKind::Fold => "fold",
                BifurcationKind::PeriodDoubling => "period doubling",
            };
            outln!(
                "  {kind} at {:.1} rpm (multipliers {:.3} and {:.3} either side)",
                rad_per_s_to_rpm(b.speed),
                b.multipliers.0,
                b.multipliers.1
            )?;
        }
        for [a, b] in &unstable {
            outln!("  unstable from {a:.1} to {b:.1} rpm")?;
        }
        for g in &branch.gaps {
            let how = match g.kind {
                GapKind::Leap => "leapt over a non-smooth point",
                GapKind::Restart => "restarted by marching",
            };
            outln!(
                "  not continued from {:.1} to {:.1} rpm: {how}",
                rad_per_s_to_rpm(g.from),
                rad_per_s_to_rpm(g.to)
            )?;
        }
    }
    Ok(())
}

/// Speed ranges [rpm] of the branch's unstable runs of points (each run's
/// lowest and highest speed).
fn unstable_ranges(branch: &planetwear::analysis::continuation::Branch) -> Vec<[f64; 2]> {
    let mut ranges = Vec::new();
    let mut current: Option<[f64; 2]> = None;
    for p in &branch.points {
        if p.after_gap {
            ranges.extend(current.take());
        }
        let rpm = rad_per_s_to_rpm(p.orbit.speed);
        match (&mut current, p.stable) {
            (Some(r), false) => {
                r[0] = r[0].min(rpm);
                r[1] = r[1].max(rpm);
            }
            (None, false) => current = Some([rpm, rpm]),
            (Some(r), true) => {
                ranges.push(*r);
                current = None;
            }
            (None, true) => {}
        }
    }
    ranges.extend(current);
    ranges
}
