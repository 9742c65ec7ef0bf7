//! Newton's method on the balance: the solve from a guess or a cold start
//! (the static state, the march's period, the orbits of neighbouring
//! speeds), the plain sums' run handing over to the run with the contact
//! switches projected, chord iterations while they contract well.

use super::arc::refit;
use super::jacobian::{newton_remainder, Jacobian, Newton};
use super::{HarmonicBalance, HarmonicOrbit, HANDOVER_STEP, NEIGHBOUR_OFFSETS, STALLED_ITERATIONS};
use crate::dynamics::periodic::{max_abs, PeriodicError};
use crate::dynamics::response::Work;

impl HarmonicBalance {
    /// The periodic state at `omega` [rad/s] by Newton's method with a
    /// backtracking line search from the coefficients `guess` (a cold start
    /// when `None`: the static state, where Newton fails from there the march's
    /// period after the shooting problem's run-in, and where that fails too the
    /// orbits of neighbouring speeds ([`NEIGHBOUR_OFFSETS`]); a guess with
    /// another number of harmonics gives its common harmonics).
    pub fn solve(&mut self, omega: f64, guess: Option<&[f64]>) -> Result<HarmonicOrbit, PeriodicError> {
        let mut newton = Newton::default();
        let x = match guess {
            // Another H's coefficients: the common harmonics, the rest zero.
            Some(g) if g.len() % self.m == 0 && (g.len() / self.m) % 2 == 1 => {
                refit(g, self.unknowns(), false)
            }
            Some(g) => {
                return Err(PeriodicError::invalid(
                    "harmonic-balance guess",
                    g.len() as f64,
                    "must hold m(2H' + 1) coefficients for some H' (m coordinates)",
                ))
            }
            None => return self.solve_cold(omega, &mut newton),
        };
        self.attempt(omega, x, &mut newton)
    }

    /// [`Self::solve`] without a guess: [`Self::cold_attempt`] at `omega`, and where that
    /// fails, from the orbits of neighbouring speeds. Both starts fail at a few speeds where
    /// the orbit lies far from the static state and the march does not approach it (κ = 0,
    /// 9600 rpm: the period-1 orbit unstable, the march quasi-periodic): then from the orbit
    /// of a neighbouring speed, found as this one would be, as a sweep's warm start
    /// ([`NEIGHBOUR_OFFSETS`]). The error is the static start's at `omega`.
    fn solve_cold(&mut self, omega: f64, newton: &mut Newton) -> Result<HarmonicOrbit, PeriodicError> {
        let solved = self.cold_attempt(omega, newton);
        if solved.is_ok() {
            return solved;
        }
        for offset in NEIGHBOUR_OFFSETS {
            let near = omega * (1.0 + offset);
            let Ok(neighbour) = self.cold_attempt(near, newton) else { continue };
            if let Ok(orbit) = self.attempt(omega, neighbour.coefficients, newton) {
                return Ok(HarmonicOrbit { neighbour: Some(near), ..orbit });
            }
        }
        solved
    }

    /// [`Self::attempt`] from the static state ([`Self::cold_start`]) and, where that fails,
    /// from the march's period. Newton from the static state can stall where the response
    /// lies far from it (4100 rpm on the torsional example: a fourth-harmonic resonance,
    /// the ring teeth separating; residual 3 after 10 iterations). Then from the state the
    /// march reaches after the shooting problem's run-in, as its own cold start does, its
    /// next period sampled and analysed into coefficients (the counts hold all attempts;
    /// the error is the static start's).
    fn cold_attempt(&mut self, omega: f64, newton: &mut Newton) -> Result<HarmonicOrbit, PeriodicError> {
        let solved = self.attempt(omega, self.cold_start(omega), newton);
        if solved.is_ok() {
            return solved;
        }
        match self.marched_start(omega, newton) {
            Ok(x) => self.attempt(omega, x, newton).or(solved),
            Err(_) => solved,
        }
    }

