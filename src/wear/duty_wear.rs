//! Wear driven by a duty cycle ([`crate::wear::duty::DutyCycle`]): the
//! Archard wear of the revolutions a run or a campaign spent in each load bin,
//! summed.
//!
//! The duty's load torques are binned per mesh. For each torque bin that
//! holds revolutions, the wear per tooth cycle is computed at the bin's mid
//! torque (quasi-static: the LTCA loads of the set under that input torque;
//! dynamic: the steady dynamic loads at the bin's torque and each occupied
//! speed bin's mid speed). The wear per input revolution of the duty is the
//! sum of each bin's wear per cycle weighted by the share of the duty's
//! revolutions in the bin: the sun–planet mesh's share for the flanks it
//! loads (sun, planet on its sun side), the ring–planet mesh's for the
//! others, each the mean over the planets of that mesh's histogram. The
//! state then advances by the revolutions the duty stands for, over as many
//! updates κ → κ + 1 as the update depth asks, the mixture recomputed on each
//! new geometry.
//!
//! Revolutions outside every torque bin cannot be given a load: they are
//! reported ([`DutyWear::outside_share`]), not worn. A bin whose mid torque is
//! not positive (coast) is refused: the coast flanks' wear under a duty is not
//! modelled.

use crate::dynamics::duty::LoadDuty;
use crate::model::gear::{GearSet, MeshKind};
use crate::model::run::RunSettings;
use crate::wear::archard::{CycleWear, Limit, PressureSource, WearError, WearSettings};
use crate::wear::duty::DutyCycle;
use crate::wear::state::{DutyRecord, WornState};
use crate::wear::stepper::WearModel;

/// One load bin's wear model and its shares of the duty's revolutions.
struct Bin {
    model: WearModel,
    /// Share of the duty's revolutions in the bin: sun–planet mesh, ring–planet mesh.
    share: [f64; 2],
}

/// The wear of a duty cycle on a gear set (module documentation).
pub struct DutyWear {
    bins: Vec<Bin>,
    /// The duty's input revolutions and time \[s\].
    revolutions: f64,
    duration: f64,
    /// The duty document's checksum and source, recorded in the states it wears.
    fingerprint: String,
    source: String,
    outside: f64,
}

/// A load bin: its torque bin and, for dynamic loads, its speed bin.
type BinIndex = (usize, Option<usize>);

/// Per torque bin (and per speed bin when `by_speed`): the mean over the planets of each mesh
/// kind's revolutions.
fn bin_revolutions(duty: &LoadDuty, by_speed: bool) -> Vec<(BinIndex, [f64; 2])> {
    let (nt, ns) = duty.bins().shape();
    let planets = duty.planets() as f64;
    let mut out = Vec::new();
    for i in 0..nt {
        let speeds: Vec<Option<usize>> = if by_speed { (0..ns).map(Some).collect() } else { vec![None] };
        for j in speeds {
            let mut r = [0.0; 2];
            for (k, kind) in MeshKind::ALL.into_iter().enumerate() {
                for p in 0..duty.planets() {
                    let mesh = duty.mesh(p, kind).unwrap_or(&[]);
                    let row = &mesh[i * ns..(i + 1) * ns];
                    r[k] += match j {
                        Some(j) => row[j],
                        None => row.iter().sum(),
                    } / planets;
                }
            }
            if r.iter().any(|x| *x > 0.0) {
                out.push(((i, j), r));
            }
        }
    }
    out
}

