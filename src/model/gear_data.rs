//! From gear data to radii (ISO 21771 geometry of spur gears).
//!
//! A gear given in a scene by its gear data (`sun.gear_data`, …: profile
//! shift x, basic rack factors h_aP*, h_fP*, ρ_fP*, tooth-thickness
//! allowance A_s, optional tip and root diameters) is turned here into the
//! radii of the radii form, which the rules of [`crate::model::build`] then
//! check like any other (one set of rules for both forms). With module m,
//! tooth count z, pressure angle α of the basic rack and r = m·z/2:
//!
//! | | external (sun, planet) | internal (ring) |
//! |---|---|---|
//! | base radius r_b | r·cos α | r·cos α |
//! | tip radius r_a | r + (h_aP* + x)·m | r − (h_aP* − x)·m (minor radius) |
//! | root radius r_f | r − (h_fP* − x)·m | r + (h_fP* + x)·m |
//! | tooth thickness s | (π/2 + 2x·tan α)·m + A_s | (π/2 − 2x·tan α)·m + A_s |
//! | tool tip | hob tip radius ρ_fP*·m | root fillet radius ρ_fP*·m |
//!
//! (ISO 21771 writes the internal gear with negative z and diameters; these
//! are the same relations in magnitudes, with x positive away from the
//! axis.) The zero-backlash operating pressure angle of a pair follows from
//! inv α_w = inv α + 2·tan α·(x₁ + x₂)/(z₁ + z₂) (external) or
//! inv α + 2·tan α·(x₂ − x₁)/(z₂ − z₁) (internal, ring 2), and its centre
//! distance from a_w = a·cos α / cos α_w with a = m·(z₁ ± z₂)/2.
//!
//! Every problem of the gear data is reported at once, named by its scene
//! key; a problem the rules of [`crate::model::build`] find in a derived
//! radius is renamed to the gear-data key it came from
//! ([`name_by_gear_data`]).

use std::f64::consts::{FRAC_PI_2, PI};

use crate::model::gear::ToothForm;
use crate::model::involute::{inv, inv_inverse};
use crate::scene::units::m_to_mm;
use crate::scene::{GearData, Problem, Scene};

/// The radii of one gear derived from its gear data \[m\].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DerivedRadii {
    /// Reference radius m·z/2 \[m\].
    pub reference_radius: f64,
    /// Base radius r·cos α \[m\].
    pub base_radius: f64,
    /// Tip radius (the ring's minor radius) \[m\].
    pub tip_radius: f64,
    /// Root radius \[m\].
    pub root_radius: f64,
    /// Circular tooth thickness at the reference circle, allowance included \[m\].
    pub tooth_thickness: f64,
    /// Hob tip radius (external) or root fillet radius (ring) \[m\].
    pub tool_tip_radius: f64,
}

/// The radii of an external gear (sun, planet) of `teeth` teeth, module
/// `module` \[m\] and pressure angle `pressure_angle` \[rad\] from its gear
/// data.
pub fn external_radii(teeth: u32, module: f64, pressure_angle: f64, gd: &GearData) -> DerivedRadii {
    radii(1.0, teeth, module, pressure_angle, gd)
}

/// The radii of an internal gear (the ring) from its gear data: the tip
/// radius is the minor radius, the tool tip radius the root fillet's.
pub fn ring_radii(teeth: u32, module: f64, pressure_angle: f64, gd: &GearData) -> DerivedRadii {
    radii(-1.0, teeth, module, pressure_angle, gd)
}

