//! `planetwear sweep --method continuation`: periodic steady states by
//! shooting or by harmonic balance (`--solver`), followed in speed by pseudo-arclength continuation
//! (docs/PERIODIC.md); the CSV and charts of the marching sweep plus
//! stability, branch segment and Floquet multipliers.

use planetwear::analysis::condensed_branch::CondensedBranch;
use planetwear::analysis::continuation::{
    branch_events, follow_branch, follow_joining, marching_jumps, nearest_event, on_one_stable_branch,
    BalanceBranch, BifurcationKind, Branch, BranchEvent, BranchPoint, BranchSolver, ContinuationSettings,
    CurvePoint, GapKind,
};
use planetwear::dynamics::periodic::{
    CondensedBalance, HarmonicBalance, HarmonicSettings, PeriodicProblem, ShootingSettings, Symmetry,
    CONDENSED_MAX_HARMONICS, MAX_RULE_HARMONICS,
};
use planetwear::dynamics::response::{sweep, Direction, SteadyState};
use planetwear::report::continuation::{
    continuation_csv, jumps_markdown, write_continuation_response, ContinuationRun, JumpRow,
};

/// A marching sweep's jump: F(rms) of planet 1's sun–planet mesh changing by
/// more than 15 % from one speed to the next.
const JUMP_RATIO: f64 = 1.15;

/// How close (relative) both ends of a marching step must lie to one stable
/// stretch of a continued branch to count as a steep flank of it, not a
/// jump: the marching sweep's own error (E_h up to 2.9e-3, docs/ACCURACY.md)
/// with a margin for its run-in.
const FLANK_TOLERANCE: f64 = 0.05;

use crate::*;

use planetwear::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

pub(crate) fn sweep_continuation(
    SweepArgs {
        set: SetArgs { scene, wear_state, accept: AcceptArgs { accept_state_difference } },
        from,
        to,
        step,
        direction,
        out,
        histories,
        json,
        max_back,
        against_march,
        solver,
        join,
        broken_symmetry,
        ..
    }: SweepArgs,
) -> Result<()> {
    let solver_name = solver_name(solver.as_deref(), broken_symmetry)?;
    let (set, run_settings) = validated_with_run(&load_scene(&scene)?)?;
    // The grid of the marching sweep: the same rules for the same flags (and
    // the grid of `--against-march`).
    let grid = speed_grid(from, to, step)?;
    let back = check_continuation((from, to, step), &direction, join, max_back)?;
    let direction = direction.as_str();
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let model = PlanetaryDynamics::new(
        &set,
        contact_model(&set, wear_state.as_deref(), accept_state_difference.as_deref())?,
    )?;
    // One run per direction: up from --from to --to, down from --to to --from
    // (the continuation's counterpart of the marching sweep's two directions).
    let ends: Vec<(&str, f64, f64)> = [("up", from, to), ("down", to, from)]
        .into_iter()
        .filter(|(d, _, _)| direction == "both" || direction == *d)
        .collect();
    let started = std::time::Instant::now();
    let per_run = ((to - from).abs() / step).ceil() as u64 + 1;
    let bar = progress_bar(per_run * ends.len() as u64);
    let done: Vec<AtomicU64> = ends.iter().map(|_| 0.into()).collect();
    let follow = Follow {
        model: &model,
        step,
        back,
        solver: solver_name,
        broken_symmetry,
        per_run,
        bar: &bar,
        done: &done,
    };
    let runs = if join {
        let up = follow.run(0, ends[0], None)?;
        let down = follow.run(1, ends[1], Some(&up.branch))?;
        vec![up, down]
    } else {
        ends.par_iter().enumerate().map(|(k, &end)| follow.run(k, end, None)).collect::<Result<Vec<Run>>>()?
    };
    bar.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();
    let mut files = write_runs(&runs, &set, &out, &histories, step)?;
    let jumps = if against_march {
        let rows = march_jumps(&runs, &model, &set, &run_settings, &grid)?;
        let path = out.join("jumps.md");
        write_atomic(&path, jumps_markdown(&rows, JUMP_RATIO, step).as_bytes())?;
        files.push(path);
        Some(rows)
    } else {
        None
    };
    let summaries: Vec<serde_json::Value> = runs.iter().map(Run::summary).collect();
    let summary = serde_json::json!({
        "scene": set.name(),
        "method": "continuation",
        "solver": solver_name,
        "points": runs.iter().map(|r| r.branch.points.len()).sum::<usize>(),
        "wall_time_s": wall,
        "flows": runs.iter().map(|r| r.branch.flows).sum::<usize>(),
        "internal_steps": runs.iter().map(|r| r.branch.work.steps).sum::<u64>(),
        "runs": summaries,
        "jumps": jumps.as_ref().map(|rows| rows.iter().map(JumpRow::json).collect::<Vec<_>>()),
        "files": files,
    });
    if write_sweep_summary(&out, &summary, json)? {
        return Ok(());
    }
    outln!(
        "continuation from {from} to {to} rpm in {wall:.2} s; {} files in {}",
        files.len(),
        out.display()
    )?;
    for row in jumps.iter().flatten() {
        outln!("{}", row.line(step))?;
    }
    for r in &runs {
        print_run(r, (from, to), solver_name)?;
    }
    Ok(())
}

