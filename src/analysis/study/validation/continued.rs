//! The validation's forced response from the continuation's branches: the
//! periodic states of the harmonic balance condensed onto the contact
//! coordinates (`CondensedBalance`, the planets' cyclic symmetry checked at
//! every point, and where a restart's march breaks it, the symmetry-broken
//! branch followed with every mesh), followed up and down in speed through their folds, with
//! their stability from the whole model's Floquet multipliers.
//!
//! A direction's curve is what its run passes on stable states: at each
//! speed of the plan's grid, the first stretch of the branch (in the order
//! the run followed it) whose two ends are stable and which spans that
//! speed. So the up run's curve holds the lower branch of a softening jump
//! up to its fold and the down run's the upper one down to its fold; no
//! reading depends on which attractor an integrator's error picked.
//! Where no stable stretch spans a speed, the curve takes the branch's
//! unstable state there, and the count of such speeds is reported.

use crate::analysis::study::StudyError;
use std::time::Instant;

use rayon::prelude::*;

use super::{Curve, CurvePoint, ForcedResponse, Spot, SweepRun, ValidationPlan, SPOT_SPEEDS};
use crate::analysis::condensed_branch::CondensedBranch;
use crate::analysis::continuation::{
    follow_branch, follow_joining, BifurcationKind, Branch, ContinuationSettings,
};
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::periodic::{
    CondensedBalance, HarmonicBalance, HarmonicSettings, PeriodicProblem, ShootingSettings, Symmetry,
};
use crate::dynamics::response::{
    steady_state, sweep_from, Direction, MeshResponse, State, SteadyState, Window,
};
use crate::model::gear::GearSet;
use crate::model::gear::MeshKind;
use crate::model::run::RunSettings;
use crate::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};

/// One direction's continuation, reduced to what the rows read.
pub(super) struct Continued {
    /// The measures of each branch point, in branch order.
    pub points: Vec<CurvePoint>,
    /// Whether each point is stable.
    pub stable: Vec<bool>,
    /// Whether each point is the first after a gap (not joined to the one before).
    pub after_gap: Vec<bool>,
    /// Each point's state at the period's end (where a march from it starts).
    pub ends: Vec<State>,
    /// Fold speeds \[rpm\], in the order met.
    pub folds: Vec<f64>,
    /// Period-doubling speeds \[rpm\].
    pub doublings: Vec<f64>,
    /// Why the run ended.
    pub ended: String,
    /// For each speed asked for a spot check, the point nearest it of those
    /// [`spot_candidates`] allows (each point once):
    /// its measures, its largest Floquet multiplier |μ| and its state at the
    /// period's end (where a march from it starts).
    pub spots: Vec<(CurvePoint, f64, State)>,
    /// The speed \[rad/s\] where the run joined an earlier run's branch and
    /// ended (`None`: it ran to its last speed or stopped for another reason).
    pub joined: Option<f64>,
    /// Whether every point of the run kept the planets' cyclic symmetry: no restart went on
    /// with every mesh along a symmetry-broken branch, and no solve gave the symmetry up.
    pub cyclic: bool,
}

/// The sun–planet and ring–planet meshes' F^(rms), each the largest of the planets', and
/// separation, each the largest of the planets'. On an orbit that keeps the planets'
/// symmetry every planet reads alike (planet 1's figures); on one that breaks it (one planet
/// loaded apart from the others, near 11 500 rpm on the example) the reading does not depend
/// on which planet the march that reached it happened to load.
pub(super) fn measures(ss: &SteadyState) -> CurvePoint {
    reading(ss.input_speed, &ss.meshes)
}

/// [`measures`] of the meshes `meshes` at the input speed `speed` [rad/s].
fn reading(speed: f64, meshes: &[MeshResponse]) -> CurvePoint {
    let largest = |k: MeshKind, of: fn(&MeshResponse) -> f64| {
        meshes.iter().filter(|m| m.mesh == k).map(of).fold(0.0, f64::max)
    };
    let (sun, ring) = (MeshKind::SunPlanet, MeshKind::RingPlanet);
    CurvePoint {
        speed,
        rms: [largest(sun, |m| m.harmonics.rms), largest(ring, |m| m.harmonics.rms)],
        separation: [largest(sun, |m| m.separation), largest(ring, |m| m.separation)],
    }
}

