//! The validation of the built-in example against the study it comes from,
//! and against the published benchmarks and closed forms the model relies
//! on: every claim as a row with the study's value, ours, the tolerance,
//! the verdict, how ours was computed (integrator settings), an estimate of
//! its error and the time it took.
//!
//! The study's claims (a 2004 study of the dynamic tooth loads of a spur
//! planetary set with worn sun and planet teeth; docs/MODEL.md): torsional
//! natural frequencies 9895, 20 800 (three planet modes) and 23 225 Hz;
//! in-phase and sequentially phased mesh harmonics; forced-response peaks
//! near 4200, 8500, 10 750 and 13 000 rpm; a softening jump with two
//! branches and tooth separation near f₂ ≈ 2 f_m; off-resonance dynamic
//! loads that rise with wear, mostly in F^(1); new peaks in the worn sweeps;
//! wear that is zero at the chamfered tips, least at the pitch point (sun
//! roll angle 22.3°) and deepest in the sun's dedendum, smaller on the
//! planet and relatively more on its addendum, about 15 µm in all at κ = 6;
//! loaded double contact about 1/5 of the mesh cycle on the sun–planet mesh
//! and nearly always on the ring–planet mesh; the magnitude of F^(1) at
//! 2750 rpm (13 N/mm unworn, about 30 N/mm at κ = 6), which is not a
//! resonance; separation on the ring–planet mesh that grows along the upper
//! branch of the jump; new worn peaks near 3000 and 7000 rpm; and little
//! influence of wear near resonance, above all where the teeth separate.
//!
//! Every row carries a label ([`Evidence`]): independent evidence (a
//! number the model was neither built nor fitted to reproduce), a fitted
//! calibration target, or an identity (it follows from how the model is
//! built or from the input data). The headline ([`headline`]) counts the
//! independent rows' passes and gives the other two apart.

use crate::analysis::study::StudyError;
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use self::rows::{Rows, SweepReading};
use self::rules::BandPoint;
use super::wear_effect::WearShape;
use crate::analysis::modes::{natural_modes, Mode, ModeClass};
use crate::contact::ltca::SetModel;
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{steady_state, sweep_from, Direction, State, SteadyState, Sweep, Window};
use crate::model::gear::{GearSet, IntegratorKind, MeshKind};
use crate::model::lumped::Fidelity;
use crate::model::run::RunSettings;
use crate::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use crate::scene::Scene;
use crate::wear::archard::WearSettings;
use crate::wear::flank::Flank;
use crate::wear::state::WornState;
use crate::wear::stepper::WearModel;

mod continued;
mod rows;
mod rules;

/// The study's torsional natural frequencies \[Hz\]: first rotational, the
/// planet modes (multiplicity n − 1), second rotational.
pub const STUDY_FREQUENCIES: [f64; 3] = [9895.0, 20800.0, 23225.0];

/// The resonance peaks of the study's forced-response curves \[rpm\].
pub const STUDY_PEAKS: [f64; 4] = [4200.0, 8500.0, 10750.0, 13000.0];

/// Off-resonance speeds at which the study's loads rise with wear \[rpm\].
pub const OFF_RESONANCE: [f64; 4] = [1500.0, 2000.0, 2750.0, 3000.0];

/// What to compute.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValidationPlan {
    /// The sweeps' speed grid as segments (first, last, step) \[rpm\], in order.
    pub sweep: Vec<(f64, f64, f64)>,
    /// Geometry state of the worn rows.
    pub kappa: u32,
    /// Relative tolerance of the reference runs that estimate the integrator's error.
    pub reference_tolerance: f64,
    /// Whether the wear's resolution error is estimated (a second wear run at R = 800, I = 200).
    pub wear_resolution_check: bool,
    /// Whether the readings of the sweeps (peaks, branches, separation) are
    /// made a second time on sweeps at a third of the tolerance, over the
    /// speeds where several attractors coexist ([`CHECK_REFINEMENT`]).
    #[serde(default)]
    pub attractor_check: bool,
    /// How the forced-response rows are computed (reports written before
    /// the field read as marching).
    #[serde(default = "ForcedResponse::marching")]
    pub forced: ForcedResponse,
}

/// How the validation computes its forced response.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForcedResponse {
    /// The continuation's branches on the cyclic condensed harmonic balance
    /// (symmetry-broken branches with every mesh), up and down, stable and
    /// unstable, with their folds; each direction's
    /// curve read on the branch its run rides; spot-checked by marching from
    /// branch points ([`SPOT_SPEEDS`]).
    Continuation,
    /// Marching sweeps up and down on the grid, read a second time at a
    /// third of the tolerance where the plan asks (`validate --full`).
    Marching,
}

impl ForcedResponse {
    fn marching() -> Self {
        ForcedResponse::Marching
    }
}

/// Speeds \[rpm\] at which the continuation's curves are spot-checked by
/// marching, each κ and direction (those on the plan's grid): the study's
/// off-resonance example, its four peaks, and the two-branch band's middle.
pub const SPOT_SPEEDS: [f64; 6] = [2750.0, 4200.0, 8000.0, 8500.0, 10750.0, 13000.0];

