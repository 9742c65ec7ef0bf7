//! The model built from a scene: every rule of the scene checked at once,
//! every problem named by the user's key (`sun.tip_radius_mm`), and the
//! values converted to SI. A [`GearSet`] exists only through
//! [`Scene::validate`] (or [`Scene::validate_with_run`]), so holding one means
//! it passed every rule; a [`RunSettings`] only through the same validation
//! or [`RunSettings::new`], which checks it by the same rules.

use std::f64::consts::PI;
use std::fmt;

use crate::model::gear::{
    Analysis, Bodies, Body, Chamfer, GearKind, GearSet, Material, MeshKind, RootForm, Supports, ToothForm,
};
use crate::model::gear::{ContactModel, Damping, Drive, Member};
use crate::model::gear_data::{minimum_profile_shift, name_by_gear_data, trochoid_margin};
use crate::model::mesh::PathOfContact;
use crate::model::run::{RunSettings, RunValues, SteadyValues};
use crate::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use crate::scene::{
    default_chamfer, ChamferSpec, DampingModel, ExternalGearSpec, Problem, RingGearSpec, Scene, SceneError,
};

impl Scene {
    /// Checks every rule and converts to SI: the gear set. The run settings
    /// are checked too (a scene is valid only with all its keys), but not
    /// returned; [`Scene::validate_with_run`] returns both.
    pub fn validate(&self) -> Result<GearSet, SceneError> {
        validate(self).map(|(set, _)| set)
    }

    /// Checks every rule and converts to SI: the gear set and the scene's run
    /// settings, every problem of either listed at once.
    pub fn validate_with_run(&self) -> Result<(GearSet, RunSettings), SceneError> {
        validate(self)
    }

    /// The scene with its derived defaults written out: the tip chamfers of
    /// sun and planet and every mass and moment of inertia, so that each of
    /// them has a key with a value (to edit, or to fit with `calibrate`).
    pub fn explicit(&self) -> Result<Self, SceneError> {
        let set = self.validate()?;
        let mut s = self.clone();
        for g in [&mut s.sun, &mut s.planet] {
            if g.tip_chamfer.is_none() {
                g.tip_chamfer = Some(default_chamfer(g.module_mm));
            }
        }
        let b = &set.bodies;
        let i = &mut s.inertia;
        i.sun_mass_kg = Some(b.sun.mass);
        i.sun_inertia_kg_m2 = Some(b.sun.inertia);
        i.planet_mass_kg = Some(b.planet.mass);
        i.planet_inertia_kg_m2 = Some(b.planet.inertia);
        i.ring_mass_kg = Some(b.ring.mass);
        i.ring_inertia_kg_m2 = Some(b.ring.inertia);
        i.carrier_mass_kg = Some(b.carrier.mass);
        i.carrier_inertia_kg_m2 = Some(b.carrier.inertia);
        Ok(s)
    }
}

struct Checker {
    problems: Vec<Problem>,
}

impl Checker {
    fn fail(&mut self, name: &str, value: impl fmt::Display, reason: impl Into<String>) {
        self.problems.push(Problem { name: name.into(), value: value.to_string(), reason: reason.into() });
    }

    fn positive(&mut self, name: &str, v: f64) -> bool {
        if !(v.is_finite() && v > 0.0) {
            self.fail(name, v, "must be a finite number greater than zero");
            false
        } else {
            true
        }
    }

    fn in_range(&mut self, name: &str, v: f64, lo: f64, hi: f64, why: &str) -> bool {
        if !(v.is_finite() && v > lo && v < hi) {
            self.fail(name, v, format!("must lie strictly between {lo} and {hi} ({why})"));
            false
        } else {
            true
        }
    }

    fn chamfer(&mut self, key: &str, c: &ChamferSpec, addendum_mm: f64) -> Chamfer {
        let name_h = format!("{key}.tip_chamfer.height_mm");
        let name_a = format!("{key}.tip_chamfer.angle_deg");
        if !(c.height_mm.is_finite() && c.height_mm >= 0.0 && c.height_mm < 0.5 * addendum_mm) {
            self.fail(
                &name_h,
                c.height_mm,
                format!("must be at least 0 and below half the addendum ({:.4} mm)", 0.5 * addendum_mm),
            );
        }
        self.in_range(&name_a, c.angle_deg, 0.0, 90.0, "angle to the tip circle's tangent");
        if !(c.edge_radius_mm.is_finite() && c.edge_radius_mm > 0.0 && c.edge_radius_mm <= 1.0) {
            self.fail(
                &format!("{key}.tip_chamfer.edge_radius_mm"),
                c.edge_radius_mm,
                "must lie above 0 and at most 1 mm (the rounding of the chamfer's edge)",
            );
        }
        Chamfer {
            height: c.height_mm * 1e-3,
            angle: c.angle_deg.to_radians(),
            edge_carries_load: c.edge_carries_load,
            edge_radius: c.edge_radius_mm * 1e-3,
        }
    }

