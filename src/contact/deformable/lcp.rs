//! The linear complementarity problem of the pairs of one mesh, and its
//! extension by a nonlinear local term.
//!
//! LCP(A, q): find p ≥ 0 with w = A p + q ≥ 0 and pᵀw = 0, A symmetric
//! positive definite (Cottle, Pang & Stone, *The Linear Complementarity
//! Problem*, 1992, §4.2). It is solved exactly by Murty's least-index
//! principal pivoting method (Murty 1974; Cottle, Pang & Stone Algorithm
//! 4.2.6): with an active set S the basic solution is p_S = −A_SS⁻¹ q_S,
//! p_i = 0 off S; the least index whose complementary variable is negative
//! (p_i < 0 in S, w_i < 0 off S) leaves or enters S. For a P-matrix (every
//! SPD matrix is one) the method ends after finitely many pivots from any
//! starting set, so a previous solution's active set serves as a warm start.
//!
//! With a local term φ_i(p_i) on the diagonal (the approach of each contact's
//! surfaces to the reference depths, [`LocalLaw`]) the problem
//! A p + φ(p) + q ≥ 0 ⊥ p ≥ 0 is the optimality condition of the strictly
//! convex J(p) = ½pᵀAp + Σ Φ_i(p_i) + qᵀp over p ≥ 0 (Φ_i' = φ_i, φ_i
//! increasing). It is solved by Newton steps whose subproblem is the LCP of
//! the linearised term (Josephy's method), each step a descent direction of J
//! (the subproblem minimises J's quadratic model), safeguarded by an Armijo
//! backtracking on J (Nocedal & Wright, *Numerical Optimization*, 2006, §3.1).

use thiserror::Error;

/// Why a complementarity problem could not be solved.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum LcpError {
    /// A matrix entry or vector component is NaN or infinite.
    #[error(
        "the complementarity problem's {what} has a non-finite entry at {index}; all entries must be finite"
    )]
    NotFinite {
        /// Which input: "matrix", "vector" or "local term".
        what: &'static str,
        /// Index of the offending entry (row-major for the matrix).
        index: usize,
    },
    /// The matrix does not have n × n entries for a vector of n.
    #[error("the matrix has {entries} entries for a vector of {n}; it must be square, n × n")]
    Shape {
        /// Entries given.
        entries: usize,
        /// Length of the vector q.
        n: usize,
    },
    /// A principal submatrix failed its Cholesky factorisation.
    #[error("the matrix is not positive definite (pivot {index}); the contact compliance must be symmetric positive definite")]
    NotPositiveDefinite {
        /// Index of the failing pivot.
        index: usize,
    },
    /// The pivoting or the Newton iteration hit its bound.
    #[error("no solution after {iterations} iterations; the bound is {limit}")]
    NoConvergence {
        /// Iterations made.
        iterations: usize,
        /// The bound.
        limit: usize,
    },
    /// The local term's tangent is not positive at a load: the problem is no
    /// longer convex there.
    #[error("the local contact term stops increasing at a pair load of {load} N (its limit is {limit} N); the load must stay below it")]
    LocalTermNotMonotone {
        /// Pair load reached \[N\].
        load: f64,
        /// The largest load at which the term still increases \[N\].
        limit: f64,
    },
}

/// Bound on the principal pivots of one LCP: far above the few pivots a
/// warm-started mesh problem takes, and above 2ⁿ for n ≤ 12.
pub const MAX_PIVOTS: usize = 4096;

/// Bound on the Newton steps of the nonlinear problem.
pub const MAX_NEWTON: usize = 60;

/// Checks the shape and finiteness of (A, q).
fn check(a: &[f64], q: &[f64]) -> Result<usize, LcpError> {
    let n = q.len();
    if a.len() != n * n {
        return Err(LcpError::Shape { entries: a.len(), n });
    }
    if let Some(index) = a.iter().position(|v| !v.is_finite()) {
        return Err(LcpError::NotFinite { what: "matrix", index });
    }
    if let Some(index) = q.iter().position(|v| !v.is_finite()) {
        return Err(LcpError::NotFinite { what: "vector", index });
    }
    Ok(n)
}

