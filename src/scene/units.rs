//! The one conversion between the units users write and read (scene files,
//! command-line flags, reports, file formats: mm, degrees, GPa, rpm) and the
//! SI units the scene and the core hold (m, rad, Pa, rad/s). Every scene
//! field, and every speed at an edge, converts through a [`FileUnit`].
//!
//! A file unit's value x is x · f in SI (f = 10⁻³ for mm, π/180 for
//! degrees, 10⁹ for GPa, π/30 for rpm). The inverse would round in the last
//! bit (2000 rpm would come back as 1999.9999999999998 for some speeds), so
//! [`FileUnit::from_si`] returns, among the few numbers next to the SI value
//! divided by f that convert to exactly that SI value, the one with the
//! shortest decimal form: a number written with up to 15 significant digits
//! (every value a user types, every grid point of a sweep) comes back
//! exactly as written, and a value held in SI is shown, and written to
//! files, in the unit it was given in. An SI value that no number of the
//! file unit converts to exactly (one set in SI, by the FMU) is written as
//! SI / f, which reads back within a unit or two in the last place.
//!
//! The serde modules [`mm`], [`deg`], [`gpa`] and [`rpm`] do that for a
//! field held in SI that a file writes and reads in the file unit
//! (`#[serde(rename = "module_mm", with = "crate::scene::units::mm")]`),
//! for a number, an optional number or a list of numbers.

use std::f64::consts::PI;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A unit a file writes a quantity in: how its numbers convert to the SI
/// unit the scene holds, and back.
#[derive(Clone, Copy, Debug)]
pub struct FileUnit {
    /// The unit's name, as in the file's keys.
    pub name: &'static str,
    /// The file's number in SI (x · f).
    to_si: fn(f64) -> f64,
    /// The SI value divided by f, the start of the search for the inverse.
    from_si_nearly: fn(f64) -> f64,
}

/// Millimetres (SI: metres).
pub const MM: FileUnit = FileUnit { name: "mm", to_si: |x| x * 1e-3, from_si_nearly: |x| x * 1e3 };
/// Degrees (SI: radians).
pub const DEG: FileUnit = FileUnit { name: "deg", to_si: f64::to_radians, from_si_nearly: f64::to_degrees };
/// Gigapascals (SI: pascals).
pub const GPA: FileUnit = FileUnit { name: "gpa", to_si: |x| x * 1e9, from_si_nearly: |x| x * 1e-9 };
/// Revolutions per minute (SI: radians per second).
pub const RPM: FileUnit =
    FileUnit { name: "rpm", to_si: |x| x * PI / 30.0, from_si_nearly: |x| x * 30.0 / PI };

impl FileUnit {
    /// A number of this unit in SI.
    #[inline]
    pub fn to_si(self, x: f64) -> f64 {
        (self.to_si)(x)
    }

    /// An SI value as a number of this unit: the number with the shortest
    /// decimal form among those within four units in the last place of
    /// `si` / f that [`FileUnit::to_si`] maps to exactly `si` (the nearest
    /// of them on a tie; `si` / f itself when none does).
    pub fn from_si(self, si: f64) -> f64 {
        let guess = (self.from_si_nearly)(si);
        if !guess.is_finite() || guess == 0.0 {
            return guess;
        }
        // Every conversion is an odd function, so search on the magnitude.
        let (target, bits) = (si.abs(), guess.abs().to_bits());
        let mut best: Option<(usize, f64)> = None;
        // Nearest first: 0, +1, −1, +2, −2, … units in the last place.
        for k in 0..=8_u64 {
            let offset = k.div_ceil(2);
            let candidate_bits = if k % 2 == 1 { bits.checked_add(offset) } else { bits.checked_sub(offset) };
            let Some(candidate) = candidate_bits.map(f64::from_bits) else { continue };
            if !candidate.is_finite() || self.to_si(candidate) != target {
                continue;
            }
            let digits = format!("{candidate:e}").len();
            if best.is_none_or(|(d, _)| digits < d) {
                best = Some((digits, candidate));
            }
        }
        best.map_or(guess, |(_, x)| x.copysign(si))
    }

