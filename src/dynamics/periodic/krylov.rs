//! Newton steps of the harmonic balance without its dense LU: the Jacobian as
//! an operator (`Operator`), GMRES without restarts on it, preconditioned by
//! the sparse LU of the Jacobian's band of neighbouring harmonics
//! (docs/PERIODIC.md §2).
//!
//! The balance's Jacobian couples every kept harmonic with every other
//! through the Fourier coefficients of the tangent stiffness and damping
//! along the orbit; its dense LU costs (2/3)(m(2H + 1))³ flops, 4 Gflop at
//! 600 rpm on the torsional example (H = 180). Its product with a vector
//! costs two transforms per coordinate instead (the tangents applied sample
//! by sample), and the harmonics within a few of each other carry most of
//! the coupling: with the band of ±[`KRYLOV_BAND`] harmonics factorised as
//! the preconditioner, GMRES reaches a relative residual of 1e-9 in 14 to
//! 33 products from 300 to 1800 unknowns (measured, docs/PERIODIC.md §2),
//! where the harmonic blocks alone take 24 to 116. Newton's steps stop
//! at the looser [`KRYLOV_TOLERANCE`].

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use rustfft::num_complex::Complex;

use super::series::{analyse_with, derivative_coefficient, synthesize_with, Plans};
use super::PeriodicError;

/// Harmonics on either side of each harmonic that the preconditioner keeps of
/// the Jacobian (docs/PERIODIC.md §2).
pub const KRYLOV_BAND: usize = 2;

/// GMRES stops when the residual of the Newton step's linear system is at most
/// this fraction of its right-hand side: an inexact Newton step (its forcing
/// term). The root is where the residual vanishes, whatever the steps' accuracy;
/// a step this inexact only changes how fast the iterations contract, by
/// about this fraction. The iterations on the projected residual contract by
/// 0.2 to 0.5 each already (the plain sums' Jacobian is not the projected
/// residual's), and the plain sums' run hands over after a step of 1e-2 of
/// the coefficients ([`super::HANDOVER_STEP`]), before a contraction of 1e-4
/// could show. Measured on the torsional example against the
/// former 1e-10 (docs/PERIODIC.md §2): the continuation from 500 to 2000 rpm
/// took half the products (up 5298 → 2656, down 5009 → 2565) at the same
/// points and, on 83 of 84 points, the same corrections (speeds within 3e-4
/// rpm); single solves 500 and 1000 rpm and transverse–torsional 3000 and
/// 8000 rpm the same orbits to E_h 5e-10. At 1e-3 the down run took other
/// steps (38 points instead of 41).
pub const KRYLOV_TOLERANCE: f64 = 1e-4;

/// Most GMRES iterations per Newton step; a step that has not reached
/// [`KRYLOV_TOLERANCE`] by then is taken as it is (the line search judges it).
pub const KRYLOV_ITERATIONS: usize = 200;

/// The sparsity of the Jacobian's band: column-compressed, each column's rows
/// one contiguous range (the harmonics within the band of its own), with
/// faer's symbolic LU of it, computed once per H.
pub(super) struct BandPattern {
    m: usize,
    harmonics: usize,
    band: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// First row of each column.
    first: Vec<usize>,
    symbolic: SymbolicLu<usize>,
}

impl BandPattern {
    /// The band of ±`band` harmonics of m coordinates and H harmonics.
    pub(super) fn new(m: usize, harmonics: usize, band: usize) -> Result<Self, PeriodicError> {
        let size = m * (2 * harmonics + 1);
        let (mut col_ptr, mut row_idx, mut first) = (vec![0], Vec::new(), Vec::with_capacity(size));
        for col in 0..size {
            let k = harmonic(col, m);
            let (lo, hi) = (block_start(k.saturating_sub(band), m), block_end((k + band).min(harmonics), m));
            first.push(lo);
            row_idx.extend(lo..hi);
            col_ptr.push(row_idx.len());
        }
        let symbolic = SymbolicLu::try_new(SymbolicSparseColMatRef::new_checked(
            size, size, &col_ptr, None, &row_idx,
        ))
        .map_err(|e| PeriodicError::invalid("harmonics", harmonics as f64, &format!("band LU: {e:?}")))?;
        Ok(Self { m, harmonics, band, col_ptr, row_idx, first, symbolic })
    }