/// ISO 21771's radii of a gear whose teeth stand outward (`side` = 1,
/// external) or inward (`side` = −1, internal): the addendum and dedendum
/// point the other way on an internal gear, while a positive profile shift
/// moves both circles outward on either and thickens an external tooth but
/// thins an internal one.
fn radii(side: f64, teeth: u32, module: f64, pressure_angle: f64, gd: &GearData) -> DerivedRadii {
    let (m, a) = (module, pressure_angle);
    let r = m * f64::from(teeth) / 2.0;
    let x = gd.profile_shift;
    DerivedRadii {
        reference_radius: r,
        base_radius: r * a.cos(),
        tip_radius: gd.tip_diameter.map_or(r + (side * gd.addendum_factor + x) * m, |d| d / 2.0),
        root_radius: gd.root_diameter.map_or(r + (x - side * gd.dedendum_factor) * m, |d| d / 2.0),
        tooth_thickness: (PI / 2.0 + side * (2.0 * x * a.tan())) * m + gd.tooth_thickness_allowance,
        tool_tip_radius: gd.tool_tip_radius_factor * m,
    }
}

/// Zero-backlash operating pressure angle \[rad\] of a pair of z₁, z₂ teeth
/// with profile shifts x₁, x₂ cut by a rack of pressure angle `alpha`
/// \[rad\]: inv α_w = inv α + 2·tan α·(x₁ ± x₂)/(z₂ ± z₁), the lower sign for
/// an internal gear 2.
pub fn operating_pressure_angle(z1: u32, x1: f64, z2: u32, x2: f64, alpha: f64, internal: bool) -> f64 {
    let (z1, z2) = (f64::from(z1), f64::from(z2));
    let (xs, zs) = if internal { (x2 - x1, z2 - z1) } else { (x1 + x2, z1 + z2) };
    inv_inverse(inv(alpha) + 2.0 * alpha.tan() * xs / zs)
}

/// Zero-backlash operating centre distance \[m\] of the same pair with
/// module `module` \[m\]: a_w = m·(z₂ ± z₁)/2 · cos α / cos α_w.
pub fn operating_centre_distance(
    module: f64,
    z1: u32,
    x1: f64,
    z2: u32,
    x2: f64,
    alpha: f64,
    internal: bool,
) -> f64 {
    let zs = if internal { f64::from(z2) - f64::from(z1) } else { f64::from(z1) + f64::from(z2) };
    let aw = operating_pressure_angle(z1, x1, z2, x2, alpha, internal);
    module * zs / 2.0 * alpha.cos() / aw.cos()
}

/// Smallest profile shift without undercut of an external gear of `teeth`
/// teeth cut by a rack of dedendum factor h_fP*, tip radius factor ρ_fP* and
/// pressure angle `alpha` \[rad\]: x_min = h_fP* − ρ_fP*·(1 − sin α) − z·sin²α/2
/// (the end of the tool's straight flank reaches the line of action at the
/// base circle's tangent point).
pub fn minimum_profile_shift(
    teeth: u32,
    dedendum_factor: f64,
    tool_tip_radius_factor: f64,
    alpha: f64,
) -> f64 {
    dedendum_factor
        - tool_tip_radius_factor * (1.0 - alpha.sin())
        - f64::from(teeth) * alpha.sin().powi(2) / 2.0
}

/// The largest difference \[m\] allowed between the scene's centre distance
/// and the zero-backlash operating centre distance of a mesh whose gears
/// are both given by gear data, 0.01 mm: a profile shift rounded to four
/// decimals moves a_w by well under it, and the backlash it leaves (at most
/// 2·0.01·sin α_w mm) is checked with the allowances.
pub const CENTRE_DISTANCE_TOLERANCE: f64 = 1.0e-5;

