//! The tooth forms of sun, planet and ring from their scene keys: sizes,
//! pressure angle, tip chamfer, tip thickness and undercut checked, and the
//! mesh's shared base pitch.

use std::f64::consts::PI;

use super::{tip_key, Checker, MIN_TIP_THICKNESS_FACTOR};
use crate::model::gear::{Chamfer, GearKind, RootForm, ToothForm};
use crate::model::gear_data::minimum_profile_shift;
use crate::scene::units::{m_to_mm, rad_to_deg};
use crate::scene::{default_chamfer, ChamferSpec, ExternalGearSpec, RingGearSpec, Scene};

/// Largest rounding radius of a chamfer's edge \[m\]: 1 mm.
const MAX_EDGE_RADIUS: f64 = 0.001;

/// The tooth forms of the three gears.
pub(super) struct Gears {
    /// The sun's tooth form.
    pub sun: ToothForm,
    /// The planets' tooth form.
    pub planet: ToothForm,
    /// The ring's tooth form.
    pub ring: ToothForm,
}

impl Checker {
    /// The tooth forms of sun, planet and ring, each checked on its own, then
    /// against the sun's base pitch (a mesh needs the same base pitch on
    /// both gears, whatever else is wrong).
    pub(super) fn gears(&mut self, scene: &Scene) -> Gears {
        let sun = self.external("sun", &scene.sun);
        let planet = self.external("planet", &scene.planet);
        let ring = self.ring(&scene.ring);
        for (key, g) in [("planet", &planet), ("ring", &ring)] {
            let (p, p0) = (g.base_pitch(), sun.base_pitch());
            if p.is_finite() && p0.is_finite() && p > 0.0 && p0 > 0.0 && (p - p0).abs() > 1e-9 {
                self.fail(
                    &format!("{key}.module_mm"),
                    m_to_mm(g.module),
                    format!(
                        "module and pressure angle must give the sun's base pitch {:.5} mm (this gives {:.5} mm)",
                        m_to_mm(p0),
                        m_to_mm(p)
                    ),
                );
            }
        }
        Gears { sun, planet, ring }
    }

    fn chamfer(&mut self, key: &str, c: &ChamferSpec, addendum: f64) -> Chamfer {
        let name_h = format!("{key}.tip_chamfer.height_mm");
        let name_a = format!("{key}.tip_chamfer.angle_deg");
        if !(c.height.is_finite() && c.height >= 0.0 && c.height < 0.5 * addendum) {
            self.fail(
                &name_h,
                m_to_mm(c.height),
                format!("must be at least 0 and below half the addendum ({:.4} mm)", m_to_mm(0.5 * addendum)),
            );
        }
        self.in_range(&name_a, rad_to_deg(c.angle), 0.0, 90.0, "angle to the tip circle's tangent");
        if !(c.edge_radius.is_finite() && c.edge_radius > 0.0 && c.edge_radius <= MAX_EDGE_RADIUS) {
            self.fail(
                &format!("{key}.tip_chamfer.edge_radius_mm"),
                m_to_mm(c.edge_radius),
                "must lie above 0 and at most 1 mm (the rounding of the chamfer's edge)",
            );
        }
        Chamfer {
            height: c.height,
            angle: c.angle,
            edge_carries_load: c.edge_carries_load,
            edge_radius: c.edge_radius,
        }
    }

