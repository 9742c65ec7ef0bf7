//! The run along a branch ([`follow_branch`](super::follow_branch),
//! [`follow_joining`](super::follow_joining)): from the first point, each
//! step planned along the tangent (landing on the last speed, or aimed at a
//! stable point of the other run), corrected (the arclength step halved
//! where the corrector fails, leaps over non-smooth points, restarts by
//! marching beyond the furthest speed reached), and its point accepted with
//! the folds and period doublings since the last, until the last speed, a
//! join with the other run's branch, or a failure.

use super::{
    add, hermite_extremum, most_negative_real, near_branch, rescaled, state_distance, unbroken, Bifurcation,
    BifurcationKind, Branch, BranchPoint, BranchSolver, ContinuationError, ContinuationSettings, Gap,
    GapKind, FIXED_SPEED_SLOPE, JOIN_TOLERANCE, RESTART_TRIES,
};
use crate::dynamics::periodic::PeriodicOrbit;
use crate::dynamics::response::Work;

/// The run of [`follow_branch`](super::follow_branch) and
/// [`follow_joining`](super::follow_joining) (with the `other` run's branch).
pub(super) fn follow<S: BranchSolver>(
    solver: &mut S,
    settings: &ContinuationSettings,
    other: Option<&Branch>,
    mut progress: impl FnMut(&BranchPoint),
) -> Result<Branch, ContinuationError> {
    settings.check()?;
    let mut run = Run::start(solver, settings, other)?;
    progress(&run.points[0]);
    while run.points.len() < settings.max_points {
        let Some(step) = run.plan(solver) else { break };
        let (mut work, mut step_flows) = (Work::default(), 0);
        let found = match run.correct(solver, &step, (&mut work, &mut step_flows)) {
            Corrected::Retry => continue,
            Corrected::Stop => break,
            Corrected::Found(found) => found,
        };
        if !run.accept(solver, &step, found, (work, step_flows), &mut progress) {
            break;
        }
    }
    Ok(run.finish())
}

/// A run along a branch: the settings in units of the nominal step, the last point with
/// its tangent and linearization, the furthest point, and what the branch holds so far.
struct Run<'a, L> {
    settings: &'a ContinuationSettings,
    /// The other run's branch, where this run may join it.
    other: Option<&'a Branch>,
    /// The nominal step [rad/s]: the unit of λ.
    unit: f64,
    /// +1 up, −1 down.
    direction: f64,
    /// λ of the first and of the last speed.
    lambda_start: f64,
    lambda_end: f64,
    /// The last point Y = (x, λ), its unit tangent and its linearization.
    y: Vec<f64>,
    t: Vec<f64>,
    lin: L,
    /// The point furthest towards `to`, where a restart begins.
    furthest: Vec<f64>,
    /// Speed travelled (in nominal steps) since the furthest point last moved on.
    travel: f64,
    segment: usize,
    points: Vec<BranchPoint>,
    bifurcations: Vec<Bifurcation>,
    gaps: Vec<Gap>,
    /// The arclength step.
    ds: f64,
    /// Whether the next correction takes a linearization at its prediction.
    refresh: bool,
    /// The run has come back to a fold it passed before ([`Run::note_bifurcations`]): restart.
    retracing: bool,
    /// Why the run ended.
    ended: String,
    /// The solver's unknown scales.
    scales: Vec<f64>,
    /// Whether the last point lies near `other`'s branch (where a step may be aimed at it).
    near: bool,
    /// The work and flows of the whole run.
    total: Work,
    flows: usize,
}

/// A step planned from the last point.
struct Step {
    /// The index of λ in Y.
    m: usize,
    /// The step lands on the last speed exactly.
    last: bool,
    /// The arclength that changes the speed by one nominal step.
    one_step: f64,
    /// The other run's stable point the step is aimed at: its index, and the share of the
    /// planned step at which it lies.
    landing: Option<(usize, f64)>,
    /// The predicted Y.
    predicted: Vec<f64>,
    /// The step is corrected at its predicted speed ([`FIXED_SPEED_SLOPE`]).
    fixed: bool,
    /// The corrector's constraint row: the speed's, or the tangent.
    constraint: Vec<f64>,
}

