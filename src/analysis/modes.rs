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

/// One eigenvalue λ = σ + iω of the linear model with the carrier frame's
/// gyroscopic and centripetal terms ([`rotating_modes`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WhirlMode {
    /// Natural frequency ω/2π \[Hz\] (0 for a rigid-body or divergent mode).
    pub frequency: f64,
    /// Real part σ [1/s]: 0 for an undamped stable mode, positive for a
    /// divergent one.
    pub growth_rate: f64,
}

/// Eigenvalues of the linear (mean-stiffness, undamped) model at carrier
/// speed `carrier_speed` Ω_c \[rad/s\]:
///
/// M q̈ + Ω_c G q̇ + (K − Ω_c² (K_Ω − K_σ)) q = 0
///
/// ([`crate::model::carrier_frame`]), a quadratic eigenvalue problem, solved
/// in its first-order form ż = A z with z = (ω_ref M^½ q, M^½ q̇),
/// A = [[0, ω_ref I], [−M^-½ K_Ω_c M^-½ / ω_ref, −Ω_c M^-½ G M^-½]]
/// (K_Ω_c the stiffness at speed, ω_ref² its largest mass-scaled diagonal
/// term, which balances the blocks), by faer's real
/// nonsymmetric eigensolver. One entry per conjugate pair (ω ≥ 0), and both
/// members of a real pair ±σ; sorted by frequency, then growth rate. At
/// Ω_c = 0 (and for a held carrier or the torsional model, whose terms
/// vanish) the frequencies are those of [`natural_modes`]. `carrier_radius`
/// r_c \[m\] places the planets (it only enters the steady centrifugal load,
/// not the eigenvalues; any positive value serves).
pub fn rotating_modes(set: &LumpedSet, carrier_speed: f64, carrier_radius: f64) -> Vec<WhirlMode> {
    let m = set.mass();
    let d = m.len();
    let k = set.stiffness();
    let inv_sqrt: Vec<f64> = m.iter().map(|x| 1.0 / x.sqrt()).collect();
    let (k_eff, g) = if crate::model::carrier_frame::CarrierFrameTerms::applies(set) && carrier_speed != 0.0 {
        let terms = set.carrier_frame(carrier_radius);
        (terms.effective_stiffness(&k, carrier_speed), terms.gyroscopic * carrier_speed)
    } else {
        (k, DMatrix::zeros(d, d))
    };
    // Balanced: z = (ω_ref M^½ q, M^½ q̇), ω_ref² the largest diagonal of
    // M^-½ K M^-½, so both off-diagonal blocks are of the frequencies' size.
    let w_ref =
        (0..d).map(|i| k_eff[(i, i)].abs() * inv_sqrt[i] * inv_sqrt[i]).fold(0.0, f64::max).sqrt().max(1.0);
    let a = faer::Mat::<f64>::from_fn(2 * d, 2 * d, |i, j| match (i < d, j < d) {
        (true, true) => 0.0,
        (true, false) => w_ref * f64::from(u8::from(j - d == i)),
        (false, true) => -inv_sqrt[i - d] * k_eff[(i - d, j)] * inv_sqrt[j] / w_ref,
        (false, false) => -inv_sqrt[i - d] * g[(i - d, j - d)] * inv_sqrt[j - d],
    });
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut out: Vec<WhirlMode> = match a.eigenvalues() {
        Ok(values) => values
            .iter()
            .filter(|l| l.im >= 0.0)
            .map(|l| WhirlMode { frequency: l.im / two_pi, growth_rate: l.re })
            .collect(),
        Err(_) => Vec::new(),
    };
    out.sort_by(|x, y| x.frequency.total_cmp(&y.frequency).then(x.growth_rate.total_cmp(&y.growth_rate)));
    out
}

/// Rayleigh damping set by the two-frequency rule on a set's first two
/// rotational modes (the in-phase modes that carry the mesh response).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RayleighRule {
    /// The damping ratio both modes get [-].
    pub zeta: f64,
    /// The first and second rotational modes' frequencies \[Hz\].
    pub frequencies: [f64; 2],
    /// Mass-proportional coefficient μ = 2ζ ω₁ω₂/(ω₁+ω₂) \[1/s\].
    pub mass_per_s: f64,
    /// Stiffness-proportional coefficient η = 2ζ/(ω₁+ω₂) \[s\].
    pub stiffness_s: f64,
}

/// The Rayleigh coefficients that give the damping ratio `zeta` [-] at the
/// first and the second rotational mode of `modes`
/// ([`Damping::two_frequency`](crate::model::gear::Damping::two_frequency));
/// `None` when there are fewer than two rotational modes.
pub fn rayleigh_rule(modes: &[Mode], zeta: f64) -> Option<RayleighRule> {
    let mut rotational = modes.iter().filter(|m| m.class == ModeClass::Rotational);
    let (f1, f2) = (rotational.next()?.frequency, rotational.next()?.frequency);
    let w = |f: f64| 2.0 * std::f64::consts::PI * f;
    let (mass_per_s, stiffness_s) = crate::model::gear::Damping::two_frequency(zeta, w(f1), w(f2));
    Some(RayleighRule { zeta, frequencies: [f1, f2], mass_per_s, stiffness_s })
}