    fn external(&mut self, key: &str, g: &ExternalGearSpec) -> ToothForm {
        let n = |f: &str| format!("{key}.{f}");
        if g.teeth < 6 {
            self.fail(&n("teeth"), g.teeth, "must be at least 6");
        }
        let mut sizes_ok = self.positive(&n("module_mm"), g.module_mm);
        sizes_ok &= self.positive(&n("tooth_thickness_mm"), g.tooth_thickness_mm);
        sizes_ok &= self.positive(&n("tip_radius_mm"), g.tip_radius_mm);
        sizes_ok &= self.positive(&n("root_radius_mm"), g.root_radius_mm);
        sizes_ok &= self.positive(&n("bore_radius_mm"), g.bore_radius_mm);
        sizes_ok &= self.positive(&n("face_width_mm"), g.face_width_mm);
        if !(g.hob_tip_radius_mm.is_finite() && g.hob_tip_radius_mm >= 0.0) {
            self.fail(
                &n("hob_tip_radius_mm"),
                g.hob_tip_radius_mm,
                "must be a finite number, zero or greater",
            );
            sizes_ok = false;
        }
        let angle_ok =
            self.in_range(&n("pressure_angle_deg"), g.pressure_angle_deg, 10.0, 35.0, "spur gear practice");
        let reference = g.module_mm * f64::from(g.teeth) / 2.0;
        let chamfer_spec = g.tip_chamfer.unwrap_or_else(|| default_chamfer(g.module_mm));
        let chamfer = self.chamfer(key, &chamfer_spec, g.tip_radius_mm - reference);
        let form = ToothForm {
            kind: GearKind::External,
            teeth: g.teeth,
            module: g.module_mm * 1e-3,
            pressure_angle: g.pressure_angle_deg.to_radians(),
            tooth_thickness: g.tooth_thickness_mm * 1e-3,
            tip_radius: g.tip_radius_mm * 1e-3,
            root_radius: g.root_radius_mm * 1e-3,
            body_radius: g.bore_radius_mm * 1e-3,
            root_form: RootForm::Hob { tip_radius: g.hob_tip_radius_mm * 1e-3 },
            chamfer: (chamfer.height > 0.0).then_some(chamfer),
            face_width: g.face_width_mm * 1e-3,
        };
        if !(sizes_ok && angle_ok && g.teeth >= 6) {
            return form;
        }
        let rb = form.base_radius() * 1e3;
        if let Some(slope) = form.edge_relief().map(|e| e.slope).filter(|s| s.is_nan() || *s <= 0.0) {
            let alpha_e = (rb / (form.involute_tip_radius() * 1e3)).clamp(-1.0, 1.0).acos().to_degrees();
            self.fail(
                &n("tip_chamfer.angle_deg"),
                chamfer_spec.angle_deg,
                format!(
                    "must be below {:.2}° (90° less the involute's pressure angle at the chamfer's edge) \
                     when the edge carries no load: the chamfer must fall away from the involute \
                     (relief slope {slope:.3})",
                    90.0 - alpha_e
                ),
            );
        }
        if g.tip_radius_mm <= rb {
            self.fail(
                &n("tip_radius_mm"),
                g.tip_radius_mm,
                format!("must exceed the base radius {rb:.4} mm, or the teeth have no involute flank"),
            );
        }
        if g.root_radius_mm >= g.tip_radius_mm {
            self.fail(
                &n("root_radius_mm"),
                g.root_radius_mm,
                format!("must be below the tip radius {} mm", g.tip_radius_mm),
            );
        }
        if g.bore_radius_mm >= g.root_radius_mm {
            self.fail(
                &n("bore_radius_mm"),
                g.bore_radius_mm,
                format!("must be below the root radius {} mm", g.root_radius_mm),
            );
        }
        if g.tooth_thickness_mm >= PI * g.module_mm {
            self.fail(
                &n("tooth_thickness_mm"),
                g.tooth_thickness_mm,
                format!("must be below the circular pitch π·m = {:.4} mm", PI * g.module_mm),
            );
        } else if g.tip_radius_mm > rb && form.thickness_at(form.tip_radius) <= 0.0 {
            self.fail(
                &n("tip_radius_mm"),
                g.tip_radius_mm,
                "the tooth is pointed below this tip radius: reduce the tip radius or thicken the tooth",
            );
        } else if g.tip_radius_mm > rb {
            self.tip_thickness(key, &form, g.tip_radius_mm);
        }
        if let RootForm::Hob { tip_radius } = form.root_form {
            let dedendum = form.reference_radius() - form.root_radius;
            if tip_radius > 0.0 && tip_radius >= dedendum {
                self.fail(
                    &n("hob_tip_radius_mm"),
                    g.hob_tip_radius_mm,
                    format!("must be below the dedendum {:.4} mm", dedendum * 1e3),
                );
            } else {
                self.undercut(key, g, &form);
            }
        }
        form
    }

