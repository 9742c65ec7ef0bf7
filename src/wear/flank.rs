//! The flanks of the set and what locates a point on them: the gears and
//! their six physical flanks, tooth cycles per input revolution, the roll
//! angles of a contact point and the active profile, and what ended an
//! update. The vocabulary the worn-profile state and the wear law share.

use crate::model::gear::{GearKind, GearSet, Member, MeshKind};
use crate::model::involute::roll_angle;
use crate::model::mesh::PathOfContact;
use serde::{Deserialize, Serialize};

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
    let (zs, zp, zr) =
        (f64::from(set.sun().teeth), f64::from(set.planet().teeth), f64::from(set.ring().teeth));
    let n = set.planet_angles().len() as f64;
    // Speed of a member as a linear form in (carrier speed c, relative sun speed u).
    let form = |m: Member| match m {
        Member::Sun => (1.0, 1.0),
        Member::Ring => (1.0, -zs / zr),
        Member::Carrier => (1.0, 0.0),
    };
    let (h, i) = (form(set.held()), form(set.input()));
    // h·(c, u) = 0, i·(c, u) = 1.
    let det = h.0 * i.1 - h.1 * i.0;
    let u = if det == 0.0 { 1.0 } else { h.0 / det };
    let mesh_cycles = zs * u.abs();
    GearCycles { sun: n * mesh_cycles / zs, planet: mesh_cycles / zp, ring: n * mesh_cycles / zr }
}
/// Roll angles \[rad\] of the contact point on gear 1's and on gear 2's flank
/// when the pair's drive-flank position is `s` \[m\].
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
/// Arc length \[m\] along an involute of base radius `base_radius` \[m\] from
/// the base circle to roll angle `roll` \[rad\]: σ = r_b ξ²/2.
pub fn involute_arc(base_radius: f64, roll: f64) -> f64 {
    0.5 * base_radius * roll * roll
}
/// Roll-angle range \[rad\] of a flank's active profile on the unloaded path
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
