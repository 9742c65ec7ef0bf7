//! Plausibility checks of a run (docs/FMU.md, "Messages"): figures that the
//! equations compute without complaint but that no real gear set of this
//! kind survives or that betray a mistake in the input — an overspeed, a
//! member running away from unbalanced torques, teeth separating for a
//! large part of the mesh cycle, a contact pressure past the material's
//! allowable. The thresholds and checks live here once; the FMU
//! (`fmi/instance/warnings.rs`) and the command line word them for their users.
//!
//! A check returns `None` when the figure is plausible and otherwise the
//! sentence that says what was seen, the threshold and why it matters.

use crate::contact::hertz::{contact_modulus, line_contact};
use crate::dynamics::response::SteadyState;
use crate::model::gear::{GearKind, GearSet, MeshKind};
use crate::scene::units::rad_per_s_to_rpm;

/// Highest pitch-line velocity of the sun–planet mesh \[m/s\] (in the
/// carrier's frame, |ω_sun − ω_carrier|·r_sun): 40 m/s, the upper end of
/// what ground, case-hardened spur gears of ISO 1328 grade 5–6 are run at
/// (beyond it the dynamic factor, scuffing and the lubricant's film, which
/// this model does not describe, decide the design).
pub const MAX_PITCH_LINE_VELOCITY: f64 = 40.0;

/// Fraction of the mesh cycle with a mesh force of zero (teeth separated)
/// above which a run is reported: 5 %. Brief separation at a resonance is
/// what the model is made to show; a mesh that is unloaded for a twentieth
/// of its cycle rattles and its impacts are beyond a design point.
pub const MAX_SEPARATION_FRACTION: f64 = 0.05;

/// Contact-fatigue endurance limit of case-hardened steel of quality MQ
/// \[Pa\] (ISO 6336-5: σ_Hlim = 1500 MPa).
pub const ENDURANCE_HERTZ_PRESSURE: f64 = 1500.0e6;

/// Life factor of case-hardened steel at static load (ISO 6336-2, Z_NT for
/// 10⁵ load cycles or fewer) [-].
pub const STATIC_LIFE_FACTOR: f64 = 1.6;

/// Allowable Hertz pressure of an instantaneous mesh force \[Pa\]: the
/// static limit σ_Hlim·Z_NT = 1500 MPa × 1.6 = 2400 MPa. The instant a check
/// sees is compared with the limit of a few load cycles, not with the
/// endurance limit (which the example's nominal load already passes: its
/// LTCA peak is 1821 MPa, the estimate 1709 MPa, and it wears by design).
pub const ALLOWABLE_HERTZ_PRESSURE: f64 = ENDURANCE_HERTZ_PRESSURE * STATIC_LIFE_FACTOR;

/// Fraction of its reference speed by which the torques given may change
/// the input member's rigid-body speed before a run is reported as running
/// away: 10 %.
pub const MAX_SPEED_DRIFT: f64 = 0.10;

/// Smallest rigid-body speed change reported \[rad/s\] (about 95 rpm), so
/// that a run started at rest is not reported for a small imbalance.
pub const MIN_SPEED_DRIFT: f64 = 10.0;

/// The fraction of its threshold a figure must fall below before a
/// condition counts as cleared and may be reported again: 0.9.
pub const CLEAR_MARGIN: f64 = 0.9;

/// The sun–planet mesh's pitch-line velocity \[m/s\] at the speeds of sun
/// and carrier \[rad/s\].
pub fn pitch_line_velocity(set: &GearSet, sun_speed: f64, carrier_speed: f64) -> f64 {
    (sun_speed - carrier_speed).abs() * set.sun().reference_radius()
}

/// The overspeed check at the speeds of sun and carrier.
pub fn overspeed(set: &GearSet, sun_speed: f64, carrier_speed: f64, margin: f64) -> Option<String> {
    let v = pitch_line_velocity(set, sun_speed, carrier_speed);
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(v > margin * MAX_PITCH_LINE_VELOCITY) {
        return None;
    }
    Some(format!(
        "overspeed: the sun–planet pitch-line velocity is {v:.4e} m/s (sun {:.6e} rpm, carrier {:.6e} rpm), \
         above the limit of {MAX_PITCH_LINE_VELOCITY} m/s for ground, case-hardened gears: the results \
         describe no gear set that could run there",
        rad_per_s_to_rpm(sun_speed),
        rad_per_s_to_rpm(carrier_speed)
    ))
}

