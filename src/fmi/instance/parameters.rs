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

use crate::fmi::variables::{Settable, Variable};
use crate::model::gear::{Drive, IntegratorKind, Member};
use crate::model::lumped::Fidelity;
use crate::scene::{ChamferSpec, GearData, PlanetLayoutSpec, Problem, Scene};

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
        Settable::SceneFile | Settable::WearStateFile => {}
        // The simulation's initial state, set when it is built.
        Settable::InitialSpeed => {}
        // Inputs act on the running simulation; the input member's torque
        // also sets the scene's operating load ([`input_torque`]).
        Settable::SunTorque
        | Settable::RingTorque
        | Settable::CarrierTorque
        | Settable::InputSpeedReference => {}
        Settable::Fidelity => {
            scene.dynamics.fidelity = match values.int(v) {
                0 => Fidelity::Torsional,
                1 => Fidelity::TransverseTorsional,
                x => {
                    return Err(format!(
                        "fidelity = {x}: allowed are 0 (torsional), 1 (transverse-torsional)"
                    ))
                }
            }
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
        Settable::RelativeTolerance => scene.dynamics.relative_tolerance = r,
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
        Settable::SceneFile
        | Settable::WearStateFile
        | Settable::InitialSpeed
        | Settable::InputSpeedReference
        | Settable::HarmonicWindowCycles => &[],
        Settable::SunTorque | Settable::RingTorque | Settable::CarrierTorque => {
            &["operation.input_torque_nm"]
        }
        Settable::Fidelity => &["dynamics.fidelity"],
        Settable::HeldMember => &["operation.held"],
        Settable::InputMember => &["operation.input"],
        Settable::DriveMode => &["dynamics.drive"],
        Settable::Integrator => &["dynamics.integrator"],
        Settable::StepsPerMeshCycle => &["dynamics.steps_per_mesh_cycle"],
        Settable::RhoInfinity => &["dynamics.rho_infinity"],
        Settable::RelativeTolerance => &["dynamics.relative_tolerance"],
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
