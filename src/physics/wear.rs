//! Archard wear of the tooth flanks, quasi-static (docs/MODEL.md §4–5).
//!
//! Archard: the depth worn at a flank point is h = ∫ k P ds (k the wear
//! coefficient [m²/N], P the contact pressure, s the sliding distance).
//!
//! # One wear cycle on the current geometry
//!
//! A wear cycle is one passage of one tooth pair of a mesh through its
//! loaded engagement, from its first to its last contact (corner contact
//! included). At R + 1 pair positions s_0..s_R, spread evenly over that range
//! (s_0 and s_R are the first and last contact, so the load is zero there),
//! the whole-set quasi-static LTCA ([`SetModel::equilibrium`]) is solved with
//! the current flank deviations in the separation tables: the load of the
//! pair, per face slice, follows from the real load sharing between the
//! pairs of a mesh and between the planets. Each planet's pair is followed
//! through its own passage (planet n's pair at position s sees the set at
//! sun travel λ = s + r_b,sun ψ_n); the wear per cycle of a flank is the mean
//! over the planets (a sun tooth meets every planet once per relative
//! revolution, so its wear per revolution is exactly n times that mean; the
//! planets are stored as one geometry).
//!
//! Why the whole set and not one mesh at the mean planet load: the planet
//! loads vary through the mesh cycle (load-sharing factor 1.26 in the
//! example), and wear changes both the sharing between the pairs of a mesh
//! and between planets. The whole set carries both; its cost is a few
//! hundred small equilibria per cycle.
//!
//! # Where the pair loads come from
//!
//! The pair's first and last contact and its load per slice at each
//! position come from a [`PressureSource`]: the whole-set quasi-static LTCA
//! above (the study's, and the default), or the steady state of the dynamic
//! model at an input speed ([`super::dynamic_wear`]). Everything after the
//! loads (bands, sliding, Archard wear, the update) is the same code for
//! both.
//!
//! # Contact point, band and sliding distance
//!
//! On the involute path a pair at position s touches gear 1 at roll angle
//! ρ1(s)/r_b1 and gear 2 at ρ2(s)/r_b2 (mesh.rs). Before the path (s <
//! start) the tip corner of gear 2 (the end of its involute at the chamfer)
//! touches gear 1: gear 2's contact point stays at its corner and gear 1's
//! is the point of its flank at the radius of the corner, whose position
//! follows from rigid rotation of gear 2 (`contact_rolls`); after the path the
//! roles swap. The Hertzian band (hertz.rs, line load of the slice,
//! curvatures at the nearest end of the involute path as in the LTCA) is
//! centred on the contact point, with half-width b, along each flank's arc
//! length σ = r_b ξ²/2 (ξ the roll angle).
//!
//! The sliding distance of a flank point between positions r and r + 1 is
//! the distance the mating surface slides past it while the point is inside
//! the band: the relative displacement of the two surfaces at the contact,
//! |Δσ_1 ∓ Δσ_2| (each Δσ the band's travel along its own flank; minus for
//! an external pair, whose arc coordinates run opposite ways along the
//! common tangent, plus for the internal one), times the fraction of the
//! step the point spends inside the band (centre and half-width linear over
//! the step). In corner contact the corner's band does not move (Δσ = 0)
//! and the whole relative slip goes by it. Through a passage with constant
//! b this sums to 2b·|1 − v_mate/v_self| (Flodin & Andersson 1997; docs/FORMULAS.md).
//!
//! Wear of one cycle (docs/MODEL.md §4.3): Δh = Σ_r ½ k s_{r→r+1} (P_r + P_{r+1}),
//! P_r the band's elliptic pressure at the point at position r. For a
//! constant band this tends to Δh_i = k w |v_i − v_j| / v_i.
//!
//! # Update
//!
//! Wear per input revolution of a flank is its wear per cycle times its
//! gear's tooth cycles per input revolution ([`cycles_per_input_revolution`]:
//! carrier held, sun driven: sun n, planet Z_sun/Z_planet, ring n·Z_sun/Z_ring).
//! An update runs the input revolutions that make the largest new wear on
//! any wearing flank reach ε^κ, or fewer when a total depth of ε_tot or a
//! given number of revolutions ends it first; every flank wears with its own
//! gear's cycles for those revolutions. The deviations enter the next
//! cycle's separation tables ([`WornState::mesh_flanks`]).

use serde::{Deserialize, Serialize};

use super::gear::{GearKind, GearSet, Member, MeshKind};
use super::hertz::{contact_modulus, line_contact, pressure_at, LineContact};
use super::involute::roll_angle;
use super::ltca::{loaded_span, Refine, SetEquilibrium, SetModel};
use super::mesh::PathOfContact;
use super::profile::{ProfileDeviation, ProfileEnds};
use super::wear_state::{FlankExtreme, UpdateRecord, WornState, WornStateError};

/// Archard wear coefficient of the example [m²/N] (docs/MODEL.md §4).
pub const EXAMPLE_ARCHARD_COEFFICIENT: f64 = 1e-18;

/// One of the three gears of the set (all planets alike).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Gear {
    /// The sun.
    Sun,
    /// A planet.
    Planet,
    /// The ring.
    Ring,
}

impl Gear {
    /// The name used in files and messages.
    pub fn name(self) -> &'static str {
        match self {
            Gear::Sun => "sun",
            Gear::Planet => "planet",
            Gear::Ring => "ring",
        }
    }
}

/// A physical tooth flank of the set. A planet tooth meets the sun on one
/// flank and the ring on the other (docs/MODEL.md §4.6), so the planet's sun-side
/// flank is gear 2's drive flank of the sun–planet mesh and gear 1's back
/// flank of the ring–planet mesh, and its ring-side flank the other way round.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Flank {
    /// The sun's flank loaded by a positive input torque.
    SunDrive,
    /// The sun's other flank.
    SunCoast,
    /// The planet's flank that meets the sun's drive flank.
    PlanetSunSide,
    /// The planet's flank that meets the ring's drive flank.
    PlanetRingSide,
    /// The ring's flank loaded by a positive input torque.
    RingDrive,
    /// The ring's other flank.
    RingCoast,
}

impl Flank {
    /// Every flank, in the order of the state file.
    pub const ALL: [Flank; 6] = [
        Flank::SunDrive,
        Flank::SunCoast,
        Flank::PlanetSunSide,
        Flank::PlanetRingSide,
        Flank::RingDrive,
        Flank::RingCoast,
    ];

