//! Newton solves with a Jacobian that is a constant matrix plus a few rank-one terms.
//!
//! The tooth contacts of a gear set enter the tangent matrices through one line-of-action vector
//! per mesh: with u_m the mesh vector (δ_m = u_mᵀq), p_m the vector of its position (s_m = p_mᵀq
//! + s0) and the contact law's tangent values k_m = ∂F/∂δ, g_m = ∂F/∂s and the damping c_m,
//!
//! ```text
//! K = K0 + Σ_m u_m (k_m u_mᵀ + g_m p_mᵀ),      C = C0 + Σ_m c_m u_m u_mᵀ,
//! ```
//!
//! K0 and C0 constant (bearings, shafts). The generalized-α iteration matrix
//! S = (1 − α_m) M + c_C C + c_K K is then S0 + U W with the constant S0 = (1 − α_m) M + c_C C0 + c_K K0,
//! U = \[u_m\] and the rows w_mᵀ = d_m u_mᵀ + e_m p_mᵀ, d_m = c_K k_m + c_C c_m, e_m = c_K g_m. By the
//! Sherman–Morrison–Woodbury identity (Golub & Van Loan, *Matrix Computations*, 4th ed., §2.1.4)
//!
//! ```text
//! S⁻¹ x = y − Z (I + W Z)⁻¹ W y,      y = S0⁻¹ x,   Z = S0⁻¹ U,
//! ```
//!
//! and (W Z)_ij = d_i u_iᵀ z_j + e_i p_iᵀ z_j needs only the constant r × r matrices UᵀZ and PᵀZ.
//! S0⁻¹ and Z are computed once per step size; a Newton iteration then factorises the r × r
//! capacitance matrix of the meshes in contact (r ≤ 2 per planet) instead of the n × n iteration
//! matrix, and a solve costs one n × n product and a few sparse dot products. S0 is symmetric
//! positive definite (M > 0, K0 and C0 positive semi-definite), so S0⁻¹ is well conditioned for any
//! step, and the update adds the contacts' positive stiffness (plus the small non-symmetric
//! position term), which keeps the identity numerically stable.

use nalgebra::DMatrix;

/// One rank-one term of a [`LowRankJacobian`]: sparse vectors as (index, value) pairs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RankOneTerm {
    /// Left (and symmetric) vector u_m.
    pub u: Vec<(usize, f64)>,
    /// Right vector p_m of the non-symmetric part.
    pub p: Vec<(usize, f64)>,
}

/// The structure of a Jacobian K = K0 + Σ u_m (k_m u_mᵀ + g_m p_mᵀ), C = C0 + Σ c_m u_m u_mᵀ.
#[derive(Clone, Debug, PartialEq)]
pub struct LowRankJacobian {
    /// Constant part of the stiffness.
    pub k0: DMatrix<f64>,
    /// Constant part of the damping.
    pub c0: DMatrix<f64>,
    /// The rank-one terms.
    pub terms: Vec<RankOneTerm>,
}

/// Coefficients of one rank-one term at a state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TermCoefficients {
    /// k_m of the symmetric stiffness part.
    pub stiffness: f64,
    /// c_m of the damping part.
    pub damping: f64,
    /// g_m of the non-symmetric part u_m p_mᵀ.
    pub cross: f64,
}

impl LowRankJacobian {
    /// The dense K and C at the given coefficients (used by tests and as a cross-check).
    pub fn assemble(&self, coefficients: &[TermCoefficients]) -> (DMatrix<f64>, DMatrix<f64>) {
        let (mut k, mut c) = (self.k0.clone(), self.c0.clone());
        for (term, co) in self.terms.iter().zip(coefficients) {
            for &(i, ui) in &term.u {
                for &(j, uj) in &term.u {
                    k[(i, j)] += co.stiffness * ui * uj;
                    c[(i, j)] += co.damping * ui * uj;
                }
                for &(j, pj) in &term.p {
                    k[(i, j)] += co.cross * ui * pj;
                }
            }
        }
        (k, c)
    }
}

