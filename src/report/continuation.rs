//! Reports of a continuation sweep: the sweep CSV's columns plus each
//! point's stability, branch segment and Floquet multipliers, and the
//! forced-response charts with the unstable parts dashed and the folds and
//! period doublings marked.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::plot::{write_chart, Chart, PlotError, Series, SeriesStyle};
use super::sweep::sweep_csv;
use crate::analysis::continuation::{BifurcationKind, Branch, BranchEvent, EventKind, Jump};
use crate::dynamics::response::{Direction, SteadyState, Sweep};
use crate::model::gear::GearSet;
use crate::scene::units::rad_per_s_to_rpm;

/// One run of a continuation (`up` from the first speed to the last,
/// `down` back) with its points' measures, in the branch's order.
#[derive(Clone, Copy, Debug)]
pub struct ContinuationRun<'a> {
    /// `up` or `down`.
    pub direction: &'a str,
    /// The branch.
    pub branch: &'a Branch,
    /// Each branch point's measures.
    pub states: &'a [SteadyState],
}

/// The CSV of a continuation's runs, one after another: the columns of
/// [`sweep_csv`] (the direction column says where the branch runs: `up`
/// towards higher speed, `down` towards lower), then `stable` (1 or 0),
/// `branch` (the run's segment between folds and gaps, 0 first),
/// `max_abs_multiplier`, the real and imaginary parts of the largest
/// multiplier, and `run` (the run's direction: `up` from the first speed,
/// `down` from the last).
pub fn continuation_csv(runs: &[ContinuationRun<'_>], width_mm: f64) -> String {
    let mut out = String::new();
    for (k, run) in runs.iter().enumerate() {
        let rows = Sweep { direction: Direction::Up, points: run.states.to_vec() };
        let base = sweep_csv(&rows, width_mm);
        for (i, line) in base.lines().enumerate() {
            if i == 0 {
                if k == 0 {
                    let _ = writeln!(
                        out,
                        "{line},stable,branch,max_abs_multiplier,multiplier_1_re,multiplier_1_im,run"
                    );
                }
                continue;
            }
            let Some(p) = run.branch.points.get(i - 1) else { continue };
            let direction = if p.speed_slope >= 0.0 { "up" } else { "down" };
            let rest = line.split_once(',').map_or("", |(_, r)| r);
            let mu = p.orbit.multipliers.first().map_or((f64::NAN, f64::NAN), |m| (m.re, m.im));
            let _ = writeln!(
                out,
                "{direction},{rest},{},{},{},{},{},{}",
                u8::from(p.stable),
                p.segment,
                p.orbit.largest_multiplier(),
                mu.0,
                mu.1,
                run.direction
            );
        }
    }
    out
}

/// The chart's x values and the stable and unstable pieces of `y` (NaN
/// where a piece has no point): a stable piece ends at the first unstable
/// point after it, so solid and dashed parts join, except across a gap
/// (`Branch::gaps`), before whose first point both pieces get a break (an
/// extra x value, the gap's far speed, with NaN in both).
fn pieces(branch: &Branch, speeds: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let gap_before = |i: usize| i > 0 && branch.points.get(i).is_some_and(|p| p.after_gap);
    let (mut x, mut stable, mut unstable) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..y.len() {
        if gap_before(i) {
            x.push(speeds[i]);
            stable.push(f64::NAN);
            unstable.push(f64::NAN);
        }
        let joins = |want: bool| {
            let is = |j: usize| branch.points.get(j).is_some_and(|p| p.stable == want);
            is(i) || (i > 0 && is(i - 1) && !gap_before(i))
        };
        x.push(speeds[i]);
        stable.push(if joins(true) { y[i] } else { f64::NAN });
        unstable.push(if joins(false) { y[i] } else { f64::NAN });
    }
    (x, stable, unstable)
}

/// Forced-response charts (F^(rms) of planet 1's sun–planet and ring–planet
/// mesh against speed) of a continuation's runs: stable points a solid line,
/// unstable ones dashed, folds and period doublings as markers; the runs are
/// drawn one after another, not joined.
pub fn write_continuation_response(
    runs: &[ContinuationRun<'_>],
    set: &GearSet,
    dir: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    let width_mm = set.sun().face_width * 1e3;
    let mut files = Vec::new();
    if runs.iter().all(|r| r.states.is_empty()) {
        return Ok(files);
    }
    let any = |want: bool| runs.iter().any(|r| r.branch.points.iter().any(|p| p.stable == want));
    for (mesh_index, name) in [(0usize, "sun_planet"), (1usize, "ring_planet")] {
        let (mut rpm, mut stable, mut unstable) = (Vec::new(), Vec::new(), Vec::new());
        let mut markers = [(Vec::new(), Vec::new()), (Vec::new(), Vec::new())];
        for run in runs {
            let speeds: Vec<f64> = run.states.iter().map(|s| rad_per_s_to_rpm(s.input_speed)).collect();
            let y: Vec<f64> =
                run.states.iter().map(|s| s.meshes[mesh_index].harmonics.rms / width_mm).collect();
            let (x, s, u) = pieces(run.branch, &speeds, &y);
            // A break between runs.
            if let Some(first) = x.first().filter(|_| !rpm.is_empty()) {
                rpm.push(*first);
                stable.push(f64::NAN);
                unstable.push(f64::NAN);
            }
            rpm.extend(x);
            stable.extend(s);
            unstable.extend(u);
            for b in &run.branch.bifurcations {
                let (i, j) = b.between;
                let (Some(a), Some(c)) = (y.get(i), y.get(j)) else { continue };
                let k = usize::from(b.kind == BifurcationKind::PeriodDoubling);
                markers[k].0.push(rad_per_s_to_rpm(b.speed));
                markers[k].1.push(0.5 * (a + c));
            }
        }
        let mut series = Vec::new();
        if any(true) {
            series.push(Series::new("stable", rpm.clone(), stable).with_style(SeriesStyle::Broken));
        }
        if any(false) {
            series.push(Series::new("unstable", rpm.clone(), unstable).with_style(SeriesStyle::Dashed));
        }
        for ((bx, by), label) in markers.into_iter().zip(["fold", "period doubling"]) {
            if !bx.is_empty() {
                series.push(Series::new(label, bx, by).with_style(SeriesStyle::Points));
            }
        }
        files.extend(write_chart(
            &Chart {
                title: format!("{name} F(rms), planet 1, continuation (unstable dashed)"),
                x_label: "input speed (rpm)".into(),
                y_label: "F(rms) of mesh harmonics 1-6 (N/mm)".into(),
                series,
                vlines: vec![],
            },
            &dir.join(format!("forced_response_{name}_continuation")),
        )?);
    }
    Ok(files)
}

/// One jump of a marching sweep beside the nearest event of the continuation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JumpRow<'a> {
    /// The marching sweep's direction: `up` or `down`.
    pub direction: &'a str,
    /// The jump (speeds in rad/s, F(rms) in N/mm).
    pub jump: Jump,
    /// The nearest fold, period doubling or change of stability, and its
    /// distance from the jump's speed step [rad/s] (0 inside it).
    pub nearest: Option<(BranchEvent, f64)>,
    /// Both ends lie on one stable stretch of a continued branch: a steep
    /// flank, not a jump between branches.
    pub on_one_branch: bool,
}

fn event_name(kind: EventKind) -> &'static str {
    match kind {
        EventKind::Fold => "fold",
        EventKind::PeriodDoubling => "period doubling",
        EventKind::TurnsStable => "turns stable",
        EventKind::TurnsUnstable => "turns unstable",
    }
}