/// The `--solver` by its name (shooting by default); `--broken-symmetry` only with the
/// condensed balance.
fn solver_name(solver: Option<&str>, broken_symmetry: bool) -> Result<&'static str> {
    let solver_name = match solver {
        None | Some("shooting") => "shooting",
        Some("harmonic-balance") => "harmonic-balance",
        Some("condensed") => "condensed",
        Some(other) => bail!("--solver {other}: allowed are shooting, harmonic-balance, condensed"),
    };
    if broken_symmetry && solver_name != "condensed" {
        bail!("--broken-symmetry applies to --solver condensed only (its restarts can leave the planets' symmetry)");
    }
    Ok(solver_name)
}

/// The continuation's flags: a nominal step within the speed range (`speeds`: --from,
/// --to, --step [rpm]), a known --direction, --join only with both directions, a positive
/// --max-back. The furthest run-back in nominal steps, when given.
fn check_continuation(
    (from, to, step): (f64, f64, f64),
    direction: &str,
    join: bool,
    max_back: Option<f64>,
) -> Result<Option<f64>> {
    if step > to - from {
        bail!(
            "--step {step} rpm: a continuation's nominal step must be at most the speed range \
             (--from {from} to --to {to} rpm)"
        );
    }
    if !matches!(direction, "up" | "down" | "both") {
        bail!("--direction {direction}: allowed are up, down, both");
    }
    if join && direction != "both" {
        bail!("--join {direction}: --join needs both directions (--direction both), the down run joining the up run");
    }
    Ok(match max_back {
        Some(back) if !(back.is_finite() && back > 0.0) => {
            bail!("--max-back {back} rpm: must be a positive, finite speed")
        }
        Some(back) => Some(back / step),
        None => None,
    })
}

/// What every direction's run shares: the model, the nominal step [rpm] and the furthest
/// run-back in nominal steps, the solver, and the progress of all runs.
struct Follow<'a> {
    model: &'a PlanetaryDynamics,
    step: f64,
    back: Option<f64>,
    solver: &'static str,
    broken_symmetry: bool,
    /// Nominal steps of one run, the bar over all runs and each run's steps done.
    per_run: u64,
    bar: &'a indicatif::ProgressBar,
    done: &'a [AtomicU64],
}

/// A run's branch, the steady state of each of its points, and the highest speed [rpm]
/// where the balance's rule's H was held.
type Followed = (Branch, Vec<SteadyState>, Option<f64>);

impl Follow<'_> {
    /// Run `k`, named `name`, from `a` to `b` [rpm] (joining `other`'s branch when given).
    fn run(&self, k: usize, (name, a, b): (&'static str, f64, f64), other: Option<&Branch>) -> Result<Run> {
        let step = self.step;
        let problem =
            PeriodicProblem::new(self.model.clone(), ShootingSettings::default(), rpm_to_rad_per_s(a))?;
        let mut settings =
            ContinuationSettings::new(rpm_to_rad_per_s(a), rpm_to_rad_per_s(b), rpm_to_rad_per_s(step));
        if let Some(back) = self.back {
            settings.max_back = back;
        }
        let (done, bar, per_run) = (self.done, self.bar, self.per_run);
        let progress = |p: &BranchPoint| {
            let at = ((rad_per_s_to_rpm(p.orbit.speed) - a).abs() / step) as u64;
            done[k].store(at.min(per_run), Ordering::Relaxed);
            bar.set_position(done.iter().map(|d| d.load(Ordering::Relaxed)).sum());
        };
        let (branch, states, held) = match self.solver {
            "condensed" => condensed_run(problem, &settings, other, progress, self.broken_symmetry)?,
            "harmonic-balance" => balance_run(problem, &settings, other, progress)?,
            _ => shooting_run(problem, &settings, other, progress)?,
        };
        Ok(Run { direction: name, branch, states, held })
    }
}

/// The branch `solver` follows, joining `other`'s branch when given.
fn follow_with<S: BranchSolver>(
    solver: &mut S,
    settings: &ContinuationSettings,
    other: Option<&Branch>,
    progress: impl FnMut(&BranchPoint),
) -> Result<Branch> {
    Ok(match other {
        Some(o) => follow_joining(solver, settings, o, progress)?,
        None => follow_branch(solver, settings, progress)?,
    })
}