/// Follows the periodic states of `model` from `from` to `to` \[rad/s\] at
/// the nominal step `step` \[rad/s\] on the cyclic condensed balance, and
/// keeps the stable point nearest each of `spots` \[rad/s\] at least half
/// the step from the run's folds and changes of stability for its spot
/// check ([`spot_candidates`]). With `joining`, an earlier run of the same model from `to`
/// towards `from`, the run ends where it joins that run's unbroken stretch
/// (`follow_joining`: beyond, it would retrace it). Also gives the branch.
/// Each point's forces are sampled at `samples` per mesh cycle, the marching
/// reading's: where a force has a narrow peak its sampled harmonics depend
/// on the grid, and the branch and marching are compared on one grid.
pub(super) fn follow(
    model: &PlanetaryDynamics,
    (from, to, step): (f64, f64, f64),
    (spots, samples): (&[f64], usize),
    joining: Option<&Branch>,
) -> Result<(Continued, Branch), StudyError> {
    let shooting = ShootingSettings { samples_per_mesh_cycle: samples, ..ShootingSettings::default() };
    let problem = PeriodicProblem::new(model.clone(), shooting, from)?;
    let hb = HarmonicBalance::new(problem, HarmonicSettings::default())?;
    let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
    let settings = ContinuationSettings::new(from, to, step);
    let mut solver = CondensedBranch::new(&mut cb);
    // A restart whose march reaches a state that breaks the planets' symmetry goes on along
    // that branch (where the symmetric one is unstable), as a marching sweep would ride it.
    solver.follow_broken_symmetry(true);
    let branch = match joining {
        Some(other) => follow_joining(&mut solver, &settings, other, |_| {}),
        None => follow_branch(&mut solver, &settings, |_| {}),
    }?;
    let orbits = std::mem::take(&mut solver.orbits);
    let cyclic = solver.broken_restarts() == 0 && cb.symmetry() == Symmetry::Cyclic;
    let mut points = Vec::with_capacity(orbits.len());
    let mut ends = Vec::with_capacity(orbits.len());
    let eligible = spot_candidates(&branch, step / 2.0);
    let mut nearest: Vec<Option<(f64, usize)>> = vec![None; spots.len()];
    for (i, (orbit, p)) in orbits.iter().zip(&branch.points).enumerate() {
        let ss = cb.balance().steady_state(orbit)?;
        for (near, spot) in nearest.iter_mut().zip(spots) {
            let d = (p.orbit.speed - spot).abs();
            if eligible[i] && near.is_none_or(|n| d < n.0) {
                *near = Some((d, i));
            }
        }
        points.push(measures(&ss));
        ends.push(ss.end);
    }
    // Two spot speeds whose nearest point is the same point check it once.
    let mut chosen: Vec<usize> = Vec::new();
    for (_, i) in nearest.into_iter().flatten() {
        if !chosen.contains(&i) {
            chosen.push(i);
        }
    }
    let mut run = Continued::of(&branch, points, cyclic);
    run.spots = chosen
        .iter()
        .map(|&i| (run.points[i], branch.points[i].orbit.largest_multiplier(), ends[i].clone()))
        .collect();
    run.ends = ends;
    Ok((run, branch))
}

