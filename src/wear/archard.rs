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
//! the whole-set quasi-static LTCA ([`SetModel::equilibrium`](crate::contact::ltca::SetModel::equilibrium)) is solved with
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
//! model at an input speed ([`crate::wear::dynamic`]). Everything after the
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

use crate::contact::hertz::{pressure_at, LineContact};
use crate::geometry::profile::ProfileEnds;
use crate::model::gear::{GearSet, MeshKind};
use crate::scene::units::rad_per_s_to_rpm;
use crate::wear::flank::{Flank, GearCycles};
use crate::wear::state::WornStateError;
use serde::{Deserialize, Serialize};

/// Archard wear coefficient of the example [m²/N] (docs/MODEL.md §4).
pub const EXAMPLE_ARCHARD_COEFFICIENT: f64 = 1e-18;
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
    /// Largest new wear of one update, ε^κ \[m\].
    pub update_depth: f64,
    /// Total wear of any point at which the wear stepper stops, ε_tot \[m\].
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
    /// window's mesh cycles ([`crate::wear::dynamic`]).
    Dynamic {
        /// Input speed [rad/s] (written in rpm, as `speed_rpm`).
        #[serde(rename = "speed_rpm", with = "crate::scene::units::rpm")]
        speed: f64,
    },
}
impl PressureSource {
    /// Checks the source; a speed that cannot be run is named.
    pub fn validate(&self) -> Result<(), WearError> {
        match *self {
            PressureSource::QuasiStatic => Ok(()),
            PressureSource::Dynamic { speed } if speed.is_finite() && speed > 0.0 => Ok(()),
            PressureSource::Dynamic { speed } => Err(WearError::InvalidSetting {
                name: "source.speed_rpm",
                value: format!("{} rpm", rad_per_s_to_rpm(speed)),
                allowed: "a finite positive input speed",
            }),
        }
    }

