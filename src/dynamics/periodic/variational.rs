//! The monodromy matrix by the variational equations: the flow of the model
//! integrated together with its derivative with respect to the initial
//! state, in one augmented flow instead of one difference flow per unknown.
//!
//! With X = ∂q/∂x₀ (n × m, one column per direction of the initial state)
//! the derivative of M q̈ = f(t, q, q̇) gives
//!
//! M Ẍ = −K(t) X − C(t) Ẋ,
//!
//! K = −∂f/∂q and C = −∂f/∂q̇ the tangent matrices along the orbit. The
//! model gives them as a constant part plus one rank-one term per mesh
//! ([`LowRankJacobian`]): K = K₀ + Σ u (k uᵀ + g pᵀ), C = C₀ + Σ c u uᵀ, so
//! a column costs the nonzeros of K₀ and C₀ and a few sparse dot products
//! per mesh, not a dense n × n product.
//!
//! The contact force is continuous across a tooth pair's entry and exit (a
//! pair enters and leaves at zero penetration), so the tangent jumps but
//! the flow's derivative does not: no saltation term arises, and the
//! integrator's event location places the switches within its tolerance. A
//! mesh's damping force does jump when the whole mesh separates or touches
//! again (it acts while a pair touches): there the columns take the
//! saltation term of the jump ([`Variational::saltation`]), applied by the
//! flow at the located event where a mesh's contact changes.

use crate::dynamics::rigid_frame::RigidFrame;
use crate::dynamics::solver::{
    LocatedEvent, LowRankJacobian, RankOneTerm, SecondOrderSystem, TangentSystem, TermCoefficients,
};

/// The model in the rigid-body frame with `columns` variational columns:
/// state (q, X) of n (1 + m) coordinates, velocities alike, X stored by
/// coordinate (entry (i, j), coordinate i of column j, at n + i m + j), so
/// that each term updates a row of all columns at once.
pub(super) struct Variational<'a, 'b> {
    frame: &'b mut RigidFrame<'a>,
    n: usize,
    columns: usize,
    mass: Vec<f64>,
    /// Nonzeros (i, j, value) of K₀ and of C₀.
    k0: Vec<(usize, usize, f64)>,
    c0: Vec<(usize, usize, f64)>,
    terms: Vec<RankOneTerm>,
    coefficients: Vec<TermCoefficients>,
    /// One row of the columns: a term's s = k uᵀX + g pᵀX + c uᵀẊ.
    row: Vec<f64>,
}