    fn external(&mut self, key: &str, g: &ExternalGearSpec) -> ToothForm {
        let n = |f: &str| format!("{key}.{f}");
        if g.teeth < 6 {
            self.fail(&n("teeth"), g.teeth, "must be at least 6");
        }
        let mut sizes_ok = self.positive(&n("module_mm"), m_to_mm(g.module));
        sizes_ok &= self.positive(&n("tooth_thickness_mm"), m_to_mm(g.tooth_thickness));
        sizes_ok &= self.positive(&n("tip_radius_mm"), m_to_mm(g.tip_radius));
        sizes_ok &= self.positive(&n("root_radius_mm"), m_to_mm(g.root_radius));
        sizes_ok &= self.positive(&n("bore_radius_mm"), m_to_mm(g.bore_radius));
        sizes_ok &= self.positive(&n("face_width_mm"), m_to_mm(g.face_width));
        if !(g.hob_tip_radius.is_finite() && g.hob_tip_radius >= 0.0) {
            self.fail(
                &n("hob_tip_radius_mm"),
                m_to_mm(g.hob_tip_radius),
                "must be a finite number, zero or greater",
            );
            sizes_ok = false;
        }
        let angle_ok = self.pressure_angle(key, g.pressure_angle);
        let reference = g.module * f64::from(g.teeth) / 2.0;
        let chamfer_spec = g.tip_chamfer.unwrap_or_else(|| default_chamfer(g.module));
        let chamfer = self.chamfer(key, &chamfer_spec, g.tip_radius - reference);
        let form = ToothForm {
            kind: GearKind::External,
            teeth: g.teeth,
            module: g.module,
            pressure_angle: g.pressure_angle,
            tooth_thickness: g.tooth_thickness,
            tip_radius: g.tip_radius,
            root_radius: g.root_radius,
            body_radius: g.bore_radius,
            root_form: RootForm::Hob { tip_radius: g.hob_tip_radius },
            chamfer: (chamfer.height > 0.0).then_some(chamfer),
            face_width: g.face_width,
        };
        if !(sizes_ok && angle_ok && g.teeth >= 6) {
            return form;
        }
        let rb = form.base_radius();
        if let Some(slope) = form.edge_relief().map(|e| e.slope).filter(|s| s.is_nan() || *s <= 0.0) {
            let alpha_e = (rb / form.involute_tip_radius()).clamp(-1.0, 1.0).acos().to_degrees();
            self.fail(
                &n("tip_chamfer.angle_deg"),
                rad_to_deg(chamfer_spec.angle),
                format!(
                    "must be below {:.2}° (90° less the involute's pressure angle at the chamfer's edge) \
                     when the edge carries no load: the chamfer must fall away from the involute \
                     (relief slope {slope:.3})",
                    90.0 - alpha_e
                ),
            );
        }
        if g.tip_radius <= rb {
            self.fail(
                &n("tip_radius_mm"),
                m_to_mm(g.tip_radius),
                format!(
                    "must exceed the base radius {:.4} mm, or the teeth have no involute flank",
                    m_to_mm(rb)
                ),
            );
        }
        if g.root_radius >= g.tip_radius {
            self.fail(
                &n("root_radius_mm"),
                m_to_mm(g.root_radius),
                format!("must be below the tip radius {} mm", m_to_mm(g.tip_radius)),
            );
        }
        if g.bore_radius >= g.root_radius {
            self.fail(
                &n("bore_radius_mm"),
                m_to_mm(g.bore_radius),
                format!("must be below the root radius {} mm", m_to_mm(g.root_radius)),
            );
        }
        if g.tooth_thickness >= PI * g.module {
            self.fail(
                &n("tooth_thickness_mm"),
                m_to_mm(g.tooth_thickness),
                format!("must be below the circular pitch π·m = {:.4} mm", m_to_mm(PI * g.module)),
            );
        } else if g.tip_radius > rb && form.thickness_at(form.tip_radius) <= 0.0 {
            self.fail(
                &n("tip_radius_mm"),
                m_to_mm(g.tip_radius),
                "the tooth is pointed below this tip radius: reduce the tip radius or thicken the tooth",
            );
        } else if g.tip_radius > rb {
            self.tip_thickness(key, &form);
        }
        if let RootForm::Hob { tip_radius } = form.root_form {
            let dedendum = form.reference_radius() - form.root_radius;
            if tip_radius > 0.0 && tip_radius >= dedendum {
                self.fail(
                    &n("hob_tip_radius_mm"),
                    m_to_mm(g.hob_tip_radius),
                    format!("must be below the dedendum {:.4} mm", m_to_mm(dedendum)),
                );
            } else {
                self.undercut(key, g, &form);
            }
        }
        form
    }

    /// A tooth tip thinner than [`MIN_TIP_THICKNESS_FACTOR`]·m breaks or
    /// hardens through: refused, named by the tip's key.
    fn tip_thickness(&mut self, key: &str, form: &ToothForm) {
        let sa = form.thickness_at(form.tip_radius);
        let least = MIN_TIP_THICKNESS_FACTOR * form.module;
        if sa.is_finite() && sa < least {
            let (sa, least) = (m_to_mm(sa), m_to_mm(least));
            self.fail(
                &tip_key(key),
                m_to_mm(form.tip_radius),
                format!(
                    "the tooth tip is too thin: s_a = {sa:.4} mm at the tip circle, at least {MIN_TIP_THICKNESS_FACTOR}·m = {least:.4} mm is allowed: reduce the tip radius or thicken the tooth"
                ),
            );
        }
    }