/// A spot check's march may differ from the branch by this share of
/// F^(rms): the marching integrator's error (E_h up to 2.9e-3,
/// docs/ACCURACY.md) with a margin for its run-in.
pub const SPOT_TOLERANCE: f64 = 0.01;

/// The second reading of the sweeps runs them at the run's relative
/// tolerance divided by this (generalized-α: this many times the steps).
pub const CHECK_REFINEMENT: f64 = 3.0;

/// The second reading's sweeps start this many grid steps below the lowest
/// speed where the up and down sweeps differ, so that its up sweeps arrive
/// there with a history of their own.
pub const CHECK_LEAD_STEPS: usize = 10;

/// Up and down sweeps that differ by more than this share of F^(rms) at a
/// speed ride different attractors there.
const DIRECTIONS_DIFFER: f64 = 0.05;

impl ValidationPlan {
    /// The whole study: 500–15 000 rpm in 50 rpm steps.
    pub fn full() -> Self {
        Self {
            sweep: vec![(500.0, 15000.0, 50.0)],
            kappa: 6,
            reference_tolerance: 1e-8,
            wear_resolution_check: true,
            attractor_check: true,
            forced: ForcedResponse::Continuation,
        }
    }

    /// A reduced grid for the test command: 3000–14 000 rpm in 250 rpm
    /// steps, 100 rpm steps from 6000 to 10 000 rpm where the jump is.
    pub fn quick() -> Self {
        Self {
            sweep: vec![(3000.0, 5750.0, 250.0), (6000.0, 10000.0, 100.0), (10250.0, 14000.0, 250.0)],
            kappa: 6,
            reference_tolerance: 1e-8,
            wear_resolution_check: false,
            attractor_check: true,
            forced: ForcedResponse::Continuation,
        }
    }

    /// The same plan with the forced response from marching sweeps, read
    /// twice where attractors coexist (`validate --full`).
    pub fn marching(self) -> Self {
        Self { forced: ForcedResponse::Marching, attractor_check: true, ..self }
    }

    fn speeds(&self) -> Vec<f64> {
        let mut out = Vec::new();
        for (a, b, h) in &self.sweep {
            let n = ((b - a) / h + 1e-9).floor() as usize + 1;
            out.extend((0..n).map(|i| a + h * i as f64));
        }
        out
    }

    /// The grid's step at `rpm` \[rpm\].
    pub fn step_at(&self, rpm: f64) -> f64 {
        self.sweep
            .iter()
            .find(|(a, b, h)| rpm >= a - h && rpm <= b + h)
            .or(self.sweep.last())
            .map_or(0.0, |s| s.2)
    }

    /// The grid in words.
    pub fn describe(&self) -> String {
        self.sweep
            .iter()
            .map(|(a, b, h)| format!("{a:.0}–{b:.0} rpm in {h:.0} rpm steps"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A row's verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Within the tolerance.
    Pass,
    /// Outside it.
    Fail,
    /// Within it on one reading and outside on the other: the sweeps at the
    /// run's tolerance and at a third of it land on different attractors,
    /// so the model does not decide the claim at the accuracy computed.
    Undecided,
}

impl Verdict {
    fn of(ok: bool) -> Self {
        if ok {
            Verdict::Pass
        } else {
            Verdict::Fail
        }
    }

    /// The verdict of a reading made at the run's tolerance (`ok`) and,
    /// where the plan asks for it, again on the finer sweeps (`again`).
    pub fn of_readings(ok: bool, again: Option<bool>) -> Self {
        match again {
            Some(b) if b != ok => Verdict::Undecided,
            _ => Verdict::of(ok),
        }
    }

    /// The verdict in the report's words.
    pub fn word(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Fail => "fail",
            Verdict::Undecided => "undecided",
        }
    }
}

impl From<bool> for Verdict {
    fn from(ok: bool) -> Self {
        Verdict::of(ok)
    }
}

/// What kind of evidence a row is: the headline counts only independent rows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Evidence {
    /// The study's or a published number that the model was neither built
    /// nor fitted to reproduce. (A report written before rows carried
    /// labels reads as this; such reports are read only to say which rows
    /// moved.)
    #[default]
    Independent,
    /// A calibration target: the parameters were fitted to meet it
    /// (docs/PARAMETERS.md), so its pass says the fit converged.
    Fitted,
    /// It follows from how the model is built or from the input data (a
    /// closed form of our own model, geometry from the study's tooth data,
    /// a consequence of a modelling choice): its pass checks the code, not
    /// the physics against the study.
    Identity,
}

impl Evidence {
    /// The label in the report's words.
    pub fn word(self) -> &'static str {
        match self {
            Evidence::Independent => "independent",
            Evidence::Fitted => "fitted",
            Evidence::Identity => "identity",
        }
    }
}

