//! The cause of the wear effect on the dynamic tooth loads: controlled
//! experiments on a scene, one modelling factor at a time.
//!
//! Each variant changes one thing against the base scene (chamfer size, the
//! chamfer edge's contact, how a worn band ends, quasi-static against
//! dynamic wear loads, which flanks wear, resolution, planet bearings, drive,
//! fidelity), runs the Archard wear model to κ, and reports at κ = 0 and at
//! κ: the wear shape of sun and planet, the loaded double-contact share and
//! static transmission error (single meshes at the mean planet load, and the
//! whole set), and the dynamic F^(1) and F^(rms) of planet 1's two meshes at
//! off-resonance speeds. The sign of ΔF^(rms) against the factor says which
//! modelling choice decides it.

use crate::analysis::study::StudyError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::contact::ltca::{mesh_ltca, set_ltca, CycleStats};
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::steady_state;
use crate::geometry::profile::ProfileEnds;
use crate::model::gear::{Drive, GearSet, MeshKind};
use crate::model::lumped::Fidelity;
use crate::model::run::RunSettings;
use crate::scene::units::{deg_to_rad, m_to_mm, mm_to_m, rad_per_s_to_rpm, rpm_to_rad_per_s};
use crate::scene::{ChamferSpec, Scene};
use crate::wear::archard::{PressureSource, WearSettings, WearingFlanks};
use crate::wear::flank::Flank;
use crate::wear::state::WornState;
use crate::wear::stepper::WearModel;

/// One variant of the experiment: the base scene and wear settings with one
/// factor changed.
#[derive(Clone, Debug)]
pub struct Variant {
    /// Short key (file and table name).
    pub key: String,
    /// What differs from the base, in words.
    pub description: String,
    /// The scene of the variant.
    pub scene: Scene,
    /// Changes to the wear settings of the variant.
    pub wear: fn(&mut WearSettings),
}

fn unchanged(_: &mut WearSettings) {}

/// `base` with sun and planet chamfers `height_mm` high (in mm, as the
/// variant's key names it).
fn with_chamfer(base: &Scene, height_mm: f64) -> Scene {
    let mut s = base.clone();
    let height = mm_to_m(height_mm);
    for g in [&mut s.sun, &mut s.planet] {
        let c = g.tip_chamfer.unwrap_or(ChamferSpec::new(height, deg_to_rad(45.0)));
        g.tip_chamfer = Some(ChamferSpec { height, ..c });
    }
    s
}

fn with_edge(base: &Scene, carries: bool) -> Scene {
    let mut s = base.clone();
    for g in [&mut s.sun, &mut s.planet] {
        let c = g.tip_chamfer.unwrap_or_else(|| crate::scene::default_chamfer(g.module));
        g.tip_chamfer = Some(ChamferSpec { edge_carries_load: carries, ..c });
    }
    s
}

/// The variants of the experiment on `base`, one factor at a time.
pub fn variants(base: &Scene) -> Vec<Variant> {
    let chamfer = |s: &Scene| {
        m_to_mm(s.sun.tip_chamfer.unwrap_or_else(|| crate::scene::default_chamfer(s.sun.module)).height)
    };
    let edge_loaded = base.sun.tip_chamfer.is_none_or(|c| c.edge_carries_load);
    let h = chamfer(base);
    let mut v = vec![Variant {
        key: "base".into(),
        description: "the base scene as it is".into(),
        scene: base.clone(),
        wear: unchanged,
    }];
    // Smaller and larger than the base, both below half the sun's addendum.
    for factor in [0.5, 1.5] {
        v.push(Variant {
            key: format!("chamfer-{:.2}", h * factor),
            description: format!("sun and planet chamfer {:.2} mm × 45° (base {h:.2} mm)", h * factor),
            scene: with_chamfer(base, h * factor),
            wear: unchanged,
        });
    }
    v.push(Variant {
        key: if edge_loaded { "edge-relieved".into() } else { "edge-loaded".into() },
        description: if edge_loaded {
            "the chamfer edges of sun and planet carry no load (no corner contact at their tips)".into()
        } else {
            "the chamfer edges of sun and planet carry load (corner contact at their tips)".into()
        },
        scene: with_edge(base, !edge_loaded),
        wear: unchanged,
    });
    v.push(Variant {
        key: "ends-unworn".into(),
        description:
            "the worn band ends in a step: no wear below the start of active profile or past the grid".into(),
        scene: base.clone(),
        wear: |w| w.profile_ends = ProfileEnds::Unworn,
    });
    v.push(Variant {
        key: "dynamic-loads".into(),
        description: "wear driven by the dynamic tooth loads of the steady state at 3000 rpm".into(),
        scene: base.clone(),
        wear: |w| w.source = PressureSource::Dynamic { speed: rpm_to_rad_per_s(3000.0) },
    });
    v.push(Variant {
        key: "sun-only".into(),
        description: "only the sun wears (the planet's flank stays unworn)".into(),
        scene: base.clone(),
        wear: |w| {
            w.wearing = WearingFlanks { planet_sun_side: false, ..WearingFlanks::sun_planet() };
        },
    });
    v.push(Variant {
        key: "fine".into(),
        description: "R = 800 positions per wear cycle and I = 200 profile points (base 200 and 50)".into(),
        scene: {
            let mut s = base.clone();
            s.analysis.profile_points = 200;
            s
        },
        wear: |w| {
            w.positions = 800;
            w.profile_points = 200;
        },
    });
    let kp = base.supports.planet_bearing_n_per_m;
    let other_kp = if kp > 1e9 { 3e8 } else { 3e10 };
    v.push(Variant {
        key: format!("planet-bearing-{other_kp:.0e}"),
        description: format!("planet bearings {other_kp:.0e} N/m (base {kp:.1e} N/m)"),
        scene: {
            let mut s = base.clone();
            s.supports.planet_bearing_n_per_m = other_kp;
            s
        },
        wear: unchanged,
    });
    v.push(Variant {
        key: "speed-drive".into(),
        description: "the sun driven through its shaft from a constant-speed source (base: constant torque)"
            .into(),
        scene: {
            let mut s = base.clone();
            s.dynamics.drive = if base.dynamics.drive == Drive::Speed { Drive::Torque } else { Drive::Speed };
            s
        },
        wear: unchanged,
    });
    let other = match base.dynamics.fidelity {
        Fidelity::Torsional => Fidelity::TransverseTorsional,
        Fidelity::TransverseTorsional => Fidelity::Torsional,
    };
    v.push(Variant {
        key: format!("{other:?}").to_lowercase(),
        description: format!("{other:?} degrees of freedom (base {:?})", base.dynamics.fidelity),
        scene: {
            let mut s = base.clone();
            s.dynamics.fidelity = other;
            s
        },
        wear: unchanged,
    });
    v
}

