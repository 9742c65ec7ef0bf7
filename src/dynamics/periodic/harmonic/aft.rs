//! The balance's residual by alternating frequency–time evaluation: the
//! series sampled at N times, the equations of motion evaluated there, their
//! Fourier coefficients taken back (with the contact switches located and
//! projected exactly when asked), and the Jacobian of the plain sums from the
//! tangent sequences along the orbit.

use rustfft::num_complex::Complex;

use super::jacobian::{assemble, project, Jacobian, PairSpectrum};
use super::{HarmonicBalance, Projected};
use crate::dynamics::periodic::krylov::{BandPattern, Inertia, Operator, KRYLOV_BAND};
use crate::dynamics::periodic::series::{analyse_with, derivative_coefficient};
use crate::dynamics::periodic::switches::{
    add_back, add_time_terms, locate, subtract, time_gradients, time_terms, SeriesResidual, Switch,
};
use crate::dynamics::periodic::PeriodicError;
use crate::dynamics::rigid_frame::RigidFrame;
use crate::dynamics::solver::{SecondOrderSystem, TangentSystem};

impl HarmonicBalance {
    /// The samples of y, ẏ, ÿ (units: static deflection, per second, per
    /// second squared), each N × m sample-major, from the coefficients `x`.
    fn samples_of(&self, x: &[f64], nu: f64) -> [Vec<f64>; 3] {
        let (m, ns) = (self.m, self.samples);
        let mut buffer = vec![Complex::new(0.0, 0.0); ns];
        let mut column = vec![0.0; ns];
        let mut out = [vec![0.0; ns * m], vec![0.0; ns * m], vec![0.0; ns * m]];
        for a in 0..m {
            for (d, o) in out.iter_mut().enumerate() {
                self.synthesize(
                    |c| {
                        let k = c.div_ceil(2) as f64;
                        match (d, c) {
                            (0, _) => x[c * m + a],
                            (1, c) => derivative_coefficient(|c| x[c * m + a], c, nu),
                            (_, 0) => 0.0,
                            _ => -k * k * nu * nu * x[c * m + a],
                        }
                    },
                    &mut buffer,
                    &mut column,
                );
                for (j, y) in column.iter().enumerate() {
                    o[j * m + a] = *y;
                }
            }
        }
        out
    }

    /// Fourier coefficients (blocks as in
    /// [`HarmonicOrbit::coefficients`](super::HarmonicOrbit::coefficients)) of N samples
    /// `values` of one quantity.
    pub(super) fn analyse(&self, values: &[f64], buffer: &mut [Complex<f64>], out: &mut [f64]) {
        analyse_with(self.plans(), self.settings.harmonics, values, buffer, out);
    }

    /// Fourier coefficients of the unknowns' m coordinates (blocks as in
    /// [`HarmonicOrbit::coefficients`](super::HarmonicOrbit::coefficients)) from N samples
    /// of each, sample-major.
    pub(super) fn analyse_samples(&self, values: &[f64]) -> Vec<f64> {
        let (m, ns) = (self.m, self.samples);
        let mut out = vec![0.0; m * (2 * self.settings.harmonics + 1)];
        let mut buffer = vec![Complex::new(0.0, 0.0); ns];
        let mut coefficients = vec![0.0; 2 * self.settings.harmonics + 1];
        let mut column = vec![0.0; ns];
        for a in 0..m {
            for j in 0..ns {
                column[j] = values[j * m + a];
            }
            self.analyse(&column, &mut buffer, &mut coefficients);
            for (c, value) in coefficients.iter().enumerate() {
                out[c * m + a] = *value;
            }
        }
        out
    }

