//! Reports of a continuation sweep: the sweep CSV's columns plus each
//! point's stability, branch segment and Floquet multipliers, and the
//! forced-response charts with the unstable parts dashed and the folds and
//! period doublings marked.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::plot::{write_chart, Chart, PlotError, Series, SeriesStyle};
use super::sweep::sweep_csv;
use crate::analysis::continuation::{BifurcationKind, Branch};
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::continuation::BranchPoint;
    use crate::dynamics::periodic::PeriodicOrbit;
    use crate::dynamics::response::Work;

    fn point(speed: f64, stable: bool, after_gap: bool) -> BranchPoint {
        BranchPoint {
            orbit: PeriodicOrbit {
                speed,
                period: 1e-3,
                cycles: 1,
                z: vec![],
                residual: 0.0,
                newton_iterations: 0,
                multipliers: vec![],
                flows: 0,
                work: Work::default(),
            },
            stable,
            segment: 0,
            speed_slope: 1.0,
            after_gap,
        }
    }

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