    /// [`Self::run`] from `x`: the plain run on half the samples where the settings allow
    /// it ([`PLAIN_SAMPLES_PER_HARMONIC`](super::PLAIN_SAMPLES_PER_HARMONIC)); where that
    /// solve fails, the whole solve again on the full samples.
    pub(super) fn attempt(
        &mut self,
        omega: f64,
        x: Vec<f64>,
        newton: &mut Newton,
    ) -> Result<HarmonicOrbit, PeriodicError> {
        if self.half.is_some() {
            if let Ok(orbit) = self.run(omega, x.clone(), true, newton) {
                return Ok(orbit);
            }
        }
        self.run(omega, x, false, newton)
    }

    /// The coefficients of the period the march from the static state reaches after the
    /// shooting problem's run-in periods
    /// ([`PeriodicProblem::cold_start`](crate::dynamics::periodic::PeriodicProblem::cold_start)):
    /// that period sampled at the settings' N and analysed. `newton` counts the flows' steps
    /// and force evaluations.
    pub(super) fn marched_start(
        &mut self,
        omega: f64,
        newton: &mut Newton,
    ) -> Result<Vec<f64>, PeriodicError> {
        let mut work = Work::default();
        let z = self.problem.cold_start(omega, &mut work)?;
        let ns = self.settings.samples;
        let coordinates = self.problem.sampled_flow(omega, &z, ns, &mut work)?;
        newton.evaluations += work.rhs_evaluations;
        newton.march_steps += work.steps;
        self.samples = ns;
        Ok(self.analyse_samples(&coordinates))
    }

    /// The kept Jacobian's storage, taken from the balance, in the form a system of
    /// `unknowns` takes (the storage of the other form is dropped): the dense LU's up to
    /// [`DENSE_UNKNOWNS`](super::DENSE_UNKNOWNS), the operator's beyond.
    pub(super) fn take_jacobian(&mut self, unknowns: usize) -> Jacobian {
        let jacobian = std::mem::take(&mut self.jacobian);
        let krylov = unknowns > self.dense_unknowns;
        if krylov == matches!(jacobian, Jacobian::Operator(_)) {
            jacobian
        } else if krylov {
            Jacobian::Operator(None)
        } else {
            Jacobian::default()
        }
    }

    /// [`Self::solve`] from the coefficients `x`, its plain run on N/2 samples when
    /// `half`; `newton` counts the work and keeps the Jacobian's storage (taken from the
    /// balance and handed back to it).
    fn run(
        &mut self,
        omega: f64,
        x: Vec<f64>,
        half: bool,
        newton: &mut Newton,
    ) -> Result<HarmonicOrbit, PeriodicError> {
        newton.jacobian = self.take_jacobian(x.len());
        // Near the root of the plain sums first (to [`HANDOVER_STEP`]); then, from there, the
        // root with the contact switches' jumps and kinks projected exactly on the full N
        // samples (module `switches`), which lies 2e-4 to 1.2e-3 of the coefficients from the
        // plain root off the separating speeds of the torsional example, more where the teeth
        // separate: each evaluation of that residual costs more.
        // The second run starts on the plain sums' factorised Jacobian; a Jacobian it takes
        // afresh holds the jumps' time terms.
        if half {
            self.samples = self.settings.samples / 2;
        }
        let plain = (|| {
            let r = self.evaluate(omega, &x, Some(&mut newton.jacobian), &mut newton.evaluations, false)?;
            newton.factorize(x.len());
            self.newton(omega, x, r, false, newton)
        })();
        self.samples = self.settings.samples;
        let projected = plain.and_then(|(x, _, _)| {
            let r = self.evaluate(omega, &x, None, &mut newton.evaluations, true)?;
            self.newton(omega, x, r, true, newton)
        });
        self.jacobian = std::mem::take(&mut newton.jacobian);
        let (x, r, last_step) = projected?;
        Ok(HarmonicOrbit {
            speed: omega,
            period: self.problem.period(omega),
            cycles: self.problem.cycles,
            harmonics: self.settings.harmonics,
            coefficients: x,
            iterations: newton.iterations,
            residual: max_abs(&r),
            last_step,
            factorizations: newton.factorizations,
            products: newton.products,
            force_evaluations: newton.evaluations,
            march_steps: newton.march_steps,
            neighbour: None,
            crossings: self.crossings.clone(),
        })
    }