    /// The spectra of the tangent sequences `tangents` (as [`Self::evaluate`] fills them),
    /// the pairs (a, b) b-major, scaled to the rows `row`, at ν = `nu`.
    fn tangent_spectra(&self, tangents: &[f64], row: &[f64], nu: f64) -> Vec<PairSpectrum> {
        let (m, ns, h) = (self.m, self.samples, self.settings.harmonics);
        let q_scale = self.problem.q_scale;
        let top = 2 * h + 1;
        let mut spectrum = vec![Complex::new(0.0, 0.0); ns];
        let mut out = Vec::with_capacity(m * m);
        for b in 0..m {
            for a in 0..m {
                let (mut cosine, mut sine) =
                    ([vec![0.0; top], vec![0.0; top]], [vec![0.0; top], vec![0.0; top]]);
                for kind in 0..2 {
                    let seq = &tangents[((kind * m + b) * m + a) * ns..][..ns];
                    for (z, v) in spectrum.iter_mut().zip(seq) {
                        *z = Complex::new(*v, 0.0);
                    }
                    self.plans().forward(&mut spectrum);
                    let scale = q_scale * row[a] * if kind == 1 { nu } else { 1.0 } / ns as f64;
                    for pp in 0..top {
                        let z = spectrum[pp % ns];
                        cosine[kind][pp] = z.re * scale;
                        sine[kind][pp] = -z.im * scale;
                    }
                }
                let [kc, cc] = cosine;
                let [ks, cs] = sine;
                out.push(PairSpectrum { kc, ks, cc, cs });
            }
        }
        out
    }

    /// The scaled residual coefficients at `x`, and, when `jacobian` is
    /// given, its Jacobian of the plain N-sample sums (column-major, unknowns
    /// × unknowns). With `switches` the contact switches are located and
    /// their jumps and kinks projected exactly (module `switches`).
    pub(super) fn evaluate(
        &mut self,
        omega: f64,
        x: &[f64],
        jacobian: Option<&mut Jacobian>,
        evaluations: &mut u64,
        switches: bool,
    ) -> Result<Vec<f64>, PeriodicError> {
        let (m, n, ns, h) = (self.m, self.n, self.samples, self.settings.harmonics);
        // The Jacobian at the point the last projected evaluation took: its residual and
        // switches as they are, the samples only for the tangents.
        let kept = self.projected.take().filter(|k| {
            switches && jacobian.is_some() && ns == self.settings.samples && k.omega == omega && k.x == x
        });
        let period = self.problem.period(omega);
        let nu = 2.0 * std::f64::consts::PI / period;
        let q_scale = self.problem.q_scale;
        let series = self.samples_of(x, nu);
        // Row scale: accelerations in units of the static deflection times ν².
        let row: Vec<f64> =
            (0..m).map(|a| 1.0 / (self.reduced_mass[a + m * a] * nu * nu * q_scale)).collect();
        self.problem.model.set_drive_speed(omega);
        let rigid = self.problem.model.rigid_velocity_at(omega);
        // Tangent sequences, (a, b) pair-major, N samples each: stiffness then damping.
        let mut tangents = std::mem::take(&mut self.tangents);
        if jacobian.is_some() {
            tangents.resize(2 * m * m * ns, 0.0);
        }
        let pass = SamplePass {
            p: &self.p,
            sizes: (m, n, ns),
            q_scale,
            period,
            row: &row,
            residual: kept.is_none(),
            switches,
            tangents: jacobian.is_some(),
        };
        let mut frame = RigidFrame::new(&mut self.problem.model, rigid);
        let mut sampled = Sampled { r: vec![0.0; ns * m], events: Vec::new(), sample_events: Vec::new() };
        pass.run(&mut frame, &series, &mut tangents, &mut sampled, evaluations)?;
        let (found, residual) = if let Some(k) = kept {
            let mut found = k.switches;
            let mut series = SeriesResidual::new(&self.p, &row, x, nu, q_scale);
            time_gradients(&mut series, &mut frame, &mut found, evaluations);
            (found, k.residual)
        } else {
            let found = if switches {
                let mut crossings = std::mem::take(&mut self.crossings);
                let found =
                    pass.locate_switches(&mut frame, (x, nu), &mut sampled, evaluations, &mut crossings);
                self.crossings = crossings;
                let found = found?;
                subtract(&found, period, &mut sampled.r);
                found
            } else {
                Vec::new()
            };
            let mut residual = self.analyse_samples(&sampled.r);
            add_back(&found, nu, h, &mut residual);
            (found, residual)
        };
        if let Some(jacobian) = jacobian {
            let inertia = Inertia { mass: &self.reduced_mass, row: &row, nu, q_scale };
            self.assemble_jacobian(jacobian, &mut tangents, &inertia, &found, period)?;
        }
        self.tangents = tangents;
        if switches {
            self.projected =
                Some(Projected { omega, x: x.to_vec(), residual: residual.clone(), switches: found });
        }
        Ok(residual)
    }