impl JumpRow<'_> {
    /// The verdict: `within the step`, `N rpm outside the step`, or `no event`.
    pub fn verdict(&self) -> String {
        if self.on_one_branch {
            return "no jump: both ends on one stable continued branch".into();
        }
        match self.nearest {
            Some((_, d)) if d <= 0.0 => "within the step".into(),
            Some((_, d)) => format!("{:.1} rpm outside the step", rad_per_s_to_rpm(d)),
            None => "no event".into(),
        }
    }

    /// One line for the command line (`step` the sweep's step in rpm).
    pub fn line(&self, step: f64) -> String {
        let j = &self.jump;
        let what = if self.on_one_branch {
            self.verdict()
        } else {
            let event = self
                .nearest
                .map_or("no fold, period doubling or change of stability".to_string(), |(e, _)| {
                    format!("{} at {:.1} rpm", event_name(e.kind), rad_per_s_to_rpm(e.speed))
                });
            format!("jump; {event}, {}", self.verdict())
        };
        format!(
            "  marching {} {:.0} -> {:.0} rpm ({:.0} -> {:.0} N/mm, step {step} rpm): {what}",
            self.direction,
            rad_per_s_to_rpm(j.from),
            rad_per_s_to_rpm(j.to),
            j.before,
            j.after,
        )
    }

    /// The row as JSON (speeds in rpm).
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "direction": self.direction,
            "from_rpm": rad_per_s_to_rpm(self.jump.from),
            "to_rpm": rad_per_s_to_rpm(self.jump.to),
            "before_n_per_mm": self.jump.before,
            "after_n_per_mm": self.jump.after,
            "event": self.nearest.map(|(e, _)| event_name(e.kind)),
            "event_rpm": self.nearest.map(|(e, _)| rad_per_s_to_rpm(e.speed)),
            "outside_rpm": self.nearest.map(|(_, d)| rad_per_s_to_rpm(d)),
            "on_one_stable_branch": self.on_one_branch,
        })
    }
}