    /// Undercut of a hobbed gear: the end of the hob's straight flank, at
    /// depth v = h − ρ·(1 − sin α) below the reference line (dedendum h,
    /// hob tip radius ρ), must not pass the base circle's tangent point,
    /// r·sin α − v/sin α ≥ 0; in gear data, x ≥ x_min = h_fP* − ρ_fP*·(1 −
    /// sin α) − z·sin²α/2.
    fn undercut(&mut self, key: &str, g: &ExternalGearSpec, form: &ToothForm) {
        let RootForm::Hob { tip_radius: rho } = form.root_form else { return };
        let (r, a) = (form.reference_radius(), form.pressure_angle);
        let v = r - form.root_radius - rho * (1.0 - a.sin());
        if r * a.sin() - v / a.sin() >= -1e-12 {
            return;
        }
        match g.gear_data.filter(|d| d.root_diameter.is_none()) {
            Some(d) => {
                let x_min = minimum_profile_shift(g.teeth, d.dedendum_factor, d.tool_tip_radius_factor, a);
                self.fail(
                    &format!("{key}.gear_data.profile_shift"),
                    d.profile_shift,
                    format!(
                        "the {key} is undercut: {} teeth cut by this rack (h_fP* = {}, ρ_fP* = {}) need a profile shift of at least x_min = h_fP* − ρ_fP*·(1 − sin α) − z·sin²α/2 = {x_min:.4}",
                        g.teeth, d.dedendum_factor, d.tool_tip_radius_factor
                    ),
                );
            }
            None => {
                let least = r - r * a.sin().powi(2) - rho * (1.0 - a.sin());
                self.fail(
                    &format!("{key}.root_radius_mm"),
                    m_to_mm(g.root_radius),
                    format!(
                        "the {key} is undercut: with {} teeth and hob tip radius {} mm the root radius must be at least r − r·sin²α − ρ·(1 − sin α) = {:.4} mm",
                        g.teeth,
                        m_to_mm(g.hob_tip_radius),
                        m_to_mm(least)
                    ),
                );
            }
        }
    }

    fn ring(&mut self, g: &RingGearSpec) -> ToothForm {
        let n = |f: &str| format!("ring.{f}");
        if g.teeth < 12 {
            self.fail(&n("teeth"), g.teeth, "must be at least 12");
        }
        let mut ok = self.positive(&n("module_mm"), m_to_mm(g.module));
        ok &= self.positive(&n("tooth_thickness_mm"), m_to_mm(g.tooth_thickness));
        ok &= self.positive(&n("minor_radius_mm"), m_to_mm(g.minor_radius));
        ok &= self.positive(&n("root_radius_mm"), m_to_mm(g.root_radius));
        ok &= self.positive(&n("rim_radius_mm"), m_to_mm(g.rim_radius));
        ok &= self.positive(&n("fillet_radius_mm"), m_to_mm(g.fillet_radius));
        ok &= self.positive(&n("face_width_mm"), m_to_mm(g.face_width));
        ok &= self.pressure_angle("ring", g.pressure_angle);
        let reference = g.module * f64::from(g.teeth) / 2.0;
        let chamfer = g.tip_chamfer.map(|c| self.chamfer("ring", &c, reference - g.minor_radius));
        let form = ToothForm {
            kind: GearKind::Internal,
            teeth: g.teeth,
            module: g.module,
            pressure_angle: g.pressure_angle,
            tooth_thickness: g.tooth_thickness,
            tip_radius: g.minor_radius,
            root_radius: g.root_radius,
            body_radius: g.rim_radius,
            root_form: RootForm::Fillet { radius: g.fillet_radius },
            chamfer: chamfer.filter(|c| c.height > 0.0),
            face_width: g.face_width,
        };
        if !(ok && g.teeth >= 12) {
            return form;
        }
        let rb = form.base_radius();
        if g.minor_radius <= rb {
            self.fail(
                &n("minor_radius_mm"),
                m_to_mm(g.minor_radius),
                format!(
                    "must exceed the ring's base radius {:.4} mm, or its teeth have no involute flank",
                    m_to_mm(rb)
                ),
            );
        }
        if g.root_radius <= g.minor_radius {
            self.fail(
                &n("root_radius_mm"),
                m_to_mm(g.root_radius),
                format!("must exceed the minor radius {} mm", m_to_mm(g.minor_radius)),
            );
        }
        if g.rim_radius <= g.root_radius {
            self.fail(
                &n("rim_radius_mm"),
                m_to_mm(g.rim_radius),
                format!("must exceed the root radius {} mm", m_to_mm(g.root_radius)),
            );
        }
        if g.tooth_thickness >= PI * g.module {
            self.fail(
                &n("tooth_thickness_mm"),
                m_to_mm(g.tooth_thickness),
                format!("must be below the circular pitch π·m = {:.4} mm", m_to_mm(PI * g.module)),
            );
        }
        if g.minor_radius > rb && g.tooth_thickness < PI * g.module {
            self.tip_thickness("ring", &form);
        }
        if g.fillet_radius >= 0.5 * (g.root_radius - g.minor_radius) {
            self.fail(
                &n("fillet_radius_mm"),
                m_to_mm(g.fillet_radius),
                format!(
                    "must be below half the tooth depth, {:.4} mm",
                    m_to_mm(0.5 * (g.root_radius - g.minor_radius))
                ),
            );
        }
        form
    }
}
