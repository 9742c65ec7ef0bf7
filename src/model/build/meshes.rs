//! The rules of the two meshes on the built gear set: the centre distance
//! both can reach, then per mesh its backlash, contact ratio, involute and
//! trochoid interference, tip/root interference and root clearance.

use super::{tip_key, Checker};
use crate::model::gear::{GearKind, GearSet, MeshKind, ToothForm};
use crate::model::gear_data::trochoid_margin;
use crate::model::mesh::PathOfContact;
use crate::scene::units::m_to_mm;

impl Checker {
    /// The centre distance must exceed what either mesh needs: the sum of
    /// sun and planet base radii, the ring's base radius less the planet's.
    pub(super) fn centre_distance(&mut self, set: &GearSet) {
        let a = set.centre_distance;
        let ext = set.sun.base_radius() + set.planet.base_radius();
        let int = set.ring.base_radius() - set.planet.base_radius();
        if a <= ext {
            self.fail(
                "centre_distance_mm",
                m_to_mm(a),
                format!("must exceed the sum of sun and planet base radii, {:.4} mm", m_to_mm(ext)),
            );
        }
        if a <= int {
            self.fail(
                "centre_distance_mm",
                m_to_mm(a),
                format!("must exceed the ring base radius less the planet's, {:.4} mm", m_to_mm(int)),
            );
        }
    }

    /// Every rule of one mesh of the set, in the order the problems are listed.
    pub(super) fn mesh(&mut self, set: &GearSet, mesh: MeshKind) {
        let (g1, g2) = set.mesh_gears(mesh);
        let (k1, k2) = match mesh {
            MeshKind::SunPlanet => ("sun", "planet"),
            MeshKind::RingPlanet => ("planet", "ring"),
        };
        let m = MeshRules { mesh, path: PathOfContact::new(set, mesh), g1, g2, k1, k2 };
        m.backlash(set, self);
        m.contact_ratio(self);
        m.involute_interference(self);
        m.trochoid_interference(set, self);
        m.tip_root_interference(self);
        m.root_clearance(self);
    }
}

/// One mesh under check: its path of contact, its gears (gear 1 the sun or
/// the planet, gear 2 its mate) and their scene keys.
struct MeshRules<'a> {
    mesh: MeshKind,
    path: PathOfContact,
    g1: &'a ToothForm,
    g2: &'a ToothForm,
    k1: &'a str,
    k2: &'a str,
}

