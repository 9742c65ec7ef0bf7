//! From the FMU's settable variables to a scene, and back from a scene's
//! problems to the variables the importer set.
//!
//! The FMU's parameters are SI (m, rad, Pa); the scene is the edge format
//! the command line reads (mm, degrees, GPa) and `Scene::validate` is the
//! one model constructor both front ends use. [`apply`] is a `match` over
//! the generated [`Settable`] enum without a catch-all arm, so a variable
//! added to `modelDescription/variables.toml` does not compile until it is
//! given its effect here; [`scene_keys`] is the same for the scene keys a
//! variable writes, which name a validation problem by the variable the
//! importer set ([`describe_problem`]).

use std::collections::BTreeMap;

use crate::fmi::variables::{Settable, Start, Variable};
use crate::model::gear::{Drive, IntegratorKind, Member};
use crate::model::lumped::Fidelity;
use crate::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use crate::scene::Response;
use crate::scene::{default_chamfer, ChamferSpec, GearData, PlanetLayoutSpec, Problem, Scene, SceneError};

/// The values the importer holds, read by variable.
pub(super) struct Values<'a> {
    /// Real values by value reference.
    pub reals: &'a BTreeMap<u32, f64>,
    /// Integer values by value reference.
    pub integers: &'a BTreeMap<u32, i32>,
}

impl Values<'_> {
    fn real(&self, v: Variable) -> f64 {
        self.reals.get(&v.value_reference()).copied().unwrap_or(0.0)
    }

    fn int(&self, v: Variable) -> i32 {
        self.integers.get(&v.value_reference()).copied().unwrap_or(0)
    }

    fn mm(&self, v: Variable) -> f64 {
        self.real(v) * 1e3
    }

    fn count(&self, v: Variable) -> Result<u32, String> {
        let x = self.int(v);
        u32::try_from(x).map_err(|_| format!("{} = {x}: must not be negative", v.name()))
    }

    /// A mass or inertia: 0 means "derived from the geometry".
    fn derived_if_zero(&self, v: Variable) -> Option<f64> {
        let x = self.real(v);
        (x != 0.0).then_some(x)
    }
}

fn member(v: Variable, code: i32) -> Result<Member, String> {
    match code {
        0 => Ok(Member::Sun),
        1 => Ok(Member::Ring),
        2 => Ok(Member::Carrier),
        other => Err(format!("{} = {other}: allowed are 0 (sun), 1 (ring), 2 (carrier)", v.name())),
    }
}