/// Where the wear of one flank sits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WearShape {
    /// Deepest wear \[m\] and its roll angle \[rad\].
    pub deepest: (f64, f64),
    /// Wear at the first grid point (start of active profile) \[m\].
    pub root_end: f64,
    /// Wear at the last grid point (end of the involute, the tip or chamfer start) \[m\].
    pub tip_end: f64,
    /// Wear at the pitch point \[m\] and the pitch point's roll angle \[rad\].
    pub pitch: (f64, f64),
    /// Share of the worn area (∫ h dξ) above the pitch point (the flank's addendum) [-].
    pub addendum_share: f64,
}

impl WearShape {
    /// The shape of `flank`'s wear in `state` (slice 0) on `set`.
    pub fn of(state: &WornState, set: &GearSet, flank: Flank) -> Self {
        let dev = &state.flanks.get(flank)[0];
        let pitch_roll = {
            let (mesh, gear1) = flank.drive_mesh().unwrap_or((MeshKind::SunPlanet, true));
            let p = crate::model::mesh::PathOfContact::new(set, mesh);
            if gear1 {
                p.roll_1(p.pitch_point())
            } else {
                p.roll_2(p.pitch_point())
            }
        };
        let deepest = dev.depth.iter().zip(&dev.roll).fold(
            (0.0, dev.roll.first().copied().unwrap_or(0.0)),
            |m, (d, r)| if *d > m.0 { (*d, *r) } else { m },
        );
        let (mut above, mut all) = (0.0, 0.0);
        for (w, x) in dev.depth.windows(2).zip(dev.roll.windows(2)) {
            let area = 0.5 * (w[0] + w[1]) * (x[1] - x[0]);
            all += area;
            if 0.5 * (x[0] + x[1]) > pitch_roll {
                above += area;
            }
        }
        Self {
            deepest,
            root_end: dev.depth.first().copied().unwrap_or(0.0),
            tip_end: dev.depth.last().copied().unwrap_or(0.0),
            pitch: (dev.at(pitch_roll), pitch_roll),
            addendum_share: if all > 0.0 { above / all } else { 0.0 },
        }
    }
}

/// Quasi-static figures of one geometry state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StaticFigures {
    /// Share of the mesh cycle with two or more loaded pairs, sun–planet and ring–planet [-].
    pub double_contact: [f64; 2],
    /// Loaded static transmission error peak-to-peak of each mesh at the mean planet load \[m\].
    pub transmission_error: [f64; 2],
    /// Peak-to-peak of the sun's rotation along the line of action in the whole-set LTCA \[m\].
    pub set_transmission_error: f64,
    /// Load-sharing factor of the whole set [-].
    pub load_sharing_factor: f64,
}

impl StaticFigures {
    /// The figures of `state` on `set` at `samples` positions per mesh cycle.
    pub fn of(state: &WornState, set: &GearSet, samples: usize) -> Self {
        let model = state.set_model(set);
        let load = set.mesh_load_per_planet();
        let sp = mesh_ltca(set, &model.sun_planet, load, samples);
        let rp = mesh_ltca(set, &model.ring_planet, load, samples);
        let whole = set_ltca(set, &model, samples);
        let share =
            |m: &crate::contact::ltca::MeshLtca| 1.0 - m.fraction_with_pairs(1) - m.fraction_with_pairs(0);
        Self {
            double_contact: [share(&sp), share(&rp)],
            transmission_error: [
                CycleStats::of(&sp.transmission_error).peak_to_peak,
                CycleStats::of(&rp.transmission_error).peak_to_peak,
            ],
            set_transmission_error: CycleStats::of(&whole.sun_approach).peak_to_peak,
            load_sharing_factor: whole.load_sharing_factor,
        }
    }
}