/// The members' speeds of the one rigid-body rotation a set with a held
/// member has, per unit speed of the input member (sun, ring, carrier):
/// the held member's is zero and r_sun ω_sun + r_ring ω_ring =
/// (r_sun + r_ring) ω_carrier, with the ring's radius signed as its
/// balanced torque (gear.rs `balanced_torques`).
pub fn rigid_body_ratios(set: &GearSet) -> [f64; 3] {
    let a = [
        set.sun().base_radius(),
        set.ring().base_radius(),
        -(set.sun().base_radius() + set.ring().base_radius()),
    ];
    let (i, o) = (set.input().index(), set.output().index());
    let mut u = [0.0; 3];
    u[i] = 1.0;
    u[o] = -a[i] / a[o];
    u
}

/// The torque imbalance of external torques (sun, ring, carrier) \[N·m\]:
/// the net torque on the rigid-body rotation referred to the input member
/// \[N·m\] and the angular acceleration of the input member it causes
/// \[rad/s²\] (the rotation's inertia: the three members, the planets'
/// spin and their orbit with the carrier). Balanced torques give zero.
pub fn torque_imbalance(set: &GearSet, torques: [f64; 3]) -> (f64, f64) {
    let u = rigid_body_ratios(set);
    let net: f64 = torques.iter().zip(u).map(|(t, v)| t * v).sum();
    let b = set.bodies();
    let n = set.planet_angles().len() as f64;
    // The planet's spin relative to the carrier: −(r_sun / r_planet)(ω_sun − ω_carrier).
    let spin = u[2] - set.sun().base_radius() / set.planet().base_radius() * (u[0] - u[2]);
    let inertia = b.sun.inertia * u[0] * u[0]
        + b.ring.inertia * u[1] * u[1]
        + b.carrier.inertia * u[2] * u[2]
        + n * (b.planet.inertia * spin * spin + b.planet.mass * (set.centre_distance() * u[2]).powi(2));
    (net, net / inertia)
}

/// The run-away check. `drift` \[rad/s\] is the change of the input
/// member's rigid-body speed that the torques given have caused since it
/// started from (or was stepped to) `reference` \[rad/s\]: the
/// acceleration of [`torque_imbalance`] integrated over the steps; a
/// steady state needs it near zero. `speed` is the speed seen \[rad/s\],
/// `torques` the external torques given now (sun, ring, carrier) \[N·m\].
pub fn speed_drift(
    set: &GearSet,
    drift: f64,
    speed: f64,
    reference: f64,
    torques: [f64; 3],
    margin: f64,
) -> Option<String> {
    let allowed = (MAX_SPEED_DRIFT * reference.abs()).max(MIN_SPEED_DRIFT);
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(drift.abs() > margin * allowed) {
        return None;
    }
    let (net, accel) = torque_imbalance(set, torques);
    let name = set.input().name();
    let [s, r, c] = torques;
    Some(format!(
        "run-away: the torques given (sunTorque = {s} N·m, ringTorque = {r} N·m, carrierTorque = {c} N·m) \
         leave a net torque of {net:.4} N·m on the rigid-body rotation (referred to the {name}), an \
         acceleration of {accel:.4e} rad/s²; they have changed the {name}'s speed by {:.1} rpm from the \
         {:.1} rpm it started from or was stepped to, more than {:.0} % (at least {:.1} rpm), and it now \
         turns at {:.1} rpm: there is no steady state; balance the torques (docs/FMU.md) or drive the \
         speed (driveMode = 1)",
        rad_per_s_to_rpm(drift),
        rad_per_s_to_rpm(reference),
        100.0 * MAX_SPEED_DRIFT,
        rad_per_s_to_rpm(MIN_SPEED_DRIFT),
        rad_per_s_to_rpm(speed),
    ))
}