/// What the correction of a step gave.
enum Corrected {
    /// Nothing at this arclength step: the run tries again with half of it.
    Retry,
    /// Nothing at all: the run ends ([`Run::ended`] says why).
    Stop,
    /// A point.
    Found(Found),
}

/// A corrected point: Y, the corrections it took, the gap before it (a leap or a
/// restart) and whether it lies at the last speed.
struct Found {
    x: Vec<f64>,
    corrections: usize,
    gap: Option<GapKind>,
    last: bool,
}

impl<'a, L> Run<'a, L> {
    /// The first point at the settings' first speed, its tangent oriented towards `to`.
    fn start<S: BranchSolver<Linear = L>>(
        solver: &mut S,
        settings: &'a ContinuationSettings,
        other: Option<&'a Branch>,
    ) -> Result<Self, ContinuationError> {
        let unit = settings.step;
        let direction = (settings.to - settings.from).signum();
        let (first, x0, lin) = solver.start(settings.from, unit)?;
        let (total, flows) = (first.work, first.flows);
        let mut seed = vec![0.0; x0.len() + 1];
        seed[x0.len()] = direction;
        let t = solver.tangent(&lin, unit, &seed);
        let y: Vec<f64> = x0.into_iter().chain([settings.from / unit]).collect();
        let points = vec![BranchPoint {
            stable: first.is_stable(),
            orbit: first,
            segment: 0,
            speed_slope: t[t.len() - 1] * unit,
            after_gap: false,
        }];
        let scales = solver.unknown_scales();
        let near = other.is_some_and(|o| near_branch(o, points[0].orbit.speed, &points[0].orbit.z, &scales));
        Ok(Self {
            settings,
            other,
            unit,
            direction,
            lambda_start: settings.from / unit,
            lambda_end: settings.to / unit,
            furthest: y.clone(),
            y,
            t,
            lin,
            travel: 0.0,
            segment: 0,
            points,
            bifurcations: Vec::new(),
            gaps: Vec::new(),
            ds: 1.0,
            refresh: false,
            retracing: false,
            ended: String::from("reached the last speed"),
            scales,
            near,
            total,
            flows,
        })
    }

    /// The step from the last point: the solver's unknowns fitted to the coming step's
    /// speeds, the arclength step (landing on the last speed exactly, speed fixed instead
    /// of the arclength, where it would pass it; no step changes the speed by more than a
    /// nominal step; aimed at the other run's point where one lies within it), the
    /// prediction and the corrector's constraint. `None` where the solver cannot take the
    /// step's speeds (the run ends there).
    fn plan<S: BranchSolver<Linear = L>>(&mut self, solver: &mut S) -> Option<Step> {
        let settings = self.settings;
        // The unknowns the solver takes for the coming step (the balance's harmonics):
        // its points lie within one nominal step of this speed, on the tangent's side (the
        // lower bound kept at half this speed where a nominal step is larger than it).
        let speed_now = self.y[self.y.len() - 1] * self.unit;
        let speeds = if self.t[self.t.len() - 1] < 0.0 {
            ((speed_now - settings.step).max(0.5 * speed_now), speed_now)
        } else {
            (speed_now, speed_now + settings.step)
        };
        match solver.fit(speeds, &mut [&mut self.y, &mut self.t, &mut self.furthest]) {
            Ok(changed) => self.refresh |= changed,
            Err(e) => {
                self.ended = format!("stopped at {speed_now:.4} rad/s: {e}");
                return None;
            }
        }
        let (y, t, direction) = (&self.y, &self.t, self.direction);
        let m = y.len() - 1;
        let mut last = false;
        let one_step = 1.0 / t[m].abs().max(f64::MIN_POSITIVE);
        let mut h = self.ds.min(one_step);
        if t[m] * direction > 0.0 && (y[m] + h * t[m] - self.lambda_end) * direction >= 0.0 {
            h = (self.lambda_end - y[m]) / t[m];
            last = true;
        }
        let landing = self.landing(last, h);
        if let Some((_, share)) = landing {
            h *= share;
        }
        let predicted: Vec<f64> = y.iter().zip(t).map(|(a, b)| a + h * b).collect();
        let fixed =
            solver.fixed_speed_steps() && !last && landing.is_none() && t[m].abs() >= FIXED_SPEED_SLOPE;
        let constraint: Vec<f64> = if last || landing.is_some() || fixed {
            let mut c = vec![0.0; m + 1];
            c[m] = 1.0;
            c
        } else {
            t.clone()
        };
        Some(Step { m, last, one_step, landing, predicted, fixed, constraint })
    }

