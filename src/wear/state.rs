//! The worn-profile state (docs/MODEL.md §5): the profile deviations of every
//! flank, the geometry state κ, the cycles and input revolutions run, the
//! history of the updates and the gear set it belongs to; and its JSON
//! document, versioned and checksummed. Reading and writing files is the
//! shell's ([`crate::files`]); this module turns a state into text and back.
//!
//! # The document (SI units: m, rad)
//!
//! ```text
//! { "format": "planetwear-worn-profile", "version": 1,
//!   "checksum": "fnv1a64:<16 hex digits>",
//!   "content": {
//!     "gear_set": { "name", "fingerprint", "parameters": { "sun.teeth": 34.0, ... } },
//!     "kappa": 6, "revolutions": <input revolutions run>,
//!     "cycles": { "sun", "planet", "ring" }            (tooth cycles run per gear)
//!     "flanks": { "sun_drive": [ {"roll": [...], "depth": [...]} per face slice ],
//!                 "sun_coast", "planet_sun_side", "planet_ring_side", "ring_drive", "ring_coast" },
//!     "history": [ { "kappa", "revolutions", "cycles", "limiting_flank", "ended_by",
//!                    "new_wear": [ {"flank", "slice", "depth", "roll"} ], "total_wear": [...] } ] } }
//! ```
//!
//! The six flanks are the physical flanks; the planet's two appear in both
//! meshes ([`WornState::mesh_flanks`]). Depth is material removed normal to
//! the involute against the flank's own roll angle, linear between grid
//! points and constant beyond the ends ([`ProfileDeviation`]).
//!
//! The checksum is FNV-1a 64 of the content written compactly with its keys
//! sorted ([`content_checksum`]): any change of a value, any truncation is
//! caught, while reformatting the file is not an error. The gear set's
//! fingerprint is FNV-1a 64 of the named geometry and material parameters
//! that wear depends on (tooth forms, planet angles, centre distance, E, ν),
//! in name order with each value's bits: the name of the scene and the
//! operating point (torque, speeds) are not part of it, so a worn set can be
//! run at any load. A state for another gear set is refused with the
//! parameters that differ, unless every difference is of a kind the caller
//! accepts explicitly ([`StateDifference`]: the material, the stiffness
//! corrections; never the geometry): the accepted state then belongs to the
//! new set and records what was accepted (`accepted_differences`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::contact::ltca::SetModel;
use crate::contact::separation::MeshFlanks;
use crate::geometry::profile::{ProfileDeviation, ProfileEnds};
use crate::model::gear::{GearSet, RootForm, ToothForm};
use crate::wear::flank::{active_profile, Flank, GearCycles, UpdateEnd};

/// Largest plausible wear depth of a flank as a fraction of its gear's
/// tooth thickness on the reference circle or of its tooth height (tip to
/// root radius), whichever is smaller: wear of a quarter of a tooth has long
/// ended the gear's life (the wear model stops at its total wear limit,
/// 15 µm by default). A state with a deeper point is refused when read for
/// a gear set.
pub const MAX_DEPTH_FRACTION: f64 = 0.25;

/// The `format` name of the document.
pub const FORMAT: &str = "planetwear-worn-profile";
/// The version of the document this build writes and reads.
pub const VERSION: u64 = 1;

/// Why a worn-profile state was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WornStateError {
    /// The text is not JSON.
    #[error("not a JSON document (line {line}, column {column}): {reason}")]
    NotJson {
        /// Line of the error.
        line: usize,
        /// Column of the error.
        column: usize,
        /// What the parser found.
        reason: String,
    },
    /// The text ends before the document does.
    #[error("the document is truncated: it ends at line {line}, column {column} before it is complete")]
    Truncated {
        /// Last line.
        line: usize,
        /// Last column.
        column: usize,
    },
    /// Another kind of document.
    #[error("format is {found}, not \"{expected}\": this is not a worn-profile state")]
    Format {
        /// The `format` found (or what stands in its place).
        found: String,
        /// The format expected.
        expected: &'static str,
    },
    /// A version this build cannot read.
    #[error(
        "worn-profile state version {found} cannot be read by this build, which reads version {supported}"
    )]
    Version {
        /// The `version` found.
        found: String,
        /// The version this build reads.
        supported: u64,
    },
    /// The content does not match its checksum.
    #[error("the checksum does not match the content (stored {stored}, computed {computed}): the file was altered or corrupted")]
    Checksum {
        /// Checksum in the document.
        stored: String,
        /// Checksum of the content read.
        computed: String,
    },
    /// A value that is not a finite number.
    #[error("{field} is not a finite number")]
    NonFinite {
        /// Where, e.g. `flanks.sun_drive[0].depth[3]`.
        field: String,
    },
    /// A value below zero where only zero or more is allowed.
    #[error("{field} = {value:e} is negative: depths, cycles and revolutions are zero or more")]
    Negative {
        /// Where.
        field: String,
        /// Value.
        value: f64,
    },
    /// A depth no flank of the gear set can have worn: beyond
    /// [`MAX_DEPTH_FRACTION`] of the gear's tooth thickness or tooth height.
    #[error(
        "{field} = {depth:e} m is deeper than the {limit:e} m a flank of the {gear} can wear \
             ({MAX_DEPTH_FRACTION} of its {basis}): not a plausible worn state"
    )]
    Implausible {
        /// Where, e.g. `flanks.sun_drive[0].depth[3]`.
        field: String,
        /// The depth \[m\].
        depth: f64,
        /// The largest plausible depth \[m\].
        limit: f64,
        /// The gear (`sun`, `planet`, `ring`).
        gear: &'static str,
        /// What the limit is a fraction of, with its size.
        basis: String,
    },
    /// A deviation grid of the wrong shape.
    #[error("{field}: {reason}")]
    GridShape {
        /// Which grid.
        field: String,
        /// What is wrong and what is allowed.
        reason: String,
    },
    /// The content does not have the document's structure.
    #[error("the content does not have the structure of a worn-profile state: {reason}")]
    Malformed {
        /// The parser's account.
        reason: String,
    },
    /// Parts of the content contradict each other.
    #[error("inconsistent worn-profile state: {reason}")]
    Inconsistent {
        /// What contradicts what.
        reason: String,
    },
    /// The state belongs to another gear set.
    #[error(
        "the worn-profile state belongs to gear set '{state_set}' (fingerprint {state_fingerprint}), not to '{expected_set}' (fingerprint {expected_fingerprint}): {}{}",
        describe_differences(.differences),
        acceptance_hint(.differences)
    )]
    Foreign {
        /// Name of the state's gear set.
        state_set: String,
        /// Its fingerprint.
        state_fingerprint: String,
        /// Name of this gear set.
        expected_set: String,
        /// This gear set's fingerprint.
        expected_fingerprint: String,
        /// The parameters that differ.
        differences: Vec<ParameterDifference>,
    },
}

