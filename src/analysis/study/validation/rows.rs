//! The validation's rows, one function per family of claims: natural
//! frequencies, loaded contact, wear, forced response, worn against
//! unworn, mesh phasing, and the published benchmarks and closed forms.
//! Each reads the computations [`super::validate`] made once and pushes its
//! rows with their label ([`Evidence`]).

use crate::analysis::study::StudyError;
use std::time::Instant;

use super::rules::{
    band_means, contiguous_band, jump_down_speed, longest_stretch, nearest, new_peak_near, peak_within,
    positive_and_growing, worn_excess_where_separating, BandPoint,
};
use super::{
    distinct, read, Curve, Evidence, Modes, OffResonance, Readings, Row, SweepRun, ValidationPlan, Verdict,
    WearRun, SPOT_TOLERANCE, STUDY_FREQUENCIES, STUDY_PEAKS,
};
use crate::analysis::modes::{Mode, ModeClass};
use crate::analysis::study::peaks::excited_family;
use crate::contact::hertz::{contact_modulus, line_contact};
use crate::contact::iso6336::{iso_stiffness, IsoPair};
use crate::contact::ltca::SetModel;
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::response::{steady_state, Direction};
use crate::dynamics::spectrum::mesh_phases;
use crate::model::gear::{GearSet, MeshKind};
use crate::model::lumped::Fidelity;
use crate::model::mesh::PathOfContact;
use crate::model::run::RunSettings;
use crate::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use crate::wear::archard::{passage_wear, Band};
use crate::wear::flank::Flank;

/// The rows builder.
#[derive(Default)]
pub(super) struct Rows {
    /// Rows in report order.
    pub rows: Vec<Row>,
}

impl Rows {
    #[allow(clippy::too_many_arguments)]
    fn push(
        &mut self,
        id: &str,
        section: &str,
        evidence: Evidence,
        claim: &str,
        study: String,
        ours: String,
        value: Option<f64>,
        tolerance: &str,
        verdict: impl Into<Verdict>,
        method: &str,
        error: String,
        seconds: f64,
    ) {
        self.rows.push(Row {
            id: id.into(),
            section: section.into(),
            evidence,
            claim: claim.into(),
            study,
            ours,
            value,
            tolerance: tolerance.into(),
            verdict: verdict.into(),
            method: method.into(),
            error,
            seconds,
        });
    }
}

/// The sweeps and what both readings found on them, for the rows that read the sweeps.
pub(super) struct SweepReading<'a> {
    set: &'a GearSet,
    plan: &'a ValidationPlan,
    tt: &'a [Mode],
    kappa: u32,
    sweeps: &'a SweepRun,
    first: Readings,
    second: Option<Readings>,
    method: String,
    fm_per_rpm: f64,
    f_rot1: f64,
    samples: usize,
}

impl<'a> SweepReading<'a> {
    pub(super) fn new(
        set: &'a GearSet,
        plan: &'a ValidationPlan,
        tt: &'a [Mode],
        kappa: u32,
        sweeps: &'a SweepRun,
        run: &RunSettings,
    ) -> Self {
        let step = plan.sweep.iter().map(|s| s.2).fold(0.0, f64::max);
        let fm_per_rpm = f64::from(set.sun().teeth) / 60.0;
        let f_rot1 = distinct(tt, ModeClass::Rotational).first().map_or(STUDY_FREQUENCIES[0], |m| m.0);
        let first = read(&sweeps.curves, step, fm_per_rpm, f_rot1);
        let second =
            (!sweeps.check_curves.is_empty()).then(|| read(&sweeps.check_curves, step, fm_per_rpm, f_rot1));
        let method = sweeps.method.clone();
        let samples = run.samples_per_mesh_cycle();
        Self { set, plan, tt, kappa, sweeps, first, second, method, fm_per_rpm, f_rot1, samples }
    }

    /// A force \[N\] per mm of face width \[N/mm\].
    fn per_mm(&self, f: f64) -> f64 {
        f / (self.set.sun().face_width * 1e3)
    }

    /// What the second reading found, for the error column.
    fn again_words(&self, what: String) -> String {
        match self.sweeps.check_from {
            Some(r) => format!("; at a third of the tolerance from {r:.0} rpm: {what}"),
            None => String::new(),
        }
    }

    /// `f` on the first reading and, where the plan asks for one, on the second.
    fn both<T>(&self, f: impl Fn(&[Curve], &Readings) -> T) -> (T, Option<T>) {
        let a = f(&self.sweeps.curves, &self.first);
        (a, self.second.as_ref().map(|r| f(&self.sweeps.check_curves, r)))
    }

    /// 2 f_m over f₂ at `rpm` [-].
    fn ratio(&self, rpm: f64) -> f64 {
        2.0 * self.fm_per_rpm * rpm / self.f_rot1
    }

    /// The harmonic and the mode of the transverse–torsional model that a peak at `rpm` lies nearest.
    fn explain(&self, rpm: f64) -> String {
        let fm = self.fm_per_rpm * rpm;
        let mut best = (f64::INFINITY, 0u32, 0.0, ModeClass::Mixed);
        for l in 1..=6u32 {
            let family = excited_family(l, self.set.sun().teeth, self.set.planet_angles().len());
            for m in self.tt.iter().filter(|m| m.class == family) {
                let mis = (f64::from(l) * fm - m.frequency).abs() / m.frequency;
                if mis < best.0 {
                    best = (mis, l, m.frequency, family);
                }
            }
        }
        format!(
            "{}×f_m = {:.0} Hz on the {} mode at {:.0} Hz",
            best.1,
            f64::from(best.1) * fm,
            format!("{:?}", best.3).to_lowercase(),
            best.2
        )
    }
}

/// A list of speeds in words \[rpm\].
fn list(xs: impl Iterator<Item = f64>) -> String {
    xs.map(|r| format!("{r:.0}")).collect::<Vec<_>>().join(", ")
}

/// How much stiffer than the stiffer mean mesh the planet bearings must be
/// for the transverse–torsional frequencies to follow from the torsional
/// ones: at ten times the rotational modes lie within 2 % of them
/// (docs/PARAMETERS.md, the bearing table: 3e10 N/m, 47 times the
/// ring–planet mesh, keeps them within 1.5 %; 3e9 N/m, 4.7 times, moves the
/// first by 13 %).
const RIGID_PIN_RATIO: f64 = 10.0;