/// The separation check of a mesh of planet number `planet` (as its front
/// end counts): `fraction` of the mesh cycle with the mesh force zero.
pub fn separation(planet: usize, mesh: MeshKind, fraction: f64, margin: f64) -> Option<String> {
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(fraction > margin * MAX_SEPARATION_FRACTION) {
        return None;
    }
    Some(format!(
        "tooth separation: planet {planet}'s {} mesh carries no force for {:.1} % of the mesh cycle, above \
         the threshold of {:.0} %: the teeth lose contact and strike again (rattle), beyond a design point",
        mesh.name(),
        100.0 * fraction,
        100.0 * MAX_SEPARATION_FRACTION
    ))
}

/// The estimate of the peak Hertz pressure of a mesh force \[Pa\]: the
/// whole force `force` \[N\] on one tooth pair over the face width, a line
/// contact at the operating pitch point (radii of curvature r_w sin α_w of
/// both flanks, the ring's concave). A cheap bound for every step: the
/// quasi-static LTCA (`planetwear ltca`) resolves the load sharing among
/// pairs, the position along the path and the face slices.
pub fn hertz_pressure_estimate(set: &GearSet, mesh: MeshKind, force: f64) -> f64 {
    let (g1, g2) = set.mesh_gears(mesh);
    let alpha = set.operating_pressure_angle(mesh);
    let ratio = f64::from(g2.teeth) / f64::from(g1.teeth);
    // Operating pitch radius of gear 1: a / (u ± 1); gear 2's is u times it.
    let r1 = match g2.kind {
        GearKind::External => set.centre_distance() / (ratio + 1.0),
        GearKind::Internal => set.centre_distance() / (ratio - 1.0),
    };
    let (rho1, rho2) = (r1 * alpha.sin(), ratio * r1 * alpha.sin());
    let m = set.material();
    let e = contact_modulus(m.youngs_modulus, m.poisson_ratio, m.youngs_modulus, m.poisson_ratio);
    let width = g1.face_width.min(g2.face_width);
    line_contact(force.abs() / width, rho1, rho2, g2.kind == GearKind::Internal, e).peak_pressure
}

/// The contact-pressure check of a mesh force \[N\] of planet number
/// `planet` (as its front end counts).
pub fn contact_pressure(
    set: &GearSet,
    planet: usize,
    mesh: MeshKind,
    force: f64,
    margin: f64,
) -> Option<String> {
    let p = hertz_pressure_estimate(set, mesh, force);
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(p > margin * ALLOWABLE_HERTZ_PRESSURE) {
        return None;
    }
    Some(format!(
        "contact pressure: planet {planet}'s {} mesh force of {force:.1} N gives an estimated Hertz pressure of \
         {:.0} MPa (the whole force on one pair at the pitch point), above the static limit of {:.0} MPa \
         of case-hardened steel (σ_Hlim 1500 MPa × Z_NT 1.6, ISO 6336-2/-5): the flanks are overloaded",
        mesh.name(),
        p / 1e6,
        ALLOWABLE_HERTZ_PRESSURE / 1e6
    ))
}

/// A condition a steady state sets off, and what to say of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    /// The condition: `overspeed`, or `separation`/`pressure` and the mesh.
    pub condition: String,
    /// The sentence for the user.
    pub message: String,
}

/// The checks of a steady state: the overspeed at its input speed, and for
/// each mesh the separation and the largest force of its worst planet
/// (planets numbered as the steady state numbers them).
pub fn steady_state(set: &GearSet, ss: &SteadyState) -> Vec<Finding> {
    let mut out = Vec::new();
    if let Some(m) = overspeed_at_input(set, ss.input_speed) {
        out.push(Finding { condition: "overspeed".into(), message: m });
    }
    for mesh in MeshKind::ALL {
        let of_mesh = || ss.meshes.iter().filter(move |m| m.mesh == mesh);
        if let Some(m) = of_mesh().max_by(|a, b| a.separation.total_cmp(&b.separation)) {
            if let Some(msg) = separation(m.planet, mesh, m.separation, 1.0) {
                out.push(Finding { condition: format!("separation {}", mesh.name()), message: msg });
            }
        }
        if let Some(m) = of_mesh().max_by(|a, b| a.max_force.abs().total_cmp(&b.max_force.abs())) {
            if let Some(msg) = contact_pressure(set, m.planet, mesh, m.max_force, 1.0) {
                out.push(Finding { condition: format!("pressure {}", mesh.name()), message: msg });
            }
        }
    }
    out
}

