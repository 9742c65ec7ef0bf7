//! Pseudo-arclength continuation of periodic steady states in input speed
//! (docs/PERIODIC.md): one connected branch through folds, with every
//! point's Floquet multipliers and stability, and the folds (a real
//! multiplier through +1, where the branch turns back in speed) and
//! period-doubling points (a real multiplier through −1) located between
//! the points that bracket them.
//!
//! The unknowns are Y = (z, λ): the periodic state's scaled relative state z
//! ([`PeriodicProblem`]) and the speed in units of the nominal step,
//! λ = ω / Δω. A step predicts along the unit tangent t of the branch
//! (the null vector of [∂G/∂z, ∂G/∂λ], oriented as the previous one) and
//! corrects by chord-Newton on G(z, λ) = 0 with tᵀ(Y − Y_pred) = 0, on the
//! linearization of the last point; the arclength step grows after easy
//! corrections and shrinks after hard or failed ones. All speeds are rad/s.

use serde::{Deserialize, Serialize};

use crate::dynamics::periodic::{
    floquet_multipliers, solve_dense, Linearization, PeriodicError, PeriodicOrbit, PeriodicProblem,
};
use crate::dynamics::response::Work;

/// Settings of a continuation run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContinuationSettings {
    /// Speed where the branch starts [rad/s].
    pub from: f64,
    /// Speed where it ends [rad/s] (either side of `from`).
    pub to: f64,
    /// Nominal speed step [rad/s]: the unit of λ and the first arclength step.
    pub step: f64,
    /// Largest arclength step, in nominal steps.
    pub max_step: f64,
    /// Smallest arclength step, in nominal steps; a step that fails below it ends the run.
    pub min_step: f64,
    /// Most points on the branch.
    pub max_points: usize,
    /// Most chord-Newton corrections per step.
    pub max_corrections: usize,
}

impl ContinuationSettings {
    /// From `from` to `to` at nominal step `step` [rad/s], with the default
    /// step bounds (1/256 to 4 nominal steps), at most 20 000 points and 8
    /// corrections per step.
    pub fn new(from: f64, to: f64, step: f64) -> Self {
        Self { from, to, step, max_step: 4.0, min_step: 1.0 / 256.0, max_points: 20_000, max_corrections: 8 }
    }

    fn check(&self) -> Result<(), ContinuationError> {
        let bad = |name: &str, value: f64, reason: &str| {
            Err(ContinuationError::InvalidRequest {
                name: name.into(),
                value: value.to_string(),
                reason: reason.into(),
            })
        };
        if !(self.from.is_finite() && self.from > 0.0) {
            return bad("from", self.from, "the first speed must be positive and finite");
        }
        if !(self.to.is_finite() && self.to > 0.0 && self.to != self.from) {
            return bad("to", self.to, "the last speed must be positive, finite and differ from the first");
        }
        if !(self.step.is_finite() && self.step > 0.0 && self.step <= (self.to - self.from).abs()) {
            return bad("step", self.step, "must be positive and at most the speed range");
        }
        if !(self.min_step > 0.0 && self.min_step <= 1.0 && self.max_step >= 1.0 && self.max_step.is_finite())
        {
            return bad("step bounds", self.min_step, "need 0 < min_step ≤ 1 ≤ max_step");
        }
        if self.max_points < 2 || self.max_corrections == 0 {
            return bad("max_points", self.max_points as f64, "need at least 2 points and 1 correction");
        }
        Ok(())
    }
}

/// Errors of a continuation run.
#[derive(Debug, thiserror::Error)]
pub enum ContinuationError {
    /// The periodic solver failed at the start.
    #[error(transparent)]
    Periodic(#[from] PeriodicError),
    /// A request that cannot be met.
    #[error("{name} = {value}: {reason}")]
    InvalidRequest {
        /// Name.
        name: String,
        /// Value.
        value: String,
        /// What is allowed.
        reason: String,
    },
}

/// One point of a branch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BranchPoint {
    /// The periodic state (speed, multipliers, work).
    pub orbit: PeriodicOrbit,
    /// All Floquet multipliers inside the unit circle.
    pub stable: bool,
    /// Segment of the branch between folds: 0 up to the first fold, 1 to the
    /// second, …
    pub segment: usize,
    /// dω/ds along the branch's tangent [rad/s per unit arclength]: its sign
    /// says whether the branch runs towards `to` (positive) or back.
    pub speed_slope: f64,
}

