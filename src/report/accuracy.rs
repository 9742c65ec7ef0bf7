//! The work-precision study's shell (issue 6; docs/ACCURACY.md): the
//! operating points, the study over all of them, and its files — log-log
//! charts of E_h against CPU time and against right-hand-side evaluations per
//! operating point, a CSV of every run, the tables of observed orders and of
//! the time each method needs to reach 1e-3, 1e-4 and 1e-6, the chosen
//! default, and the whole study as JSON. Every file is written atomically.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::plot::{write_chart, Chart, PlotError, Series, SeriesStyle};
use super::write_atomic;
use crate::analysis::accuracy::{
    cheapest_meeting, observed_order, study_point, time_to_reach, AccuracyError, IndependentIntegrator,
    Method, OperatingPoint, PointResult, SettingResult, StudyPlan,
};
use crate::model::lumped::Fidelity;
use crate::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use crate::scene::{Scene, SceneError};

/// The accuracy every default setting must reach at every operating point.
pub const DEFAULT_TARGET: f64 = 1e-3;

/// The error levels of the time-to-reach table.
pub const TARGETS: [f64; 3] = [1e-3, 1e-4, 1e-6];

/// Errors of the study's shell.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A variant scene of an operating point is invalid.
    #[error("operating point {point}: {source}")]
    Scene {
        /// The operating point.
        point: String,
        /// Why.
        source: SceneError,
    },
    /// A computation failed.
    #[error(transparent)]
    Accuracy(#[from] AccuracyError),
    /// A file could not be written.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// The JSON document could not be formed.
    #[error("JSON: {0}")]
    Json(#[from] serde_json::Error),
}

/// The suffix of an operating point's name at `fidelity`.
fn fidelity_tag(fidelity: Fidelity) -> &'static str {
    match fidelity {
        Fidelity::Torsional => "torsional",
        Fidelity::TransverseTorsional => "transverse_torsional",
    }
}

fn point(name: &str, description: &str, scene: &Scene, speed_rpm: f64) -> Result<OperatingPoint, StudyError> {
    let (set, run) =
        scene.validate_with_run().map_err(|source| StudyError::Scene { point: name.into(), source })?;
    Ok(OperatingPoint {
        name: name.into(),
        description: description.into(),
        set,
        run,
        speed: rpm_to_rad_per_s(speed_rpm),
    })
}

/// The study's operating points of the stiff-pin reading
/// (`example-2004-stiff-pins`, on whose resonances they were chosen) at one
/// fidelity level:
///
/// - `off_resonance`: the example at 3000 rpm (f_m = 1700 Hz).
/// - `separating_resonance`: mesh damping ratio 0.02; torsional at 13 000 rpm
///   (2×f_m = 14 733 Hz on the softening branch of the 14 317 Hz rotational
///   mode: both meshes of planet 1 lose contact 8–9 % of the cycle),
///   transverse–torsional at 13 500 rpm (4×f_m = 30 600 Hz near the
///   31 149 Hz rotational mode: the sun–planet mesh separates). The torsional
///   variant's 11 500 rpm peak separates more but is not periodic: its
///   harmonics over 8 cycles change by 4–24 % from one window to the next
///   and by 7e-3 for a tenfold change of the reference tolerance, so no
///   E_h target below ~1e-1 has a meaning there (docs/ACCURACY.md).
/// - `high_speed`: the example at 14 500 rpm (f_m = 8217 Hz).
/// - `stiff_light`: planet bearings and the sun bearing 10× stiffer
///   (3e9 and 1e9 N/m), planets of half the mass and inertia, 8000 rpm:
///   higher support frequencies, the explicit method's stability bound.
pub fn operating_points(fidelity: Fidelity) -> Result<Vec<OperatingPoint>, StudyError> {
    let mut base = Scene::example_2004_stiff_pins();
    base.dynamics.fidelity = fidelity;
    let tag = fidelity_tag(fidelity);
    let mut points = Vec::new();
    points.push(point(
        &format!("off_resonance_{tag}"),
        "example-2004-stiff-pins, 3000 rpm: off resonance",
        &base,
        3000.0,
    )?);
    let mut light_damping = base.clone();
    light_damping.dynamics.mesh_damping_ratio = 0.02;
    let (speed, why) = match fidelity {
        Fidelity::Torsional => (
            13000.0,
            "mesh damping ratio 0.02, 13 000 rpm: 3×f_m = 22 100 Hz, between the planet modes (20 852 Hz) and the second rotational mode (23 144 Hz); the ring–planet mesh separates",
        ),
        Fidelity::TransverseTorsional => (
            13500.0,
            "mesh damping ratio 0.02, 13 500 rpm: 3×f_m = 22 950 Hz, near the second rotational mode (23 090 Hz)",
        ),
    };
    points.push(point(&format!("separating_resonance_{tag}"), why, &light_damping, speed)?);
    points.push(point(
        &format!("high_speed_{tag}"),
        "example-2004-stiff-pins, 14 500 rpm: high speed",
        &base,
        14500.0,
    )?);
    let set = base.validate().map_err(|source| StudyError::Scene { point: "stiff_light".into(), source })?;
    let mut stiff = base.clone();
    stiff.supports.planet_bearing_n_per_m *= 10.0;
    stiff.supports.sun_radial_n_per_m *= 10.0;
    stiff.inertia.planet_mass_kg = Some(0.5 * set.bodies().planet.mass);
    stiff.inertia.planet_inertia_kg_m2 = Some(0.5 * set.bodies().planet.inertia);
    points.push(point(
        &format!("stiff_light_{tag}"),
        "planet and sun bearings 10× stiffer, planets of half the mass and inertia, 8000 rpm",
        &stiff,
        8000.0,
    )?);
    Ok(points)
}

