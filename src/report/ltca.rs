//! The `planetwear ltca` report: JSON (SI units, keys documented in
//! docs/LTCA_JSON.md) and plots.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::plot::{write_chart, Chart, PlotError, Series};
use crate::contact::iso6336::{iso_stiffness, IsoPair};
use crate::contact::ltca::{mesh_ltca, set_ltca, CycleStats, MeshLtca, SetLtca, SetModel};
use crate::model::gear::{GearSet, MeshKind};

/// Everything the LTCA command computes.
#[derive(Clone, Debug)]
pub struct LtcaStudy {
    /// The gear set analysed.
    pub set: GearSet,
    /// Single-mesh LTCA of the sun–planet and ring–planet meshes at the mean planet load.
    pub meshes: Vec<MeshLtca>,
    /// Whole-set LTCA.
    pub whole_set: SetLtca,
    /// Per mesh: ISO c'·b and c_γα·b [N/m] and the energy-method single-pair extremes.
    pub stiffness_summary: Vec<Value>,
    /// The worn-profile state's κ the flanks carry (`None`: unworn).
    pub kappa: Option<u32>,
}

/// ISO 6336-1 stiffness of a mesh of the set ([`IsoPair::of_mesh`]).
fn iso_for(set: &GearSet, mesh: MeshKind, contact_ratio: f64) -> crate::contact::iso6336::IsoStiffness {
    iso_stiffness(&IsoPair::of_mesh(set, mesh, contact_ratio))
}

impl LtcaStudy {
    /// Runs the single-mesh and whole-set analyses at `samples` positions per mesh cycle.
    pub fn run(set: &GearSet, samples: usize) -> Self {
        Self::run_on(set, &SetModel::new(set), samples, None)
    }

    /// The analyses on the contact models `model` (e.g. the flanks of a
    /// worn-profile state of κ = `kappa`).
    pub fn run_on(set: &GearSet, model: &SetModel, samples: usize, kappa: Option<u32>) -> Self {
        let load = set.mesh_load_per_planet();
        let mut meshes = Vec::new();
        let mut stiffness_summary = Vec::new();
        for (mesh, m) in
            [(MeshKind::SunPlanet, &model.sun_planet), (MeshKind::RingPlanet, &model.ring_planet)]
        {
            let r = mesh_ltca(set, m, load, samples);
            let p = m.path();
            let width = set.sun().face_width.min(set.planet().face_width).min(set.ring().face_width);
            let iso = iso_for(set, mesh, p.nominal_contact_ratio());
            let singles: Vec<f64> =
                (0..=200).map(|i| m.stiffness.at(p.start + (p.end - p.start) * i as f64 / 200.0)).collect();
            let nominal = CycleStats::of(&r.mesh_stiffness_nominal);
            stiffness_summary.push(json!({
                "single_pair_stiffness": {
                    "min": singles.iter().cloned().fold(f64::INFINITY, f64::min),
                    "max": singles.iter().cloned().fold(0.0, f64::max),
                    "at_pitch_point": m.stiffness.at(p.pitch_point()),
                },
                "iso6336": {
                    "single_stiffness": iso.single * 1e9 * width,
                    "mesh_stiffness": iso.mesh * 1e9 * width,
                    "single_stiffness_per_width_N_per_mm_um": iso.single,
                    "mesh_stiffness_per_width_N_per_mm_um": iso.mesh,
                    "ratio_mean_nominal_mesh_stiffness_to_iso_mesh_stiffness": nominal.mean / (iso.mesh * 1e9 * width),
                },
                "foundation_coefficients": {
                    "gear1": m.stiffness.gear1.foundation_coefficients,
                    "gear2": m.stiffness.gear2.foundation_coefficients,
                },
            }));
            meshes.push(r);
        }
        let whole_set = set_ltca(set, model, samples);
        Self { set: set.clone(), meshes, whole_set, stiffness_summary, kappa }
    }