    /// A value held in SI (a number, an optional number, a list) as the file
    /// writes it in this unit.
    pub fn written<T: Quantity>(self, value: &T) -> T {
        value.map_numbers(&|x| self.from_si(x))
    }
}

/// An angular speed in revolutions per minute as radians per second:
/// rpm · π / 30.
#[inline]
pub fn rpm_to_rad_per_s(rpm: f64) -> f64 {
    RPM.to_si(rpm)
}

/// An angular speed in radians per second as revolutions per minute
/// ([`FileUnit::from_si`] of [`RPM`]).
pub fn rad_per_s_to_rpm(omega: f64) -> f64 {
    RPM.from_si(omega)
}

/// A length in millimetres as metres.
#[inline]
pub fn mm_to_m(mm: f64) -> f64 {
    MM.to_si(mm)
}

/// A length in metres as millimetres ([`FileUnit::from_si`] of [`MM`]).
pub fn m_to_mm(m: f64) -> f64 {
    MM.from_si(m)
}

/// An angle in degrees as radians.
#[inline]
pub fn deg_to_rad(deg: f64) -> f64 {
    DEG.to_si(deg)
}

/// An angle in radians as degrees ([`FileUnit::from_si`] of [`DEG`]).
pub fn rad_to_deg(rad: f64) -> f64 {
    DEG.from_si(rad)
}

/// A modulus (pressure) in gigapascals as pascals.
#[inline]
pub fn gpa_to_pa(gpa: f64) -> f64 {
    GPA.to_si(gpa)
}

/// A modulus (pressure) in pascals as gigapascals ([`FileUnit::from_si`] of [`GPA`]).
pub fn pa_to_gpa(pa: f64) -> f64 {
    GPA.from_si(pa)
}

/// A value a file writes in a [`FileUnit`]: a number, an optional number or
/// a list of them, each number converted on its own.
pub trait Quantity: Sized {
    /// The value with every number replaced by `f` of it.
    fn map_numbers(&self, f: &dyn Fn(f64) -> f64) -> Self;
}

impl Quantity for f64 {
    fn map_numbers(&self, f: &dyn Fn(f64) -> f64) -> Self {
        f(*self)
    }
}

impl<T: Quantity> Quantity for Option<T> {
    fn map_numbers(&self, f: &dyn Fn(f64) -> f64) -> Self {
        self.as_ref().map(|v| v.map_numbers(f))
    }
}

impl<T: Quantity> Quantity for Vec<T> {
    fn map_numbers(&self, f: &dyn Fn(f64) -> f64) -> Self {
        self.iter().map(|v| v.map_numbers(f)).collect()
    }
}

/// Writes `value` (SI) in `unit`.
pub fn serialize_in<T: Quantity + Serialize, S: Serializer>(
    unit: FileUnit,
    value: &T,
    s: S,
) -> Result<S::Ok, S::Error> {
    unit.written(value).serialize(s)
}

/// Reads a value written in `unit` as SI.
pub fn deserialize_in<'de, T: Quantity + Deserialize<'de>, D: Deserializer<'de>>(
    unit: FileUnit,
    d: D,
) -> Result<T, D::Error> {
    T::deserialize(d).map(|v| v.map_numbers(&|x| unit.to_si(x)))
}

/// A serde module (`#[serde(with = …)]`) for a field held in SI and written
/// in a file unit.
macro_rules! serde_in_unit {
    ($module:ident, $unit:ident, $doc:literal) => {
        #[doc = $doc]
        pub mod $module {
            use serde::{Deserialize, Deserializer, Serialize, Serializer};

            #[doc = concat!("Writes the value (SI) in [`", stringify!($unit), "`](super::", stringify!($unit), ").")]
            pub fn serialize<T: super::Quantity + Serialize, S: Serializer>(value: &T, s: S) -> Result<S::Ok, S::Error> {
                super::serialize_in(super::$unit, value, s)
            }

            #[doc = concat!("Reads a value written in [`", stringify!($unit), "`](super::", stringify!($unit), ") as SI.")]
            pub fn deserialize<'de, T: super::Quantity + Deserialize<'de>, D: Deserializer<'de>>(d: D) -> Result<T, D::Error> {
                super::deserialize_in(super::$unit, d)
            }
        }
    };
}