/// One claim beside our figure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Stable identifier (for tests and for spotting a moved row).
    pub id: String,
    /// Section of the report.
    pub section: String,
    /// What kind of evidence the row is.
    #[serde(default)]
    pub evidence: Evidence,
    /// The claim, in words.
    pub claim: String,
    /// The study's (or the published) value.
    pub study: String,
    /// Ours.
    pub ours: String,
    /// Our headline number, when there is one (to tell whether a row moved).
    pub value: Option<f64>,
    /// The tolerance and why.
    pub tolerance: String,
    /// The verdict.
    pub verdict: Verdict,
    /// How ours was computed (method, integrator settings).
    pub method: String,
    /// Estimate of the error of ours.
    pub error: String,
    /// Time of the computation behind the row \[s\] (shared computations are named in `method`).
    pub seconds: f64,
}

/// One point of a forced-response curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Input speed [rad/s] (written in rpm, as `speed_rpm`).
    #[serde(rename = "speed_rpm", with = "crate::scene::units::rpm")]
    pub speed: f64,
    /// F^(rms) of the sun–planet and ring–planet mesh, each the most loaded planet's \[N\].
    pub rms: [f64; 2],
    /// Separation fraction of both meshes, each the largest of the planets' [-].
    pub separation: [f64; 2],
}

/// A forced-response curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    /// Geometry state.
    pub kappa: u32,
    /// Sweep direction.
    pub direction: Direction,
    /// Points in speed order.
    pub points: Vec<CurvePoint>,
}

/// A worn profile for the figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    /// Flank.
    pub flank: Flank,
    /// Roll angles \[rad\].
    pub roll: Vec<f64>,
    /// Depth at κ \[m\].
    pub depth: Vec<f64>,
    /// The pitch point's roll angle \[rad\].
    pub pitch_roll: f64,
}

/// Everything the validation computes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Validation {
    /// Scene name.
    pub scene: String,
    /// The plan.
    pub plan: ValidationPlan,
    /// The integrator of the dynamic rows, in words.
    pub integrator: String,
    /// Rows in report order.
    pub rows: Vec<Row>,
    /// Forced-response curves: κ = 0 and κ, up and down.
    pub curves: Vec<Curve>,
    /// The same four curves from the second reading's sweeps (at a third of
    /// the tolerance from [`Validation::check_from`] up; the first
    /// curves' points below it), when the plan asks for them.
    #[serde(default)]
    pub check_curves: Vec<Curve>,
    /// Lowest speed of the second reading's sweeps \[rpm\].
    #[serde(default)]
    pub check_from: Option<f64>,
    /// Worn profiles of sun and planet at κ.
    pub profiles: Vec<Profile>,
    /// Natural frequencies of both fidelities \[Hz\] with their classes.
    pub modes: Vec<(Fidelity, f64, ModeClass, usize)>,
    /// Wall time \[s\].
    pub seconds: f64,
}

impl Validation {
    /// The row with `id`.
    pub fn row(&self, id: &str) -> Option<&Row> {
        self.rows.iter().find(|r| r.id == id)
    }
}

/// The report's headline: the passes among the independent rows (with the
/// undecided ones), then the fitted rows and the identities apart, e.g.
/// "Independent evidence: 12 of 20 rows pass (2 undecided); fitted: 4 of
/// 4; identities: 12 of 12."
pub fn headline(rows: &[Row]) -> String {
    let count = |evidence: Evidence, verdict: Option<Verdict>| {
        rows.iter().filter(|r| r.evidence == evidence && verdict.is_none_or(|v| r.verdict == v)).count()
    };
    let of = |evidence| (count(evidence, Some(Verdict::Pass)), count(evidence, None));
    let (pass, all) = of(Evidence::Independent);
    let ((fp, fa), (ip, ia)) = (of(Evidence::Fitted), of(Evidence::Identity));
    format!(
        "Independent evidence: {pass} of {all} rows pass ({} undecided); fitted: {fp} of {fa}; identities: {ip} of {ia}.",
        count(Evidence::Independent, Some(Verdict::Undecided))
    )
}

fn integrator_words(run: &RunSettings) -> String {
    let d = run.values();
    match d.integrator {
        IntegratorKind::Rk45 => format!(
            "RK 5(4) at relative tolerance {:e}; run-in ≤ {} input revolution, window {} revolutions, {} samples per mesh cycle",
            d.relative_tolerance, d.run_in_revolutions, d.measured_revolutions, d.samples_per_mesh_cycle
        ),
        IntegratorKind::GeneralizedAlpha => format!(
            "generalized-α ρ∞ = {}, {} steps per mesh cycle; run-in ≤ {} input revolution, window {} revolutions",
            d.rho_infinity, d.steps_per_mesh_cycle, d.run_in_revolutions, d.measured_revolutions
        ),
    }
}

/// Distinct frequencies of a class, lowest first, with multiplicities.
fn distinct(modes: &[Mode], class: ModeClass) -> Vec<(f64, usize)> {
    let mut out: Vec<(f64, usize)> = Vec::new();
    for m in modes.iter().filter(|m| m.class == class) {
        match out.last_mut() {
            Some(last) if (m.frequency - last.0).abs() <= 1e-6 * m.frequency => last.1 += 1,
            _ => out.push((m.frequency, 1)),
        }
    }
    out
}