/// A gear-set parameter whose value differs between a state and a set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParameterDifference {
    /// Parameter name, e.g. `sun.teeth`.
    pub name: String,
    /// Value in the state, `None` where absent [SI unit of the parameter].
    pub state: Option<f64>,
    /// Value of this gear set, `None` where absent [SI unit of the parameter].
    pub expected: Option<f64>,
}

/// The differing parameters in words, each with its value in the file and here.
pub fn describe_differences(d: &[ParameterDifference]) -> String {
    if d.is_empty() {
        return "the parameters agree but the fingerprint does not (the state was made by another fingerprint rule)"
            .into();
    }
    let show = |v: Option<f64>| v.map_or("absent".to_string(), |x| format!("{x}"));
    let mut parts: Vec<String> = d
        .iter()
        .take(6)
        .map(|p| format!("{} is {} in the state and {} here", p.name, show(p.state), show(p.expected)))
        .collect();
    if d.len() > 6 {
        parts.push(format!("and {} more", d.len() - 6));
    }
    parts.join("; ")
}

/// What may be done about `d`: whether every difference is of a kind that
/// can be accepted explicitly, or which ones never can.
fn acceptance_hint(d: &[ParameterDifference]) -> String {
    if d.is_empty() {
        return String::new();
    }
    let geometry: Vec<&str> = d
        .iter()
        .filter(|p| StateDifference::of_parameter(&p.name).is_none())
        .map(|p| p.name.as_str())
        .collect();
    if !geometry.is_empty() {
        return format!(" (a geometry difference, here {}, is never accepted)", geometry.join(", "));
    }
    let mut kinds: Vec<&str> =
        d.iter().filter_map(|p| StateDifference::of_parameter(&p.name)).map(StateDifference::name).collect();
    kinds.dedup();
    format!(" (differences of kind {} only: they may be accepted explicitly)", kinds.join(", "))
}

/// A kind of difference between a state's gear set and another that a user
/// may accept explicitly: the state's wear was made on one set and is then
/// read on the other. The geometry is never one of them (a worn profile is
/// a deviation of a particular involute and grid), and the operating point
/// (torque, speeds) is not part of a gear set's print at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StateDifference {
    /// Young's modulus and Poisson's ratio (`material.*` of the print).
    Material,
    /// The factors on the tooth-pair stiffness (`mesh_stiffness.*`).
    MeshStiffness,
}

impl StateDifference {
    /// Every kind, in the order of their names.
    pub const ALL: [StateDifference; 2] = [StateDifference::Material, StateDifference::MeshStiffness];

    /// Its name as a user writes it (`material`, `mesh_stiffness`).
    pub fn name(self) -> &'static str {
        match self {
            StateDifference::Material => "material",
            StateDifference::MeshStiffness => "mesh_stiffness",
        }
    }

    /// The kind of a difference in the print's parameter `name`; `None` for
    /// the geometry, which is never accepted.
    pub fn of_parameter(name: &str) -> Option<Self> {
        if name.starts_with("material.") {
            Some(StateDifference::Material)
        } else if name.starts_with("mesh_stiffness.") {
            Some(StateDifference::MeshStiffness)
        } else {
            None
        }
    }

    /// The kinds of a comma-separated list (`material,mesh_stiffness`;
    /// blanks around a name are ignored, an empty list accepts nothing), or
    /// why an entry is not one.
    pub fn parse_list(text: &str) -> Result<Vec<Self>, String> {
        let mut out = Vec::new();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let kind = Self::ALL.into_iter().find(|k| k.name() == item).ok_or_else(|| {
                let why = match item {
                    "geometry" => " (the geometry is never accepted: a worn profile belongs to its involute)",
                    "load" | "torque" | "speed" => {
                        " (the operating point is not part of a state's gear set: a state is read at any load and speed)"
                    }
                    _ => "",
                };
                format!("'{item}' is not a difference that can be accepted: allowed are material, mesh_stiffness{why}")
            })?;
            if !out.contains(&kind) {
                out.push(kind);
            }
        }
        out.sort();
        Ok(out)
    }
}

