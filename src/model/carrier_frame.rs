//! The inertial terms of coordinates that turn with the carrier.
//!
//! The translations of every body (x, y of the central members, ζ, η of the
//! planets) are measured in axes fixed to the carrier, which turns at Ω_c
//! [rad/s] (counter-clockwise positive). Newton's law for a body of mass m at
//! position (x, y) in those axes, the axes turning at the constant mean speed
//! Ω_c, reads (Lin & Parker 1999; Cooley & Parker 2012, J. Vib. Acoust. 134,
//! 061014)
//!
//! m (ẍ − 2 Ω_c ẏ − Ω_c² x) = F_x,  m (ÿ + 2 Ω_c ẋ − Ω_c² y) = F_y,
//!
//! and for planet n, at (r_c + ζ_n, η_n) in its own radial and tangential
//! axes, the same with x → r_c + ζ_n, y → η_n. Collected over the model:
//!
//! M q̈ + (C + Ω_c G) q̇ + (K_b + K_m − Ω_c² (K_Ω − K_σ)) q = f + Ω_c² f_c
//!
//! - G: skew-symmetric, 2m [[0, −1], [1, 0]] on each body's two
//!   translations (x, y) or (ζ, η); the rotations u carry no gyroscopic term
//!   (they turn about the axis of Ω_c);
//! - K_Ω = diag(m) on the translations (the centripetal softening);
//! - f_c: the planets' centrifugal load m_p r_c on every ζ_n (per Ω_c²), a
//!   steady force radially outward that the planet bearings carry;
//! - K_σ: m_p in the row of η_n and the column of u_c. The centrifugal load is
//!   radial in the carrier's own axes; when the carrier turns by an extra
//!   angle u_c / r_c the load turns with it and has the tangential component
//!   −m_p Ω_c² u_c in the axes of the mean rotation. With it, the planet's
//!   tangential centripetal force is m_p Ω_c² (η_n − u_c): its position
//!   relative to its own carrier arm, so a rigid rotation of the whole set
//!   stays a free motion (zero frequency) at any carrier speed, and the
//!   torsional model (η_n = u_c) gets no term at all.
//!
//! The reduced matrices are Tᵀ G T, Tᵀ K_Ω T, Tᵀ K_σ T and Tᵀ f_c with the
//! fidelity's reduction T ([`crate::model::lumped::Reduction`]). In the
//! transverse–torsional model the rotation u_c of a turning carrier is a
//! coordinate that grows with the carrier's angle, and so does η_n (the
//! planets ride on the carrier): the gyroscopic term acts on the velocities
//! relative to the mean rigid rotation, q̇ − Ω_c v̄ (v̄ the rigid-body
//! velocities per rad/s of carrier speed), which only changes the planets'
//! η̇_n by r_c Ω_c.

use nalgebra::DMatrix;

use crate::model::gear::Member;
use crate::model::lumped::{full_index, Coordinate, Fidelity, LumpedSet};

/// The carrier-frame matrices of a lumped set, reduced, per unit carrier
/// speed (G) or squared speed (K_Ω, K_σ, f_c).
#[derive(Clone, Debug, PartialEq)]
pub struct CarrierFrameTerms {
    /// G: the gyroscopic matrix per rad/s, skew-symmetric \[kg\].
    pub gyroscopic: DMatrix<f64>,
    /// K_Ω: the centripetal matrix per (rad/s)², diag(m) on the translations \[kg\].
    pub centripetal: DMatrix<f64>,
    /// K_σ: the rotation of the planets' centrifugal bearing load with the
    /// carrier, per (rad/s)² \[kg\].
    pub preload_rotation: DMatrix<f64>,
    /// f_c: the planets' centrifugal load per (rad/s)², m_p r_c on each ζ_n [kg·m].
    pub centrifugal: Vec<f64>,
}

impl CarrierFrameTerms {
    /// The matrices of `set` with the planets' centres at radius
    /// `carrier_radius` r_c \[m\] (the centre distance).
    pub fn new(set: &LumpedSet, carrier_radius: f64) -> Self {
        let red = set.reduction();
        let n = set.planet_angles.len();
        let full = red.full;
        let mass = set.full_mass();
        let mut g = DMatrix::zeros(full, full);
        let mut k = DMatrix::zeros(full, full);
        let mut sigma = DMatrix::zeros(full, full);
        let mut fc = vec![0.0; full];
        let mut pairs: Vec<(usize, usize)> = [Member::Carrier, Member::Ring, Member::Sun]
            .iter()
            .map(|m| (full_index(Coordinate::X(*m)), full_index(Coordinate::Y(*m))))
            .collect();
        pairs.extend((0..n).map(|p| (full_index(Coordinate::Zeta(p)), full_index(Coordinate::Eta(p)))));
        for (x, y) in pairs {
            let m = mass[x];
            g[(x, y)] = -2.0 * m;
            g[(y, x)] = 2.0 * m;
            k[(x, x)] = m;
            k[(y, y)] = m;
        }
        let uc = full_index(Coordinate::U(Member::Carrier));
        for p in 0..n {
            sigma[(full_index(Coordinate::Eta(p)), uc)] = set.planet_mass;
            fc[full_index(Coordinate::Zeta(p))] = set.planet_mass * carrier_radius;
        }
        // Tᵀ A T with T full × reduced.
        let d = red.dim();
        let mut t = DMatrix::zeros(full, d);
        for (row, entries) in red.t.iter().enumerate() {
            for (col, f) in entries {
                t[(row, *col)] += f;
            }
        }
        let reduce = |a: &DMatrix<f64>| t.transpose() * a * &t;
        Self {
            gyroscopic: reduce(&g),
            centripetal: reduce(&k),
            preload_rotation: reduce(&sigma),
            centrifugal: red.reduce_vector(&fc),
        }
    }

    /// Whether the terms can be nonzero: a transverse–torsional model whose
    /// carrier turns (torsional models have no translations; a held carrier
    /// has Ω_c = 0).
    pub fn applies(set: &LumpedSet) -> bool {
        set.fidelity == Fidelity::TransverseTorsional && set.held != Some(Member::Carrier)
    }

    /// K − Ω_c² (K_Ω − K_σ): the stiffness of the linear model at carrier
    /// speed `omega_c`, given its stiffness `k` at rest.
    pub fn effective_stiffness(&self, k: &DMatrix<f64>, omega_c: f64) -> DMatrix<f64> {
        let w2 = omega_c * omega_c;
        k - (&self.centripetal - &self.preload_rotation) * w2
    }
}

impl LumpedSet {
    /// The carrier-frame terms of this set ([`CarrierFrameTerms`]), with
    /// the planets at radius `carrier_radius` \[m\].
    pub fn carrier_frame(&self, carrier_radius: f64) -> CarrierFrameTerms {
        CarrierFrameTerms::new(self, carrier_radius)
    }
}