/// Prominent local maxima of y(x): at least `share` of the peak above the
/// higher of the two valleys that separate it from higher ground.
pub fn prominent_peaks(x: &[f64], y: &[f64], share: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for i in 1..y.len().saturating_sub(1) {
        if !(y[i] > y[i - 1] && y[i] >= y[i + 1]) {
            continue;
        }
        let valley = |range: &mut dyn Iterator<Item = usize>| {
            let mut low = y[i];
            for j in range {
                if y[j] > y[i] {
                    break;
                }
                low = low.min(y[j]);
            }
            low
        };
        let left = valley(&mut (0..i).rev());
        let right = valley(&mut (i + 1..y.len()));
        if y[i] - left.max(right) >= share * y[i] {
            out.push((x[i], y[i]));
        }
    }
    out
}

fn curve(s: &Sweep, kappa: u32) -> Curve {
    let mut points: Vec<CurvePoint> = s.points.iter().map(continued::measures).collect();
    points.sort_by(|a, b| a.speed.total_cmp(&b.speed));
    Curve { kappa, direction: s.direction, points }
}

/// The lowest speed \[rad/s\] where two sweeps on the same grid differ by
/// more than [`DIRECTIONS_DIFFER`] of F^(rms) of the sun–planet mesh.
fn lowest_differing(up: &Curve, down: &Curve) -> Option<f64> {
    up.points
        .iter()
        .zip(&down.points)
        .find(|(u, d)| (u.rms[0] - d.rms[0]).abs() > DIRECTIONS_DIFFER * u.rms[0].max(d.rms[0]))
        .map(|(u, _)| u.speed)
}

/// `f(0)` … `f(3)` on rayon's threads (the validation's four sweeps: κ = 0
/// up and down, the worn κ up and down).
fn four<R: Send>(f: impl Fn(usize) -> R + Sync) -> [R; 4] {
    let ((a, b), (c, d)) = rayon::join(|| rayon::join(|| f(0), || f(1)), || rayon::join(|| f(2), || f(3)));
    [a, b, c, d]
}

/// `again`'s points, below them `first`'s: a curve whose upper stretch was swept again.
fn splice(first: &Curve, again: &Curve) -> Curve {
    let lowest = again.points.first().map_or(f64::INFINITY, |p| p.speed);
    let mut points: Vec<CurvePoint> = first.points.iter().filter(|p| p.speed < lowest).copied().collect();
    points.extend(again.points.iter().copied());
    Curve { kappa: first.kappa, direction: first.direction, points }
}

/// What the dynamic rows read off the four curves (κ = 0 and the worn κ, up and down).
struct Readings {
    /// Prominent peaks of either direction at κ = 0: (rpm, F^(rms) \[N\]).
    peaks0: Vec<(f64, f64)>,
    /// The same at the worn κ.
    peaks6: Vec<(f64, f64)>,
    /// Speeds near 2 f_m = f₂ where the directions differ at κ = 0, in grid order.
    band: Vec<BandPoint>,
    /// The same at the worn κ.
    worn_band: Vec<BandPoint>,
    /// The largest separation of κ = 0's sun–planet mesh and its speed \[rpm\].
    separation: (f64, f64),
}

/// A peak counts where either direction has one; peaks within two steps are one.
fn peaks_of(up: &Curve, down: &Curve, step: f64) -> Vec<(f64, f64)> {
    let xs: Vec<f64> = up.points.iter().map(|p| rad_per_s_to_rpm(p.speed)).collect();
    let ys = |c: &Curve| c.points.iter().map(|p| p.rms[0]).collect::<Vec<f64>>();
    let mut peaks = prominent_peaks(&xs, &ys(up), 0.1);
    peaks.extend(prominent_peaks(&xs, &ys(down), 0.1));
    peaks.sort_by(|a, b| a.0.total_cmp(&b.0));
    peaks.dedup_by(|a, b| (a.0 - b.0).abs() <= 2.0 * step);
    peaks
}

/// Speeds with 2 f_m between 0.7 and 1.1 f_rot1 where the up and down sweeps differ by more than 10 %.
fn branches(up: &Curve, down: &Curve, fm_per_rpm: f64, f_rot1: f64) -> Vec<BandPoint> {
    up.points
        .iter()
        .zip(&down.points)
        .enumerate()
        .map(|(index, (u, d))| BandPoint {
            index,
            rpm: rad_per_s_to_rpm(u.speed),
            up: u.rms[0],
            down: d.rms[0],
            separation: d.separation[0].max(u.separation[0]),
        })
        .filter(|p| {
            let r = 2.0 * fm_per_rpm * p.rpm / f_rot1;
            (0.7..=1.1).contains(&r) && p.difference() > 0.1
        })
        .collect()
}