/// The evidence of the transverse–torsional frequency rows: identities
/// where the planet bearings are near rigid against the meshes (the
/// torsional calibration then carries over), independent evidence where
/// they are flexible (the bearings, not the calibration, set the modes,
/// and the study's forced response shows where its own were).
fn tt_frequency_evidence(set: &GearSet, modes: &Modes) -> Evidence {
    let lumped = &modes.torsional_model.lumped;
    let mesh = lumped.sun_mesh.max(lumped.ring_mesh);
    let bearing =
        set.supports().planet_bearings.iter().copied().fold(set.supports().planet_bearing, f64::min);
    if bearing >= RIGID_PIN_RATIO * mesh {
        Evidence::Identity
    } else {
        Evidence::Independent
    }
}

/// The natural frequencies of both fidelities. The torsional ones are the
/// calibration's targets (fitted); the transverse–torsional ones, and the
/// absence of a new low mode, are identities on near-rigid planet bearings
/// and independent evidence on flexible ones ([`tt_frequency_evidence`]);
/// one rigid-body rotation follows from the boundary conditions.
pub(super) fn frequency_rows(rows: &mut Rows, set: &GearSet, modes: &Modes) {
    let tt_evidence = tt_frequency_evidence(set, modes);
    let sec = "Natural frequencies (mean-stiffness linear model, carrier held)";
    let modal = "modal analysis of the mean loaded mesh stiffness (64 positions per mesh cycle at the mean planet load)";
    let names = ["first rotational", "planet modes", "second rotational"];
    let picks = [(ModeClass::Rotational, 0), (ModeClass::Planet, 0), (ModeClass::Rotational, 1)];
    let n = set.planet_angles().len();
    for (fid, found_modes, tol, tag) in [
        (Fidelity::Torsional, &modes.torsional, 0.01, "torsional"),
        (Fidelity::TransverseTorsional, &modes.tt, 0.02, "transverse–torsional"),
    ] {
        for ((study, name), (class, k)) in STUDY_FREQUENCIES.iter().zip(names).zip(picks) {
            let (f, mult) = distinct(found_modes, class).get(k).copied().unwrap_or((f64::NAN, 0));
            let expect_mult = match (class, fid) {
                (ModeClass::Planet, Fidelity::Torsional) => n - 1,
                (ModeClass::Planet, Fidelity::TransverseTorsional) => n.saturating_sub(3).max(1),
                _ => 1,
            };
            let rel = f / study - 1.0;
            let torsional = fid == Fidelity::Torsional;
            rows.push(
                &format!(
                    "frequency-{}-{}",
                    if torsional { "torsional" } else { "tt" },
                    name.replace(' ', "-")
                ),
                sec,
                if torsional { Evidence::Fitted } else { tt_evidence },
                &format!("{tag} model: {name}"),
                if class == ModeClass::Planet {
                    format!("{study:.0} Hz (×{})", n - 1)
                } else {
                    format!("{study:.0} Hz")
                },
                format!("{f:.1} Hz (×{mult}, {:+.2} %)", 100.0 * rel),
                Some(f),
                &format!("±{:.0} % and multiplicity {expect_mult}", 100.0 * tol),
                rel.abs() <= tol && mult == expect_mult,
                modal,
                "eigenvalues to rounding; the mean stiffness to 1e-4 (64 positions)".into(),
                modes.seconds,
            );
        }
    }
    let f2 = STUDY_FREQUENCIES[0];
    let lowest_excitable = modes
        .tt
        .iter()
        .filter(|m| matches!(m.class, ModeClass::Rotational | ModeClass::Planet))
        .map(|m| m.frequency)
        .fold(f64::INFINITY, f64::min);
    let translational: Vec<String> = distinct(&modes.tt, ModeClass::Translational)
        .iter()
        .filter(|(f, _)| *f < f2)
        .map(|(f, _)| format!("{f:.0}"))
        .collect();
    let translational_excited =
        (1..=6).any(|l| excited_family(l, set.sun().teeth, n) == ModeClass::Translational);
    rows.push(
        "frequency-tt-no-new-low-mode",
        sec,
        tt_evidence,
        "the supports put no new rotational or planet mode below f₂ (the torsional model suffices)",
        format!("none below f₂ = {f2:.0} Hz"),
        format!(
            "lowest rotational/planet mode {lowest_excitable:.0} Hz; translational modes below f₂: {} Hz ({})",
            if translational.is_empty() { "none".into() } else { translational.join(", ") },
            if translational_excited {
                "excited by some harmonic"
            } else {
                "no mesh harmonic excites them: l·Z_s ± 1 is never a multiple of n"
            }
        ),
        Some(lowest_excitable),
        "≥ 0.98 f₂",
        lowest_excitable >= 0.98 * f2,
        modal,
        "eigenvalues to rounding".into(),
        modes.seconds,
    );
    let rigid = modes.torsional.iter().filter(|m| m.class == ModeClass::RigidBody).count();
    rows.push(
        "frequency-rigid-body",
        sec,
        Evidence::Identity,
        "one free rigid-body rotation (carrier held, torque boundary conditions)",
        "one zero frequency".into(),
        format!("{rigid} rigid-body mode(s)"),
        Some(rigid as f64),
        "exactly one",
        rigid == 1,
        modal,
        "exact".into(),
        modes.seconds,
    );
}

/// Quasi-static load sharing: the sun–planet share is a calibration target
/// (the chamfer height), the ring–planet share is not.
pub(super) fn contact_rows(rows: &mut Rows, set: &GearSet, contact: &SetModel) {
    let t = Instant::now();
    let load = set.mesh_load_per_planet();
    let share_sp = contact.sun_planet.double_contact_share(load);
    let share_rp = contact.ring_planet.double_contact_share(load);
    let t_share = t.elapsed().as_secs_f64();
    let sec = "Loaded tooth contact (quasi-static, unworn)";
    let ltca = "one pair's loaded engagement at the mean planet load (bisection to 1e-12 of a base pitch)";
    rows.push(
        "double-contact-sun-planet",
        sec,
        Evidence::Fitted,
        "share of the mesh cycle with two pairs loaded, sun–planet",
        "≈ 1/5".into(),
        format!("{share_sp:.4}"),
        Some(share_sp),
        "0.20 ± 0.02 (read off a figure)",
        (share_sp - 0.2).abs() <= 0.02,
        ltca,
        "contact tables every 11 µm of travel; the engagement's ends to 1e-12 p_b".into(),
        t_share,
    );
    rows.push(
        "double-contact-ring-planet",
        sec,
        Evidence::Independent,
        "share of the mesh cycle with two pairs loaded, ring–planet",
        "nearly always (≥ 0.9)".into(),
        format!("{share_rp:.4}"),
        Some(share_rp),
        "≥ 0.9",
        share_rp >= 0.9,
        ltca,
        "as above".into(),
        t_share,
    );
}

