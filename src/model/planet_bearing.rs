//! The radial stiffness of a planet on its pin: a needle roller bearing
//! running directly in the planet's bore and on the pin, in series with the
//! pin bent and sheared between the two carrier plates.
//!
//! Bearing (Harris & Kotzalas, Rolling Bearing Analysis: Palmgren's
//! line-contact deflection and Stribeck's load distribution): each roller–raceway line contact deflects by Palmgren's
//!
//! δ_c = 3.84e-5 · Q^0.9 / l^0.8   (δ_c in mm, Q in N, l in mm),
//!
//! a roller by δ_j = 2 δ_c (inner and outer raceway), so Q_j = K_n δ_j^(10/9).
//! Without clearance a radial shift δ_r of the pin in the bore loads the
//! rollers at angles ψ_j from the load line with δ_j = δ_r cos ψ_j (Stribeck),
//!
//! F_r = Σ_{cos ψ_j > 0} K_n (δ_r cos ψ_j)^(10/9) cos ψ_j,
//!
//! homogeneous of degree 10/9 in δ_r: the tangent stiffness at the load is
//! k_b = dF_r/dδ_r = (10/9) F_r/δ_r, and across the load F_r/δ_r.
//!
//! Pin: a round steel beam of span L between the plates, clamped in both
//! (a press fit), under the bearing load spread evenly along the span: at
//! mid-span bending F L³/(384 E I) and shear F L/(8 κ G A) (Roark's Formulas
//! for Stress and Strain, the beam with both ends fixed under a uniform
//! load; κ = 0.9 for a round section after Cowper), so k_pin = F / (δ_bending + δ_shear).
//!
//! The planet's support stiffness is k = (1/k_b + 1/k_pin)⁻¹.

use crate::model::gear::{GearSet, MeshKind};

/// A needle roller bearing in a planet's bore on a pin between two plates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeedleBearing {
    /// Roller diameter \[m\].
    pub roller_diameter: f64,
    /// Effective roller length (the contact length) \[m\].
    pub roller_length: f64,
    /// Number of rollers.
    pub rollers: u32,
    /// Span of the pin between the carrier plates \[m\].
    pub pin_span: f64,
}

impl NeedleBearing {
    /// The bearing assumed for the 2004 example (docs/PARAMETERS.md): rollers
    /// of 2 mm running directly in the 11.88 mm planet bore (so the pin is
    /// 7.88 mm), 26 mm long (the 30 mm face less the cage's side rims), 12
    /// of them in a cage, the pin spanning 32 mm between the plates (the
    /// face and two 1 mm thrust washers).
    pub fn example_2004() -> Self {
        Self { roller_diameter: 2.0e-3, roller_length: 26.0e-3, rollers: 12, pin_span: 32.0e-3 }
    }
}

/// The stiffness of a planet's support and the figures it comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanetSupport {
    /// Bearing load: the vector sum of the planet's two mesh forces \[N\].
    pub load: f64,
    /// Pin diameter (the bore less two rollers) \[m\].
    pub pin_diameter: f64,
    /// Load of the most loaded roller \[N\].
    pub roller_load_max: f64,
    /// Stribeck's number Q_max · Z / F_r [-].
    pub stribeck_number: f64,
    /// Radial deflection of the bearing at the load \[m\].
    pub bearing_deflection: f64,
    /// Tangent stiffness of the bearing along the load, (10/9) F_r/δ_r [N/m].
    pub bearing_stiffness: f64,
    /// Stiffness of the bearing across the load, F_r/δ_r [N/m].
    pub bearing_stiffness_across: f64,
    /// Stiffness of the pin between the plates (bending and shear) [N/m].
    pub pin_stiffness: f64,
    /// The support: bearing along the load and pin in series [N/m].
    pub stiffness: f64,
}

/// Palmgren's deflection of one roller–raceway line contact \[m\] under the
/// roller load `q` \[N\] over the contact length `length` \[m\] (the formula
/// in mm and N).
pub fn palmgren_deflection(q: f64, length: f64) -> f64 {
    3.84e-5 * q.powf(0.9) / (length * 1e3).powf(0.8) * 1e-3
}

/// The support stiffness of each planet of `set` on `bearing`: the bearing
/// load from the set's mesh load per planet ([`GearSet::mesh_load_per_planet`])
/// along both lines of action, with the most loaded roller on the load line.
pub fn planet_support(set: &GearSet, bearing: &NeedleBearing) -> PlanetSupport {
    let w = set.mesh_load_per_planet();
    let (a_s, a_r) = (
        set.operating_pressure_angle(MeshKind::SunPlanet),
        set.operating_pressure_angle(MeshKind::RingPlanet),
    );
    // The sun pushes the planet along its line of action tilted by α_s from
    // the tangent, the ring along its line tilted the other way by α_r: the
    // radial parts cancel as far as the angles agree.
    let load = w * ((a_s.cos() + a_r.cos()).powi(2) + (a_s.sin() - a_r.sin()).powi(2)).sqrt();
    let bore = 2.0 * set.planet().body_radius;
    let pin_diameter = bore - 2.0 * bearing.roller_diameter;
    // Roller law Q = K_n δ_j^(10/9) from δ_j = 2 δ_c(Q): K_n from one point.
    let q_ref = 1.0e3;
    let k_n = q_ref / (2.0 * palmgren_deflection(q_ref, bearing.roller_length)).powf(10.0 / 9.0);
    let z = bearing.rollers;
    let sum: f64 = (0..z)
        .map(|j| (2.0 * std::f64::consts::PI * f64::from(j) / f64::from(z)).cos())
        .filter(|c| *c > 0.0)
        .map(|c| c.powf(10.0 / 9.0) * c)
        .sum();
    let bearing_deflection = (load / (k_n * sum)).powf(0.9);
    let roller_load_max = k_n * bearing_deflection.powf(10.0 / 9.0);
    let bearing_stiffness_across = load / bearing_deflection;
    let bearing_stiffness = 10.0 / 9.0 * bearing_stiffness_across;
    let m = set.material();
    let (e, g) = (m.youngs_modulus, m.shear_modulus());
    let area = std::f64::consts::PI * pin_diameter * pin_diameter / 4.0;
    let inertia = std::f64::consts::PI * pin_diameter.powi(4) / 64.0;
    let l = bearing.pin_span;
    let compliance = l.powi(3) / (384.0 * e * inertia) + l / (8.0 * 0.9 * g * area);
    let pin_stiffness = 1.0 / compliance;
    PlanetSupport {
        load,
        pin_diameter,
        roller_load_max,
        stribeck_number: roller_load_max * f64::from(z) / load,
        bearing_deflection,
        bearing_stiffness,
        bearing_stiffness_across,
        pin_stiffness,
        stiffness: 1.0 / (1.0 / bearing_stiffness + 1.0 / pin_stiffness),
    }
}
