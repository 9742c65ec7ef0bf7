//! The gear-data form of a gear in a scene file: a gear given as a drawing
//! gives it (ISO 21771: profile shift, basic rack factors, tooth-thickness
//! allowance, optional tip and root diameters) instead of its radii.
//!
//! A gear table holds either the radii (`tooth_thickness_mm`,
//! `tip_radius_mm`, `root_radius_mm`, `hob_tip_radius_mm`; for the ring
//! `tooth_thickness_mm`, `minor_radius_mm`, `root_radius_mm`,
//! `fillet_radius_mm`) or a `gear_data` sub-table, never both; `teeth`,
//! `module_mm`, `pressure_angle_deg`, the body radius, the face width and
//! the chamfer are written as in the radii form. This module reads and
//! writes the two forms; the model stage derives the radii from the gear
//! data (`crate::model::gear_data`) when the scene is validated. While a
//! gear is given by gear data its derived radius fields in the Rust value
//! hold 0 and are not read; validation refuses a value put there.

use serde::{Deserialize, Serialize};

use super::{units, ChamferSpec, ExternalGearSpec, RingGearSpec};

/// ISO 21771 gear data of one gear (sun, planet or ring), the part of a
/// drawing's gear data that fixes its radii and tooth thickness.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearData {
    /// Profile shift coefficient x [-]. For the ring (internal gear) a
    /// positive x moves the profile away from the axis, as in ISO 21771:
    /// larger minor and root diameters, thinner ring teeth.
    #[serde(default)]
    pub profile_shift: f64,
    /// Addendum factor of the basic rack h_aP* [-] (the gear's addendum is
    /// (h_aP* + x)·m, the ring's (h_aP* − x)·m).
    #[serde(default = "addendum_factor_default")]
    pub addendum_factor: f64,
    /// Dedendum factor of the basic rack h_fP* [-] (the tool's addendum).
    #[serde(default = "dedendum_factor_default")]
    pub dedendum_factor: f64,
    /// Tip radius factor of the tool ρ_fP* [-]: the hob's tip radius
    /// ρ_fP*·m for sun and planet, the ring's root fillet radius for the ring.
    #[serde(default = "tool_tip_radius_factor_default")]
    pub tool_tip_radius_factor: f64,
    /// Tooth-thickness allowance A_s \[m\] (file: `tooth_thickness_allowance_mm`)
    /// on the circular tooth thickness at the reference circle (zero or
    /// negative: it thins the tooth and carries the backlash).
    #[serde(rename = "tooth_thickness_allowance_mm", with = "units::mm", default)]
    pub tooth_thickness_allowance: f64,
    /// Tip diameter \[m\] (file: `tip_diameter_mm`; the ring's minor
    /// diameter) as made, overriding the one of the addendum factor and
    /// profile shift.
    #[serde(
        rename = "tip_diameter_mm",
        with = "units::mm",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub tip_diameter: Option<f64>,
    /// Root diameter \[m\] (file: `root_diameter_mm`) as made, overriding the
    /// one of the dedendum factor and profile shift.
    #[serde(
        rename = "root_diameter_mm",
        with = "units::mm",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub root_diameter: Option<f64>,
}

/// Basic rack profile A of ISO 53: h_aP* = 1.
pub const ADDENDUM_FACTOR: f64 = 1.0;
/// Basic rack profile A of ISO 53: h_fP* = 1.25.
pub const DEDENDUM_FACTOR: f64 = 1.25;
/// Basic rack profile A of ISO 53: ρ_fP* = 0.38.
pub const TOOL_TIP_RADIUS_FACTOR: f64 = 0.38;

fn addendum_factor_default() -> f64 {
    ADDENDUM_FACTOR
}

fn dedendum_factor_default() -> f64 {
    DEDENDUM_FACTOR
}

fn tool_tip_radius_factor_default() -> f64 {
    TOOL_TIP_RADIUS_FACTOR
}

impl GearData {
    /// Gear data of an unshifted gear on the ISO 53 profile A basic rack
    /// without allowance.
    pub fn standard() -> Self {
        Self {
            profile_shift: 0.0,
            addendum_factor: ADDENDUM_FACTOR,
            dedendum_factor: DEDENDUM_FACTOR,
            tool_tip_radius_factor: TOOL_TIP_RADIUS_FACTOR,
            tooth_thickness_allowance: 0.0,
            tip_diameter: None,
            root_diameter: None,
        }
    }
}

impl Default for GearData {
    fn default() -> Self {
        Self::standard()
    }
}

/// An external gear table as written: the radii form or the gear-data form.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ExternalGearFile {
    teeth: u32,
    #[serde(rename = "module_mm", with = "units::mm")]
    module: f64,
    #[serde(rename = "pressure_angle_deg", with = "units::deg")]
    pressure_angle: f64,
    #[serde(
        rename = "tooth_thickness_mm",
        with = "units::mm",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    tooth_thickness: Option<f64>,
    #[serde(rename = "tip_radius_mm", with = "units::mm", default, skip_serializing_if = "Option::is_none")]
    tip_radius: Option<f64>,
    #[serde(rename = "root_radius_mm", with = "units::mm", default, skip_serializing_if = "Option::is_none")]
    root_radius: Option<f64>,
    #[serde(rename = "bore_radius_mm", with = "units::mm")]
    bore_radius: f64,
    #[serde(
        rename = "hob_tip_radius_mm",
        with = "units::mm",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    hob_tip_radius: Option<f64>,
    #[serde(rename = "face_width_mm", with = "units::mm")]
    face_width: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tip_chamfer: Option<ChamferSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    gear_data: Option<GearData>,
}