/// A run by the condensed balance (with `broken_symmetry`, along a branch that breaks the
/// planets' symmetry where a restart lands on one).
fn condensed_run(
    problem: PeriodicProblem,
    settings: &ContinuationSettings,
    other: Option<&Branch>,
    progress: impl FnMut(&BranchPoint),
    broken_symmetry: bool,
) -> Result<Followed> {
    let hb = HarmonicBalance::new(problem, HarmonicSettings::default())?;
    let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
    let mut solver = CondensedBranch::new(&mut cb);
    solver.follow_broken_symmetry(broken_symmetry);
    let branch = follow_with(&mut solver, settings, other, progress)?;
    let orbits = std::mem::take(&mut solver.orbits);
    let (mut states, mut held) = (Vec::new(), None);
    for orbit in &orbits {
        states.push(cb.balance().steady_state(orbit)?);
        if orbit.harmonics == CONDENSED_MAX_HARMONICS
            && cb.balance().rule_harmonics(orbit.speed) > CONDENSED_MAX_HARMONICS
        {
            held = Some(held.unwrap_or(0.0_f64).max(rad_per_s_to_rpm(orbit.speed)));
        }
    }
    Ok((branch, states, held))
}

/// A run by the full harmonic balance.
fn balance_run(
    problem: PeriodicProblem,
    settings: &ContinuationSettings,
    other: Option<&Branch>,
    progress: impl FnMut(&BranchPoint),
) -> Result<Followed> {
    let mut hb = HarmonicBalance::new(problem, HarmonicSettings::default())?;
    let mut solver = BalanceBranch::new(&mut hb);
    let branch = follow_with(&mut solver, settings, other, progress)?;
    let orbits = std::mem::take(&mut solver.orbits);
    let (mut states, mut held) = (Vec::new(), None);
    for orbit in &orbits {
        states.push(hb.steady_state(orbit)?);
        // Only the cap: elsewhere a point may keep more harmonics than the rule at
        // its own speed (the rule's at the lowest speed its step could reach).
        if orbit.harmonics == MAX_RULE_HARMONICS && hb.rule_harmonics(orbit.speed) > MAX_RULE_HARMONICS {
            held = Some(held.unwrap_or(0.0_f64).max(rad_per_s_to_rpm(orbit.speed)));
        }
    }
    Ok((branch, states, held))
}

/// A run by shooting.
fn shooting_run(
    mut problem: PeriodicProblem,
    settings: &ContinuationSettings,
    other: Option<&Branch>,
    progress: impl FnMut(&BranchPoint),
) -> Result<Followed> {
    let branch = follow_with(&mut problem, settings, other, progress)?;
    let mut states = Vec::new();
    for p in &branch.points {
        states.push(problem.steady_state(&p.orbit)?);
    }
    Ok((branch, states, None))
}

/// The runs' CSV, the time histories of the points within half a step of a speed in
/// `histories` [rpm], and the charts of the forced responses, written into `out`: the
/// files written.
fn write_runs(runs: &[Run], set: &GearSet, out: &Path, histories: &[f64], step: f64) -> Result<Vec<PathBuf>> {
    let width_mm = set.sun().face_width * 1e3;
    let mut files = Vec::new();
    let path = out.join("sweep_continuation.csv");
    let tables: Vec<ContinuationRun<'_>> = runs.iter().map(Run::table).collect();
    write_csv(&path, &continuation_csv(&tables, width_mm))?;
    files.push(path);
    for s in runs
        .iter()
        .flat_map(|r| &r.states)
        .filter(|s| histories.iter().any(|h| (h - rad_per_s_to_rpm(s.input_speed)).abs() <= 0.5 * step))
    {
        files.extend(write_steady_state(s, set, out)?);
    }
    files.extend(write_continuation_response(&tables, set, out)?);
    Ok(files)
}

