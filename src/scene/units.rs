//! The one conversion between the speed unit users write and read (rpm: scene
//! files, command-line flags, reports, file formats) and the core's (rad/s).
//! Every edge converts through this pair; nothing else multiplies by π/30.
//!
//! rpm → rad/s is the product rpm · π / 30. Its inverse would round in the
//! last bit (2000 rpm would come back as 1999.9999999999998 for some
//! speeds), so [`rad_per_s_to_rpm`] returns, among the few numbers next to
//! ω · 30 / π that convert to exactly ω, the one with the shortest decimal
//! form: a speed written with up to 15 significant digits (every speed a
//! user types, every grid point of a sweep) comes back exactly as written,
//! and a speed stored in rad/s is shown, and written to files, in the rpm it
//! was given in. The [`rpm`] module does that for serde: a field held in
//! rad/s that a file writes and reads in rpm.

use std::f64::consts::PI;

/// An angular speed in revolutions per minute as radians per second:
/// rpm · π / 30.
#[inline]
pub fn rpm_to_rad_per_s(rpm: f64) -> f64 {
    rpm * PI / 30.0
}

/// An angular speed in radians per second as revolutions per minute: the
/// number with the shortest decimal form among those within four units in
/// the last place of ω · 30 / π that [`rpm_to_rad_per_s`] maps to exactly
/// ω (the nearest of them on a tie; ω · 30 / π itself when none does).
pub fn rad_per_s_to_rpm(omega: f64) -> f64 {
    let guess = omega * 30.0 / PI;
    if !guess.is_finite() || guess == 0.0 {
        return guess;
    }
    // Both conversions are odd functions, so search on the magnitude.
    let (target, bits) = (omega.abs(), guess.abs().to_bits());
    let mut best: Option<(usize, f64)> = None;
    // Nearest first: 0, +1, −1, +2, −2, … units in the last place.
    for k in 0..=8_u64 {
        let offset = k.div_ceil(2);
        let candidate_bits = if k % 2 == 1 { bits.checked_add(offset) } else { bits.checked_sub(offset) };
        let Some(candidate) = candidate_bits.map(f64::from_bits) else { continue };
        if !candidate.is_finite() || rpm_to_rad_per_s(candidate) != target {
            continue;
        }
        let digits = format!("{candidate:e}").len();
        if best.is_none_or(|(d, _)| digits < d) {
            best = Some((digits, candidate));
        }
    }
    best.map_or(guess, |(_, rpm)| rpm.copysign(omega))
}

/// Serde for a speed held in rad/s and written in rpm
/// (`#[serde(with = "crate::scene::units::rpm")]`, with the field renamed to
/// its file name): the file keeps its unit and its numbers, the struct is
/// SI.
pub mod rpm {
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the speed `omega` [rad/s] in rpm.
    pub fn serialize<S: Serializer>(omega: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(super::rad_per_s_to_rpm(*omega))
    }

    /// Reads a speed written in rpm as rad/s.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        f64::deserialize(d).map(super::rpm_to_rad_per_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_revolution_per_minute_is_two_pi_per_sixty_seconds() {
        assert!((rpm_to_rad_per_s(1.0) - 2.0 * PI / 60.0).abs() < 1e-16);
        assert!((rpm_to_rad_per_s(3000.0) - 100.0 * PI).abs() < 1e-12);
        assert!((rad_per_s_to_rpm(2.0 * PI) - 60.0).abs() < 1e-12);
    }

    #[test]
    fn a_speed_written_in_rpm_comes_back_exactly() {
        for r in 0..200_000 {
            let rpm = f64::from(r);
            assert_eq!(rad_per_s_to_rpm(rpm_to_rad_per_s(rpm)), rpm);
            assert_eq!(rad_per_s_to_rpm(rpm_to_rad_per_s(-rpm)), -rpm);
            let tenths = rpm / 10.0;
            assert_eq!(rad_per_s_to_rpm(rpm_to_rad_per_s(tenths)), tenths);
        }
        for rpm in [0.3, 2.5e-7, 1.0e6, 12_345.678_901, 1.234_567_89, 1e-300, 1e300] {
            assert_eq!(rad_per_s_to_rpm(rpm_to_rad_per_s(rpm)), rpm, "{rpm}");
        }
        // A speed in rad/s converts to an rpm that converts back to it.
        for omega in [1.0, 314.159_265, 1_047.197_551, 0.1, 7.0e4] {
            assert_eq!(rpm_to_rad_per_s(rad_per_s_to_rpm(omega)), omega, "{omega}");
        }
    }

    #[test]
    fn the_serde_helper_keeps_the_file_in_rpm() {
        #[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
        struct Doc {
            #[serde(rename = "speed_rpm", with = "rpm")]
            speed: f64,
        }
        let doc: Doc = serde_json::from_str(r#"{"speed_rpm": 3000.0}"#).unwrap();
        assert_eq!(doc.speed, rpm_to_rad_per_s(3000.0));
        assert_eq!(serde_json::to_string(&doc).unwrap(), r#"{"speed_rpm":3000.0}"#);
    }

    #[test]
    fn the_round_trip_agrees_to_rounding_both_ways() {
        for x in [-1.0e6, -3000.0, -1.0, 0.0, 1e-9, 0.3, 5.0, 2000.0, 5500.0, 9000.0, 12_345.678, 1.0e6] {
            let back = rad_per_s_to_rpm(rpm_to_rad_per_s(x));
            assert!((back - x).abs() <= 4.0 * f64::EPSILON * x.abs(), "{x} rpm came back as {back}");
            let back = rpm_to_rad_per_s(rad_per_s_to_rpm(x));
            assert!((back - x).abs() <= 4.0 * f64::EPSILON * x.abs(), "{x} rad/s came back as {back}");
        }
        assert_eq!(rpm_to_rad_per_s(0.0), 0.0);
        assert!(rpm_to_rad_per_s(f64::NAN).is_nan() && rad_per_s_to_rpm(f64::INFINITY).is_infinite());
    }
}