/// The ring's table as written: the radii form or the gear-data form.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RingGearFile {
    teeth: u32,
    #[serde(rename = "module_mm", with = "units::mm")]
    module: f64,
    #[serde(rename = "pressure_angle_deg", with = "units::deg")]
    pressure_angle: f64,
    #[serde(
        rename = "tooth_thickness_mm",
        with = "units::mm",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    tooth_thickness: Option<f64>,
    #[serde(
        rename = "minor_radius_mm",
        with = "units::mm",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    minor_radius: Option<f64>,
    #[serde(rename = "root_radius_mm", with = "units::mm", default, skip_serializing_if = "Option::is_none")]
    root_radius: Option<f64>,
    #[serde(rename = "rim_radius_mm", with = "units::mm")]
    rim_radius: f64,
    #[serde(
        rename = "fillet_radius_mm",
        with = "units::mm",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    fillet_radius: Option<f64>,
    #[serde(rename = "face_width_mm", with = "units::mm")]
    face_width: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tip_chamfer: Option<ChamferSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    gear_data: Option<GearData>,
}

/// The radius fields of one form: every one given (radii form) or none
/// (gear-data form); the message names what is missing or doubled.
fn one_form(derived: &[(&str, Option<f64>)], has_gear_data: bool) -> Result<Vec<f64>, String> {
    if has_gear_data {
        let given: Vec<&str> = derived.iter().filter(|(_, v)| v.is_some()).map(|(k, _)| *k).collect();
        if !given.is_empty() {
            return Err(format!(
                "{} given together with gear_data: a gear is given either by its radii or by its gear data \
                 (gear_data.tip_diameter_mm and gear_data.root_diameter_mm override the derived diameters)",
                given.join(", ")
            ));
        }
        Ok(vec![0.0; derived.len()])
    } else {
        let missing: Vec<&str> = derived.iter().filter(|(_, v)| v.is_none()).map(|(k, _)| *k).collect();
        if !missing.is_empty() {
            return Err(format!(
                "missing field {}: a gear is given by its radii ({}) or by a gear_data table",
                missing.join(", "),
                derived.iter().map(|(k, _)| *k).collect::<Vec<_>>().join(", ")
            ));
        }
        Ok(derived.iter().filter_map(|(_, v)| *v).collect())
    }
}

impl TryFrom<ExternalGearFile> for ExternalGearSpec {
    type Error = String;

    fn try_from(f: ExternalGearFile) -> Result<Self, String> {
        let v = one_form(
            &[
                ("tooth_thickness_mm", f.tooth_thickness),
                ("tip_radius_mm", f.tip_radius),
                ("root_radius_mm", f.root_radius),
                ("hob_tip_radius_mm", f.hob_tip_radius),
            ],
            f.gear_data.is_some(),
        )?;
        Ok(Self {
            teeth: f.teeth,
            module: f.module,
            pressure_angle: f.pressure_angle,
            tooth_thickness: v[0],
            tip_radius: v[1],
            root_radius: v[2],
            bore_radius: f.bore_radius,
            hob_tip_radius: v[3],
            face_width: f.face_width,
            tip_chamfer: f.tip_chamfer,
            gear_data: f.gear_data,
        })
    }
}

impl From<ExternalGearSpec> for ExternalGearFile {
    fn from(g: ExternalGearSpec) -> Self {
        let radius = |v: f64| g.gear_data.is_none().then_some(v);
        Self {
            teeth: g.teeth,
            module: g.module,
            pressure_angle: g.pressure_angle,
            tooth_thickness: radius(g.tooth_thickness),
            tip_radius: radius(g.tip_radius),
            root_radius: radius(g.root_radius),
            bore_radius: g.bore_radius,
            hob_tip_radius: radius(g.hob_tip_radius),
            face_width: g.face_width,
            tip_chamfer: g.tip_chamfer,
            gear_data: g.gear_data,
        }
    }
}

impl TryFrom<RingGearFile> for RingGearSpec {
    type Error = String;

    fn try_from(f: RingGearFile) -> Result<Self, String> {
        let v = one_form(
            &[
                ("tooth_thickness_mm", f.tooth_thickness),
                ("minor_radius_mm", f.minor_radius),
                ("root_radius_mm", f.root_radius),
                ("fillet_radius_mm", f.fillet_radius),
            ],
            f.gear_data.is_some(),
        )?;
        Ok(Self {
            teeth: f.teeth,
            module: f.module,
            pressure_angle: f.pressure_angle,
            tooth_thickness: v[0],
            minor_radius: v[1],
            root_radius: v[2],
            rim_radius: f.rim_radius,
            fillet_radius: v[3],
            face_width: f.face_width,
            tip_chamfer: f.tip_chamfer,
            gear_data: f.gear_data,
        })
    }
}

impl From<RingGearSpec> for RingGearFile {
    fn from(g: RingGearSpec) -> Self {
        let radius = |v: f64| g.gear_data.is_none().then_some(v);
        Self {
            teeth: g.teeth,
            module: g.module,
            pressure_angle: g.pressure_angle,
            tooth_thickness: radius(g.tooth_thickness),
            minor_radius: radius(g.minor_radius),
            root_radius: radius(g.root_radius),
            rim_radius: g.rim_radius,
            fillet_radius: radius(g.fillet_radius),
            face_width: g.face_width,
            tip_chamfer: g.tip_chamfer,
            gear_data: g.gear_data,
        }
    }
}