    /// The other run's stable point furthest within the planned step `h` (between half
    /// and all of it), where the step may be aimed at it: not the last step, not while
    /// retracing, on a stretch clear of folds, near the other run's branch.
    fn landing(&self, last: bool, h: f64) -> Option<(usize, f64)> {
        let (y, t) = (&self.y, &self.t);
        let m = y.len() - 1;
        let unit = self.unit;
        self.other
            .filter(|_| !last && !self.retracing && t[m].abs() >= FIXED_SPEED_SLOPE && self.near)
            .and_then(|o| {
                let (from, planned) = (y[m], h * t[m]);
                unbroken(o)
                    .iter()
                    .enumerate()
                    .filter(|(_, p)| p.stable)
                    .map(|(j, p)| (j, (p.orbit.speed / unit - from) / planned))
                    .filter(|(_, share)| (0.5..1.0).contains(share))
                    .max_by(|a, b| a.1.total_cmp(&b.1))
            })
    }

    /// The corrected point of `step` (`counts`: the step's work and flows): by the
    /// corrector on the last linearization (a step at fixed speed beyond a fold the
    /// tangent did not foresee finds no point there: then the same step along the
    /// pseudo-arclength plane); where that fails, half the arclength step next, or at the
    /// smallest step the leaps; where the point found leaves the branch, or the run
    /// retraces, a restart.
    fn correct<S: BranchSolver<Linear = L>>(
        &mut self,
        solver: &mut S,
        step: &Step,
        (work, step_flows): (&mut Work, &mut usize),
    ) -> Corrected {
        let settings = self.settings;
        let limits = (self.unit, settings.max_corrections);
        let (mut last, mut gap) = (step.last, None);
        let mut accepted = if self.retracing {
            None
        } else {
            let (lin, fresh) = (&self.lin, self.refresh);
            solver.correct(
                lin,
                fresh,
                &step.constraint,
                &step.predicted,
                limits,
                (&mut *work, &mut *step_flows),
            )
        };
        if accepted.is_none() && step.fixed {
            let counts = (&mut *work, &mut *step_flows);
            accepted = solver.correct(&self.lin, true, &self.t, &step.predicted, limits, counts);
        }
        if accepted.is_none() && !self.retracing {
            self.ds *= 0.5;
            self.refresh = true;
            if self.ds >= settings.min_step {
                add(&mut self.total, work);
                self.flows += *step_flows;
                return Corrected::Retry;
            }
            if let Some(found) = self.leap(solver, step.one_step, (&mut *work, &mut *step_flows)) {
                accepted = Some(found);
                gap = Some(GapKind::Leap);
            }
            last = false;
        }
        // A branch that turns back past the first speed, runs back more than
        // `max_back` below the furthest speed, or travels twice that without
        // reaching further, is left too.
        let m = step.m;
        let left = accepted.as_ref().is_some_and(|(x, _)| {
            (x[m] - self.lambda_start) * self.direction < 0.0
                || (self.furthest[m] - x[m]) * self.direction > settings.max_back
                || self.travel + (x[m] - self.y[m]).abs() > 2.0 * settings.max_back
        });
        if accepted.is_none() || left || self.retracing {
            self.retracing = false;
            // What the corrector or a leap found is left.
            let Some((x, beyond)) = self.restart(solver, m, (work, step_flows)) else {
                return Corrected::Stop;
            };
            accepted = Some((x, 0));
            gap = Some(GapKind::Restart);
            last = beyond;
        }
        let Some((x, corrections)) = accepted else { unreachable!("a failed step has ended the run") };
        Corrected::Found(Found { x, corrections, gap, last })
    }