/// `--against-march`: the marching sweep up and down on the same `grid` [rpm], each of its
/// jumps set beside the nearest event of the runs and whether it lies on a steep flank of
/// one of their stable stretches.
fn march_jumps(
    runs: &[Run],
    model: &PlanetaryDynamics,
    set: &GearSet,
    run_settings: &RunSettings,
    grid: &[f64],
) -> Result<Vec<JumpRow<'static>>> {
    let width_mm = set.sun().face_width * 1e3;
    let events: Vec<BranchEvent> = runs.iter().flat_map(|r| branch_events(&r.branch)).collect();
    let curves: Vec<Vec<CurvePoint>> = runs
        .iter()
        .map(|r| {
            r.branch
                .points
                .iter()
                .zip(&r.states)
                .map(|(p, s)| CurvePoint {
                    speed: p.orbit.speed,
                    value: s.meshes[0].harmonics.rms / width_mm,
                    stable: p.stable,
                    after_gap: p.after_gap,
                })
                .collect()
        })
        .collect();
    let march = |d: Direction| -> Result<Vec<JumpRow<'static>>> {
        let mut m = model.clone();
        let mut speeds: Vec<f64> = grid.iter().copied().map(rpm_to_rad_per_s).collect();
        if d == Direction::Down {
            speeds.reverse();
        }
        let sw = sweep(set, run_settings, &mut m, d, &speeds, &[], |_| {})?;
        let values: Vec<f64> = sw.points.iter().map(|p| p.meshes[0].harmonics.rms / width_mm).collect();
        let name = if d == Direction::Up { "up" } else { "down" };
        Ok(marching_jumps(&speeds, &values, JUMP_RATIO)
            .into_iter()
            .map(|jump| JumpRow {
                direction: name,
                jump,
                nearest: nearest_event(&jump, &events),
                on_one_branch: curves.iter().any(|c| on_one_stable_branch(c, &jump, FLANK_TOLERANCE)),
            })
            .collect())
    };
    let (up, down) = rayon::join(|| march(Direction::Up), || march(Direction::Down));
    Ok(up?.into_iter().chain(down?).collect())
}

/// One run's lines of the text report (`range`: --from and --to [rpm]): its points and
/// how it ended, its folds and period doublings, unstable stretches and gaps.
fn print_run(r: &Run, (from, to): (f64, f64), solver_name: &str) -> Result<()> {
    let (a, b) = if r.direction == "up" { (from, to) } else { (to, from) };
    let branch = &r.branch;
    if solver_name != "shooting" {
        outln!(
            "{}: {} periodic states from {a} to {b} rpm by harmonic balance{} ({} force evaluations; \
             {} flows over one period in its restarts{}); {}",
            r.direction,
            branch.points.len(),
            if solver_name == "condensed" { " condensed onto the contact coordinates" } else { "" },
            branch.work.rhs_evaluations,
            branch.flows,
            r.held.map_or(String::new(), |rpm| format!(
                "; the rule's H held at {} up to {rpm:.1} rpm: docs/PERIODIC.md §2",
                if solver_name == "condensed" { CONDENSED_MAX_HARMONICS } else { MAX_RULE_HARMONICS }
            )),
            branch.ended,
        )?;
    } else {
        outln!(
            "{}: {} periodic states from {a} to {b} rpm ({} flows over one period, {} steps); {}",
            r.direction,
            branch.points.len(),
            branch.flows,
            branch.work.steps,
            branch.ended,
        )?;
    }
    for b in &branch.bifurcations {
        let kind = match b.kind {
            BifurcationKind::Fold => "fold",
            BifurcationKind::PeriodDoubling => "period doubling",
        };
        // NaN: the point has no real multiplier (a fold at a grazing corner).
        let mu = |m: f64| if m.is_nan() { "none real".to_string() } else { format!("{m:.3}") };
        outln!(
            "  {kind} at {:.1} rpm (multipliers {} and {} either side)",
            rad_per_s_to_rpm(b.speed),
            mu(b.multipliers.0),
            mu(b.multipliers.1)
        )?;
    }
    for [a, b] in &unstable_ranges(branch) {
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
    Ok(())
}

/// One direction's continuation and the measures of its points.
struct Run {
    direction: &'static str,
    branch: Branch,
    states: Vec<SteadyState>,
    /// The highest speed [rpm] of the balance's points whose rule's H
    /// `MAX_RULE_HARMONICS` held.
    held: Option<f64>,
}

impl Run {
    fn table(&self) -> ContinuationRun<'_> {
        ContinuationRun { direction: self.direction, branch: &self.branch, states: &self.states }
    }

    fn summary(&self) -> serde_json::Value {
        let branch = &self.branch;
        let rpm = |i: usize| rad_per_s_to_rpm(branch.points[i].orbit.speed);
        let bifurcations: Vec<_> = branch
            .bifurcations
            .iter()
            .map(|b| {
                serde_json::json!({
                    "kind": b.kind,
                    "speed_rpm": rad_per_s_to_rpm(b.speed),
                    "between_rpm": [rpm(b.between.0), rpm(b.between.1)],
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
        serde_json::json!({
            "direction": self.direction,
            "points": branch.points.len(),
            "ended": branch.ended,
            "flows": branch.flows,
            "internal_steps": branch.work.steps,
            "bifurcations": bifurcations,
            "gaps": gaps,
            "unstable_rpm": unstable_ranges(branch),
            "rule_harmonics_held_up_to_rpm": self.held,
        })
    }
}

/// Speed ranges [rpm] of the branch's unstable runs of points (each run's
/// lowest and highest speed).
fn unstable_ranges(branch: &Branch) -> Vec<[f64; 2]> {
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
