//! The model built from a scene: every rule of the scene checked at once,
//! every problem named by the user's key (`sun.tip_radius_mm`) and shown
//! in the key's unit as the user wrote it; the scene holds SI, which the
//! model takes as it is. A [`GearSet`] exists only through
//! [`Scene::validate`] (or [`Scene::validate_with_run`]), so holding one means
//! it passed every rule; a [`RunSettings`] only through the same validation
//! or [`RunSettings::new`], which checks it by the same rules.
//!
//! The rules by family: the tooth forms (`gears`), the scalar keys and run
//! settings (`settings`), the planets' layout (`layout`) and the meshes of
//! the built set (`meshes`).

mod gears;
mod layout;
mod meshes;
mod settings;

use std::fmt;

use crate::model::gear::{Analysis, Bodies, Body, Damping, GearSet, Material, MeshKind, Supports};
use crate::model::gear_data::name_by_gear_data;
use crate::model::run::RunSettings;
use crate::scene::units::{m_to_mm, rad_to_deg};
use crate::scene::{default_chamfer, DampingModel, InertiaSpec, Problem, Scene, SceneError};
use gears::Gears;
use settings::{check_analysis, check_inertia, check_mesh_stiffness, check_operation, check_supports};

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
                g.tip_chamfer = Some(default_chamfer(g.module));
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

/// The problems found so far, in the order the rules ran.
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

    /// A gear's pressure angle `angle` \[rad\] under `key`, in degrees strictly between 10
    /// and 35 (spur gear practice).
    fn pressure_angle(&mut self, key: &str, angle: f64) -> bool {
        self.in_range(
            &format!("{key}.pressure_angle_deg"),
            rad_to_deg(angle),
            10.0,
            35.0,
            "spur gear practice",
        )
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

/// Every rule, on the scene with the radii its gear data give: the rules
/// that need no gear set first, then those of the built set (which need
/// valid gears and centre distance), then the run's cost.
fn validate_radii(given: &Scene) -> Result<(GearSet, RunSettings), SceneError> {
    let (resolved, data_problems) = crate::model::gear_data::resolve(given);
    let scene = &resolved;
    let mut c = Checker { problems: data_problems };
    let gears = c.gears(scene);
    let gears_ok = c.problems.is_empty();
    let material = settings::material(&scene.material, &mut c);
    check_analysis(&scene.analysis, &mut c);
    check_supports(&scene.supports, scene.planets.count, &mut c);
    check_inertia(&scene.inertia, &mut c);
    check_mesh_stiffness(&scene.mesh_stiffness, &mut c);
    let run = settings::run_values(scene, &mut c);
    check_operation(&scene.dynamics, &scene.operation, &mut c);
    let angles = c.planet_angles(&scene.planets);
    let centre_ok = c.positive("centre_distance_mm", m_to_mm(scene.centre_distance));
    if !(gears_ok && centre_ok) {
        return Err(SceneError::Invalid { problems: c.problems });
    }

    let set = gear_set(scene, gears, angles, material);
    c.centre_distance(&set);
    if !c.problems.is_empty() {
        return Err(SceneError::Invalid { problems: c.problems });
    }
    for mesh in MeshKind::ALL {
        c.mesh(&set, mesh);
    }
    c.assembly(&set, &scene.planets);
    c.planet_clearance(&set, &scene.planets);

    c.problems.extend(crate::model::cost::problems(scene));
    if c.problems.is_empty() {
        Ok((set, RunSettings { values: run }))
    } else {
        Err(SceneError::Invalid { problems: c.problems })
    }
}

/// The gear set of a scene whose gears and centre distance passed their
/// rules, in SI: the bodies from the geometry, then the scene's overrides.
fn gear_set(scene: &Scene, gears: Gears, angles: Vec<f64>, material: Material) -> GearSet {
    let (a, sp, d, op, ms) =
        (&scene.analysis, &scene.supports, &scene.dynamics, &scene.operation, &scene.mesh_stiffness);
    let angles_len = angles.len();
    let mut set = GearSet {
        name: scene.name.clone(),
        sun: gears.sun,
        planet: gears.planet,
        ring: gears.ring,
        planet_angles: angles,
        centre_distance: scene.centre_distance,
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
    set.bodies = bodies(&scene.inertia, Bodies::from_geometry(&set));
    set
}

/// The bodies `derived` from the geometry, each mass and moment of inertia
/// the scene gives in their place.
fn bodies(inertia: &InertiaSpec, derived: Bodies) -> Bodies {
    let pick = |v: Option<f64>, d: f64| v.unwrap_or(d);
    Bodies {
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
    }
}