    /// The leaps over a point where the corrector fails at the smallest step: one, then
    /// two nominal steps (`one_step` the arclength of one) along the tangent, corrected
    /// from their far end with twice the corrections.
    fn leap<S: BranchSolver<Linear = L>>(
        &self,
        solver: &mut S,
        one_step: f64,
        (work, step_flows): (&mut Work, &mut usize),
    ) -> Option<(Vec<f64>, usize)> {
        for leap in [1.0, 2.0] {
            let h = leap * one_step.min(1.0);
            let far: Vec<f64> = self.y.iter().zip(&self.t).map(|(a, b)| a + h * b).collect();
            let limits = (self.unit, 2 * self.settings.max_corrections);
            let counts = (&mut *work, &mut *step_flows);
            if let Some(found) = solver.correct(&self.lin, true, &self.t, &far, limits, counts) {
                return Some(found);
            }
        }
        None
    }

    /// The restart: from one nominal step beyond the furthest speed reached (never the
    /// last speed: a point there has ended the run); where marching finds no periodic
    /// state (the attractor is not periodic in one mesh cycle) one step further, at most
    /// [`RESTART_TRIES`] times. The point Y found and whether it lies at the last speed;
    /// where none, the run's end is recorded with the step's work (`counts`).
    fn restart<S: BranchSolver<Linear = L>>(
        &mut self,
        solver: &mut S,
        m: usize,
        (work, step_flows): (&mut Work, &mut usize),
    ) -> Option<(Vec<f64>, bool)> {
        let mut tried = Vec::new();
        for k in 1..=RESTART_TRIES {
            let lambda = self.furthest[m] + self.direction * k as f64;
            let beyond = (lambda - self.lambda_end) * self.direction >= 0.0;
            let lambda = if beyond { self.lambda_end } else { lambda };
            tried.push(lambda * self.unit);
            if let Some(z) = solver.restart(lambda * self.unit, &self.furthest[..m], work, step_flows) {
                return Some((z.into_iter().chain([lambda]).collect(), beyond));
            }
            if beyond {
                break;
            }
        }
        self.ended = format!(
            "stopped at {:.4} rad/s: no periodic state within the smallest arclength step, and \
             none by marching at {}",
            self.y[m] * self.unit,
            tried.iter().map(|w| format!("{w:.4}")).collect::<Vec<_>>().join(", ") + " rad/s"
        );
        add(&mut self.total, work);
        self.flows += *step_flows;
        None
    }