/// Solves A_SS x = b in place by Cholesky, S the indices `set` of the
/// row-major n × n matrix `a` (n² = `a.len()`); `work` holds the factor.
pub fn solve_spd(a: &[f64], set: &[usize], b: &mut [f64], work: &mut Vec<f64>) -> Result<(), LcpError> {
    let n = (a.len() as f64).sqrt().round() as usize;
    let m = set.len();
    work.clear();
    work.resize(m * m, 0.0);
    for (r, &i) in set.iter().enumerate() {
        for (c, &j) in set.iter().enumerate().take(r + 1) {
            let mut v = a[i * n + j];
            for k in 0..c {
                v -= work[r * m + k] * work[c * m + k];
            }
            if r == c {
                if v <= 0.0 || v.is_nan() {
                    return Err(LcpError::NotPositiveDefinite { index: i });
                }
                work[r * m + r] = v.sqrt();
            } else {
                work[r * m + c] = v / work[c * m + c];
            }
        }
    }
    for r in 0..m {
        let mut v = b[r];
        for k in 0..r {
            v -= work[r * m + k] * b[k];
        }
        b[r] = v / work[r * m + r];
    }
    for r in (0..m).rev() {
        let mut v = b[r];
        for k in r + 1..m {
            v -= work[k * m + r] * b[k];
        }
        b[r] = v / work[r * m + r];
    }
    Ok(())
}

/// The solution of one LCP and the workspace that produced it.
#[derive(Clone, Debug, Default)]
pub struct LcpSolution {
    /// p ≥ 0 (the pair forces \[N\] in a mesh problem).
    pub p: Vec<f64>,
    /// w = A p + q ≥ 0 (the remaining gaps \[m\] in a mesh problem).
    pub w: Vec<f64>,
    /// Which components are active (p_i basic).
    pub active: Vec<bool>,
    /// Principal pivots made.
    pub pivots: usize,
    set: Vec<usize>,
    rhs: Vec<f64>,
    work: Vec<f64>,
}

/// Solves LCP(A, q) for a symmetric positive definite A (row-major n × n),
/// starting from the active set `out.active` when it has n entries (a warm
/// start) and from the empty set otherwise.
///
/// A component counts as infeasible when it is below −tol, tol = 1e-14 times
/// the problem's scale (|q|∞ for w; |q|∞ over the largest diagonal entry
/// for p), so that ties and degenerate problems end instead of cycling on
/// rounding.
pub fn solve_lcp(a: &[f64], q: &[f64], out: &mut LcpSolution) -> Result<(), LcpError> {
    let n = check(a, q)?;
    if out.active.len() != n {
        out.active.clear();
        out.active.resize(n, false);
    }
    out.p.clear();
    out.p.resize(n, 0.0);
    out.w.clear();
    out.w.resize(n, 0.0);
    out.pivots = 0;
    let q_scale = q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diag_max = (0..n).fold(0.0f64, |m, i| m.max(a[i * n + i]));
    let tol_w = 1e-14 * q_scale;
    let tol_p = if diag_max > 0.0 { tol_w / diag_max } else { 0.0 };
    loop {
        out.set.clear();
        out.set.extend((0..n).filter(|&i| out.active[i]));
        out.rhs.clear();
        out.rhs.extend(out.set.iter().map(|&i| -q[i]));
        solve_spd(a, &out.set, &mut out.rhs, &mut out.work)?;
        out.p.iter_mut().for_each(|v| *v = 0.0);
        for (&i, &v) in out.set.iter().zip(&out.rhs) {
            out.p[i] = v;
        }
        for i in 0..n {
            out.w[i] = if out.active[i] {
                0.0
            } else {
                q[i] + (0..n).filter(|&j| out.active[j]).map(|j| a[i * n + j] * out.p[j]).sum::<f64>()
            };
        }
        let flip = (0..n).find(|&i| if out.active[i] { out.p[i] < -tol_p } else { out.w[i] < -tol_w });
        match flip {
            None => break,
            Some(i) => {
                if out.pivots == MAX_PIVOTS {
                    return Err(LcpError::NoConvergence { iterations: out.pivots, limit: MAX_PIVOTS });
                }
                out.active[i] = !out.active[i];
                out.pivots += 1;
            }
        }
    }
    // Components within the tolerance of zero are zero.
    for i in 0..n {
        out.p[i] = out.p[i].max(0.0);
        out.w[i] = out.w[i].max(0.0);
    }
    Ok(())
}