fn read(curves: &[Curve], step: f64, fm_per_rpm: f64, f_rot1: f64) -> Readings {
    Readings {
        peaks0: peaks_of(&curves[0], &curves[1], step),
        peaks6: peaks_of(&curves[2], &curves[3], step),
        band: branches(&curves[0], &curves[1], fm_per_rpm, f_rot1),
        worn_band: branches(&curves[2], &curves[3], fm_per_rpm, f_rot1),
        separation: curves[..2]
            .iter()
            .flat_map(|c| c.points.iter())
            .map(|p| (p.separation[0], rad_per_s_to_rpm(p.speed)))
            .fold((0.0, 0.0), |m, p| if p.0 > m.0 { p } else { m }),
    }
}

fn sun_planet(ss: &SteadyState) -> (f64, f64) {
    ss.meshes
        .iter()
        .find(|m| m.planet == 0 && m.mesh == MeshKind::SunPlanet)
        .map_or((0.0, 0.0), |m| (m.harmonics.amplitude[0], m.harmonics.rms))
}

/// The natural modes of both fidelities.
struct Modes {
    /// The torsional model (it also serves the closed-form planet-mode check).
    torsional_model: PlanetaryDynamics,
    /// Modes of the torsional model.
    torsional: Vec<Mode>,
    /// Modes of the transverse–torsional model.
    tt: Vec<Mode>,
    /// Time of the computation \[s\].
    seconds: f64,
}

impl Modes {
    fn compute(scene: &Scene, contact: &SetModel) -> Result<Self, StudyError> {
        let t = Instant::now();
        let dynamics_of = |fidelity: Fidelity| -> Result<PlanetaryDynamics, StudyError> {
            // The fidelity is a term of the equations, so of the gear set.
            let mut at = scene.clone();
            at.dynamics.fidelity = fidelity;
            let s = at.validate()?;
            Ok(PlanetaryDynamics::new(&s, contact.clone())?)
        };
        let torsional_model = dynamics_of(Fidelity::Torsional)?;
        let torsional = natural_modes(&torsional_model.lumped);
        let tt = natural_modes(&dynamics_of(Fidelity::TransverseTorsional)?.lumped);
        Ok(Self { torsional_model, torsional, tt, seconds: t.elapsed().as_secs_f64() })
    }
}

/// The wear to κ and, when the plan asks, a finer run for its error.
struct WearRun {
    /// The unworn state.
    unworn: WornState,
    /// The state at κ.
    worn: WornState,
    /// Shapes of the sun's and the planet's wear at κ.
    sun: WearShape,
    /// See `sun`.
    planet: WearShape,
    /// The same shapes from the run at R = 800, I = 200.
    fine: Option<(WearShape, WearShape)>,
    /// How the wear was computed, in words.
    method: String,
    /// Time of the coarse run \[s\].
    seconds: f64,
}

impl WearRun {
    fn compute(set: &GearSet, plan: &ValidationPlan) -> Result<Self, StudyError> {
        let t = Instant::now();
        let wear = WearModel::new(set, WearSettings::for_set(set))?;
        let unworn = wear.unworn();
        let worn = wear.run_to_kappa(&unworn, plan.kappa)?;
        let seconds = t.elapsed().as_secs_f64();
        let fine = if plan.wear_resolution_check {
            let t = Instant::now();
            let mut s = WearSettings::for_set(set);
            s.positions = 800;
            s.profile_points = 200;
            let m = WearModel::new(set, s)?;
            let w = m.run_to_kappa(&m.unworn(), plan.kappa)?;
            Some((w, t.elapsed().as_secs_f64()))
        } else {
            None
        };
        let method = format!(
            "whole-set LTCA at R = {} positions per wear cycle, I = {} profile points, {} updates{}",
            wear.settings().positions,
            wear.settings().profile_points,
            worn.kappa,
            fine.as_ref().map(|(_, s)| format!("; the finer run took {s:.1} s")).unwrap_or_default()
        );
        Ok(Self {
            sun: WearShape::of(&worn, set, Flank::SunDrive),
            planet: WearShape::of(&worn, set, Flank::PlanetSunSide),
            fine: fine.map(|(w, _)| {
                (WearShape::of(&w, set, Flank::SunDrive), WearShape::of(&w, set, Flank::PlanetSunSide))
            }),
            unworn,
            worn,
            method,
            seconds,
        })
    }

    /// The finer run's figure `f` of the sun's (or the planet's) shape and
    /// its difference from ours, in µm.
    fn error(&self, f: &dyn Fn(&WearShape) -> f64, of_sun: bool) -> String {
        match &self.fine {
            Some((s, p)) => {
                let (coarse, finer) = if of_sun { (f(&self.sun), f(s)) } else { (f(&self.planet), f(p)) };
                format!("R = 800, I = 200 gives {:.2} µm ({:+.2} µm)", finer * 1e6, (finer - coarse) * 1e6)
            }
            None => "not estimated on the reduced grid".into(),
        }
    }
}