/// Relative difference below which two gear-set parameters are the same
/// (unit conversions round in the last bits; any design change is far larger).
pub const SAME_PARAMETER: f64 = 1e-12;

/// The gear set a state belongs to: its name, fingerprint and the
/// parameters the fingerprint is made of.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GearSetPrint {
    /// Scene name (not part of the fingerprint).
    pub name: String,
    /// FNV-1a 64 of the parameters, `fnv1a64:` and 16 hex digits.
    pub fingerprint: String,
    /// Geometry and material parameters by name [SI: m, rad, Pa, counts].
    pub parameters: BTreeMap<String, f64>,
}

fn form_parameters(out: &mut BTreeMap<String, f64>, gear: &str, f: &ToothForm) {
    let mut put = |k: &str, v: f64| {
        out.insert(format!("{gear}.{k}"), v);
    };
    put("teeth", f64::from(f.teeth));
    put("module", f.module);
    put("pressure_angle", f.pressure_angle);
    put("tooth_thickness", f.tooth_thickness);
    put("tip_radius", f.tip_radius);
    put("root_radius", f.root_radius);
    put("body_radius", f.body_radius);
    put("face_width", f.face_width);
    match f.root_form {
        RootForm::Hob { tip_radius } => put("hob_tip_radius", tip_radius),
        RootForm::Fillet { radius } => put("fillet_radius", radius),
    }
    let (h, a) = f.chamfer.map_or((0.0, 0.0), |c| (c.height, c.angle));
    put("chamfer_height", h);
    put("chamfer_angle", a);
    // Present only for a relieved chamfer edge, so the prints of sets whose
    // edges carry load (all sets before the option existed) are unchanged.
    if !f.tip_corner_carries_load() {
        put("chamfer_edge_relieved", 1.0);
    }
}

impl GearSetPrint {
    /// The parameters in which `self` (a state's or a file's set) and `here` differ by more
    /// than [`SAME_PARAMETER`] relatively, or that only one of them has (none for the same
    /// set, whatever the last bits of its values).
    pub fn differences(&self, here: &GearSetPrint) -> Vec<ParameterDifference> {
        let names: std::collections::BTreeSet<&String> =
            here.parameters.keys().chain(self.parameters.keys()).collect();
        let mut differences = Vec::new();
        for name in names {
            let (a, b) = (self.parameters.get(name).copied(), here.parameters.get(name).copied());
            let same = match (a, b) {
                (Some(x), Some(y)) => (x - y).abs() <= SAME_PARAMETER * x.abs().max(y.abs()),
                _ => false,
            };
            if !same {
                differences.push(ParameterDifference { name: name.clone(), state: a, expected: b });
            }
        }
        differences
    }

    /// The print of a gear set.
    pub fn of(set: &GearSet) -> Self {
        let mut p = BTreeMap::new();
        form_parameters(&mut p, "sun", set.sun());
        form_parameters(&mut p, "planet", set.planet());
        form_parameters(&mut p, "ring", set.ring());
        p.insert("planets".into(), set.planet_angles().len() as f64);
        for (i, a) in set.planet_angles().iter().enumerate() {
            p.insert(format!("planet_angle.{i}"), *a);
        }
        p.insert("centre_distance".into(), set.centre_distance());
        p.insert("material.youngs_modulus".into(), set.material().youngs_modulus);
        p.insert("material.poisson_ratio".into(), set.material().poisson_ratio);
        // Present only when not 1, so the prints of sets without a correction
        // (all sets before the option existed) are unchanged.
        for (mesh, scale) in ["sun_planet", "ring_planet"].iter().zip(set.stiffness_scales()) {
            if scale != 1.0 {
                p.insert(format!("mesh_stiffness.{mesh}_scale"), scale);
            }
        }
        let fingerprint = Self::fingerprint_of(&p);
        Self { name: set.name().to_string(), fingerprint, parameters: p }
    }

    /// The fingerprint of a parameter list: FNV-1a 64 over `name=bits;` in
    /// name order, the value's bits little-endian.
    pub fn fingerprint_of(parameters: &BTreeMap<String, f64>) -> String {
        let mut bytes = Vec::new();
        for (k, v) in parameters {
            bytes.extend_from_slice(k.as_bytes());
            bytes.push(b'=');
            bytes.extend_from_slice(&v.to_bits().to_le_bytes());
            bytes.push(b';');
        }
        format!("fnv1a64:{:016x}", crate::files::hash::fnv1a64(&bytes))
    }
}

/// The largest depth of a flank and where it sits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlankExtreme {
    /// The flank.
    pub flank: Flank,
    /// Face slice.
    pub slice: usize,
    /// Depth \[m\].
    pub depth: f64,
    /// Roll angle of the grid point \[rad\].
    pub roll: f64,
}