/// Writes the effect of one settable variable into `scene`, or says why its
/// value is not allowed. Variables that do not describe the gear set (the
/// files, the inputs, the initial speed, the output window) have none here
/// and are read where they act.
pub(super) fn apply(p: Settable, values: &Values, scene: &mut Scene) -> Result<(), String> {
    let v = p.variable();
    let r = values.real(v);
    match p {
        // Read before the scene exists (it chooses the scene) and by the
        // contact model (the worn flanks).
        Settable::SceneFile | Settable::WearStateFile | Settable::WearStateAccept => {}
        // The load duty's bins, read when the simulation is built.
        Settable::DutyTorqueEdges | Settable::DutySpeedEdges => {}
        // The simulation's initial state, set when it is built; also the
        // run's input speed, so that the scene's speed rule names it.
        Settable::InitialSpeed => {
            scene.dynamics.input_speed_rpm = crate::scene::units::rad_per_s_to_rpm(r);
        }
        // Inputs act on the running simulation; the input member's torque
        // also sets the scene's operating load ([`input_torque`]).
        Settable::SunTorque
        | Settable::RingTorque
        | Settable::CarrierTorque
        | Settable::InputSpeedReference => {}
        Settable::Fidelity => {
            let (fidelity, response) = match values.int(v) {
                0 => (Fidelity::Torsional, Response::Time),
                1 => (Fidelity::TransverseTorsional, Response::Time),
                2 => (Fidelity::Torsional, Response::Steady),
                3 => (Fidelity::TransverseTorsional, Response::Steady),
                x => {
                    return Err(format!(
                        "fidelity = {x}: allowed are 0 (torsional), 1 (transverse-torsional), \
                         2 (steady, torsional), 3 (steady, transverse-torsional)"
                    ))
                }
            };
            (scene.dynamics.fidelity, scene.dynamics.response) = (fidelity, response);
        }
        Settable::HeldMember => scene.operation.held = member(v, values.int(v))?,
        Settable::InputMember => scene.operation.input = member(v, values.int(v))?,
        Settable::SpeedDrivenMember => {
            scene.dynamics.speed_driven_member = match values.int(v) {
                -1 => None,
                code => Some(member(v, code).map_err(|e| format!("{e}, or -1 (the input member)"))?),
            }
        }
        Settable::DriveMode => {
            scene.dynamics.drive = match values.int(v) {
                0 => Drive::Torque,
                1 => Drive::Speed,
                2 => Drive::SpeedSteps,
                x => {
                    return Err(format!(
                        "driveMode = {x}: allowed are 0 (torque), 1 (speed through the input shaft), \
                         2 (torque, with speed steps to each new inputSpeedReference)"
                    ))
                }
            }
        }
        Settable::Integrator => {
            scene.dynamics.integrator = match values.int(v) {
                0 => IntegratorKind::GeneralizedAlpha,
                1 => IntegratorKind::Rk45,
                x => {
                    return Err(format!(
                        "integrator = {x}: allowed are 0 (generalized-alpha), 1 (Runge-Kutta 5(4))"
                    ))
                }
            }
        }
        Settable::StepsPerMeshCycle => scene.dynamics.steps_per_mesh_cycle = values.count(v)?,
        Settable::RhoInfinity => scene.dynamics.rho_infinity = r,
        Settable::RelativeTolerance => scene.dynamics.simulation_relative_tolerance = r,
        // The order-tracking window of the outputs, read when the simulation is built.
        Settable::HarmonicWindowCycles => {}
        Settable::SamplesPerMeshCycle => scene.dynamics.samples_per_mesh_cycle = values.count(v)?,
        Settable::Planets => scene.planets = PlanetLayoutSpec { count: values.count(v)?, angles_deg: None },
        Settable::SunTeeth => scene.sun.teeth = values.count(v)?,
        Settable::PlanetTeeth => scene.planet.teeth = values.count(v)?,
        Settable::RingTeeth => scene.ring.teeth = values.count(v)?,
        Settable::Module => {
            let m = values.mm(v);
            scene.sun.module_mm = m;
            scene.planet.module_mm = m;
            scene.ring.module_mm = m;
        }
        Settable::PressureAngle => {
            let d = r.to_degrees();
            scene.sun.pressure_angle_deg = d;
            scene.planet.pressure_angle_deg = d;
            scene.ring.pressure_angle_deg = d;
        }
        Settable::FaceWidth => {
            let w = values.mm(v);
            scene.sun.face_width_mm = w;
            scene.planet.face_width_mm = w;
            scene.ring.face_width_mm = w;
        }
        Settable::CentreDistance => scene.centre_distance_mm = values.mm(v),
        Settable::SunToothThickness => scene.sun.tooth_thickness_mm = values.mm(v),
        Settable::PlanetToothThickness => scene.planet.tooth_thickness_mm = values.mm(v),
        Settable::RingToothThickness => scene.ring.tooth_thickness_mm = values.mm(v),
        Settable::SunTipRadius => scene.sun.tip_radius_mm = values.mm(v),
        Settable::SunRootRadius => scene.sun.root_radius_mm = values.mm(v),
        Settable::SunBoreRadius => scene.sun.bore_radius_mm = values.mm(v),
        Settable::PlanetTipRadius => scene.planet.tip_radius_mm = values.mm(v),
        Settable::PlanetRootRadius => scene.planet.root_radius_mm = values.mm(v),
        Settable::PlanetBoreRadius => scene.planet.bore_radius_mm = values.mm(v),
        Settable::RingMinorRadius => scene.ring.minor_radius_mm = values.mm(v),
        Settable::RingRootRadius => scene.ring.root_radius_mm = values.mm(v),
        Settable::RingRimRadius => scene.ring.rim_radius_mm = values.mm(v),
        Settable::HobTipRadius => {
            scene.sun.hob_tip_radius_mm = values.mm(v);
            scene.planet.hob_tip_radius_mm = values.mm(v);
        }
        Settable::RingFilletRadius => scene.ring.fillet_radius_mm = values.mm(v),
        // Height and angle make one chamfer: either sets both from the
        // current values. The edge's reading (whether it carries load, its
        // rounding) stays the scene's.
        Settable::TipChamferHeight | Settable::TipChamferAngle => {
            let h = values.mm(Variable::TipChamferHeight);
            let a = values.real(Variable::TipChamferAngle).to_degrees();
            let set = |c: Option<ChamferSpec>| {
                Some(ChamferSpec { height_mm: h, angle_deg: a, ..c.unwrap_or(ChamferSpec::new(h, a)) })
            };
            scene.sun.tip_chamfer = set(scene.sun.tip_chamfer);
            scene.planet.tip_chamfer = set(scene.planet.tip_chamfer);
        }
        Settable::YoungsModulus => scene.material.youngs_modulus_gpa = r * 1e-9,
        Settable::PoissonRatio => scene.material.poisson_ratio = r,
        Settable::Density => scene.material.density_kg_per_m3 = r,
        Settable::SunInertia => scene.inertia.sun_inertia_kg_m2 = values.derived_if_zero(v),
        Settable::PlanetInertia => scene.inertia.planet_inertia_kg_m2 = values.derived_if_zero(v),
        Settable::RingInertia => scene.inertia.ring_inertia_kg_m2 = values.derived_if_zero(v),
        Settable::CarrierInertia => scene.inertia.carrier_inertia_kg_m2 = values.derived_if_zero(v),
        Settable::SunMass => scene.inertia.sun_mass_kg = values.derived_if_zero(v),
        Settable::PlanetMass => scene.inertia.planet_mass_kg = values.derived_if_zero(v),
        Settable::RingMass => scene.inertia.ring_mass_kg = values.derived_if_zero(v),
        Settable::CarrierMass => scene.inertia.carrier_mass_kg = values.derived_if_zero(v),
        Settable::SunBearingStiffness => scene.supports.sun_radial_n_per_m = r,
        Settable::RingBearingStiffness => scene.supports.ring_radial_n_per_m = r,
        Settable::CarrierBearingStiffness => scene.supports.carrier_radial_n_per_m = r,
        Settable::PlanetBearingStiffness => scene.supports.planet_bearing_n_per_m = r,
        Settable::BearingDampingRatio => scene.supports.bearing_damping_ratio = r,
        Settable::MeshDampingRatio => scene.dynamics.mesh_damping_ratio = r,
        Settable::ShaftStiffness => scene.dynamics.shaft_stiffness_nm_per_rad = r,
        Settable::SteadySpeedStep => scene.dynamics.steady_speed_step_rpm = rad_per_s_to_rpm(r),
        Settable::SteadyTorqueStep => scene.dynamics.steady_torque_step_nm = Some(r),
        Settable::SteadyAgreement => scene.dynamics.steady_agreement = r,
        // Gear data (ISO 21771): every one of them writes the three gears'
        // gear data from the current values when gearData = 1.
        Settable::GearData
        | Settable::SunProfileShift
        | Settable::PlanetProfileShift
        | Settable::RingProfileShift
        | Settable::AddendumFactor
        | Settable::DedendumFactor
        | Settable::ToolTipRadiusFactor
        | Settable::RingToolTipRadiusFactor
        | Settable::SunToothThicknessAllowance
        | Settable::PlanetToothThicknessAllowance
        | Settable::RingToothThicknessAllowance
        | Settable::SunTipDiameter
        | Settable::PlanetTipDiameter
        | Settable::RingTipDiameter => gear_data(values, scene)?,
        Settable::LoadBalance => {
            scene.dynamics.load_balance = match values.int(v) {
                0 => false,
                1 => true,
                x => {
                    return Err(format!(
                        "loadBalance = {x}: allowed are 0 (the output loaded by its torque input), \
                         1 (load balance: a speed controller holds the output at its kinematic speed)"
                    ))
                }
            }
        }
    }
    Ok(())
}

