//! Resonance peaks of forced-response curves, each matched to the mesh
//! harmonic and natural mode that explain it, with the mode family each
//! harmonic can excite (Parker & Lin 2004, J. Mech. Des. 126:365).

use serde::Serialize;

use crate::analysis::modes::{Mode, ModeClass};
use crate::dynamics::response::{Direction, Sweep};
use crate::model::gear::{GearSet, MeshKind};

/// Mode family a mesh harmonic excites, for equally spaced planets:
/// rotational iff l·Z_s/n is an integer, translational iff (l·Z_s ± 1)/n is,
/// planet modes otherwise (Parker & Lin 2004).
pub fn excited_family(harmonic: u32, sun_teeth: u32, planets: usize) -> ModeClass {
    let n = planets as i64;
    let lz = i64::from(harmonic) * i64::from(sun_teeth);
    if lz % n == 0 {
        ModeClass::Rotational
    } else if (lz + 1) % n == 0 || (lz - 1) % n == 0 {
        ModeClass::Translational
    } else {
        ModeClass::Planet
    }
}

/// A resonance peak of a forced-response curve.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Peak {
    /// Direction of the sweep.
    pub direction: Direction,
    /// The mesh (of planet 1, the first) whose curve peaks.
    pub mesh: MeshKind,
    /// Input speed of the peak [rad/s] (written in rpm, as `speed_rpm`).
    #[serde(rename = "speed_rpm", with = "crate::scene::units::rpm")]
    pub speed: f64,
    /// Mesh frequency there \[Hz\].
    pub mesh_frequency: f64,
    /// F^(rms) at the peak [N/mm].
    pub rms_n_per_mm: f64,
    /// The harmonic l and natural frequency whose coincidence l·f_m = f_n
    /// explains it best, among the modes the phasing rule lets harmonic l excite.
    pub harmonic: u32,
    /// That natural frequency \[Hz\].
    pub natural_frequency: f64,
    /// Its mode family.
    pub family: ModeClass,
    /// Relative distance |l·f_m − f_n| / f_n.
    pub mismatch: f64,
}

/// Local maxima of a curve (strictly above both neighbours and above
/// `floor`), with the mode each is matched to.
pub fn find_peaks(
    sweep: &Sweep,
    mesh_index: usize,
    width_mm: f64,
    modes: &[Mode],
    set: &GearSet,
) -> Vec<Peak> {
    let pts = &sweep.points;
    let y: Vec<f64> = pts.iter().map(|p| p.meshes[mesh_index].harmonics.rms / width_mm).collect();
    let mut out = Vec::new();
    for i in 1..pts.len().saturating_sub(1) {
        if !(y[i] > y[i - 1] && y[i] >= y[i + 1]) {
            continue;
        }
        let fm = pts[i].mesh_frequency;
        let mut best: Option<Peak> = None;
        for l in 1..=6u32 {
            let family = excited_family(l, set.sun().teeth, set.planet_angles().len());
            for m in modes.iter().filter(|m| m.class == family) {
                let mismatch = (f64::from(l) * fm - m.frequency).abs() / m.frequency;
                if best.as_ref().is_none_or(|b| mismatch < b.mismatch) {
                    best = Some(Peak {
                        direction: sweep.direction,
                        mesh: pts[i].meshes[mesh_index].mesh,
                        speed: pts[i].input_speed,
                        mesh_frequency: fm,
                        rms_n_per_mm: y[i],
                        harmonic: l,
                        natural_frequency: m.frequency,
                        family,
                        mismatch,
                    });
                }
            }
        }
        if let Some(p) = best {
            out.push(p);
        }
    }
    out
}