/// The scene with every gear given by gear data written in the radii form
/// (its derived radius fields filled in, `gear_data` kept), and the
/// problems of the gear data itself: values out of range, a radius field
/// set beside gear data, a centre distance the profile shifts do not give.
pub fn resolve(scene: &Scene) -> (Scene, Vec<Problem>) {
    let mut s = scene.clone();
    let mut problems = Vec::new();
    if let Some(gd) = scene.sun.gear_data {
        check_data("sun", &gd, scene.sun.module, &mut problems);
        conflicts("sun", &external_derived_fields(&scene.sun), &mut problems);
        let d = external_radii(scene.sun.teeth, scene.sun.module, scene.sun.pressure_angle, &gd);
        fill_external(&mut s.sun, &d);
    }
    if let Some(gd) = scene.planet.gear_data {
        check_data("planet", &gd, scene.planet.module, &mut problems);
        conflicts("planet", &external_derived_fields(&scene.planet), &mut problems);
        let d = external_radii(scene.planet.teeth, scene.planet.module, scene.planet.pressure_angle, &gd);
        fill_external(&mut s.planet, &d);
    }
    if let Some(gd) = scene.ring.gear_data {
        check_data("ring", &gd, scene.ring.module, &mut problems);
        conflicts("ring", &ring_derived_fields(&scene.ring), &mut problems);
        let d = ring_radii(scene.ring.teeth, scene.ring.module, scene.ring.pressure_angle, &gd);
        s.ring.tooth_thickness = d.tooth_thickness;
        s.ring.minor_radius = d.tip_radius;
        s.ring.root_radius = d.root_radius;
        s.ring.fillet_radius = d.tool_tip_radius;
    }
    if problems.is_empty() {
        centre_distance(scene, &mut problems);
    }
    (s, problems)
}

fn fill_external(g: &mut crate::scene::ExternalGearSpec, d: &DerivedRadii) {
    g.tooth_thickness = d.tooth_thickness;
    g.tip_radius = d.tip_radius;
    g.root_radius = d.root_radius;
    g.hob_tip_radius = d.tool_tip_radius;
}