/// Which points of `branch` a spot check may start from: the stable points at
/// least `margin` \[rad/s\] in speed from every fold, period doubling, change
/// of stability, turn of the run in speed and gap. Near a fold F^(rms) moves
/// steeply with speed (on `example-2004-deformable` at κ = 6, up: from 260.7
/// to 276.6 N/mm within 1.4 rpm below the fold at 10 152 rpm), so a march
/// from a point there meets the branch's steepness, not its error.
fn spot_candidates(branch: &Branch, margin: f64) -> Vec<bool> {
    let p = &branch.points;
    let mut edges: Vec<f64> = branch.bifurcations.iter().map(|b| b.speed).collect();
    for w in p.windows(2) {
        let turned = w[0].speed_slope.signum() != w[1].speed_slope.signum();
        if w[0].stable != w[1].stable || w[1].after_gap || turned {
            edges.extend([w[0].orbit.speed, w[1].orbit.speed]);
        }
    }
    p.iter().map(|q| q.stable && edges.iter().all(|e| (q.orbit.speed - e).abs() >= margin)).collect()
}

impl Continued {
    fn of(branch: &Branch, points: Vec<CurvePoint>, cyclic: bool) -> Self {
        let at = |kind: BifurcationKind| {
            branch.bifurcations.iter().filter(|b| b.kind == kind).map(|b| rad_per_s_to_rpm(b.speed)).collect()
        };
        Self {
            stable: branch.points.iter().map(|p| p.stable).collect(),
            after_gap: branch.points.iter().map(|p| p.after_gap).collect(),
            ends: Vec::new(),
            folds: at(BifurcationKind::Fold),
            doublings: at(BifurcationKind::PeriodDoubling),
            ended: branch.ended.clone(),
            joined: branch
                .ended
                .starts_with("joined")
                .then(|| branch.points.last().map(|p| p.orbit.speed))
                .flatten(),
            spots: Vec::new(),
            cyclic,
            points,
        }
    }

    /// The direction's curve on `grid` \[rad/s, ascending\] (see the module's
    /// words) and, for each of its speeds, the branch point nearest it on the
    /// stretch read, or `None` where that stretch is stable.
    pub fn curve(&self, grid: &[f64], kappa: u32, direction: Direction) -> (Curve, Vec<Option<usize>>) {
        let mut unstable = Vec::with_capacity(grid.len());
        let points = grid
            .iter()
            .map(|&speed| {
                let (p, stable, near) = self.at(speed);
                unstable.push((!stable).then_some(near));
                p
            })
            .collect();
        (Curve { kappa, direction, points }, unstable)
    }

    /// The branch point a marching sweep over the unstable stretch of grid indices `indices`
    /// (in the order of a sweep in `direction`) starts from: where the grid speed before the
    /// stretch is read on a stable state, that state's point, as a sweep enters the stretch
    /// from it; otherwise `near`, the point nearest the stretch's first speed.
    fn march_start(&self, grid: &[f64], indices: &[usize], near: usize, direction: Direction) -> usize {
        let first = indices[0];
        let before = match direction {
            Direction::Up => first.checked_sub(1),
            Direction::Down => Some(first + 1).filter(|&j| j < grid.len()),
        };
        before.map(|j| self.at(grid[j])).filter(|(_, stable, _)| *stable).map_or(near, |(_, _, point)| point)
    }