/// With gearData = 1, sun, planet and ring given by their gear data from
/// the gear-data parameters (their radius fields cleared: the radius
/// parameters are not used); with 0, nothing.
fn gear_data(values: &Values, scene: &mut Scene) -> Result<(), String> {
    match values.int(Variable::GearData) {
        0 => return Ok(()),
        1 => {}
        x => {
            return Err(format!(
                "gearData = {x}: allowed are 0 (gears given by their radii), 1 (by gear data, ISO 21771)"
            ))
        }
    }
    let diameter = |v: Variable| {
        let d = values.mm(v);
        (d != 0.0).then_some(d)
    };
    let data = |x: Variable, rho: Variable, allowance: Variable, tip: Variable| GearData {
        profile_shift: values.real(x),
        addendum_factor: values.real(Variable::AddendumFactor),
        dedendum_factor: values.real(Variable::DedendumFactor),
        tool_tip_radius_factor: values.real(rho),
        tooth_thickness_allowance_mm: values.mm(allowance),
        tip_diameter_mm: diameter(tip),
        root_diameter_mm: None,
    };
    scene.sun.gear_data = Some(data(
        Variable::SunProfileShift,
        Variable::ToolTipRadiusFactor,
        Variable::SunToothThicknessAllowance,
        Variable::SunTipDiameter,
    ));
    scene.planet.gear_data = Some(data(
        Variable::PlanetProfileShift,
        Variable::ToolTipRadiusFactor,
        Variable::PlanetToothThicknessAllowance,
        Variable::PlanetTipDiameter,
    ));
    scene.ring.gear_data = Some(data(
        Variable::RingProfileShift,
        Variable::RingToolTipRadiusFactor,
        Variable::RingToothThicknessAllowance,
        Variable::RingTipDiameter,
    ));
    for g in [&mut scene.sun, &mut scene.planet] {
        (g.tooth_thickness_mm, g.tip_radius_mm, g.root_radius_mm, g.hob_tip_radius_mm) = (0.0, 0.0, 0.0, 0.0);
    }
    let r = &mut scene.ring;
    (r.tooth_thickness_mm, r.minor_radius_mm, r.root_radius_mm, r.fillet_radius_mm) = (0.0, 0.0, 0.0, 0.0);
    Ok(())
}