    /// The name used in files and messages.
    pub fn name(self) -> &'static str {
        match self {
            Flank::SunDrive => "sun_drive",
            Flank::SunCoast => "sun_coast",
            Flank::PlanetSunSide => "planet_sun_side",
            Flank::PlanetRingSide => "planet_ring_side",
            Flank::RingDrive => "ring_drive",
            Flank::RingCoast => "ring_coast",
        }
    }

    /// The gear the flank belongs to.
    pub fn gear(self) -> Gear {
        match self {
            Flank::SunDrive | Flank::SunCoast => Gear::Sun,
            Flank::PlanetSunSide | Flank::PlanetRingSide => Gear::Planet,
            Flank::RingDrive | Flank::RingCoast => Gear::Ring,
        }
    }

    /// The mesh whose drive-flank contact loads this flank, and whether it is
    /// gear 1 of that mesh; `None` for the coast flanks.
    pub fn drive_mesh(self) -> Option<(MeshKind, bool)> {
        match self {
            Flank::SunDrive => Some((MeshKind::SunPlanet, true)),
            Flank::PlanetSunSide => Some((MeshKind::SunPlanet, false)),
            Flank::PlanetRingSide => Some((MeshKind::RingPlanet, true)),
            Flank::RingDrive => Some((MeshKind::RingPlanet, false)),
            Flank::SunCoast | Flank::RingCoast => None,
        }
    }
}

/// Which drive flanks wear. The coast flanks carry no load under a positive
/// input torque and never wear here.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct WearingFlanks {
    /// The sun's drive flank.
    pub sun_drive: bool,
    /// The planet's sun-side flank.
    pub planet_sun_side: bool,
    /// The planet's ring-side flank.
    pub planet_ring_side: bool,
    /// The ring's drive flank.
    pub ring_drive: bool,
}

impl Default for WearingFlanks {
    /// The study's choice: sun and planet wear in the sun–planet mesh, the
    /// ring mesh is left unworn.
    fn default() -> Self {
        Self::sun_planet()
    }
}

impl WearingFlanks {
    /// The two flanks of the sun–planet mesh.
    pub fn sun_planet() -> Self {
        Self { sun_drive: true, planet_sun_side: true, planet_ring_side: false, ring_drive: false }
    }

    /// All four loaded flanks: both meshes wear.
    pub fn both_meshes() -> Self {
        Self { sun_drive: true, planet_sun_side: true, planet_ring_side: true, ring_drive: true }
    }

    /// Whether `flank` wears.
    pub fn contains(&self, flank: Flank) -> bool {
        match flank {
            Flank::SunDrive => self.sun_drive,
            Flank::PlanetSunSide => self.planet_sun_side,
            Flank::PlanetRingSide => self.planet_ring_side,
            Flank::RingDrive => self.ring_drive,
            Flank::SunCoast | Flank::RingCoast => false,
        }
    }

    /// The wearing flanks.
    pub fn flanks(&self) -> Vec<Flank> {
        Flank::ALL.into_iter().filter(|f| self.contains(*f)).collect()
    }
}

/// Settings of the wear model (docs/MODEL.md §4), SI.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WearSettings {
    /// Archard wear coefficient k [m²/N].
    pub archard_coefficient: f64,
    /// Steps R over one wear cycle: the pair is analysed at R + 1 positions
    /// from its first to its last contact [-].
    pub positions: usize,
    /// Grid points I along each flank's active profile, uniform in roll angle
    /// (used when an unworn state is made) [-].
    pub profile_points: usize,
    /// Face slices J, each with its own deviations (1: a 2-D profile grid) [-].
    pub face_slices: usize,
    /// Largest new wear of one update, ε^κ [m].
    pub update_depth: f64,
    /// Total wear of any point at which the wear stepper stops, ε_tot [m].
    pub total_depth: f64,
    /// Which flanks wear.
    pub wearing: WearingFlanks,
    /// Where the tooth-pair loads of a wear cycle come from (the quasi-static
    /// LTCA unless set).
    #[serde(default)]
    pub source: PressureSource,
    /// What the worn profile is beyond each flank's grid (below its start of
    /// active profile and past its last point): the end value held (default)
    /// or the unworn surface.
    #[serde(default)]
    pub profile_ends: ProfileEnds,
}

impl Default for WearSettings {
    /// The study's settings: k = 1e-18 m²/N, R = 200, I = 50, J = 1,
    /// ε^κ = 2.5 µm, ε_tot = 15 µm, sun and planet wear, quasi-static loads.
    fn default() -> Self {
        Self {
            archard_coefficient: EXAMPLE_ARCHARD_COEFFICIENT,
            positions: 200,
            profile_points: 50,
            face_slices: 1,
            update_depth: 2.5e-6,
            total_depth: 15e-6,
            wearing: WearingFlanks::default(),
            source: PressureSource::QuasiStatic,
            profile_ends: ProfileEnds::Hold,
        }
    }
}

/// Where a wear cycle takes the tooth-pair loads from (docs/MODEL.md §4.1 uses
/// the quasi-static ones; the dynamic ones are an option beyond the study).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum PressureSource {
    /// The whole-set quasi-static LTCA at each pair position.
    #[default]
    QuasiStatic,
    /// The steady state of the nonlinear dynamic model at an input speed, on
    /// the state's worn geometry, with the gear set's dynamics settings: each
    /// pair's elastic load as a function of its position, averaged over the
    /// window's mesh cycles ([`super::dynamic_wear`]).
    Dynamic {
        /// Input speed [rpm].
        speed_rpm: f64,
    },
}

impl PressureSource {
    /// Checks the source; a speed that cannot be run is named.
    pub fn validate(&self) -> Result<(), WearError> {
        match *self {
            PressureSource::QuasiStatic => Ok(()),
            PressureSource::Dynamic { speed_rpm } if speed_rpm.is_finite() && speed_rpm > 0.0 => Ok(()),
            PressureSource::Dynamic { speed_rpm } => Err(WearError::InvalidSetting {
                name: "source.speed_rpm",
                value: format!("{speed_rpm} rpm"),
                allowed: "a finite positive input speed",
            }),
        }
    }

    /// A short description for messages and reports.
    pub fn describe(&self) -> String {
        match self {
            PressureSource::QuasiStatic => "quasi-static".into(),
            PressureSource::Dynamic { speed_rpm } => format!("dynamic at {speed_rpm} rpm"),
        }
    }
}

