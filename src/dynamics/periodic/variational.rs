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
//! mesh's damping force does jump when the whole mesh separates (it acts
//! while a pair touches); the columns miss that jump's saltation term, which
//! a difference flow carries. The monodromy of a separating orbit is
//! therefore approximate, and Newton's method converges on it linearly
//! instead of quadratically ([`super::MonodromyMethod`]; tests/periodic.rs
//! measures the difference against forward differences).

use crate::dynamics::rigid_frame::RigidFrame;
use crate::dynamics::solver::{
    LowRankJacobian, RankOneTerm, SecondOrderSystem, TangentSystem, TermCoefficients,
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