    /// The Jacobian of the plain sums into `jacobian` from the tangent sequences
    /// `tangents` and the inertia (`inertia`: PᵀMP, the rows' scale, ν), with the time
    /// terms of the switches `found` in the period `period` \[s\]: dense, or as the
    /// operator GMRES takes ([`Self::operator`]).
    fn assemble_jacobian(
        &self,
        jacobian: &mut Jacobian,
        tangents: &mut Vec<f64>,
        inertia: &Inertia<'_>,
        found: &[Switch],
        period: f64,
    ) -> Result<(), PeriodicError> {
        let (m, h) = (self.m, self.settings.harmonics);
        // (1/N) Σ_j x_j cos pθ_j and (1/N) Σ_j x_j sin pθ_j, p = 0 ..= 2H (mod N), of the
        // stiffness (index 0) and damping (index 1) sequence of each pair (a, b), scaled
        // to row a (the damping also by ν: ẏ of cos cνt is −cν sin cνt).
        let spectra = self.tangent_spectra(tangents, inertia.row, inertia.nu);
        match jacobian {
            Jacobian::Dense { matrix: jac, .. } => {
                let size = m * (2 * h + 1);
                jac.clear();
                jac.resize(size * size, 0.0);
                assemble(m, h, h, &spectra, inertia, |r, c, v| jac[r + size * c] += v);
                add_time_terms(found, period, h, jac);
            }
            Jacobian::Operator(slot) => {
                let operator = self.operator(slot.take(), &spectra, inertia, found, period, tangents)?;
                *slot = Some(Box::new(operator));
            }
        }
        Ok(())
    }

    /// The Jacobian as the operator GMRES takes: its band of [`KRYLOV_BAND`] harmonics
    /// with the switches' time terms, assembled and factorised, in the `last` operator's
    /// pattern and storage where they fit. The tangent sequences move into the operator;
    /// `tangents` receives the last operator's storage, which the next evaluation
    /// overwrites whole.
    fn operator(
        &self,
        last: Option<Box<Operator>>,
        spectra: &[PairSpectrum],
        inertia: &Inertia<'_>,
        found: &[Switch],
        period: f64,
        tangents: &mut Vec<f64>,
    ) -> Result<Operator, PeriodicError> {
        let (m, h) = (self.m, self.settings.harmonics);
        let (pattern, mut band, mut kept) = match last {
            Some(op) if op.pattern.is(m, h, KRYLOV_BAND) => {
                let op = *op;
                (op.pattern, op.band, op.tangents)
            }
            _ => (BandPattern::new(m, h, KRYLOV_BAND)?, Vec::new(), Vec::new()),
        };
        band.clear();
        band.resize(pattern.len(), 0.0);
        assemble(m, h, pattern.band(), spectra, inertia, |r, c, v| {
            if let Some(i) = pattern.index(r, c) {
                band[i] += v;
            }
        });
        let terms = time_terms(found, period, h);
        for (u, v) in &terms {
            for (c, column) in v.iter().enumerate() {
                let (lo, hi) = pattern.rows(c);
                for (r, w) in u.iter().enumerate().take(hi).skip(lo) {
                    if let Some(i) = pattern.index(r, c) {
                        band[i] += column * w;
                    }
                }
            }
        }
        let lu = pattern.factorize(&band)?;
        std::mem::swap(&mut kept, tangents);
        Ok(Operator {
            m,
            harmonics: h,
            plans: self.plans().share(),
            nu: inertia.nu,
            q_scale: inertia.q_scale,
            mass: self.reduced_mass.clone(),
            row: inertia.row.to_vec(),
            tangents: kept,
            terms,
            pattern,
            band,
            lu,
        })
    }
}