impl WearSettings {
    /// The defaults with the scene's profile grid points and face slices
    /// (`analysis.profile_points`, `analysis.face_slices`).
    pub fn for_set(set: &GearSet) -> Self {
        Self {
            profile_points: set.analysis.profile_points,
            face_slices: set.analysis.face_slices,
            ..Self::default()
        }
    }

    /// Checks every setting; the first one that cannot be used is named.
    pub fn validate(&self) -> Result<(), WearError> {
        let bad = |name: &'static str, value: String, allowed: &'static str| {
            Err(WearError::InvalidSetting { name, value, allowed })
        };
        let k = self.archard_coefficient;
        if !(k.is_finite() && k > 0.0) {
            return bad("archard_coefficient", format!("{k:e} m²/N"), "a finite positive wear coefficient");
        }
        if !(10..=100_000).contains(&self.positions) {
            return bad(
                "positions",
                self.positions.to_string(),
                "between 10 and 100000 steps over one wear cycle (the band must span several steps)",
            );
        }
        if !(3..=10_000).contains(&self.profile_points) {
            return bad("profile_points", self.profile_points.to_string(), "between 3 and 10000 grid points");
        }
        if !(1..=1000).contains(&self.face_slices) {
            return bad("face_slices", self.face_slices.to_string(), "between 1 and 1000 slices");
        }
        let e = self.update_depth;
        if !(e.is_finite() && e > 0.0) {
            return bad("update_depth", format!("{e:e} m"), "a finite positive depth");
        }
        let t = self.total_depth;
        if !(t.is_finite() && t >= e && t <= 1e-3) {
            return bad("total_depth", format!("{t:e} m"), "at least update_depth and at most 1 mm");
        }
        if self.wearing.flanks().is_empty() {
            return bad(
                "wearing",
                "no flank".into(),
                "at least one of sun_drive, planet_sun_side, planet_ring_side, ring_drive",
            );
        }
        self.source.validate()
    }
}

/// Why the wear model refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WearError {
    /// A setting that cannot be used.
    #[error("wear setting {name} = {value}: allowed is {allowed}")]
    InvalidSetting {
        /// Setting.
        name: &'static str,
        /// Value given.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
    /// A limit of one update or run that cannot be used.
    #[error("wear limit {name} = {value}: allowed is {allowed}")]
    InvalidLimit {
        /// Limit.
        name: &'static str,
        /// Value given.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
    /// The state does not fit this gear set or its grids are unusable.
    #[error("worn-profile state: {0}")]
    State(#[from] WornStateError),
    /// The state's face slices differ from the settings'.
    #[error("the worn-profile state has {state} face slices but the wear settings ask for {settings}: set face_slices to {state} or start from an unworn state")]
    SliceCount {
        /// Slices in the state.
        state: usize,
        /// Slices in the settings.
        settings: usize,
    },
    /// No wearing flank wears: nothing carries load or nothing slides.
    #[error("no wearing flank wears in a cycle (largest wear per revolution {rate:e} m): check input_torque and the wearing flanks")]
    NoWear {
        /// Largest wear per input revolution [m].
        rate: f64,
    },
    /// The cycle was not computed on this state.
    #[error("the wear cycle of κ = {cycle_kappa} does not belong to this state (κ = {state_kappa}) on flank {flank}: compute the cycle on the state it updates")]
    CycleMismatch {
        /// κ of the cycle.
        cycle_kappa: u32,
        /// κ of the state.
        state_kappa: u32,
        /// The first flank whose grid differs (or the flank checked).
        flank: &'static str,
    },
    /// The dynamic run of a dynamic pressure source failed.
    #[error("dynamic tooth loads at {speed_rpm} rpm: {reason}")]
    DynamicRun {
        /// Input speed [rpm].
        speed_rpm: f64,
        /// What failed (the dynamic model's or the integrator's error).
        reason: String,
    },
    /// The total wear limit is already reached.
    #[error("the deepest wear {depth:e} m already reaches total_depth = {limit:e} m: no further update")]
    TotalWearReached {
        /// Deepest wear of the state [m].
        depth: f64,
        /// The limit [m].
        limit: f64,
    },
}

/// Tooth cycles of each gear (a revolution count when per input revolution).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GearCycles {
    /// Cycles of one sun tooth [-].
    pub sun: f64,
    /// Cycles of one planet tooth (each of its flanks) [-].
    pub planet: f64,
    /// Cycles of one ring tooth [-].
    pub ring: f64,
}

impl GearCycles {
    /// Cycles of `gear` [-].
    pub fn of(&self, gear: Gear) -> f64 {
        match gear {
            Gear::Sun => self.sun,
            Gear::Planet => self.planet,
            Gear::Ring => self.ring,
        }
    }

    /// Every count times `factor`.
    pub fn scaled(&self, factor: f64) -> Self {
        Self { sun: self.sun * factor, planet: self.planet * factor, ring: self.ring * factor }
    }

    /// The sum of two counts.
    pub fn plus(&self, other: &Self) -> Self {
        Self { sun: self.sun + other.sun, planet: self.planet + other.planet, ring: self.ring + other.ring }
    }
}

/// Tooth cycles per revolution of the input member (docs/MODEL.md §4.5), from
/// the speeds relative to the carrier: with the held member still and the
/// input turning once, Willis' relation (ω_s − ω_c) Z_s = −(ω_r − ω_c) Z_r
/// gives the relative sun speed u; a mesh then passes M = Z_s |u| teeth,
/// a sun tooth meets n·M/Z_s planets, a planet tooth M/Z_p sun (and ring)
/// teeth, a ring tooth n·M/Z_r planets. Carrier held, sun driven: sun n,
/// planet Z_s/Z_p, ring n·Z_s/Z_r.
pub fn cycles_per_input_revolution(set: &GearSet) -> GearCycles {
    let (zs, zp, zr) = (f64::from(set.sun.teeth), f64::from(set.planet.teeth), f64::from(set.ring.teeth));
    let n = set.planet_angles.len() as f64;
    // Speed of a member as a linear form in (carrier speed c, relative sun speed u).
    let form = |m: Member| match m {
        Member::Sun => (1.0, 1.0),
        Member::Ring => (1.0, -zs / zr),
        Member::Carrier => (1.0, 0.0),
    };
    let (h, i) = (form(set.held), form(set.input));
    // h·(c, u) = 0, i·(c, u) = 1.
    let det = h.0 * i.1 - h.1 * i.0;
    let u = if det == 0.0 { 1.0 } else { h.0 / det };
    let mesh_cycles = zs * u.abs();
    GearCycles { sun: n * mesh_cycles / zs, planet: mesh_cycles / zp, ring: n * mesh_cycles / zr }
}

/// Roll angles [rad] of the contact point on gear 1's and on gear 2's flank
/// when the pair's drive-flank position is `s` [m].
///
/// On the involute path they are ρ1/r_b1 and ρ2/r_b2. Outside it the tip
/// corner (the end of the involute) of one gear touches the other's flank:
/// before the path gear 2's corner, which sat on the line of action at
/// `start`; gear 1 is touched at the radius the corner reaches by rigid
/// rotation of gear 2 (coordinates: line of action on the x axis, T1 at the
/// origin, gear 1's centre at (0, −r_b1); gear 2's at (L, r_b2) turning
/// counter-clockwise as s grows, or for the ring at (−L, −r_b2) turning
/// clockwise; gear 1 turns clockwise). After the path gear 1's corner
/// touches gear 2 likewise. The gap of corner contact is a few µm, so the
/// radius of the corner is the radius of the touched flank point.
pub fn contact_rolls(path: &PathOfContact, s: f64) -> (f64, f64) {
    let (rb1, rb2, l) = (path.base_radius_1, path.base_radius_2, path.tangency_distance);
    let o1 = [0.0, -rb1];
    let (o2, turn2) = match path.kind {
        GearKind::External => ([l, rb2], 1.0),
        GearKind::Internal => ([-l, -rb2], -1.0),
    };
    let rotate_about = |p: [f64; 2], c: [f64; 2], angle: f64| {
        let (sn, cs) = angle.sin_cos();
        let d = [p[0] - c[0], p[1] - c[1]];
        [c[0] + cs * d[0] - sn * d[1], c[1] + sn * d[0] + cs * d[1]]
    };
    let dist = |p: [f64; 2], c: [f64; 2]| (p[0] - c[0]).hypot(p[1] - c[1]);
    if s < path.start {
        let corner = rotate_about([path.start, 0.0], o2, turn2 * (s - path.start) / rb2);
        (roll_angle(dist(corner, o1), rb1), path.roll_2(path.start))
    } else if s > path.end {
        let corner = rotate_about([path.end, 0.0], o1, -(s - path.end) / rb1);
        (path.roll_1(path.end), roll_angle(dist(corner, o2), rb2))
    } else {
        (path.roll_1(s), path.roll_2(s))
    }
}

/// Arc length [m] along an involute of base radius `base_radius` [m] from
/// the base circle to roll angle `roll` [rad]: σ = r_b ξ²/2.
pub fn involute_arc(base_radius: f64, roll: f64) -> f64 {
    0.5 * base_radius * roll * roll
}

/// Roll-angle range [rad] of a flank's active profile on the unloaded path
/// with the involute ends: from its lowest to its highest contact point
/// (start of active profile to the end of the involute at the tip or
/// chamfer). A coast flank takes its drive flank's range (symmetric teeth,
/// the same path backwards).
pub fn active_profile(set: &GearSet, flank: Flank) -> (f64, f64) {
    let (mesh, gear1) = match flank {
        Flank::SunDrive | Flank::SunCoast => (MeshKind::SunPlanet, true),
        Flank::PlanetSunSide => (MeshKind::SunPlanet, false),
        Flank::PlanetRingSide => (MeshKind::RingPlanet, true),
        Flank::RingDrive | Flank::RingCoast => (MeshKind::RingPlanet, false),
    };
    let p = PathOfContact::new(set, mesh);
    let (a, b) =
        if gear1 { (p.roll_1(p.start), p.roll_1(p.end)) } else { (p.roll_2(p.start), p.roll_2(p.end)) };
    (a.min(b), a.max(b))
}

/// The Hertzian band on one flank at one pair position.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// Arc length along the flank from its base circle to the band's centre [m].
    pub centre: f64,
    /// The line contact: half-width [m] and peak pressure [Pa].
    pub contact: LineContact,
}

