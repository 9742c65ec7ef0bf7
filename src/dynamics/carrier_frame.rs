//! The carrier frame's inertial forces in the equations of motion: the
//! gyroscopic (Coriolis) and centripetal terms and the planets' centrifugal
//! load of a turning carrier ([`crate::model::carrier_frame`]), at the
//! carrier's mean speed.
//!
//! Ω_c is the constant mean carrier speed, the kinematic speed of the carrier
//! at the drive's reference input speed (the published linear form): the
//! terms then stay linear in q and q̇, the Jacobian stays constant, and a
//! change of the carrier's instantaneous speed about its mean enters through
//! the carrier rotation u_c the model already has. The generalised force the
//! frame adds is
//!
//! f_frame = −Ω_c G (q̇ − Ω_c v̄) + Ω_c² (K_Ω − K_σ) q + Ω_c² f_c,
//!
//! with v̄ the rigid-body velocities per rad/s of carrier speed (the planets'
//! η̇_n = r_c), so a set turning rigidly at its mean speed feels only the
//! centrifugal load.

use nalgebra::DMatrix;

use crate::model::carrier_frame::CarrierFrameTerms;
use crate::model::lumped::LumpedSet;

/// The carrier frame's terms of a dynamic model with a turning carrier.
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
        let mut steady = terms.centrifugal.clone();
        for i in 0..d {
            for j in 0..d {
                steady[i] += terms.gyroscopic[(i, j)] * rigid[j] / carrier_per_input;
            }
        }
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
