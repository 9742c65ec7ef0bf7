//! The one conversion between the speed unit users write and read (rpm: scene
//! files, command-line flags, reports, file formats) and the core's (rad/s).
//! Every edge converts through this pair; nothing else multiplies by π/30.
//!
//! A value converted to rad/s and back may differ from the one given in its
//! last bit, so an edge that shows a speed the user gave (a sweep's grid
//! point, a recorded operating point) shows the given value, not the round
//! trip.

use std::f64::consts::PI;

/// An angular speed in revolutions per minute as radians per second:
/// rpm · π / 30.
#[inline]
pub fn rpm_to_rad_per_s(rpm: f64) -> f64 {
    rpm * PI / 30.0
}

/// An angular speed in radians per second as revolutions per minute:
/// ω · 30 / π.
#[inline]
pub fn rad_per_s_to_rpm(omega: f64) -> f64 {
    omega * 30.0 / PI
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