/// One update of the worn geometry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UpdateRecord {
    /// The geometry state the update made.
    pub kappa: u32,
    /// Input revolutions of the update \[rev\].
    pub revolutions: f64,
    /// Tooth cycles of each gear in the update [-]; C^κ is the limiting
    /// flank's gear's.
    pub cycles: GearCycles,
    /// The flank whose wear per revolution is largest (it set the update's length).
    pub limiting_flank: Flank,
    /// What ended the update.
    pub ended_by: UpdateEnd,
    /// Largest new wear of each wearing flank and where.
    pub new_wear: Vec<FlankExtreme>,
    /// Largest total wear of every flank after the update and where.
    pub total_wear: Vec<FlankExtreme>,
}

/// Profile deviations of the six physical flanks, one per face slice.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlankDeviations {
    /// Sun drive flank.
    pub sun_drive: Vec<ProfileDeviation>,
    /// Sun coast flank.
    pub sun_coast: Vec<ProfileDeviation>,
    /// Planet flank meeting the sun.
    pub planet_sun_side: Vec<ProfileDeviation>,
    /// Planet flank meeting the ring.
    pub planet_ring_side: Vec<ProfileDeviation>,
    /// Ring drive flank.
    pub ring_drive: Vec<ProfileDeviation>,
    /// Ring coast flank.
    pub ring_coast: Vec<ProfileDeviation>,
}

impl FlankDeviations {
    /// The deviations of `flank`, one per slice.
    pub fn get(&self, flank: Flank) -> &Vec<ProfileDeviation> {
        match flank {
            Flank::SunDrive => &self.sun_drive,
            Flank::SunCoast => &self.sun_coast,
            Flank::PlanetSunSide => &self.planet_sun_side,
            Flank::PlanetRingSide => &self.planet_ring_side,
            Flank::RingDrive => &self.ring_drive,
            Flank::RingCoast => &self.ring_coast,
        }
    }

    /// The deviations of `flank`, mutable.
    pub fn get_mut(&mut self, flank: Flank) -> &mut Vec<ProfileDeviation> {
        match flank {
            Flank::SunDrive => &mut self.sun_drive,
            Flank::SunCoast => &mut self.sun_coast,
            Flank::PlanetSunSide => &mut self.planet_sun_side,
            Flank::PlanetRingSide => &mut self.planet_ring_side,
            Flank::RingDrive => &mut self.ring_drive,
            Flank::RingCoast => &mut self.ring_coast,
        }
    }
}

/// The worn-profile state of a gear set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WornState {
    /// The gear set it belongs to.
    pub gear_set: GearSetPrint,
    /// Geometry state κ (0: unworn), the number of updates made.
    pub kappa: u32,
    /// Input revolutions run \[rev\].
    pub revolutions: f64,
    /// Tooth cycles run per gear [-].
    pub cycles: GearCycles,
    /// Flank deviations.
    pub flanks: FlankDeviations,
    /// The updates, oldest first.
    pub history: Vec<UpdateRecord>,
    /// Kinds of difference accepted explicitly when this state, or one it
    /// was advanced from, was read for a set that differed from the one its
    /// wear was made on (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub accepted_differences: Vec<StateDifference>,
    /// Operating time the wear stands for \[s\]: the duty cycles' (absent when no duty cycle
    /// wore it).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub operating_time: f64,
    /// The duty cycles that wore it, oldest first (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub duty_cycles: Vec<DutyRecord>,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// A duty cycle's passes that wore a state (`wear step --duty-cycle`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DutyRecord {
    /// The duty-cycle document's checksum (`fnv1a64:…`): its fingerprint.
    pub checksum: String,
    /// What produced the duty (`simulate`, `fmu`, …).
    pub source: String,
    /// Passes of the duty worn [-].
    pub passes: f64,
    /// Input revolutions worn \[rev\].
    pub revolutions: f64,
    /// Operating time worn \[s\].
    pub operating_time: f64,
    /// κ before and after.
    pub kappa: (u32, u32),
}

