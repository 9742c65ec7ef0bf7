//! Stage 1, scene: what a user writes to describe a planetary gear set.
//!
//! A [`Scene`] is the file as written, held in SI: the file (TOML) names
//! an engineering unit in every key (`_mm`, `_deg`, `_gpa`, `_rpm`, `_nm`,
//! `_n_per_m`), and a key in mm, degrees, GPa or rpm is held in m, rad, Pa
//! or rad/s by the field of its name without the unit (`module_mm` by
//! `module`), converted as the file is read and written by [`units`], so a
//! number a user wrote is written back as written. With it come the
//! built-in scenes and the words the file is written in (members, drives,
//! integrators, fidelity). `Scene::validate` (in [`crate::model::build`])
//! checks every rule at once and returns either the model's `GearSet`
//! (proven valid; with its `RunSettings` through
//! `Scene::validate_with_run`) or a [`SceneError`] listing one [`Problem`]
//! per broken rule, each naming the parameter by its file key, with its
//! value in the key's unit, and what is allowed.
//!
//! May import: [`crate::files`].

mod example;
mod gear_data;
pub mod lumped;
mod terms;
pub mod units;
mod validate;

use serde::{Deserialize, Serialize};

pub use gear_data::{GearData, ADDENDUM_FACTOR, DEDENDUM_FACTOR, TOOL_TIP_RADIUS_FACTOR};
pub use validate::{default_chamfer, Problem, SceneError};

pub use terms::{ContactModel, DampingModel, Drive, Fidelity, IntegratorKind, Member, Response};

/// A planetary gear set as written in a scene file, held in SI (the file's
/// engineering units converted by [`units`] as it is read and written).
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
    /// Centre distance sun–planet = ring–planet \[m\] (file: mm). The
    /// operating pressure angles of both meshes follow from it and the base
    /// radii.
    #[serde(rename = "centre_distance_mm", with = "units::mm")]
    pub centre_distance: f64,
    /// Material of all gears.
    #[serde(default)]
    pub material: MaterialSpec,
    /// Which member is held fixed, which one is driven, and the drive torque.
    pub operation: OperationSpec,
    /// Resolution of the quasi-static analyses.
    #[serde(default)]
    pub analysis: AnalysisSpec,
    /// Bearing supports (defaults and reasons: docs/PARAMETERS.md).
    #[serde(default)]
    pub supports: SupportSpec,
    /// Inertia overrides; omitted values are derived from the geometry.
    #[serde(default)]
    pub inertia: InertiaSpec,
    /// Corrections of the tooth-pair stiffness of each mesh.
    #[serde(default)]
    pub mesh_stiffness: MeshStiffnessSpec,
    /// Dynamic model and integrator settings.
    #[serde(default)]
    pub dynamics: DynamicsSpec,
}

/// Bearing supports of the members.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SupportSpec {
    /// Radial bearing stiffness of the sun, per direction [N/m].
    pub sun_radial_n_per_m: f64,
    /// Radial bearing stiffness of the ring, per direction [N/m].
    pub ring_radial_n_per_m: f64,
    /// Radial bearing stiffness of the carrier, per direction [N/m].
    pub carrier_radial_n_per_m: f64,
    /// Stiffness of each planet bearing, radial and tangential [N/m].
    pub planet_bearing_n_per_m: f64,
    /// Damping ratio of every bearing (on the mode of the supported body on its bearing).
    pub bearing_damping_ratio: f64,
    /// Per-planet bearing stiffnesses [N/m], overriding `planet_bearing_n_per_m`
    /// (one value per planet).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planet_bearings_n_per_m: Option<Vec<f64>>,
    /// Damping ratio of the sun bearing, overriding `bearing_damping_ratio`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sun_damping_ratio: Option<f64>,
    /// Damping ratio of the ring bearing, overriding `bearing_damping_ratio`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ring_damping_ratio: Option<f64>,
    /// Damping ratio of the carrier bearing, overriding `bearing_damping_ratio`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub carrier_damping_ratio: Option<f64>,
    /// Damping ratio of the planet bearings, overriding `bearing_damping_ratio`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planet_damping_ratio: Option<f64>,
}