/// The value of every settable variable with a counterpart in `scene`, in
/// the variable's unit (SI): the inverse of the parameters → scene map the
/// instance applies, so that the FMU's parameters at these values describe
/// the scene's set. The torque inputs
/// are the set's balanced torques (the input torque on the input member);
/// initialSpeed and inputSpeedReference are the scene's input speed of a
/// single run (`dynamics.input_speed_rpm`). Variables without a counterpart
/// are left out: the files, wearStateAccept and harmonicWindowCycles (the
/// CLI measures over `dynamics.measured_revolutions` instead).
pub fn scene_values(scene: &Scene) -> Result<BTreeMap<Settable, Start>, SceneError> {
    let set = scene.validate()?;
    let torques = set.balanced_torques();
    let mut out = BTreeMap::new();
    let mm = |x: f64| Start::Real(x * 1e-3);
    let count = |x: u32| Start::Integer(i32::try_from(x).unwrap_or(i32::MAX));
    let code = |m: Member| match m {
        Member::Sun => Start::Integer(0),
        Member::Ring => Start::Integer(1),
        Member::Carrier => Start::Integer(2),
    };
    let optional = |x: Option<f64>| Start::Real(x.unwrap_or(0.0));
    let (d, g) = (&scene.dynamics, &scene.sun);
    let chamfer = g.tip_chamfer.unwrap_or_else(|| default_chamfer(g.module_mm));
    let speed = crate::scene::units::rpm_to_rad_per_s(d.input_speed_rpm);
    // The FMU gives either every gear by its radii or every gear by its
    // gear data (gearData); a scene that mixes the two forms has no
    // parameter set.
    let data = [&scene.sun.gear_data, &scene.planet.gear_data, &scene.ring.gear_data];
    let by_data = match data.iter().filter(|g| g.is_some()).count() {
        0 => None,
        3 => Some([data[0].unwrap_or_default(), data[1].unwrap_or_default(), data[2].unwrap_or_default()]),
        _ => {
            return Err(SceneError::Invalid {
                problems: vec![Problem {
                    name: "sun.gear_data, planet.gear_data, ring.gear_data".into(),
                    value: "some given, some not".into(),
                    reason:
                        "the FMU's parameters give all three gears by their radii or all three by gear data \
                             (gearData); write every gear in one form"
                            .into(),
                }],
            })
        }
    };
    // One addendum and one dedendum factor for all three gears, one hob tip
    // factor for sun and planets: the FMU's parameters hold no more.
    if let Some([sun, planet, ring]) = by_data {
        let shared = [
            ("addendum_factor", [sun.addendum_factor, planet.addendum_factor, ring.addendum_factor]),
            ("dedendum_factor", [sun.dedendum_factor, planet.dedendum_factor, ring.dedendum_factor]),
            (
                "tool_tip_radius_factor",
                [sun.tool_tip_radius_factor, planet.tool_tip_radius_factor, sun.tool_tip_radius_factor],
            ),
        ];
        for (key, [a, b, c]) in shared {
            if a != b || a != c {
                return Err(SceneError::Invalid {
                    problems: vec![Problem {
                        name: format!("sun.gear_data.{key}, planet.gear_data.{key}"),
                        value: format!("{a}, {b}, {c}"),
                        reason: "the FMU's parameters hold one value for the gears that share it \
                                 (docs/GEAR_DATA.md); give it alike"
                            .into(),
                    }],
                });
            }
        }
    }
    let diameter = |x: Option<f64>| Start::Real(x.map_or(0.0, |d| d * 1e-3));
    for p in Settable::ALL.iter().copied() {
        let value = match p {
            Settable::SceneFile
            | Settable::WearStateFile
            | Settable::WearStateAccept
            | Settable::DutyTorqueEdges
            | Settable::DutySpeedEdges
            | Settable::HarmonicWindowCycles => continue,
            Settable::GearData => Start::Integer(i32::from(by_data.is_some())),
            Settable::SpeedDrivenMember => d.speed_driven_member.map_or(Start::Integer(-1), code),
            Settable::SunProfileShift
            | Settable::PlanetProfileShift
            | Settable::RingProfileShift
            | Settable::AddendumFactor
            | Settable::DedendumFactor
            | Settable::ToolTipRadiusFactor
            | Settable::RingToolTipRadiusFactor
            | Settable::SunToothThicknessAllowance
            | Settable::PlanetToothThicknessAllowance
            | Settable::RingToothThicknessAllowance
            | Settable::SunTipDiameter
            | Settable::PlanetTipDiameter
            | Settable::RingTipDiameter => {
                // Unused with the radii form: their start values stand.
                let Some([sun, planet, ring]) = by_data else { continue };
                match p {
                    Settable::SunProfileShift => Start::Real(sun.profile_shift),
                    Settable::PlanetProfileShift => Start::Real(planet.profile_shift),
                    Settable::RingProfileShift => Start::Real(ring.profile_shift),
                    Settable::AddendumFactor => Start::Real(sun.addendum_factor),
                    Settable::DedendumFactor => Start::Real(sun.dedendum_factor),
                    Settable::ToolTipRadiusFactor => Start::Real(sun.tool_tip_radius_factor),
                    Settable::RingToolTipRadiusFactor => Start::Real(ring.tool_tip_radius_factor),
                    Settable::SunToothThicknessAllowance => mm(sun.tooth_thickness_allowance_mm),
                    Settable::PlanetToothThicknessAllowance => mm(planet.tooth_thickness_allowance_mm),
                    Settable::RingToothThicknessAllowance => mm(ring.tooth_thickness_allowance_mm),
                    Settable::SunTipDiameter => diameter(sun.tip_diameter_mm),
                    Settable::PlanetTipDiameter => diameter(planet.tip_diameter_mm),
                    _ => diameter(ring.tip_diameter_mm),
                }
            }
            Settable::InitialSpeed | Settable::InputSpeedReference => Start::Real(speed),
            Settable::SunTorque => Start::Real(torques[0]),
            Settable::RingTorque => Start::Real(torques[1]),
            Settable::CarrierTorque => Start::Real(torques[2]),
            Settable::Fidelity => Start::Integer(
                match d.fidelity {
                    Fidelity::Torsional => 0,
                    Fidelity::TransverseTorsional => 1,
                } + match d.response {
                    Response::Time => 0,
                    Response::Steady => 2,
                },
            ),
            Settable::HeldMember => code(scene.operation.held),
            Settable::InputMember => code(scene.operation.input),
            Settable::DriveMode => Start::Integer(match d.drive {
                Drive::Torque => 0,
                Drive::Speed => 1,
                Drive::SpeedSteps => 2,
            }),
            Settable::Integrator => Start::Integer(match d.integrator {
                IntegratorKind::GeneralizedAlpha => 0,
                IntegratorKind::Rk45 => 1,
            }),
            Settable::StepsPerMeshCycle => count(d.steps_per_mesh_cycle),
            Settable::RhoInfinity => Start::Real(d.rho_infinity),
            Settable::RelativeTolerance => Start::Real(d.simulation_relative_tolerance),
            Settable::SamplesPerMeshCycle => count(d.samples_per_mesh_cycle),
            Settable::Planets => count(scene.planets.count),
            Settable::SunTeeth => count(scene.sun.teeth),
            Settable::PlanetTeeth => count(scene.planet.teeth),
            Settable::RingTeeth => count(scene.ring.teeth),
            Settable::Module => mm(g.module_mm),
            Settable::PressureAngle => Start::Real(g.pressure_angle_deg.to_radians()),
            Settable::FaceWidth => mm(g.face_width_mm),
            Settable::CentreDistance => mm(scene.centre_distance_mm),
            Settable::SunToothThickness => mm(scene.sun.tooth_thickness_mm),
            Settable::PlanetToothThickness => mm(scene.planet.tooth_thickness_mm),
            Settable::RingToothThickness => mm(scene.ring.tooth_thickness_mm),
            Settable::SunTipRadius => mm(scene.sun.tip_radius_mm),
            Settable::SunRootRadius => mm(scene.sun.root_radius_mm),
            Settable::SunBoreRadius => mm(scene.sun.bore_radius_mm),
            Settable::PlanetTipRadius => mm(scene.planet.tip_radius_mm),
            Settable::PlanetRootRadius => mm(scene.planet.root_radius_mm),
            Settable::PlanetBoreRadius => mm(scene.planet.bore_radius_mm),
            Settable::RingMinorRadius => mm(scene.ring.minor_radius_mm),
            Settable::RingRootRadius => mm(scene.ring.root_radius_mm),
            Settable::RingRimRadius => mm(scene.ring.rim_radius_mm),
            Settable::HobTipRadius => mm(g.hob_tip_radius_mm),
            Settable::RingFilletRadius => mm(scene.ring.fillet_radius_mm),
            Settable::TipChamferHeight => mm(chamfer.height_mm),
            Settable::TipChamferAngle => Start::Real(chamfer.angle_deg.to_radians()),
            Settable::YoungsModulus => Start::Real(scene.material.youngs_modulus_gpa * 1e9),
            Settable::PoissonRatio => Start::Real(scene.material.poisson_ratio),
            Settable::Density => Start::Real(scene.material.density_kg_per_m3),
            Settable::SunInertia => optional(scene.inertia.sun_inertia_kg_m2),
            Settable::PlanetInertia => optional(scene.inertia.planet_inertia_kg_m2),
            Settable::RingInertia => optional(scene.inertia.ring_inertia_kg_m2),
            Settable::CarrierInertia => optional(scene.inertia.carrier_inertia_kg_m2),
            Settable::SunMass => optional(scene.inertia.sun_mass_kg),
            Settable::PlanetMass => optional(scene.inertia.planet_mass_kg),
            Settable::RingMass => optional(scene.inertia.ring_mass_kg),
            Settable::CarrierMass => optional(scene.inertia.carrier_mass_kg),
            Settable::SunBearingStiffness => Start::Real(scene.supports.sun_radial_n_per_m),
            Settable::RingBearingStiffness => Start::Real(scene.supports.ring_radial_n_per_m),
            Settable::CarrierBearingStiffness => Start::Real(scene.supports.carrier_radial_n_per_m),
            Settable::PlanetBearingStiffness => Start::Real(scene.supports.planet_bearing_n_per_m),
            Settable::BearingDampingRatio => Start::Real(scene.supports.bearing_damping_ratio),
            Settable::MeshDampingRatio => Start::Real(d.mesh_damping_ratio),
            Settable::ShaftStiffness => Start::Real(d.shaft_stiffness_nm_per_rad),
            Settable::SteadySpeedStep => Start::Real(rpm_to_rad_per_s(d.steady_speed_step_rpm)),
            Settable::SteadyTorqueStep => Start::Real(
                d.steady_torque_step_nm
                    .unwrap_or(crate::scene::STEADY_TORQUE_STEP * scene.operation.input_torque_nm.abs()),
            ),
            Settable::SteadyAgreement => Start::Real(d.steady_agreement),
            Settable::LoadBalance => Start::Integer(i32::from(d.load_balance)),
        };
        out.insert(p, value);
    }
    Ok(out)
}

