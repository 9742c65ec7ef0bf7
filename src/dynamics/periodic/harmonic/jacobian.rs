//! The balance's Jacobian and Newton's step on it: the Fourier convolution
//! of the tangent sequences and the inertia, assembled entry by entry; the
//! dense LU that factorises it, or the operator GMRES takes beyond
//! [`DENSE_UNKNOWNS`](super::DENSE_UNKNOWNS); the counters of a solve's Newton runs.

use crate::dynamics::periodic::krylov::{
    gmres, precondition, Inertia, Operator, KRYLOV_ITERATIONS, KRYLOV_TOLERANCE,
};

/// faer's LU with partial pivoting of a square matrix, factorised in place in
/// storage kept from one factorisation to the next (faer's `PartialPivLu`
/// allocates and zeroes its two factors each time: at 3000 rpm 2 × 1.5 MB
/// paged in per point). The arithmetic is faer's, the same as
/// `PartialPivLu`'s.
pub(super) struct DenseLu {
    /// L below the diagonal (unit diagonal implied) and U on and above it.
    factor: faer::Mat<f64>,
    forward: Vec<usize>,
    inverse: Vec<usize>,
}

impl Default for DenseLu {
    fn default() -> Self {
        Self { factor: faer::Mat::zeros(0, 0), forward: Vec::new(), inverse: Vec::new() }
    }
}

impl DenseLu {
    /// Factorises the column-major `n` × `n` matrix `a`.
    pub(super) fn factorize(&mut self, a: &[f64], n: usize) {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
        if self.factor.nrows() != n {
            self.factor = faer::Mat::zeros(n, n);
        }
        self.factor.copy_from(faer::MatRef::from_column_major_slice(a, n, n));
        self.forward.resize(n, 0);
        self.inverse.resize(n, 0);
        let par = faer::get_global_parallelism();
        let mut memory = MemBuffer::new(lu_in_place_scratch::<usize, f64>(n, n, par, Default::default()));
        lu_in_place(
            self.factor.as_mut(),
            &mut self.forward,
            &mut self.inverse,
            par,
            MemStack::new(&mut memory),
            Default::default(),
        );
    }

    /// The Newton step −J⁻¹ r.
    pub(super) fn step(&self, r: &[f64]) -> Vec<f64> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::lu::partial_pivoting::solve::{solve_in_place, solve_in_place_scratch};
        let n = r.len();
        let mut x = faer::Mat::<f64>::from_fn(n, 1, |i, _| -r[i]);
        let par = faer::get_global_parallelism();
        let permutation = faer::perm::PermRef::new_checked(&self.forward, &self.inverse, n);
        let mut memory = MemBuffer::new(solve_in_place_scratch::<usize, f64>(n, 1, par));
        let lu = self.factor.as_ref();
        solve_in_place(lu, lu, permutation, x.as_mut(), par, MemStack::new(&mut memory));
        (0..n).map(|i| x[(i, 0)]).collect()
    }
}

/// The Fourier coefficients of the tangent sequences of one coordinate pair (a, b), scaled
/// to row a, p = 0 ..= 2H: the stiffness's cosine and sine sums `kc`, `ks` and the
/// damping's `cc`, `cs` (the damping's also by ν).
pub(super) struct PairSpectrum {
    pub(super) kc: Vec<f64>,
    pub(super) ks: Vec<f64>,
    pub(super) cc: Vec<f64>,
    pub(super) cs: Vec<f64>,
}

/// The balance's Jacobian, the tangent and inertia terms, entry by entry into `put(row,
/// column, value)`: the entries whose harmonics lie at most `band` apart (all with band =
/// H). Each entry is put once, so the sums are those of the dense assembly whatever the
/// band. `spectra` holds the pairs (a, b) b-major.
pub(super) fn assemble(
    m: usize,
    h: usize,
    band: usize,
    spectra: &[PairSpectrum],
    inertia: &Inertia<'_>,
    mut put: impl FnMut(usize, usize, f64),
) {
    for b in 0..m {
        for a in 0..m {
            pair_entries(h, band, &spectra[b * m + a], |row_block, col_block, v| {
                put(row_block * m + a, col_block * m + b, v)
            });
        }
    }
    for cc in 1..=2 * h {
        for b in 0..m {
            for a in 0..m {
                put(cc * m + a, cc * m + b, inertia.at(cc, a, b));
            }
        }
    }
}