impl Default for SupportSpec {
    fn default() -> Self {
        Self {
            sun_radial_n_per_m: 1.0e8,
            ring_radial_n_per_m: 1.0e9,
            carrier_radial_n_per_m: 1.0e9,
            planet_bearing_n_per_m: 3.0e8,
            bearing_damping_ratio: 0.02,
            planet_bearings_n_per_m: None,
            sun_damping_ratio: None,
            ring_damping_ratio: None,
            carrier_damping_ratio: None,
            planet_damping_ratio: None,
        }
    }
}

/// Factors on the tooth-pair stiffness of the potential-energy method, one
/// per mesh: a correction for what the 2-D tooth model leaves out (rim and
/// hub compliance, a measured or finite-element stiffness). 1 uses the
/// method's stiffness as it is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeshStiffnessSpec {
    /// Factor on the sun–planet pair stiffness [-].
    pub sun_planet_scale: f64,
    /// Factor on the ring–planet pair stiffness [-].
    pub ring_planet_scale: f64,
}

impl Default for MeshStiffnessSpec {
    fn default() -> Self {
        Self { sun_planet_scale: 1.0, ring_planet_scale: 1.0 }
    }
}

/// Optional overrides of masses \[kg\] and polar moments of inertia [kg·m²].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InertiaSpec {
    /// Sun mass \[kg\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sun_mass_kg: Option<f64>,
    /// Sun polar moment of inertia [kg·m²].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sun_inertia_kg_m2: Option<f64>,
    /// Planet mass \[kg\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planet_mass_kg: Option<f64>,
    /// Planet polar moment of inertia [kg·m²].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub planet_inertia_kg_m2: Option<f64>,
    /// Ring mass \[kg\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ring_mass_kg: Option<f64>,
    /// Ring polar moment of inertia [kg·m²].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ring_inertia_kg_m2: Option<f64>,
    /// Carrier mass without planets \[kg\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub carrier_mass_kg: Option<f64>,
    /// Carrier polar moment of inertia without planets [kg·m²].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub carrier_inertia_kg_m2: Option<f64>,
}

/// Default node spacing of input speed of the steady cache \[rpm\]: about a tenth of the
/// half-power width of the example's mesh resonances at its mesh damping (docs/STEADY.md).
pub const STEADY_SPEED_STEP_RPM: f64 = 200.0;
/// Default node spacing of input torque of the steady cache, a fraction of the input torque.
pub const STEADY_TORQUE_STEP: f64 = 0.2;
/// Default lowest input speed the steady cache solves \[rpm\].
pub const STEADY_SPEED_FLOOR_RPM: f64 = 500.0;
/// Default largest interpolation error of the steady cache (of the static mesh load).
pub const STEADY_AGREEMENT: f64 = 0.05;
/// Default halvings of a steady-cache cell.
pub const STEADY_REFINEMENTS: u32 = 3;

fn is_default_steady_speed_step(x: &f64) -> bool {
    *x == units::rpm_to_rad_per_s(STEADY_SPEED_STEP_RPM)
}
fn is_default_steady_speed_floor(x: &f64) -> bool {
    *x == units::rpm_to_rad_per_s(STEADY_SPEED_FLOOR_RPM)
}
fn is_default_steady_agreement(x: &f64) -> bool {
    *x == STEADY_AGREEMENT
}
fn is_default_steady_refinements(x: &u32) -> bool {
    *x == STEADY_REFINEMENTS
}

