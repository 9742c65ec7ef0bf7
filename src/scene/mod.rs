//! Scenes: what a user writes to describe a planetary gear set, and its
//! validation into the SI types the physics accepts.
//!
//! A [`Scene`] is the file as written (TOML, engineering units named in every
//! key: `_mm`, `_deg`, `_gpa`, `_nm`, `_n_per_m`). [`Scene::validate`] checks
//! every rule at once and returns either a [`GearSet`] (SI inside, proven
//! valid) or a [`SceneError`] listing one [`Problem`] per broken rule, each
//! naming the parameter and what is allowed.

mod example;
mod validate;

use serde::{Deserialize, Serialize};

pub use validate::{Problem, SceneError};

use crate::physics::gear::{GearSet, Member};

/// A planetary gear set as written in a scene file (engineering units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Free-text name of the scene.
    pub name: String,
    /// Sun gear (external).
    pub sun: ExternalGearSpec,
    /// Planet gears (external, all identical).
    pub planet: ExternalGearSpec,
    /// Ring gear (internal).
    pub ring: RingGearSpec,
    /// Number and placement of the planets.
    pub planets: PlanetLayoutSpec,
    /// Centre distance sun–planet = ring–planet [mm]. The operating pressure
    /// angles of both meshes follow from it and the base radii.
    pub centre_distance_mm: f64,
    /// Material of all gears.
    #[serde(default)]
    pub material: MaterialSpec,
    /// Which member is held fixed, which one is driven, and the drive torque.
    pub operation: OperationSpec,
    /// Resolution of the quasi-static analyses.
    #[serde(default)]
    pub analysis: AnalysisSpec,
}

/// An external spur gear (sun or planet) as written in a scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExternalGearSpec {
    /// Number of teeth.
    pub teeth: u32,
    /// Module [mm].
    pub module_mm: f64,
    /// Pressure angle of the generating rack [deg]; with the standard centre
    /// distance it is also the operating pressure angle.
    pub pressure_angle_deg: f64,
    /// Circular tooth thickness at the reference circle m·Z/2 [mm]; it carries
    /// the backlash allowance.
    pub tooth_thickness_mm: f64,
    /// Tip radius [mm].
    pub tip_radius_mm: f64,
    /// Root radius [mm].
    pub root_radius_mm: f64,
    /// Bore (inner) radius of the gear body [mm].
    pub bore_radius_mm: f64,
    /// Tip radius of the hob that generated the root fillet [mm].
    pub hob_tip_radius_mm: f64,
    /// Face width [mm].
    pub face_width_mm: f64,
    /// Tip chamfer; `None` (omitted) means the default of docs/PARAMETERS.md.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip_chamfer: Option<ChamferSpec>,
}

/// The internal ring gear as written in a scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RingGearSpec {
    /// Number of teeth.
    pub teeth: u32,
    /// Module [mm].
    pub module_mm: f64,
    /// Pressure angle of the generating tool [deg].
    pub pressure_angle_deg: f64,
    /// Circular tooth thickness of a ring tooth at the reference circle [mm].
    pub tooth_thickness_mm: f64,
    /// Minor radius: the radius of the ring's tooth tips [mm].
    pub minor_radius_mm: f64,
    /// Root radius [mm].
    pub root_radius_mm: f64,
    /// Outside radius of the rim [mm].
    pub rim_radius_mm: f64,
    /// Radius of the root fillet [mm].
    pub fillet_radius_mm: f64,
    /// Face width [mm].
    pub face_width_mm: f64,
    /// Tip chamfer of the ring teeth; omitted means none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip_chamfer: Option<ChamferSpec>,
}

/// A straight tip chamfer: it starts on the involute `height_mm` below the
/// tip circle and meets the tip circle at `angle_deg` to the tip circle's
/// tangent (the usual "h × 45°" edge break).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChamferSpec {
    /// Radial height of the chamfer [mm].
    pub height_mm: f64,
    /// Angle between the chamfer and the tip circle's tangent [deg].
    pub angle_deg: f64,
}

/// Number and placement of the planets.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanetLayoutSpec {
    /// Number of planets.
    pub count: u32,
    /// Angular positions of the planet centres [deg], counter-clockwise from
    /// the first; omitted means equally spaced.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angles_deg: Option<Vec<f64>>,
}

/// Material constants of all gears.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Young's modulus [GPa].
    pub youngs_modulus_gpa: f64,
    /// Poisson's ratio [-].
    pub poisson_ratio: f64,
    /// Density [kg/m³].
    pub density_kg_per_m3: f64,
}

impl Default for MaterialSpec {
    /// Steel (MODEL.md §1).
    fn default() -> Self {
        Self { youngs_modulus_gpa: 207.0, poisson_ratio: 0.3, density_kg_per_m3: 7850.0 }
    }
}

/// Which member is held, which is driven and by what torque.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OperationSpec {
    /// The member held fixed.
    pub held: Member,
    /// The driving (input) member.
    pub input: Member,
    /// Torque on the input member [N·m], for the whole face width.
    pub input_torque_nm: f64,
}

/// Resolution of the quasi-static analyses.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AnalysisSpec {
    /// Mesh positions per mesh cycle in the loaded tooth contact analysis.
    pub positions_per_mesh_cycle: u32,
    /// Points along each flank's profile-deviation grid (I of MODEL.md §4).
    pub profile_points: u32,
    /// Slices across the face width (J; 1 means a 2-D profile grid).
    pub face_slices: u32,
}

impl Default for AnalysisSpec {
    fn default() -> Self {
        Self { positions_per_mesh_cycle: 200, profile_points: 50, face_slices: 1 }
    }
}

impl Scene {
    /// Parses a scene from TOML text.
    pub fn from_toml(text: &str) -> Result<Self, SceneError> {
        toml::from_str(text).map_err(|e| SceneError::Syntax { message: e.to_string() })
    }

    /// The scene as TOML text a user can edit.
    pub fn to_toml(&self) -> String {
        // Serialising plain data structs to TOML cannot fail: every field is
        // a number, string, table or array of numbers.
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// A built-in scene by name.
    pub fn builtin(name: &str) -> Option<Self> {
        match name {
            "example-2004" => Some(Self::example_2004()),
            _ => None,
        }
    }

    /// Names of the built-in scenes.
    pub const BUILTIN: &'static [&'static str] = &["example-2004"];

    /// Checks every rule and converts to SI.
    pub fn validate(&self) -> Result<GearSet, SceneError> {
        validate::validate(self)
    }
}