/// The fields of an external gear that its gear data derive, by key (SI).
fn external_derived_fields(g: &crate::scene::ExternalGearSpec) -> [(&'static str, f64); 4] {
    [
        ("tooth_thickness_mm", g.tooth_thickness),
        ("tip_radius_mm", g.tip_radius),
        ("root_radius_mm", g.root_radius),
        ("hob_tip_radius_mm", g.hob_tip_radius),
    ]
}

/// The fields of the ring that its gear data derive, by key (SI).
fn ring_derived_fields(g: &crate::scene::RingGearSpec) -> [(&'static str, f64); 4] {
    [
        ("tooth_thickness_mm", g.tooth_thickness),
        ("minor_radius_mm", g.minor_radius),
        ("root_radius_mm", g.root_radius),
        ("fillet_radius_mm", g.fillet_radius),
    ]
}

/// A radius field set beside gear data would be ignored: refuse it.
fn conflicts(gear: &str, fields: &[(&str, f64)], problems: &mut Vec<Problem>) {
    for (field, v) in fields {
        if *v != 0.0 {
            problems.push(Problem {
                name: format!("{gear}.{field}"),
                value: m_to_mm(*v).to_string(),
                reason: format!(
                    "{gear} is given by its gear data ({gear}.gear_data): its radii follow from it; \
                     give a tip or root diameter as {gear}.gear_data.tip_diameter_mm or root_diameter_mm"
                ),
            });
        }
    }
}

fn check_data(gear: &str, gd: &GearData, module: f64, problems: &mut Vec<Problem>) {
    let mut fail = |field: &str, value: String, reason: &str| {
        problems.push(Problem { name: format!("{gear}.gear_data.{field}"), value, reason: reason.into() })
    };
    let x = gd.profile_shift;
    if !(x.is_finite() && (-1.5..=2.5).contains(&x)) {
        fail("profile_shift", x.to_string(), "must lie between -1.5 and 2.5 (profile shift coefficient x)");
    }
    if !(gd.addendum_factor.is_finite() && gd.addendum_factor > 0.0 && gd.addendum_factor <= 2.0) {
        fail(
            "addendum_factor",
            gd.addendum_factor.to_string(),
            "must lie above 0 and at most 2 (basic rack addendum factor h_aP*; ISO 53: 1)",
        );
    }
    if !(gd.dedendum_factor.is_finite() && gd.dedendum_factor > 0.0 && gd.dedendum_factor <= 2.5) {
        fail(
            "dedendum_factor",
            gd.dedendum_factor.to_string(),
            "must lie above 0 and at most 2.5 (basic rack dedendum factor h_fP*; ISO 53: 1.25)",
        );
    }
    let rho = gd.tool_tip_radius_factor;
    if !(rho.is_finite() && rho > 0.0 && rho < 1.0) {
        fail(
            "tool_tip_radius_factor",
            rho.to_string(),
            "must lie above 0 and below 1 (tool tip radius factor ρ_fP*; ISO 53: 0.38)",
        );
    }
    let a = gd.tooth_thickness_allowance;
    let limit = if module.is_finite() && module > 0.0 { 0.5 * module } else { f64::INFINITY };
    if !(a.is_finite() && a <= 0.0 && a > -limit) {
        fail(
            "tooth_thickness_allowance_mm",
            m_to_mm(a).to_string(),
            &format!(
                "must be zero or negative and above -0.5·m = {:.4} mm (an allowance thins the tooth)",
                m_to_mm(-limit)
            ),
        );
    }
    for (field, d) in [("tip_diameter_mm", gd.tip_diameter), ("root_diameter_mm", gd.root_diameter)] {
        if let Some(d) = d {
            if !(d.is_finite() && d > 0.0) {
                fail(field, m_to_mm(d).to_string(), "must be a finite number greater than zero");
            }
        }
    }
}

/// Each mesh whose two gears are given by gear data must run at the
/// centre distance its profile shifts give (within
/// [`CENTRE_DISTANCE_TOLERANCE`]).
fn centre_distance(scene: &Scene, problems: &mut Vec<Problem>) {
    let (sun, planet, ring) = (&scene.sun, &scene.planet, &scene.ring);
    let (m, alpha) = (sun.module, sun.pressure_angle);
    let same = [planet.module, ring.module].iter().all(|v| *v == m)
        && [planet.pressure_angle, ring.pressure_angle].iter().all(|v| *v == alpha);
    if !(same && m.is_finite() && m > 0.0 && alpha.is_finite() && alpha > 0.0 && alpha < FRAC_PI_2) {
        return; // The rules of the radii name unequal or invalid modules and angles.
    }
    let a = scene.centre_distance;
    let tolerance_mm = m_to_mm(CENTRE_DISTANCE_TOLERANCE);
    if let (Some(gs), Some(gp)) = (sun.gear_data, planet.gear_data) {
        let (xs, xp) = (gs.profile_shift, gp.profile_shift);
        let aw = operating_centre_distance(m, sun.teeth, xs, planet.teeth, xp, alpha, false);
        if aw.is_finite() && (a - aw).abs() > CENTRE_DISTANCE_TOLERANCE {
            problems.push(Problem {
                name: "centre_distance_mm".into(),
                value: m_to_mm(a).to_string(),
                reason: format!(
                    "the profile shifts of sun and planet (x_sun + x_planet = {:.4}) give the operating centre \
                     distance a_w = {:.4} mm (inv α_w = inv α + 2·tan α·(x_sun + x_planet)/(z_sun + z_planet)); \
                     the centre distance must be it within {tolerance_mm} mm (backlash comes \
                     from the tooth-thickness allowances)",
                    xs + xp,
                    m_to_mm(aw)
                ),
            });
        }
    }
    if let (Some(gp), Some(gr)) = (planet.gear_data, ring.gear_data) {
        let (xp, xr) = (gp.profile_shift, gr.profile_shift);
        let aw = operating_centre_distance(m, planet.teeth, xp, ring.teeth, xr, alpha, true);
        if aw.is_finite() && (a - aw).abs() > CENTRE_DISTANCE_TOLERANCE {
            // The ring's shift that makes the internal mesh run at `a`.
            let zd = f64::from(ring.teeth) - f64::from(planet.teeth);
            let cos_w = m * zd / 2.0 * alpha.cos() / a;
            let fit = (cos_w.abs() <= 1.0)
                .then(|| xp + (inv(cos_w.acos()) - inv(alpha)) * zd / (2.0 * alpha.tan()))
                .map_or_else(String::new, |x| format!("; x_ring = {x:.4} gives it"));
            problems.push(Problem {
                name: "ring.gear_data.profile_shift".into(),
                value: xr.to_string(),
                reason: format!(
                    "the ring–planet mesh runs at a_w = {:.4} mm with these profile shifts \
                     (inv α_w = inv α + 2·tan α·(x_ring − x_planet)/(z_ring − z_planet)), not at \
                     centre_distance_mm = {} mm (within {tolerance_mm} mm){fit}",
                    m_to_mm(aw),
                    m_to_mm(a)
                ),
            });
        }
    }
}

/// A problem found in a derived radius, named by the gear-data key it came
/// from (`sun.tip_radius_mm` → `sun.gear_data.addendum_factor`, or
/// `sun.gear_data.tip_diameter_mm` when that is given), the derived value
/// kept beside the gear data's.
pub fn name_by_gear_data(problem: Problem, scene: &Scene) -> Problem {
    let Some((gear, field)) = problem.name.split_once('.') else { return problem };
    let gd = match gear {
        "sun" => scene.sun.gear_data,
        "planet" => scene.planet.gear_data,
        "ring" => scene.ring.gear_data,
        _ => None,
    };
    let Some(gd) = gd else { return problem };
    if problem.reason.contains("is given by its gear data") {
        return problem; // A radius field set beside the gear data: its own key.
    }
    let (key, value) = match field {
        "tooth_thickness_mm" => ("tooth_thickness_allowance_mm", m_to_mm(gd.tooth_thickness_allowance)),
        "tip_radius_mm" | "minor_radius_mm" => match gd.tip_diameter {
            Some(d) => ("tip_diameter_mm", m_to_mm(d)),
            None => ("addendum_factor", gd.addendum_factor),
        },
        "root_radius_mm" => match gd.root_diameter {
            Some(d) => ("root_diameter_mm", m_to_mm(d)),
            None => ("dedendum_factor", gd.dedendum_factor),
        },
        "hob_tip_radius_mm" | "fillet_radius_mm" => ("tool_tip_radius_factor", gd.tool_tip_radius_factor),
        _ => return problem,
    };
    Problem {
        name: format!("{gear}.gear_data.{key}"),
        value: format!(
            "{value} (with profile shift {}: {} = {})",
            gd.profile_shift, problem.name, problem.value
        ),
        reason: problem.reason,
    }
}

/// Margin \[rad\] against trochoid (tip) interference of an internal mesh,
/// planet `p` in ring `r` at centre distance `a`: the planet's tip corner,
/// leaving mesh, must pass the ring's tip corner, θ₁·z_p/z_r + inv α_w −
/// inv α_a,r − θ₂ ≥ 0 with θ₁ = acos((r_a,r² − r_a,p² − a²)/(2·a·r_a,p)) +
/// inv α_a,p − inv α_w and θ₂ = acos((a² + r_a,r² − r_a,p²)/(2·a·r_a,r))
/// (the condition of the gear handbooks for internal gears, docs/GEAR_DATA.md).
/// `None` when the tip circles do not cross (then the tips never meet).
pub fn trochoid_margin(p: &ToothForm, r: &ToothForm, a: f64) -> Option<f64> {
    let (rap, rar) = (p.tip_radius, r.tip_radius);
    let (rbp, rbr) = (p.base_radius(), r.base_radius());
    let aw = ((rbr - rbp) / a).clamp(-1.0, 1.0).acos();
    let c1 = (rar * rar - rap * rap - a * a) / (2.0 * a * rap);
    let c2 = (a * a + rar * rar - rap * rap) / (2.0 * a * rar);
    if !(c1.abs() <= 1.0 && c2.abs() <= 1.0) || rap <= rbp || rar <= rbr {
        return None;
    }
    let inv_ap = inv((rbp / rap).acos());
    let inv_ar = inv((rbr / rar).acos());
    let theta1 = c1.acos() + inv_ap - inv(aw);
    let theta2 = c2.acos();
    Some(theta1 * f64::from(p.teeth) / f64::from(r.teeth) + inv(aw) - inv_ar - theta2)
}