/// Dynamic model and integrator settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsSpec {
    /// Degrees of freedom.
    pub fidelity: Fidelity,
    /// Viscous mesh damping as a ratio of the mesh mode's critical damping
    /// (read only with `damping = "ratio"`) [-].
    pub mesh_damping_ratio: f64,
    /// The damping model: `"ratio"` (the mesh and bearing damping ratios) or
    /// `"rayleigh"` (C = μM + ηK with the two coefficients below; the damping
    /// ratios are then not read).
    #[serde(skip_serializing_if = "DampingModel::is_ratio")]
    pub damping: DampingModel,
    /// The tooth contact law: `"pair"` (each tooth pair its own spring) or
    /// `"deformable"` (all pairs of a mesh solved together over
    /// finite-element bodies; the mesh stiffness scales are then not read).
    #[serde(skip_serializing_if = "ContactModel::is_pair")]
    pub contact: ContactModel,
    /// Mass-proportional Rayleigh coefficient μ, acting on the motion
    /// relative to the rigid-body rotation of the train \[1/s\].
    #[serde(skip_serializing_if = "is_zero")]
    pub rayleigh_mass_per_s: f64,
    /// Stiffness-proportional Rayleigh coefficient η, on the meshes' tangent
    /// stiffness and the bearings' stiffness \[s\].
    #[serde(skip_serializing_if = "is_zero")]
    pub rayleigh_stiffness_s: f64,
    /// How the input is driven.
    pub drive: Drive,
    /// Input speed \[rad/s\] (file: rpm) of a single run (sweeps set their own).
    #[serde(rename = "input_speed_rpm", with = "units::rpm")]
    pub input_speed: f64,
    /// Torsional stiffness of the input shaft for the speed drive [N·m/rad].
    pub shaft_stiffness_nm_per_rad: f64,
    /// Integrator.
    pub integrator: IntegratorKind,
    /// Spectral radius at infinite frequency of the generalized-α method.
    pub rho_infinity: f64,
    /// Steps per mesh cycle of the generalized-α method.
    pub steps_per_mesh_cycle: u32,
    /// Relative tolerance of the adaptive method.
    pub relative_tolerance: f64,
    /// Relative tolerance of the adaptive method in the time-domain
    /// simulation (the FMU's `relativeTolerance`, `planetwear simulate`).
    /// Its error weight measures rotations and their rates from the
    /// rigid-body motion of the communication step, not from zero, so the
    /// allowance does not grow with the angle turned and a looser value
    /// holds the same accuracy (docs/PERFORMANCE.md).
    pub simulation_relative_tolerance: f64,
    /// Longest run-in before measuring, in input revolutions.
    pub run_in_revolutions: f64,
    /// The run-in ends early once two successive mesh cycles agree to this
    /// fraction of the mean tooth force; 0 runs the whole run-in.
    pub steady_tolerance: f64,
    /// Measured window, in input revolutions (rounded to whole mesh cycles).
    pub measured_revolutions: f64,
    /// Samples per mesh cycle of the recorded outputs.
    pub samples_per_mesh_cycle: u32,
    /// How `simulate` and the FMU compute the tooth outputs: `"time"` (integrated over
    /// every mesh cycle, the default) or `"steady"` (the rigid-body rotation at the
    /// communication step, the tooth outputs from cached periodic steady states:
    /// docs/STEADY.md).
    #[serde(skip_serializing_if = "Response::is_time")]
    pub response: Response,
    /// The steady response's cache: node spacing of input speed on its coarsest grid
    /// \[rad/s\] (file: rpm).
    #[serde(
        rename = "steady_speed_step_rpm",
        with = "units::rpm",
        skip_serializing_if = "is_default_steady_speed_step"
    )]
    pub steady_speed_step: f64,
    /// ... node spacing of input torque on its coarsest grid \[N·m\]; absent: a fifth of
    /// the scene's input torque.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub steady_torque_step_nm: Option<f64>,
    /// ... the lowest input speed it solves; slower steps take the steady state there
    /// \[rad/s\] (file: rpm).
    #[serde(
        rename = "steady_speed_floor_rpm",
        with = "units::rpm",
        skip_serializing_if = "is_default_steady_speed_floor"
    )]
    pub steady_speed_floor: f64,
    /// ... the largest interpolation error a cell may have, estimated at its centre and at
    /// the midpoint of its edge nearest the request, as a fraction of the static mesh load
    /// (and of the separation fraction) \[-\].
    #[serde(skip_serializing_if = "is_default_steady_agreement")]
    pub steady_agreement: f64,
    /// ... the halvings of a cell whose interpolation error is larger.
    #[serde(skip_serializing_if = "is_default_steady_refinements")]
    pub steady_refinements: u32,
    /// Load balance: a speed controller (a dynamometer) holds the output
    /// member at the kinematic speed of the input speed, its torque in place
    /// of the output's external torque.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub load_balance: bool,
    /// The member the speed drive turns (drive = "speed"): absent means the
    /// input member; the output member makes the set speed-driven from its
    /// output side, torque on the input.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_driven_member: Option<Member>,
}