    /// A tooth tip thinner than [`MIN_TIP_THICKNESS_FACTOR`]·m breaks or
    /// hardens through: refused, named by the tip's key.
    fn tip_thickness(&mut self, key: &str, form: &ToothForm, tip_radius_mm: f64) {
        let sa = form.thickness_at(form.tip_radius) * 1e3;
        let least = MIN_TIP_THICKNESS_FACTOR * form.module * 1e3;
        if sa.is_finite() && sa < least {
            self.fail(
                &tip_key(key),
                tip_radius_mm,
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
        match g.gear_data.filter(|d| d.root_diameter_mm.is_none()) {
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
                    g.root_radius_mm,
                    format!(
                        "the {key} is undercut: with {} teeth and hob tip radius {} mm the root radius must be at least r − r·sin²α − ρ·(1 − sin α) = {:.4} mm",
                        g.teeth,
                        g.hob_tip_radius_mm,
                        least * 1e3
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
        let mut ok = self.positive(&n("module_mm"), g.module_mm);
        ok &= self.positive(&n("tooth_thickness_mm"), g.tooth_thickness_mm);
        ok &= self.positive(&n("minor_radius_mm"), g.minor_radius_mm);
        ok &= self.positive(&n("root_radius_mm"), g.root_radius_mm);
        ok &= self.positive(&n("rim_radius_mm"), g.rim_radius_mm);
        ok &= self.positive(&n("fillet_radius_mm"), g.fillet_radius_mm);
        ok &= self.positive(&n("face_width_mm"), g.face_width_mm);
        ok &= self.in_range(&n("pressure_angle_deg"), g.pressure_angle_deg, 10.0, 35.0, "spur gear practice");
        let reference = g.module_mm * f64::from(g.teeth) / 2.0;
        let chamfer = g.tip_chamfer.map(|c| self.chamfer("ring", &c, reference - g.minor_radius_mm));
        let form = ToothForm {
            kind: GearKind::Internal,
            teeth: g.teeth,
            module: g.module_mm * 1e-3,
            pressure_angle: g.pressure_angle_deg.to_radians(),
            tooth_thickness: g.tooth_thickness_mm * 1e-3,
            tip_radius: g.minor_radius_mm * 1e-3,
            root_radius: g.root_radius_mm * 1e-3,
            body_radius: g.rim_radius_mm * 1e-3,
            root_form: RootForm::Fillet { radius: g.fillet_radius_mm * 1e-3 },
            chamfer: chamfer.filter(|c| c.height > 0.0),
            face_width: g.face_width_mm * 1e-3,
        };
        if !(ok && g.teeth >= 12) {
            return form;
        }
        let rb = form.base_radius() * 1e3;
        if g.minor_radius_mm <= rb {
            self.fail(
                &n("minor_radius_mm"),
                g.minor_radius_mm,
                format!("must exceed the ring's base radius {rb:.4} mm, or its teeth have no involute flank"),
            );
        }
        if g.root_radius_mm <= g.minor_radius_mm {
            self.fail(
                &n("root_radius_mm"),
                g.root_radius_mm,
                format!("must exceed the minor radius {} mm", g.minor_radius_mm),
            );
        }
        if g.rim_radius_mm <= g.root_radius_mm {
            self.fail(
                &n("rim_radius_mm"),
                g.rim_radius_mm,
                format!("must exceed the root radius {} mm", g.root_radius_mm),
            );
        }
        if g.tooth_thickness_mm >= PI * g.module_mm {
            self.fail(
                &n("tooth_thickness_mm"),
                g.tooth_thickness_mm,
                format!("must be below the circular pitch π·m = {:.4} mm", PI * g.module_mm),
            );
        }
        if g.minor_radius_mm > rb && g.tooth_thickness_mm < PI * g.module_mm {
            self.tip_thickness("ring", &form, g.minor_radius_mm);
        }
        if g.fillet_radius_mm >= 0.5 * (g.root_radius_mm - g.minor_radius_mm) {
            self.fail(
                &n("fillet_radius_mm"),
                g.fillet_radius_mm,
                format!(
                    "must be below half the tooth depth, {:.4} mm",
                    0.5 * (g.root_radius_mm - g.minor_radius_mm)
                ),
            );
        }
        form
    }
}

/// The scene key of a gear's tip radius (the ring's is its minor radius).
fn tip_key(gear: &str) -> String {
    if gear == "ring" {
        "ring.minor_radius_mm".into()
    } else {
        format!("{gear}.tip_radius_mm")
    }
}

/// Least tooth thickness at the tip circle, as a fraction of the module:
/// 0.2·m, the usual limit for case-hardened gears (a thinner tip hardens
/// through and chips), docs/GEAR_DATA.md.
pub const MIN_TIP_THICKNESS_FACTOR: f64 = 0.2;

/// Least radial gap between the tip circles of neighbouring planets, as a
/// fraction of the module: 0.5·m (docs/GEAR_DATA.md).
pub const PLANET_TIP_GAP_FACTOR: f64 = 0.5;

/// Checks every rule of a scene and converts it to SI; a problem found in a
/// radius that gear data gave is named by its gear-data key.
fn validate(scene: &Scene) -> Result<(GearSet, RunSettings), SceneError> {
    validate_radii(scene).map_err(|e| match e {
        SceneError::Invalid { problems } => SceneError::Invalid {
            problems: problems.into_iter().map(|p| name_by_gear_data(p, scene)).collect(),
        },
        other => other,
    })
}

/// Every rule, on the scene with the radii its gear data give.
fn validate_radii(given: &Scene) -> Result<(GearSet, RunSettings), SceneError> {
    let (resolved, data_problems) = crate::model::gear_data::resolve(given);
    let scene = &resolved;
    let mut c = Checker { problems: data_problems };
    let sun = c.external("sun", &scene.sun);
    let planet = c.external("planet", &scene.planet);
    let ring = c.ring(&scene.ring);
    // Same base pitch on all gears: a mesh needs it, whatever else is wrong.
    for (key, g) in [("planet", &planet), ("ring", &ring)] {
        let (p, p0) = (g.base_pitch(), sun.base_pitch());
        if p.is_finite() && p0.is_finite() && p > 0.0 && p0 > 0.0 && (p - p0).abs() > 1e-9 {
            c.fail(
                &format!("{key}.module_mm"),
                g.module * 1e3,
                format!(
                    "module and pressure angle must give the sun's base pitch {:.5} mm (this gives {:.5} mm)",
                    p0 * 1e3,
                    p * 1e3
                ),
            );
        }
    }
    let gears_ok = c.problems.is_empty();

    let m = &scene.material;
    c.in_range(
        "material.youngs_modulus_gpa",
        m.youngs_modulus_gpa,
        0.0,
        1.0e4,
        "an engineering metal or polymer",
    );
    c.in_range("material.poisson_ratio", m.poisson_ratio, 0.0, 0.5, "isotropic elastic material");
    c.positive("material.density_kg_per_m3", m.density_kg_per_m3);
    let material = Material {
        youngs_modulus: m.youngs_modulus_gpa * 1e9,
        poisson_ratio: m.poisson_ratio,
        density: m.density_kg_per_m3,
    };

    let a = &scene.analysis;
    if !(8..=100_000).contains(&a.positions_per_mesh_cycle) {
        c.fail(
            "analysis.positions_per_mesh_cycle",
            a.positions_per_mesh_cycle,
            "must be between 8 and 100000",
        );
    }
    if !(5..=10_000).contains(&a.profile_points) {
        c.fail("analysis.profile_points", a.profile_points, "must be between 5 and 10000");
    }
    if !(1..=1000).contains(&a.face_slices) {
        c.fail("analysis.face_slices", a.face_slices, "must be between 1 and 1000");
    }

    let sp = &scene.supports;
    for (name, v) in [
        ("supports.sun_radial_n_per_m", sp.sun_radial_n_per_m),
        ("supports.ring_radial_n_per_m", sp.ring_radial_n_per_m),
        ("supports.carrier_radial_n_per_m", sp.carrier_radial_n_per_m),
        ("supports.planet_bearing_n_per_m", sp.planet_bearing_n_per_m),
    ] {
        c.positive(name, v);
    }
    for (name, v) in [
        ("supports.bearing_damping_ratio", Some(sp.bearing_damping_ratio)),
        ("supports.sun_damping_ratio", sp.sun_damping_ratio),
        ("supports.ring_damping_ratio", sp.ring_damping_ratio),
        ("supports.carrier_damping_ratio", sp.carrier_damping_ratio),
        ("supports.planet_damping_ratio", sp.planet_damping_ratio),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && (0.0..1.0).contains(&v)) {
                c.fail(name, v, "must be at least 0 and below 1");
            }
        }
    }
    if let Some(list) = &sp.planet_bearings_n_per_m {
        if list.len() != scene.planets.count as usize {
            c.fail(
                "supports.planet_bearings_n_per_m",
                format!("{list:?}"),
                format!("must list one stiffness per planet (planets.count = {})", scene.planets.count),
            );
        }
        for (i, v) in list.iter().enumerate() {
            c.positive(&format!("supports.planet_bearings_n_per_m[{i}]"), *v);
        }
    }
    let inertia = &scene.inertia;
    for (name, v) in [
        ("inertia.sun_mass_kg", inertia.sun_mass_kg),
        ("inertia.sun_inertia_kg_m2", inertia.sun_inertia_kg_m2),
        ("inertia.planet_mass_kg", inertia.planet_mass_kg),
        ("inertia.planet_inertia_kg_m2", inertia.planet_inertia_kg_m2),
        ("inertia.ring_mass_kg", inertia.ring_mass_kg),
        ("inertia.ring_inertia_kg_m2", inertia.ring_inertia_kg_m2),
        ("inertia.carrier_mass_kg", inertia.carrier_mass_kg),
        ("inertia.carrier_inertia_kg_m2", inertia.carrier_inertia_kg_m2),
    ] {
        if let Some(v) = v {
            c.positive(name, v);
        }
    }
    let ms = &scene.mesh_stiffness;
    for (name, v) in [
        ("mesh_stiffness.sun_planet_scale", ms.sun_planet_scale),
        ("mesh_stiffness.ring_planet_scale", ms.ring_planet_scale),
    ] {
        c.in_range(name, v, 0.1, 10.0, "a correction factor on the energy method's pair stiffness");
    }
    let d = &scene.dynamics;
    if !(d.mesh_damping_ratio.is_finite() && (0.0..1.0).contains(&d.mesh_damping_ratio)) {
        c.fail("dynamics.mesh_damping_ratio", d.mesh_damping_ratio, "must be at least 0 and below 1");
    }
    check_rayleigh(d, &mut c);
    check_contact(scene, &mut c);
    c.positive("dynamics.shaft_stiffness_nm_per_rad", d.shaft_stiffness_nm_per_rad);
    let run = RunValues {
        input_speed: rpm_to_rad_per_s(d.input_speed_rpm),
        integrator: d.integrator,
        rho_infinity: d.rho_infinity,
        steps_per_mesh_cycle: d.steps_per_mesh_cycle as usize,
        relative_tolerance: d.relative_tolerance,
        simulation_relative_tolerance: d.simulation_relative_tolerance,
        run_in_revolutions: d.run_in_revolutions,
        steady_tolerance: d.steady_tolerance,
        measured_revolutions: d.measured_revolutions,
        samples_per_mesh_cycle: d.samples_per_mesh_cycle as usize,
        response: d.response,
        steady: SteadyValues {
            speed_step: rpm_to_rad_per_s(d.steady_speed_step_rpm),
            torque_step: d
                .steady_torque_step_nm
                .unwrap_or(crate::scene::STEADY_TORQUE_STEP * scene.operation.input_torque_nm.abs()),
            speed_floor: rpm_to_rad_per_s(d.steady_speed_floor_rpm),
            agreement: d.steady_agreement,
            refinements: d.steady_refinements,
            sample_phase: 0.0,
        },
    };
    check_run_settings(&run, Some(d.input_speed_rpm), &mut c);
    if let (Some(x), false) = (d.steady_torque_step_nm, d.response == crate::scene::Response::Steady) {
        if !(x.is_finite() && (1e-3..=1e7).contains(&x)) {
            c.fail("dynamics.steady_torque_step_nm", x, "must lie between 1e-3 and 1e7 N·m");
        }
    }

    let op = &scene.operation;
    if op.held == op.input {
        c.fail(
            "operation.input",
            op.input.name(),
            format!("must differ from the held member ({})", op.held.name()),
        );
    }
    check_speed_driven_member(d, op, &mut c);
    if !op.input_torque_nm.is_finite() {
        c.fail("operation.input_torque_nm", op.input_torque_nm, "must be a finite number");
    }

    // Planet layout and the assembly condition.
    let count = scene.planets.count;
    let mut angles = Vec::new();
    if !(1..=32).contains(&count) {
        c.fail("planets.count", count, "must be between 1 and 32");
    } else {
        angles = match &scene.planets.angles_deg {
            None => (0..count).map(|i| 2.0 * PI * f64::from(i) / f64::from(count)).collect(),
            Some(list) => {
                if list.len() != count as usize {
                    c.fail(
                        "planets.angles_deg",
                        format!("{list:?}"),
                        format!("must list exactly planets.count = {count} angles"),
                    );
                }
                list.iter().map(|d| d.to_radians()).collect()
            }
        };
        if angles.iter().any(|a| !a.is_finite()) {
            c.fail("planets.angles_deg", format!("{:?}", scene.planets.angles_deg), "must be finite numbers");
            angles.clear();
        }
    }

    let centre_ok = c.positive("centre_distance_mm", scene.centre_distance_mm);
    if !(gears_ok && centre_ok) {
        return Err(SceneError::Invalid { problems: c.problems });
    }

    let angles_len = angles.len();
    let set = GearSet {
        name: scene.name.clone(),
        sun,
        planet,
        ring,
        planet_angles: angles,
        centre_distance: scene.centre_distance_mm * 1e-3,
        material,
        held: op.held,
        input: op.input,
        input_torque: op.input_torque_nm,
        stiffness_scale: [ms.sun_planet_scale, ms.ring_planet_scale],
        analysis: Analysis {
            positions_per_mesh_cycle: a.positions_per_mesh_cycle as usize,
            profile_points: a.profile_points as usize,
            face_slices: a.face_slices as usize,
        },
        supports: Supports {
            sun_radial: sp.sun_radial_n_per_m,
            ring_radial: sp.ring_radial_n_per_m,
            carrier_radial: sp.carrier_radial_n_per_m,
            planet_bearing: sp.planet_bearing_n_per_m,
            planet_bearings: sp
                .planet_bearings_n_per_m
                .clone()
                .unwrap_or_else(|| vec![sp.planet_bearing_n_per_m; angles_len]),
            damping_ratios: [
                sp.carrier_damping_ratio.unwrap_or(sp.bearing_damping_ratio),
                sp.ring_damping_ratio.unwrap_or(sp.bearing_damping_ratio),
                sp.sun_damping_ratio.unwrap_or(sp.bearing_damping_ratio),
                sp.planet_damping_ratio.unwrap_or(sp.bearing_damping_ratio),
            ],
        },
        bodies: Bodies {
            sun: Body { mass: 0.0, inertia: 0.0 },
            planet: Body { mass: 0.0, inertia: 0.0 },
            ring: Body { mass: 0.0, inertia: 0.0 },
            carrier: Body { mass: 0.0, inertia: 0.0 },
        },
        fidelity: d.fidelity,
        mesh_damping_ratio: d.mesh_damping_ratio,
        damping: match d.damping {
            DampingModel::Ratio => Damping::Ratio,
            DampingModel::Rayleigh => {
                Damping::Rayleigh { mass: d.rayleigh_mass_per_s, stiffness: d.rayleigh_stiffness_s }
            }
        },
        contact: d.contact,
        drive: d.drive,
        shaft_stiffness: d.shaft_stiffness_nm_per_rad,
        load_balance: d.load_balance,
        speed_driven: d.speed_driven_member.unwrap_or(op.input),
    };
    // Bodies from the geometry, then the user's overrides.
    let mut set = set;
    let derived = Bodies::from_geometry(&set);
    let pick = |v: Option<f64>, d: f64| v.unwrap_or(d);
    set.bodies = Bodies {
        sun: Body {
            mass: pick(inertia.sun_mass_kg, derived.sun.mass),
            inertia: pick(inertia.sun_inertia_kg_m2, derived.sun.inertia),
        },
        planet: Body {
            mass: pick(inertia.planet_mass_kg, derived.planet.mass),
            inertia: pick(inertia.planet_inertia_kg_m2, derived.planet.inertia),
        },
        ring: Body {
            mass: pick(inertia.ring_mass_kg, derived.ring.mass),
            inertia: pick(inertia.ring_inertia_kg_m2, derived.ring.inertia),
        },
        carrier: Body {
            mass: pick(inertia.carrier_mass_kg, derived.carrier.mass),
            inertia: pick(inertia.carrier_inertia_kg_m2, derived.carrier.inertia),
        },
    };

    // Centre distance must be reachable by both meshes.
    let a_mm = scene.centre_distance_mm;
    let ext = (set.sun.base_radius() + set.planet.base_radius()) * 1e3;
    let int = (set.ring.base_radius() - set.planet.base_radius()) * 1e3;
    if a_mm <= ext {
        c.fail(
            "centre_distance_mm",
            a_mm,
            format!("must exceed the sum of sun and planet base radii, {ext:.4} mm"),
        );
    }
    if a_mm <= int {
        c.fail(
            "centre_distance_mm",
            a_mm,
            format!("must exceed the ring base radius less the planet's, {int:.4} mm"),
        );
    }
    if !c.problems.is_empty() {
        return Err(SceneError::Invalid { problems: c.problems });
    }

    for mesh in MeshKind::ALL {
        let j = set.circumferential_backlash(mesh);
        if j < 0.0 {
            let (key1, key2) = match mesh {
                MeshKind::SunPlanet => ("sun", "planet"),
                MeshKind::RingPlanet => ("planet", "ring"),
            };
            c.fail(
                &format!("{key1}.tooth_thickness_mm"),
                format!("{} (with {key2})", set.mesh_gears(mesh).0.tooth_thickness * 1e3),
                format!(
                    "the {} mesh has negative backlash ({:.4} mm at the operating pitch circle): thin the teeth of {key1} or {key2} or increase centre_distance_mm",
                    mesh.name(),
                    j * 1e3
                ),
            );
        }
        let path = PathOfContact::new(&set, mesh);
        let eps = path.nominal_contact_ratio();
        if eps < 1.0 {
            c.fail(
                &format!("{}.tip_radius_mm", if mesh == MeshKind::SunPlanet { "sun" } else { "planet" }),
                format!("{} (contact ratio {eps:.4})", path.gear1_tip_radius_mm()),
                format!("the {} mesh's contact ratio must be at least 1: lengthen the teeth", mesh.name()),
            );
        }
        // Tip/root interference: each gear's start of active profile must lie
        // on its involute, above the form circle where the fillet begins.
        let (g1, g2) = set.mesh_gears(mesh);
        let (k1, k2) = match mesh {
            MeshKind::SunPlanet => ("sun", "planet"),
            MeshKind::RingPlanet => ("planet", "ring"),
        };
        // Involute interference: the mate's tip must not carry the contact
        // past the base circle's tangent point of either gear (the start
        // of the involute), where the flanks would cut each other.
        if path.start_sharp < 0.0 {
            c.fail(
                &tip_key(k2),
                g2.tip_radius * 1e3,
                format!(
                    "involute interference in the {} mesh: the {k2} tip reaches {:.4} mm past the {k1}'s \
                     base-circle tangent point (usable limit: the {k1} base circle, radius {:.4} mm); \
                     {}",
                    mesh.name(),
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
                    mesh.name(),
                    (path.end_sharp - path.tangency_distance) * 1e3,
                    g2.base_radius() * 1e3
                ),
            );
        }
        if g2.kind == GearKind::Internal {
            if let Some(margin) = trochoid_margin(g1, g2, set.centre_distance) {
                if margin < 0.0 {
                    c.fail(
                        &tip_key(k1),
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
        }
        let (r1, r2) = path.active_profile_start_radii();
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
                    mesh.name(), r1 * 1e3, f1 * 1e3
                ),
            );
        }
        if interferes2 {
            c.fail(
                &tip_key(k1),
                g1.tip_radius * 1e3,
                format!(
                    "tip/root interference in the {} mesh: the {k1} tip reaches {k2} radius {:.4} mm, beyond its form radius {:.4} mm where the fillet begins",
                    mesh.name(), r2 * 1e3, f2 * 1e3
                ),
            );
        }
        // Root clearance: the mating tip circle must not reach the root circle.
        for (clearance, tip_gear, root_key) in path.root_clearances() {
            if clearance <= 0.0 {
                c.fail(
                    &tip_key(tip_gear),
                    format!("clearance {:.4} mm", clearance * 1e3),
                    format!(
                        "the {tip_gear} tip circle must clear the {root_key} root circle in the {} mesh",
                        mesh.name()
                    ),
                );
            }
        }
    }

    // Assembly: planet n at ψ_n fits when (Z_s + Z_r)·ψ_n / 2π is an integer.
    let zsum = f64::from(set.sun.teeth + set.ring.teeth);
    let n_planets = set.planet_angles.len();
    let equally_spaced = scene.planets.angles_deg.is_none() && n_planets > 0;
    if equally_spaced && (set.sun.teeth + set.ring.teeth) % n_planets as u32 != 0 {
        c.fail(
            "planets.count",
            n_planets,
            format!(
                "equally spaced planets can be assembled only when (Z_sun + Z_ring)/N is an integer: \
                 ({} + {})/{n_planets} = {:.4}",
                set.sun.teeth,
                set.ring.teeth,
                zsum / n_planets as f64
            ),
        );
    }
    for (i, psi) in set.planet_angles.iter().enumerate().filter(|_| !equally_spaced) {
        let k = zsum * psi / (2.0 * PI);
        if (k - k.round()).abs() > 1e-6 {
            c.fail(
                &format!("planets.angles_deg[{i}]"),
                format!("{:.6}", psi.to_degrees()),
                format!(
                    "planets can only be assembled at multiples of 360°/(Z_sun + Z_ring) = {:.6}°: (Z_sun + Z_ring)·ψ/360° = {k:.6} is not an integer",
                    360.0 / zsum
                ),
            );
        }
    }
    // Neighbouring planets must not touch.
    let mut sorted = set.planet_angles.clone();
    sorted.sort_by(f64::total_cmp);
    if sorted.len() > 1 {
        for i in 0..sorted.len() {
            let next = if i + 1 < sorted.len() { sorted[i + 1] } else { sorted[0] + 2.0 * PI };
            let gap = next - sorted[i];
            let chord = 2.0 * set.centre_distance * (gap / 2.0).sin();
            let need = 2.0 * set.planet.tip_radius + PLANET_TIP_GAP_FACTOR * set.planet.module;
            if chord <= need {
                let (key, value) = if scene.planets.angles_deg.is_none() {
                    ("planets.count".to_string(), sorted.len().to_string())
                } else {
                    (
                        "planets.angles_deg".to_string(),
                        format!(
                            "{:.4}° and {:.4}°",
                            sorted[i].to_degrees(),
                            next.to_degrees().rem_euclid(360.0)
                        ),
                    )
                };
                c.fail(
                    &key,
                    value,
                    format!(
                        "neighbouring planets collide: centres {:.4} mm apart, their tip diameters \
                         {:.4} mm need {:.4} mm with the gap of {PLANET_TIP_GAP_FACTOR}·m between tip circles",
                        chord * 1e3,
                        2.0 * set.planet.tip_radius * 1e3,
                        need * 1e3
                    ),
                );
                break;
            }
        }
    }

    c.problems.extend(crate::model::cost::problems(scene));
    if c.problems.is_empty() {
        Ok((set, RunSettings { values: run }))
    } else {
        Err(SceneError::Invalid { problems: c.problems })
    }
}

/// Largest input speed magnitude a scene may give \[rpm\].
const MAX_INPUT_SPEED_RPM: f64 = 1.0e6;

/// The input-speed rule: a finite speed of at most [`MAX_INPUT_SPEED_RPM`] in
/// magnitude, checked in rad/s. `given_rpm` is the value the user wrote, when
/// there is one, shown as given in the problem; otherwise the speed is shown
/// converted to rpm (the scene key's unit).
fn check_input_speed(omega: f64, given_rpm: Option<f64>, c: &mut Checker) {
    if !(omega.is_finite() && omega.abs() <= rpm_to_rad_per_s(MAX_INPUT_SPEED_RPM)) {
        c.fail(
            "dynamics.input_speed_rpm",
            given_rpm.unwrap_or_else(|| rad_per_s_to_rpm(omega)),
            "must be a finite speed below 1e6 rpm in magnitude",
        );
    }
}

/// Every rule of the run settings, each problem named by its scene key (the
/// input speed shown in rpm, as the scene gives it). Shared by
/// [`Scene::validate`] and [`RunSettings::new`].
fn check_run_settings(d: &RunValues, given_rpm: Option<f64>, c: &mut Checker) {
    check_input_speed(d.input_speed, given_rpm, c);
    if !(d.rho_infinity.is_finite() && (0.0..=1.0).contains(&d.rho_infinity)) {
        c.fail("dynamics.rho_infinity", d.rho_infinity, "must lie between 0 and 1 (spectral radius)");
    }
    if !(4..=100_000).contains(&d.steps_per_mesh_cycle) {
        c.fail("dynamics.steps_per_mesh_cycle", d.steps_per_mesh_cycle, "must be between 4 and 100000");
    }
    for (key, rtol) in [
        ("dynamics.relative_tolerance", d.relative_tolerance),
        ("dynamics.simulation_relative_tolerance", d.simulation_relative_tolerance),
    ] {
        if !(rtol.is_finite() && (1e-14..=1e-1).contains(&rtol)) {
            c.fail(key, rtol, "must lie between 1e-14 and 0.1");
        }
    }
    if !(d.run_in_revolutions.is_finite() && d.run_in_revolutions >= 0.0) {
        c.fail("dynamics.run_in_revolutions", d.run_in_revolutions, "must be zero or more");
    }
    c.positive("dynamics.measured_revolutions", d.measured_revolutions);
    if !(d.steady_tolerance.is_finite() && (0.0..1.0).contains(&d.steady_tolerance)) {
        c.fail("dynamics.steady_tolerance", d.steady_tolerance, "must be at least 0 and below 1");
    }
    if !(8..=100_000).contains(&d.samples_per_mesh_cycle) {
        c.fail("dynamics.samples_per_mesh_cycle", d.samples_per_mesh_cycle, "must be between 8 and 100000");
    }
    check_steady(&d.steady, d.response == crate::scene::Response::Steady, c);
}

/// The steady response's cache grid (docs/STEADY.md), checked when the response is steady.
fn check_steady(s: &SteadyValues, steady: bool, c: &mut Checker) {
    let rpm = rad_per_s_to_rpm;
    if !(s.speed_step.is_finite() && (1.0..=10_000.0).contains(&rpm(s.speed_step))) {
        c.fail("dynamics.steady_speed_step_rpm", rpm(s.speed_step), "must lie between 1 and 10000 rpm");
    }
    if steady && !(s.torque_step.is_finite() && (1e-3..=1e7).contains(&s.torque_step)) {
        c.fail(
            "dynamics.steady_torque_step_nm",
            s.torque_step,
            "must lie between 1e-3 and 1e7 N·m (given, or a fifth of operation.input_torque_nm when absent)",
        );
    }
    if !(s.speed_floor.is_finite() && (1.0..=100_000.0).contains(&rpm(s.speed_floor))) {
        c.fail("dynamics.steady_speed_floor_rpm", rpm(s.speed_floor), "must lie between 1 and 100000 rpm");
    }
    if !(s.agreement.is_finite() && (1e-6..=1.0).contains(&s.agreement)) {
        c.fail(
            "dynamics.steady_agreement",
            s.agreement,
            "must lie between 1e-6 and 1 (of the static mesh load)",
        );
    }
    if !(0.0..1.0).contains(&s.sample_phase) {
        c.fail("steady sample phase", s.sample_phase, "must lie in [0, 1) (of the sample interval)");
    }
    if s.refinements > 8 {
        c.fail("dynamics.steady_refinements", s.refinements, "must be between 0 and 8");
    }
}

impl RunSettings {
    /// Checks `values` by the scene's rules for run settings and returns
    /// them as settings, or every problem at once, each named by its scene
    /// key (`dynamics.relative_tolerance`, …).
    pub fn new(values: RunValues) -> Result<RunSettings, SceneError> {
        let mut c = Checker { problems: Vec::new() };
        check_run_settings(&values, None, &mut c);
        if c.problems.is_empty() {
            Ok(RunSettings { values })
        } else {
            Err(SceneError::Invalid { problems: c.problems })
        }
    }

    /// These settings changed by `change` (which edits a copy of the values),
    /// checked again by [`RunSettings::new`].
    pub fn with(&self, change: impl FnOnce(&mut RunValues)) -> Result<RunSettings, SceneError> {
        let mut values = self.values;
        change(&mut values);
        RunSettings::new(values)
    }
}

/// `dynamics.speed_driven_member`: a turning member (not the held one),
/// only under the speed drive, and not the output member when the load
/// balance already holds that member's speed.
fn check_speed_driven_member(
    d: &crate::scene::DynamicsSpec,
    op: &crate::scene::OperationSpec,
    c: &mut Checker,
) {
    let Some(m) = d.speed_driven_member else { return };
    let key = "dynamics.speed_driven_member";
    let output =
        [Member::Sun, Member::Ring, Member::Carrier].into_iter().find(|x| *x != op.held && *x != op.input);
    if m == op.held {
        c.fail(
            key,
            m.name(),
            format!(
                "the held member ({}) cannot be speed-driven; allowed: the input member ({}) or the output member{}",
                op.held.name(),
                op.input.name(),
                output.map_or(String::new(), |o| format!(" ({})", o.name()))
            ),
        );
    } else if d.drive != Drive::Speed {
        c.fail(key, m.name(), format!("applies to dynamics.drive = \"speed\" only (drive is {:?})", d.drive));
    } else if d.load_balance && Some(m) == output {
        c.fail(
            key,
            m.name(),
            "the load balance already holds the output member's speed: drive the input member, or turn \
             dynamics.load_balance off",
        );
    }
}

/// The mesh stiffness scales correct the pair model's tooth stiffness; the
/// deformable law takes its stiffness from the bodies and does not read them.
fn check_contact(scene: &Scene, c: &mut Checker) {
    if scene.dynamics.contact != ContactModel::Deformable {
        return;
    }
    let ms = &scene.mesh_stiffness;
    for (key, v) in [
        ("mesh_stiffness.sun_planet_scale", ms.sun_planet_scale),
        ("mesh_stiffness.ring_planet_scale", ms.ring_planet_scale),
    ] {
        if v != 1.0 {
            c.fail(
                key,
                v,
                "is read only with dynamics.contact = \"pair\" (the deformable law's stiffness comes from its \
                 finite-element bodies): remove the key or set it to 1",
            );
        }
    }
}

/// The Rayleigh coefficients: finite and not negative, and set only with
/// `dynamics.damping = "rayleigh"` (the ratio model would ignore them).
fn check_rayleigh(d: &crate::scene::DynamicsSpec, c: &mut Checker) {
    for (key, v) in [
        ("dynamics.rayleigh_mass_per_s", d.rayleigh_mass_per_s),
        ("dynamics.rayleigh_stiffness_s", d.rayleigh_stiffness_s),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            c.fail(key, v, "must be a finite number, at least 0");
        } else if v != 0.0 && d.damping == DampingModel::Ratio {
            c.fail(
                key,
                v,
                "is read only with dynamics.damping = \"rayleigh\" (the damping is \"ratio\"): set the damping \
                 model, or remove the key",
            );
        }
    }
}