impl WornState {
    /// The unworn state: every flank's grid of `profile_points` points,
    /// uniform in roll angle over its active profile, zero depth, in each
    /// of `face_slices` slices.
    pub fn unworn(set: &GearSet, profile_points: usize, face_slices: usize) -> Self {
        let n = profile_points.max(2);
        let grid = |flank: Flank| {
            let (lo, hi) = active_profile(set, flank);
            let roll: Vec<f64> = (0..n).map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64).collect();
            vec![ProfileDeviation::new(roll, vec![0.0; n]); face_slices.max(1)]
        };
        Self {
            gear_set: GearSetPrint::of(set),
            kappa: 0,
            revolutions: 0.0,
            cycles: GearCycles::default(),
            flanks: FlankDeviations {
                sun_drive: grid(Flank::SunDrive),
                sun_coast: grid(Flank::SunCoast),
                planet_sun_side: grid(Flank::PlanetSunSide),
                planet_ring_side: grid(Flank::PlanetRingSide),
                ring_drive: grid(Flank::RingDrive),
                ring_coast: grid(Flank::RingCoast),
            },
            history: Vec::new(),
            accepted_differences: Vec::new(),
            operating_time: 0.0,
            duty_cycles: Vec::new(),
        }
    }

    /// The state with every flank's deviation read as `ends` says beyond its grid.
    pub fn with_profile_ends(mut self, ends: ProfileEnds) -> Self {
        for flank in Flank::ALL {
            for dev in self.flanks.get_mut(flank) {
                dev.ends = ends;
            }
        }
        self
    }

    /// Number of face slices.
    pub fn face_slices(&self) -> usize {
        self.flanks.sun_drive.len()
    }

    /// The deviations as the four flanks of each mesh, per face slice, for
    /// [`SetModel::with_flanks`] and [`crate::contact::ltca::MeshModel::sliced`]:
    /// (sun–planet slices, ring–planet slices).
    pub fn mesh_flanks(&self) -> (Vec<MeshFlanks>, Vec<MeshFlanks>) {
        let f = &self.flanks;
        let sun_planet = (0..self.face_slices())
            .map(|j| MeshFlanks {
                gear1_drive: f.sun_drive[j].clone(),
                gear1_back: f.sun_coast[j].clone(),
                gear2_drive: f.planet_sun_side[j].clone(),
                gear2_back: f.planet_ring_side[j].clone(),
            })
            .collect();
        let ring_planet = (0..self.face_slices())
            .map(|j| MeshFlanks {
                gear1_drive: f.planet_ring_side[j].clone(),
                gear1_back: f.planet_sun_side[j].clone(),
                gear2_drive: f.ring_drive[j].clone(),
                gear2_back: f.ring_coast[j].clone(),
            })
            .collect();
        (sun_planet, ring_planet)
    }

    /// Contact models of both meshes with this state's deviations.
    pub fn set_model(&self, set: &GearSet) -> SetModel {
        let (sp, rp) = self.mesh_flanks();
        SetModel::with_flanks(set, &sp, &rp)
    }

    /// Refuses a state made for another gear set, naming what differs.
    /// Parameters agree when they differ by at most [`SAME_PARAMETER`] of
    /// their size: a set entered in other units (degrees, millimetres, as
    /// through the FMU's parameters) converts back with rounding in the last
    /// bits and is the same set.
    pub fn check_gear_set(&self, set: &GearSet) -> Result<(), WornStateError> {
        self.gear_set_differences(set, &[]).map(|_| ())
    }

    /// The differences between this state's gear set and `set` when every
    /// one is of a kind in `accept` (none when the sets agree); otherwise
    /// the refusal of [`WornState::check_gear_set`], which names every
    /// differing parameter.
    pub fn gear_set_differences(
        &self,
        set: &GearSet,
        accept: &[StateDifference],
    ) -> Result<Vec<ParameterDifference>, WornStateError> {
        let here = GearSetPrint::of(set);
        if here.fingerprint == self.gear_set.fingerprint {
            return Ok(Vec::new());
        }
        let differences = self.gear_set.differences(&here);
        let accepted = |d: &ParameterDifference| {
            StateDifference::of_parameter(&d.name).is_some_and(|k| accept.contains(&k))
        };
        if differences.iter().all(accepted) {
            return Ok(differences);
        }
        Err(WornStateError::Foreign {
            state_set: self.gear_set.name.clone(),
            state_fingerprint: self.gear_set.fingerprint.clone(),
            expected_set: here.name,
            expected_fingerprint: here.fingerprint,
            differences,
        })
    }

    /// This state taken over by `set` when it differs from the state's gear
    /// set only in kinds of `accept`: the state then belongs to `set` (its
    /// print) and records the kinds accepted; returned with the differences
    /// accepted (none when the sets agree). Otherwise the refusal of
    /// [`WornState::check_gear_set`].
    pub fn accepted_for(
        mut self,
        set: &GearSet,
        accept: &[StateDifference],
    ) -> Result<(Self, Vec<ParameterDifference>), WornStateError> {
        let differences = self.gear_set_differences(set, accept)?;
        if !differences.is_empty() {
            for d in &differences {
                if let Some(kind) = StateDifference::of_parameter(&d.name) {
                    if !self.accepted_differences.contains(&kind) {
                        self.accepted_differences.push(kind);
                    }
                }
            }
            self.accepted_differences.sort();
            self.gear_set = GearSetPrint::of(set);
        }
        Ok((self, differences))
    }

    /// The deepest point of `flank` over its slices.
    pub fn deepest_on(&self, flank: Flank) -> FlankExtreme {
        let mut top = FlankExtreme { flank, slice: 0, depth: 0.0, roll: 0.0 };
        let mut first = true;
        for (j, dev) in self.flanks.get(flank).iter().enumerate() {
            for (d, xi) in dev.depth.iter().zip(&dev.roll) {
                if first || *d > top.depth {
                    top = FlankExtreme { flank, slice: j, depth: *d, roll: *xi };
                    first = false;
                }
            }
        }
        top
    }

    /// The deepest point of any flank.
    pub fn deepest(&self) -> FlankExtreme {
        Flank::ALL
            .iter()
            .map(|f| self.deepest_on(*f))
            .fold(None, |m: Option<FlankExtreme>, e| match m {
                Some(m) if m.depth >= e.depth => Some(m),
                _ => Some(e),
            })
            .unwrap_or(FlankExtreme { flank: Flank::SunDrive, slice: 0, depth: 0.0, roll: 0.0 })
    }

    /// Checks every value: finite, not negative where a count or depth,
    /// grids of matching shape with increasing roll angles, the counts and
    /// the history in agreement.
    pub fn validate(&self) -> Result<(), WornStateError> {
        let finite = |field: &dyn Fn() -> String, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(WornStateError::NonFinite { field: field() })
            }
        };
        let amount = |field: &dyn Fn() -> String, v: f64| {
            finite(field, v)?;
            if v < 0.0 {
                return Err(WornStateError::Negative { field: field(), value: v });
            }
            Ok(())
        };
        for (name, v) in &self.gear_set.parameters {
            finite(&|| format!("gear_set.parameters.{name}"), *v)?;
        }
        amount(&|| "operating_time".into(), self.operating_time)?;
        for (i, d) in self.duty_cycles.iter().enumerate() {
            amount(&|| format!("duty_cycles[{i}].passes"), d.passes)?;
            amount(&|| format!("duty_cycles[{i}].revolutions"), d.revolutions)?;
            amount(&|| format!("duty_cycles[{i}].operating_time"), d.operating_time)?;
        }
        let slices = self.face_slices();
        for flank in Flank::ALL {
            let devs = self.flanks.get(flank);
            let fname = flank.name();
            if devs.len() != slices || slices == 0 {
                return Err(WornStateError::GridShape {
                    field: format!("flanks.{fname}"),
                    reason: format!(
                        "{} face slices where flanks.sun_drive has {slices}: every flank needs the same number, at least one",
                        devs.len()
                    ),
                });
            }
            for (j, dev) in devs.iter().enumerate() {
                let at = |what: &str, i: usize| format!("flanks.{fname}[{j}].{what}[{i}]");
                if dev.roll.len() != dev.depth.len() || dev.roll.len() < 2 {
                    return Err(WornStateError::GridShape {
                        field: format!("flanks.{fname}[{j}]"),
                        reason: format!(
                            "{} roll angles and {} depths: both need the same length, at least 2",
                            dev.roll.len(),
                            dev.depth.len()
                        ),
                    });
                }
                for (i, xi) in dev.roll.iter().enumerate() {
                    finite(&|| at("roll", i), *xi)?;
                    if i > 0 && *xi <= dev.roll[i - 1] {
                        return Err(WornStateError::GridShape {
                            field: at("roll", i),
                            reason: format!(
                                "roll angle {xi} rad does not exceed the one before ({} rad): the grid must increase",
                                dev.roll[i - 1]
                            ),
                        });
                    }
                }
                for (i, d) in dev.depth.iter().enumerate() {
                    amount(&|| at("depth", i), *d)?;
                }
            }
        }
        amount(&|| "revolutions".into(), self.revolutions)?;
        amount(&|| "cycles.sun".into(), self.cycles.sun)?;
        amount(&|| "cycles.planet".into(), self.cycles.planet)?;
        amount(&|| "cycles.ring".into(), self.cycles.ring)?;
        if self.history.len() != self.kappa as usize {
            return Err(WornStateError::Inconsistent {
                reason: format!(
                    "kappa is {} but the history holds {} updates",
                    self.kappa,
                    self.history.len()
                ),
            });
        }
        let mut revolutions = 0.0;
        for (i, u) in self.history.iter().enumerate() {
            let at = |what: &str| format!("history[{i}].{what}");
            if u.kappa as usize != i + 1 {
                return Err(WornStateError::Inconsistent {
                    reason: format!(
                        "history[{i}].kappa is {} where update {} made kappa {}",
                        u.kappa,
                        i + 1,
                        i + 1
                    ),
                });
            }
            amount(&|| at("revolutions"), u.revolutions)?;
            amount(&|| at("cycles.sun"), u.cycles.sun)?;
            amount(&|| at("cycles.planet"), u.cycles.planet)?;
            amount(&|| at("cycles.ring"), u.cycles.ring)?;
            for (k, e) in u.new_wear.iter().chain(&u.total_wear).enumerate() {
                amount(&|| at(&format!("wear[{k}].depth")), e.depth)?;
                finite(&|| at(&format!("wear[{k}].roll")), e.roll)?;
            }
            revolutions += u.revolutions;
        }
        if (revolutions - self.revolutions).abs() > 1e-9 * self.revolutions.abs().max(1.0) {
            return Err(WornStateError::Inconsistent {
                reason: format!(
                    "revolutions is {} but the updates in the history add up to {revolutions}",
                    self.revolutions
                ),
            });
        }
        Ok(())
    }

    /// The state as its JSON document. A state with a non-finite or
    /// negative value or a malformed grid is refused rather than written.
    pub fn to_json(&self) -> Result<String, WornStateError> {
        self.validate()?;
        let content =
            serde_json::to_value(self).map_err(|e| WornStateError::Malformed { reason: e.to_string() })?;
        let checksum = content_checksum(&content);
        let doc = serde_json::json!({
            "format": FORMAT,
            "version": VERSION,
            "checksum": checksum,
            "content": content,
        });
        serde_json::to_string_pretty(&doc).map_err(|e| WornStateError::Malformed { reason: e.to_string() })
    }

    /// Reads a JSON document for the gear set `set`: refuses text that is
    /// not JSON or is cut short, another format or version, a checksum
    /// mismatch, non-finite or negative values, malformed grids, and a state
    /// of another gear set.
    pub fn from_json(text: &str, set: &GearSet) -> Result<Self, WornStateError> {
        Self::from_json_accepting(text, set, &[]).map(|(state, _)| state)
    }

    /// [`WornState::from_json`] accepting a gear set that differs only in
    /// kinds of `accept` ([`WornState::accepted_for`]); returned with the
    /// differences accepted.
    pub fn from_json_accepting(
        text: &str,
        set: &GearSet,
        accept: &[StateDifference],
    ) -> Result<(Self, Vec<ParameterDifference>), WornStateError> {
        let (state, differences) = Self::from_json_any_set(text)?.accepted_for(set, accept)?;
        state.check_plausible(set)?;
        Ok((state, differences))
    }

    /// The largest plausible depth on a flank of `gear` of `set` \[m\]
    /// ([`MAX_DEPTH_FRACTION`]) and what it is a fraction of.
    pub fn plausible_depth(set: &GearSet, gear: crate::wear::flank::Gear) -> (f64, String) {
        use crate::wear::flank::Gear;
        let form = match gear {
            Gear::Sun => set.sun(),
            Gear::Planet => set.planet(),
            Gear::Ring => set.ring(),
        };
        let height = (form.tip_radius - form.root_radius).abs();
        let (size, basis) = if form.tooth_thickness <= height {
            (form.tooth_thickness, "tooth thickness")
        } else {
            (height, "tooth height")
        };
        (MAX_DEPTH_FRACTION * size, format!("{basis} {:.4} mm", size * 1e3))
    }

    /// Refuses a depth deeper than any flank of `set` can wear
    /// ([`Self::plausible_depth`]), naming the point and the figure.
    pub fn check_plausible(&self, set: &GearSet) -> Result<(), WornStateError> {
        for flank in Flank::ALL {
            let gear = flank.gear();
            let (limit, basis) = Self::plausible_depth(set, gear);
            for (j, dev) in self.flanks.get(flank).iter().enumerate() {
                if let Some((i, d)) = dev.depth.iter().enumerate().find(|(_, d)| **d > limit) {
                    return Err(WornStateError::Implausible {
                        field: format!("flanks.{}[{j}].depth[{i}]", flank.name()),
                        depth: *d,
                        limit,
                        gear: gear.name(),
                        basis,
                    });
                }
            }
        }
        Ok(())
    }

    /// Reads a JSON document with every check but the gear set's.
    pub fn from_json_any_set(text: &str) -> Result<Self, WornStateError> {
        let content = open_document(text, FORMAT, VERSION).map_err(|e| match e {
            DocumentError::NotJson { line, column, reason } => {
                WornStateError::NotJson { line, column, reason }
            }
            DocumentError::Truncated { line, column } => WornStateError::Truncated { line, column },
            DocumentError::Format { found } => WornStateError::Format { found, expected: FORMAT },
            DocumentError::Version { found } => WornStateError::Version { found, supported: VERSION },
            DocumentError::NoContent => {
                WornStateError::Malformed { reason: "the document has no \"content\"".into() }
            }
            DocumentError::Checksum { stored, computed } => WornStateError::Checksum { stored, computed },
            DocumentError::NonFinite { field } => WornStateError::NonFinite { field },
        })?;
        let state: WornState = serde_json::from_value(content)
            .map_err(|e| WornStateError::Malformed { reason: e.to_string() })?;
        state.validate()?;
        Ok(state)
    }
}