/// The local term of one contact, φ(P) = P·(a − c·ln P) \[m\] for a pair
/// load P \[N\]: the form of Johnson's 2-D approach of the surfaces to the
/// reference depths (see [`crate::contact::deformable::law`]), c ≥ 0; c = 0
/// is a linear compliance a [m/N].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalLaw {
    /// Constant part a [m/N] (with P in newtons inside the logarithm).
    pub a: f64,
    /// Logarithmic part c [m/N].
    pub c: f64,
}

impl LocalLaw {
    /// The approach φ(P) \[m\] at load `p` \[N\] (zero at zero load).
    pub fn approach(&self, p: f64) -> f64 {
        if p <= 0.0 {
            0.0
        } else {
            p * (self.a - self.c * p.ln())
        }
    }

    /// The tangent dφ/dP [m/N] at load `p` \[N\] (infinite at zero load when c > 0).
    pub fn tangent(&self, p: f64) -> f64 {
        if self.c == 0.0 {
            self.a
        } else if p <= 0.0 {
            f64::INFINITY
        } else {
            self.a - self.c - self.c * p.ln()
        }
    }

    /// Φ(P) = ∫₀ᴾ φ \[J\]: a P²/2 − c (P²/2 · ln P − P²/4).
    pub fn energy(&self, p: f64) -> f64 {
        if p <= 0.0 {
            0.0
        } else {
            0.5 * self.a * p * p - self.c * (0.5 * p * p * p.ln() - 0.25 * p * p)
        }
    }

    /// The largest load \[N\] at which φ still increases, exp((a − c)/c)
    /// (infinite for a linear term).
    pub fn monotone_limit(&self) -> f64 {
        if self.c == 0.0 {
            f64::INFINITY
        } else {
            ((self.a - self.c) / self.c).exp()
        }
    }
}

/// Workspace and result of [`solve_with_local`].
#[derive(Clone, Debug, Default)]
pub struct LocalSolution {
    /// The linearised problem's last solution (its `p` is the answer).
    pub lcp: LcpSolution,
    /// Newton steps taken.
    pub newton_steps: usize,
    /// The tangents φ'(p) [m/N] at the solution (those of open pairs at the
    /// floor load).
    pub tangent: Vec<f64>,
    m: Vec<f64>,
    qq: Vec<f64>,
    trial: Vec<f64>,
    p: Vec<f64>,
}

/// J(p) = ½pᵀAp + Σ Φ_i(p_i) + qᵀp \[J\].
fn objective(a: &[f64], q: &[f64], local: &[LocalLaw], p: &[f64]) -> f64 {
    let n = q.len();
    let mut v = 0.0;
    for i in 0..n {
        let row: f64 = (0..n).map(|j| a[i * n + j] * p[j]).sum();
        v += 0.5 * p[i] * row + local[i].energy(p[i]) + q[i] * p[i];
    }
    v
}