/// What happens at a bifurcation point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BifurcationKind {
    /// A real multiplier crosses +1; the branch turns back in speed (the
    /// jump of a sweep).
    Fold,
    /// A real multiplier crosses −1; a branch of twice the period starts.
    PeriodDoubling,
}

/// A located bifurcation point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bifurcation {
    /// Kind.
    pub kind: BifurcationKind,
    /// Speed [rad/s] (cubic Hermite interpolation of the speed along the
    /// arclength for a fold; linear interpolation of μ + 1 for a period doubling).
    pub speed: f64,
    /// Indices of the two branch points that bracket it.
    pub between: (usize, usize),
    /// The real multiplier nearest the crossing value at those two points.
    pub multipliers: (f64, f64),
}

/// A branch of periodic states.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Branch {
    /// The points in the order continued.
    pub points: Vec<BranchPoint>,
    /// Folds and period doublings, in the order met.
    pub bifurcations: Vec<Bifurcation>,
    /// Why the run ended: "reached the last speed", or the reason it stopped early.
    pub ended: String,
    /// Work of the whole run.
    pub work: Work,
    /// Flows over one period integrated in the whole run.
    pub flows: usize,
}

fn add(work: &mut Work, w: &Work) {
    work.steps += w.steps;
    work.rejected_steps += w.rejected_steps;
    work.rhs_evaluations += w.rhs_evaluations;
    work.events_located += w.events_located;
}

/// The bordered matrix [[M − I, ∂G/∂λ]; cᵀ] (column-major, size m + 1).
fn bordered(lin: &Linearization, unit: f64, c: &[f64]) -> Vec<f64> {
    let m = lin.dim;
    let k = m + 1;
    let mut a = vec![0.0; k * k];
    for j in 0..m {
        for i in 0..m {
            a[i + k * j] = lin.monodromy[i + m * j] - if i == j { 1.0 } else { 0.0 };
        }
    }
    for i in 0..m {
        a[i + k * m] = lin.speed_derivative[i] * unit;
    }
    for (j, cj) in c.iter().enumerate() {
        a[m + k * j] = *cj;
    }
    a
}

/// The unit tangent of the branch at a point, oriented along `previous`.
fn tangent(lin: &Linearization, unit: f64, previous: &[f64]) -> Vec<f64> {
    let k = lin.dim + 1;
    let a = bordered(lin, unit, previous);
    let mut rhs = vec![0.0; k];
    rhs[k - 1] = 1.0;
    let t = solve_dense(&a, k, &rhs);
    let norm = t.iter().map(|x| x * x).sum::<f64>().sqrt();
    let sign = if t.iter().zip(previous).map(|(a, b)| a * b).sum::<f64>() < 0.0 { -1.0 } else { 1.0 };
    t.iter().map(|x| sign * x / norm).collect()
}

/// The point of a cubic Hermite curve on [0, h] (values y0, y1, slopes d0,
/// d1) where its slope vanishes, and the value there; `None` without such a point.
fn hermite_extremum(h: f64, y0: f64, y1: f64, d0: f64, d1: f64) -> Option<f64> {
    // p(σ) = y0 + d0 σ + a σ² + b σ³.
    let a = (3.0 * (y1 - y0) / h - 2.0 * d0 - d1) / h;
    let b = (d0 + d1 - 2.0 * (y1 - y0) / h) / (h * h);
    let roots: Vec<f64> = if b.abs() < 1e-14 * (a.abs() + d0.abs()) / h {
        if a == 0.0 {
            vec![]
        } else {
            vec![-d0 / (2.0 * a)]
        }
    } else {
        let disc = 4.0 * a * a - 12.0 * b * d0;
        if disc < 0.0 {
            vec![]
        } else {
            vec![(-2.0 * a + disc.sqrt()) / (6.0 * b), (-2.0 * a - disc.sqrt()) / (6.0 * b)]
        }
    };
    roots
        .into_iter()
        .filter(|s| (0.0..=h).contains(s))
        .map(|s| y0 + d0 * s + a * s * s + b * s * s * s)
        .next()
}