    /// Accepts the corrected point `found` of `step` (`counts`: the step's work and
    /// flows): its orbit and linearization (the run ends where the solver fails there),
    /// its tangent (after a restart pointing towards `to`, otherwise along the branch),
    /// the gap before it or the bifurcations since the last point, whether it joins the
    /// other run's branch; the furthest point and the arclength step for the next.
    /// Whether the run goes on.
    fn accept<S: BranchSolver<Linear = L>>(
        &mut self,
        solver: &mut S,
        step: &Step,
        found: Found,
        (mut work, mut step_flows): (Work, usize),
        progress: &mut impl FnMut(&BranchPoint),
    ) -> bool {
        let Found { mut x, corrections, gap, last } = found;
        let (unit, mut m) = (self.unit, step.m);
        self.refresh = false;
        let mut k = x.len() - 1;
        let omega = x[k] * unit;
        let accepted = solver.accept((&x[..k], omega, unit), corrections, (&mut work, &mut step_flows));
        add(&mut self.total, &work);
        self.flows += step_flows;
        let (orbit, new_lin) = match accepted {
            Ok(accepted) => accepted,
            Err(e) => {
                self.ended = format!("stopped at {omega:.4} rad/s: {e}");
                return false;
            }
        };
        if let Some(resolved) = solver.resolved() {
            // The point was solved again at more harmonics: the run's vectors follow.
            let lambda = x[k];
            x = resolved;
            x.push(lambda);
            if let Err(e) = solver.fit((omega, omega), &mut [&mut self.y, &mut self.t, &mut self.furthest]) {
                self.ended = format!("stopped at {omega:.4} rad/s: {e}");
                return false;
            }
            (m, k) = (self.y.len() - 1, x.len() - 1);
        }
        let mut seed = vec![0.0; x.len()];
        seed[k] = self.direction;
        let orient = if gap == Some(GapKind::Restart) { &seed } else { &self.t };
        let new_t = solver.tangent(&new_lin, unit, orient);
        let i = self.points.len();
        if let Some(kind) = gap {
            self.gaps.push(Gap { kind, from: self.y[m] * unit, to: omega, point: i });
            self.segment += 1;
        } else {
            self.note_bifurcations(&orbit, &x, &new_t, (m, k));
        }
        let prev_lambda = if gap.is_some() { x[k] } else { self.y[m] };
        let joined = self.joined(step.landing, gap, &orbit);
        self.near = self.other.is_some_and(|o| near_branch(o, orbit.speed, &orbit.z, &self.scales));
        let point = BranchPoint {
            stable: orbit.is_stable(),
            orbit,
            segment: self.segment,
            speed_slope: new_t[k] * unit,
            after_gap: gap.is_some(),
        };
        progress(&point);
        self.points.push(point);
        self.y = x;
        self.t = new_t;
        self.lin = new_lin;
        // The furthest point's λ is its last entry (its x may hold other harmonics
        // until the next step's fit).
        if (self.y[k] - self.furthest[self.furthest.len() - 1]) * self.direction > 0.0 {
            self.furthest = self.y.clone();
            self.travel = 0.0;
        } else {
            self.travel += (self.y[k] - prev_lambda).abs();
        }
        self.ds = if gap.is_some() {
            1.0
        } else if corrections <= 2 {
            (self.ds * 1.5).min(self.settings.max_step)
        } else if corrections >= 5 {
            (self.ds * 0.6).max(self.settings.min_step)
        } else {
            self.ds
        };
        if let Some((j, distance)) = joined {
            self.ended = format!(
                "joined the other run's branch at {:.4} rad/s (its point {j}; states within {distance:.1e} of \
                 their size), which that run follows from there",
                self.y[k] * unit
            );
            return false;
        }
        !(last || (self.y[k] - self.lambda_end) * self.direction >= 0.0)
    }

    /// The folds and period doublings between the last point and the new one (`x`, its
    /// `orbit` and tangent `new_t`; `(m, k)` the index of λ in the last point and in the
    /// new). A fold within a tenth of a nominal step of an earlier fold of the run: the run
    /// is going round a closed loop, or back and forth between two corners where the
    /// tangent flips, and restarts. A turn of the tangent starts a new segment.
    fn note_bifurcations(&mut self, orbit: &PeriodicOrbit, x: &[f64], new_t: &[f64], (m, k): (usize, usize)) {
        let i = self.points.len();
        let known = self.bifurcations.len();
        let previous = &self.points[i - 1].orbit;
        detect_bifurcations(
            previous,
            orbit,
            (&self.y, x),
            (&self.t, new_t),
            self.unit,
            i,
            &mut self.bifurcations,
        );
        let (earlier, new) = self.bifurcations.split_at(known);
        let unit = self.unit;
        self.retracing = new.iter().filter(|b| b.kind == BifurcationKind::Fold).any(|b| {
            earlier.iter().any(|e| e.kind == BifurcationKind::Fold && (e.speed - b.speed).abs() <= 0.1 * unit)
        });
        if new_t[k] * self.t[m] < 0.0 {
            self.segment += 1;
        }
    }