impl Default for DynamicsSpec {
    fn default() -> Self {
        Self {
            fidelity: Fidelity::TransverseTorsional,
            mesh_damping_ratio: 0.05,
            damping: DampingModel::Ratio,
            contact: ContactModel::Pair,
            rayleigh_mass_per_s: 0.0,
            rayleigh_stiffness_s: 0.0,
            drive: Drive::Torque,
            input_speed: units::rpm_to_rad_per_s(3000.0),
            shaft_stiffness_nm_per_rad: 5.0e4,
            // The cheapest setting of the work-precision study with E_h ≤ 1e-3
            // at every operating point (docs/ACCURACY.md).
            integrator: IntegratorKind::Rk45,
            rho_infinity: 0.9,
            steps_per_mesh_cycle: 120,
            relative_tolerance: 3e-6,
            simulation_relative_tolerance: 1e-5,
            run_in_revolutions: 1.0,
            steady_tolerance: 1e-5,
            measured_revolutions: 2.0,
            samples_per_mesh_cycle: 60,
            load_balance: false,
            speed_driven_member: None,
            response: Response::Time,
            steady_speed_step: units::rpm_to_rad_per_s(STEADY_SPEED_STEP_RPM),
            steady_torque_step_nm: None,
            steady_speed_floor: units::rpm_to_rad_per_s(STEADY_SPEED_FLOOR_RPM),
            steady_agreement: STEADY_AGREEMENT,
            steady_refinements: STEADY_REFINEMENTS,
        }
    }
}

/// An external spur gear (sun or planet) as written in a scene file, in SI
/// (each field's file key and unit in brackets): by its radii, or by its
/// gear data (`gear_data`, ISO 21771; then the four derived fields
/// `tooth_thickness`, `tip_radius`, `root_radius` and `hob_tip_radius` are
/// absent from the file, hold 0 here and are derived when the scene is
/// validated).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "gear_data::ExternalGearFile", into = "gear_data::ExternalGearFile")]
pub struct ExternalGearSpec {
    /// Number of teeth.
    pub teeth: u32,
    /// Module \[m\] (`module_mm`).
    pub module: f64,
    /// Pressure angle of the generating rack \[rad\] (`pressure_angle_deg`);
    /// with the standard centre distance it is also the operating pressure
    /// angle.
    pub pressure_angle: f64,
    /// Circular tooth thickness at the reference circle m·Z/2 \[m\]
    /// (`tooth_thickness_mm`); it carries the backlash allowance.
    pub tooth_thickness: f64,
    /// Tip radius \[m\] (`tip_radius_mm`).
    pub tip_radius: f64,
    /// Root radius \[m\] (`root_radius_mm`).
    pub root_radius: f64,
    /// Bore (inner) radius of the gear body \[m\] (`bore_radius_mm`).
    pub bore_radius: f64,
    /// Tip radius of the hob that generated the root fillet \[m\] (`hob_tip_radius_mm`).
    pub hob_tip_radius: f64,
    /// Face width \[m\] (`face_width_mm`).
    pub face_width: f64,
    /// Tip chamfer; `None` (omitted) means the default of docs/PARAMETERS.md.
    pub tip_chamfer: Option<ChamferSpec>,
    /// Gear data (ISO 21771) the radii are derived from; `None` for the
    /// radii form.
    pub gear_data: Option<GearData>,
}