/// The most negative real multiplier (or 0 when none is real and negative).
fn most_negative_real(orbit: &PeriodicOrbit) -> f64 {
    orbit.multipliers.iter().filter(|m| m.is_real() && m.re < 0.0).map(|m| m.re).fold(0.0, f64::min)
}

/// Follows the branch of periodic states of `problem` from `settings.from`
/// to `settings.to` by pseudo-arclength continuation; `progress` sees every
/// point as it is accepted. A step that cannot be corrected even at the
/// smallest arclength step ends the run early, keeping the points found
/// (the reason is in [`Branch::ended`]).
pub fn continue_branch(
    problem: &mut PeriodicProblem,
    settings: &ContinuationSettings,
    mut progress: impl FnMut(&BranchPoint),
) -> Result<Branch, ContinuationError> {
    settings.check()?;
    let unit = settings.step;
    let direction = (settings.to - settings.from).signum();
    let lambda_end = settings.to / unit;
    let lambda_start = settings.from / unit;
    let tol = problem.settings().newton_tolerance;
    let (first, mut lin) = problem.solve_linearized(settings.from, None)?;
    let m = first.z.len();
    let mut total = first.work;
    let mut flows = first.flows;
    let mut seed = vec![0.0; m + 1];
    seed[m] = direction;
    let mut t = tangent(&lin, unit, &seed);
    let mut y: Vec<f64> = first.z.iter().copied().chain([settings.from / unit]).collect();
    let mut previous_orbit = first.clone();
    let mut segment = 0;
    let mut points =
        vec![BranchPoint { stable: first.is_stable(), orbit: first, segment: 0, speed_slope: t[m] * unit }];
    progress(&points[0]);
    let mut bifurcations = Vec::new();
    let mut ds = 1.0;
    let mut refresh = false;
    let mut ended = String::from("reached the last speed");
    while points.len() < settings.max_points {
        // The last step lands on the last speed exactly (speed fixed instead
        // of the arclength).
        let mut last = false;
        let mut h = ds;
        if t[m] * direction > 0.0 && (y[m] + h * t[m] - lambda_end) * direction >= 0.0 {
            h = (lambda_end - y[m]) / t[m];
            last = true;
        }
        let predicted: Vec<f64> = y.iter().zip(&t).map(|(a, b)| a + h * b).collect();
        let constraint: Vec<f64> = if last {
            let mut c = vec![0.0; m + 1];
            c[m] = 1.0;
            c
        } else {
            t.clone()
        };
        let mut work = Work::default();
        let mut step_flows = 0;
        // After a failed correction the chord matrix is taken at the
        // predicted point instead of the last accepted one (a contact that
        // starts or ends between the two changes the linearization).
        let chord = if refresh {
            match problem.linearize(predicted[m] * unit, &predicted[..m], &mut work) {
                Ok(l) => {
                    step_flows += problem.linearization_flows();
                    bordered(&l, unit, &constraint)
                }
                Err(_) => bordered(&lin, unit, &constraint),
            }
        } else {
            bordered(&lin, unit, &constraint)
        };
        let mut x = predicted.clone();
        let mut converged = None;
        let mut previous_norm = f64::INFINITY;
        for iteration in 1..=settings.max_corrections {
            let g = match problem.residual(x[m] * unit, &x[..m], &mut work) {
                Ok(g) => g,
                Err(_) => break,
            };
            step_flows += 1;
            let norm = g.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
            let size = x[..m].iter().fold(1.0_f64, |a, b| a.max(b.abs()));
            if norm <= tol * size {
                converged = Some(iteration - 1);
                break;
            }
            if (norm >= previous_norm || norm.is_nan()) && iteration > 2 {
                break;
            }
            previous_norm = norm;
            let mut rhs: Vec<f64> = g.iter().map(|v| -v).collect();
            rhs.push(
                -constraint.iter().zip(x.iter().zip(&predicted)).map(|(c, (a, b))| c * (a - b)).sum::<f64>(),
            );
            let dx = solve_dense(&chord, m + 1, &rhs);
            if dx.iter().any(|v| !v.is_finite()) {
                break;
            }
            x.iter_mut().zip(&dx).for_each(|(a, d)| *a += d);
        }
        add(&mut total, &work);
        flows += step_flows;
        let Some(corrections) = converged else {
            ds *= 0.5;
            refresh = true;
            if ds < settings.min_step {
                ended = format!(
                    "stopped at {:.4} rad/s: no periodic state within the smallest arclength step",
                    y[m] * unit
                );
                break;
            }
            continue;
        };
        refresh = false;
        let omega = x[m] * unit;
        let new_lin = match problem.linearize(omega, &x[..m], &mut work) {
            Ok(l) => l,
            Err(e) => {
                ended = format!("stopped at {omega:.4} rad/s: {e}");
                break;
            }
        };
        flows += problem.linearization_flows();
        add(&mut total, &work);
        let new_t = tangent(&new_lin, unit, &t);
        let multipliers = floquet_multipliers(&new_lin.monodromy, m);
        let orbit = PeriodicOrbit {
            speed: omega,
            period: problem.period(omega),
            cycles: problem.cycles(),
            z: x[..m].to_vec(),
            residual: new_lin.residual.iter().fold(0.0_f64, |a, b| a.max(b.abs())),
            newton_iterations: corrections,
            multipliers,
            flows: step_flows + problem.linearization_flows(),
            work,
        };
        let prev = (&previous_orbit, segment);
        let i = points.len();
        if new_t[m] * t[m] < 0.0 {
            let arc = y.iter().zip(&x).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
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
                multipliers: (near_one(prev.0), near_one(&orbit)),
            });
            segment += 1;
        }
        // A period doubling: a real multiplier passes −1, so the number of
        // multipliers outside the unit circle changes by as many as the
        // number of real ones below −1 (two real multipliers that meet and
        // leave the real axis outside the circle are no crossing).
        let below =
            |o: &PeriodicOrbit| o.multipliers.iter().filter(|u| u.is_real() && u.re < -1.0).count() as i64;
        let outside = |o: &PeriodicOrbit| o.multipliers.iter().filter(|u| u.modulus() > 1.0).count() as i64;
        let d_below = below(&orbit) - below(prev.0);
        if d_below != 0 && outside(&orbit) - outside(prev.0) == d_below {
            let (a, b) = (most_negative_real(prev.0), most_negative_real(&orbit));
            let w = if (a + 1.0) * (b + 1.0) < 0.0 { (a + 1.0) / (a - b) } else { 0.5 };
            bifurcations.push(Bifurcation {
                kind: BifurcationKind::PeriodDoubling,
                speed: prev.0.speed + w * (omega - prev.0.speed),
                between: (i - 1, i),
                multipliers: (a, b),
            });
        }
        previous_orbit = orbit.clone();
        let point = BranchPoint { stable: orbit.is_stable(), orbit, segment, speed_slope: new_t[m] * unit };
        progress(&point);
        points.push(point);
        y = x;
        t = new_t;
        lin = new_lin;
        ds = if corrections <= 2 {
            (ds * 1.5).min(settings.max_step)
        } else if corrections >= 5 {
            (ds * 0.6).max(settings.min_step)
        } else {
            ds
        };
        if last {
            break;
        }
        if (y[m] - lambda_start) * direction < 0.0 {
            ended = format!("the branch turned back below the first speed at {:.4} rad/s", y[m] * unit);
            break;
        }
    }
    if points.len() >= settings.max_points {
        ended = format!("stopped after {} points (the most allowed)", settings.max_points);
    }
    Ok(Branch { points, bifurcations, ended, work: total, flows })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_extremum_of_a_parabola() {
        // y = 1 − (s − 0.3)² on [0, 1]: slopes 0.6 and −1.4; the top is 1 at s = 0.3.
        let y = |s: f64| 1.0 - (s - 0.3) * (s - 0.3);
        let top = hermite_extremum(1.0, y(0.0), y(1.0), 0.6, -1.4).unwrap();
        assert!((top - 1.0).abs() < 1e-12, "{top}");
        assert!(hermite_extremum(1.0, 0.0, 1.0, 1.0, 1.0).is_none());
    }
}