/// Dynamic figures of planet 1's meshes at one speed \[N\].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshLoads {
    /// Input speed [rad/s] (written in rpm, as `speed_rpm`).
    #[serde(rename = "speed_rpm", with = "crate::scene::units::rpm")]
    pub speed: f64,
    /// F^(1) of the sun–planet and ring–planet mesh \[N\].
    pub first_harmonic: [f64; 2],
    /// F^(rms) of the sun–planet and ring–planet mesh \[N\].
    pub rms: [f64; 2],
    /// Fraction of the window without tooth force, both meshes [-].
    pub separation: [f64; 2],
}

/// The steady-state loads of `state` on `set` at each input speed of `speeds` [rad/s].
pub fn mesh_loads(
    set: &GearSet,
    run: &RunSettings,
    state: &WornState,
    speeds: &[f64],
) -> Result<Vec<MeshLoads>, StudyError> {
    let mut model = PlanetaryDynamics::new(set, state.set_model(set))?;
    speeds
        .iter()
        .map(|omega| {
            let ss = steady_state(&mut model, set, run, *omega, None)
                .map_err(|e| StudyError::from(e).at(format!("{} rpm", rad_per_s_to_rpm(*omega))))?;
            let m = |k: MeshKind| {
                ss.meshes
                    .iter()
                    .find(|m| m.planet == 0 && m.mesh == k)
                    .ok_or(StudyError::Incomplete("no mesh of planet 1"))
            };
            let (s, r) = (m(MeshKind::SunPlanet)?, m(MeshKind::RingPlanet)?);
            Ok(MeshLoads {
                speed: *omega,
                first_harmonic: [s.harmonics.amplitude[0], r.harmonics.amplitude[0]],
                rms: [s.harmonics.rms, r.harmonics.rms],
                separation: [s.separation, r.separation],
            })
        })
        .collect()
}

/// What one variant gives.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VariantResult {
    /// The variant's key.
    pub key: String,
    /// The variant's description.
    pub description: String,
    /// κ reached (the run stops early at ε_tot).
    pub kappa: u32,
    /// Wear shape of the sun's drive flank at κ.
    pub sun: WearShape,
    /// Wear shape of the planet's sun-side flank at κ.
    pub planet: WearShape,
    /// Quasi-static figures at κ = 0 and at κ.
    pub statics: [StaticFigures; 2],
    /// Dynamic loads at κ = 0 and at κ, per speed.
    pub loads: [Vec<MeshLoads>; 2],
    /// Face width \[m\], for loads per unit width.
    pub face_width: f64,
    /// Wall time of the variant \[s\].
    pub seconds: f64,
}

impl VariantResult {
    /// Mean relative change of the sun–planet F^(rms) from κ = 0 to κ over the speeds [-].
    pub fn sun_rms_change(&self) -> f64 {
        let n = self.loads[0].len().max(1) as f64;
        self.loads[0].iter().zip(&self.loads[1]).map(|(a, b)| b.rms[0] / a.rms[0] - 1.0).sum::<f64>() / n
    }
}

/// Runs one variant: the wear model to `kappa`, then the figures at κ = 0 and κ.
pub fn run_variant(v: &Variant, kappa: u32, speeds: &[f64]) -> Result<VariantResult, StudyError> {
    let started = std::time::Instant::now();
    let (set, run) = v.scene.validate_with_run().map_err(|e| StudyError::from(e).at(&v.key))?;
    let mut settings = WearSettings::for_set(&set);
    (v.wear)(&mut settings);
    let model = WearModel::with_run(&set, &run, settings).map_err(|e| StudyError::from(e).at(&v.key))?;
    let unworn = model.unworn();
    let worn = model.run_to_kappa(&unworn, kappa).map_err(|e| StudyError::from(e).at(&v.key))?;
    let samples = set.analysis().positions_per_mesh_cycle;
    let statics = [StaticFigures::of(&unworn, &set, samples), StaticFigures::of(&worn, &set, samples)];
    let loads = [mesh_loads(&set, &run, &unworn, speeds)?, mesh_loads(&set, &run, &worn, speeds)?];
    Ok(VariantResult {
        key: v.key.clone(),
        description: v.description.clone(),
        kappa: worn.kappa,
        sun: WearShape::of(&worn, &set, Flank::SunDrive),
        planet: WearShape::of(&worn, &set, Flank::PlanetSunSide),
        statics,
        loads,
        face_width: set.sun().face_width,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Runs every variant (in parallel) and returns their results in order.
pub fn run_all(variants: &[Variant], kappa: u32, speeds: &[f64]) -> Vec<Result<VariantResult, StudyError>> {
    variants.par_iter().map(|v| run_variant(v, kappa, speeds)).collect()
}