const WEAR_SECTION: &str = "Wear (Archard, quasi-static loads, sun and planet wear, ε^κ = 2.5 µm per update)";

/// Depth, tips and pitch point of the wear. The total is an identity (κ
/// updates of ε^κ = 2.5 µm each); the tips and the pitch point are not.
pub(super) fn wear_rows(rows: &mut Rows, plan: &ValidationPlan, wear: &WearRun) {
    let (sun, planet) = (&wear.sun, &wear.planet);
    let um = |x: f64| x * 1e6;
    let deepest = wear.worn.deepest();
    rows.push(
        "wear-total",
        WEAR_SECTION,
        Evidence::Identity,
        &format!("total wear at κ = {}", plan.kappa),
        "ε_tot ≈ 15 µm".into(),
        format!(
            "{:.2} µm ({} at {:.2}°)",
            um(deepest.depth),
            deepest.flank.name(),
            deepest.roll.to_degrees()
        ),
        Some(deepest.depth),
        "15 ± 0.5 µm",
        (um(deepest.depth) - 15.0).abs() <= 0.5,
        &wear.method,
        wear.error(&|s| s.deepest.0, true),
        wear.seconds,
    );
    let tip_ratio = (sun.tip_end / sun.deepest.0).max(planet.tip_end / sun.deepest.0);
    rows.push(
        "wear-tips",
        WEAR_SECTION,
        Evidence::Independent,
        "wear goes to zero at the chamfered tips",
        "0 at the tips".into(),
        format!(
            "sun tip {:.2} µm, planet tip {:.2} µm ({:.0} % of the deepest)",
            um(sun.tip_end),
            um(planet.tip_end),
            100.0 * tip_ratio
        ),
        Some(tip_ratio),
        "≤ 10 % of the deepest: the grid's last point sits on the edge where the load stops, under half a Hertz band",
        tip_ratio <= 0.10,
        &wear.method,
        wear.error(&|s| s.tip_end, true),
        wear.seconds,
    );
    let dev = &wear.worn.flanks.get(Flank::SunDrive)[0];
    let inner_min = dev
        .depth
        .iter()
        .zip(&dev.roll)
        .skip(1)
        .take(dev.depth.len().saturating_sub(2))
        .fold((f64::INFINITY, 0.0), |m, (d, r)| if *d < m.0 { (*d, *r) } else { m });
    let pitch_ok =
        (inner_min.1 - sun.pitch.1).abs() <= 1.0_f64.to_radians() && sun.pitch.0 <= 0.1 * sun.deepest.0;
    rows.push(
        "wear-pitch-point",
        WEAR_SECTION,
        Evidence::Independent,
        "almost no wear at the pitch point (sun roll angle 22.3°)",
        "minimum at 22.3°".into(),
        format!(
            "least sun wear {:.2} µm at {:.2}°; at the pitch point ({:.2}°) {:.2} µm ({:.0} % of the deepest)",
            um(inner_min.0),
            inner_min.1.to_degrees(),
            sun.pitch.1.to_degrees(),
            um(sun.pitch.0),
            100.0 * sun.pitch.0 / sun.deepest.0
        ),
        Some(inner_min.1.to_degrees()),
        "minimum within ±1° of the pitch point and ≤ 10 % of the deepest",
        pitch_ok,
        &wear.method,
        wear.error(&|s| s.pitch.0, true),
        wear.seconds,
    );
}

/// Where the wear lies: the sun's dedendum, less on the planet, the planet's addendum.
pub(super) fn wear_shape_rows(rows: &mut Rows, wear: &WearRun) {
    let (sun, planet) = (&wear.sun, &wear.planet);
    let um = |x: f64| x * 1e6;
    let sap = wear.worn.flanks.get(Flank::SunDrive)[0].roll.first().copied().unwrap_or(0.0);
    rows.push(
        "wear-sun-dedendum",
        WEAR_SECTION,
        Evidence::Independent,
        "the sun wears most in its dedendum",
        "deepest between the start of active profile and the pitch point".into(),
        format!(
            "deepest {:.2} µm at {:.2}° (start of active profile {:.2}°, pitch point {:.2}°)",
            um(sun.deepest.0),
            sun.deepest.1.to_degrees(),
            sap.to_degrees(),
            sun.pitch.1.to_degrees()
        ),
        Some(sun.deepest.1.to_degrees()),
        "start of active profile < roll < pitch point",
        sun.deepest.1 > sap && sun.deepest.1 < sun.pitch.1,
        &wear.method,
        wear.error(&|s| s.deepest.1.to_degrees() * 1e-6, true).replace("µm", "°"),
        wear.seconds,
    );
    rows.push(
        "wear-planet-smaller",
        WEAR_SECTION,
        Evidence::Independent,
        "the planet wears less than the sun",
        "planet < sun".into(),
        format!(
            "planet deepest {:.2} µm against the sun's {:.2} µm",
            um(planet.deepest.0),
            um(sun.deepest.0)
        ),
        Some(planet.deepest.0 / sun.deepest.0),
        "planet / sun < 1",
        planet.deepest.0 < sun.deepest.0,
        &wear.method,
        wear.error(&|s| s.deepest.0, false),
        wear.seconds,
    );
    rows.push(
        "wear-planet-addendum",
        WEAR_SECTION,
        Evidence::Independent,
        "the planet's wear lies relatively more on its addendum",
        "more above its pitch point".into(),
        format!(
            "{:.0} % of the planet's worn area above its pitch point ({:.2}°); deepest at {:.2}°",
            100.0 * planet.addendum_share,
            planet.pitch.1.to_degrees(),
            planet.deepest.1.to_degrees()
        ),
        Some(planet.addendum_share),
        "share above the pitch point > 50 %",
        planet.addendum_share > 0.5,
        &wear.method,
        "shares of a 50-point grid: ±2 %".into(),
        wear.seconds,
    );
}

const FORCED_SECTION: &str = "Forced response (κ = 0)";