/// The Markdown table of a marching sweep's jumps beside the continuation's
/// events (`ratio` the jump threshold, `step` the grid step in rpm).
pub fn jumps_markdown(rows: &[JumpRow<'_>], ratio: f64, step: f64) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Marching sweep's jumps beside the continuation\n\n\
         A jump: F(rms) of planet 1's sun–planet mesh changing by more than a factor {ratio} from one \
         speed to the next ({step} rpm steps). Beside each, the continuation's nearest fold, period \
         doubling or change of stability (either run), and how far it lies from the jump's speed step. \
         A change whose two ends lie on one stable stretch of a continued branch (to 5 %) is a \
         steep flank, not a jump. A jump with no event near it is one between attractors the \
         continuation does not follow (not periodic in one mesh cycle, or of twice the period).\n"
    );
    let _ = writeln!(out, "| sweep | step [rpm] | F(rms) [N/mm] | nearest event | at [rpm] | verdict |");
    let _ = writeln!(out, "|---|---|---|---|---|---|");
    for r in rows {
        let j = &r.jump;
        let (name, at) = match r.nearest {
            Some((e, _)) if !r.on_one_branch => {
                (event_name(e.kind), format!("{:.1}", rad_per_s_to_rpm(e.speed)))
            }
            _ => ("—", "—".to_string()),
        };
        let _ = writeln!(
            out,
            "| {} | {:.0} → {:.0} | {:.0} → {:.0} | {name} | {at} | {} |",
            r.direction,
            rad_per_s_to_rpm(j.from),
            rad_per_s_to_rpm(j.to),
            j.before,
            j.after,
            r.verdict()
        );
    }
    if rows.is_empty() {
        let _ = writeln!(out, "\nThe marching sweeps do not jump.");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::continuation::test_point as point;
    use crate::dynamics::response::Work;

    #[test]
    fn a_gap_breaks_both_pieces_and_a_change_of_stability_joins_them() {
        let branch = Branch {
            points: vec![
                point(1.0, true, false),
                point(2.0, true, false),
                point(5.0, true, true),
                point(6.0, false, false),
            ],
            bifurcations: vec![],
            gaps: vec![],
            ended: String::new(),
            work: Work::default(),
            flows: 0,
            scales: Vec::new(),
        };
        let (x, stable, unstable) = pieces(&branch, &[1.0, 2.0, 5.0, 6.0], &[10.0, 20.0, 50.0, 60.0]);
        assert_eq!(x, vec![1.0, 2.0, 5.0, 5.0, 6.0]);
        let show = |v: &[f64]| v.iter().map(|a| if a.is_nan() { -1.0 } else { *a }).collect::<Vec<_>>();
        // Solid to the gap, broken at it, then on to the unstable point it joins.
        assert_eq!(show(&stable), vec![10.0, 20.0, -1.0, 50.0, 60.0]);
        assert_eq!(show(&unstable), vec![-1.0, -1.0, -1.0, -1.0, 60.0]);
        // Without the gap the solid line runs through.
        let mut joined = branch.clone();
        joined.points[2].after_gap = false;
        let (x, stable, _) = pieces(&joined, &[1.0, 2.0, 5.0, 6.0], &[10.0, 20.0, 50.0, 60.0]);
        assert_eq!(x.len(), 4);
        assert!(stable.iter().all(|v| v.is_finite()));
    }
}
