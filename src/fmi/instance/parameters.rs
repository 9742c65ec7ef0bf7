//! From the FMU's settable variables to a scene, and back from a scene's
//! problems to the variables the importer set.
//!
//! The FMU's parameters are SI (m, rad, Pa, rad/s), as the scene holds
//! them (its files write mm, degrees, GPa and rpm), so a value goes into
//! the scene as it is; `Scene::validate` is the one model constructor both
//! front ends use. The variable table
//! (`modelDescription/variables.toml`) says where each variable acts: a
//! variable with a `scene.slot` is written and read back through generated
//! field accessors ([`SceneField`]);
//! the others are the generated [`Special`] enum, which [`apply_special`]
//! and [`special_value`] match without a catch-all arm, so that such a
//! variable does not compile until it is given its effect here. The scene
//! keys a variable answers for ([`Settable::scene_keys`]) name a validation
//! problem by the variable the importer set ([`describe_problem`]).

use std::collections::BTreeMap;

use crate::fmi::variables::{SceneField, Settable, Special, Start, Target, Variable};
use crate::model::gear::{Drive, IntegratorKind, Member};
use crate::model::lumped::Fidelity;
use crate::scene::Response;
use crate::scene::{
    default_chamfer, ChamferSpec, DampingModel, GearData, PlanetLayoutSpec, Problem, Scene, SceneError,
};

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
/// value is not allowed: through its scene fields ([`SceneField`], from the
/// table), or by hand ([`apply_special`]).
pub(super) fn apply(p: Settable, values: &Values, scene: &mut Scene) -> Result<(), String> {
    let v = p.variable();
    match p.target() {
        Target::Field(SceneField::Real(fields)) => {
            let x = values.real(v);
            fields.iter().for_each(|f| *f(scene) = x);
        }
        Target::Field(SceneField::Count(fields)) => {
            let n = values.count(v)?;
            fields.iter().for_each(|f| *f(scene) = n);
        }
        Target::Field(SceneField::Derived(f)) => *f(scene) = values.derived_if_zero(v),
        Target::Special(special) => apply_special(special, values, scene)?,
    }
    Ok(())
}