/// A singular matrix met by the solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Singular;

/// The Woodbury solver of the iteration matrix S0 + U W (see the module documentation).
#[derive(Clone, Debug)]
pub(crate) struct LowRankSolver {
    structure: LowRankJacobian,
    n: usize,
    /// The (1 − α_m, c_K, c_C) that S0 was built for.
    key: Option<[u64; 3]>,
    /// S0⁻¹ by rows without its exact zeros (bodies that no bearing couples stay uncoupled in
    /// S0, so most of S0⁻¹ is zero): row i holds `inv_values[inv_rows[i]..inv_rows[i + 1]]` in
    /// the columns `inv_cols[..]`.
    inv_rows: Vec<usize>,
    inv_cols: Vec<usize>,
    inv_values: Vec<f64>,
    /// Z = S0⁻¹ U, column m at m·n.
    z: Vec<f64>,
    /// u_iᵀ z_j and p_iᵀ z_j, row-major r × r.
    uz: Vec<f64>,
    pz: Vec<f64>,
    /// Terms in contact (d or e nonzero) and their d, e.
    active: Vec<usize>,
    d: Vec<f64>,
    e: Vec<f64>,
    /// LU of the capacitance matrix of the active terms, row-major, with its row pivots.
    cap: Vec<f64>,
    pivots: Vec<usize>,
    y: Vec<f64>,
    w: Vec<f64>,
}

fn dot(v: &[(usize, f64)], x: &[f64]) -> f64 {
    v.iter().map(|(i, a)| a * x[*i]).sum()
}

impl LowRankSolver {
    pub(crate) fn new(structure: LowRankJacobian, n: usize) -> Option<Self> {
        let fits = structure.k0.shape() == (n, n)
            && structure.c0.shape() == (n, n)
            && structure.terms.iter().all(|t| t.u.iter().chain(&t.p).all(|(i, _)| *i < n));
        if !fits {
            return None;
        }
        let r = structure.terms.len();
        Some(Self {
            structure,
            n,
            key: None,
            inv_rows: vec![0; n + 1],
            inv_cols: Vec::new(),
            inv_values: Vec::new(),
            z: vec![0.0; n * r],
            uz: vec![0.0; r * r],
            pz: vec![0.0; r * r],
            active: Vec::with_capacity(r),
            d: vec![0.0; r],
            e: vec![0.0; r],
            cap: vec![0.0; r * r],
            pivots: vec![0; r],
            y: vec![0.0; n],
            w: vec![0.0; r],
        })
    }

    /// Builds S0⁻¹ and Z for S0 = m_factor·M + c_k K0 + c_c C0, unless already built for these
    /// factors.
    pub(crate) fn prepare(
        &mut self,
        mass: &[f64],
        m_factor: f64,
        c_k: f64,
        c_c: f64,
    ) -> Result<(), Singular> {
        let key = [m_factor.to_bits(), c_k.to_bits(), c_c.to_bits()];
        if self.key == Some(key) {
            return Ok(());
        }
        self.key = None;
        let n = self.n;
        let mut s0 = &self.structure.k0 * c_k + &self.structure.c0 * c_c;
        for (i, m) in mass.iter().enumerate() {
            s0[(i, i)] += m_factor * m;
        }
        let inv = s0.try_inverse().ok_or(Singular)?;
        if inv.iter().any(|x| !x.is_finite()) {
            return Err(Singular);
        }
        self.inv_cols.clear();
        self.inv_values.clear();
        for i in 0..n {
            for j in 0..n {
                if inv[(i, j)] != 0.0 {
                    self.inv_cols.push(j);
                    self.inv_values.push(inv[(i, j)]);
                }
            }
            self.inv_rows[i + 1] = self.inv_values.len();
        }
        let r = self.structure.terms.len();
        for (m, term) in self.structure.terms.iter().enumerate() {
            let col = &mut self.z[m * n..(m + 1) * n];
            for (i, zi) in col.iter_mut().enumerate() {
                *zi = term.u.iter().map(|(j, u)| inv[(i, *j)] * u).sum();
            }
        }
        for (i, term) in self.structure.terms.iter().enumerate() {
            for j in 0..r {
                let zj = &self.z[j * n..(j + 1) * n];
                self.uz[i * r + j] = dot(&term.u, zj);
                self.pz[i * r + j] = dot(&term.p, zj);
            }
        }
        self.key = Some(key);
        Ok(())
    }