/// One evaluation's pass over its N samples: what it reads, and which of the
/// event values, the residual's samples and the tangent sequences it takes.
struct SamplePass<'a> {
    /// P, n × m column-major.
    p: &'a [f64],
    /// The unknowns' coordinates per time m, the model's coordinates n, the samples N.
    sizes: (usize, usize, usize),
    /// The static mesh deflection, the unit of the series \[m\].
    q_scale: f64,
    /// The period \[s\].
    period: f64,
    /// The rows' scale of the residual.
    row: &'a [f64],
    /// Whether the residual's samples are evaluated (not where the last projected
    /// evaluation's residual is kept).
    residual: bool,
    /// Whether the event values are taken, for the contact switches.
    switches: bool,
    /// Whether the tangent sequences are filled, for the Jacobian.
    tangents: bool,
}

/// What a [`SamplePass`] leaves.
struct Sampled {
    /// The residual's samples, N × m sample-major.
    r: Vec<f64>,
    /// With the switches: the event values at the N samples (and at t = T once
    /// located), sample-major.
    events: Vec<f64>,
    /// The event values of the last time taken.
    sample_events: Vec<f64>,
}

/// The buffers of one pass over the samples, allocated once per evaluation.
struct PassBuffers {
    q: Vec<f64>,
    v: Vec<f64>,
    /// The inertia force, then the inertia less the model's force.
    f: Vec<f64>,
    force: Vec<f64>,
    kt: nalgebra::DMatrix<f64>,
    ct: nalgebra::DMatrix<f64>,
    kp: Vec<f64>,
    reduced: Vec<f64>,
}