/// The internal ring gear as written in a scene file, in SI (each field's
/// file key and unit in brackets): by its radii, or by its gear data
/// (`gear_data`; then `tooth_thickness`, `minor_radius`, `root_radius` and
/// `fillet_radius` are absent from the file, hold 0 here and are derived
/// when the scene is validated).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "gear_data::RingGearFile", into = "gear_data::RingGearFile")]
pub struct RingGearSpec {
    /// Number of teeth.
    pub teeth: u32,
    /// Module \[m\] (`module_mm`).
    pub module: f64,
    /// Pressure angle of the generating tool \[rad\] (`pressure_angle_deg`).
    pub pressure_angle: f64,
    /// Circular tooth thickness of a ring tooth at the reference circle \[m\]
    /// (`tooth_thickness_mm`).
    pub tooth_thickness: f64,
    /// Minor radius: the radius of the ring's tooth tips \[m\] (`minor_radius_mm`).
    pub minor_radius: f64,
    /// Root radius \[m\] (`root_radius_mm`).
    pub root_radius: f64,
    /// Outside radius of the rim \[m\] (`rim_radius_mm`).
    pub rim_radius: f64,
    /// Radius of the root fillet \[m\] (`fillet_radius_mm`).
    pub fillet_radius: f64,
    /// Face width \[m\] (`face_width_mm`).
    pub face_width: f64,
    /// Tip chamfer of the ring teeth; omitted means none.
    pub tip_chamfer: Option<ChamferSpec>,
    /// Gear data (ISO 21771) the radii are derived from; `None` for the
    /// radii form.
    pub gear_data: Option<GearData>,
}

/// A straight tip chamfer: it starts on the involute `height` below the
/// tip circle and meets the tip circle at `angle` to the tip circle's
/// tangent (the usual "h × 45°" edge break). SI; the file writes
/// `height_mm`, `angle_deg` and `edge_radius_mm`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChamferSpec {
    /// Radial height of the chamfer \[m\].
    #[serde(rename = "height_mm", with = "units::mm")]
    pub height: f64,
    /// Angle between the chamfer and the tip circle's tangent \[rad\].
    #[serde(rename = "angle_deg", with = "units::deg")]
    pub angle: f64,
    /// Whether the edge where the chamfer meets the involute may touch the
    /// mating flank (corner contact outside the involute path). `false`
    /// reads the chamfer as relieving the tip: contact ends at the involute
    /// (docs/PARAMETERS.md).
    #[serde(default = "edge_carries_load_default", skip_serializing_if = "is_true")]
    pub edge_carries_load: bool,
    /// Radius to which the edge between involute and chamfer is rounded
    /// \[m\]; read only when the edge carries no load: it sets how the
    /// relief begins (docs/PARAMETERS.md).
    #[serde(
        rename = "edge_radius_mm",
        with = "units::mm",
        default = "edge_radius_default",
        skip_serializing_if = "is_edge_radius_default"
    )]
    pub edge_radius: f64,
}

/// Default rounding radius of a chamfer's edge \[mm\]: a deburred edge.
pub const EDGE_RADIUS_MM: f64 = 0.05;

fn edge_radius_default() -> f64 {
    units::mm_to_m(EDGE_RADIUS_MM)
}

fn is_edge_radius_default(v: &f64) -> bool {
    *v == edge_radius_default()
}

fn edge_carries_load_default() -> bool {
    true
}

fn is_true(v: &bool) -> bool {
    *v
}

impl ChamferSpec {
    /// A chamfer of radial height `height` \[m\] at `angle` \[rad\] to the
    /// tip circle's tangent whose edge may carry load.
    pub fn new(height: f64, angle: f64) -> Self {
        Self { height, angle, edge_carries_load: true, edge_radius: edge_radius_default() }
    }
}

/// Number and placement of the planets.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanetLayoutSpec {
    /// Number of planets.
    pub count: u32,
    /// Angular positions of the planet centres \[rad\] (file: `angles_deg`),
    /// counter-clockwise from the first; omitted means equally spaced.
    #[serde(rename = "angles_deg", with = "units::deg", default, skip_serializing_if = "Option::is_none")]
    pub angles: Option<Vec<f64>>,
}

/// Material constants of all gears.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Young's modulus \[Pa\] (file: GPa).
    #[serde(rename = "youngs_modulus_gpa", with = "units::gpa")]
    pub youngs_modulus: f64,
    /// Poisson's ratio [-].
    pub poisson_ratio: f64,
    /// Density [kg/m³].
    pub density_kg_per_m3: f64,
}