/// Why a versioned, checksummed document (`{ "format", "version", "checksum", "content" }`,
/// as the worn-profile state's) could not be opened.
#[derive(Debug, Clone, PartialEq)]
pub enum DocumentError {
    /// The text is not JSON.
    NotJson {
        /// Line of the error.
        line: usize,
        /// Column of the error.
        column: usize,
        /// What the parser found.
        reason: String,
    },
    /// The text ends before the document does.
    Truncated {
        /// Last line.
        line: usize,
        /// Last column.
        column: usize,
    },
    /// Another `format` (what was found, quoted, or `absent`).
    Format {
        /// What was found.
        found: String,
    },
    /// Another `version` (or `absent`).
    Version {
        /// What was found.
        found: String,
    },
    /// No `content`.
    NoContent,
    /// The content does not match its checksum.
    Checksum {
        /// Checksum in the document.
        stored: String,
        /// Checksum of the content read.
        computed: String,
    },
    /// A value that is not a finite number (JSON `null`, or a number out of range).
    NonFinite {
        /// Where.
        field: String,
    },
}

/// The content of a document of `format` and `version`, its checksum checked
/// ([`content_checksum`]) and free of `null` (serde_json's non-finite numbers).
pub fn open_document(text: &str, format: &str, version: u64) -> Result<Value, DocumentError> {
    let doc: Value = serde_json::from_str(text).map_err(|e| {
        let (line, column) = (e.line(), e.column());
        if e.is_eof() {
            DocumentError::Truncated { line, column }
        } else if e.to_string().contains("number out of range") {
            DocumentError::NonFinite { field: format!("the number at line {line}, column {column}") }
        } else {
            DocumentError::NotJson { line, column, reason: e.to_string() }
        }
    })?;
    match doc.get("format") {
        Some(Value::String(s)) if s == format => {}
        Some(Value::String(s)) => return Err(DocumentError::Format { found: format!("\"{s}\"") }),
        Some(other) => return Err(DocumentError::Format { found: other.to_string() }),
        None => return Err(DocumentError::Format { found: "absent".into() }),
    }
    match doc.get("version") {
        Some(Value::Number(n)) if n.as_u64() == Some(version) => {}
        Some(v) => return Err(DocumentError::Version { found: v.to_string() }),
        None => return Err(DocumentError::Version { found: "absent".into() }),
    }
    let content = doc.get("content").ok_or(DocumentError::NoContent)?;
    let stored = match doc.get("checksum") {
        Some(Value::String(s)) => s.clone(),
        _ => String::from("absent"),
    };
    let computed = content_checksum(content);
    if stored != computed {
        return Err(DocumentError::Checksum { stored, computed });
    }
    if let Some(field) = first_null(content, String::new()) {
        return Err(DocumentError::NonFinite { field });
    }
    Ok(content.clone())
}