    /// Factorises the capacitance matrix for the terms' coefficients (after [`Self::prepare`]).
    pub(crate) fn factor(
        &mut self,
        coefficients: &[TermCoefficients],
        c_k: f64,
        c_c: f64,
    ) -> Result<(), Singular> {
        let r = self.structure.terms.len();
        self.active.clear();
        for (m, co) in coefficients.iter().enumerate().take(r) {
            let d = c_k * co.stiffness + c_c * co.damping;
            let e = c_k * co.cross;
            if d != 0.0 || e != 0.0 {
                self.active.push(m);
                self.d[m] = d;
                self.e[m] = e;
            }
        }
        let na = self.active.len();
        for (a, &i) in self.active.iter().enumerate() {
            for (b, &j) in self.active.iter().enumerate() {
                let identity = if a == b { 1.0 } else { 0.0 };
                self.cap[a * na + b] =
                    identity + self.d[i] * self.uz[i * r + j] + self.e[i] * self.pz[i * r + j];
            }
        }
        // LU with partial pivoting, in place (L below the diagonal with unit diagonal, U on and above).
        let cap = &mut self.cap[..na * na];
        for k in 0..na {
            let mut p = k;
            for i in k + 1..na {
                if cap[i * na + k].abs() > cap[p * na + k].abs() {
                    p = i;
                }
            }
            self.pivots[k] = p;
            if p != k {
                for j in 0..na {
                    cap.swap(k * na + j, p * na + j);
                }
            }
            let pivot = cap[k * na + k];
            if pivot == 0.0 || !pivot.is_finite() {
                return Err(Singular);
            }
            for i in k + 1..na {
                let l = cap[i * na + k] / pivot;
                cap[i * na + k] = l;
                for j in k + 1..na {
                    cap[i * na + j] -= l * cap[k * na + j];
                }
            }
        }
        Ok(())
    }

    /// Overwrites `x` with S⁻¹ x (after [`Self::factor`]).
    pub(crate) fn solve(&mut self, x: &mut [f64]) {
        let n = self.n;
        for (i, yi) in self.y.iter_mut().enumerate() {
            let range = self.inv_rows[i]..self.inv_rows[i + 1];
            *yi = self.inv_cols[range.clone()]
                .iter()
                .zip(&self.inv_values[range])
                .map(|(j, a)| a * x[*j])
                .sum();
        }
        let na = self.active.len();
        let terms = &self.structure.terms;
        for (a, &m) in self.active.iter().enumerate() {
            self.w[a] = self.d[m] * dot(&terms[m].u, &self.y) + self.e[m] * dot(&terms[m].p, &self.y);
        }
        let cap = &self.cap[..na * na];
        let w = &mut self.w[..na];
        for k in 0..na {
            w.swap(k, self.pivots[k]);
        }
        for i in 0..na {
            let s: f64 = (0..i).map(|j| cap[i * na + j] * w[j]).sum();
            w[i] -= s;
        }
        for i in (0..na).rev() {
            let s: f64 = (i + 1..na).map(|j| cap[i * na + j] * w[j]).sum();
            w[i] = (w[i] - s) / cap[i * na + i];
        }
        x.copy_from_slice(&self.y);
        for (a, &m) in self.active.iter().enumerate() {
            let zm = &self.z[m * n..(m + 1) * n];
            for (xi, zi) in x.iter_mut().zip(zm) {
                *xi -= w[a] * zi;
            }
        }
    }
}