    /// Where the step was aimed at the other run's point (`landing`, not after a gap) and
    /// the `orbit` found is that point's (within [`JOIN_TOLERANCE`]): the point's index and
    /// the distance of the two states.
    fn joined(
        &self,
        landing: Option<(usize, f64)>,
        gap: Option<GapKind>,
        orbit: &PeriodicOrbit,
    ) -> Option<(usize, f64)> {
        match (landing, self.other) {
            (Some((j, _)), Some(o)) if gap.is_none() => rescaled(o, &o.points[j].orbit.z, &self.scales)
                .map(|theirs| (j, state_distance(&theirs, &orbit.z)))
                .filter(|(_, distance)| *distance <= JOIN_TOLERANCE),
            _ => None,
        }
    }

    /// The branch the run followed.
    fn finish(mut self) -> Branch {
        if self.points.len() >= self.settings.max_points {
            self.ended = format!("stopped after {} points (the most allowed)", self.settings.max_points);
        }
        Branch {
            points: self.points,
            bifurcations: self.bifurcations,
            gaps: self.gaps,
            ended: self.ended,
            work: self.total,
            flows: self.flows,
            scales: self.scales,
        }
    }
}

/// The folds and period doublings between two successive points of a
/// branch (`y`, `t`: the points in (z, λ) and their tangents); `i` is the
/// second point's index.
fn detect_bifurcations(
    prev: &PeriodicOrbit,
    orbit: &PeriodicOrbit,
    (y, x): (&[f64], &[f64]),
    (t, new_t): (&[f64], &[f64]),
    unit: f64,
    i: usize,
    bifurcations: &mut Vec<Bifurcation>,
) {
    let m = y.len() - 1;
    if new_t[m] * t[m] < 0.0 {
        let arc = y.iter().zip(x).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        let speed =
            hermite_extremum(arc, y[m], x[m], t[m], new_t[m]).map_or(0.5 * (y[m] + x[m]), |v| v) * unit;
        let near_one = |o: &PeriodicOrbit| {
            o.multipliers
                .iter()
                .filter(|u| u.is_real())
                .map(|u| u.re)
                .min_by(|a, b| (a - 1.0).abs().total_cmp(&(b - 1.0).abs()))
                .unwrap_or(f64::NAN)
        };
        bifurcations.push(Bifurcation {
            kind: BifurcationKind::Fold,
            speed,
            between: (i - 1, i),
            multipliers: (near_one(prev), near_one(orbit)),
        });
    }
    // A period doubling: a real multiplier passes −1, so the number of
    // multipliers outside the unit circle changes by as many as the
    // number of real ones below −1 (two real multipliers that meet and
    // leave the real axis outside the circle are no crossing).
    let below =
        |o: &PeriodicOrbit| o.multipliers.iter().filter(|u| u.is_real() && u.re < -1.0).count() as i64;
    let outside = |o: &PeriodicOrbit| o.multipliers.iter().filter(|u| u.modulus() > 1.0).count() as i64;
    let d_below = below(orbit) - below(prev);
    if d_below != 0 && outside(orbit) - outside(prev) == d_below {
        let (a, b) = (most_negative_real(prev), most_negative_real(orbit));
        let w = if (a + 1.0) * (b + 1.0) < 0.0 { (a + 1.0) / (a - b) } else { 0.5 };
        bifurcations.push(Bifurcation {
            kind: BifurcationKind::PeriodDoubling,
            speed: prev.speed + w * (orbit.speed - prev.speed),
            between: (i - 1, i),
            multipliers: (a, b),
        });
    }
}
