//! ISO 6336-1 single stiffness c' and mesh stiffness c_γα (method B), the
//! sanity band for the potential-energy stiffness (docs/FORMULAS.md).
//!
//! q' = C1 + C2/z_n1 + C3/z_n2 + C4 x1 + C5 x1/z_n1 + C6 x2 + C7 x2/z_n2 + C8 x1² + C9 x2²
//! [mm·µm/N], z_n = z / (cos²β_b cos β), internal gears z_n2 = ∞;
//! c'_th = 1/q'; c' = c'_th C_M C_R C_B cos β with C_M = 0.8, C_R = 1 (solid
//! blanks), C_B = [1 + 0.5(1.2 − h_fP/m_n)][1 − 0.02(20° − α_Pn)];
//! c_γα = c'(0.75 ε_α + 0.25). Stiffnesses in N/(mm·µm) per mm of face width.

use serde::{Deserialize, Serialize};

use crate::model::gear::{GearSet, MeshKind};

/// Inputs of the ISO stiffness of one gear pair.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IsoPair {
    /// Teeth of gear 1 (pinion).
    pub z1: f64,
    /// Teeth of gear 2; `None` for an internal gear (z_n2 = ∞).
    pub z2: Option<f64>,
    /// Profile shift coefficient of gear 1.
    pub x1: f64,
    /// Profile shift coefficient of gear 2.
    pub x2: f64,
    /// Helix angle \[rad\].
    pub helix: f64,
    /// Normal pressure angle of the basic rack \[rad\].
    pub rack_pressure_angle: f64,
    /// Basic rack dedendum over normal module, h_fP / m_n.
    pub rack_dedendum: f64,
    /// Transverse contact ratio ε_α.
    pub contact_ratio: f64,
}

impl IsoPair {
    /// The ISO inputs of a mesh of a gear set with transverse contact ratio
    /// `contact_ratio`: profile shifts from the tooth thicknesses with the
    /// circumferential backlash shared equally, the basic-rack dedendum from
    /// gear 1's root radius, spur teeth (the ring, gear 2 of its mesh, is
    /// internal: z_n2 = ∞).
    pub fn of_mesh(set: &GearSet, mesh: MeshKind, contact_ratio: f64) -> Self {
        let (g1, g2) = set.mesh_gears(mesh);
        let j = set.circumferential_backlash(mesh);
        let a = g1.pressure_angle;
        let m = g1.module;
        let shift = |t: f64| (t + j / 2.0 - std::f64::consts::PI * m / 2.0) / (2.0 * m * a.tan());
        let x1 = shift(g1.tooth_thickness);
        let (z2, x2) = match mesh {
            MeshKind::SunPlanet => (Some(f64::from(g2.teeth)), shift(g2.tooth_thickness)),
            MeshKind::RingPlanet => (None, 0.0),
        };
        Self {
            z1: f64::from(g1.teeth),
            z2,
            x1,
            x2,
            helix: 0.0,
            rack_pressure_angle: a,
            rack_dedendum: (g1.reference_radius() + x1 * m - g1.root_radius) / m,
            contact_ratio,
        }
    }
}

/// ISO 6336-1 stiffnesses [N/(mm·µm)].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IsoStiffness {
    /// Theoretical single stiffness c'_th.
    pub single_theoretical: f64,
    /// Single stiffness c'.
    pub single: f64,
    /// Mesh stiffness c_γα.
    pub mesh: f64,
}

/// Evaluates ISO 6336-1 method B.
pub fn iso_stiffness(p: &IsoPair) -> IsoStiffness {
    const C: [f64; 9] = [0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182];
    let beta_b = (p.helix.tan() * p.rack_pressure_angle.cos()).atan();
    let zn = |z: f64| z / (beta_b.cos().powi(2) * p.helix.cos());
    let zn1 = zn(p.z1);
    let inv_zn2 = p.z2.map_or(0.0, |z| 1.0 / zn(z));
    let q = C[0]
        + C[1] / zn1
        + C[2] * inv_zn2
        + C[3] * p.x1
        + C[4] * p.x1 / zn1
        + C[5] * p.x2
        + C[6] * p.x2 * inv_zn2
        + C[7] * p.x1 * p.x1
        + C[8] * p.x2 * p.x2;
    let single_theoretical = 1.0 / q;
    let c_b =
        (1.0 + 0.5 * (1.2 - p.rack_dedendum)) * (1.0 - 0.02 * (20.0 - p.rack_pressure_angle.to_degrees()));
    let single = single_theoretical * 0.8 * 1.0 * c_b * p.helix.cos();
    IsoStiffness { single_theoretical, single, mesh: single * (0.75 * p.contact_ratio + 0.25) }
}