impl DutyWear {
    /// The duty `cycle`'s wear on `set` with `settings` (its source: quasi-static loads per
    /// torque bin, or with [`PressureSource::Dynamic`] the steady dynamic loads per torque and
    /// speed bin, which needs `run`).
    pub fn new(
        set: &GearSet,
        run: Option<&RunSettings>,
        settings: &WearSettings,
        cycle: &DutyCycle,
    ) -> Result<Self, WearError> {
        let duty = &cycle.duty;
        let total = duty.total_revolutions();
        if !(total > 0.0 && total.is_finite()) {
            return Err(WearError::InvalidLimit {
                name: "duty cycle",
                value: format!("{total} input revolutions"),
                allowed: "a duty with revolutions (the run recorded none)",
            });
        }
        let dynamic = matches!(settings.source, PressureSource::Dynamic { .. });
        let (t_edges, s_edges) = (duty.bins().torque_edges(), duty.bins().speed_edges());
        let mut bins = Vec::new();
        for ((i, j), r) in bin_revolutions(duty, dynamic) {
            let torque = 0.5 * (t_edges[i] + t_edges[i + 1]);
            if torque <= 0.0 {
                return Err(WearError::InvalidLimit {
                    name: "duty cycle",
                    value: format!("{:.4e} revolutions at {torque} N·m", r[0].max(r[1])),
                    allowed:
                        "bins of positive load torque (the coast flanks' wear under a duty is not modelled)",
                });
            }
            let loaded = set.with_input_torque(torque).ok_or(WearError::InvalidLimit {
                name: "duty cycle",
                value: format!("a bin at {torque} N·m"),
                allowed: "finite load torques",
            })?;
            let mut s = *settings;
            let model = match (j, run) {
                (Some(j), Some(run)) => {
                    s.source = PressureSource::Dynamic { speed: 0.5 * (s_edges[j] + s_edges[j + 1]) };
                    WearModel::with_run(&loaded, run, s)?
                }
                (Some(_), None) => {
                    return Err(WearError::InvalidSetting {
                        name: "source",
                        value: "dynamic".into(),
                        allowed: "quasi-static without the run settings of a dynamic run",
                    })
                }
                (None, _) => WearModel::new(&loaded, s)?,
            };
            bins.push(Bin { model, share: r.map(|x| x / total) });
        }
        let outside = (0..duty.planets())
            .flat_map(|p| MeshKind::ALL.map(|k| duty.outside(p, k).unwrap_or(0.0)))
            .fold(0.0_f64, f64::max);
        Ok(Self {
            bins,
            revolutions: total,
            duration: duty.duration(),
            fingerprint: cycle.fingerprint(),
            source: cycle.source.clone(),
            outside: outside / total,
        })
    }

    /// The largest share of a mesh's revolutions outside every torque bin (not worn).
    pub fn outside_share(&self) -> f64 {
        self.outside
    }

    /// Input revolutions and time \[s\] of one pass of the duty.
    pub fn duty(&self) -> (f64, f64) {
        (self.revolutions, self.duration)
    }

    /// Load bins worn (occupied torque bins, or torque × speed bins for dynamic loads).
    pub fn bins(&self) -> usize {
        self.bins.len()
    }

    /// The wear per input revolution of the duty on `state`, as one cycle: each flank's wear
    /// per tooth cycle the bins' weighted by their shares of the flank's mesh (the other fields
    /// are the first bin's).
    pub fn cycle(&self, state: &WornState) -> Result<CycleWear, WearError> {
        let cycles: Vec<CycleWear> =
            self.bins.iter().map(|b| b.model.cycle(state)).collect::<Result<_, _>>()?;
        let mut mixed = cycles[0].clone();
        for fw in &mut mixed.flanks {
            let kind = fw.flank.drive_mesh().map_or(MeshKind::SunPlanet, |(k, _)| k);
            let k = kind.offset();
            fw.wear_per_cycle.iter_mut().for_each(|h| *h = 0.0);
            fw.wear_per_planet.iter_mut().flatten().for_each(|h| *h = 0.0);
            for (bin, c) in self.bins.iter().zip(&cycles) {
                let Some(w) = c.flank(fw.flank, fw.slice) else { continue };
                for (h, x) in fw.wear_per_cycle.iter_mut().zip(&w.wear_per_cycle) {
                    *h += bin.share[k] * x;
                }
                for (hp, xp) in fw.wear_per_planet.iter_mut().zip(&w.wear_per_planet) {
                    for (h, x) in hp.iter_mut().zip(xp) {
                        *h += bin.share[k] * x;
                    }
                }
            }
        }
        Ok(mixed)
    }

    /// Advances `state` by `repeat` passes of the duty: its revolutions times `repeat`, over
    /// as many updates as the update depth asks (or until the total wear limit). The state
    /// records the duty (its checksum, the passes, revolutions and operating time).
    pub fn advance(&self, state: &WornState, repeat: f64) -> Result<WornState, WearError> {
        if !(repeat.is_finite() && repeat > 0.0) {
            return Err(WearError::InvalidLimit {
                name: "repeat",
                value: repeat.to_string(),
                allowed: "a finite number of passes of the duty cycle > 0",
            });
        }
        let model = &self.bins[0].model;
        let target = self.revolutions * repeat;
        let mut current = state.clone();
        let mut done = 0.0;
        while target - done > 1e-12 * target {
            if current.deepest().depth >= model.settings().total_depth * (1.0 - 1e-12) {
                break;
            }
            let cycle = self.cycle(&current)?;
            let next = model.apply(&current, &cycle, Limit::Revolutions(target - done))?;
            done += next.revolutions - current.revolutions;
            current = next;
        }
        let passes = done / self.revolutions;
        current.operating_time += passes * self.duration;
        current.duty_cycles.push(DutyRecord {
            checksum: self.fingerprint.clone(),
            source: self.source.clone(),
            passes,
            revolutions: done,
            operating_time: passes * self.duration,
            kappa: (state.kappa, current.kappa),
        });
        Ok(current)
    }
}