/// Solves A p + φ(p) + q ≥ 0 ⊥ p ≥ 0 for SPD A and increasing local terms
/// `local` (one per component), starting from `out.lcp.p` when it has n
/// entries. Converged when a Newton step changes no component by more than
/// `tol` times the largest component (and at least `floor` \[N\], the load
/// below which a component counts as zero and where an open pair's tangent
/// is read).
pub fn solve_with_local(
    a: &[f64],
    q: &[f64],
    local: &[LocalLaw],
    tol: f64,
    floor: f64,
    out: &mut LocalSolution,
) -> Result<(), LcpError> {
    let n = check(a, q)?;
    if local.len() != n {
        return Err(LcpError::Shape { entries: local.len(), n });
    }
    if let Some(index) = local.iter().position(|l| !(l.a.is_finite() && l.c.is_finite())) {
        return Err(LcpError::NotFinite { what: "local term", index });
    }
    out.p.clear();
    if out.lcp.p.len() == n {
        out.p.extend(out.lcp.p.iter().map(|v| v.max(0.0)));
    } else {
        out.p.resize(n, 0.0);
    }
    out.newton_steps = 0;
    loop {
        // The linearisation at the current loads: M = A + diag(t), q̃ = q + φ(p) − t∘p.
        out.tangent.clear();
        for (law, &p) in local.iter().zip(&out.p) {
            let at = p.max(floor);
            let t = law.tangent(at);
            if t.is_nan() || t <= 0.0 {
                return Err(LcpError::LocalTermNotMonotone { load: at, limit: law.monotone_limit() });
            }
            out.tangent.push(t);
        }
        out.m.clear();
        out.m.extend_from_slice(a);
        out.qq.clear();
        for i in 0..n {
            out.m[i * n + i] += out.tangent[i];
            out.qq.push(q[i] + local[i].approach(out.p[i]) - out.tangent[i] * out.p[i]);
        }
        solve_lcp(&out.m, &out.qq, &mut out.lcp)?;
        let scale = out.p.iter().chain(&out.lcp.p).fold(floor, |m, v| m.max(*v));
        let step = out.p.iter().zip(&out.lcp.p).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        if step <= tol * scale {
            out.p.clone_from(&out.lcp.p);
            return Ok(());
        }
        if out.newton_steps == MAX_NEWTON {
            return Err(LcpError::NoConvergence { iterations: out.newton_steps, limit: MAX_NEWTON });
        }
        out.newton_steps += 1;
        // Armijo backtracking on J along the feasible segment to the subproblem's solution.
        let j0 = objective(a, q, local, &out.p);
        let slope: f64 = (0..n)
            .map(|i| {
                let grad =
                    (0..n).map(|j| a[i * n + j] * out.p[j]).sum::<f64>() + local[i].approach(out.p[i]) + q[i];
                grad * (out.lcp.p[i] - out.p[i])
            })
            .sum();
        let mut alpha = 1.0;
        loop {
            out.trial.clear();
            out.trial.extend(out.p.iter().zip(&out.lcp.p).map(|(x, y)| x + alpha * (y - x)));
            let j1 = objective(a, q, local, &out.trial);
            // Near the solution J's differences are rounding: a full step is then taken.
            if j1 <= j0 + 1e-4 * alpha * slope || alpha < 1e-6 || (j1 - j0).abs() <= 1e-14 * j0.abs() {
                break;
            }
            alpha *= 0.5;
        }
        std::mem::swap(&mut out.p, &mut out.trial);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded generator (SplitMix64), so the random problems are the same on every run.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A random SPD matrix BᵀB + εI, row-major.
    fn spd(n: usize, rng: &mut Rng) -> Vec<f64> {
        let b: Vec<f64> = (0..n * n).map(|_| 2.0 * rng.next() - 1.0).collect();
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = (0..n).map(|k| b[k * n + i] * b[k * n + j]).sum::<f64>()
                    + if i == j { 0.05 } else { 0.0 };
            }
        }
        a
    }

    /// Complementarity residuals relative to the problem's scale: min p, min w, max |p_i w_i|.
    fn residuals(a: &[f64], q: &[f64], p: &[f64]) -> (f64, f64, f64) {
        let n = q.len();
        let scale = q.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
        let diag = (0..n).fold(0.0f64, |m, i| m.max(a[i * n + i]));
        let mut worst = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..n {
            let w = q[i] + (0..n).map(|j| a[i * n + j] * p[j]).sum::<f64>();
            worst.0 = worst.0.max(-p[i] * diag / scale);
            worst.1 = worst.1.max(-w / scale);
            worst.2 = worst.2.max((p[i] * w).abs() * diag / (scale * scale));
        }
        worst
    }

    /// Every active set of a small problem tried in turn: the complementary
    /// basic solution that is feasible (unique for a P-matrix).
    fn brute_force(a: &[f64], q: &[f64]) -> Vec<f64> {
        let n = q.len();
        let mut found = None;
        for mask in 0..(1u32 << n) {
            let set: Vec<usize> = (0..n).filter(|i| mask & (1 << i) != 0).collect();
            let mut rhs: Vec<f64> = set.iter().map(|&i| -q[i]).collect();
            solve_spd(a, &set, &mut rhs, &mut Vec::new()).unwrap();
            let mut p = vec![0.0; n];
            for (&i, &v) in set.iter().zip(&rhs) {
                p[i] = v;
            }
            let (np, nw, _) = residuals(a, q, &p);
            if np <= 1e-12 && nw <= 1e-12 {
                assert!(found.is_none(), "two feasible complementary solutions");
                found = Some(p);
            }
        }
        found.expect("a P-matrix LCP has a solution")
    }

    /// Random SPD problems up to n = 6: the complementarity conditions hold
    /// to 1e-12 relative and the solution is brute-force enumeration's to 1e-10.
    #[test]
    fn random_spd_problems_are_solved_exactly() {
        let mut rng = Rng(7);
        let mut out = LcpSolution::default();
        for trial in 0..600 {
            let n = 1 + trial % 6;
            let a = spd(n, &mut rng);
            let q: Vec<f64> = (0..n).map(|_| 2.0 * rng.next() - 1.0).collect();
            out.active.clear();
            solve_lcp(&a, &q, &mut out).unwrap();
            let (np, nw, comp) = residuals(&a, &q, &out.p);
            assert!(np <= 1e-12 && nw <= 1e-12 && comp <= 1e-12, "trial {trial}: {np} {nw} {comp}");
            let want = brute_force(&a, &q);
            let size = want.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
            for (x, y) in out.p.iter().zip(&want) {
                assert!((x - y).abs() <= 1e-10 * size, "trial {trial}: {:?} vs {want:?}", out.p);
            }
        }
    }

    /// A warm start from any active set reaches the same solution.
    #[test]
    fn warm_starts_from_any_active_set_agree() {
        let mut rng = Rng(11);
        for _ in 0..100 {
            let n = 5;
            let a = spd(n, &mut rng);
            let q: Vec<f64> = (0..n).map(|_| 2.0 * rng.next() - 1.0).collect();
            let mut cold = LcpSolution::default();
            solve_lcp(&a, &q, &mut cold).unwrap();
            for mask in 0..32u32 {
                let mut warm = LcpSolution {
                    active: (0..n).map(|i| mask & (1 << i) != 0).collect(),
                    ..Default::default()
                };
                solve_lcp(&a, &q, &mut warm).unwrap();
                for (x, y) in warm.p.iter().zip(&cold.p) {
                    assert!((x - y).abs() <= 1e-12 * (1.0 + y.abs()));
                }
            }
        }
    }

    /// Degenerate cases: all gaps open (q ≥ 0 gives p = 0), all closed (p = −A⁻¹q > 0),
    /// ties (q_i = 0: p_i = 0 = w_i) and an empty problem.
    #[test]
    fn degenerate_problems() {
        let a = vec![2.0, 0.5, 0.0, 0.5, 2.0, 0.5, 0.0, 0.5, 2.0];
        let mut out = LcpSolution::default();
        solve_lcp(&a, &[1.0, 0.0, 3.0], &mut out).unwrap();
        assert_eq!(out.p, vec![0.0; 3]);
        solve_lcp(&a, &[-1.0, -1.0, -1.0], &mut out).unwrap();
        // Closed form of the symmetric tridiagonal system: p = (3/7, 2/7, 3/7)·... solved exactly.
        let p = &out.p;
        for i in 0..3 {
            let w: f64 = -1.0 + (0..3).map(|j| a[i * 3 + j] * p[j]).sum::<f64>();
            assert!(w.abs() < 1e-15 && p[i] > 0.0);
        }
        assert!((p[0] - p[2]).abs() < 1e-15 && (2.0 * p[0] + 0.5 * p[1] - 1.0).abs() < 1e-15);
        // A tie: the second component's gap closes exactly when the first carries its load.
        // w_1 = −0.25 + 0.5·0.5 = 0 and w_2 = 0 with p_1 = p_2 = 0: both ties.
        solve_lcp(&a, &[-1.0, -0.25, 0.0], &mut out).unwrap();
        assert!((out.p[0] - 0.5).abs() < 1e-15, "{:?} {:?}", out.p, out.w);
        assert!(
            out.p[1] < 1e-15 && out.w[1] < 1e-15 && out.p[2] == 0.0 && out.w[2] == 0.0,
            "{:?} {:?}",
            out.p,
            out.w
        );
        solve_lcp(&[], &[], &mut out).unwrap();
        assert!(out.p.is_empty());
    }

    /// Bad inputs give their error, not a panic or NaN.
    #[test]
    fn bad_inputs_are_errors() {
        let mut out = LcpSolution::default();
        assert_eq!(
            solve_lcp(&[1.0, f64::NAN, 0.0, 1.0], &[0.0, 0.0], &mut out),
            Err(LcpError::NotFinite { what: "matrix", index: 1 })
        );
        assert_eq!(
            solve_lcp(&[1.0], &[f64::INFINITY], &mut out),
            Err(LcpError::NotFinite { what: "vector", index: 0 })
        );
        assert_eq!(solve_lcp(&[1.0, 0.0], &[1.0], &mut out), Err(LcpError::Shape { entries: 2, n: 1 }));
        assert_eq!(solve_lcp(&[-1.0], &[-1.0], &mut out), Err(LcpError::NotPositiveDefinite { index: 0 }));
    }

    /// With a logarithmic local term the solution satisfies
    /// A p + φ(p) + q ≥ 0 ⊥ p ≥ 0 to 1e-12 of the gaps' scale, and
    /// φ, Φ agree: Φ' = φ by central differences to 1e-7.
    #[test]
    fn nonlinear_local_term_is_solved() {
        let law = LocalLaw { a: 2.0e-9, c: 1.0e-10 };
        for p in [1.0, 10.0, 1e3, 1e4] {
            let h = 1e-4 * p;
            let d = (law.energy(p + h) - law.energy(p - h)) / (2.0 * h);
            assert!((d / law.approach(p) - 1.0).abs() < 1e-7);
            let t = (law.approach(p + h) - law.approach(p - h)) / (2.0 * h);
            assert!((t / law.tangent(p) - 1.0).abs() < 1e-7);
        }
        let mut rng = Rng(3);
        let mut out = LocalSolution::default();
        for _ in 0..200 {
            let n = 1 + (rng.next() * 5.0) as usize;
            let mut a = spd(n, &mut rng);
            a.iter_mut().for_each(|v| *v *= 1e-9);
            let q: Vec<f64> = (0..n).map(|_| (2.0 * rng.next() - 1.5) * 1e-5).collect();
            let local = vec![law; n];
            out.lcp.p.clear();
            solve_with_local(&a, &q, &local, 1e-13, 1e-9, &mut out).unwrap();
            let scale = q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for i in 0..n {
                let p = out.lcp.p[i];
                let w = q[i] + law.approach(p) + (0..n).map(|j| a[i * n + j] * out.lcp.p[j]).sum::<f64>();
                assert!(p >= 0.0 && w >= -1e-12 * scale, "{p} {w}");
                if p > 1e-6 {
                    assert!(w.abs() <= 1e-12 * scale, "active pair with gap {w}");
                }
            }
        }
    }
}