/// The four forced-response curves (κ = 0 and the worn κ, up and down):
/// from the continuation's branches, or from marching sweeps and, when the
/// plan asks, their second reading.
struct SweepRun {
    /// The four curves in the order κ = 0 up, down, worn up, down.
    curves: Vec<Curve>,
    /// The same from the second reading's sweeps (empty without one).
    check_curves: Vec<Curve>,
    /// Lowest speed of the second reading's sweeps \[rpm\].
    check_from: Option<f64>,
    /// How the curves were computed, in words.
    method: String,
    /// The continuation's folds, in words (empty for marching sweeps).
    folds: String,
    /// The spot checks by marching (empty for marching sweeps).
    spots: Vec<Spot>,
    /// Time of the curves (both readings, or the branches) \[s\].
    seconds: f64,
    /// Time of the spot checks \[s\].
    spot_seconds: f64,
}

/// A march from a stable branch point against the branch.
#[derive(Clone, Debug)]
struct Spot {
    /// Geometry state.
    kappa: u32,
    /// The run the point is on.
    direction: Direction,
    /// The point's speed \[rpm\].
    rpm: f64,
    /// F^(rms) of the sun–planet and the ring–planet mesh on the branch \[N\].
    branch: [f64; 2],
    /// The same after marching from the point's state \[N\].
    marched: [f64; 2],
    /// The point's largest Floquet multiplier |μ|: a march approaches the
    /// orbit by this factor per period of the orbit.
    multiplier: f64,
}

impl Spot {
    /// The larger relative difference of the two meshes' F^(rms).
    fn difference(&self) -> f64 {
        (0..2)
            .map(|k| (self.marched[k] - self.branch[k]).abs() / self.branch[k].abs().max(1e-300))
            .fold(0.0, f64::max)
    }
}

impl SweepRun {
    fn compute(
        set: &GearSet,
        run: &RunSettings,
        plan: &ValidationPlan,
        models: [&PlanetaryDynamics; 2],
        kappa: u32,
        integrator: &str,
    ) -> Result<Self, StudyError> {
        match plan.forced {
            ForcedResponse::Continuation => continued::sweep_run(set, run, plan, models, kappa, integrator),
            ForcedResponse::Marching => {
                Self::marched(set, run, plan, models[0], models[1], kappa, integrator)
            }
        }
    }

    /// The curves from marching sweeps and, where the plan asks, their second reading.
    #[allow(clippy::too_many_arguments)]
    fn marched(
        set: &GearSet,
        run: &RunSettings,
        plan: &ValidationPlan,
        model0: &PlanetaryDynamics,
        model6: &PlanetaryDynamics,
        kappa: u32,
        integrator: &str,
    ) -> Result<Self, StudyError> {
        let t = Instant::now();
        let speeds: Vec<f64> = plan.speeds().into_iter().map(rpm_to_rad_per_s).collect();
        // The four sweeps in the order of `four`: κ = 0 up and down, the worn κ up and down.
        let models = [model0, model0, model6, model6];
        let directions = [Direction::Up, Direction::Down, Direction::Up, Direction::Down];
        // A sweep over `grid` (ascending; run downwards for a down sweep) from `start`.
        let sweep_over = |k: usize,
                          settings: &RunSettings,
                          grid: &[f64],
                          start: Option<&State>|
         -> Result<Sweep, StudyError> {
            let mut m = models[k].clone();
            let mut grid = grid.to_vec();
            if directions[k] == Direction::Down {
                grid.reverse();
            }
            Ok(sweep_from(set, settings, &mut m, directions[k], &grid, &[], Window::Fixed, start, |_| {})?)
        };
        let [a, b, c, d] = four(|k| sweep_over(k, run, &speeds, None));
        let firsts = [a?, b?, c?, d?];
        let kappas = [0, 0, kappa, kappa];
        let curves: Vec<Curve> = firsts.iter().zip(kappas).map(|(s, k)| curve(s, k)).collect();

        // The second reading. Where the up and down sweeps differ, several
        // attractors coexist, and which one a sweep rides can turn on an error as
        // small as the integrator's: the sweeps are run again there at a third of
        // the tolerance and every reading is made on both.
        let lowest = [(0, 1), (2, 3)]
            .iter()
            .filter_map(|&(u, d)| lowest_differing(&curves[u], &curves[d]))
            .fold(f64::INFINITY, f64::min);
        let check_index = (plan.attractor_check && lowest.is_finite()).then(|| {
            let i = speeds.iter().position(|w| *w >= lowest * (1.0 - 1e-12)).unwrap_or(0);
            i.saturating_sub(CHECK_LEAD_STEPS)
        });
        let check_curves = match check_index {
            None => Vec::new(),
            Some(i) => {
                let finer = run.with(|d| match d.integrator {
                    IntegratorKind::Rk45 => d.relative_tolerance /= CHECK_REFINEMENT,
                    IntegratorKind::GeneralizedAlpha => {
                        d.steps_per_mesh_cycle =
                            (d.steps_per_mesh_cycle as f64 * CHECK_REFINEMENT).ceil() as usize
                    }
                })?;
                // The up sweeps enter the band from the first sweep's state at the
                // speed below it; the down sweeps start at the top, as the first did.
                let [a, b, c, d] = four(|k| {
                    let start =
                        (directions[k] == Direction::Up && i > 0).then(|| &firsts[k].points[i - 1].end);
                    sweep_over(k, &finer, &speeds[i..], start)
                });
                let again = [a?, b?, c?, d?];
                (0..4).map(|k| splice(&curves[k], &curve(&again[k], kappas[k]))).collect()
            }
        };
        let check_from = check_index.map(|i| rad_per_s_to_rpm(speeds[i]));
        let method = format!(
            "marching sweeps {}, up and down, κ = 0 and κ = {kappa} (4 sweeps, {} speeds each, run in parallel; {integrator}){}",
            plan.describe(),
            speeds.len(),
            match check_from {
                Some(r) => format!(
                    "; read again on the same sweeps at a third of the tolerance from {r:.0} rpm up ({CHECK_LEAD_STEPS} steps below the lowest speed where up and down differ by more than {:.0} %)",
                    100.0 * DIRECTIONS_DIFFER
                ),
                None => String::new(),
            }
        );
        Ok(Self {
            curves,
            check_curves,
            check_from,
            method,
            folds: String::new(),
            spots: Vec::new(),
            seconds: t.elapsed().as_secs_f64(),
            spot_seconds: 0.0,
        })
    }
}