    /// Whether this pattern is the one of `m`, `harmonics` and `band`.
    pub(super) fn is(&self, m: usize, harmonics: usize, band: usize) -> bool {
        (self.m, self.harmonics, self.band) == (m, harmonics, band)
    }

    /// Entries in the band.
    pub(super) fn len(&self) -> usize {
        self.row_idx.len()
    }

    /// The band's harmonics on either side.
    pub(super) fn band(&self) -> usize {
        self.band
    }

    /// The position of entry (`row`, `col`) among the band's values, if it lies in the band.
    #[inline]
    pub(super) fn index(&self, row: usize, col: usize) -> Option<usize> {
        let at = self.col_ptr[col] + row.checked_sub(self.first[col])?;
        (at < self.col_ptr[col + 1]).then_some(at)
    }

    /// The rows of column `col` in the band: the first and the end.
    pub(super) fn rows(&self, col: usize) -> (usize, usize) {
        (self.first[col], self.first[col] + self.col_ptr[col + 1] - self.col_ptr[col])
    }

    /// faer's sparse LU of the band with `values` (in the pattern's order).
    pub(super) fn factorize(&self, values: &[f64]) -> Result<Lu<usize, f64>, PeriodicError> {
        let size = self.first.len();
        let structure = SymbolicSparseColMatRef::new_checked(size, size, &self.col_ptr, None, &self.row_idx);
        Lu::try_new_with_symbolic(self.symbolic.clone(), SparseColMatRef::new(structure, values)).map_err(
            |e| PeriodicError::InvalidRequest {
                name: "harmonic-balance Jacobian".into(),
                value: format!("its band of ±{} harmonics", self.band),
                reason: format!(
                    "faer's sparse LU of it failed ({e:?}): the iterate diverged or the band is singular"
                ),
            },
        )
    }
}

/// The harmonic of unknown `i` (coefficient block ⌈c/2⌉, blocks of m).
#[inline]
pub(super) fn harmonic(i: usize, m: usize) -> usize {
    (i / m).div_ceil(2)
}

/// The first unknown of harmonic `k`.
fn block_start(k: usize, m: usize) -> usize {
    if k == 0 {
        0
    } else {
        (2 * k - 1) * m
    }
}

/// One past the last unknown of harmonic `k`.
fn block_end(k: usize, m: usize) -> usize {
    (2 * k + 1) * m
}

/// The preconditioner's solve in place: `v` ← B⁻¹ `v`.
pub(super) fn precondition(lu: &Lu<usize, f64>, v: &mut [f64]) {
    let n = v.len();
    let mut column = faer::Mat::<f64>::from_fn(n, 1, |i, _| v[i]);
    lu.solve_in_place(column.as_mut());
    v.iter_mut().enumerate().for_each(|(i, x)| *x = column[(i, 0)]);
}

/// What one GMRES solve took.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct GmresReport {
    /// Products with the operator.
    pub products: usize,
}

