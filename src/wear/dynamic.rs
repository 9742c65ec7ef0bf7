//! Wear driven by the tooth loads of a dynamic run (beyond the study).
//!
//! The study's wear cycle (docs/MODEL.md §4.1, [`crate::wear::archard`]) takes each tooth
//! pair's load from the quasi-static LTCA. Here the pair loads come instead
//! from the steady state of the nonlinear dynamic model at an input speed:
//!
//! 1. The dynamic model is built on the state's worn geometry
//!    ([`WornState::set_model`](crate::wear::state::WornState::set_model) → [`PlanetaryDynamics::new`]), and run
//!    with the wear model's run settings to steady state at the speed
//!    ([`steady_state_observed`]: run-in, then a window of whole mesh cycles).
//! 2. At every sample of the window, each mesh's reference position s and
//!    approach δ give every pair's position s + k·p_b and its elastic load
//!    per face slice ([`MeshContact::pairs`](crate::contact::mesh_law::MeshContact::pairs),
//!    [`MeshContact::slice_forces`](crate::contact::mesh_law::MeshContact::slice_forces):
//!    the pair model's slices, or the deformable law's one transverse slice);
//!    back-flank forces count as zero, as in the quasi-static path (the
//!    coast flanks do not wear). The viscous mesh damping force is not a
//!    tooth load here, as it is not part of F^(m) (docs/MODEL_CHOICES.md).
//! 3. The steady state repeats every mesh cycle and the rigid rotation moves
//!    every pair by one base pitch per cycle, so the samples at the same
//!    phase j of the cycle fall on the same pair positions in every cycle,
//!    pair k + c of cycle c where pair k sat in cycle 0. The load of each
//!    such position is averaged over the window's cycles: one mesh cycle of
//!    samples covers the whole passage of a pair (its pair k at offset
//!    k·p_b), at S samples per cycle, i.e. p_b/S apart. A response that does
//!    not repeat every mesh cycle (subharmonic) is averaged all the same.
//! 4. The wear cycle ([`WearModel`](crate::wear::stepper::WearModel)) takes the pair's first and last loaded
//!    position from these profiles (the unloaded samples just outside, so the
//!    load is zero at both ends of the passage, as in the quasi-static path)
//!    and reads each planet's pair load per slice at its R + 1 positions by
//!    linear interpolation; bands, sliding and Archard wear are computed by
//!    the same code as for the quasi-static loads.
//!
//! S is the run settings' samples per mesh cycle, raised to at least R/ε_α (ε_α
//! the smaller involute contact ratio of the meshes) so that the passage,
//! which is longer than ε_α base pitches, holds at least R samples.
//!
//! Balance (a check): with a periodic steady state every pair sees the same
//! load f(x) at position x, and the mesh force at reference position s is
//! F(s) = Σ_k f(s + k p_b), so ∫ f dx over the passage = ∫_0^{p_b} F ds =
//! p_b·F̄: a pair carries the mean mesh force times the base pitch.

use crate::contact::ltca::{PairContact, SetModel};
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{steady_state_observed, Work};
use crate::geometry::profile::interpolate;
use crate::model::gear::{GearSet, MeshKind};
use crate::model::mesh::PathOfContact;
use crate::model::run::RunSettings;
use crate::wear::archard::{PairLoads, PressureSource, WearError};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// One planet's tooth pair of one mesh through its passage in the dynamic
/// steady state: its load against its position, averaged over the window's
/// mesh cycles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairLoadProfile {
    /// Planet index.
    pub planet: usize,
    /// The mesh.
    pub mesh: MeshKind,
    /// Pair positions on the line of action, increasing, over the contact
    /// tables (wider than the passage) \[m\].
    pub position: Vec<f64>,
    /// Drive-flank load of each face slice at each position, mean over the
    /// window's cycles: `slice_load[slice][i]` \[N\].
    pub slice_load: Vec<Vec<f64>>,
    /// Mean elastic mesh force over the window \[N\].
    pub mean_mesh_force: f64,
    /// F^(rms) of the mesh force, harmonics 1..6 \[N\].
    pub rms_mesh_force: f64,
    /// Largest mesh force of the window \[N\].
    pub max_mesh_force: f64,
}
impl PairLoadProfile {
    /// The pair's load (all slices) at each position \[N\].
    pub fn pair_load(&self) -> Vec<f64> {
        (0..self.position.len()).map(|i| self.slice_load.iter().map(|v| v[i]).sum()).collect()
    }