/// What one passage does to the points of a flank.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Passage {
    /// Depth worn at each point [m].
    pub wear: Vec<f64>,
    /// Sliding distance of each point: how far the mating surface slid past
    /// it while it was inside the band [m].
    pub sliding: Vec<f64>,
}

/// Fraction of a step (t from 0 to 1) during which a point at distance x(t)
/// from the band's centre lies inside the band, |x(t)| < b(t), with x and b
/// linear over the step from (`x0`, `b0`) to (`x1`, `b1`).
pub fn fraction_inside(x0: f64, x1: f64, b0: f64, b1: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    // x − b < 0 and −x − b < 0.
    for (f0, f1) in [(x0 - b0, x1 - b1), (-x0 - b0, -x1 - b1)] {
        match (f0 < 0.0, f1 < 0.0) {
            (true, true) => {}
            (false, false) => return 0.0,
            (true, false) => hi = hi.min(f0 / (f0 - f1)),
            (false, true) => lo = lo.max(f0 / (f0 - f1)),
        }
    }
    (hi - lo).max(0.0)
}

/// Sliding distance [m] of each point (arc positions `arc` [m]) in each
/// step: `slip[r]` (the relative displacement of the surfaces between band
/// positions r and r + 1 [m]) times the fraction of the step the point is
/// inside the band. `out[r][g]`.
pub fn sliding_map(arc: &[f64], bands: &[Band], slip: &[f64]) -> Vec<Vec<f64>> {
    bands
        .windows(2)
        .zip(slip)
        .map(|(w, s)| {
            arc.iter()
                .map(|a| {
                    let f = fraction_inside(
                        a - w[0].centre,
                        a - w[1].centre,
                        w[0].contact.half_width,
                        w[1].contact.half_width,
                    );
                    f * s
                })
                .collect()
        })
        .collect()
}

