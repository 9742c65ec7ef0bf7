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

/// The carrier frame's terms of a dynamic model with a turning carrier, as
/// forces.
///
/// Ω_c is the constant mean carrier speed, the kinematic speed of the carrier
/// at the drive's reference input speed (the published linear form): the
/// terms then stay linear in q and q̇, the Jacobian stays constant, and a
/// change of the carrier's instantaneous speed about its mean enters through
/// the carrier rotation u_c the model already has (to first order: the
/// Coriolis term on q̇ − Ω_c v̄ holds the change of the centrifugal load with
/// the carrier's speed). The generalised force the frame adds is
///
/// f_frame = −Ω_c G (q̇ − Ω_c v̄) + Ω_c² (K_Ω − K_σ) q + Ω_c² f_c,
///
/// so a set turning rigidly at its mean speed feels only the centrifugal
/// load.
#[derive(Clone, Debug)]
pub struct CarrierFrame {
    /// Nonzero entries (i, j, G_ij) of the gyroscopic matrix per rad/s.
    gyroscopic: Vec<(usize, usize, f64)>,
    /// Nonzero entries (i, j, (K_Ω − K_σ)_ij) per (rad/s)².
    centripetal: Vec<(usize, usize, f64)>,
    /// Constant force per (rad/s)²: f_c + G v̄.
    steady: Vec<(usize, f64)>,
    /// Carrier speed per rad/s of input speed.
    carrier_per_input: f64,
    /// The mean carrier speed Ω_c \[rad/s\].
    speed: f64,
    /// Centrifugal load of one planet per (rad/s)², m_p r_c [kg·m].
    planet_load: f64,
}

impl CarrierFrame {
    /// The frame of `set` (reduced coordinates of the set's reduction), the
    /// planets at radius `carrier_radius` \[m\]; `rigid` the rigid-body
    /// velocities per rad/s of input speed and `carrier_per_input` the
    /// carrier's speed per rad/s of input speed. None when the terms vanish
    /// (held carrier, torsional model).
    pub fn new(set: &LumpedSet, carrier_radius: f64, rigid: &[f64], carrier_per_input: f64) -> Option<Self> {
        if !CarrierFrameTerms::applies(set) || carrier_per_input == 0.0 {
            return None;
        }
        let terms = set.carrier_frame(carrier_radius);
        let d = rigid.len();
        let sparse = |a: &DMatrix<f64>| {
            let mut out = Vec::new();
            for i in 0..d {
                for j in 0..d {
                    if a[(i, j)] != 0.0 {
                        out.push((i, j, a[(i, j)]));
                    }
                }
            }
            out
        };
        let k = &terms.centripetal - &terms.preload_rotation;
        // f_c + G v̄, v̄ the rigid-body velocities per rad/s of carrier speed.
        let per_carrier = nalgebra::DVector::from_iterator(d, rigid.iter().map(|r| r / carrier_per_input));
        let g_vbar = &terms.gyroscopic * per_carrier;
        let steady: Vec<f64> = terms.centrifugal.iter().zip(g_vbar.iter()).map(|(f, g)| f + g).collect();
        Some(Self {
            gyroscopic: sparse(&terms.gyroscopic),
            centripetal: sparse(&k),
            steady: steady.into_iter().enumerate().filter(|(_, x)| *x != 0.0).collect(),
            carrier_per_input,
            speed: 0.0,
            planet_load: set.planet_mass * carrier_radius,
        })
    }

    /// Sets the mean carrier speed from the drive's reference input speed
    /// `omega` \[rad/s\].
    pub fn set_input_speed(&mut self, omega: f64) {
        self.speed = omega * self.carrier_per_input;
    }

    /// The mean carrier speed Ω_c \[rad/s\].
    pub fn speed(&self) -> f64 {
        self.speed
    }

    /// The steady centrifugal load of one planet on its bearing,
    /// m_p Ω_c² r_c \[N\], radially outward.
    pub fn planet_centrifugal_force(&self) -> f64 {
        self.planet_load * self.speed * self.speed
    }

    /// Adds the frame's generalised forces at (`q`, `v`) to `f`.
    pub fn add_force(&self, q: &[f64], v: &[f64], f: &mut [f64]) {
        let w = self.speed;
        if w == 0.0 {
            return;
        }
        let w2 = w * w;
        for &(i, j, g) in &self.gyroscopic {
            f[i] -= w * g * v[j];
        }
        for &(i, j, k) in &self.centripetal {
            f[i] += w2 * k * q[j];
        }
        for &(i, s) in &self.steady {
            f[i] += w2 * s;
        }
    }

    /// Adds the frame's terms to the tangent stiffness `k` = −∂f/∂q and
    /// damping `c` = −∂f/∂q̇.
    pub fn add_jacobian(&self, k: &mut DMatrix<f64>, c: &mut DMatrix<f64>) {
        let w = self.speed;
        if w == 0.0 {
            return;
        }
        for &(i, j, g) in &self.gyroscopic {
            c[(i, j)] += w * g;
        }
        for &(i, j, kk) in &self.centripetal {
            k[(i, j)] -= w * w * kk;
        }
    }
}