/// The study's resonance peaks, and the speed it uses as its off-resonance
/// example, 2750 rpm, which must not be a peak.
pub(super) fn peak_rows(rows: &mut Rows, r: &SweepReading) {
    for study in STUDY_PEAKS {
        let nearest = |peaks: &[(f64, f64)]| {
            peaks.iter().min_by(|a, b| (a.0 - study).abs().total_cmp(&(b.0 - study).abs())).copied()
        };
        let within = |n: Option<(f64, f64)>| n.is_some_and(|(rpm, _)| (rpm / study - 1.0).abs() <= 0.05);
        let short = |n: Option<(f64, f64)>| match n {
            Some((rpm, _)) => format!("{rpm:.0} rpm ({:+.1} %)", 100.0 * (rpm / study - 1.0)),
            None => "no peak".into(),
        };
        let (n1, n2) = r.both(|_, x| nearest(&x.peaks0));
        let differs = n2.is_some_and(|n| n.map(|p| p.0) != n1.map(|p| p.0));
        let mut ours = match n1 {
            Some((rpm, f)) => format!("{}, F^(rms) {:.1} N/mm; {}", short(n1), r.per_mm(f), r.explain(rpm)),
            None => "no peak".into(),
        };
        if let (true, Some(n)) = (differs, n2) {
            ours += &format!("; at a third of the tolerance {}", short(n));
        }
        let again = n2.map_or(String::new(), |n| {
            r.again_words(if differs { short(n) } else { "the same peak".into() })
        });
        rows.push(
            &format!("peak-{study:.0}"),
            FORCED_SECTION,
            Evidence::Independent,
            &format!("a resonance peak near {study:.0} rpm"),
            format!("≈ {study:.0} rpm"),
            ours,
            n1.map(|p| p.0),
            "±5 % (read off the study's figure)",
            Verdict::of_readings(within(n1), n2.map(within)),
            &r.method,
            format!("±{:.0} rpm (half the speed step){again}", r.plan.step_at(study) / 2.0),
            r.sweeps.seconds,
        );
    }
    // 2750 rpm is the study's off-resonance example. A peak at a grid
    // point needs a neighbour on each side, so the grid must reach two
    // steps beyond 2750 rpm either way for the row to be read at all.
    let at = super::OFF_RESONANCE[2];
    let step = r.plan.step_at(at);
    let grid = &r.sweeps.curves[0].points;
    let covered = grid.first().is_some_and(|p| rad_per_s_to_rpm(p.speed) <= at - 2.0 * step + 1e-6)
        && grid.last().is_some_and(|p| rad_per_s_to_rpm(p.speed) >= at + 2.0 * step - 1e-6);
    let (p1, p2) = r.both(|_, x| peak_within(&x.peaks0, at, step));
    let words = |p: Option<(f64, f64)>| match p {
        Some((rpm, f)) => format!("a prominent peak at {rpm:.0} rpm, F^(rms) {:.1} N/mm", r.per_mm(f)),
        None => format!("no prominent peak within ±{step:.0} rpm"),
    };
    let ours = if covered {
        format!("{} (κ = 0, either direction)", words(p1))
    } else {
        format!("not read: the sweeps' grid does not reach {:.0}–{:.0} rpm", at - 2.0 * step, at + 2.0 * step)
    };
    rows.push(
        "off-resonance-2750",
        FORCED_SECTION,
        Evidence::Independent,
        "2750 rpm, the study's off-resonance example, is not a resonance peak at κ = 0",
        "no peak at 2750 rpm".into(),
        ours,
        p1.map(|p| p.0),
        "no prominent peak (10 % prominence, either direction) within ± one speed step of 2750 rpm; the grid must reach two steps beyond it",
        Verdict::of_readings(covered && p1.is_none(), p2.map(|p| covered && p.is_none())),
        &r.method,
        format!("±{:.0} rpm (half the speed step){}", step / 2.0, p2.map_or(String::new(), |p| r.again_words(words(p)))),
        r.sweeps.seconds,
    );
}

/// The jump: its two-branch band as one contiguous stretch of the grid (the
/// stretch holding the largest difference; any other point is a stray).
/// Returns the words, whether the claim holds and the band's lower edge \[rpm\].
fn jump(r: &SweepReading, x: &Readings) -> (String, bool, Option<f64>) {
    let (band, strays) = contiguous_band(&x.band);
    let (worn_band, _) = contiguous_band(&x.worn_band);
    let worn_words = match (worn_band.first(), worn_band.last()) {
        (Some(a), Some(b)) => {
            format!("; at κ = {}: two branches from {:.0} to {:.0} rpm", r.kappa, a.rpm, b.rpm)
        }
        _ => format!("; at κ = {}: none", r.kappa),
    };
    let stray_words = if strays.is_empty() {
        "one contiguous band".to_string()
    } else {
        format!("stray points apart from the band at {} rpm", list(strays.iter().map(|p| p.rpm)))
    };
    match (band.first(), band.last()) {
        (Some(a), Some(b)) => {
            let upper = band.iter().filter(|p| p.down > p.up).count();
            (
                format!(
                    "two branches from {:.0} to {:.0} rpm (2f_m = {:.2}–{:.2} f₂, f₂ = {:.0} Hz); the down sweep stays on the upper branch at {upper} of {} speeds (softening); {stray_words}{worn_words}",
                    a.rpm,
                    b.rpm,
                    r.ratio(a.rpm),
                    r.ratio(b.rpm),
                    r.f_rot1,
                    band.len()
                ),
                strays.is_empty() && r.ratio(a.rpm) >= 0.7 && r.ratio(b.rpm) <= 1.05 && upper * 2 >= band.len(),
                Some(a.rpm),
            )
        }
        _ => (
            format!(
                "the up and down sweeps agree within 10 % everywhere near 2 f_m = f₂ at κ = 0{worn_words}"
            ),
            false,
            None,
        ),
    }
}

/// The separation of the ring–planet mesh on the κ = 0 down sweep at 9000,
/// 8500 rpm and the jump-down speed: (rpm, share) each, and whether it is
/// above zero and grows towards the jump-down speed within one sample.
fn ring_separation(r: &SweepReading, curves: &[Curve], x: &Readings) -> (Vec<(f64, f64)>, bool) {
    let (band, _) = contiguous_band(&x.band);
    let Some(down_at) = jump_down_speed(&band) else {
        return (Vec::new(), false);
    };
    let at: Vec<(f64, f64)> = [9000.0, 8500.0, down_at]
        .iter()
        .filter_map(|s| nearest(&curves[1], *s).map(|p| (rad_per_s_to_rpm(p.speed), p.separation[1])))
        .collect();
    let shares: Vec<f64> = at.iter().map(|p| p.1).collect();
    let ok =
        at.len() == 3 && down_at <= 8500.0 + 1e-6 && positive_and_growing(&shares, 1.0 / r.samples as f64);
    (at, ok)
}