/// The operating points of the example itself (`example-2004`: its planets on
/// the derived needle bearings, Rayleigh damping, 240 samples per mesh cycle),
/// which the full study adds to [`operating_points`] at one fidelity level:
///
/// - `example_off_resonance`: 3000 rpm (f_m = 1700 Hz), both fidelities.
/// - `example_resonance`, transverse–torsional: 3600 rpm, where 2×f_m = 4080 Hz
///   meets the first rotational mode (4119.6 Hz): the sweep's first peak.
///
/// The torsional level has no planet bearings, so it differs from the stiff-pin
/// reading's only in its damping and samples: one point. The sweep's peak near the
/// study's 13 000 rpm (12 850 rpm) is not a point: there references at rtol
/// 1e-12 and 1e-13 land on states whose third mesh harmonics lie 0.3 to 3.5 %
/// apart after the drift check's run-in, docs/ACCURACY.md.
pub fn example_points(fidelity: Fidelity) -> Result<Vec<OperatingPoint>, StudyError> {
    let mut base = Scene::example_2004();
    base.dynamics.fidelity = fidelity;
    let tag = fidelity_tag(fidelity);
    let mut points = vec![point(
        &format!("example_off_resonance_{tag}"),
        "example-2004 (derived planet bearings, Rayleigh damping), 3000 rpm: off resonance",
        &base,
        3000.0,
    )?];
    if fidelity == Fidelity::TransverseTorsional {
        points.push(point(
            &format!("example_resonance_{tag}"),
            "example-2004, 3600 rpm: 2×f_m = 4080 Hz on the first rotational mode (4119.6 Hz), the sweep's first peak",
            &base,
            3600.0,
        )?);
    }
    Ok(points)
}

/// The study's default choice.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DefaultChoice {
    /// The family it was chosen in ("all" for the overall choice).
    pub family: String,
    /// The chosen setting, if any setting meets the target everywhere.
    pub method: Option<Method>,
    /// Its total CPU time over the operating points \[s\].
    pub total_cpu_seconds: Option<f64>,
    /// Its E_h at each operating point (name, E_h) \[1\].
    pub errors: Vec<(String, f64)>,
}

/// The whole study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Study {
    /// The grid.
    pub plan: StudyPlan,
    /// Results per operating point.
    pub points: Vec<PointResult>,
    /// The cheapest setting meeting [`DEFAULT_TARGET`] everywhere, overall and per family.
    pub defaults: Vec<DefaultChoice>,
    /// Wall time of the study \[s\].
    pub wall_seconds: f64,
}

/// Runs the study at every point; `progress(point, run)` after each run.
pub fn run_study(
    points: &[OperatingPoint],
    plan: &StudyPlan,
    independent: Option<&dyn IndependentIntegrator>,
    mut progress: impl FnMut(&str, &str),
) -> Result<Study, StudyError> {
    let started = std::time::Instant::now();
    let mut results = Vec::with_capacity(points.len());
    for p in points {
        results.push(study_point(p, plan, independent, |run| progress(&p.name, run))?);
    }
    let defaults = choose_defaults(&results);
    Ok(Study { plan: plan.clone(), points: results, defaults, wall_seconds: started.elapsed().as_secs_f64() })
}

