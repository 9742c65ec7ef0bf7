//! Reports of speed sweeps and single steady states: CSV tables, plots, and
//! the identification of resonance peaks with the mode family each mesh
//! harmonic can excite (Parker & Lin 2004, docs/FORMULAS.md).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

pub use crate::analysis::study::peaks::{excited_family, find_peaks, Peak};

use super::plot::{write_chart, Chart, PlotError, Series, SeriesStyle};
use super::write_atomic;
use crate::analysis::modes::{Mode, ModeClass};
use crate::dynamics::response::{Direction, SteadyState, Sweep};
use crate::dynamics::spectrum::order_spectrum;
use crate::model::gear::{GearSet, MeshKind};
use crate::scene::units::rad_per_s_to_rpm;

fn mesh_label(m: MeshKind) -> &'static str {
    match m {
        MeshKind::SunPlanet => "sun",
        MeshKind::RingPlanet => "ring",
    }
}

/// The CSV table of a sweep: one row per speed; forces in N/mm.
pub fn sweep_csv(sweep: &Sweep, width_mm: f64) -> String {
    let mut s = String::from("direction,speed_rpm,mesh_frequency_hz,steps,newton_iterations,rhs_evaluations");
    if let Some(first) = sweep.points.first() {
        for m in &first.meshes {
            // Planets numbered from 1, as the FMU's planet[1]… (docs/FMU.md).
            let p = format!("p{}_{}", m.planet + 1, mesh_label(m.mesh));
            let _ = write!(s, ",{p}_mean_n_per_mm");
            for i in 1..=6 {
                let _ = write!(s, ",{p}_f{i}_n_per_mm");
            }
            let _ = write!(s, ",{p}_rms_n_per_mm,{p}_separation,{p}_max_n_per_mm");
        }
    }
    s.push('\n');
    for pt in &sweep.points {
        let dir = match sweep.direction {
            Direction::Up => "up",
            Direction::Down => "down",
        };
        let _ = write!(
            s,
            "{dir},{},{},{},{},{}",
            rad_per_s_to_rpm(pt.input_speed),
            pt.mesh_frequency,
            pt.stats.steps,
            pt.stats.newton_iterations,
            pt.stats.rhs_evaluations
        );
        for m in &pt.meshes {
            let h = &m.harmonics;
            let _ = write!(s, ",{}", h.mean / width_mm);
            for a in &h.amplitude {
                let _ = write!(s, ",{}", a / width_mm);
            }
            let _ = write!(s, ",{},{},{}", h.rms / width_mm, m.separation, m.max_force / width_mm);
        }
        s.push('\n');
    }
    s
}

/// Writes a CSV table atomically.
pub fn write_csv(path: &Path, text: &str) -> Result<(), PlotError> {
    write_atomic(path, text.as_bytes())
}

