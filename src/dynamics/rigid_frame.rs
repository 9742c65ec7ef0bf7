//! The model seen from a frame that turns with its rigid-body motion: the
//! coordinates the accuracy study's reference and the periodic solver
//! integrate in.

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::solver::{LowRankJacobian, SecondOrderSystem, TangentSystem, TermCoefficients};

/// The model in coordinates relative to its rigid-body motion: q = q_e +
/// r t, q̇ = q̇_e + r with r the rigid-body velocity at the speed. The same
/// equations (the rigid motion has no acceleration), but the integrated
/// coordinates stay of the size of the elastic deflections instead of
/// growing with the rotation angles, so a relative tolerance means what it
/// says for every coordinate and no rounding of large angles accumulates.
pub struct RigidFrame<'a> {
    model: &'a mut PlanetaryDynamics,
    rigid: Vec<f64>,
    q: Vec<f64>,
    v: Vec<f64>,
}

impl<'a> RigidFrame<'a> {
    /// The frame of the rigid-body velocity `rigid` (one entry per coordinate).
    pub fn new(model: &'a mut PlanetaryDynamics, rigid: Vec<f64>) -> Self {
        let n = rigid.len();
        Self { model, rigid, q: vec![0.0; n], v: vec![0.0; n] }
    }

    /// The model the frame evaluates (its last evaluation's state absolute).
    pub fn model(&self) -> &PlanetaryDynamics {
        self.model
    }

    /// Writes the absolute state of the frame state (`qe`, `ve`) at `t`.
    fn absolute(&mut self, t: f64, qe: &[f64], ve: &[f64]) {
        for i in 0..self.rigid.len() {
            self.q[i] = qe[i] + self.rigid[i] * t;
            self.v[i] = ve[i] + self.rigid[i];
        }
    }
}

impl SecondOrderSystem for RigidFrame<'_> {
    fn dim(&self) -> usize {
        self.model.dim()
    }

    fn mass(&self) -> &[f64] {
        self.model.mass()
    }

    fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        self.absolute(t, q, v);
        self.model.force(t, &self.q, &self.v, f);
    }

    fn events(&mut self, t: f64, q: &[f64], v: &[f64], out: &mut Vec<f64>) {
        self.absolute(t, q, v);
        self.model.events(t, &self.q, &self.v, out);
    }
}

impl TangentSystem for RigidFrame<'_> {
    fn jacobian(
        &mut self,
        t: f64,
        q: &[f64],
        v: &[f64],
        k: &mut nalgebra::DMatrix<f64>,
        c: &mut nalgebra::DMatrix<f64>,
    ) {
        self.absolute(t, q, v);
        self.model.jacobian(t, &self.q, &self.v, k, c);
    }

    fn low_rank_jacobian(&self) -> Option<LowRankJacobian> {
        self.model.low_rank_jacobian()
    }

    fn jacobian_coefficients(&mut self, t: f64, q: &[f64], v: &[f64], out: &mut [TermCoefficients]) {
        self.absolute(t, q, v);
        self.model.jacobian_coefficients(t, &self.q, &self.v, out);
    }
}