/// The overspeed check of the rigid-body rotation at the input member's
/// speed \[rad/s\].
pub fn overspeed_at_input(set: &GearSet, input_speed: f64) -> Option<String> {
    let u = rigid_body_ratios(set);
    overspeed(set, u[0] * input_speed, u[2] * input_speed, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    fn set() -> GearSet {
        Scene::example_2004().validate().unwrap()
    }

    #[test]
    fn the_balanced_torques_have_no_imbalance_and_others_do() {
        let s = set();
        let (net, accel) = torque_imbalance(&s, s.balanced_torques());
        assert!(net.abs() < 1e-9 * s.input_torque().abs(), "{net}");
        assert!(accel.abs() < 1e-6, "{accel}");
        let mut t = s.balanced_torques();
        t[0] *= 0.4;
        let (net, accel) = torque_imbalance(&s, t);
        assert!(net < -100.0 && accel < -100.0, "{net} {accel}");
    }

    #[test]
    fn the_rigid_body_rotation_has_the_held_member_still_and_the_willis_relation() {
        let s = set();
        let u = rigid_body_ratios(&s);
        let (rs, rr) = (s.sun().base_radius(), s.ring().base_radius());
        assert!((rs * u[0] + rr * u[1] - (rs + rr) * u[2]).abs() < 1e-15);
        assert_eq!(u[s.held().index()], 0.0);
    }

    #[test]
    fn each_check_fires_above_its_threshold_only() {
        let s = set();
        let r = s.sun().reference_radius();
        assert!(overspeed(&s, 0.99 * MAX_PITCH_LINE_VELOCITY / r, 0.0, 1.0).is_none());
        let m = overspeed(&s, 1.01 * MAX_PITCH_LINE_VELOCITY / r, 0.0, 1.0).unwrap();
        assert!(overspeed(&s, 0.91 * MAX_PITCH_LINE_VELOCITY / r, 0.0, CLEAR_MARGIN).is_some());
        assert!(m.contains("4.0400e1 m/s"), "{m}");
        assert!(separation(1, MeshKind::SunPlanet, 0.05, 1.0).is_none());
        assert!(separation(1, MeshKind::RingPlanet, 0.06, 1.0).unwrap().contains("6.0 %"));
        assert!(speed_drift(&s, 31.0, 330.0, 314.0, s.balanced_torques(), 1.0).is_none());
        assert!(speed_drift(&s, 9.9, 5.0, 0.0, s.balanced_torques(), 1.0).is_none());
        assert!(speed_drift(&s, -32.0, 250.0, 314.0, s.balanced_torques(), 1.0)
            .unwrap()
            .contains("run-away"));
        // The pressure estimate grows with the square root of the force.
        let p1 = hertz_pressure_estimate(&s, MeshKind::SunPlanet, 1000.0);
        let p4 = hertz_pressure_estimate(&s, MeshKind::SunPlanet, 4000.0);
        assert!((p4 / p1 - 2.0).abs() < 1e-12);
        // The internal mesh's concave flank spreads the contact.
        assert!(hertz_pressure_estimate(&s, MeshKind::RingPlanet, 1000.0) < p1);
        let limit_force = 1000.0 * (ALLOWABLE_HERTZ_PRESSURE / p1).powi(2);
        assert!(contact_pressure(&s, 1, MeshKind::SunPlanet, 0.99 * limit_force, 1.0).is_none());
        assert!(contact_pressure(&s, 1, MeshKind::SunPlanet, 1.01 * limit_force, 1.0).is_some());
    }
}
