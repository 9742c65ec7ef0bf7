//! The wear run's report: a summary document (JSON, engineering units) of
//! the worn-profile states κ = 0..N and the plots of wear depth against roll
//! angle for the sun and the planet at every κ.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::plot::{write_chart, Chart, PlotError, Series};
use crate::geometry::profile::ProfileDeviation;
use crate::model::gear::{GearSet, MeshKind};
use crate::wear::state::WornState;

const DEG: f64 = 180.0 / std::f64::consts::PI;

/// The deviation of a flank averaged over the face slices (they share one
/// roll grid).
fn mean_over_slices(slices: &[ProfileDeviation]) -> (Vec<f64>, Vec<f64>) {
    let Some(first) = slices.first() else { return (Vec::new(), Vec::new()) };
    let n = slices.len() as f64;
    let depth = (0..first.depth.len()).map(|i| slices.iter().map(|s| s.depth[i]).sum::<f64>() / n).collect();
    (first.roll.clone(), depth)
}

fn flank_summary(slices: &[ProfileDeviation]) -> Value {
    let (roll, depth) = mean_over_slices(slices);
    let (imax, dmax) =
        depth.iter().enumerate().fold((0, 0.0f64), |m, (i, d)| if *d > m.1 { (i, *d) } else { m });
    json!({
        "roll_deg": roll.iter().map(|r| r * DEG).collect::<Vec<_>>(),
        "depth_um": depth.iter().map(|d| d * 1e6).collect::<Vec<_>>(),
        "max_um": dmax * 1e6,
        "max_roll_deg": roll.get(imax).map_or(0.0, |r| r * DEG),
    })
}

/// The summary document of states κ = 0..N of one gear set (engineering
/// units: µm, degrees of roll angle, cycles and revolutions).
pub fn summary(set: &GearSet, states: &[WornState], seconds: &[f64]) -> Value {
    let pitch = set.operating_pressure_angle(MeshKind::SunPlanet).tan() * DEG;
    let rows: Vec<Value> = states
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let last = s.history.last().filter(|h| h.kappa == s.kappa);
            json!({
                "kappa": s.kappa,
                "cycles_sun": last.map_or(0.0, |h| h.cycles.sun),
                "cycles_planet": last.map_or(0.0, |h| h.cycles.planet),
                "cycles_ring": last.map_or(0.0, |h| h.cycles.ring),
                "input_revolutions": last.map_or(0.0, |h| h.revolutions),
                "cumulative_input_revolutions": s.revolutions,
                "limiting_flank": last.map(|h| h.limiting_flank),
                "seconds": seconds.get(i).copied().unwrap_or(0.0),
                "flanks": {
                    "sun": flank_summary(&s.flanks.sun_drive),
                    "planet": flank_summary(&s.flanks.planet_sun_side),
                    "planet_ring_side": flank_summary(&s.flanks.planet_ring_side),
                    "ring": flank_summary(&s.flanks.ring_drive),
                },
            })
        })
        .collect();
    json!({
        "scene": set.name(),
        "pitch_roll_deg": { "sun": pitch, "planet": pitch },
        "states": rows,
    })
}

/// Picks one flank's deviations (per face slice) out of a state.
type FlankOf = fn(&WornState) -> &Vec<ProfileDeviation>;

/// Plots of wear depth against roll angle, one series per κ, for the sun's
/// drive flank and the planet's sun-side flank (and the ring-side flanks when
/// they wore); returns the files written.
pub fn write_plots(set: &GearSet, states: &[WornState], dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let pitch = set.operating_pressure_angle(MeshKind::SunPlanet).tan() * DEG;
    let mut files = Vec::new();
    let charts: [(&str, &str, FlankOf); 4] = [
        ("sun", "sun drive flank (meets the planet)", |s| &s.flanks.sun_drive),
        ("planet", "planet flank meeting the sun", |s| &s.flanks.planet_sun_side),
        ("planet_ring_side", "planet flank meeting the ring", |s| &s.flanks.planet_ring_side),
        ("ring", "ring drive flank", |s| &s.flanks.ring_drive),
    ];
    for (stem, title, flank) in charts {
        let worn = states.iter().any(|s| flank(s).iter().any(|d| !d.is_zero()));
        if !worn && (stem == "planet_ring_side" || stem == "ring") {
            continue;
        }
        let series = states
            .iter()
            .map(|s| {
                let (roll, depth) = mean_over_slices(flank(s));
                Series::new(
                    format!("κ = {}", s.kappa),
                    roll.iter().map(|r| r * DEG).collect(),
                    depth.iter().map(|d| d * 1e6).collect(),
                )
            })
            .filter(|s| !s.x.is_empty())
            .collect();
        let vlines =
            if stem == "sun" || stem == "planet" { vec![(pitch, "pitch point".into())] } else { vec![] };
        files.extend(write_chart(
            &Chart {
                title: format!("{}: wear depth of the {title}", set.name()),
                x_label: "roll angle (deg)".into(),
                y_label: "wear depth (µm)".into(),
                series,
                vlines,
            },
            &dir.join(format!("wear_{stem}")),
        )?);
    }
    Ok(files)
}
