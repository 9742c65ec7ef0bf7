//! Tooth-pair stiffness by the potential-energy method.
//!
//! 1/k_pair = 1/k_h + Σ_{i=1,2} (1/k_b,i + 1/k_s,i + 1/k_a,i + 1/k_f,i)
//! (docs/FORMULAS.md): each tooth is a cantilever of variable section from its
//! root chord (where the fillets meet the root circle) to the contact point,
//! its section half-thickness taken from the real outline (fillet and
//! involute, [`FlankOutline`]) rather than the straight-line approximations
//! of Yang & Lin (1987) and Tian (2004) below the base circle; internal teeth
//! are the same cantilever pointing inward (Liang, Zuo & Pandey 2014).
//! With f the unit contact force on the tooth (components f_x along the
//! centreline, f_y across it), C = (x_c, y_c) the contact point and ξ the
//! distance from the root chord:
//!
//! - bending 1/k_b = ∫ m(ξ)² / (E' I) dξ, m = (ξ_c − ξ) f_y − y_c f_x (signed
//!   for the tooth's direction), I = (2h)³ L / 12;
//! - shear 1/k_s = ∫ 1.2 f_y² / (G A) dξ, axial 1/k_a = ∫ f_x² / (E' A) dξ, A = 2hL;
//! - fillet foundation, Sainsot, Velex & Duverger (2004, J. Mech. Des.
//!   126:748) with the coefficients of docs/FORMULAS.md;
//! - Hertz: the load-independent 1/k_h = 4(1 − ν²)/(π E L) of the
//!   energy-method papers, so that the contact law stays piecewise linear and
//!   its Jacobian exact. Load-dependent flattening laws (Weber–Banaschek,
//!   Lundberg) are softer; this one is not counted twice.
//!
//! E' = E/(1 − ν²): the face (30 mm) is many times the tooth thickness, so
//! the teeth bend in plane strain. The integrals are cumulative on a grid
//! from the root, so a contact point costs O(1): m² expands into
//! B² J0 − 2 B f_y J1 + f_y² J2 with J_k = ∫ ξ^k / (E' I) dξ.

use serde::{Deserialize, Serialize};

use crate::geometry::profile::{interpolate, FlankOutline, ProfileDeviation};
use crate::model::gear::{GearKind, GearSet, Material, MeshKind, ToothForm};
use crate::model::involute::radius_at_roll;
use crate::model::mesh::PathOfContact;

/// Compliances of one tooth for a unit force at one contact point [m/N].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ToothCompliance {
    /// Bending.
    pub bending: f64,
    /// Shear.
    pub shear: f64,
    /// Axial compression.
    pub axial: f64,
    /// Fillet foundation.
    pub foundation: f64,
}

impl ToothCompliance {
    /// Sum of the four terms [m/N].
    pub fn total(&self) -> f64 {
        self.bending + self.shear + self.axial + self.foundation
    }
}

/// Coefficients L*, M*, P*, Q* of Sainsot's fillet-foundation formula for a
/// root half angle θ_f \[rad\] and h_f = r_f / r_bore.
pub fn sainsot_coefficients(theta_f: f64, h_f: f64) -> [f64; 4] {
    const C: [[f64; 6]; 4] = [
        [-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045],
        [60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086],
        [-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236],
        [-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904],
    ];
    C.map(|[a, b, c, d, e, f]| {
        a / (theta_f * theta_f) + b * h_f * h_f + c * h_f / theta_f + d / theta_f + e * h_f + f
    })
}

/// h_f of Sainsot's formula. External gear: root radius over bore radius.
/// Internal gear: the rim is taken as the body of an external gear of the
/// same depth below the root, r_f / (r_f − (r_rim − r_f)) — an assumption
/// (the formula was fitted on external gears), stated in docs/MODEL_CHOICES.md.
pub fn foundation_ratio(form: &ToothForm) -> f64 {
    match form.kind {
        GearKind::External => form.root_radius / form.body_radius,
        GearKind::Internal => form.root_radius / (2.0 * form.root_radius - form.body_radius),
    }
}