impl SamplePass<'_> {
    /// The pass over the samples of the series' y, ẏ, ÿ (`series`, each N × m
    /// sample-major): at each sample the model's state, then as asked the event values
    /// (before the force: the model keeps that evaluation, and the force or the tangents
    /// reuse it), the residual's sample into `out.r` and the tangents into `tangents`.
    fn run(
        &self,
        frame: &mut RigidFrame<'_>,
        series: &[Vec<f64>; 3],
        tangents: &mut [f64],
        out: &mut Sampled,
        evaluations: &mut u64,
    ) -> Result<(), PeriodicError> {
        let (m, n, ns) = self.sizes;
        let mut b = PassBuffers {
            q: vec![0.0; n],
            v: vec![0.0; n],
            f: vec![0.0; n],
            force: vec![0.0; n],
            kt: nalgebra::DMatrix::zeros(n, n),
            ct: nalgebra::DMatrix::zeros(n, n),
            kp: vec![0.0; n * m],
            reduced: vec![0.0; m * m],
        };
        for j in 0..ns {
            let t = self.period * j as f64 / ns as f64;
            self.state(j, series, frame.mass(), &mut b);
            if self.switches {
                frame.events(t, &b.q, &b.v, &mut out.sample_events);
                *evaluations += 1;
            }
            // With the residual kept, only the tangents below: through the same pass as the
            // residual's evaluation (the law with the event values, not used then), so that
            // the Jacobian is the one assembled afresh.
            if self.residual {
                if self.switches {
                    out.events.extend_from_slice(&out.sample_events);
                } else {
                    *evaluations += 1;
                }
                self.residual_at(frame, (j, t), &mut b, &mut out.r)?;
            }
            if self.tangents {
                self.tangents_at(frame, (j, t), &mut b, tangents);
            }
        }
        Ok(())
    }

    /// The model's relative state at sample `j` into `b.q`, `b.v`, and its inertia
    /// force M q̈ into `b.f` (`mass` the diagonal of M).
    #[inline]
    fn state(&self, j: usize, [y, yd, ydd]: &[Vec<f64>; 3], mass: &[f64], b: &mut PassBuffers) {
        let (m, n, _) = self.sizes;
        let (p, q_scale) = (self.p, self.q_scale);
        for i in 0..n {
            let (mut qi, mut vi, mut ai) = (0.0, 0.0, 0.0);
            for a in 0..m {
                let pia = p[i + n * a];
                qi += pia * y[j * m + a];
                vi += pia * yd[j * m + a];
                ai += pia * ydd[j * m + a];
            }
            b.q[i] = qi * q_scale;
            b.v[i] = vi * q_scale;
            b.f[i] = mass[i] * ai * q_scale;
        }
    }

    /// The residual's sample `j` (at time `t`): the inertia force less the model's,
    /// projected on P and scaled to the rows, into `r`; an error where the force is not
    /// finite.
    #[inline]
    fn residual_at(
        &self,
        frame: &mut RigidFrame<'_>,
        (j, t): (usize, f64),
        b: &mut PassBuffers,
        r: &mut [f64],
    ) -> Result<(), PeriodicError> {
        let (m, n, _) = self.sizes;
        let p = self.p;
        frame.force(t, &b.q, &b.v, &mut b.force);
        if let Some(i) = b.force.iter().position(|x| !x.is_finite()) {
            return Err(PeriodicError::invalid(
                "harmonic-balance iterate",
                b.force[i],
                "gives a non-finite force: the iterate diverged",
            ));
        }
        for i in 0..n {
            b.f[i] -= b.force[i];
        }
        for a in 0..m {
            r[j * m + a] = self.row[a] * (0..n).map(|i| p[i + n * a] * b.f[i]).sum::<f64>();
        }
        Ok(())
    }

    /// The tangent stiffness and damping at sample `j` (at time `t`), projected to PᵀKP
    /// and PᵀCP, into sample `j` of the tangent sequences.
    #[inline]
    fn tangents_at(
        &self,
        frame: &mut RigidFrame<'_>,
        (j, t): (usize, f64),
        b: &mut PassBuffers,
        tangents: &mut [f64],
    ) {
        let (m, _, ns) = self.sizes;
        frame.jacobian(t, &b.q, &b.v, &mut b.kt, &mut b.ct);
        for (s, mat) in [&b.kt, &b.ct].into_iter().enumerate() {
            project(self.p, mat, m, &mut b.kp, &mut b.reduced);
            for bb in 0..m {
                for a in 0..m {
                    tangents[((s * m + bb) * m + a) * ns + j] = b.reduced[a + m * bb];
                }
            }
        }
    }

    /// The contact switches of the residual on the series `x` (at ν): the event values at
    /// t = T added to the samples', each sign change located on the series, its jump and
    /// kink computed (with the switch time's gradient when the pass takes the tangents),
    /// the crossings located into `crossings` (module `switches`).
    fn locate_switches(
        &self,
        frame: &mut RigidFrame<'_>,
        (x, nu): (&[f64], f64),
        out: &mut Sampled,
        evaluations: &mut u64,
        crossings: &mut Vec<(f64, usize)>,
    ) -> Result<Vec<Switch>, PeriodicError> {
        let (_, _, ns) = self.sizes;
        let mut series = SeriesResidual::new(self.p, self.row, x, nu, self.q_scale);
        series.events(frame, self.period, &mut out.sample_events);
        out.events.extend_from_slice(&out.sample_events);
        crossings.clear();
        locate(
            &mut series,
            frame,
            &out.events,
            out.sample_events.len(),
            self.period / ns as f64,
            self.tangents,
            evaluations,
            crossings,
        )
    }
}