/// Forced-response charts (F^(rms) vs speed) of the sun–planet and
/// ring–planet meshes of planet 1 for every sweep, with separated points
/// marked and the speeds where a harmonic meets a natural frequency of the
/// family it excites drawn as vertical lines.
pub fn write_forced_response(
    sweeps: &[Sweep],
    set: &GearSet,
    modes: &[Mode],
    dir: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    let width_mm = set.sun().face_width * 1e3;
    let mut files = Vec::new();
    let Some(first) = sweeps.iter().find(|s| !s.points.is_empty()) else { return Ok(files) };
    let (lo, hi) = first.points.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), p| {
        (lo.min(rad_per_s_to_rpm(p.input_speed)), hi.max(rad_per_s_to_rpm(p.input_speed)))
    });
    let fm_per_rpm = first.points[0].mesh_frequency / rad_per_s_to_rpm(first.points[0].input_speed);
    let mut vlines = Vec::new();
    for l in 1..=3u32 {
        let family = excited_family(l, set.sun().teeth, set.planet_angles().len());
        for m in modes.iter().filter(|m| m.class == family) {
            let rpm = m.frequency / (f64::from(l) * fm_per_rpm);
            if rpm >= lo && rpm <= hi && !vlines.iter().any(|(x, _): &(f64, String)| (x - rpm).abs() < 1e-6) {
                let name = match family {
                    ModeClass::Rotational => "rotational",
                    ModeClass::Translational => "translational",
                    _ => "planet",
                };
                vlines.push((rpm, format!("{l}×f_m = {:.0} Hz ({name})", m.frequency)));
            }
        }
    }
    for (mesh_index, name) in [(0usize, "sun_planet"), (1usize, "ring_planet")] {
        let mut series = Vec::new();
        for sw in sweeps.iter().filter(|s| !s.points.is_empty()) {
            let label = match sw.direction {
                Direction::Up => "sweep up",
                Direction::Down => "sweep down",
            };
            let x: Vec<f64> = sw.points.iter().map(|p| rad_per_s_to_rpm(p.input_speed)).collect();
            let y: Vec<f64> =
                sw.points.iter().map(|p| p.meshes[mesh_index].harmonics.rms / width_mm).collect();
            series.push(Series::new(label, x.clone(), y.clone()));
            let (sx, sy): (Vec<f64>, Vec<f64>) = sw
                .points
                .iter()
                .filter(|p| p.meshes[mesh_index].separation > 0.0)
                .map(|p| (rad_per_s_to_rpm(p.input_speed), p.meshes[mesh_index].harmonics.rms / width_mm))
                .unzip();
            if !sx.is_empty() {
                series.push(
                    Series::new(format!("{label}: tooth separation"), sx, sy).with_style(SeriesStyle::Points),
                );
            }
        }
        files.extend(write_chart(
            &Chart {
                title: format!("{name} F(rms), planet 1 (f_m = {:.4} Hz per rpm)", fm_per_rpm),
                x_label: "input speed (rpm)".into(),
                y_label: "F(rms) of mesh harmonics 1-6 (N/mm)".into(),
                series,
                vlines: vlines.clone(),
            },
            &dir.join(format!("forced_response_{name}")),
        )?);
    }
    Ok(files)
}

/// Time history and order spectrum charts of one steady state.
pub fn write_steady_state(ss: &SteadyState, set: &GearSet, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let width_mm = set.sun().face_width * 1e3;
    let mut files = Vec::new();
    let tag = format!("{:.0}rpm", rad_per_s_to_rpm(ss.input_speed));
    if ss.time.is_empty() {
        return Ok(files);
    }
    let t0 = ss.time[0];
    // Two mesh cycles of time history.
    let keep = (2 * ss.time.len() / ss.cycles.max(1)).min(ss.time.len());
    let cycles: Vec<f64> = ss.time[..keep].iter().map(|t| (t - t0) * ss.mesh_frequency).collect();
    let mut series = Vec::new();
    for (i, m) in ss.meshes.iter().enumerate().filter(|(_, m)| m.planet == 0) {
        series.push(Series::new(
            format!("planet 1 {}", mesh_label(m.mesh)),
            cycles.clone(),
            ss.mesh_force[i][..keep].iter().map(|f| f / width_mm).collect(),
        ));
    }
    files.extend(write_chart(
        &Chart {
            title: format!("mesh force at {:.0} rpm", rad_per_s_to_rpm(ss.input_speed)),
            x_label: "time (mesh cycles)".into(),
            y_label: "mesh force (N/mm)".into(),
            series,
            vlines: vec![],
        },
        &dir.join(format!("time_history_{tag}")),
    )?);
    let mut series = Vec::new();
    for (i, m) in ss.meshes.iter().enumerate().filter(|(_, m)| m.planet == 0) {
        if let Ok(spec) = order_spectrum(&ss.mesh_force[i], ss.cycles, 8.0) {
            let (x, y): (Vec<f64>, Vec<f64>) = spec.into_iter().map(|(o, a)| (o, a / width_mm)).unzip();
            series.push(Series::new(format!("planet 1 {}", mesh_label(m.mesh)), x, y));
        }
    }
    if !series.is_empty() {
        files.extend(write_chart(
            &Chart {
                title: format!("order spectrum at {:.0} rpm", rad_per_s_to_rpm(ss.input_speed)),
                x_label: "order of the mesh frequency".into(),
                y_label: "amplitude (N/mm)".into(),
                series,
                vlines: vec![],
            },
            &dir.join(format!("order_spectrum_{tag}")),
        )?);
    }
    Ok(files)
}