/// F^(1) and F^(rms) of the sun–planet mesh \[N\].
type Amplitudes = (f64, f64);

/// F^(1) and F^(rms) of the sun–planet mesh at the off-resonance speeds.
struct OffResonance {
    /// (rpm, κ = 0, worn, κ = 0 reference, worn reference).
    figures: Vec<(f64, Amplitudes, Amplitudes, Amplitudes, Amplitudes)>,
    /// How they were computed, in words.
    method: String,
    /// Time \[s\].
    seconds: f64,
}

impl OffResonance {
    fn compute(
        set: &GearSet,
        run: &RunSettings,
        plan: &ValidationPlan,
        models: [&PlanetaryDynamics; 2],
        integrator: &str,
    ) -> Result<Self, StudyError> {
        let t = Instant::now();
        let tight = run.with(|d| {
            d.integrator = IntegratorKind::Rk45;
            d.relative_tolerance = plan.reference_tolerance;
        })?;
        // The sixteen steady states on rayon's threads.
        let figures = OFF_RESONANCE
            .par_iter()
            .map(|&rpm| {
                let omega = rpm_to_rad_per_s(rpm);
                let at = |r: &RunSettings, m: &PlanetaryDynamics| -> Result<(f64, f64), StudyError> {
                    let mut m = m.clone();
                    steady_state(&mut m, set, r, omega, None)
                        .map(|ss| sun_planet(&ss))
                        .map_err(|e| StudyError::from(e).at(format!("{rpm} rpm")))
                };
                let ((a0, a6), (r0, r6)) = rayon::join(
                    || rayon::join(|| at(run, models[0]), || at(run, models[1])),
                    || rayon::join(|| at(&tight, models[0]), || at(&tight, models[1])),
                );
                Ok((rpm, a0?, a6?, r0?, r6?))
            })
            .collect::<Result<Vec<_>, StudyError>>()?;
        let method = format!(
            "steady states from the static deflection at each speed; {integrator}; reference RK 5(4) at {:e}",
            plan.reference_tolerance
        );
        Ok(Self { figures, method, seconds: t.elapsed().as_secs_f64() })
    }
}