    /// ∫ pair load ds over the profile (trapezoid) [N·m].
    pub fn load_integral(&self) -> f64 {
        let f = self.pair_load();
        self.position.windows(2).zip(f.windows(2)).map(|(x, y)| 0.5 * (y[0] + y[1]) * (x[1] - x[0])).sum()
    }

    /// Largest pair load \[N\].
    pub fn max_pair_load(&self) -> f64 {
        self.pair_load().into_iter().fold(0.0, f64::max)
    }

    /// First and last position with load, widened to the unloaded samples
    /// just outside \[m\]; `None` when the pair never carries load.
    fn loaded_range(&self) -> Option<(f64, f64)> {
        let load = self.pair_load();
        let first = load.iter().position(|f| *f > 0.0)?;
        let last = load.iter().rposition(|f| *f > 0.0)?;
        Some((self.position[first.saturating_sub(1)], self.position[(last + 1).min(load.len() - 1)]))
    }
}
/// The tooth-pair loads of a dynamic steady state, each planet and mesh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynamicPairLoads {
    /// Input speed [rad/s] (written in rpm, as `speed_rpm`).
    #[serde(rename = "speed_rpm", with = "crate::scene::units::rpm")]
    pub speed: f64,
    /// Mesh frequency \[Hz\].
    pub mesh_frequency: f64,
    /// Mesh cycles in the window, averaged [-].
    pub cycles: usize,
    /// Samples per mesh cycle [-].
    pub samples_per_cycle: usize,
    /// One profile per mesh of the dynamic model (planet-major: sun, ring).
    pub profiles: Vec<PairLoadProfile>,
    /// Integrator work of the run.
    pub stats: Work,
}
impl DynamicPairLoads {
    /// The profiles of `mesh`, in planet order.
    pub fn of(&self, mesh: MeshKind) -> impl Iterator<Item = &PairLoadProfile> {
        self.profiles.iter().filter(move |p| p.mesh == mesh)
    }
}
impl PairLoads for DynamicPairLoads {
    fn engagement(&self, mesh: MeshKind) -> (f64, f64) {
        let ranges: Vec<(f64, f64)> = self.of(mesh).filter_map(PairLoadProfile::loaded_range).collect();
        if ranges.is_empty() {
            // No load anywhere: the tables' range, which wears nothing.
            let lo = self.of(mesh).filter_map(|p| p.position.first()).cloned().fold(f64::INFINITY, f64::min);
            let hi =
                self.of(mesh).filter_map(|p| p.position.last()).cloned().fold(f64::NEG_INFINITY, f64::max);
            return if lo < hi { (lo, hi) } else { (0.0, 0.0) };
        }
        let first = ranges.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
        let last = ranges.iter().map(|r| r.1).fold(f64::NEG_INFINITY, f64::max);
        (first, last)
    }

