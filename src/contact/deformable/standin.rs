//! A stand-in body: the pair model's tooth compliance curve
//! ([`ToothComplianceCurve`], potential-energy method) as a
//! [`BodyInfluence`], until the finite-element bodies give the real
//! coefficients. It is not a finite-element body: a tooth's own coefficient
//! is its energy-method compliance at the load's roll angle (the same at
//! every measuring point of that tooth), and neighbouring teeth are coupled
//! only through an optional fraction of it.
//!
//! Reference depth: half the circular tooth thickness at the contact radius,
//! the depth to the tooth's centreline that Weber's approach formula uses
//! (Weber & Banaschek 1953; the energy method's cantilever is measured from
//! that centreline).

use crate::contact::deformable::BodyInfluence;
use crate::contact::stiffness::ToothComplianceCurve;
use crate::model::gear::{Material, ToothForm};
use crate::model::involute::radius_at_roll;

/// The pair model's compliance curve of one gear's teeth, as a body.
#[derive(Clone, Debug)]
pub struct CurveBody {
    /// Compliance of one tooth against the roll angle of its load.
    pub curve: ToothComplianceCurve,
    /// Cross-coefficient of adjacent teeth as a fraction of the geometric
    /// mean of their own coefficients [-] (0: no coupling; below 0.5 keeps
    /// the matrix positive definite).
    pub neighbour_fraction: f64,
    form: ToothForm,
}

impl CurveBody {
    /// The uncoupled stand-in body of a tooth form.
    pub fn new(form: &ToothForm, material: &Material) -> Self {
        Self { curve: ToothComplianceCurve::new(form, material), neighbour_fraction: 0.0, form: form.clone() }
    }

    /// The same body with adjacent teeth coupled by `fraction` [-].
    pub fn coupled(mut self, fraction: f64) -> Self {
        self.neighbour_fraction = fraction;
        self
    }
}

impl BodyInfluence for CurveBody {
    fn coefficient(&self, i: i32, roll_i: f64, j: i32, roll_j: f64) -> f64 {
        match (i - j).abs() {
            0 => self.curve.total_at(roll_j),
            1 => self.neighbour_fraction * (self.curve.total_at(roll_i) * self.curve.total_at(roll_j)).sqrt(),
            _ => 0.0,
        }
    }

    fn reference_depth(&self, roll: f64) -> f64 {
        let lo = self.curve.roll[0];
        let hi = self.curve.roll[self.curve.roll.len() - 1];
        let r = radius_at_roll(roll.clamp(lo, hi), self.form.base_radius());
        0.5 * self.form.thickness_at(r)
    }

    fn reach(&self) -> i32 {
        if self.neighbour_fraction == 0.0 {
            0
        } else {
            1
        }
    }
}