/// x with A x ≈ `rhs` by GMRES without restarts, right-preconditioned:
/// `apply(v, out)` sets out = A v, `precondition(v)` replaces v by B⁻¹ v.
/// Stops at a residual of `tolerance` times |rhs| or after `max_iterations`
/// products (Saad, Iterative Methods for Sparse Linear Systems, 2nd ed.,
/// Algorithm 9.5, with Givens rotations for the least-squares problem).
pub(super) fn gmres(
    mut apply: impl FnMut(&[f64], &mut [f64]),
    mut precondition: impl FnMut(&mut [f64]),
    rhs: &[f64],
    tolerance: f64,
    max_iterations: usize,
) -> (Vec<f64>, GmresReport) {
    let n = rhs.len();
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let beta = norm(rhs);
    if beta == 0.0 || !beta.is_finite() {
        return (vec![if beta == 0.0 { 0.0 } else { f64::NAN }; n], GmresReport { products: 0 });
    }
    let mut basis: Vec<Vec<f64>> = vec![rhs.iter().map(|x| x / beta).collect()];
    // Columns of the Hessenberg matrix after the rotations (upper triangular).
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let (mut cosines, mut sines) = (Vec::<f64>::new(), Vec::<f64>::new());
    let mut g = vec![beta];
    let (mut z, mut w) = (vec![0.0; n], vec![0.0; n]);
    while columns.len() < max_iterations {
        let j = columns.len();
        z.copy_from_slice(&basis[j]);
        precondition(&mut z);
        apply(&z, &mut w);
        // Modified Gram–Schmidt.
        let mut column = vec![0.0; j + 2];
        for (i, q) in basis.iter().enumerate() {
            let d: f64 = w.iter().zip(q).map(|(a, b)| a * b).sum();
            column[i] = d;
            w.iter_mut().zip(q).for_each(|(a, b)| *a -= d * b);
        }
        let length = norm(&w);
        column[j + 1] = length;
        for i in 0..j {
            let t = cosines[i] * column[i] + sines[i] * column[i + 1];
            column[i + 1] = -sines[i] * column[i] + cosines[i] * column[i + 1];
            column[i] = t;
        }
        let r = column[j].hypot(column[j + 1]);
        let (c, s) = if r == 0.0 { (1.0, 0.0) } else { (column[j] / r, column[j + 1] / r) };
        cosines.push(c);
        sines.push(s);
        column[j] = r;
        column.truncate(j + 1);
        g.push(-s * g[j]);
        g[j] *= c;
        columns.push(column);
        let residual = g[j + 1].abs() / beta;
        if residual <= tolerance || length == 0.0 || !residual.is_finite() {
            break;
        }
        basis.push(w.iter().map(|x| x / length).collect());
    }
    // y from the triangular system, x = B⁻¹ V y.
    let k = columns.len();
    let mut y = vec![0.0; k];
    for i in (0..k).rev() {
        let s = g[i] - (i + 1..k).map(|l| columns[l][i] * y[l]).sum::<f64>();
        y[i] = s / columns[i][i];
    }
    let mut x = vec![0.0; n];
    for (q, yi) in basis.iter().zip(&y) {
        x.iter_mut().zip(q).for_each(|(a, b)| *a += yi * b);
    }
    precondition(&mut x);
    (x, GmresReport { products: k })
}

/// The balance's Jacobian at one point as an operator, for GMRES (module `krylov`):
/// its product with a vector from the tangent sequences sample by sample (two transforms
/// per coordinate), the inertia per harmonic and the switches' rank-one time terms; and
/// the sparse LU of its band of neighbouring harmonics as the preconditioner.
pub(super) struct Operator {
    pub(super) m: usize,
    pub(super) harmonics: usize,
    /// The transforms of the evaluation's N samples.
    pub(super) plans: Plans,
    /// ν [rad/s], the deflection scale, PᵀMP and the rows' scale (as [`Inertia`]).
    pub(super) nu: f64,
    pub(super) q_scale: f64,
    pub(super) mass: Vec<f64>,
    pub(super) row: Vec<f64>,
    /// The evaluation's tangent sequences, as `HarmonicBalance::evaluate` keeps them.
    pub(super) tangents: Vec<f64>,
    /// The switches' time terms u vᵀ.
    pub(super) terms: Vec<(Vec<f64>, Vec<f64>)>,
    /// The band's pattern, values and LU.
    pub(super) pattern: BandPattern,
    pub(super) band: Vec<f64>,
    pub(super) lu: faer::sparse::linalg::solvers::Lu<usize, f64>,
}