/// The effect of a variable that is not one scene field. Variables that do
/// not describe the gear set (the files, the inputs, the output window)
/// have none here and are read where they act.
fn apply_special(p: Special, values: &Values, scene: &mut Scene) -> Result<(), String> {
    let v = Settable::from(p).variable();
    let r = values.real(v);
    match p {
        // Read before the scene exists (it chooses the scene) and by the
        // contact model (the worn flanks).
        Special::SceneFile | Special::WearStateFile | Special::WearStateAccept => {}
        // The load duty's bins, read when the simulation is built.
        Special::DutyTorqueEdges | Special::DutySpeedEdges => {}
        // Inputs act on the running simulation; the input member's torque
        // also sets the scene's operating load ([`input_torque`]).
        Special::SunTorque | Special::RingTorque | Special::CarrierTorque | Special::InputSpeedReference => {}
        Special::Fidelity => {
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
        Special::HeldMember => scene.operation.held = member(v, values.int(v))?,
        Special::InputMember => scene.operation.input = member(v, values.int(v))?,
        Special::SpeedDrivenMember => {
            scene.dynamics.speed_driven_member = match values.int(v) {
                -1 => None,
                code => Some(member(v, code).map_err(|e| format!("{e}, or -1 (the input member)"))?),
            }
        }
        Special::DriveMode => {
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
        Special::Integrator => {
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
        // The order-tracking window of the outputs, read when the simulation is built.
        Special::HarmonicWindowCycles => {}
        Special::Planets => scene.planets = PlanetLayoutSpec { count: values.count(v)?, angles: None },
        // Height and angle make one chamfer: either sets both from the
        // current values. The edge's reading (whether it carries load, its
        // rounding) stays the scene's.
        Special::TipChamferHeight | Special::TipChamferAngle => {
            let (height, angle) =
                (values.real(Variable::TipChamferHeight), values.real(Variable::TipChamferAngle));
            let set = |c: Option<ChamferSpec>| {
                Some(ChamferSpec { height, angle, ..c.unwrap_or(ChamferSpec::new(height, angle)) })
            };
            scene.sun.tip_chamfer = set(scene.sun.tip_chamfer);
            scene.planet.tip_chamfer = set(scene.planet.tip_chamfer);
        }
        Special::SteadyTorqueStep => scene.dynamics.steady_torque_step_nm = Some(r),
        // Gear data (ISO 21771): every one of them writes the three gears'
        // gear data from the current values when gearData = 1.
        Special::GearData
        | Special::SunProfileShift
        | Special::PlanetProfileShift
        | Special::RingProfileShift
        | Special::AddendumFactor
        | Special::DedendumFactor
        | Special::ToolTipRadiusFactor
        | Special::RingToolTipRadiusFactor
        | Special::SunToothThicknessAllowance
        | Special::PlanetToothThicknessAllowance
        | Special::RingToothThicknessAllowance
        | Special::SunTipDiameter
        | Special::PlanetTipDiameter
        | Special::RingTipDiameter => gear_data(values, scene)?,
        Special::DampingModel | Special::RayleighMassCoefficient | Special::RayleighStiffnessCoefficient => {
            damping(p, values, scene)?
        }
        Special::LoadBalance => {
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

/// The damping model (`dampingModel`) and Rayleigh's coefficients, read
/// only with dampingModel = 1 (as stepsPerMeshCycle only by generalized-α;
/// 0 in the scene otherwise)
/// but checked either way: the scene's own check (`dynamics.rayleigh_*`)
/// sees a coefficient only where it is written. The coefficients read the
/// scene's damping model, which `dampingModel` (value reference 64, before
/// theirs in `Settable::ALL`, the table's order) has already set.
fn damping(p: Special, values: &Values, scene: &mut Scene) -> Result<(), String> {
    let v = Settable::from(p).variable();
    let d = &mut scene.dynamics;
    match p {
        Special::DampingModel => {
            d.damping = match values.int(v) {
                0 => DampingModel::Ratio,
                1 => DampingModel::Rayleigh,
                x => return Err(format!("dampingModel = {x}: allowed are 0 (damping ratios), 1 (Rayleigh)")),
            }
        }
        _ => {
            let r = values.real(v);
            if !(r.is_finite() && r >= 0.0) {
                return Err(format!("{} = {r}: must be a finite number, at least 0", v.name()));
            }
            // Under the ratio model the coefficients are cleared, so a scene
            // switched from the example's Rayleigh damping keeps none of its
            // coefficients (the scene's check refuses them there).
            *match p {
                Special::RayleighMassCoefficient => &mut d.rayleigh_mass_per_s,
                _ => &mut d.rayleigh_stiffness_s,
            } = if d.damping == DampingModel::Rayleigh { r } else { 0.0 };
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
        let d = values.real(v);
        (d != 0.0).then_some(d)
    };
    let data = |x: Variable, rho: Variable, allowance: Variable, tip: Variable| GearData {
        profile_shift: values.real(x),
        addendum_factor: values.real(Variable::AddendumFactor),
        dedendum_factor: values.real(Variable::DedendumFactor),
        tool_tip_radius_factor: values.real(rho),
        tooth_thickness_allowance: values.real(allowance),
        tip_diameter: diameter(tip),
        root_diameter: None,
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
        (g.tooth_thickness, g.tip_radius, g.root_radius, g.hob_tip_radius) = (0.0, 0.0, 0.0, 0.0);
    }
    let r = &mut scene.ring;
    (r.tooth_thickness, r.minor_radius, r.root_radius, r.fillet_radius) = (0.0, 0.0, 0.0, 0.0);
    Ok(())
}

/// The value of every settable variable with a counterpart in `scene`, in
/// the variable's unit (SI): the inverse of the parameters → scene map the
/// instance applies, so that the FMU's parameters at these values describe
/// the scene's set. The torque inputs
/// are the set's balanced torques (the input torque on the input member);
/// initialSpeed and inputSpeedReference are the scene's input speed of a
/// single run (`dynamics.input_speed`). Variables without a counterpart
/// are left out: the files, wearStateAccept and harmonicWindowCycles (the
/// CLI measures over `dynamics.measured_revolutions` instead).
pub fn scene_values(scene: &Scene) -> Result<BTreeMap<Settable, Start>, SceneError> {
    let set = scene.validate()?;
    let torques = set.balanced_torques();
    let by_data = gear_data_form(scene)?;
    // The fields are read through the same accessors that write them.
    let mut fields = scene.clone();
    let mut out = BTreeMap::new();
    for p in Settable::ALL.iter().copied() {
        let value = match p.target() {
            Target::Field(SceneField::Real(f)) => Start::Real(*f[0](&mut fields)),
            Target::Field(SceneField::Count(f)) => count(*f[0](&mut fields)),
            Target::Field(SceneField::Derived(f)) => Start::Real(f(&mut fields).unwrap_or(0.0)),
            Target::Special(special) => match special_value(special, scene, torques, by_data) {
                Some(value) => value,
                None => continue,
            },
        };
        out.insert(p, value);
    }
    Ok(out)
}

fn count(x: u32) -> Start {
    Start::Integer(i32::try_from(x).unwrap_or(i32::MAX))
}

/// The three gears' gear data when the scene gives all three by it, `None`
/// when it gives all three by their radii; a scene that mixes the two forms,
/// or whose gears differ in a factor the FMU holds once, has no parameter set.
fn gear_data_form(scene: &Scene) -> Result<Option<[GearData; 3]>, SceneError> {
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
    Ok(by_data)
}

/// The value of a variable written by hand ([`apply_special`]) in the
/// scene, or `None` for one without a counterpart.
fn special_value(
    p: Special,
    scene: &Scene,
    torques: [f64; 3],
    by_data: Option<[GearData; 3]>,
) -> Option<Start> {
    let code = |m: Member| match m {
        Member::Sun => Start::Integer(0),
        Member::Ring => Start::Integer(1),
        Member::Carrier => Start::Integer(2),
    };
    let diameter = |x: Option<f64>| Start::Real(x.unwrap_or(0.0));
    let d = &scene.dynamics;
    let chamfer = scene.sun.tip_chamfer.unwrap_or_else(|| default_chamfer(scene.sun.module));
    Some(match p {
        Special::SceneFile
        | Special::WearStateFile
        | Special::WearStateAccept
        | Special::DutyTorqueEdges
        | Special::DutySpeedEdges
        | Special::HarmonicWindowCycles => return None,
        Special::GearData => Start::Integer(i32::from(by_data.is_some())),
        Special::SpeedDrivenMember => d.speed_driven_member.map_or(Start::Integer(-1), code),
        Special::SunProfileShift
        | Special::PlanetProfileShift
        | Special::RingProfileShift
        | Special::AddendumFactor
        | Special::DedendumFactor
        | Special::ToolTipRadiusFactor
        | Special::RingToolTipRadiusFactor
        | Special::SunToothThicknessAllowance
        | Special::PlanetToothThicknessAllowance
        | Special::RingToothThicknessAllowance
        | Special::SunTipDiameter
        | Special::PlanetTipDiameter
        | Special::RingTipDiameter => {
            // Unused with the radii form: their start values stand.
            let [sun, planet, ring] = by_data?;
            match p {
                Special::SunProfileShift => Start::Real(sun.profile_shift),
                Special::PlanetProfileShift => Start::Real(planet.profile_shift),
                Special::RingProfileShift => Start::Real(ring.profile_shift),
                Special::AddendumFactor => Start::Real(sun.addendum_factor),
                Special::DedendumFactor => Start::Real(sun.dedendum_factor),
                Special::ToolTipRadiusFactor => Start::Real(sun.tool_tip_radius_factor),
                Special::RingToolTipRadiusFactor => Start::Real(ring.tool_tip_radius_factor),
                Special::SunToothThicknessAllowance => Start::Real(sun.tooth_thickness_allowance),
                Special::PlanetToothThicknessAllowance => Start::Real(planet.tooth_thickness_allowance),
                Special::RingToothThicknessAllowance => Start::Real(ring.tooth_thickness_allowance),
                Special::SunTipDiameter => diameter(sun.tip_diameter),
                Special::PlanetTipDiameter => diameter(planet.tip_diameter),
                _ => diameter(ring.tip_diameter),
            }
        }
        Special::InputSpeedReference => Start::Real(d.input_speed),
        Special::SunTorque => Start::Real(torques[0]),
        Special::RingTorque => Start::Real(torques[1]),
        Special::CarrierTorque => Start::Real(torques[2]),
        Special::Fidelity => Start::Integer(
            match d.fidelity {
                Fidelity::Torsional => 0,
                Fidelity::TransverseTorsional => 1,
            } + match d.response {
                Response::Time => 0,
                Response::Steady => 2,
            },
        ),
        Special::HeldMember => code(scene.operation.held),
        Special::InputMember => code(scene.operation.input),
        Special::DriveMode => Start::Integer(match d.drive {
            Drive::Torque => 0,
            Drive::Speed => 1,
            Drive::SpeedSteps => 2,
        }),
        Special::Integrator => Start::Integer(match d.integrator {
            IntegratorKind::GeneralizedAlpha => 0,
            IntegratorKind::Rk45 => 1,
        }),
        Special::Planets => count(scene.planets.count),
        Special::TipChamferHeight => Start::Real(chamfer.height),
        Special::TipChamferAngle => Start::Real(chamfer.angle),
        Special::SteadyTorqueStep => Start::Real(
            d.steady_torque_step_nm
                .unwrap_or(crate::scene::STEADY_TORQUE_STEP * scene.operation.input_torque_nm.abs()),
        ),
        Special::LoadBalance => Start::Integer(i32::from(d.load_balance)),
        Special::DampingModel => Start::Integer(match d.damping {
            DampingModel::Ratio => 0,
            DampingModel::Rayleigh => 1,
        }),
        Special::RayleighMassCoefficient => Start::Real(d.rayleigh_mass_per_s),
        Special::RayleighStiffnessCoefficient => Start::Real(d.rayleigh_stiffness_s),
    })
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
        Settable::ALL.iter().copied().find(|p| used(*p) && p.scene_keys().contains(&problem.name.as_str()));
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