/// The checksum of a document's content: FNV-1a 64 of its compact JSON
/// text with keys in sorted order, as `fnv1a64:` and 16 hex digits.
pub fn content_checksum(content: &Value) -> String {
    // serde_json's map keeps keys sorted (no `preserve_order`), so this text
    // is canonical; floats are written in their shortest round-trip form.
    let text = serde_json::to_string(content).unwrap_or_default();
    format!("fnv1a64:{:016x}", crate::files::hash::fnv1a64(text.as_bytes()))
}

/// Path of the first `null` in a JSON value: serde_json writes non-finite
/// floats as `null`, and the document has no optional values.
fn first_null(v: &Value, path: String) -> Option<String> {
    match v {
        Value::Null => Some(if path.is_empty() { "content".into() } else { path }),
        Value::Array(a) => a.iter().enumerate().find_map(|(i, x)| first_null(x, format!("{path}[{i}]"))),
        Value::Object(m) => m.iter().find_map(|(k, x)| {
            first_null(x, if path.is_empty() { k.clone() } else { format!("{path}.{k}") })
        }),
        _ => None,
    }
}

/// Why a worn-profile state file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum StateFileError {
    /// The file system refused.
    #[error("worn-profile state file {0}")]
    Io(crate::files::FileError),
    /// The file was read but its content was refused.
    #[error("worn-profile state file '{}': {source}", path.display())]
    State {
        /// The file.
        path: std::path::PathBuf,
        /// Why it was refused.
        #[source]
        source: Box<WornStateError>,
    },
}