    fn slice_loads(&self, mesh: MeshKind, position: &[f64]) -> Vec<Vec<Vec<f64>>> {
        self.of(mesh)
            .map(|p| {
                p.slice_load
                    .iter()
                    .map(|load| {
                        position
                            .iter()
                            .map(|s| {
                                // Beyond the tables no pair touches.
                                let inside = p.position.first().is_some_and(|a| s >= a)
                                    && p.position.last().is_some_and(|b| s <= b);
                                if inside {
                                    interpolate(&p.position, load, *s).max(0.0)
                                } else {
                                    0.0
                                }
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect()
    }
}
/// Sums of one pair position's samples over the window's cycles.
#[derive(Clone, Debug, Default)]
struct Accumulator {
    position: f64,
    slice_load: Vec<f64>,
    count: usize,
}
/// Samples per mesh cycle of a dynamic wear run: the run settings', raised
/// to at least R/ε_α so that a passage holds at least R samples [-].
pub fn samples_per_cycle(set: &GearSet, run: &RunSettings, positions: usize) -> usize {
    let ratio = MeshKind::ALL
        .iter()
        .map(|m| PathOfContact::new(set, *m).involute_contact_ratio())
        .fold(f64::INFINITY, f64::min)
        .max(1.0);
    run.samples_per_mesh_cycle().max((positions as f64 / ratio).ceil() as usize)
}
/// Runs the dynamic model on `contact` (the contact models of a worn or
/// unworn set) to steady state at input speed `speed` [rad/s] and records each planet's
/// tooth-pair load per face slice through its passage, at
/// [`samples_per_cycle`] samples per mesh cycle for `positions` wear
/// positions. Gives the contact models back for the wear cycle.
pub fn record_pair_loads(
    set: &GearSet,
    run: &RunSettings,
    contact: SetModel,
    speed: f64,
    positions: usize,
) -> Result<(DynamicPairLoads, SetModel), WearError> {
    PressureSource::Dynamic { speed }.validate()?;
    let failed = |reason: String| WearError::DynamicRun { speed, reason };
    let samples = samples_per_cycle(set, run, positions);
    let run = run.with(|d| d.samples_per_mesh_cycle = samples).map_err(|e| failed(e.to_string()))?;
    let mut dynamics = PlanetaryDynamics::new(set, contact).map_err(|e| failed(e.to_string()))?;
    let n_mesh = dynamics.mesh_count();
    // Per mesh: the reference position of each phase in the first cycle, and
    // the sums per (phase, pair offset from that reference).
    let mut reference: Vec<Vec<Option<f64>>> = vec![vec![None; samples]; n_mesh];
    let mut sums: Vec<HashMap<(usize, i64), Accumulator>> = vec![HashMap::new(); n_mesh];
    let mut pairs: Vec<PairContact> = Vec::new();
    let mut slice = Vec::new();
    let mut failure: Option<String> = None;
    let ss = steady_state_observed(&mut dynamics, set, &run, speed, None, |k, model| {
        let phase = k % samples;
        for (i, state) in model.meshes.iter().enumerate() {
            let (_, kind) = model.mesh_identity(i);
            let mesh = model.mesh_model(kind);
            let pb = mesh.path().base_pitch;
            let origin = *reference[i][phase].get_or_insert(state.position);
            let shift = ((state.position - origin) / pb).round() as i64;
            if let Err(e) = mesh.pairs(state.position, state.approach, &mut pairs) {
                failure.get_or_insert(e.to_string());
                continue;
            }
            for pair in &pairs {
                mesh.slice_forces(pair, state.approach, &mut slice);
                let acc = sums[i].entry((phase, i64::from(pair.index) + shift)).or_default();
                if acc.slice_load.len() < slice.len() {
                    acc.slice_load.resize(slice.len(), 0.0);
                }
                acc.position += pair.position;
                for (a, f) in acc.slice_load.iter_mut().zip(&slice) {
                    // Only the drive flanks wear; a back-flank force is negative.
                    *a += f.max(0.0);
                }
                acc.count += 1;
            }
        }
    })
    .map_err(|e| failed(e.to_string()))?;
    if let Some(reason) = failure {
        return Err(failed(reason));
    }
    let mut profiles = Vec::with_capacity(n_mesh);
    for (i, map) in sums.into_iter().enumerate() {
        let (planet, mesh) = dynamics.mesh_identity(i);
        let mut points: Vec<(f64, Vec<f64>)> = map
            .into_values()
            .map(|a| {
                let n = a.count.max(1) as f64;
                (a.position / n, a.slice_load.iter().map(|f| f / n).collect())
            })
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let slices = points.iter().map(|p| p.1.len()).max().unwrap_or(0);
        let response = &ss.meshes[i];
        profiles.push(PairLoadProfile {
            planet,
            mesh,
            position: points.iter().map(|p| p.0).collect(),
            slice_load: (0..slices)
                .map(|j| points.iter().map(|p| p.1.get(j).copied().unwrap_or(0.0)).collect())
                .collect(),
            mean_mesh_force: response.harmonics.mean,
            rms_mesh_force: response.harmonics.rms,
            max_mesh_force: response.max_force,
        });
    }
    let loads = DynamicPairLoads {
        speed,
        mesh_frequency: ss.mesh_frequency,
        cycles: ss.cycles,
        samples_per_cycle: samples,
        profiles,
        stats: ss.stats,
    };
    Ok((loads, dynamics.contact))
}
