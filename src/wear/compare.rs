//! Quasi-static against dynamic wear loads: the wear of one cycle from each
//! source on the same state, flank by flank and mesh by mesh.

use crate::model::gear::MeshKind;
use crate::wear::archard::{CycleWear, PressureSource, WearError};
use crate::wear::dynamic::{DynamicPairLoads, PairLoadProfile};
use crate::wear::flank::Flank;
use crate::wear::state::WornState;
use crate::wear::stepper::{dynamic_cycle, WearModel};
use serde::{Deserialize, Serialize};

/// One flank's wear per cycle from both sources.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlankComparison {
    /// The flank.
    pub flank: Flank,
    /// Face slice.
    pub slice: usize,
    /// Grid roll angles \[rad\].
    pub roll: Vec<f64>,
    /// Wear per tooth cycle from the quasi-static loads, mean over the planets \[m\].
    pub quasi_static: Vec<f64>,
    /// Wear per tooth cycle from the dynamic loads, mean over the planets \[m\].
    pub dynamic: Vec<f64>,
    /// Largest quasi-static wear per cycle \[m\].
    pub quasi_static_max: f64,
    /// Roll angle of the largest quasi-static wear per cycle \[rad\].
    pub quasi_static_max_roll: f64,
    /// Largest dynamic wear per cycle \[m\].
    pub dynamic_max: f64,
    /// Roll angle of the largest dynamic wear per cycle \[rad\].
    pub dynamic_max_roll: f64,
    /// Largest dynamic over largest quasi-static wear per cycle [-].
    pub ratio: f64,
    /// Largest pointwise difference dynamic − quasi-static, in magnitude,
    /// over the largest quasi-static wear per cycle [-].
    pub largest_difference: f64,
}
/// One mesh's pair loads from both sources.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshComparison {
    /// The mesh.
    pub mesh: MeshKind,
    /// Largest quasi-static pair load over the passage and the planets \[N\].
    pub quasi_static_max_pair_load: f64,
    /// Largest dynamic pair load over the passage and the planets \[N\].
    pub dynamic_max_pair_load: f64,
    /// Mean dynamic mesh force, mean over the planets \[N\].
    pub mean_mesh_force: f64,
    /// F^(rms) of the dynamic mesh force, largest over the planets \[N\].
    pub rms_mesh_force: f64,
    /// Quasi-static passage: first and last loaded position \[m\].
    pub quasi_static_passage: (f64, f64),
    /// Dynamic passage: first and last loaded position (the unloaded samples
    /// just outside) \[m\].
    pub dynamic_passage: (f64, f64),
}
/// Wear per cycle from the quasi-static and from the dynamic tooth loads on
/// one state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SourceComparison {
    /// Input speed of the dynamic run [rad/s] (written in rpm, as `speed_rpm`).
    #[serde(rename = "speed_rpm", with = "crate::scene::units::rpm")]
    pub speed: f64,
    /// Each wearing flank and slice.
    pub flanks: Vec<FlankComparison>,
    /// Each wearing mesh.
    pub meshes: Vec<MeshComparison>,
    /// The quasi-static cycle.
    pub quasi_static: CycleWear,
    /// The dynamic cycle.
    pub dynamic: CycleWear,
    /// The dynamic pair loads.
    pub loads: DynamicPairLoads,
}
impl SourceComparison {
    /// The comparison of `flank` in slice 0, if it wears.
    pub fn flank(&self, flank: Flank) -> Option<&FlankComparison> {
        self.flanks.iter().find(|f| f.flank == flank && f.slice == 0)
    }

    /// The comparison of `mesh`, if it wears.
    pub fn mesh(&self, mesh: MeshKind) -> Option<&MeshComparison> {
        self.meshes.iter().find(|m| m.mesh == mesh)
    }
}
/// The wear per cycle of `state` from the quasi-static loads and from the
/// dynamic loads at input speed `speed` [rad/s]: profiles, maxima and where they sit,
/// their ratio, and the largest pair load of each source.
pub fn compare_sources(
    wear: &WearModel,
    state: &WornState,
    speed: f64,
) -> Result<SourceComparison, WearError> {
    let quasi_static = wear.cycle_with(state, PressureSource::QuasiStatic)?;
    let (dynamic, loads) = dynamic_cycle(wear, state, speed)?;
    let mut flanks = Vec::new();
    for q in &quasi_static.flanks {
        let Some(d) = dynamic.flank(q.flank, q.slice) else { continue };
        let ((qm, qr), (dm, dr)) = (q.max_wear(), d.max_wear());
        let largest_difference =
            q.wear_per_cycle.iter().zip(&d.wear_per_cycle).map(|(a, b)| (b - a).abs()).fold(0.0, f64::max)
                / qm.max(f64::MIN_POSITIVE);
        flanks.push(FlankComparison {
            flank: q.flank,
            slice: q.slice,
            roll: q.roll.clone(),
            quasi_static: q.wear_per_cycle.clone(),
            dynamic: d.wear_per_cycle.clone(),
            quasi_static_max: qm,
            quasi_static_max_roll: qr,
            dynamic_max: dm,
            dynamic_max_roll: dr,
            ratio: dm / qm.max(f64::MIN_POSITIVE),
            largest_difference,
        });
    }
    let max_load = |c: &CycleWear, mesh: MeshKind| {
        c.mesh(mesh).map_or(0.0, |p| p.pair_load.iter().flatten().cloned().fold(0.0, f64::max))
    };
    let ends = |c: &CycleWear, mesh: MeshKind| {
        c.mesh(mesh).map_or((0.0, 0.0), |p| {
            (p.position.first().copied().unwrap_or(0.0), p.position.last().copied().unwrap_or(0.0))
        })
    };
    let meshes = quasi_static
        .meshes
        .iter()
        .map(|m| {
            let profiles: Vec<&PairLoadProfile> = loads.of(m.mesh).collect();
            let n = profiles.len().max(1) as f64;
            MeshComparison {
                mesh: m.mesh,
                quasi_static_max_pair_load: max_load(&quasi_static, m.mesh),
                dynamic_max_pair_load: max_load(&dynamic, m.mesh),
                mean_mesh_force: profiles.iter().map(|p| p.mean_mesh_force).sum::<f64>() / n,
                rms_mesh_force: profiles.iter().map(|p| p.rms_mesh_force).fold(0.0, f64::max),
                quasi_static_passage: ends(&quasi_static, m.mesh),
                dynamic_passage: ends(&dynamic, m.mesh),
            }
        })
        .collect();
    Ok(SourceComparison { speed, flanks, meshes, quasi_static, dynamic, loads })
}