impl From<crate::files::FileError> for StateFileError {
    fn from(e: crate::files::FileError) -> Self {
        StateFileError::Io(e)
    }
}

/// Writes a worn-profile state to `path` (atomically). A state with a
/// non-finite or negative value or a malformed grid is refused and nothing
/// is written.
pub fn write_worn_state(path: &std::path::Path, state: &WornState) -> Result<(), StateFileError> {
    let text = state
        .to_json()
        .map_err(|source| StateFileError::State { path: path.to_path_buf(), source: Box::new(source) })?;
    crate::files::check_output_size(path, crate::files::InputKind::WornState, text.len())?;
    Ok(crate::files::write_durable(path, text.as_bytes())?)
}

/// Reads the worn-profile state at `path` for the gear set `set`, with every
/// check of [`WornState::from_json`] (through [`crate::files::read_input`]).
pub fn read_worn_state(path: &std::path::Path, set: &GearSet) -> Result<WornState, StateFileError> {
    read_worn_state_accepting(path, set, &[]).map(|(state, _)| state)
}

/// [`read_worn_state`] accepting a gear set that differs only in kinds of
/// `accept` ([`WornState::from_json_accepting`]); returned with the
/// differences accepted.
pub fn read_worn_state_accepting(
    path: &std::path::Path,
    set: &GearSet,
    accept: &[StateDifference],
) -> Result<(WornState, Vec<ParameterDifference>), StateFileError> {
    let bytes = crate::files::read_input(path, crate::files::InputKind::WornState)?;
    parse_worn_state_accepting(path, &bytes, set, accept)
}

/// [`read_worn_state_accepting`] on the bytes already read from `path`, for a caller that
/// also keys a cache by them (the file is read once).
pub fn parse_worn_state_accepting(
    path: &std::path::Path,
    bytes: &[u8],
    set: &GearSet,
    accept: &[StateDifference],
) -> Result<(WornState, Vec<ParameterDifference>), StateFileError> {
    WornState::from_json_accepting(&String::from_utf8_lossy(bytes), set, accept)
        .map_err(|source| StateFileError::State { path: path.to_path_buf(), source: Box::new(source) })
}

/// One line that says what was accepted: each kind with its parameters'
/// values in the state and here.
pub fn describe_accepted(differences: &[ParameterDifference]) -> String {
    let mut kinds: Vec<&str> = differences
        .iter()
        .filter_map(|d| StateDifference::of_parameter(&d.name))
        .map(StateDifference::name)
        .collect();
    kinds.sort();
    kinds.dedup();
    format!(
        "accepted a worn-profile state whose gear set differs in {}: {}",
        kinds.join(", "),
        describe_differences(differences)
    )
}