/// The jump near f₂ ≈ 2 f_m and the separation on its upper branch, on both meshes.
pub(super) fn jump_rows(rows: &mut Rows, r: &SweepReading) {
    let ((mut ours, ok, value), again) = r.both(|_, x| jump(r, x));
    if !r.sweeps.folds.is_empty() {
        ours += &format!("; the branches: {}", r.sweeps.folds);
    }
    let edges = |t: &(String, bool, Option<f64>)| t.0.split(';').next().unwrap_or_default().to_string();
    rows.push(
        "jump-softening",
        FORCED_SECTION,
        Evidence::Independent,
        "a softening jump with one contiguous two-branch band near f₂ ≈ 2 f_m",
        "up and down sweeps differ; jump below the linear resonance".into(),
        ours,
        value,
        "the speeds where the branches differ by > 10 % (2f_m between 0.7 and 1.1 f₂) form one contiguous stretch of the grid (a stray point fails the row), at 2f_m between 0.7 and 1.05 f₂, the upper one reached from above",
        Verdict::of_readings(ok, again.as_ref().map(|a| a.1)),
        &r.method,
        format!("band edges ±{:.0} rpm{}", r.plan.step_at(8500.0), again.map_or(String::new(), |a| r.again_words(edges(&a)))),
        r.sweeps.seconds,
    );
    let sun = |x: &Readings| -> (f64, f64, String) {
        let (band, _) = contiguous_band(&x.band);
        let top = band
            .iter()
            .fold((0.0, 0.0), |m, p: &BandPoint| if p.separation > m.0 { (p.separation, p.rpm) } else { m });
        let span = match (band.first(), band.last()) {
            (Some(a), Some(b)) => format!("{:.0}–{:.0} rpm", a.rpm, b.rpm),
            _ => "none".into(),
        };
        (top.0, top.1, span)
    };
    let ((sep, at, span), sep_again) = r.both(|_, x| sun(x));
    rows.push(
        "separation-large-peak",
        FORCED_SECTION,
        Evidence::Independent,
        "tooth separation at the large peak: the sun–planet mesh on the jump's two-branch band",
        "the sun–planet mesh loses contact".into(),
        format!(
            "sun–planet mesh: largest separation on the band ({span}) {:.1} % of the cycle at {at:.0} rpm; largest anywhere {:.1} % at {:.0} rpm",
            100.0 * sep,
            100.0 * r.first.separation.0,
            r.first.separation.1
        ),
        Some(sep),
        "> 0 on the contiguous two-branch band, either direction",
        Verdict::of_readings(sep > 0.0, sep_again.as_ref().map(|s| s.0 > 0.0)),
        &r.method,
        format!(
            "samples of {0} per mesh cycle: 1/{0} of the cycle{1}",
            r.samples,
            sep_again.map_or(String::new(), |s| r.again_words(format!("{:.1} % at {:.0} rpm", 100.0 * s.0, s.1)))
        ),
        r.sweeps.seconds,
    );
    let ((at, ok), again) = r.both(|c, x| ring_separation(r, c, x));
    let words = |at: &[(f64, f64)]| match at {
        [] => "the down sweep holds no upper branch on the band".to_string(),
        _ => at.iter().map(|(s, f)| format!("{s:.0} rpm {:.1} %", 100.0 * f)).collect::<Vec<_>>().join(", "),
    };
    rows.push(
        "separation-ring-upper-branch",
        FORCED_SECTION,
        Evidence::Independent,
        "the ring–planet mesh separates along the upper branch of the jump, more towards the jump-down speed",
        "separation at 9000 and 8500 rpm and near the jump-down, growing towards it".into(),
        format!("ring–planet mesh, κ = 0 down sweep, at 9000, 8500 rpm and the jump-down speed: {}", words(&at)),
        at.last().map(|p| p.1),
        "> 0 at each, non-decreasing from 9000 to 8500 rpm to the jump-down speed (within one sample of the cycle), the jump-down speed (lowest of the band where the down sweep lies above the up) at or below 8500 rpm",
        Verdict::of_readings(ok, again.as_ref().map(|a| a.1)),
        &r.method,
        format!(
            "samples of {0} per mesh cycle: 1/{0} of the cycle{1}",
            r.samples,
            again.map_or(String::new(), |a| r.again_words(words(&a.0)))
        ),
        r.sweeps.seconds,
    );
}