/// Wear and sliding distance of the points of a flank at arc positions
/// `arc` [m] through one passage of the band (`bands`, one per pair
/// position, `slip` between consecutive ones [m]) with Archard coefficient
/// `archard` [m²/N]: Δh = Σ_r ½ k s_{r→r+1} (P_r + P_{r+1}) (docs/MODEL.md §4.3).
pub fn passage_wear(arc: &[f64], bands: &[Band], slip: &[f64], archard: f64) -> Passage {
    let mut out = Passage { wear: vec![0.0; arc.len()], sliding: vec![0.0; arc.len()] };
    for (w, s) in bands.windows(2).zip(slip) {
        let (a, b) = (&w[0], &w[1]);
        if a.contact.half_width == 0.0 && b.contact.half_width == 0.0 {
            continue;
        }
        for (g, x) in arc.iter().enumerate() {
            let f = fraction_inside(x - a.centre, x - b.centre, a.contact.half_width, b.contact.half_width);
            if f == 0.0 {
                continue;
            }
            let sliding = f * s;
            let p = pressure_at(&a.contact, x - a.centre) + pressure_at(&b.contact, x - b.centre);
            out.wear[g] += 0.5 * archard * sliding * p;
            out.sliding[g] += sliding;
        }
    }
    out
}

/// One mesh's pair through one wear cycle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshPassage {
    /// The mesh.
    pub mesh: MeshKind,
    /// Pair positions s_0..s_R on the line of action, first to last contact [m].
    pub position: Vec<f64>,
    /// Roll angle of the contact point on gear 1's flank at each position [rad].
    pub roll_gear1: Vec<f64>,
    /// Roll angle of the contact point on gear 2's flank at each position [rad].
    pub roll_gear2: Vec<f64>,
    /// Relative slip of the two surfaces between consecutive positions [m].
    pub slip: Vec<f64>,
    /// The pair's load at each position, per planet, all slices: `pair_load[planet][r]` [N].
    pub pair_load: Vec<Vec<f64>>,
}

/// The wear of one flank (one face slice) in one cycle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlankWear {
    /// The flank.
    pub flank: Flank,
    /// Face slice.
    pub slice: usize,
    /// Grid roll angles [rad].
    pub roll: Vec<f64>,
    /// Grid arc lengths from the base circle [m].
    pub arc: Vec<f64>,
    /// Depth worn per tooth cycle at each grid point, mean over the planets [m].
    pub wear_per_cycle: Vec<f64>,
    /// Depth worn per cycle by each planet's passage: `[planet][point]` [m].
    pub wear_per_planet: Vec<Vec<f64>>,
    /// Sliding distance per passage, each planet: `[planet][point]` [m].
    pub sliding: Vec<Vec<f64>>,
    /// The band at each position, each planet: `[planet][r]`.
    pub bands: Vec<Vec<Band>>,
    /// Relative slip of the surfaces between consecutive positions [m].
    pub slip: Vec<f64>,
}

impl FlankWear {
    /// Contact pressure at each grid point at each position for `planet`:
    /// `[r][point]` [Pa].
    pub fn pressure_map(&self, planet: usize) -> Vec<Vec<f64>> {
        self.bands[planet]
            .iter()
            .map(|b| self.arc.iter().map(|x| pressure_at(&b.contact, x - b.centre)).collect())
            .collect()
    }

    /// Sliding distance of each grid point in each step for `planet`:
    /// `[r][point]` [m].
    pub fn sliding_map(&self, planet: usize) -> Vec<Vec<f64>> {
        sliding_map(&self.arc, &self.bands[planet], &self.slip)
    }

    /// Largest wear per cycle [m] and the roll angle [rad] where it sits.
    pub fn max_wear(&self) -> (f64, f64) {
        self.wear_per_cycle.iter().zip(&self.roll).fold(
            (0.0, self.roll.first().copied().unwrap_or(0.0)),
            |m, (h, xi)| if *h > m.0 { (*h, *xi) } else { m },
        )
    }
}

/// Everything one wear cycle on the current geometry gives.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CycleWear {
    /// Geometry state the cycle ran on.
    pub kappa: u32,
    /// Where the tooth-pair loads came from.
    #[serde(default)]
    pub source: PressureSource,
    /// Tooth cycles per input revolution [-].
    pub cycles_per_revolution: GearCycles,
    /// The pair's passage through each wearing mesh.
    pub meshes: Vec<MeshPassage>,
    /// Wear of each wearing flank and slice.
    pub flanks: Vec<FlankWear>,
}

impl CycleWear {
    /// The wear of `flank` in `slice`, if it wears.
    pub fn flank(&self, flank: Flank, slice: usize) -> Option<&FlankWear> {
        self.flanks.iter().find(|f| f.flank == flank && f.slice == slice)
    }

    /// The passage through `mesh`, if it wears.
    pub fn mesh(&self, mesh: MeshKind) -> Option<&MeshPassage> {
        self.meshes.iter().find(|m| m.mesh == mesh)
    }
}

/// How far one update may go at most (it never exceeds ε^κ of new wear
/// nor ε_tot of total wear).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Limit {
    /// A whole update: the largest new wear reaches ε^κ.
    Update,
    /// At most this many input revolutions [rev].
    Revolutions(f64),
}

/// When a run of updates stops (it always stops at ε_tot).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Stop {
    /// When the geometry state reaches κ.
    Kappa(u32),
    /// After this many more input revolutions [rev]; the last update is
    /// partial.
    Revolutions(f64),
    /// Only at ε_tot.
    TotalWear,
}

/// What ended an update.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UpdateEnd {
    /// The largest new wear reached ε^κ.
    UpdateDepth,
    /// A point's total wear reached ε_tot.
    TotalDepth,
    /// The given number of input revolutions ran out.
    Revolutions,
}

/// The tooth-pair loads of one wear cycle: where the pairs of a mesh are
/// first and last loaded, and each planet's pair load per face slice at
/// given positions. The whole-set quasi-static LTCA gives them
/// ([`QuasiStaticLoads`]), or a dynamic run ([`super::dynamic_wear`]); the
/// bands, sliding distances and wear follow from them in one place.
pub(crate) trait PairLoads {
    /// First and last loaded position of the pairs of `mesh` over all planets [m].
    fn engagement(&self, mesh: MeshKind) -> (f64, f64);

    /// Per-slice drive-flank loads [N] (never negative) of each planet's
    /// pair of `mesh` at each of `position` [m]: `[planet][slice][r]`.
    fn slice_loads(&self, mesh: MeshKind, position: &[f64]) -> Vec<Vec<Vec<f64>>>;
}

/// The pair loads of the whole-set quasi-static LTCA on a set's contact models.
struct QuasiStaticLoads<'a> {
    wear: &'a WearModel,
    model: &'a SetModel,
}

