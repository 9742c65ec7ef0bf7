//! Kinematics of one mesh along its line of action (LOA).
//!
//! Positions `s` on the LOA are measured from the point T1 where the LOA
//! touches the base circle of gear 1, in the direction the contact travels
//! when gear 1 drives (docs/FORMULAS.md). With `L = a sin α_w` the distance T1T2:
//! external pair ρ1 = s, ρ2 = L − s; internal pair (planet 1, ring 2)
//! ρ1 = s, ρ2 = s + L. The roll angle of gear i at the contact is ρi / r_bi.

use serde::{Deserialize, Serialize};

use crate::model::gear::{GearKind, GearSet, MeshKind, ToothForm};

/// The path of contact of one mesh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PathOfContact {
    /// Which mesh.
    pub mesh: MeshKind,
    /// External or internal (the kind of gear 2).
    pub kind: GearKind,
    /// Base radius of gear 1 \[m\].
    pub base_radius_1: f64,
    /// Base radius of gear 2 \[m\].
    pub base_radius_2: f64,
    /// Centre distance \[m\].
    pub centre_distance: f64,
    /// Operating pressure angle \[rad\].
    pub pressure_angle: f64,
    /// Distance between the base-circle tangency points, a·sin α_w \[m\].
    pub tangency_distance: f64,
    /// Base pitch \[m\].
    pub base_pitch: f64,
    /// Start of contact with sharp tips \[m\].
    pub start_sharp: f64,
    /// End of contact with sharp tips \[m\].
    pub end_sharp: f64,
    /// Start of contact on the involutes, chamfers excluded \[m\].
    pub start: f64,
    /// End of contact on the involutes, chamfers excluded \[m\].
    pub end: f64,
    tip_1: f64,
    root_1: f64,
    tip_2: f64,
    root_2: f64,
}

fn along(r: f64, rb: f64) -> f64 {
    (r * r - rb * rb).max(0.0).sqrt()
}

impl PathOfContact {
    /// The path of contact of a mesh of a validated gear set.
    pub fn new(set: &GearSet, mesh: MeshKind) -> Self {
        let (g1, g2) = set.mesh_gears(mesh);
        Self::between(g1, g2, set.centre_distance, mesh)
    }

    /// The path of contact of two tooth forms at a centre distance.
    pub fn between(g1: &ToothForm, g2: &ToothForm, centre_distance: f64, mesh: MeshKind) -> Self {
        let (rb1, rb2) = (g1.base_radius(), g2.base_radius());
        let sum = match g2.kind {
            GearKind::External => rb1 + rb2,
            GearKind::Internal => rb2 - rb1,
        };
        let aw = (sum / centre_distance).clamp(-1.0, 1.0).acos();
        let l = centre_distance * aw.sin();
        let ends = |tip1: f64, tip2: f64| match g2.kind {
            GearKind::External => (l - along(tip2, rb2), along(tip1, rb1)),
            GearKind::Internal => (along(tip2, rb2) - l, along(tip1, rb1)),
        };
        let (start_sharp, end_sharp) = ends(g1.tip_radius, g2.tip_radius);
        let (start, end) = ends(g1.involute_tip_radius(), g2.involute_tip_radius());
        Self {
            mesh,
            kind: g2.kind,
            base_radius_1: rb1,
            base_radius_2: rb2,
            centre_distance,
            pressure_angle: aw,
            tangency_distance: l,
            base_pitch: g1.base_pitch(),
            start_sharp,
            end_sharp,
            start,
            end,
            tip_1: g1.tip_radius,
            root_1: g1.root_radius,
            tip_2: g2.tip_radius,
            root_2: g2.root_radius,
        }
    }

    /// Contact ratio with sharp tips, (end − start) / p_b.
    pub fn nominal_contact_ratio(&self) -> f64 {
        (self.end_sharp - self.start_sharp) / self.base_pitch
    }

    /// Contact ratio on the involutes only (tip chamfers excluded).
    pub fn involute_contact_ratio(&self) -> f64 {
        (self.end - self.start) / self.base_pitch
    }

    /// Position of the pitch point, r_b1·tan α_w \[m\].
    pub fn pitch_point(&self) -> f64 {
        self.base_radius_1 * self.pressure_angle.tan()
    }

    /// Radius of curvature of gear 1's flank at position `s` \[m\].
    pub fn rho_1(&self, s: f64) -> f64 {
        s
    }

    /// Radius of curvature of gear 2's flank at position `s` \[m\] (positive;
    /// the ring flank is concave).
    pub fn rho_2(&self, s: f64) -> f64 {
        match self.kind {
            GearKind::External => self.tangency_distance - s,
            GearKind::Internal => self.tangency_distance + s,
        }
    }

    /// Roll angle of gear 1 at position `s` \[rad\].
    pub fn roll_1(&self, s: f64) -> f64 {
        self.rho_1(s) / self.base_radius_1
    }

    /// Roll angle of gear 2 at position `s` \[rad\].
    pub fn roll_2(&self, s: f64) -> f64 {
        self.rho_2(s) / self.base_radius_2
    }

    /// Radius of gear 1's contact point at `s` \[m\].
    pub fn radius_1(&self, s: f64) -> f64 {
        (self.base_radius_1.powi(2) + self.rho_1(s).powi(2)).sqrt()
    }

    /// Radius of gear 2's contact point at `s` \[m\].
    pub fn radius_2(&self, s: f64) -> f64 {
        (self.base_radius_2.powi(2) + self.rho_2(s).powi(2)).sqrt()
    }

    /// Radii \[m\] of the start of active profile of gear 1 (at the start of
    /// contact) and of gear 2 (at the end of contact), sharp tips.
    pub fn active_profile_start_radii(&self) -> (f64, f64) {
        (self.radius_1(self.start_sharp), self.radius_2(self.end_sharp))
    }

    /// Radial clearance \[m\] between each tip circle and the mating root
    /// circle, with the name of the tip's gear and the root's gear.
    pub fn root_clearances(&self) -> [(f64, &'static str, &'static str); 2] {
        let a = self.centre_distance;
        match self.mesh {
            MeshKind::SunPlanet => [
                (a - self.tip_1 - self.root_2, "sun", "planet"),
                (a - self.tip_2 - self.root_1, "planet", "sun"),
            ],
            MeshKind::RingPlanet => [
                (self.root_2 - (a + self.tip_1), "planet", "ring"),
                (self.tip_2 - (a + self.root_1), "ring", "planet"),
            ],
        }
    }

    /// Ratio of the rolling (surface) velocities v2 / v1 at position `s`,
    /// relative to the carrier: v_i = ω_i ρ_i with ω1 r_b1 = ω2 r_b2.
    pub fn rolling_velocity_ratio(&self, s: f64) -> f64 {
        (self.rho_2(s) / self.base_radius_2) / (self.rho_1(s) / self.base_radius_1)
    }

    /// Name of gear 1 and gear 2.
    pub fn gear_names(&self) -> (&'static str, &'static str) {
        match self.mesh {
            MeshKind::SunPlanet => ("sun", "planet"),
            MeshKind::RingPlanet => ("planet", "ring"),
        }
    }

    /// Gear-1 tip radius in mm (for messages).
    pub fn gear1_tip_radius_mm(&self) -> f64 {
        self.tip_1 * 1e3
    }
}