/// The continuation's curves against marching: each spot check marches
/// from a stable branch point's state with the run's integrator and
/// compares F^(rms) of both meshes; a march that left the branch, or a
/// branch state that is not a solution of the equations of motion, shows
/// as a difference far above the integrator's error.
pub(super) fn spot_row(rows: &mut Rows, r: &SweepReading) {
    if r.sweeps.spots.is_empty() {
        return;
    }
    let spots = &r.sweeps.spots;
    let worst = spots.iter().max_by(|a, b| a.difference().total_cmp(&b.difference())).expect("not empty");
    let dir = |d: Direction| if d == Direction::Up { "up" } else { "down" };
    let each = spots
        .iter()
        .map(|s| {
            format!(
                "κ = {} {} {:.0} rpm {:.2e} (|μ| {:.3})",
                s.kappa,
                dir(s.direction),
                s.rpm,
                s.difference(),
                s.multiplier
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    rows.push(
        "forced-response-spot-check",
        FORCED_SECTION,
        Evidence::Identity,
        "the continuation's stable branch points are the steady states time marching reaches from them",
        "—".into(),
        format!(
            "largest difference of F^(rms) {:.2e} (κ = {} {} at {:.0} rpm: {:.1} against {:.1} N/mm on the branch); {} points: {each}",
            worst.difference(),
            worst.kappa,
            dir(worst.direction),
            worst.rpm,
            r.per_mm(worst.marched[0]),
            r.per_mm(worst.branch[0]),
            spots.len()
        ),
        Some(worst.difference()),
        &format!("≤ {SPOT_TOLERANCE} of F^(rms), both meshes (the marching integrator's error with a margin for its run-in)"),
        worst.difference() <= SPOT_TOLERANCE,
        &format!("marching from each branch point's state at the period's end; {}", r.method),
        "the marching integrator's error (docs/ACCURACY.md)".into(),
        r.sweeps.spot_seconds,
    );
}

/// The off-resonance rise with wear (a sign test) and the size of F^(1) at 2750 rpm.
pub(super) fn rise_rows(rows: &mut Rows, r: &SweepReading, off: &OffResonance) {
    let sec = format!("Worn set (κ = {}) against unworn", r.kappa);
    let share = off.seconds / off.figures.len() as f64;
    for (rpm, a0, a6, r0, r6) in &off.figures {
        let e = ((a0.1 - r0.1).abs() / r0.1).max((a6.1 - r6.1).abs() / r6.1);
        rows.push(
            &format!("wear-rise-{rpm:.0}"),
            &sec,
            Evidence::Independent,
            &format!("off-resonance F^(rms) of the sun–planet mesh rises with κ, {rpm:.0} rpm"),
            "rises".into(),
            format!(
                "{:.2} → {:.2} N/mm ({:+.1} %); F^(1) {:.2} → {:.2} N/mm",
                r.per_mm(a0.1),
                r.per_mm(a6.1),
                100.0 * (a6.1 / a0.1 - 1.0),
                r.per_mm(a0.0),
                r.per_mm(a6.0)
            ),
            Some(a6.1 / a0.1 - 1.0),
            "κ = 6 above κ = 0 by more than the error (a sign test: the magnitude rows carry the size)",
            a6.1 - a0.1 > e * a6.1.max(a0.1),
            &off.method,
            format!("{e:.1e} of F^(rms) against the reference"),
            share,
        );
    }
    let (df1, drms): (f64, f64) =
        off.figures.iter().fold((0.0, 0.0), |s, f| (s.0 + (f.2 .0 - f.1 .0), s.1 + (f.2 .1 - f.1 .1)));
    rows.push(
        "wear-rise-mostly-first-harmonic",
        &sec,
        Evidence::Independent,
        "the rise is mostly in F^(1)",
        "mostly F^(1)".into(),
        format!("ΔF^(1) / ΔF^(rms) = {:.2} (summed over the four speeds)", df1 / drms),
        Some(df1 / drms),
        "> 0.5",
        drms > 0.0 && df1 / drms > 0.5,
        &off.method,
        "as the rows above".into(),
        off.seconds,
    );
    let at = super::OFF_RESONANCE[2];
    let Some((_, a0, a6, r0, r6)) = off.figures.iter().find(|f| f.0 == at) else {
        return;
    };
    for (id, kappa, study, ours, reference) in
        [("magnitude-2750-unworn", 0, 13.0, a0.0, r0.0), ("magnitude-2750-worn", r.kappa, 30.0, a6.0, r6.0)]
    {
        let rel = r.per_mm(ours) / study - 1.0;
        rows.push(
            id,
            &sec,
            Evidence::Independent,
            &format!("F^(1) of the sun–planet mesh at {at:.0} rpm (off resonance), κ = {kappa}"),
            format!("{}{study:.0} N/mm", if kappa == 0 { "" } else { "about " }),
            format!("{:.2} N/mm ({:+.0} %)", r.per_mm(ours), 100.0 * rel),
            Some(r.per_mm(ours)),
            "±25 %",
            rel.abs() <= 0.25,
            &off.method,
            format!("{:.1e} of F^(1) against the reference", ((ours - reference) / reference).abs()),
            share,
        );
    }
}

/// The worn sweeps against the unworn: the new peaks the study names, and
/// the little influence of wear near resonance and where teeth separate.
pub(super) fn worn_sweep_rows(rows: &mut Rows, r: &SweepReading) {
    let sec = format!("Worn set (κ = {}) against unworn", r.kappa);
    let targets = [3000.0, 7000.0];
    let new = |x: &Readings| targets.map(|t| new_peak_near(&x.peaks6, &x.peaks0, t, 0.05, 0.03));
    let words = |n: &[Option<f64>; 2]| {
        targets
            .iter()
            .zip(n)
            .map(|(t, p)| match p {
                Some(p) => format!("near {t:.0}: {p:.0} rpm"),
                None => format!("near {t:.0}: none"),
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    let (n1, n2) = r.both(|_, x| new(x));
    let found = |n: &[Option<f64>; 2]| n.iter().all(Option::is_some);
    rows.push(
        "wear-new-peaks",
        &sec,
        Evidence::Independent,
        "new resonance peaks appear in the worn sweeps near 3000 and 7000 rpm",
        "new peaks near 3000 and 7000 rpm".into(),
        format!(
            "{} (peaks at κ = 0: {} rpm; at κ = {}: {} rpm)",
            words(&n1),
            list(r.first.peaks0.iter().map(|p| p.0)),
            r.kappa,
            list(r.first.peaks6.iter().map(|p| p.0))
        ),
        Some(n1.iter().flatten().count() as f64),
        "a peak of κ = 6 within ±5 % of each speed, more than 3 % from every peak of κ = 0",
        Verdict::of_readings(found(&n1), n2.as_ref().map(found)),
        &r.method,
        format!(
            "±{:.0} rpm{}",
            r.plan.step_at(7000.0) / 2.0,
            n2.map_or(String::new(), |n| r.again_words(words(&n)))
        ),
        r.sweeps.seconds,
    );
    // (a) The upper branch of the jump: the down sweeps over κ = 0's band.
    let upper = |c: &[Curve], x: &Readings| {
        let (band, _) = contiguous_band(&x.band);
        let means = band_means(&c[1], &c[3], &band);
        let span = band.first().zip(band.last()).map(|(a, b)| (a.rpm, b.rpm));
        (means, span, means.is_some_and(|(m0, m6)| m6 <= 1.1 * m0))
    };
    let ((means, span, ok), again) = r.both(upper);
    let words = |m: Option<(f64, f64)>| match m {
        Some((m0, m6)) => {
            format!("{:.1} → {:.1} N/mm ({:+.1} %)", r.per_mm(m0), r.per_mm(m6), 100.0 * (m6 / m0 - 1.0))
        }
        None => "no two-branch band at κ = 0".into(),
    };
    rows.push(
        "wear-near-resonance-upper-branch",
        &sec,
        Evidence::Independent,
        "near resonance wear has little influence: the upper branch at f₂ ≈ 2 f_m is not higher at κ = 6",
        "not above κ = 0".into(),
        format!(
            "mean F^(rms) of the down sweeps over κ = 0's two-branch band{}: {}",
            span.map_or(String::new(), |(a, b)| format!(" ({a:.0}–{b:.0} rpm)")),
            words(means)
        ),
        means.map(|(m0, m6)| m6 / m0),
        "κ = 6 at most 10 % above κ = 0 (the share that tells two branches apart)",
        Verdict::of_readings(ok, again.as_ref().map(|a| a.2)),
        &r.method,
        format!("the curves' integrator error{}", again.map_or(String::new(), |a| r.again_words(words(a.0)))),
        r.sweeps.seconds,
    );
    // (b) Where the teeth separate: no long stretch of a worn rise.
    let stretch = |c: &[Curve], _: &Readings| {
        [(0, 2), (1, 3)]
            .map(|(u, w)| longest_stretch(&worn_excess_where_separating(&c[u], &c[w], 0.25)))
            .into_iter()
            .flatten()
            .max_by(|a, b| (a.1 - a.0).total_cmp(&(b.1 - b.0)))
    };
    let (s1, s2) = r.both(stretch);
    let words = |s: Option<(f64, f64)>| match s {
        Some((a, b)) => format!("longest stretch {a:.0}–{b:.0} rpm ({:.0} rpm)", b - a),
        None => "no speed".into(),
    };
    let short = |s: Option<(f64, f64)>| s.is_none_or(|(a, b)| b - a <= 500.0);
    rows.push(
        "wear-near-resonance-separating",
        &sec,
        Evidence::Independent,
        "where teeth separate wear has little influence: no long stretch of separating speeds where κ = 6 is well above κ = 0",
        "little influence where teeth separate".into(),
        format!("speeds with separation (either κ, either mesh) and κ = 6's F^(rms) more than 25 % above κ = 0's, same direction: {}", words(s1)),
        Some(s1.map_or(0.0, |(a, b)| b - a)),
        "no such stretch of consecutive grid speeds spans more than 500 rpm (first to last speed)",
        Verdict::of_readings(short(s1), s2.map(short)),
        &r.method,
        format!("±{:.0} rpm at each end{}", r.plan.step_at(7000.0), s2.map_or(String::new(), |s| r.again_words(words(s)))),
        r.sweeps.seconds,
    );
}

/// Mesh phasing from the steady state at 3000 rpm: the rule follows from
/// the equally spaced planets, an identity of the model's construction.
pub(super) fn phasing_row(
    rows: &mut Rows,
    set: &GearSet,
    run: &RunSettings,
    model0: &PlanetaryDynamics,
    integrator: &str,
) -> Result<(), StudyError> {
    let t = Instant::now();
    let mut m = model0.clone();
    let ss = steady_state(&mut m, set, run, rpm_to_rad_per_s(3000.0), None)?;
    let n = set.planet_angles().len();
    let phases: Vec<Vec<f64>> =
        (0..n).map(|p| mesh_phases(&ss.mesh_force[2 * p], ss.cycles, 6)).collect::<Result<_, _>>()?;
    let amps = &ss.meshes[0].harmonics.amplitude;
    let top = amps.iter().cloned().fold(0.0, f64::max);
    let wrap =
        |a: f64| (a + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI;
    let mut worst = [0.0_f64; 2];
    for (k, sign) in [1.0, -1.0].iter().enumerate() {
        for l in 1..=6usize {
            if amps[l - 1] < 1e-3 * top {
                continue;
            }
            for p in 1..n {
                let rule = sign
                    * 2.0
                    * std::f64::consts::PI
                    * l as f64
                    * f64::from(set.sun().teeth)
                    * set.planet_angles()[p]
                    / (2.0 * std::f64::consts::PI);
                let measured = phases[p][l - 1] - phases[0][l - 1];
                worst[k] = worst[k].max(wrap(measured - rule).abs());
            }
        }
    }
    let worst = worst[0].min(worst[1]).to_degrees();
    let in_phase: Vec<String> = (1..=6u32)
        .filter(|l| excited_family(*l, set.sun().teeth, n) == ModeClass::Rotational)
        .map(|l| l.to_string())
        .collect();
    rows.push(
        "phasing",
        "Mesh phasing (equally spaced planets)",
        Evidence::Identity,
        "harmonic l of the planets' mesh forces is in phase when l·Z_s/n is an integer, sequentially phased otherwise",
        format!("in phase: l = {}; sequential otherwise", in_phase.join(", ")),
        format!("largest deviation of the measured phases from the rule {worst:.3}° (harmonics above 1e-3 of the largest, 3000 rpm)"),
        Some(worst),
        "≤ 1°",
        worst <= 1.0,
        &format!("steady state at 3000 rpm, κ = 0; {integrator}; phases of each planet's sun–planet mesh force"),
        "window of whole mesh cycles: phases exact to the integrator's error".into(),
        t.elapsed().as_secs_f64(),
    );
    Ok(())
}

const BENCHMARK_SECTION: &str = "Published benchmarks and closed forms";

/// The geometry that follows from the study's own tooth data (identities).
pub(super) fn geometry_rows(rows: &mut Rows, set: &GearSet) {
    let t = Instant::now();
    let sp = PathOfContact::new(set, MeshKind::SunPlanet);
    let rp = PathOfContact::new(set, MeshKind::RingPlanet);
    let roll = sp.roll_1(sp.pitch_point()).to_degrees();
    rows.push(
        "geometry-pitch-roll",
        BENCHMARK_SECTION,
        Evidence::Identity,
        "roll angle of the sun at the pitch point",
        "22.3° (study)".into(),
        format!("{roll:.3}°"),
        Some(roll),
        "±0.05°",
        (roll - 22.3).abs() <= 0.05,
        "involute geometry: ξ = tan α_w",
        "exact".into(),
        t.elapsed().as_secs_f64(),
    );
    let (j1, j2) = (
        set.circumferential_backlash(MeshKind::SunPlanet) * 1e3,
        set.circumferential_backlash(MeshKind::RingPlanet) * 1e3,
    );
    rows.push(
        "geometry-backlash",
        BENCHMARK_SECTION,
        Evidence::Identity,
        "circumferential backlash at the pitch circles, sun–planet and ring–planet",
        "p − t_s − t_p = 0.232 mm; p − t_r − t_p = 0.243 mm".into(),
        format!("{j1:.4} mm, {j2:.4} mm"),
        Some(j1),
        "±0.0005 mm",
        (j1 - 0.232).abs() <= 0.0005 && (j2 - 0.243).abs() <= 0.0005,
        "involute geometry from the tooth thicknesses",
        "exact".into(),
        0.0,
    );
    let (e1, e2) = (sp.nominal_contact_ratio(), rp.nominal_contact_ratio());
    rows.push(
        "geometry-contact-ratios",
        BENCHMARK_SECTION,
        Evidence::Identity,
        "nominal contact ratios (sharp tips), sun–planet and ring–planet",
        "about 1.34 and 1.36".into(),
        format!("{e1:.4}, {e2:.4}"),
        Some(e1),
        "±0.005",
        (e1 - 1.34).abs() <= 0.005 && (e2 - 1.36).abs() <= 0.005,
        "path of contact from the tip radii",
        "exact".into(),
        0.0,
    );
    let pb = sp.base_pitch * 1e3;
    rows.push(
        "geometry-base-pitch",
        BENCHMARK_SECTION,
        Evidence::Identity,
        "base pitch π m cos α",
        "4.3905 mm".into(),
        format!("{pb:.4} mm"),
        Some(pb),
        "±0.00005 mm",
        (pb - 4.3905).abs() <= 0.00005,
        "involute geometry",
        "exact".into(),
        0.0,
    );
}

/// The ISO/TR 6336-30 example (independent evidence for the stiffness
/// method) and two closed forms of our own model (identities).
pub(super) fn benchmark_rows(rows: &mut Rows, set: &GearSet, modes: &Modes) {
    // Its contact ratio ε_α is the one the published c_γα implies with the published c'.
    let iso = iso_stiffness(&IsoPair {
        z1: 17.0,
        z2: Some(103.0),
        x1: 0.145,
        x2: 0.0,
        helix: 15.8_f64.to_radians(),
        rack_pressure_angle: 20.0_f64.to_radians(),
        rack_dedendum: 1.4,
        contact_ratio: (17.46485 / 12.37047 - 0.25) / 0.75,
    });
    let rel =
        [iso.single_theoretical / 17.85584 - 1.0, iso.single / 12.37047 - 1.0, iso.mesh / 17.46485 - 1.0];
    let worst = rel.iter().map(|r| r.abs()).fold(0.0, f64::max);
    rows.push(
        "iso-6336-30",
        BENCHMARK_SECTION,
        Evidence::Independent,
        "ISO/TR 6336-30 example 1 (z = 17/103, m_n = 8, α_n = 20°, β = 15.8°, x = 0.145/0): c'_th, c', c_γα",
        "17.85584, 12.37047, 17.46485 N/(mm·µm)".into(),
        format!(
            "{:.5}, {:.5}, {:.5} N/(mm·µm) (largest difference {:.1e})",
            iso.single_theoretical, iso.single, iso.mesh, worst
        ),
        Some(iso.single_theoretical),
        "1e-3 relative (the standard rounds its intermediate factors)",
        worst <= 1e-3,
        "ISO 6336-1 method B",
        "exact".into(),
        0.0,
    );
    // Kahraman's torsional planet modes: ω² = (k_sp + k_rp)/m_p.
    let l = &modes.torsional_model.lumped;
    let closed =
        ((l.sun_mesh + l.ring_mesh) / l.planet_rotational_mass).sqrt() / (2.0 * std::f64::consts::PI);
    let modal = distinct(&modes.torsional, ModeClass::Planet).first().map_or(f64::NAN, |m| m.0);
    rows.push(
        "closed-form-planet-mode",
        BENCHMARK_SECTION,
        Evidence::Identity,
        "torsional planet modes: ω² = (k_sp + k_rp)/m_p, multiplicity n − 1 (Kahraman 1994)",
        format!("{closed:.3} Hz"),
        format!("{modal:.3} Hz"),
        Some(modal),
        "1e-9 relative",
        (modal / closed - 1.0).abs() <= 1e-9,
        "modal analysis against the closed form on the same stiffnesses",
        "rounding".into(),
        0.0,
    );
    // Archard over one passage of a steady Hertz band (Flodin & Andersson 1997):
    // Δh_i = k w |v_i − v_j| / v_i and the sliding distance 2b |1 − v_j / v_i|.
    let e_star = contact_modulus(
        set.material().youngs_modulus,
        set.material().poisson_ratio,
        set.material().youngs_modulus,
        set.material().poisson_ratio,
    );
    let w = 263.07e3; // N/m
    let c = line_contact(w, 0.008, 0.006, false, e_star);
    let (k, ratio) = (1e-18, 0.6); // mating surface at 0.6 of this one's rolling speed
    let steps = 400;
    let travel = 8.0 * c.half_width;
    let bands: Vec<Band> =
        (0..=steps).map(|r| Band { centre: travel * r as f64 / steps as f64, contact: c }).collect();
    let slip: Vec<f64> = (0..steps).map(|_| travel / steps as f64 * (1.0 - ratio)).collect();
    let arc = vec![travel / 2.0];
    let p = passage_wear(&arc, &bands, &slip, k);
    let closed_h = k * w * (1.0 - ratio);
    let closed_s = 2.0 * c.half_width * (1.0 - ratio);
    let (eh, es) = (p.wear[0] / closed_h - 1.0, p.sliding[0] / closed_s - 1.0);
    rows.push(
        "closed-form-archard-passage",
        BENCHMARK_SECTION,
        Evidence::Identity,
        "Archard wear of one passage of a Hertz band: Δh = k w |v_i − v_j|/v_i, sliding 2b|1 − v_j/v_i| (Flodin & Andersson 1997)",
        format!("{:.4e} m, {:.4e} m", closed_h, closed_s),
        format!("{:.4e} m ({:+.2} %), {:.4e} m ({:+.2e})", p.wear[0], 100.0 * eh, p.sliding[0], es),
        Some(p.wear[0]),
        "wear ±1 % (the trapezoid of the square-root edges, 100 steps across the band), sliding 1e-9",
        eh.abs() <= 0.01 && es.abs() <= 1e-9,
        "the wear model's passage on a synthetic steady band",
        "exact but for the trapezoid rule".into(),
        0.0,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::ltca::SetModel;
    use crate::scene::Scene;

    /// The transverse–torsional frequency rows are identities on the
    /// example's stiff pins (3e10 N/m, 47 times the ring–planet mesh) and
    /// independent evidence on the derived needle bearings (2.46e8 N/m,
    /// below the meshes), whose first rotational mode is 4120 Hz.
    #[test]
    fn the_tt_frequency_rows_are_identities_on_stiff_pins_only() {
        for (scene, expected) in [
            (Scene::example_2004_stiff_pins(), Evidence::Identity),
            (Scene::example_2004(), Evidence::Independent),
        ] {
            let set = scene.validate().unwrap();
            let modes = Modes::compute(&scene, &SetModel::new(&set)).unwrap();
            assert_eq!(tt_frequency_evidence(&set, &modes), expected, "{}", scene.name);
        }
    }
}