fn choice(points: &[PointResult], family: &str, picked: Option<(Method, f64)>) -> DefaultChoice {
    let errors = match &picked {
        Some((m, _)) => points
            .iter()
            .filter_map(|p| {
                let s = p.settings.iter().find(|s| s.method == *m)?;
                Some((p.name.clone(), s.error?))
            })
            .collect(),
        None => Vec::new(),
    };
    DefaultChoice {
        family: family.into(),
        method: picked.map(|p| p.0),
        total_cpu_seconds: picked.map(|p| p.1),
        errors,
    }
}

/// The cheapest setting meeting [`DEFAULT_TARGET`] at every point, overall
/// and within each family.
pub fn choose_defaults(points: &[PointResult]) -> Vec<DefaultChoice> {
    let mut out = vec![choice(points, "all", cheapest_meeting(points, DEFAULT_TARGET))];
    if let Some(first) = points.first() {
        for family in first.families() {
            let only: Vec<PointResult> = points
                .iter()
                .map(|p| {
                    let mut q = p.clone();
                    q.settings.retain(|s| s.method.family() == family);
                    q
                })
                .collect();
            out.push(choice(points, &family, cheapest_meeting(&only, DEFAULT_TARGET)));
        }
    }
    out
}

/// A number for a table: three significant digits, scientific below 1e-2.
fn num(x: f64) -> String {
    if !x.is_finite() {
        "–".into()
    } else if x != 0.0 && x.abs() < 1e-2 {
        format!("{x:.2e}")
    } else {
        format!("{x:.3}")
    }
}

/// A time for a table, in ms.
fn ms(x: Option<f64>) -> String {
    match x {
        Some(t) => format!("{:.1}", t * 1e3),
        None => "not reached".into(),
    }
}

/// Time to reach `target`, or why not: below the point's reporting floor
/// the study cannot tell.
fn reach(p: &PointResult, family: &[&SettingResult], target: f64) -> String {
    if target < p.floor() {
        return format!("below floor ({})", num(p.floor()));
    }
    ms(time_to_reach(family, target))
}

/// The tables of the study in Markdown: the references, observed orders
/// and times to reach each target per method and operating point, and the
/// default choice.
pub fn tables_markdown(study: &Study) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "### References\n");
    let _ = writeln!(
        s,
        "| operating point | fidelity | rpm | f_m (Hz) | separation (sun, ring) | reference steps | events in window | closest event (sample intervals) | self-check | independent | agreement | drift | floor |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for p in &study.points {
        let r = &p.reference;
        let sep: Vec<String> = r.measured.separation.iter().map(|x| format!("{:.1} %", 100.0 * x)).collect();
        let (ind, agree) = match &p.independent {
            Some(a) => (a.name.clone(), num(a.error)),
            None => ("–".into(), "–".into()),
        };
        let _ = writeln!(
            s,
            "| {} | {:?} | {:.0} | {:.0} | {} | {} | {} | {:.3} | {} | {} | {} | {} | {} |",
            p.name,
            p.fidelity,
            rad_per_s_to_rpm(p.speed),
            p.mesh_frequency,
            sep.join(", "),
            r.measured.work.steps,
            r.events_in_window,
            r.closest_event,
            num(p.self_check),
            ind,
            agree,
            num(p.drift),
            num(p.floor())
        );
    }
    let _ = writeln!(s, "\n### Time to reach E_h (ms of CPU time, median of {} runs)\n", study.plan.repeats);
    let _ = writeln!(s, "| operating point | method | observed order | 1e-3 | 1e-4 | 1e-6 |");
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for p in &study.points {
        for family in p.families() {
            let f = p.family(&family);
            let order = observed_order(&f, p.floor()).map_or("–".into(), |o| format!("{o:.2}"));
            let cells: Vec<String> = TARGETS.iter().map(|t| reach(p, &f, *t)).collect();
            let _ = writeln!(s, "| {} | {} | {} | {} |", p.name, family, order, cells.join(" | "));
        }
    }
    let _ =
        writeln!(s, "\n### Defaults: the cheapest setting with E_h ≤ {DEFAULT_TARGET:e} at every point\n");
    let _ = writeln!(s, "| family | setting | total CPU time (ms) | largest E_h | E_h per point |");
    let _ = writeln!(s, "|---|---|---|---|---|");
    for d in &study.defaults {
        let per: Vec<String> = d.errors.iter().map(|(n, e)| format!("{n} {}", num(*e))).collect();
        let worst = d.errors.iter().map(|e| e.1).fold(f64::NAN, f64::max);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            d.family,
            d.method.map_or("none meets it".into(), |m| m.label()),
            d.total_cpu_seconds.map_or("–".into(), |t| format!("{:.1}", t * 1e3)),
            num(worst),
            per.join("; ")
        );
    }
    s
}