/// Compliance of one tooth as a function of the contact roll angle.
#[derive(Clone, Debug, PartialEq)]
pub struct ToothComplianceCurve {
    /// Roll angles of the samples \[rad\].
    pub roll: Vec<f64>,
    /// Compliance at each sample.
    pub compliance: Vec<ToothCompliance>,
    /// Sainsot coefficients used.
    pub foundation_coefficients: [f64; 4],
}

const SECTION_STEPS: usize = 2000;
const CONTACT_SAMPLES: usize = 300;

impl ToothComplianceCurve {
    /// The compliance curve of a tooth over its involute.
    pub fn new(form: &ToothForm, material: &Material) -> Self {
        let outline = FlankOutline::new(form, &ProfileDeviation::none());
        let e = material.youngs_modulus;
        let e_plane = e / (1.0 - material.poisson_ratio.powi(2));
        let g = material.shear_modulus();
        let width = form.face_width;
        let theta_f = outline.root_half_angle;
        let x_root = form.root_radius * theta_f.cos();
        let dir = match form.kind {
            GearKind::External => 1.0,
            GearKind::Internal => -1.0,
        };
        let x_tip = form.tip_radius;
        let depth = dir * (x_tip - x_root);
        let d = depth / SECTION_STEPS as f64;
        // Cumulative integrals from the root chord.
        let mut j =
            [vec![0.0; SECTION_STEPS + 1], vec![0.0; SECTION_STEPS + 1], vec![0.0; SECTION_STEPS + 1]];
        let mut inv_area = vec![0.0; SECTION_STEPS + 1];
        let integrand = |xi: f64| {
            let h = outline.half_thickness_at(x_root + dir * xi).max(1e-6);
            let inertia = (2.0 * h).powi(3) * width / 12.0;
            let area = 2.0 * h * width;
            ([1.0 / (e_plane * inertia), xi / (e_plane * inertia), xi * xi / (e_plane * inertia)], 1.0 / area)
        };
        let mut prev = integrand(0.0);
        for k in 1..=SECTION_STEPS {
            let cur = integrand(k as f64 * d);
            for (m, column) in j.iter_mut().enumerate() {
                column[k] = column[k - 1] + 0.5 * d * (prev.0[m] + cur.0[m]);
            }
            inv_area[k] = inv_area[k - 1] + 0.5 * d * (prev.1 + cur.1);
            prev = cur;
        }
        let at = |v: &[f64], xi: f64| {
            let x = (xi / d).clamp(0.0, SECTION_STEPS as f64);
            let i = (x.floor() as usize).min(SECTION_STEPS - 1);
            v[i] + (x - i as f64) * (v[i + 1] - v[i])
        };
        let h_f = foundation_ratio(form);
        let coef = sainsot_coefficients(theta_f, h_f);
        let s_f = 2.0 * form.root_radius * theta_f;
        let (xi_lo, xi_hi) = outline.involute_roll_range;
        let mut roll = Vec::with_capacity(CONTACT_SAMPLES + 1);
        let mut compliance = Vec::with_capacity(CONTACT_SAMPLES + 1);
        for k in 0..=CONTACT_SAMPLES {
            let xr = xi_lo + (xi_hi - xi_lo) * k as f64 / CONTACT_SAMPLES as f64;
            let r = radius_at_roll(xr, form.base_radius());
            let phi = form.involute_half_angle(r);
            let (xc, yc) = (r * phi.cos(), r * phi.sin());
            // Unit force on the tooth: opposite to the outward normal.
            let alpha = xr.atan();
            let normal_angle = match form.kind {
                GearKind::External => phi - alpha + std::f64::consts::FRAC_PI_2,
                GearKind::Internal => phi + alpha - std::f64::consts::FRAC_PI_2,
            };
            let (fx, fy) = (-normal_angle.cos(), -normal_angle.sin());
            let xi_c = dir * (xc - x_root);
            let b = xi_c * fy - dir * yc * fx;
            let bending =
                b * b * at(&j[0], xi_c) - 2.0 * b * fy * at(&j[1], xi_c) + fy * fy * at(&j[2], xi_c);
            let shear = 1.2 * fy * fy / g * at(&inv_area, xi_c);
            let axial = fx * fx / e_plane * at(&inv_area, xi_c);
            // Where the force line crosses the centreline, measured from the root chord.
            let x_cross = xc - yc * fx / fy;
            let u_f = dir * (x_cross - x_root);
            let cos2 = fy * fy;
            let tan2 = (fx / fy).powi(2);
            let ratio = u_f / s_f;
            let foundation = cos2 / (e * width)
                * (coef[0] * ratio * ratio + coef[1] * ratio + coef[2] * (1.0 + coef[3] * tan2));
            roll.push(xr);
            compliance.push(ToothCompliance { bending, shear, axial, foundation });
        }
        // Internal teeth run from the form circle inward: keep the grid increasing.
        if roll.first() > roll.last() {
            roll.reverse();
            compliance.reverse();
        }
        Self { roll, compliance, foundation_coefficients: coef }
    }