serde_in_unit!(mm, MM, "Serde for a length held in metres and written in millimetres.");
serde_in_unit!(deg, DEG, "Serde for an angle held in radians and written in degrees.");
serde_in_unit!(gpa, GPA, "Serde for a modulus held in pascals and written in gigapascals.");
serde_in_unit!(rpm, RPM, "Serde for a speed held in rad/s and written in rpm.");

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

    #[test]
    fn lengths_angles_and_moduli_written_in_file_units_come_back_exactly() {
        for unit in [MM, DEG, GPA] {
            for i in 0..100_000 {
                for x in [f64::from(i), f64::from(i) / 10.0, f64::from(i) / 1000.0, f64::from(i) * 0.37] {
                    let x: f64 = format!("{x:.12e}").parse().unwrap();
                    assert_eq!(unit.from_si(unit.to_si(x)), x, "{} {x}", unit.name);
                    assert_eq!(unit.from_si(unit.to_si(-x)), -x, "{} {x}", unit.name);
                }
            }
            for x in [
                0.05,
                0.25,
                2.5,
                20.0,
                207.0,
                22.5,
                27.87,
                53.225,
                60.45,
                1e-300,
                1e200,
                123_456_789_012_345.0,
            ] {
                assert_eq!(unit.from_si(unit.to_si(x)), x, "{} {x}", unit.name);
            }
        }
        assert_eq!(mm_to_m(39.0), 39.0 * 1e-3);
        assert_eq!(deg_to_rad(20.0), 20.0_f64.to_radians());
        assert_eq!(gpa_to_pa(207.0), 207.0 * 1e9);
        assert_eq!((m_to_mm(0.0025), rad_to_deg(PI / 4.0), pa_to_gpa(2.07e11)), (2.5, 45.0, 207.0));
    }

    #[test]
    fn an_si_value_converts_to_a_file_number_that_converts_back_to_it() {
        for unit in [MM, DEG, GPA, RPM] {
            for si in [1.0, 0.0025, 0.349_065_850_398_865_9, 2.07e11, 314.159_265, 7.0e-5] {
                assert_eq!(unit.to_si(unit.from_si(si)), si, "{} {si}", unit.name);
            }
        }
    }

    #[test]
    fn the_serde_helpers_keep_the_file_in_its_units() {
        #[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
        struct Doc {
            #[serde(rename = "module_mm", with = "mm")]
            module: f64,
            #[serde(rename = "angles_deg", default, with = "deg", skip_serializing_if = "Option::is_none")]
            angles: Option<Vec<f64>>,
            #[serde(
                rename = "tip_diameter_mm",
                default,
                with = "mm",
                skip_serializing_if = "Option::is_none"
            )]
            tip_diameter: Option<f64>,
            #[serde(rename = "youngs_modulus_gpa", with = "gpa")]
            youngs_modulus: f64,
        }
        let text = r#"{"module_mm":2.5,"angles_deg":[0.0,91.0,180.0],"youngs_modulus_gpa":207.0}"#;
        let doc: Doc = serde_json::from_str(text).unwrap();
        assert_eq!(doc.module, 2.5 * 1e-3);
        assert_eq!(doc.angles, Some(vec![0.0, 91.0_f64.to_radians(), PI]));
        assert_eq!((doc.tip_diameter, doc.youngs_modulus), (None, 207.0e9));
        assert_eq!(serde_json::to_string(&doc).unwrap(), text);
    }

    proptest::proptest! {
        /// Any number with up to 15 significant digits, of any magnitude a
        /// scene holds, comes back as written from each file unit.
        #[test]
        fn any_number_of_fifteen_digits_comes_back_as_written(
            mantissa in 1_u64..1_000_000_000_000_000,
            exponent in -40_i32..40,
            negative in proptest::bool::ANY,
        ) {
            let x: f64 = format!("{}{mantissa}e{exponent}", if negative { "-" } else { "" }).parse().unwrap();
            for unit in [MM, DEG, GPA, RPM] {
                proptest::prop_assert_eq!(unit.from_si(unit.to_si(x)), x, "{}", unit.name);
            }
        }
    }
}
