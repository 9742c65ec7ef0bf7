//! The planets' layout: their number and angles, the assembly condition,
//! and the clearance between neighbouring planets.

use std::f64::consts::PI;

use super::{Checker, PLANET_TIP_GAP_FACTOR};
use crate::model::gear::GearSet;
use crate::scene::units::DEG;
use crate::scene::PlanetLayoutSpec;

impl Checker {
    /// The planet angles \[rad\]: equally spaced, or as listed (one per
    /// planet, finite); empty when the count or the angles are refused.
    pub(super) fn planet_angles(&mut self, planets: &PlanetLayoutSpec) -> Vec<f64> {
        let count = planets.count;
        if !(1..=32).contains(&count) {
            self.fail("planets.count", count, "must be between 1 and 32");
            return Vec::new();
        }
        let mut angles: Vec<f64> = match &planets.angles {
            None => (0..count).map(|i| 2.0 * PI * f64::from(i) / f64::from(count)).collect(),
            Some(list) => {
                if list.len() != count as usize {
                    self.fail(
                        "planets.angles_deg",
                        format!("{:?}", DEG.written(list)),
                        format!("must list exactly planets.count = {count} angles"),
                    );
                }
                list.clone()
            }
        };
        if angles.iter().any(|a| !a.is_finite()) {
            self.fail(
                "planets.angles_deg",
                format!("{:?}", DEG.written(&planets.angles)),
                "must be finite numbers",
            );
            angles.clear();
        }
        angles
    }

    /// Assembly: planet n at ψ_n fits when (Z_s + Z_r)·ψ_n / 2π is an integer;
    /// for equally spaced planets, when (Z_s + Z_r)/N is.
    pub(super) fn assembly(&mut self, set: &GearSet, planets: &PlanetLayoutSpec) {
        let zsum = f64::from(set.sun.teeth + set.ring.teeth);
        let n_planets = set.planet_angles.len();
        let equally_spaced = planets.angles.is_none() && n_planets > 0;
        if equally_spaced && (set.sun.teeth + set.ring.teeth) % n_planets as u32 != 0 {
            self.fail(
                "planets.count",
                n_planets,
                format!(
                    "equally spaced planets can be assembled only when (Z_sun + Z_ring)/N is an integer: \
                     ({} + {})/{n_planets} = {:.4}",
                    set.sun.teeth,
                    set.ring.teeth,
                    zsum / n_planets as f64
                ),
            );
        }
        for (i, psi) in set.planet_angles.iter().enumerate().filter(|_| !equally_spaced) {
            let k = zsum * psi / (2.0 * PI);
            if (k - k.round()).abs() > 1e-6 {
                self.fail(
                    &format!("planets.angles_deg[{i}]"),
                    format!("{:.6}", psi.to_degrees()),
                    format!(
                        "planets can only be assembled at multiples of 360°/(Z_sun + Z_ring) = {:.6}°: (Z_sun + Z_ring)·ψ/360° = {k:.6} is not an integer",
                        360.0 / zsum
                    ),
                );
            }
        }
    }

    /// Neighbouring planets must not touch: their centres' chord exceeds
    /// the tip diameter and a gap of [`PLANET_TIP_GAP_FACTOR`]·m. The first
    /// pair that collides is named.
    pub(super) fn planet_clearance(&mut self, set: &GearSet, planets: &PlanetLayoutSpec) {
        let mut sorted = set.planet_angles.clone();
        sorted.sort_by(f64::total_cmp);
        if sorted.len() <= 1 {
            return;
        }
        for i in 0..sorted.len() {
            let next = if i + 1 < sorted.len() { sorted[i + 1] } else { sorted[0] + 2.0 * PI };
            let gap = next - sorted[i];
            let chord = 2.0 * set.centre_distance * (gap / 2.0).sin();
            let need = 2.0 * set.planet.tip_radius + PLANET_TIP_GAP_FACTOR * set.planet.module;
            if chord <= need {
                let (key, value) = if planets.angles.is_none() {
                    ("planets.count".to_string(), sorted.len().to_string())
                } else {
                    (
                        "planets.angles_deg".to_string(),
                        format!(
                            "{:.4}° and {:.4}°",
                            sorted[i].to_degrees(),
                            next.to_degrees().rem_euclid(360.0)
                        ),
                    )
                };
                self.fail(
                    &key,
                    value,
                    format!(
                        "neighbouring planets collide: centres {:.4} mm apart, their tip diameters \
                         {:.4} mm need {:.4} mm with the gap of {PLANET_TIP_GAP_FACTOR}·m between tip circles",
                        chord * 1e3,
                        2.0 * set.planet.tip_radius * 1e3,
                        need * 1e3
                    ),
                );
                break;
            }
        }
    }
}