impl Operator {
    /// `out` = J `d`.
    pub(super) fn apply(&self, d: &[f64], out: &mut [f64]) {
        let (m, h) = (self.m, self.harmonics);
        let plans = &self.plans;
        let ns = plans.len();
        let mut buffer = vec![Complex::new(0.0, 0.0); ns];
        // δy and δẏ of each coordinate, coordinate-major.
        let (mut y, mut yd) = (vec![0.0; ns * m], vec![0.0; ns * m]);
        let nu = self.nu;
        for b in 0..m {
            synthesize_with(plans, h, |c| d[c * m + b], &mut buffer, &mut y[b * ns..][..ns]);
            let velocity = |c| derivative_coefficient(|c| d[c * m + b], c, nu);
            synthesize_with(plans, h, velocity, &mut buffer, &mut yd[b * ns..][..ns]);
        }
        let mut g = vec![0.0; ns];
        let mut coefficients = vec![0.0; 2 * h + 1];
        for a in 0..m {
            g.iter_mut().for_each(|v| *v = 0.0);
            for b in 0..m {
                let k = &self.tangents[(b * m + a) * ns..][..ns];
                let c = &self.tangents[((m + b) * m + a) * ns..][..ns];
                let (yb, ydb) = (&y[b * ns..][..ns], &yd[b * ns..][..ns]);
                for j in 0..ns {
                    g[j] += k[j] * yb[j] + c[j] * ydb[j];
                }
            }
            analyse_with(plans, h, &g, &mut buffer, &mut coefficients);
            for (cc, value) in coefficients.iter().enumerate() {
                out[cc * m + a] = self.q_scale * self.row[a] * value;
            }
        }
        let inertia = Inertia { mass: &self.mass, row: &self.row, nu, q_scale: self.q_scale };
        for cc in 1..=2 * h {
            for a in 0..m {
                out[cc * m + a] += (0..m).map(|b| inertia.at(cc, a, b) * d[cc * m + b]).sum::<f64>();
            }
        }
        for (u, v) in &self.terms {
            let along: f64 = v.iter().zip(d).map(|(p, q)| p * q).sum();
            out.iter_mut().zip(u).for_each(|(o, w)| *o += along * w);
        }
    }
}

/// The inertia terms of the balance's Jacobian: −k²ν² PᵀMP on harmonic k, scaled to the row.
pub(super) struct Inertia<'a> {
    /// PᵀMP, m × m column-major.
    pub(super) mass: &'a [f64],
    /// The rows' scale.
    pub(super) row: &'a [f64],
    pub(super) nu: f64,
    pub(super) q_scale: f64,
}

