//! Linear modal analysis of the mean-stiffness lumped model: natural
//! frequencies, mode shapes and their classes.
//!
//! K φ = ω² M φ with M diagonal is solved as the symmetric problem
//! (M^-1/2 K M^-1/2) ψ = ω² ψ, φ = M^-1/2 ψ. Classes after Lin & Parker (1999)
//! for equally spaced planets: rotational modes (central members only rotate,
//! all planets move alike), translational modes (central members only
//! translate; degenerate pairs), planet modes (central members at rest;
//! multiplicity n − 3, or n − 1 in the torsional model). A mode that fits none
//! (unequal planet spacing, mixed supports) is reported as mixed.

use nalgebra::{DMatrix, SymmetricEigen};
use serde::{Deserialize, Serialize};

use crate::model::gear::Member;
use crate::model::lumped::{full_index, Coordinate, LumpedSet};

/// Class of a vibration mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModeClass {
    /// Zero frequency: free rotation of the train.
    RigidBody,
    /// Central members rotate without translating; planets move alike (in phase).
    Rotational,
    /// Central members translate without rotating.
    Translational,
    /// Central members at rest; planets move (sequentially phased).
    Planet,
    /// None of the above.
    Mixed,
}

/// One natural mode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mode {
    /// Natural frequency \[Hz\].
    pub frequency: f64,
    /// Class.
    pub class: ModeClass,
    /// Number of modes sharing this frequency (within 1e-6 relative).
    pub multiplicity: usize,
    /// Mass-normalised shape in the reduced coordinates.
    pub shape: Vec<f64>,
    /// Share of the modal kinetic energy in central rotations, central
    /// translations and planets.
    pub energy_shares: [f64; 3],
}

/// Size from which the modal problem is solved by faer rather than nalgebra:
/// `cargo bench --bench linear_algebra` measured nalgebra 1.6× faster at
/// n = 20 (the example, transverse–torsional) and faer 1.8× faster at n = 33,
/// 3.4× at n = 105 and 6.5× at n = 201 (docs/PERFORMANCE.md).
pub const FAER_FROM: usize = 30;

/// Eigenvalues and eigenvectors (columns) of a symmetric matrix: nalgebra's
/// symmetric QR below [`FAER_FROM`] rows, faer's self-adjoint
/// divide-and-conquer from there on, sequentially. Both agree to a few ulp
/// in the eigenvalues; within a repeated eigenvalue each returns its own
/// orthonormal basis of the same eigenspace.
pub fn symmetric_eigen(a: DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>) {
    let n = a.nrows();
    if n < FAER_FROM {
        let eig = SymmetricEigen::new(a);
        return (eig.eigenvalues.iter().copied().collect(), eig.eigenvectors);
    }
    let fa = faer::Mat::<f64>::from_fn(n, n, |i, j| a[(i, j)]);
    match fa.self_adjoint_eigen(faer::Side::Lower) {
        Ok(e) => {
            let (s, u) = (e.S(), e.U());
            ((0..n).map(|i| s[i]).collect(), DMatrix::from_fn(n, n, |i, j| u[(i, j)]))
        }
        // faer reports non-convergence (never seen on a symmetric matrix);
        // nalgebra's iteration then gives the answer.
        Err(_) => {
            let eig = SymmetricEigen::new(a);
            (eig.eigenvalues.iter().copied().collect(), eig.eigenvectors)
        }
    }
}

/// The symmetric modal matrix M^-1/2 K M^-1/2 of a lumped set (M diagonal),
/// symmetrized against round-off: its eigenvalues are the squared natural
/// circular frequencies, its eigenvectors the mass-normalized shapes scaled
/// by M^1/2.
pub fn modal_matrix(set: &LumpedSet) -> DMatrix<f64> {
    let m = set.mass();
    let k = set.stiffness();
    let d = m.len();
    let inv_sqrt: Vec<f64> = m.iter().map(|x| 1.0 / x.sqrt()).collect();
    let a = DMatrix::from_fn(d, d, |i, j| inv_sqrt[i] * k[(i, j)] * inv_sqrt[j]);
    (&a + a.transpose()) * 0.5
}

/// Natural modes of a lumped set, by increasing frequency.
pub fn natural_modes(set: &LumpedSet) -> Vec<Mode> {
    let red = set.reduction();
    let d = red.dim();
    let inv_sqrt: Vec<f64> = set.mass().iter().map(|x| 1.0 / x.sqrt()).collect();
    let (eigenvalues, eigenvectors) = symmetric_eigen(modal_matrix(set));
    let mut order: Vec<usize> = (0..d).collect();
    order.sort_by(|i, j| eigenvalues[*i].total_cmp(&eigenvalues[*j]));
    let omega_max = eigenvalues.iter().cloned().fold(0.0, f64::max).max(0.0).sqrt();
    let full_mass = set.full_mass();
    let n = set.planet_angles.len();
    let mut modes: Vec<Mode> = order
        .iter()
        .map(|&i| {
            let lambda = eigenvalues[i].max(0.0);
            let omega = lambda.sqrt();
            let shape: Vec<f64> = (0..d).map(|r| eigenvectors[(r, i)] * inv_sqrt[r]).collect();
            // Expand to full coordinates for the energy bookkeeping.
            let mut full = vec![0.0; red.full];
            for (row, entries) in red.t.iter().enumerate() {
                for (col, f) in entries {
                    full[row] += f * shape[*col];
                }
            }
            let e = |c: Coordinate| full_mass[full_index(c)] * full[full_index(c)].powi(2);
            let members = [Member::Carrier, Member::Ring, Member::Sun];
            let rot: f64 = members.iter().map(|m| e(Coordinate::U(*m))).sum();
            let trans: f64 = members.iter().map(|m| e(Coordinate::X(*m)) + e(Coordinate::Y(*m))).sum();
            let planets: f64 = (0..n)
                .map(|p| e(Coordinate::Zeta(p)) + e(Coordinate::Eta(p)) + e(Coordinate::PlanetU(p)))
                .sum();
            let total = (rot + trans + planets).max(f64::MIN_POSITIVE);
            let shares = [rot / total, trans / total, planets / total];
            let tol = 1e-8;
            let alike = (1..n).all(|p| {
                [Coordinate::Zeta, Coordinate::Eta, Coordinate::PlanetU].iter().all(|c| {
                    let a = full[full_index(c(p))];
                    let b = full[full_index(c(0))];
                    (a - b).abs() <= 1e-6 * total.sqrt()
                })
            });
            let class = if omega <= 1e-6 * omega_max {
                ModeClass::RigidBody
            } else if shares[0] + shares[1] < tol {
                ModeClass::Planet
            } else if shares[1] < tol && alike {
                ModeClass::Rotational
            } else if shares[0] < tol && shares[1] > tol {
                ModeClass::Translational
            } else {
                ModeClass::Mixed
            };
            Mode {
                frequency: omega / (2.0 * std::f64::consts::PI),
                class,
                multiplicity: 1,
                shape,
                energy_shares: shares,
            }
        })
        .collect();
    // Multiplicities: groups of equal frequency.
    let mut i = 0;
    while i < modes.len() {
        let f = modes[i].frequency;
        let mut j = i + 1;
        while j < modes.len() && (modes[j].frequency - f).abs() <= 1e-6 * f.max(1e-9) {
            j += 1;
        }
        for mode in &mut modes[i..j] {
            mode.multiplicity = j - i;
        }
        i = j;
    }
    modes
}