/// Every run as CSV (one row per operating point and setting).
pub fn study_csv(study: &Study) -> String {
    let mut s = String::from(
        "point,fidelity,speed_rpm,family,setting,error,below_floor,cpu_seconds,steps,rejected_steps,newton_iterations,rhs_evaluations,jacobian_evaluations,events_located,failure\n",
    );
    for p in &study.points {
        for r in &p.settings {
            let (e, t, w) = match (&r.error, &r.measured) {
                (Some(e), Some(m)) => (format!("{e:e}"), format!("{:e}", m.cpu_seconds), Some(m.work)),
                _ => (String::new(), String::new(), None),
            };
            let below = r.error.is_some_and(|e| e < p.floor());
            let w = w.map_or(",,,,,".into(), |w| {
                format!(
                    "{},{},{},{},{},{}",
                    w.steps,
                    w.rejected_steps,
                    w.newton_iterations,
                    w.rhs_evaluations,
                    w.jacobian_evaluations,
                    w.events_located
                )
            });
            let _ = writeln!(
                s,
                "{},{:?},{},{},{},{e},{below},{t},{w},{}",
                p.name,
                p.fidelity,
                rad_per_s_to_rpm(p.speed),
                r.method.family(),
                r.method.setting(),
                r.failure.as_deref().unwrap_or("").replace(',', ";")
            );
        }
    }
    s
}

/// The two log-log charts of one operating point: E_h against CPU time and
/// against right-hand-side evaluations; errors below the point's floor
/// are left out.
pub fn write_point_charts(p: &PointResult, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let mut files = Vec::new();
    let floor = p.floor();
    let time = |r: &SettingResult| r.measured.as_ref().map(|m| m.cpu_seconds);
    let work = |r: &SettingResult| r.measured.as_ref().map(|m| m.work.rhs_evaluations as f64);
    for (stem, x_of) in
        [("error_vs_time", &time as &dyn Fn(&SettingResult) -> Option<f64>), ("error_vs_work", &work)]
    {
        let mut series = Vec::new();
        for family in p.families() {
            let mut pts: Vec<(f64, f64)> = p
                .family(&family)
                .into_iter()
                .filter_map(|r| Some((x_of(r)?, r.error?)))
                .filter(|(x, e)| *x > 0.0 && *e >= floor && e.is_finite())
                .map(|(x, e)| (x.log10(), e.log10()))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            if pts.is_empty() {
                continue;
            }
            let (x, y) = pts.into_iter().unzip();
            series.push(Series::new(family, x, y).with_style(SeriesStyle::LineAndPoints));
        }
        if series.is_empty() {
            continue;
        }
        let unit =
            if stem == "error_vs_time" { "log₁₀ CPU time [s]" } else { "log₁₀ RHS evaluations" };
        files.extend(write_chart(
            &Chart {
                title: format!("{}, {:.0} rpm", p.name.replace('_', " "), rad_per_s_to_rpm(p.speed)),
                x_label: unit.into(),
                y_label: format!("log₁₀ E_h (below {floor:.0e} not shown)"),
                series,
                vlines: vec![],
            },
            &dir.join(format!("{}_{stem}", p.name)),
        )?);
    }
    Ok(files)
}

/// Writes the study: charts per point, `work_precision.csv`,
/// `work_precision_tables.md` and `work_precision.json` (with `context`,
/// e.g. the machine and the command, added at the top). Returns the files.
pub fn write_study(
    study: &Study,
    dir: &Path,
    context: serde_json::Value,
) -> Result<Vec<PathBuf>, StudyError> {
    let mut files = Vec::new();
    for p in &study.points {
        files.extend(write_point_charts(p, dir)?);
    }
    let csv = dir.join("work_precision.csv");
    write_atomic(&csv, study_csv(study).as_bytes())?;
    files.push(csv);
    let md = dir.join("work_precision_tables.md");
    write_atomic(&md, tables_markdown(study).as_bytes())?;
    files.push(md);
    let json = dir.join("work_precision.json");
    let doc = serde_json::json!({ "context": context, "study": study });
    write_atomic(&json, serde_json::to_string_pretty(&doc)?.as_bytes())?;
    files.push(json);
    Ok(files)
}

/// The machine in one line: CPU model, logical cores, OS and architecture.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{cpu}, {cores} logical cores, {} {}", std::env::consts::OS, std::env::consts::ARCH)
}