impl PairLoads for QuasiStaticLoads<'_> {
    fn engagement(&self, mesh: MeshKind) -> (f64, f64) {
        self.wear.engagement(self.model, mesh)
    }

    fn slice_loads(&self, mesh: MeshKind, position: &[f64]) -> Vec<Vec<Vec<f64>>> {
        self.wear.quasi_static_loads(self.model, mesh, position)
    }
}

/// The Archard wear model of a gear set.
#[derive(Clone, Debug)]
pub struct WearModel {
    set: GearSet,
    settings: WearSettings,
    cycles_per_revolution: GearCycles,
    contact_modulus: f64,
}

/// Coarse samples per base pitch when searching the first and last contact.
const ENGAGEMENT_SCAN: usize = 40;
/// Bisection steps refining the first and last contact.
const ENGAGEMENT_BISECTIONS: usize = 40;

impl WearModel {
    /// The wear model of a validated gear set with checked settings.
    pub fn new(set: &GearSet, settings: WearSettings) -> Result<Self, WearError> {
        settings.validate()?;
        let m = &set.material;
        Ok(Self {
            set: set.clone(),
            settings,
            cycles_per_revolution: cycles_per_input_revolution(set),
            contact_modulus: contact_modulus(
                m.youngs_modulus,
                m.poisson_ratio,
                m.youngs_modulus,
                m.poisson_ratio,
            ),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &WearSettings {
        &self.settings
    }

    /// The gear set.
    pub fn set(&self) -> &GearSet {
        &self.set
    }

    /// Tooth cycles per input revolution [-].
    pub fn cycles_per_revolution(&self) -> GearCycles {
        self.cycles_per_revolution
    }

    /// The unworn state (κ = 0) on the settings' grids.
    pub fn unworn(&self) -> WornState {
        WornState::unworn(&self.set, self.settings.profile_points, self.settings.face_slices)
            .with_profile_ends(self.settings.profile_ends)
    }

    /// Refuses a state of another gear set, with unusable grids or with
    /// another number of face slices.
    pub(crate) fn check(&self, state: &WornState) -> Result<(), WearError> {
        state.check_gear_set(&self.set)?;
        state.validate()?;
        let slices = state.face_slices();
        if slices != self.settings.face_slices {
            return Err(WearError::SliceCount { state: slices, settings: self.settings.face_slices });
        }
        Ok(())
    }

    /// One wear cycle on the state's geometry: each wearing flank's wear per
    /// tooth cycle on its grid, with the pressures and sliding distances,
    /// from the tooth-pair loads of the settings' source.
    pub fn cycle(&self, state: &WornState) -> Result<CycleWear, WearError> {
        self.cycle_with(state, self.settings.source)
    }

    /// One wear cycle on the state's geometry with the tooth-pair loads of
    /// `source`: the bands, sliding distances and Archard wear are the same
    /// for every source; only the pair loads per position differ.
    pub fn cycle_with(&self, state: &WornState, source: PressureSource) -> Result<CycleWear, WearError> {
        match source {
            PressureSource::QuasiStatic => {
                self.check(state)?;
                let model = state.set_model(&self.set);
                let loads = QuasiStaticLoads { wear: self, model: &model };
                Ok(self.cycle_on(state, &model, &loads, source))
            }
            PressureSource::Dynamic { speed_rpm } => {
                super::dynamic_wear::dynamic_cycle(self, state, speed_rpm).map(|(cycle, _)| cycle)
            }
        }
    }

    /// One wear cycle on `model` (the state's contact models) with the pair
    /// loads of `loads`, labelled with `source`.
    pub(crate) fn cycle_on(
        &self,
        state: &WornState,
        model: &SetModel,
        loads: &dyn PairLoads,
        source: PressureSource,
    ) -> CycleWear {
        let wearing = self.settings.wearing;
        let mut out = CycleWear {
            kappa: state.kappa,
            source,
            cycles_per_revolution: self.cycles_per_revolution,
            meshes: Vec::new(),
            flanks: Vec::new(),
        };
        for mesh in MeshKind::ALL {
            let (f1, f2) = match mesh {
                MeshKind::SunPlanet => (Flank::SunDrive, Flank::PlanetSunSide),
                MeshKind::RingPlanet => (Flank::PlanetRingSide, Flank::RingDrive),
            };
            if !wearing.contains(f1) && !wearing.contains(f2) {
                continue;
            }
            let (passage, slice_loads) = self.passage(model, mesh, loads);
            for (flank, gear1) in [(f1, true), (f2, false)] {
                if !wearing.contains(flank) {
                    continue;
                }
                for (j, dev) in state.flanks.get(flank).iter().enumerate() {
                    out.flanks.push(self.flank_wear(model, &passage, &slice_loads, flank, gear1, j, dev));
                }
            }
            out.meshes.push(passage);
        }
        out
    }

    /// Sun travel [m] at which planet `planet`'s pair of `mesh` sits at `s`.
    fn travel(model: &SetModel, set: &GearSet, mesh: MeshKind, planet: usize, s: f64) -> f64 {
        let own = set.sun.base_radius() * model.planet_angles[planet];
        match mesh {
            MeshKind::SunPlanet => s + own,
            MeshKind::RingPlanet => s - model.ring_shift + own,
        }
    }

    /// Per-slice forces [N] of planet `planet`'s pair of `mesh` at `s`, the
    /// set solved from `guess` (updated to the new equilibrium).
    fn pair_at(
        &self,
        model: &SetModel,
        mesh: MeshKind,
        planet: usize,
        s: f64,
        guess: &mut SetEquilibrium,
        forces: &mut Vec<f64>,
    ) {
        let total = self.set.mesh_load_per_planet() * model.planet_angles.len() as f64;
        let lambda = Self::travel(model, &self.set, mesh, planet, s);
        *guess = model.equilibrium(total, lambda, guess);
        let (m, delta) = match mesh {
            MeshKind::SunPlanet => (&model.sun_planet, guess.sun_mesh_approach[planet]),
            MeshKind::RingPlanet => {
                (&model.ring_planet, guess.sun_approach - guess.sun_mesh_approach[planet])
            }
        };
        m.pair_slice_forces(s, delta, forces);
        for f in forces.iter_mut() {
            // Under the drive load only the drive flanks touch; a back-flank
            // force (negative) would wear the coast flanks, which do not wear here.
            *f = f.max(0.0);
        }
    }

    /// First and last loaded position of the pairs of `mesh` over all planets [m].
    fn engagement(&self, model: &SetModel, mesh: MeshKind) -> (f64, f64) {
        let path = match mesh {
            MeshKind::SunPlanet => model.sun_planet.path(),
            MeshKind::RingPlanet => model.ring_planet.path(),
        };
        let planets = model.planet_angles.len();
        let mut guesses = vec![SetEquilibrium::unloaded(planets); planets];
        let mut forces = Vec::new();
        let loaded = |s: f64| {
            (0..planets).any(|p| {
                self.pair_at(model, mesh, p, s, &mut guesses[p], &mut forces);
                forces.iter().any(|f| *f > 0.0)
            })
        };
        let pb = path.base_pitch;
        let (lo, hi) = (path.start - pb / 2.0, path.end + pb / 2.0);
        let n = ((hi - lo) / pb * ENGAGEMENT_SCAN as f64).ceil() as usize;
        loaded_span(lo, hi, n, loaded, Refine::Steps(ENGAGEMENT_BISECTIONS)).unwrap_or((path.start, path.end))
    }

    /// The pair's passage through `mesh` and its per-slice loads
    /// `[planet][slice][r]` [N], from the pair loads of `loads`.
    fn passage(
        &self,
        model: &SetModel,
        mesh: MeshKind,
        loads: &dyn PairLoads,
    ) -> (MeshPassage, Vec<Vec<Vec<f64>>>) {
        let path = match mesh {
            MeshKind::SunPlanet => model.sun_planet.path().clone(),
            MeshKind::RingPlanet => model.ring_planet.path().clone(),
        };
        let (first, last) = loads.engagement(mesh);
        let r_steps = self.settings.positions;
        let position: Vec<f64> =
            (0..=r_steps).map(|r| first + (last - first) * r as f64 / r_steps as f64).collect();
        let rolls: Vec<(f64, f64)> = position.iter().map(|s| contact_rolls(&path, *s)).collect();
        // Arc coordinates run the same way along the common tangent for the
        // internal pair and opposite ways for the external one.
        let orientation = match path.kind {
            GearKind::External => -1.0,
            GearKind::Internal => 1.0,
        };
        let slip: Vec<f64> = rolls
            .windows(2)
            .map(|w| {
                let d1 = involute_arc(path.base_radius_1, w[1].0) - involute_arc(path.base_radius_1, w[0].0);
                let d2 = involute_arc(path.base_radius_2, w[1].1) - involute_arc(path.base_radius_2, w[0].1);
                (d1 - orientation * d2).abs()
            })
            .collect();
        let loads = loads.slice_loads(mesh, &position);
        let pair_load = loads
            .iter()
            .map(|slices| (0..position.len()).map(|r| slices.iter().map(|v| v[r]).sum()).collect())
            .collect();
        let passage = MeshPassage {
            mesh,
            roll_gear1: rolls.iter().map(|r| r.0).collect(),
            roll_gear2: rolls.iter().map(|r| r.1).collect(),
            position,
            slip,
            pair_load,
        };
        (passage, loads)
    }

    #[allow(clippy::too_many_arguments)]
    fn flank_wear(
        &self,
        model: &SetModel,
        passage: &MeshPassage,
        slice_loads: &[Vec<Vec<f64>>],
        flank: Flank,
        gear1: bool,
        slice: usize,
        dev: &ProfileDeviation,
    ) -> FlankWear {
        let m = match passage.mesh {
            MeshKind::SunPlanet => &model.sun_planet,
            MeshKind::RingPlanet => &model.ring_planet,
        };
        let path = m.path();
        let slice_width = m.face_width() / self.settings.face_slices as f64;
        let base = if gear1 { path.base_radius_1 } else { path.base_radius_2 };
        let arc: Vec<f64> = dev.roll.iter().map(|xi| involute_arc(base, *xi)).collect();
        let centres: Vec<f64> = (if gear1 { &passage.roll_gear1 } else { &passage.roll_gear2 })
            .iter()
            .map(|xi| involute_arc(base, *xi))
            .collect();
        let internal = path.kind == GearKind::Internal;
        let mut out = FlankWear {
            flank,
            slice,
            roll: dev.roll.clone(),
            arc: arc.clone(),
            wear_per_cycle: vec![0.0; arc.len()],
            wear_per_planet: Vec::new(),
            sliding: Vec::new(),
            bands: Vec::new(),
            slip: passage.slip.clone(),
        };
        for loads in slice_loads {
            let bands: Vec<Band> = passage
                .position
                .iter()
                .zip(&loads[slice])
                .zip(&centres)
                .map(|((s, f), centre)| {
                    // Curvatures at the nearest end of the involute path in
                    // corner contact, as the LTCA's Hertz figures.
                    let sc = s.clamp(path.start, path.end);
                    let contact = line_contact(
                        f / slice_width,
                        path.rho_1(sc),
                        path.rho_2(sc),
                        internal,
                        self.contact_modulus,
                    );
                    Band { centre: *centre, contact }
                })
                .collect();
            let p = passage_wear(&arc, &bands, &passage.slip, self.settings.archard_coefficient);
            out.wear_per_planet.push(p.wear);
            out.sliding.push(p.sliding);
            out.bands.push(bands);
        }
        let planets = out.wear_per_planet.len().max(1) as f64;
        for w in &out.wear_per_planet {
            for (acc, h) in out.wear_per_cycle.iter_mut().zip(w) {
                *acc += h / planets;
            }
        }
        out
    }

    /// Per-slice loads `[planet][slice][r]` [N] of each planet's pair of
    /// `mesh` at `position` [m] from the whole-set quasi-static LTCA.
    fn quasi_static_loads(&self, model: &SetModel, mesh: MeshKind, position: &[f64]) -> Vec<Vec<Vec<f64>>> {
        let planets = model.planet_angles.len();
        let mut loads = vec![Vec::new(); planets];
        let mut forces = Vec::new();
        for (p, planet_loads) in loads.iter_mut().enumerate() {
            let mut guess = SetEquilibrium::unloaded(planets);
            let mut per_slice = vec![Vec::with_capacity(position.len()); self.settings.face_slices];
            for s in position {
                self.pair_at(model, mesh, p, *s, &mut guess, &mut forces);
                for (j, f) in forces.iter().enumerate() {
                    if let Some(v) = per_slice.get_mut(j) {
                        v.push(*f);
                    }
                }
            }
            *planet_loads = per_slice;
        }
        loads
    }

    /// Applies one update to `state` from the wear of one `cycle` on it
    /// (see the module doc), limited by `limit`.
    pub fn apply(&self, state: &WornState, cycle: &CycleWear, limit: Limit) -> Result<WornState, WearError> {
        self.check(state)?;
        let cpr = self.cycles_per_revolution;
        let eps = self.settings.update_depth;
        let eps_total = self.settings.total_depth;
        let deepest = state.deepest();
        if deepest.depth >= eps_total * (1.0 - 1e-12) {
            return Err(WearError::TotalWearReached { depth: deepest.depth, limit: eps_total });
        }
        let limit_revolutions = match limit {
            Limit::Update => f64::INFINITY,
            Limit::Revolutions(r) => {
                if !(r.is_finite() && r > 0.0) {
                    return Err(WearError::InvalidLimit {
                        name: "revolutions",
                        value: r.to_string(),
                        allowed: "a finite positive number of input revolutions",
                    });
                }
                r
            }
        };
        for fw in &cycle.flanks {
            let grid = state.flanks.get(fw.flank).get(fw.slice).map(|d| &d.roll);
            if cycle.kappa != state.kappa || grid != Some(&fw.roll) {
                return Err(WearError::CycleMismatch {
                    cycle_kappa: cycle.kappa,
                    state_kappa: state.kappa,
                    flank: fw.flank.name(),
                });
            }
        }
        // Wear per input revolution at every grid point of every wearing flank.
        let mut max_rate = 0.0_f64;
        let mut limiting = cycle.flanks.first().map(|f| f.flank).unwrap_or(Flank::SunDrive);
        let mut to_total = f64::INFINITY;
        for fw in &cycle.flanks {
            let per_rev = cpr.of(fw.flank.gear());
            let current = &state.flanks.get(fw.flank)[fw.slice];
            for (h, depth) in fw.wear_per_cycle.iter().zip(&current.depth) {
                let rate = h * per_rev;
                if rate > max_rate {
                    max_rate = rate;
                    limiting = fw.flank;
                }
                if rate > 0.0 {
                    to_total = to_total.min((eps_total - depth) / rate);
                }
            }
        }
        if !(max_rate > 0.0 && max_rate.is_finite()) {
            return Err(WearError::NoWear { rate: max_rate });
        }
        let to_update = eps / max_rate;
        let (revolutions, ended_by) = [
            (to_update, UpdateEnd::UpdateDepth),
            (to_total, UpdateEnd::TotalDepth),
            (limit_revolutions, UpdateEnd::Revolutions),
        ]
        .into_iter()
        .fold((f64::INFINITY, UpdateEnd::UpdateDepth), |a, b| if b.0 < a.0 { b } else { a });
        let mut next = state.clone();
        let mut new_wear: Vec<FlankExtreme> = Vec::new();
        for fw in &cycle.flanks {
            let cycles = revolutions * cpr.of(fw.flank.gear());
            let dev = &mut next.flanks.get_mut(fw.flank)[fw.slice];
            let mut top = FlankExtreme { flank: fw.flank, slice: fw.slice, depth: 0.0, roll: fw.roll[0] };
            for ((d, h), xi) in dev.depth.iter_mut().zip(&fw.wear_per_cycle).zip(&fw.roll) {
                let added = cycles * h;
                *d += added;
                if added > top.depth {
                    top = FlankExtreme { flank: fw.flank, slice: fw.slice, depth: added, roll: *xi };
                }
            }
            match new_wear.iter_mut().find(|e| e.flank == fw.flank) {
                Some(e) if top.depth > e.depth => *e = top,
                Some(_) => {}
                None => new_wear.push(top),
            }
        }
        let cycles = cpr.scaled(revolutions);
        next.kappa += 1;
        next.revolutions += revolutions;
        next.cycles = next.cycles.plus(&cycles);
        let total_wear = Flank::ALL.iter().map(|f| next.deepest_on(*f)).collect();
        next.history.push(UpdateRecord {
            kappa: next.kappa,
            revolutions,
            cycles,
            limiting_flank: limiting,
            ended_by,
            new_wear,
            total_wear,
        });
        Ok(next)
    }

    /// One update: a wear cycle on the state's geometry, then [`Self::apply`].
    pub fn step(&self, state: &WornState, limit: Limit) -> Result<WornState, WearError> {
        self.step_with(state, limit, self.settings.source)
    }

    /// One update with the tooth-pair loads of `source`: a wear cycle on the
    /// state's geometry ([`Self::cycle_with`]), then [`Self::apply`].
    pub fn step_with(
        &self,
        state: &WornState,
        limit: Limit,
        source: PressureSource,
    ) -> Result<WornState, WearError> {
        let cycle = self.cycle_with(state, source)?;
        self.apply(state, &cycle, limit)
    }

    /// Updates until `stop` or until a point's total wear reaches ε_tot,
    /// whichever comes first (a state already there is returned as it is).
    pub fn run(&self, state: &WornState, stop: Stop) -> Result<WornState, WearError> {
        self.check(state)?;
        let start_revolutions = state.revolutions;
        let mut current = state.clone();
        loop {
            if current.deepest().depth >= self.settings.total_depth * (1.0 - 1e-12) {
                return Ok(current);
            }
            let limit = match stop {
                Stop::Kappa(k) if current.kappa >= k => return Ok(current),
                Stop::Kappa(_) | Stop::TotalWear => Limit::Update,
                Stop::Revolutions(r) => {
                    if !(r.is_finite() && r >= 0.0) {
                        return Err(WearError::InvalidLimit {
                            name: "revolutions",
                            value: r.to_string(),
                            allowed: "a finite non-negative number of input revolutions",
                        });
                    }
                    let left = start_revolutions + r - current.revolutions;
                    if left <= r * 1e-12 {
                        return Ok(current);
                    }
                    Limit::Revolutions(left)
                }
            };
            current = self.step(&current, limit)?;
        }
    }

    /// Updates until the geometry state reaches `kappa` (or ε_tot first).
    pub fn run_to_kappa(&self, state: &WornState, kappa: u32) -> Result<WornState, WearError> {
        self.run(state, Stop::Kappa(kappa))
    }
}