    /// The measures at `speed` on the first stretch spanning it whose ends
    /// are both stable; failing that, one end stable; failing that, any;
    /// with no stretch spanning it, the nearest point. Linear in speed
    /// between the stretch's ends. Also whether the state read is stable, and
    /// the branch point nearest `speed` of those read.
    fn at(&self, speed: f64) -> (CurvePoint, bool, usize) {
        let spans = |i: usize| {
            let (a, b) = (self.points[i].speed, self.points[i + 1].speed);
            !self.after_gap[i + 1] && speed >= a.min(b) && speed <= a.max(b)
        };
        let stable_ends = |i: usize| usize::from(self.stable[i]) + usize::from(self.stable[i + 1]);
        let pairs = 0..self.points.len().saturating_sub(1);
        let found = [2, 1, 0]
            .into_iter()
            .find_map(|need| pairs.clone().find(|&i| spans(i) && stable_ends(i) >= need).map(|i| (i, need)));
        match found {
            Some((i, need)) => {
                let (a, b) = (&self.points[i], &self.points[i + 1]);
                let t = if b.speed == a.speed { 0.0 } else { (speed - a.speed) / (b.speed - a.speed) };
                let mix = |x: f64, y: f64| x + (y - x) * t;
                let point = CurvePoint {
                    speed,
                    rms: [mix(a.rms[0], b.rms[0]), mix(a.rms[1], b.rms[1])],
                    separation: [
                        mix(a.separation[0], b.separation[0]),
                        mix(a.separation[1], b.separation[1]),
                    ],
                };
                let near = if (speed - a.speed).abs() <= (speed - b.speed).abs() { i } else { i + 1 };
                (point, need == 2, near)
            }
            None => {
                let i = (0..self.points.len())
                    .min_by(|&i, &j| {
                        (self.points[i].speed - speed).abs().total_cmp(&(self.points[j].speed - speed).abs())
                    })
                    .unwrap_or(0);
                let mut p = self.points.get(i).copied().unwrap_or(CurvePoint {
                    speed,
                    rms: [f64::NAN; 2],
                    separation: [f64::NAN; 2],
                });
                p.speed = speed;
                (p, self.stable.get(i).copied().unwrap_or(false), i)
            }
        }
    }
}

/// What the steps of the validation's continuation share.
struct Continuing<'a> {
    set: &'a GearSet,
    run: &'a RunSettings,
    /// The models at κ = 0 and at the worn κ.
    models: [&'a PlanetaryDynamics; 2],
    /// The geometry states of the two models.
    kappas: [u32; 2],
    /// The plan's grid \[rad/s, ascending\].
    speeds: Vec<f64>,
    /// The runs' ends and nominal step \[rad/s\].
    first: f64,
    last: f64,
    step: f64,
    /// The spot checks' speeds \[rad/s\].
    spots: Vec<f64>,
}

/// One run and the curve read on it, with the count of its speeds read by marching.
struct Read {
    run: Continued,
    curve: Curve,
    marched: usize,
}

impl Continuing<'_> {
    /// Model `s`'s up run, then its down run ending where it joins the up run's
    /// unbroken stretch (below, it would retrace it); the up run's curve is
    /// read (its unstable stretches marched) while the down run is followed
    /// and read.
    fn state(&self, s: usize) -> Result<[Read; 2], StudyError> {
        let model = self.models[s];
        let grid = (&self.spots[..], self.run.samples_per_mesh_cycle());
        let (up, branch) = follow(model, (self.first, self.last, self.step), grid, None)?;
        let (up, down) = rayon::join(
            || self.read(s, up, Direction::Up),
            || {
                let (down, _) = follow(model, (self.last, self.first, self.step), grid, Some(&branch))?;
                self.read(s, down, Direction::Down)
            },
        );
        let (up, mut down) = (up?, down?);
        // Below the down run's join its curve is the up run's.
        if let Some(joined) = down.run.joined {
            for i in (0..self.speeds.len()).filter(|&i| self.speeds[i] < joined) {
                down.curve.points[i] = up.curve.points[i];
            }
        }
        Ok([up, down])
    }

    /// The curve of `run` on the grid. Where the run's periodic state is
    /// unstable, a sweep leaves it for another attractor (a longer period, a
    /// torus): those speeds are read on a marching sweep over each such
    /// stretch, in the run's direction, started as a sweep enters it: from the
    /// stable state read at the grid speed before it ([`Continued::march_start`]).
    /// Speeds below a run's join are left to the caller.
    fn read(&self, s: usize, run: Continued, direction: Direction) -> Result<Read, StudyError> {
        let (mut curve, mut unstable) = run.curve(&self.speeds, self.kappas[s], direction);
        if let Some(joined) = run.joined {
            for (u, w) in unstable.iter_mut().zip(&self.speeds) {
                if *w < joined {
                    *u = None;
                }
            }
        }
        let stretches = unstable_stretches(&unstable, direction);
        let marched = stretches
            .par_iter()
            .map(|(indices, near)| {
                let grid: Vec<f64> = indices.iter().map(|&i| self.speeds[i]).collect();
                let mut m = self.models[s].clone();
                let start = &run.ends[run.march_start(&self.speeds, indices, *near, direction)];
                sweep_from(
                    self.set,
                    self.run,
                    &mut m,
                    direction,
                    &grid,
                    &[],
                    Window::Fixed,
                    Some(start),
                    |_| {},
                )
                .map(|sweep| (indices, sweep))
                .map_err(|e| {
                    StudyError::from(e).at(format!(
                        "marching over an unstable stretch from {:.0} rpm",
                        rad_per_s_to_rpm(grid[0])
                    ))
                })
            })
            .collect::<Result<Vec<_>, StudyError>>()?;
        let mut count = 0;
        for (indices, sweep) in marched {
            count += indices.len();
            for (&i, ss) in indices.iter().zip(&sweep.points) {
                curve.points[i] = measures(ss);
            }
        }
        Ok(Read { run, curve, marched: count })
    }

    /// Marches from each run's stable points nearest the spot speeds and
    /// sets the result beside the branch.
    fn spot_checks(&self, reads: &[Read]) -> Result<Vec<Spot>, StudyError> {
        let marches: Vec<(usize, &Read, &(CurvePoint, f64, State))> =
            reads.iter().enumerate().flat_map(|(k, r)| r.run.spots.iter().map(move |s| (k, r, s))).collect();
        marches
            .par_iter()
            .map(|&(k, r, (point, multiplier, state))| {
                let mut m = self.models[k / 2].clone();
                let ss = steady_state(&mut m, self.set, self.run, point.speed, Some(state)).map_err(|e| {
                    StudyError::from(e).at(format!("spot check at {:.1} rpm", rad_per_s_to_rpm(point.speed)))
                })?;
                Ok(Spot {
                    kappa: r.curve.kappa,
                    direction: r.curve.direction,
                    rpm: rad_per_s_to_rpm(point.speed),
                    branch: point.rms,
                    marched: measures(&ss).rms,
                    multiplier: *multiplier,
                })
            })
            .collect()
    }
}