    /// Newton's method with a backtracking line search from `x`, whose residual
    /// is `r`, on the residual with or without the contact switches projected
    /// (`switches`); chord iterations on `newton`'s factorised Jacobian while
    /// they contract well. The root, its residual and the last step.
    pub(super) fn newton(
        &mut self,
        omega: f64,
        mut x: Vec<f64>,
        mut r: Vec<f64>,
        switches: bool,
        newton: &mut Newton,
    ) -> Result<(Vec<f64>, Vec<f64>, f64), PeriodicError> {
        let (mut stalled, mut iterations) = (0, 0);
        // The length of the last step taken whole (no line search), for the contraction.
        let mut whole: Option<f64> = None;
        loop {
            let norm = max_abs(&r);
            let step = newton.step(&r);
            let last_step = max_abs(&step);
            if !last_step.is_finite() {
                return Err(PeriodicError::NotConverged {
                    speed: omega,
                    iterations: newton.iterations,
                    residual: norm,
                });
            }
            // A step below the tolerance is taken whole and ends the run, without the
            // residual after it; the plain sums' run hands over at HANDOVER_STEP. On the
            // projected residual, so does a step after which the distance to the root,
            // estimated from the contraction θ of the steps (θ / (1 − θ) times this one,
            // [`newton_remainder`]), is at most the tolerance.
            let tolerance =
                if switches { self.settings.tolerance } else { self.settings.tolerance.max(HANDOVER_STEP) };
            let allowed = tolerance * max_abs(&x).max(1.0);
            let remainder = if switches { newton_remainder(whole, last_step) } else { f64::INFINITY };
            if last_step <= allowed || remainder <= allowed {
                newton.iterations += 1;
                x.iter_mut().zip(&step).for_each(|(a, d)| *a += d);
                return Ok((x, r, last_step));
            }
            iterations += 1;
            newton.iterations += 1;
            let mut alpha = 1.0;
            let (mut x_new, mut r_new);
            loop {
                x_new = x.iter().zip(&step).map(|(a, d)| a + alpha * d).collect::<Vec<f64>>();
                r_new = self.evaluate(omega, &x_new, None, &mut newton.evaluations, switches)?;
                if max_abs(&r_new) < (1.0 - 1e-4 * alpha) * norm || alpha < 1.0 / 64.0 {
                    break;
                }
                alpha *= 0.5;
            }
            x = x_new;
            whole = (alpha == 1.0).then_some(last_step);
            let contraction = max_abs(&r_new) / norm;
            r = r_new;
            if alpha * last_step <= self.settings.tolerance * max_abs(&x).max(1.0) {
                return Ok((x, r, last_step));
            }
            // Newton converges by a factor 10 or more per iteration here; iterations that
            // no longer halve the residual cycle between contact patterns the series cannot
            // settle (docs/PERIODIC.md §2) and do not converge.
            stalled = if contraction > 0.5 { stalled + 1 } else { 0 };
            if iterations >= self.settings.max_iterations || stalled >= STALLED_ITERATIONS {
                return Err(PeriodicError::NotConverged {
                    speed: omega,
                    iterations: newton.iterations,
                    residual: max_abs(&r),
                });
            }
            // Chord iterations while they contract well; a fresh Jacobian otherwise.
            if contraction > self.settings.chord_contraction {
                r =
                    self.evaluate(omega, &x, Some(&mut newton.jacobian), &mut newton.evaluations, switches)?;
                newton.factorize(x.len());
            }
        }
    }
}