    /// The JSON document (SI units).
    pub fn to_json(&self) -> Value {
        let set = &self.set;
        let meshes: Vec<Value> = self
            .meshes
            .iter()
            .zip(MeshKind::ALL)
            .zip(&self.stiffness_summary)
            .map(|((r, mesh), summary)| {
                let p = crate::model::mesh::PathOfContact::new(set, mesh);
                let mut v = json!({
                    "name": r.name,
                    "load": r.load,
                    "base_pitch": p.base_pitch,
                    "operating_pressure_angle": p.pressure_angle,
                    "normal_backlash": set.normal_backlash(mesh),
                    "circumferential_backlash": set.circumferential_backlash(mesh),
                    "pitch_point_roll_angle_gear1": p.roll_1(p.pitch_point()),
                    "path_of_contact": {"start": p.start_sharp, "end": p.end_sharp, "start_involute": p.start, "end_involute": p.end},
                    "contact_ratio_nominal": p.nominal_contact_ratio(),
                    "contact_ratio_involute": p.involute_contact_ratio(),
                    "contact_ratio_loaded": r.loaded_contact_ratio(),
                    "pairs_in_contact_fraction": {
                        "1": r.fraction_with_pairs(1),
                        "2": r.fraction_with_pairs(2),
                        "3": r.fraction_with_pairs(3),
                    },
                    "mesh_stiffness_nominal": CycleStats::of(&r.mesh_stiffness_nominal),
                    "mesh_stiffness_loaded": CycleStats::of(&r.mesh_stiffness_loaded),
                    "static_transmission_error": CycleStats::of(&r.transmission_error),
                    "peak_hertz_pressure": r.peak_pressure.iter().cloned().fold(0.0, f64::max),
                    "max_hertz_half_width": r.half_width.iter().cloned().fold(0.0, f64::max),
                    "curves": {
                        "position": r.position,
                        "roll_angle_gear1": r.roll_angle_gear1,
                        "transmission_error": r.transmission_error,
                        "mesh_stiffness_loaded": r.mesh_stiffness_loaded,
                        "mesh_stiffness_nominal": r.mesh_stiffness_nominal,
                        "pairs_in_contact": r.pairs_in_contact,
                        "peak_pressure": r.peak_pressure,
                        "half_width": r.half_width,
                    },
                    "pair_path": {
                        "position": r.pair_path_position,
                        "roll_angle_gear1": r.pair_path_roll_gear1,
                        "load": r.pair_path_load,
                        "peak_pressure": r.pair_path_peak_pressure,
                        "half_width": r.pair_path_half_width,
                    },
                });
                if let (Some(obj), Some(extra)) = (v.as_object_mut(), summary.as_object()) {
                    obj.extend(extra.clone());
                }
                v
            })
            .collect();
        let w = &self.whole_set;
        json!({
            "scene": set.name(),
            "kappa": self.kappa.unwrap_or(0),
            "units": "SI: m, N, N/m, Pa, rad, N·m",
            "input_torque": set.input_torque(),
            "face_width": set.sun().face_width,
            "meshes": meshes,
            "planets": {
                "model": "torsional statics, central members on their axes, carrier and output held",
                "angles": set.planet_angles(),
                "mean_load": w.planet_mean_load,
                "load_sharing_factor": w.load_sharing_factor,
                "sun_transmission_error": CycleStats::of(&w.sun_approach),
                "travel": w.travel,
                "sun_approach": w.sun_approach,
                "load": w.planet_load,
            },
        })
    }

    /// Writes the plots into `dir` and returns the files written.
    pub fn write_plots(&self, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
        let width_mm = self.set.sun().face_width * 1e3;
        let deg = |v: &[f64]| v.iter().map(|x| x.to_degrees()).collect::<Vec<_>>();
        let mut files = Vec::new();
        for r in &self.meshes {
            let x = deg(&r.roll_angle_gear1);
            let gear1 = if r.name == "sun_planet" { "sun" } else { "planet" };
            let per = |v: &[f64]| v.iter().map(|k| k / width_mm * 1e-6).collect::<Vec<_>>();
            files.extend(write_chart(
                &Chart {
                    title: format!("{}: mesh stiffness over one mesh cycle", r.name),
                    x_label: format!("{gear1} roll angle (deg)"),
                    y_label: "mesh stiffness (N/(mm·µm))".into(),
                    series: vec![
                        Series::new("loaded (pairs in contact)", x.clone(), per(&r.mesh_stiffness_loaded)),
                        Series::new("nominal path (sharp tips)", x.clone(), per(&r.mesh_stiffness_nominal)),
                    ],
                    vlines: vec![],
                },
                &dir.join(format!("{}_mesh_stiffness", r.name)),
            )?);
            files.extend(write_chart(
                &Chart {
                    title: format!(
                        "{}: loaded static transmission error, {:.0} N/mm",
                        r.name,
                        r.load / width_mm
                    ),
                    x_label: format!("{gear1} roll angle (deg)"),
                    y_label: "transmission error along the line of action (µm)".into(),
                    series: vec![Series::new(
                        "loaded STE",
                        x.clone(),
                        r.transmission_error.iter().map(|d| d * 1e6).collect(),
                    )],
                    vlines: vec![],
                },
                &dir.join(format!("{}_transmission_error", r.name)),
            )?);
            files.extend(write_chart(
                &Chart {
                    title: format!("{}: load of one tooth pair through its engagement", r.name),
                    x_label: format!("{gear1} roll angle (deg)"),
                    y_label: "tooth-pair load (N/mm)".into(),
                    series: vec![Series::new(
                        "tooth-pair load",
                        deg(&r.pair_path_roll_gear1),
                        r.pair_path_load.iter().map(|f| f / width_mm).collect(),
                    )],
                    vlines: vec![],
                },
                &dir.join(format!("{}_pair_load", r.name)),
            )?);
        }
        let w = &self.whole_set;
        let travel_mm: Vec<f64> = w.travel.iter().map(|t| t * 1e3).collect();
        files.extend(write_chart(
            &Chart {
                title: "load sharing between planets over one mesh cycle".into(),
                x_label: "sun travel along the line of action (mm)".into(),
                y_label: "planet load (N/mm)".into(),
                series: w
                    .planet_load
                    .iter()
                    .enumerate()
                    .map(|(n, l)| {
                        Series::new(
                            format!("planet {}", n + 1),
                            travel_mm.clone(),
                            l.iter().map(|f| f / width_mm).collect(),
                        )
                    })
                    .collect(),
                vlines: vec![],
            },
            &dir.join("planet_load_sharing"),
        )?);
        Ok(files)
    }
}