/// Each run's folds and period doublings, in words.
fn bifurcation_words(reads: &[Read]) -> String {
    let list = |xs: &[f64]| xs.iter().map(|x| format!("{x:.0}")).collect::<Vec<_>>().join(", ");
    reads
        .iter()
        .map(|r| {
            let dir = if r.curve.direction == Direction::Up { "up" } else { "down" };
            let folds = if r.run.folds.is_empty() {
                "no fold".to_string()
            } else {
                format!("folds at {} rpm", list(&r.run.folds))
            };
            let doubling = if r.run.doublings.is_empty() {
                String::new()
            } else {
                format!(", period doubling at {} rpm", list(&r.run.doublings))
            };
            format!("κ = {} {dir}: {folds}{doubling}", r.curve.kappa)
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// The validation's four curves (κ = 0 and `kappa`, up and down) from the
/// continuation's branches (module documentation), with the spot checks.
pub(super) fn sweep_run(
    set: &GearSet,
    run: &RunSettings,
    plan: &ValidationPlan,
    models: [&PlanetaryDynamics; 2],
    kappa: u32,
    integrator: &str,
) -> Result<SweepRun, StudyError> {
    debug_assert_eq!(plan.forced, ForcedResponse::Continuation);
    let t = Instant::now();
    let grid = plan.speeds();
    let (first, last) = (grid[0], grid[grid.len() - 1]);
    let step = plan.sweep.iter().map(|s| s.2).fold(f64::INFINITY, f64::min);
    let c = Continuing {
        set,
        run,
        models,
        kappas: [0, kappa],
        speeds: grid.iter().copied().map(rpm_to_rad_per_s).collect(),
        first: rpm_to_rad_per_s(first),
        last: rpm_to_rad_per_s(last),
        step: rpm_to_rad_per_s(step),
        spots: SPOT_SPEEDS
            .iter()
            .filter(|s| (first..=last).contains(*s))
            .copied()
            .map(rpm_to_rad_per_s)
            .collect(),
    };
    // The two states on rayon's threads.
    let (a, b) = rayon::join(|| c.state(0), || c.state(1));
    let reads: Vec<Read> = a?.into_iter().chain(b?).collect();
    let seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let spots = c.spot_checks(&reads)?;
    let spot_seconds = t.elapsed().as_secs_f64();
    let cyclic = reads.iter().all(|r| r.run.cyclic);
    let early: String = reads
        .iter()
        .filter(|r| !r.run.ended.starts_with("reached") && r.run.joined.is_none())
        .map(|r| format!("; a run ended early: {}", r.run.ended))
        .collect();
    let method = format!(
        "continuation of the periodic states {first:.0}–{last:.0} rpm at a nominal step of {step:.0} rpm, up and down, κ = 0 and κ = {kappa} (each state's down run after its up run, ending where it joins the up run's unbroken stretch, below which its curve is the up run's; the two states in parallel), on the harmonic balance condensed onto the contact coordinates ({}; H by the rule, at most {}); stability from the whole model's Floquet multipliers; each direction's curve read on the first stable stretch of its run spanning each speed of the grid ({}){early}; {} of the 4 × {} curve points, where no stable periodic state of the run spans the speed, read on marching sweeps over those stretches, each from the stable state read at the grid speed before it ({integrator}); spot-checked by marching from {} stable branch points, each the nearest a spot speed of those at least half the nominal step from the run's folds, changes of stability and gaps ({integrator})",
        if cyclic {
            "the planets' cyclic symmetry held on every run, checked at every point"
        } else {
            "where a restart's march broke the planets' cyclic symmetry, on with every mesh along that branch to the next restart"
        },
        crate::dynamics::periodic::CONDENSED_MAX_HARMONICS,
        plan.describe(),
        reads.iter().map(|r| r.marched).sum::<usize>(),
        grid.len(),
        spots.len(),
    );
    Ok(SweepRun {
        folds: bifurcation_words(&reads),
        curves: reads.into_iter().map(|r| r.curve).collect(),
        check_curves: Vec::new(),
        check_from: None,
        method,
        spots,
        seconds,
        spot_seconds,
    })
}

/// The stretches of consecutive grid indices read on an unstable state
/// (`unstable[i]`: the branch point nearest speed i), each in the order a
/// sweep in `direction` meets them, with the branch point nearest its first speed.
fn unstable_stretches(unstable: &[Option<usize>], direction: Direction) -> Vec<(Vec<usize>, usize)> {
    let mut out: Vec<(Vec<usize>, usize)> = Vec::new();
    let mut i = 0;
    while i < unstable.len() {
        if unstable[i].is_none() {
            i += 1;
            continue;
        }
        let start = i;
        while i < unstable.len() && unstable[i].is_some() {
            i += 1;
        }
        let mut indices: Vec<usize> = (start..i).collect();
        if direction == Direction::Down {
            indices.reverse();
        }
        let near = unstable[indices[0]].expect("in the stretch");
        out.push((indices, near));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Planet `planet`'s two meshes with F^(rms) `rms` and separation `separation`.
    fn planet_meshes(planet: usize, rms: f64, separation: f64) -> Vec<MeshResponse> {
        [(MeshKind::SunPlanet, 1.0), (MeshKind::RingPlanet, 0.5)]
            .into_iter()
            .map(|(mesh, share)| MeshResponse {
                planet,
                mesh,
                harmonics: crate::dynamics::spectrum::Harmonics {
                    mean: 263.0,
                    amplitude: vec![share * rms],
                    rms: share * rms,
                },
                separation: share * separation,
                max_force: 0.0,
            })
            .collect()
    }

    #[test]
    fn a_reading_is_planet_1_where_the_planets_are_alike_and_the_loaded_planet_where_one_breaks_ranks() {
        let alike: Vec<MeshResponse> = (0..4).flat_map(|p| planet_meshes(p, 120.0, 0.0)).collect();
        let r = reading(1000.0, &alike);
        assert_eq!((r.rms, r.separation), ([120.0, 60.0], [0.0, 0.0]));
        // One planet loaded apart from the others (the example near 11 500 rpm): the same
        // reading whichever planet it is.
        let broken = |loaded: usize| -> Vec<MeshResponse> {
            (0..4)
                .flat_map(|p| {
                    if p == loaded {
                        planet_meshes(p, 400.0, 0.3)
                    } else {
                        planet_meshes(p, 115.0, 0.0)
                    }
                })
                .collect()
        };
        for loaded in 0..4 {
            let r = reading(1000.0, &broken(loaded));
            assert_eq!((r.rms, r.separation), ([400.0, 200.0], [0.3, 0.15]), "planet {loaded} loaded");
        }
    }

    fn point(speed: f64, rms: f64) -> CurvePoint {
        CurvePoint { speed, rms: [rms, 2.0 * rms], separation: [0.0, 0.0] }
    }

    /// A softening fold as an up run meets it: the lower branch up to 10,
    /// back unstable to 8, a restart at 11 onto the branch beyond.
    fn up_run() -> Continued {
        let speeds = [5.0, 7.0, 9.0, 10.0, 9.0, 8.0, 11.0, 12.0];
        let rms = [1.0, 1.2, 1.5, 2.0, 3.0, 4.0, 1.1, 1.0];
        let stable = [true, true, true, true, false, false, true, true];
        let after_gap = [false, false, false, false, false, false, true, false];
        Continued {
            points: speeds.iter().zip(rms).map(|(&s, r)| point(s, r)).collect(),
            stable: stable.to_vec(),
            after_gap: after_gap.to_vec(),
            ends: Vec::new(),
            folds: vec![10.0],
            doublings: Vec::new(),
            ended: String::new(),
            joined: None,
            spots: Vec::new(),
            cyclic: true,
        }
    }

    #[test]
    fn a_run_reads_its_first_stable_stretch_and_never_the_unstable_branch_or_across_a_gap() {
        let (curve, unstable) = up_run().curve(&[5.0, 6.0, 8.5, 9.5, 10.5, 11.5], 0, Direction::Up);
        let rms: Vec<f64> = curve.points.iter().map(|p| p.rms[0]).collect();
        // 8.5 and 9.5 on the lower branch (not the unstable 3.5 or 3.0), 10.5 between the fold
        // and the restart: no stretch spans it (the gap), so the nearest point (10 or 11, both
        // stable), 11.5 on the branch after the restart.
        let expected = [1.0, 1.1, 1.425, 1.75, f64::NAN, 1.05];
        for (i, (r, e)) in rms.iter().zip(expected).enumerate() {
            if i == 4 {
                assert!(*r == 2.0 || *r == 1.1, "{r}");
            } else {
                assert!((r - e).abs() < 1e-12, "{i}: {r} against {e}");
            }
        }
        assert!((curve.points[2].rms[1] - 2.85).abs() < 1e-12, "the ring–planet mesh interpolated alike");
        assert!(unstable.iter().all(Option::is_none));
        assert!(curve.points.iter().zip([5.0, 6.0, 8.5, 9.5, 10.5, 11.5]).all(|(p, s)| p.speed == s));
    }

    #[test]
    fn a_speed_only_an_unstable_stretch_spans_is_read_there_and_counted() {
        let mut run = up_run();
        // The lower branch loses stability between 7 and 9 without a fold (a period doubling).
        run.stable[2] = false;
        let (curve, unstable) = run.curve(&[8.0, 8.5], 0, Direction::Up);
        // 8.0: no stretch with two stable ends spans it; (7, 9) has one, (9, 8) none.
        assert!((curve.points[0].rms[0] - 1.35).abs() < 1e-12, "{}", curve.points[0].rms[0]);
        // Both read on the stretch (7, 9): the point nearer each speed (7 at a tie).
        assert_eq!(unstable, [Some(1), Some(2)]);
    }

    #[test]
    fn a_march_over_an_unstable_stretch_starts_from_the_stable_state_before_it() {
        let mut run = up_run();
        // The lower branch loses stability between 7 and 9 without a fold (a period doubling).
        run.stable[2] = false;
        // Up: 5.5 is read on the stable stretch (5, 7), nearest point 0; 8.0 and 8.5 only on
        // (7, 9), one end stable: the stretch [1, 2], whose own nearest point is 1 (7 at 8.0).
        let grid = [5.5, 8.0, 8.5];
        let (_, unstable) = run.curve(&grid, 0, Direction::Up);
        assert_eq!(unstable, [None, Some(1), Some(2)]);
        let (indices, near) = unstable_stretches(&unstable, Direction::Up).remove(0);
        assert_eq!((indices.as_slice(), near), ([1, 2].as_slice(), 1));
        assert_eq!(run.march_start(&grid, &indices, near, Direction::Up), 0, "from 5.5's state");
        // A grid that begins in the stretch: nothing before it, its own nearest point.
        assert_eq!(run.march_start(&grid[1..], &[0, 1], 1, Direction::Up), 1);
        // Down: the sweep meets 11.5 first (the branch after the restart, stable, point 6),
        // then the stretch [8.5, 8.0].
        let grid = [8.0, 8.5, 11.5];
        let (_, unstable) = run.curve(&grid, 0, Direction::Down);
        let (indices, near) = unstable_stretches(&unstable, Direction::Down).remove(0);
        assert_eq!(indices, [1, 0]);
        assert_eq!(run.march_start(&grid, &indices, near, Direction::Down), 6, "from 11.5's state");
    }

    #[test]
    fn unstable_stretches_run_in_the_sweeps_direction_from_the_point_nearest_their_first_speed() {
        let unstable = [None, Some(4), Some(5), None, Some(9), Some(9), Some(10), None];
        let up = unstable_stretches(&unstable, Direction::Up);
        assert_eq!(up, vec![(vec![1, 2], 4), (vec![4, 5, 6], 9)]);
        let down = unstable_stretches(&unstable, Direction::Down);
        assert_eq!(down, vec![(vec![2, 1], 5), (vec![6, 5, 4], 10)]);
        assert!(unstable_stretches(&[None, None], Direction::Up).is_empty());
    }

    /// A run with a fold at 10.2: the lower branch stable to the fold, back unstable.
    #[test]
    fn a_spot_check_starts_only_from_stable_points_away_from_folds_and_changes_of_stability() {
        use crate::analysis::continuation::{Bifurcation, BranchPoint};
        use crate::dynamics::periodic::PeriodicOrbit;
        let speeds = [8.0, 9.0, 9.5, 9.9, 10.15, 10.1, 9.0, 8.0];
        let stable = [true, true, true, true, true, false, false, false];
        let points = speeds
            .iter()
            .zip(stable)
            .enumerate()
            .map(|(i, (&s, st))| BranchPoint {
                orbit: PeriodicOrbit::bare(s, 1.0),
                stable: st,
                segment: usize::from(i > 4),
                speed_slope: if i > 4 { -1.0 } else { 1.0 },
                after_gap: false,
            })
            .collect();
        let fold = Bifurcation {
            kind: BifurcationKind::Fold,
            speed: 10.2,
            between: (4, 5),
            multipliers: (f64::NAN, f64::NAN),
        };
        let branch = Branch {
            points,
            bifurcations: vec![fold],
            gaps: Vec::new(),
            ended: String::new(),
            work: Default::default(),
            flows: 0,
            scales: Vec::new(),
        };
        // Half a step of 1.0: 9.9 and 10.15 lie within 0.5 of the fold (and of the change of
        // stability between 10.15 and 10.1); the unstable points never qualify.
        let ok = spot_candidates(&branch, 0.5);
        assert_eq!(ok, [true, true, true, false, false, false, false, false]);
        // Without a margin every stable point qualifies.
        assert_eq!(spot_candidates(&branch, 0.0), stable);
    }
}