/// The torque input of the scene's input member, which sets the operating
/// load of the mean-stiffness linearisation and the static transmission
/// error (the inputs themselves drive the simulation).
pub(super) fn input_torque(input: Member) -> Settable {
    match input {
        Member::Sun => Settable::SunTorque,
        Member::Ring => Settable::RingTorque,
        Member::Carrier => Settable::CarrierTorque,
    }
}

/// The scene keys a settable variable writes (as `Scene::validate` names
/// its problems). The input torques write `operation.input_torque_nm` when
/// they belong to the input member.
pub(super) fn scene_keys(p: Settable) -> &'static [&'static str] {
    match p {
        Settable::InitialSpeed => &["dynamics.input_speed_rpm"],
        Settable::SceneFile
        | Settable::WearStateFile
        | Settable::WearStateAccept
        | Settable::DutyTorqueEdges
        | Settable::DutySpeedEdges
        | Settable::InputSpeedReference
        | Settable::HarmonicWindowCycles => &[],
        Settable::SunTorque | Settable::RingTorque | Settable::CarrierTorque => {
            &["operation.input_torque_nm"]
        }
        Settable::Fidelity => &["dynamics.fidelity", "dynamics.response"],
        Settable::HeldMember => &["operation.held"],
        Settable::InputMember => &["operation.input"],
        Settable::DriveMode => &["dynamics.drive"],
        Settable::Integrator => &["dynamics.integrator"],
        Settable::StepsPerMeshCycle => &["dynamics.steps_per_mesh_cycle"],
        Settable::RhoInfinity => &["dynamics.rho_infinity"],
        Settable::RelativeTolerance => &["dynamics.simulation_relative_tolerance"],
        Settable::SamplesPerMeshCycle => &["dynamics.samples_per_mesh_cycle"],
        Settable::Planets => &["planets.count", "planets.angles_deg"],
        Settable::SunTeeth => &["sun.teeth"],
        Settable::PlanetTeeth => &["planet.teeth"],
        Settable::RingTeeth => &["ring.teeth"],
        Settable::Module => &["sun.module_mm", "planet.module_mm", "ring.module_mm"],
        Settable::PressureAngle => {
            &["sun.pressure_angle_deg", "planet.pressure_angle_deg", "ring.pressure_angle_deg"]
        }
        Settable::FaceWidth => &["sun.face_width_mm", "planet.face_width_mm", "ring.face_width_mm"],
        Settable::CentreDistance => &["centre_distance_mm"],
        Settable::SunToothThickness => &["sun.tooth_thickness_mm"],
        Settable::PlanetToothThickness => &["planet.tooth_thickness_mm"],
        Settable::RingToothThickness => &["ring.tooth_thickness_mm"],
        Settable::SunTipRadius => &["sun.tip_radius_mm"],
        Settable::SunRootRadius => &["sun.root_radius_mm"],
        Settable::SunBoreRadius => &["sun.bore_radius_mm"],
        Settable::PlanetTipRadius => &["planet.tip_radius_mm"],
        Settable::PlanetRootRadius => &["planet.root_radius_mm"],
        Settable::PlanetBoreRadius => &["planet.bore_radius_mm"],
        Settable::RingMinorRadius => &["ring.minor_radius_mm"],
        Settable::RingRootRadius => &["ring.root_radius_mm"],
        Settable::RingRimRadius => &["ring.rim_radius_mm"],
        Settable::HobTipRadius => &["sun.hob_tip_radius_mm", "planet.hob_tip_radius_mm"],
        Settable::RingFilletRadius => &["ring.fillet_radius_mm"],
        Settable::TipChamferHeight => &["sun.tip_chamfer.height_mm", "planet.tip_chamfer.height_mm"],
        Settable::TipChamferAngle => &["sun.tip_chamfer.angle_deg", "planet.tip_chamfer.angle_deg"],
        Settable::YoungsModulus => &["material.youngs_modulus_gpa"],
        Settable::PoissonRatio => &["material.poisson_ratio"],
        Settable::Density => &["material.density_kg_per_m3"],
        Settable::SunInertia => &["inertia.sun_inertia_kg_m2"],
        Settable::PlanetInertia => &["inertia.planet_inertia_kg_m2"],
        Settable::RingInertia => &["inertia.ring_inertia_kg_m2"],
        Settable::CarrierInertia => &["inertia.carrier_inertia_kg_m2"],
        Settable::SunMass => &["inertia.sun_mass_kg"],
        Settable::PlanetMass => &["inertia.planet_mass_kg"],
        Settable::RingMass => &["inertia.ring_mass_kg"],
        Settable::CarrierMass => &["inertia.carrier_mass_kg"],
        Settable::SunBearingStiffness => &["supports.sun_radial_n_per_m"],
        Settable::RingBearingStiffness => &["supports.ring_radial_n_per_m"],
        Settable::CarrierBearingStiffness => &["supports.carrier_radial_n_per_m"],
        Settable::PlanetBearingStiffness => {
            &["supports.planet_bearing_n_per_m", "supports.planet_bearings_n_per_m"]
        }
        Settable::BearingDampingRatio => &["supports.bearing_damping_ratio"],
        Settable::MeshDampingRatio => &["dynamics.mesh_damping_ratio"],
        Settable::ShaftStiffness => &["dynamics.shaft_stiffness_nm_per_rad"],
        Settable::SteadySpeedStep => &["dynamics.steady_speed_step_rpm"],
        Settable::SteadyTorqueStep => &["dynamics.steady_torque_step_nm"],
        Settable::SteadyAgreement => &["dynamics.steady_agreement"],
        Settable::LoadBalance => &["dynamics.load_balance"],
        Settable::GearData => &[],
        Settable::SunProfileShift => &["sun.gear_data.profile_shift"],
        Settable::PlanetProfileShift => &["planet.gear_data.profile_shift"],
        Settable::RingProfileShift => &["ring.gear_data.profile_shift"],
        Settable::AddendumFactor => &[
            "sun.gear_data.addendum_factor",
            "planet.gear_data.addendum_factor",
            "ring.gear_data.addendum_factor",
        ],
        Settable::DedendumFactor => &[
            "sun.gear_data.dedendum_factor",
            "planet.gear_data.dedendum_factor",
            "ring.gear_data.dedendum_factor",
        ],
        Settable::ToolTipRadiusFactor => {
            &["sun.gear_data.tool_tip_radius_factor", "planet.gear_data.tool_tip_radius_factor"]
        }
        Settable::RingToolTipRadiusFactor => &["ring.gear_data.tool_tip_radius_factor"],
        Settable::SunToothThicknessAllowance => &["sun.gear_data.tooth_thickness_allowance_mm"],
        Settable::PlanetToothThicknessAllowance => &["planet.gear_data.tooth_thickness_allowance_mm"],
        Settable::RingToothThicknessAllowance => &["ring.gear_data.tooth_thickness_allowance_mm"],
        Settable::SunTipDiameter => &["sun.gear_data.tip_diameter_mm"],
        Settable::PlanetTipDiameter => &["planet.gear_data.tip_diameter_mm"],
        Settable::RingTipDiameter => &["ring.gear_data.tip_diameter_mm"],
        Settable::SpeedDrivenMember => &["dynamics.speed_driven_member"],
    }
}

/// A validation problem said in the importer's terms: by the variable that
/// wrote its scene key, with the variable's value in its own unit, when the
/// importer's parameters wrote that key (`used`); otherwise by the scene
/// file it came from.
pub(super) fn describe_problem(
    problem: &Problem,
    values: &Values,
    used: impl Fn(Settable) -> bool,
    scene_file: &str,
) -> String {
    let writer =
        Settable::ALL.iter().copied().find(|p| used(*p) && scene_keys(*p).contains(&problem.name.as_str()));
    match writer {
        Some(p) => {
            let v = p.variable();
            let info = v.info();
            let value = match info.kind {
                crate::fmi::variables::Kind::Integer => values.int(v).to_string(),
                _ => {
                    let unit = if info.unit.is_empty() || info.unit == "1" {
                        String::new()
                    } else {
                        format!(" {}", info.unit)
                    };
                    format!("{}{unit}", values.real(v))
                }
            };
            format!(
                "{} = {value}: {} (the scene's {} = {})",
                v.name(),
                problem.reason,
                problem.name,
                problem.value
            )
        }
        None if scene_file.is_empty() => format!("{problem}"),
        None => format!("sceneFile = {scene_file}: {problem}"),
    }
}