impl<'a, 'b> Variational<'a, 'b> {
    /// The augmented system of `frame` with `columns` columns; `None` when
    /// the model gives no low-rank tangent structure.
    pub(super) fn new(frame: &'b mut RigidFrame<'a>, columns: usize) -> Option<Self> {
        let LowRankJacobian { k0, c0, terms } = frame.low_rank_jacobian()?;
        let n = frame.dim();
        let nonzeros = |m: &nalgebra::DMatrix<f64>| {
            let mut nz = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    if m[(i, j)] != 0.0 {
                        nz.push((i, j, m[(i, j)]));
                    }
                }
            }
            nz
        };
        let mut mass = frame.mass().to_vec();
        for i in 0..n {
            mass.extend(std::iter::repeat_n(frame.mass()[i], columns));
        }
        let coefficients = vec![TermCoefficients::default(); terms.len()];
        Some(Self {
            n,
            columns,
            mass,
            k0: nonzeros(&k0),
            c0: nonzeros(&c0),
            terms,
            coefficients,
            row: vec![0.0; columns],
            frame,
        })
    }

    /// The augmented initial state of the relative state (q, v) and the
    /// columns' initial states (X₀ⱼ, Ẋ₀ⱼ), one per column.
    pub(super) fn initial_state(
        &self,
        q: &[f64],
        v: &[f64],
        columns: &[(Vec<f64>, Vec<f64>)],
    ) -> (Vec<f64>, Vec<f64>) {
        let (n, m) = (self.n, self.columns);
        let (mut qa, mut va) = (q.to_vec(), v.to_vec());
        qa.resize(n * (1 + m), 0.0);
        va.resize(n * (1 + m), 0.0);
        for (j, (x, y)) in columns.iter().enumerate() {
            for i in 0..n {
                qa[n + i * m + j] = x[i];
                va[n + i * m + j] = y[i];
            }
        }
        (qa, va)
    }

    /// Whether the model's mesh damping is Rayleigh's, whose force jumps at
    /// every pair switch.
    pub(super) fn rayleigh_meshes(&self) -> bool {
        self.frame.model().rayleigh_meshes()
    }

    /// Whether each mesh has a pair in contact at the augmented state (q, v)
    /// at time `t` \[s\] (the flow's part of it decides).
    pub(super) fn touching(&mut self, t: f64, q: &[f64], v: &[f64]) -> Vec<bool> {
        let n = self.n;
        let mut f = vec![0.0; n];
        self.frame.force(t, &q[..n], &v[..n], &mut f);
        self.frame.model().meshes.iter().map(|m| m.stiffness > 0.0).collect()
    }

    /// The saltation of the columns where a mesh's damping force switched:
    /// at a located event at time `t` \[s\] the flow's state (q, v) lies on
    /// the far side of the switching surface h = 0 of the tooth pair whose
    /// event it was, and each column's velocities take
    ///
    /// Ẋⱼ⁺ = Ẋⱼ⁻ + M⁻¹ Δf (∂h/∂q · Xⱼ) / ḣ,
    ///
    /// Δf the jump of the generalized forces ([`PlanetaryDynamics::add_damping_switch`])
    /// and ḣ the rate of h along the orbit, a difference of h over `tau` \[s\]
    /// along (1, q̇) in time and state; ∂h/∂q · Xⱼ is a difference of h along
    /// the column, `scale` \[m\] setting its step. `before` and `now` say which meshes
    /// touched at the step's start and end, `events` are the step's located
    /// events. Returns whether any column changed.
    ///
    /// [`PlanetaryDynamics::add_damping_switch`]: crate::dynamics::equations::PlanetaryDynamics::add_damping_switch
    pub(super) fn saltation(
        &mut self,
        t: f64,
        q: &[f64],
        v: &mut [f64],
        (before, now): (&[bool], &[bool]),
        events: &[LocatedEvent],
        (tau, scale): (f64, f64),
    ) -> bool {
        let (n, m) = (self.n, self.columns);
        let mut changed = false;
        let mut g = Vec::new();
        let mut qp = q[..n].to_vec();
        let rayleigh = self.frame.model().rayleigh_meshes();
        for (i, (&was, &is)) in before.iter().zip(now).enumerate() {
            // A mesh that stays in contact jumps under Rayleigh damping only.
            if was == is && !(rayleigh && is) {
                continue;
            }
            let Some(e) = events.iter().rev().find(|e| self.frame.model().event_mesh(e.index) == Some(i))
            else {
                continue;
            };
            // Under Rayleigh damping, the tangent stiffness just before the
            // switching surface (a step τ back along the flow).
            let stiffness_before = if was == is {
                for k in 0..n {
                    qp[k] = q[k] - tau * v[k];
                }
                self.frame.events(t - tau, &qp, &v[..n], &mut g);
                self.frame.model().meshes[i].stiffness
            } else {
                0.0
            };
            self.frame.events(t, &q[..n], &v[..n], &mut g);
            let h1 = g[e.index];
            // A pair's switch in a mesh that stays in contact: the jump at
            // the landing's state.
            let mut jump = vec![0.0; n];
            if was == is {
                let after = self.frame.model().meshes[i].stiffness;
                self.frame.model().add_rayleigh_jump(i, [stiffness_before, after], &mut jump);
                if jump.iter().all(|a| *a == 0.0) {
                    continue;
                }
            }
            for k in 0..n {
                qp[k] = q[k] + tau * v[k];
            }
            self.frame.events(t + tau, &qp, &v[..n], &mut g);
            let rate = (g[e.index] - h1) / tau;
            if !(rate.is_finite() && rate != 0.0) {
                continue;
            }
            // A mesh's contact starting or ending: δ̇ of the evaluations
            // above, all at the landing's velocities.
            if was != is {
                self.frame.model().add_damping_switch(i, is, &mut jump);
            }
            for (a, mass) in jump.iter_mut().zip(&self.mass) {
                *a /= mass;
            }
            for j in 0..m {
                let size = (0..n).fold(0.0_f64, |a, k| a.max(q[n + k * m + j].abs()));
                if size == 0.0 {
                    continue;
                }
                let eps = 1e-6 * scale / size;
                for k in 0..n {
                    qp[k] = q[k] + eps * q[n + k * m + j];
                }
                self.frame.events(t, &qp, &v[..n], &mut g);
                let factor = (g[e.index] - h1) / eps / rate;
                for (k, a) in jump.iter().enumerate() {
                    v[n + k * m + j] += a * factor;
                }
            }
            changed = true;
        }
        changed
    }

    /// Column `j` of an augmented state (q, v): (Xⱼ, Ẋⱼ).
    pub(super) fn column(&self, q: &[f64], v: &[f64], j: usize) -> (Vec<f64>, Vec<f64>) {
        let (n, m) = (self.n, self.columns);
        ((0..n).map(|i| q[n + i * m + j]).collect(), (0..n).map(|i| v[n + i * m + j]).collect())
    }
}

/// y += a x over a row.
#[inline(always)]
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

impl SecondOrderSystem for Variational<'_, '_> {
    fn dim(&self) -> usize {
        self.mass.len()
    }

    fn mass(&self) -> &[f64] {
        &self.mass
    }

    fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        let (n, m) = (self.n, self.columns);
        let (q0, v0) = (&q[..n], &v[..n]);
        let (f0, out) = f.split_at_mut(n);
        self.frame.force(t, q0, v0, f0);
        // The same state: the model's mesh evaluation is reused.
        self.frame.jacobian_coefficients(t, q0, v0, &mut self.coefficients);
        let (x, y) = (&q[n..], &v[n..]);
        out.fill(0.0);
        for &(i, j, a) in &self.k0 {
            axpy(-a, &x[j * m..(j + 1) * m], &mut out[i * m..(i + 1) * m]);
        }
        for &(i, j, a) in &self.c0 {
            axpy(-a, &y[j * m..(j + 1) * m], &mut out[i * m..(i + 1) * m]);
        }
        let row = &mut self.row;
        for (term, c) in self.terms.iter().zip(&self.coefficients) {
            if c.stiffness == 0.0 && c.cross == 0.0 && c.damping == 0.0 {
                continue;
            }
            row.fill(0.0);
            for &(j, uj) in &term.u {
                axpy(c.stiffness * uj, &x[j * m..(j + 1) * m], row);
                axpy(c.damping * uj, &y[j * m..(j + 1) * m], row);
            }
            for &(j, pj) in &term.p {
                axpy(c.cross * pj, &x[j * m..(j + 1) * m], row);
            }
            for &(i, ui) in &term.u {
                axpy(-ui, row, &mut out[i * m..(i + 1) * m]);
            }
        }
    }

    fn events(&mut self, t: f64, q: &[f64], v: &[f64], out: &mut Vec<f64>) {
        let n = self.n;
        self.frame.events(t, &q[..n], &v[..n], out);
    }
}
