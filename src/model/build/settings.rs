//! The scene's scalar keys: material, analysis grid, supports, inertia,
//! mesh stiffness scales, dynamics and run settings, operation. One function
//! per family of keys, each adding its problems to the [`Checker`].

use super::Checker;
use crate::model::gear::{ContactModel, Drive, Material, Member};
use crate::model::run::{RunSettings, RunValues, SteadyValues};
use crate::scene::units::{pa_to_gpa, rad_per_s_to_rpm, rpm_to_rad_per_s};
use crate::scene::{
    AnalysisSpec, DampingModel, DynamicsSpec, InertiaSpec, MaterialSpec, MeshStiffnessSpec, OperationSpec,
    Scene, SceneError, SupportSpec,
};

/// The material's elastic constants and density, in SI.
pub(super) fn material(m: &MaterialSpec, c: &mut Checker) -> Material {
    c.in_range(
        "material.youngs_modulus_gpa",
        pa_to_gpa(m.youngs_modulus),
        0.0,
        1.0e4,
        "an engineering metal or polymer",
    );
    c.in_range("material.poisson_ratio", m.poisson_ratio, 0.0, 0.5, "isotropic elastic material");
    c.positive("material.density_kg_per_m3", m.density_kg_per_m3);
    Material {
        youngs_modulus: m.youngs_modulus,
        poisson_ratio: m.poisson_ratio,
        density: m.density_kg_per_m3,
    }
}

/// The quasi-static analysis grid: positions per mesh cycle, profile points, face slices.
pub(super) fn check_analysis(a: &AnalysisSpec, c: &mut Checker) {
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
}

/// The bearing stiffnesses (positive), the damping ratios (at least 0,
/// below 1) and the per-planet stiffnesses, one per planet when given.
pub(super) fn check_supports(sp: &SupportSpec, planets: u32, c: &mut Checker) {
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
        if list.len() != planets as usize {
            c.fail(
                "supports.planet_bearings_n_per_m",
                format!("{list:?}"),
                format!("must list one stiffness per planet (planets.count = {planets})"),
            );
        }
        for (i, v) in list.iter().enumerate() {
            c.positive(&format!("supports.planet_bearings_n_per_m[{i}]"), *v);
        }
    }
}

/// The masses and moments of inertia the scene gives (positive).
pub(super) fn check_inertia(inertia: &InertiaSpec, c: &mut Checker) {
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
}

/// The correction factors on the energy method's pair stiffness.
pub(super) fn check_mesh_stiffness(ms: &MeshStiffnessSpec, c: &mut Checker) {
    for (name, v) in [
        ("mesh_stiffness.sun_planet_scale", ms.sun_planet_scale),
        ("mesh_stiffness.ring_planet_scale", ms.ring_planet_scale),
    ] {
        c.in_range(name, v, 0.1, 10.0, "a correction factor on the energy method's pair stiffness");
    }
}

/// The dynamics keys: mesh damping, Rayleigh coefficients, contact law,
/// shaft stiffness, and the run settings in SI with their rules.
pub(super) fn run_values(scene: &Scene, c: &mut Checker) -> RunValues {
    let d = &scene.dynamics;
    if !(d.mesh_damping_ratio.is_finite() && (0.0..1.0).contains(&d.mesh_damping_ratio)) {
        c.fail("dynamics.mesh_damping_ratio", d.mesh_damping_ratio, "must be at least 0 and below 1");
    }
    check_rayleigh(d, c);
    check_contact(scene, c);
    c.positive("dynamics.shaft_stiffness_nm_per_rad", d.shaft_stiffness_nm_per_rad);
    let run = RunValues {
        input_speed: d.input_speed,
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
            speed_step: d.steady_speed_step,
            torque_step: d
                .steady_torque_step_nm
                .unwrap_or(crate::scene::STEADY_TORQUE_STEP * scene.operation.input_torque_nm.abs()),
            speed_floor: d.steady_speed_floor,
            agreement: d.steady_agreement,
            refinements: d.steady_refinements,
            sample_phase: 0.0,
        },
    };
    check_run_settings(&run, c);
    if let (Some(x), false) = (d.steady_torque_step_nm, d.response == crate::scene::Response::Steady) {
        if !(x.is_finite() && (1e-3..=1e7).contains(&x)) {
            c.fail("dynamics.steady_torque_step_nm", x, "must lie between 1e-3 and 1e7 N·m");
        }
    }
    run
}

/// The operating point: input and held member differ, the speed-driven
/// member fits the drive, the input torque is finite.
pub(super) fn check_operation(d: &DynamicsSpec, op: &OperationSpec, c: &mut Checker) {
    if op.held == op.input {
        c.fail(
            "operation.input",
            op.input.name(),
            format!("must differ from the held member ({})", op.held.name()),
        );
    }
    check_speed_driven_member(d, op, c);
    if !op.input_torque_nm.is_finite() {
        c.fail("operation.input_torque_nm", op.input_torque_nm, "must be a finite number");
    }
}

/// Largest input speed magnitude a scene may give \[rpm\].
const MAX_INPUT_SPEED_RPM: f64 = 1.0e6;

/// The input-speed rule: a finite speed of at most [`MAX_INPUT_SPEED_RPM`] in
/// magnitude, checked in rad/s, shown in rpm (the scene key's unit) as the
/// user wrote it.
fn check_input_speed(omega: f64, c: &mut Checker) {
    if !(omega.is_finite() && omega.abs() <= rpm_to_rad_per_s(MAX_INPUT_SPEED_RPM)) {
        c.fail(
            "dynamics.input_speed_rpm",
            rad_per_s_to_rpm(omega),
            "must be a finite speed below 1e6 rpm in magnitude",
        );
    }
}

/// Every rule of the run settings, each problem named by its scene key (the
/// input speed shown in rpm, as the scene gives it). Shared by
/// [`Scene::validate`] and [`RunSettings::new`].
fn check_run_settings(d: &RunValues, c: &mut Checker) {
    check_input_speed(d.input_speed, c);
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
        check_run_settings(&values, &mut c);
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
fn check_speed_driven_member(d: &DynamicsSpec, op: &OperationSpec, c: &mut Checker) {
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
fn check_rayleigh(d: &DynamicsSpec, c: &mut Checker) {
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