impl Default for MaterialSpec {
    /// Steel (docs/MODEL.md §1).
    fn default() -> Self {
        Self { youngs_modulus: units::gpa_to_pa(207.0), poisson_ratio: 0.3, density_kg_per_m3: 7850.0 }
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
    /// Points along each flank's profile-deviation grid (I of docs/MODEL.md §4).
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
            "example-2004-annulus" => Some(Self::example_2004_annulus()),
            "example-2004-gear-data" => Some(Self::example_2004_gear_data()),
            "example-2004-stiff-pins" => Some(Self::example_2004_stiff_pins()),
            "example-2004-deformable" => Some(Self::example_2004_deformable()),
            _ => None,
        }
    }

    /// Names of the built-in gear scenes.
    pub const BUILTIN: &'static [&'static str] = &[
        "example-2004",
        "example-2004-annulus",
        "example-2004-gear-data",
        "example-2004-stiff-pins",
        "example-2004-deformable",
    ];

    /// The calibration plan (TOML) of a built-in scene made by
    /// `planetwear calibrate`, if it has one.
    pub fn builtin_plan(name: &str) -> Option<&'static str> {
        match name {
            "example-2004" => Some(include_str!("example-2004.calibration.toml")),
            "example-2004-deformable" => Some(include_str!("example-2004-deformable.calibration.toml")),
            _ => None,
        }
    }

    /// The real number at `key`, a dotted path of the scene file
    /// (`inertia.sun_inertia_kg_m2`, `sun.tip_chamfer.height_mm`), in the
    /// file's units.
    pub fn value_at(&self, key: &str) -> Result<f64, KeyError> {
        let doc = toml::Value::try_from(self)
            .map_err(|e| KeyError::Unusable { key: key.into(), why: e.to_string() })?;
        let mut v = &doc;
        for part in key.split('.') {
            v = v.get(part).ok_or_else(|| KeyError::Unknown { key: key.into() })?;
        }
        match v {
            toml::Value::Float(x) => Ok(*x),
            _ => Err(KeyError::NotReal { key: key.into() }),
        }
    }

    /// The scene with the real number at `key` set to `value` (file units).
    pub fn with_value(&self, key: &str, value: f64) -> Result<Self, KeyError> {
        self.value_at(key)?;
        self.with_toml(key, toml::Value::Float(value))
    }

    /// The scene with the value at `key` (an existing key, or a new key of
    /// an existing table) replaced by `value`, of any type the key takes.
    pub fn with_toml(&self, key: &str, value: toml::Value) -> Result<Self, KeyError> {
        let unusable = |why: String| KeyError::Unusable { key: key.into(), why };
        let mut doc = toml::Value::try_from(self).map_err(|e| unusable(e.to_string()))?;
        let (path, last) = key.rsplit_once('.').map_or(("", key), |(p, l)| (p, l));
        let mut v = &mut doc;
        for part in path.split('.').filter(|p| !p.is_empty()) {
            v = v.get_mut(part).ok_or_else(|| KeyError::Unknown { key: key.into() })?;
        }
        let table = v.as_table_mut().ok_or_else(|| KeyError::Unknown { key: key.into() })?;
        table.insert(last.to_string(), value);
        Scene::deserialize(doc).map_err(|e| unusable(e.to_string()))
    }
}

/// A scene key that cannot be read or set as a real number.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KeyError {
    /// No such key in the scene (an optional key must be written out first:
    /// [`Scene::explicit`] writes the derived defaults).
    #[error("{key}: no such key in the scene (keys are dotted paths of the scene file, e.g. inertia.sun_inertia_kg_m2, sun.tip_chamfer.height_mm)")]
    Unknown {
        /// The key.
        key: String,
    },
    /// The key holds something other than a real number.
    #[error("{key}: not a real-valued key (counts, names and tables cannot be fitted)")]
    NotReal {
        /// The key.
        key: String,
    },
    /// The scene could not be converted with the value.
    #[error("{key}: {why}")]
    Unusable {
        /// The key.
        key: String,
        /// The converter's message.
        why: String,
    },
}

/// Whether a real scene value is zero (the scene file then omits it).
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}