    /// Compliance at roll angle `xi`, clamped to the involute's ends.
    pub fn at(&self, xi: f64) -> ToothCompliance {
        let pick = |f: fn(&ToothCompliance) -> f64| {
            let y: Vec<f64> = self.compliance.iter().map(f).collect();
            interpolate(&self.roll, &y, xi)
        };
        ToothCompliance {
            bending: pick(|c| c.bending),
            shear: pick(|c| c.shear),
            axial: pick(|c| c.axial),
            foundation: pick(|c| c.foundation),
        }
    }

    /// Total compliance at roll angle `xi` [m/N].
    pub fn total_at(&self, xi: f64) -> f64 {
        let totals: Vec<f64> = self.compliance.iter().map(ToothCompliance::total).collect();
        interpolate(&self.roll, &totals, xi)
    }
}

/// Linear Hertzian compliance of a pair, 4(1 − ν²)/(π E L) [m/N].
pub fn hertz_compliance(material: &Material, face_width: f64) -> f64 {
    4.0 * (1.0 - material.poisson_ratio.powi(2))
        / (std::f64::consts::PI * material.youngs_modulus * face_width)
}

/// Tooth-pair stiffness of one mesh as a function of the contact position
/// on the line of action.
#[derive(Clone, Debug, PartialEq)]
pub struct PairStiffness {
    /// Path of contact.
    pub path: PathOfContact,
    /// Gear 1's tooth compliance.
    pub gear1: ToothComplianceCurve,
    /// Gear 2's tooth compliance.
    pub gear2: ToothComplianceCurve,
    /// Hertzian compliance of the pair [m/N].
    pub hertz: f64,
    /// Factor on the pair stiffness (the scene's correction, 1 by default) [-].
    pub scale: f64,
}

impl PairStiffness {
    /// The pair stiffness of a mesh of a gear set.
    pub fn new(set: &GearSet, mesh: MeshKind) -> Self {
        let (g1, g2) = set.mesh_gears(mesh);
        let width = g1.face_width.min(g2.face_width);
        Self {
            path: PathOfContact::new(set, mesh),
            gear1: ToothComplianceCurve::new(g1, set.material()),
            gear2: ToothComplianceCurve::new(g2, set.material()),
            hertz: hertz_compliance(set.material(), width),
            scale: set.stiffness_scale(mesh),
        }
    }

    /// Stiffness [N/m] of a pair touching at position `s` on its line of
    /// action. Outside the involutes (tip-corner contact) the compliance of
    /// the nearest involute end is used.
    pub fn at(&self, s: f64) -> f64 {
        let c =
            self.hertz + self.gear1.total_at(self.path.roll_1(s)) + self.gear2.total_at(self.path.roll_2(s));
        self.scale / c
    }
}