impl MeshRules<'_> {
    /// The circumferential backlash at the operating pitch circle is not negative.
    fn backlash(&self, set: &GearSet, c: &mut Checker) {
        let (mesh, k1, k2) = (self.mesh, self.k1, self.k2);
        let j = set.circumferential_backlash(mesh);
        if j < 0.0 {
            c.fail(
                &format!("{k1}.tooth_thickness_mm"),
                format!("{} (with {k2})", self.g1.tooth_thickness * 1e3),
                format!(
                    "the {} mesh has negative backlash ({:.4} mm at the operating pitch circle): thin the teeth of {k1} or {k2} or increase centre_distance_mm",
                    mesh.name(),
                    j * 1e3
                ),
            );
        }
    }

    /// The nominal contact ratio is at least 1.
    fn contact_ratio(&self, c: &mut Checker) {
        let eps = self.path.nominal_contact_ratio();
        if eps < 1.0 {
            c.fail(
                &format!("{}.tip_radius_mm", self.k1),
                format!("{} (contact ratio {eps:.4})", self.path.gear1_tip_radius_mm()),
                format!(
                    "the {} mesh's contact ratio must be at least 1: lengthen the teeth",
                    self.mesh.name()
                ),
            );
        }
    }

    /// Involute interference: the mate's tip must not carry the contact past
    /// the base circle's tangent point of either gear (the start of the
    /// involute), where the flanks would cut each other.
    fn involute_interference(&self, c: &mut Checker) {
        let (path, g1, g2, k1, k2) = (&self.path, self.g1, self.g2, self.k1, self.k2);
        if path.start_sharp < 0.0 {
            c.fail(
                &tip_key(k2),
                g2.tip_radius * 1e3,
                format!(
                    "involute interference in the {} mesh: the {k2} tip reaches {:.4} mm past the {k1}'s \
                     base-circle tangent point (usable limit: the {k1} base circle, radius {:.4} mm); \
                     {}",
                    self.mesh.name(),
                    -path.start_sharp * 1e3,
                    g1.base_radius() * 1e3,
                    if g2.kind == GearKind::Internal {
                        "raise the ring's minor radius or its profile shift"
                    } else {
                        "shorten that tip or shift the mate's profile positively"
                    }
                ),
            );
        }
        if g2.kind == GearKind::External && path.end_sharp > path.tangency_distance {
            c.fail(
                &tip_key(k1),
                g1.tip_radius * 1e3,
                format!(
                    "involute interference in the {} mesh: the {k1} tip reaches {:.4} mm past the {k2}'s \
                     base-circle tangent point (usable limit: the {k2} base circle, radius {:.4} mm)",
                    self.mesh.name(),
                    (path.end_sharp - path.tangency_distance) * 1e3,
                    g2.base_radius() * 1e3
                ),
            );
        }
    }

    /// Tip (trochoid) interference of an internal mesh: the planet tip's
    /// path must not cut the ring teeth as it leaves mesh.
    fn trochoid_interference(&self, set: &GearSet, c: &mut Checker) {
        let (g1, g2) = (self.g1, self.g2);
        if g2.kind != GearKind::Internal {
            return;
        }
        let Some(margin) = trochoid_margin(g1, g2, set.centre_distance) else { return };
        if margin < 0.0 {
            c.fail(
                &tip_key(self.k1),
                g1.tip_radius * 1e3,
                format!(
                    "tip (trochoid) interference in the ring–planet mesh: the planet tip's path \
                     cuts the ring teeth as it leaves mesh (θ₁·z_p/z_r + inv α_w − inv α_a,ring − θ₂ \
                     = {margin:.5} rad, must be ≥ 0): more teeth difference z_ring − z_planet \
                     (now {}; the handbooks' rule for unshifted 20° gears: more than 9) or other tip \
                     diameters and profile shifts",
                    g2.teeth - g1.teeth.min(g2.teeth)
                ),
            );
        }
    }

    /// Tip/root interference: each gear's start of active profile must lie
    /// on its involute, above the form circle where the fillet begins.
    fn tip_root_interference(&self, c: &mut Checker) {
        let (g1, g2, k1, k2) = (self.g1, self.g2, self.k1, self.k2);
        let (r1, r2) = self.path.active_profile_start_radii();
        let f1 = g1.form_radius();
        let f2 = g2.form_radius();
        let interferes1 = r1 < f1;
        let interferes2 = match g2.kind {
            GearKind::External => r2 < f2,
            GearKind::Internal => r2 > f2,
        };
        if interferes1 {
            c.fail(
                &tip_key(k2),
                g2.tip_radius * 1e3,
                format!(
                    "tip/root interference in the {} mesh: the {k2} tip reaches {k1} radius {:.4} mm, below its form radius {:.4} mm where the fillet begins",
                    self.mesh.name(), r1 * 1e3, f1 * 1e3
                ),
            );
        }
        if interferes2 {
            c.fail(
                &tip_key(k1),
                g1.tip_radius * 1e3,
                format!(
                    "tip/root interference in the {} mesh: the {k1} tip reaches {k2} radius {:.4} mm, beyond its form radius {:.4} mm where the fillet begins",
                    self.mesh.name(), r2 * 1e3, f2 * 1e3
                ),
            );
        }
    }

    /// Root clearance: the mating tip circle must not reach the root circle.
    fn root_clearance(&self, c: &mut Checker) {
        for (clearance, tip_gear, root_key) in self.path.root_clearances() {
            if clearance <= 0.0 {
                c.fail(
                    &tip_key(tip_gear),
                    format!("clearance {:.4} mm", clearance * 1e3),
                    format!(
                        "the {tip_gear} tip circle must clear the {root_key} root circle in the {} mesh",
                        self.mesh.name()
                    ),
                );
            }
        }
    }
}