/// The entries of one tangent pair's Fourier convolution, ∂(coefficients of τ·y + γ·ẏ)/∂(coefficients
/// of y), as `put(row block, column block, value)`: τ, γ the pair's stiffness and damping
/// sequences (`spectrum`), the entries whose harmonics lie at most `band` apart (all with band
/// = H). Blocks as in
/// [`HarmonicOrbit::coefficients`](super::HarmonicOrbit::coefficients).
pub(super) fn pair_entries(
    h: usize,
    band: usize,
    spectrum: &PairSpectrum,
    mut put: impl FnMut(usize, usize, f64),
) {
    let PairSpectrum { kc, ks, cc, cs } = spectrum;
    // Σ ψ_l x φ_c by the product-to-sum identities, ψ the test functions
    // (1; 2cos lθ; 2sin lθ, with the 1/N of the spectra), φ the basis functions.
    let mut add = |(r, c): (usize, usize), v: f64| put(r, c, v);
    add((0, 0), kc[0]);
    for c in 1..=h.min(band) {
        let cf = c as f64;
        // Row of the constant: (1/N) Σ x cos cθ and Σ x sin cθ; with the damping of
        // ẏ: cos → −c sin, sin → c cos.
        add((0, 2 * c - 1), kc[c] - cf * cs[c]);
        add((0, 2 * c), ks[c] + cf * cc[c]);
        // Column of the constant (no velocity).
        add((2 * c - 1, 0), 2.0 * kc[c]);
        add((2 * c, 0), 2.0 * ks[c]);
    }
    for l in 1..=h {
        for c in l.saturating_sub(band).max(1)..=(l + band).min(h) {
            let cf = c as f64;
            let d = l.abs_diff(c);
            // ks(c − l), odd in its argument.
            let sign = if c >= l { 1.0 } else { -1.0 };
            let (ka, kb, ks1, ks2) = (kc[d], kc[l + c], ks[l + c], sign * ks[d]);
            let (ca, cb, cs1, cs2) = (cc[d], cc[l + c], cs[l + c], sign * cs[d]);
            // (cos l, cos c) = A + B, (cos l, sin c) = S₁ + S₂,
            // (sin l, cos c) = S₁ − S₂, (sin l, sin c) = A − B.
            add((2 * l - 1, 2 * c - 1), ka + kb - cf * (cs1 + cs2));
            add((2 * l - 1, 2 * c), ks1 + ks2 + cf * (ca + cb));
            add((2 * l, 2 * c - 1), ks1 - ks2 - cf * (ca - cb));
            add((2 * l, 2 * c), ka - kb + cf * (cs1 - cs2));
        }
    }
}

/// The Jacobian an evaluation assembles for Newton's step: dense (column-major), with its
/// LU's storage, or as the operator GMRES takes where the unknowns exceed
/// [`DENSE_UNKNOWNS`](super::DENSE_UNKNOWNS) (none before the first evaluation).
pub(super) enum Jacobian {
    Dense { matrix: Vec<f64>, lu: DenseLu },
    Operator(Option<Box<Operator>>),
}

impl Default for Jacobian {
    fn default() -> Self {
        Self::Dense { matrix: Vec::new(), lu: DenseLu::default() }
    }
}

/// The counters and the factorised Jacobian of
/// [`HarmonicBalance::solve`](super::HarmonicBalance::solve)'s Newton runs.
#[derive(Default)]
pub(super) struct Newton {
    pub(super) evaluations: u64,
    pub(super) march_steps: u64,
    pub(super) iterations: usize,
    pub(super) factorizations: usize,
    /// Products with the Jacobian in GMRES (none with the dense LU).
    pub(super) products: usize,
    pub(super) jacobian: Jacobian,
}

impl Newton {
    /// Factorises the Jacobian of the last evaluation: the dense one's LU (the operator's
    /// evaluation factorised its band).
    pub(super) fn factorize(&mut self, size: usize) {
        if let Jacobian::Dense { matrix, lu } = &mut self.jacobian {
            lu.factorize(matrix, size);
        }
        self.factorizations += 1;
    }

    /// The Newton step −J⁻¹ r.
    pub(super) fn step(&mut self, r: &[f64]) -> Vec<f64> {
        match &self.jacobian {
            Jacobian::Dense { lu, .. } => lu.step(r),
            // No evaluation has set the operator: no step (Newton stops on it).
            Jacobian::Operator(None) => vec![f64::NAN; r.len()],
            Jacobian::Operator(Some(op)) => {
                let rhs: Vec<f64> = r.iter().map(|v| -v).collect();
                let (x, report) = gmres(
                    |v, out| op.apply(v, out),
                    |v| precondition(&op.lu, v),
                    &rhs,
                    KRYLOV_TOLERANCE,
                    KRYLOV_ITERATIONS,
                );
                self.products += report.products;
                x
            }
        }
    }
}

/// PᵀXP into `out` (m × m, column-major) for the n × n matrix `x` and P
/// (n × m, column-major); `xp` (n × m) receives XP.
pub(super) fn project(p: &[f64], x: &nalgebra::DMatrix<f64>, m: usize, xp: &mut [f64], out: &mut [f64]) {
    let n = x.nrows();
    let x = x.as_slice();
    // Column b of XP as the sum of X's columns weighted by P's column b, in the
    // order of the former dot products and from their start, −0 (the same rounding).
    for (xp_b, p_b) in xp.chunks_exact_mut(n).zip(p.chunks_exact(n)).take(m) {
        xp_b.fill(-0.0);
        for (x_l, &w) in x.chunks_exact(n).zip(p_b) {
            for (o, &v) in xp_b.iter_mut().zip(x_l) {
                *o += v * w;
            }
        }
    }
    for (out_b, xp_b) in out.chunks_exact_mut(m).zip(xp.chunks_exact(n)) {
        for (o, p_a) in out_b.iter_mut().zip(p.chunks_exact(n)) {
            *o = p_a.iter().zip(xp_b).map(|(a, b)| a * b).sum();
        }
    }
}

/// The distance to the root left after a Newton step of length `step`,
/// estimated from the contraction θ = step / `previous` of the steps (the
/// previous one taken whole): θ / (1 − θ) · step, the sum of the geometric
/// series of the steps still to come (the stopping rule of the simplified
/// Newton iteration, Hairer & Wanner, Solving ODEs II, IV.8). Infinite where
/// there is no previous whole step or the steps do not contract.
pub(super) fn newton_remainder(previous: Option<f64>, step: f64) -> f64 {
    match previous {
        Some(p) if p > 0.0 && step < p => {
            let theta = step / p;
            theta / (1.0 - theta) * step
        }
        _ => f64::INFINITY,
    }
}