    /// A short description for messages and reports.
    pub fn describe(&self) -> String {
        match self {
            PressureSource::QuasiStatic => "quasi-static".into(),
            PressureSource::Dynamic { speed } => format!("dynamic at {} rpm", rad_per_s_to_rpm(*speed)),
        }
    }
}
impl WearSettings {
    /// The defaults with the scene's profile grid points and face slices
    /// (`analysis.profile_points`, `analysis.face_slices`).
    pub fn for_set(set: &GearSet) -> Self {
        Self {
            profile_points: set.analysis().profile_points,
            face_slices: set.analysis().face_slices,
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
    /// The deformable contact law could not be built or solved for the state.
    #[error("deformable contact: {0}")]
    Contact(String),
    /// No wearing flank wears: nothing carries load or nothing slides.
    #[error("no wearing flank wears in a cycle (largest wear per revolution {rate:e} m): check input_torque and the wearing flanks")]
    NoWear {
        /// Largest wear per input revolution \[m\].
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
    #[error("dynamic tooth loads at {} rpm: {reason}", rad_per_s_to_rpm(*.speed))]
    DynamicRun {
        /// Input speed [rad/s].
        speed: f64,
        /// What failed (the dynamic model's or the integrator's error).
        reason: String,
    },
    /// The total wear limit lies deeper than a state of this gear set may
    /// be (the reader would refuse the states it leads to).
    #[error(
        "total_depth = {total:e} m is deeper than the {gear}'s flanks may wear: at most {limit:e} m, a quarter of its {basis}"
    )]
    TotalDepthImplausible {
        /// The setting \[m\].
        total: f64,
        /// The largest plausible depth of the wearing gear \[m\].
        limit: f64,
        /// The gear that sets the limit.
        gear: &'static str,
        /// What the limit is a fraction of.
        basis: String,
    },
    /// A dynamic source asked of a wear model made without run settings.
    #[error("the dynamic tooth loads need run settings: make the wear model with WearModel::with_run")]
    NoRunSettings,
    /// The total wear limit is already reached.
    #[error("the deepest wear {depth:e} m already reaches total_depth = {limit:e} m: no further update")]
    TotalWearReached {
        /// Deepest wear of the state \[m\].
        depth: f64,
        /// The limit \[m\].
        limit: f64,
    },
}
/// The Hertzian band on one flank at one pair position.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// Arc length along the flank from its base circle to the band's centre \[m\].
    pub centre: f64,
    /// The line contact: half-width \[m\] and peak pressure \[Pa\].
    pub contact: LineContact,
}
/// What one passage does to the points of a flank.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Passage {
    /// Depth worn at each point \[m\].
    pub wear: Vec<f64>,
    /// Sliding distance of each point: how far the mating surface slid past
    /// it while it was inside the band \[m\].
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
/// Sliding distance \[m\] of each point (arc positions `arc` \[m\]) in each
/// step: `slip[r]` (the relative displacement of the surfaces between band
/// positions r and r + 1 \[m\]) times the fraction of the step the point is
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
/// `arc` \[m\] through one passage of the band (`bands`, one per pair
/// position, `slip` between consecutive ones \[m\]) with Archard coefficient
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
    /// Pair positions s_0..s_R on the line of action, first to last contact \[m\].
    pub position: Vec<f64>,
    /// Roll angle of the contact point on gear 1's flank at each position \[rad\].
    pub roll_gear1: Vec<f64>,
    /// Roll angle of the contact point on gear 2's flank at each position \[rad\].
    pub roll_gear2: Vec<f64>,
    /// Relative slip of the two surfaces between consecutive positions \[m\].
    pub slip: Vec<f64>,
    /// The pair's load at each position, per planet, all slices: `pair_load[planet][r]` \[N\].
    pub pair_load: Vec<Vec<f64>>,
}
/// The wear of one flank (one face slice) in one cycle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlankWear {
    /// The flank.
    pub flank: Flank,
    /// Face slice.
    pub slice: usize,
    /// Grid roll angles \[rad\].
    pub roll: Vec<f64>,
    /// Grid arc lengths from the base circle \[m\].
    pub arc: Vec<f64>,
    /// Depth worn per tooth cycle at each grid point, mean over the planets \[m\].
    pub wear_per_cycle: Vec<f64>,
    /// Depth worn per cycle by each planet's passage: `[planet][point]` \[m\].
    pub wear_per_planet: Vec<Vec<f64>>,
    /// Sliding distance per passage, each planet: `[planet][point]` \[m\].
    pub sliding: Vec<Vec<f64>>,
    /// The band at each position, each planet: `[planet][r]`.
    pub bands: Vec<Vec<Band>>,
    /// Relative slip of the surfaces between consecutive positions \[m\].
    pub slip: Vec<f64>,
}
impl FlankWear {
    /// Contact pressure at each grid point at each position for `planet`:
    /// `[r][point]` \[Pa\].
    pub fn pressure_map(&self, planet: usize) -> Vec<Vec<f64>> {
        self.bands[planet]
            .iter()
            .map(|b| self.arc.iter().map(|x| pressure_at(&b.contact, x - b.centre)).collect())
            .collect()
    }

    /// Sliding distance of each grid point in each step for `planet`:
    /// `[r][point]` \[m\].
    pub fn sliding_map(&self, planet: usize) -> Vec<Vec<f64>> {
        sliding_map(&self.arc, &self.bands[planet], &self.slip)
    }

    /// Largest wear per cycle \[m\] and the roll angle \[rad\] where it sits.
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
    /// At most this many input revolutions \[rev\].
    Revolutions(f64),
}
/// When a run of updates stops (it always stops at ε_tot).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Stop {
    /// When the geometry state reaches κ.
    Kappa(u32),
    /// After this many more input revolutions \[rev\]; the last update is
    /// partial.
    Revolutions(f64),
    /// Only at ε_tot.
    TotalWear,
}
/// The tooth-pair loads of one wear cycle: where the pairs of a mesh are
/// first and last loaded, and each planet's pair load per face slice at
/// given positions. The whole-set quasi-static LTCA gives them
/// (the quasi-static loads of [`crate::wear::stepper`]), or a dynamic run ([`crate::wear::dynamic`]); the
/// bands, sliding distances and wear follow from them in one place.
pub(crate) trait PairLoads {
    /// First and last loaded position of the pairs of `mesh` over all planets \[m\].
    fn engagement(&self, mesh: MeshKind) -> (f64, f64);

    /// Per-slice drive-flank loads \[N\] (never negative) of each planet's
    /// pair of `mesh` at each of `position` \[m\]: `[planet][slice][r]`.
    fn slice_loads(&self, mesh: MeshKind, position: &[f64]) -> Vec<Vec<Vec<f64>>>;
}