impl Inertia<'_> {
    /// The entry (a, b) of coefficient block `cc`'s inertia.
    #[inline]
    pub(super) fn at(&self, cc: usize, a: usize, b: usize) -> f64 {
        let k = cc.div_ceil(2) as f64;
        let m = self.row.len();
        -k * k * self.mass[a + m * b] * self.row[a] * self.nu * self.nu * self.q_scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A non-symmetric, diagonally weighted test matrix of size n, column-major.
    fn matrix(n: usize) -> Vec<f64> {
        (0..n * n)
            .map(|idx| {
                let (i, j) = (idx % n, idx / n);
                let v = ((i * 31 + j * 17) % 23) as f64 / 23.0 - 0.4;
                if i == j {
                    4.0 + i as f64 * 0.1
                } else {
                    v / (1.0 + i.abs_diff(j) as f64)
                }
            })
            .collect()
    }

    fn times(a: &[f64], v: &[f64], out: &mut [f64]) {
        let n = v.len();
        out.iter_mut().enumerate().for_each(|(i, o)| *o = (0..n).map(|j| a[i + n * j] * v[j]).sum());
    }

    /// GMRES without a preconditioner solves a non-symmetric system to its
    /// tolerance: A x − b is at most the tolerance times |b|, and x agrees
    /// with the dense LU's solution.
    #[test]
    fn gmres_solves_a_non_symmetric_system_to_its_tolerance() {
        let n = 60;
        let a = matrix(n);
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let (x, report) = gmres(|v, out| times(&a, v, out), |_| {}, &b, 1e-12, 200);
        let mut ax = vec![0.0; n];
        times(&a, &x, &mut ax);
        let miss = ax.iter().zip(&b).map(|(p, q)| (p - q).powi(2)).sum::<f64>().sqrt();
        let size = b.iter().map(|q| q * q).sum::<f64>().sqrt();
        assert!(miss <= 1e-11 * size, "|Ax − b| = {miss:e} of {size:e}");
        assert!(report.products <= n, "{report:?}");
        let exact =
            faer::Mat::<f64>::from_fn(n, n, |i, j| a[i + n * j])
                .partial_piv_lu()
                .solve(faer::Mat::<f64>::from_fn(n, 1, |i, _| b[i]));
        let off = (0..n).map(|i| (x[i] - exact[(i, 0)]).abs()).fold(0.0, f64::max);
        assert!(off <= 1e-10, "off the LU's solution by {off:e}");
    }

    /// With the exact inverse as its preconditioner GMRES takes one product;
    /// with a band of the matrix, fewer than without.
    #[test]
    fn the_band_preconditioner_cuts_the_products() {
        let (m, h) = (2, 10);
        let pattern = BandPattern::new(m, h, 1).unwrap();
        let n = m * (2 * h + 1);
        let a = matrix(n);
        let mut values = vec![0.0; pattern.len()];
        for col in 0..n {
            let (lo, hi) = pattern.rows(col);
            for row in lo..hi {
                values[pattern.index(row, col).unwrap()] = a[row + n * col];
            }
        }
        // Outside the band: no index.
        assert_eq!(pattern.index(n - 1, 0), None);
        assert_eq!(pattern.index(0, n - 1), None);
        let lu = pattern.factorize(&values).unwrap();
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.71).cos()).collect();
        let (_, plain) = gmres(|v, out| times(&a, v, out), |_| {}, &b, 1e-10, 200);
        let (x, banded) = gmres(|v, out| times(&a, v, out), |v| precondition(&lu, v), &b, 1e-10, 200);
        assert!(banded.products < plain.products, "{banded:?} against {plain:?}");
        let mut ax = vec![0.0; n];
        times(&a, &x, &mut ax);
        let miss = ax.iter().zip(&b).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
        assert!(miss <= 1e-8, "{miss:e}");
        // The whole matrix as the band: one product.
        let whole = BandPattern::new(m, h, h).unwrap();
        let all: Vec<f64> = (0..n * n).map(|idx| a[idx]).collect();
        let (_, exact) = gmres(
            |v, out| times(&a, v, out),
            |v| precondition(&whole.factorize(&all).unwrap(), v),
            &b,
            1e-10,
            200,
        );
        assert_eq!(exact.products, 1, "{exact:?}");
    }

    /// A singular band (all zeros) factorises, but its solve is not finite: GMRES with it
    /// stops at once and returns a step that is not finite, which Newton reports as not
    /// converged, rather than looping or panicking.
    #[test]
    fn a_singular_band_gives_a_step_that_is_not_finite() {
        let (m, h) = (2, 4);
        let pattern = BandPattern::new(m, h, 1).unwrap();
        let lu = pattern.factorize(&vec![0.0; pattern.len()]).unwrap();
        let n = m * (2 * h + 1);
        let a = matrix(n);
        let b = vec![1.0; n];
        let (x, report) = gmres(|v, out| times(&a, v, out), |v| precondition(&lu, v), &b, 1e-10, 200);
        assert!(x.iter().any(|v| !v.is_finite()), "{x:?}");
        assert!(report.products <= 1, "{report:?}");
    }
}