/// Runs the validation of `scene` (the built-in example) under `plan`:
/// computes the modes, the wear, the sweeps and the steady states once, and
/// lets each family of claims read its rows off them.
pub fn validate(scene: &Scene, plan: &ValidationPlan) -> Result<Validation, StudyError> {
    let started = Instant::now();
    let (set, run) = scene.validate_with_run()?;
    let mut rows = Rows::default();
    let integrator = integrator_words(&run);
    let contact = SetModel::new(&set);
    let modes = Modes::compute(scene, &contact)?;
    rows::frequency_rows(&mut rows, &set, &modes);
    rows::contact_rows(&mut rows, &set, &contact);
    let wear = WearRun::compute(&set, plan)?;
    rows::wear_rows(&mut rows, plan, &wear);
    rows::wear_shape_rows(&mut rows, &wear);

    let model0 = PlanetaryDynamics::new(&set, wear.unworn.set_model(&set))?;
    let model6 = PlanetaryDynamics::new(&set, wear.worn.set_model(&set))?;
    // The off-resonance steady states beside the curves (a core is idle on
    // the curves' sequential stretches).
    let (sweeps, off) = rayon::join(
        || SweepRun::compute(&set, &run, plan, [&model0, &model6], wear.worn.kappa, &integrator),
        || OffResonance::compute(&set, &run, plan, [&model0, &model6], &integrator),
    );
    let (sweeps, off) = (sweeps?, off?);
    let reading = SweepReading::new(&set, plan, &modes.tt, wear.worn.kappa, &sweeps, &run);
    rows::peak_rows(&mut rows, &reading);
    rows::jump_rows(&mut rows, &reading);
    rows::spot_row(&mut rows, &reading);
    rows::rise_rows(&mut rows, &reading, &off);
    rows::worn_sweep_rows(&mut rows, &reading);
    rows::phasing_row(&mut rows, &set, &run, &model0, &integrator)?;
    rows::geometry_rows(&mut rows, &set);
    rows::benchmark_rows(&mut rows, &set, &modes);

    let worn = &wear.worn;
    let profiles = [Flank::SunDrive, Flank::PlanetSunSide]
        .into_iter()
        .map(|f| {
            let d = &worn.flanks.get(f)[0];
            let shape = WearShape::of(worn, &set, f);
            Profile { flank: f, roll: d.roll.clone(), depth: d.depth.clone(), pitch_roll: shape.pitch.1 }
        })
        .collect();
    let modes = [(Fidelity::Torsional, &modes.torsional), (Fidelity::TransverseTorsional, &modes.tt)]
        .iter()
        .flat_map(|(f, ms)| {
            [ModeClass::Rotational, ModeClass::Planet, ModeClass::Translational]
                .into_iter()
                .flat_map(move |c| distinct(ms, c).into_iter().map(move |(fr, mult)| (*f, fr, c, mult)))
        })
        .collect();
    Ok(Validation {
        scene: set.name().to_string(),
        plan: plan.clone(),
        integrator,
        rows: rows.rows,
        curves: sweeps.curves,
        check_curves: sweeps.check_curves,
        check_from: sweeps.check_from,
        profiles,
        modes,
        seconds: started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve_of(direction: Direction, rms: &[f64]) -> Curve {
        let points = rms
            .iter()
            .enumerate()
            .map(|(i, f)| CurvePoint { speed: 100.0 + 10.0 * i as f64, rms: [*f, 0.0], separation: [0.0; 2] })
            .collect();
        Curve { kappa: 0, direction, points }
    }

    #[test]
    fn a_verdict_is_undecided_only_where_the_two_readings_disagree() {
        assert_eq!(Verdict::of_readings(true, None), Verdict::Pass);
        assert_eq!(Verdict::of_readings(false, None), Verdict::Fail);
        assert_eq!(Verdict::of_readings(true, Some(true)), Verdict::Pass);
        assert_eq!(Verdict::of_readings(false, Some(false)), Verdict::Fail);
        assert_eq!(Verdict::of_readings(true, Some(false)), Verdict::Undecided);
        assert_eq!(Verdict::of_readings(false, Some(true)), Verdict::Undecided);
    }

    #[test]
    fn the_second_reading_starts_where_the_directions_first_differ_and_keeps_the_first_below() {
        let up = curve_of(Direction::Up, &[1.0, 1.0, 1.04, 1.0, 2.0]);
        let down = curve_of(Direction::Down, &[1.0, 1.0, 1.0, 1.06, 1.0]);
        // 4 % apart at 120 rad/s is one attractor; 6 % at 130 rad/s is not.
        assert_eq!(lowest_differing(&up, &down), Some(130.0));
        assert_eq!(lowest_differing(&up, &up), None);
        let mut again = curve_of(Direction::Up, &[9.0, 9.0, 9.0, 9.0, 9.0]);
        again.points.drain(..2);
        let spliced = splice(&up, &again);
        let speeds: Vec<f64> = spliced.points.iter().map(|p| p.speed).collect();
        assert_eq!(speeds, [100.0, 110.0, 120.0, 130.0, 140.0]);
        let rms: Vec<f64> = spliced.points.iter().map(|p| p.rms[0]).collect();
        assert_eq!(rms, [1.0, 1.0, 9.0, 9.0, 9.0]);
    }

    #[test]
    fn the_headline_counts_independent_passes_and_gives_fitted_rows_and_identities_apart() {
        let row = |evidence, verdict| Row {
            id: "r".into(),
            section: "s".into(),
            evidence,
            claim: "c".into(),
            study: "1".into(),
            ours: "1".into(),
            value: None,
            tolerance: "t".into(),
            verdict,
            method: "m".into(),
            error: "e".into(),
            seconds: 0.0,
        };
        use Evidence::*;
        let rows = [
            row(Independent, Verdict::Pass),
            row(Independent, Verdict::Fail),
            row(Independent, Verdict::Undecided),
            row(Fitted, Verdict::Pass),
            row(Fitted, Verdict::Fail),
            row(Identity, Verdict::Pass),
            row(Identity, Verdict::Pass),
        ];
        assert_eq!(
            headline(&rows),
            "Independent evidence: 1 of 3 rows pass (1 undecided); fitted: 1 of 2; identities: 2 of 2."
        );
        // A row written before labels reads as independent.
        let json = serde_json::to_string(&rows[3]).unwrap().replace(r#""evidence":"fitted","#, "");
        let old: Row = serde_json::from_str(&json).unwrap();
        assert_eq!(old.evidence, Independent);
    }
}
