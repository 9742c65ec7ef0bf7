//! Involute functions of spur gearing.
//!
//! A flank point at radius `r` on an involute of base radius `r_b` has the
//! pressure angle `α_r = acos(r_b / r)` and the roll angle
//! `ξ = sqrt(r² − r_b²) / r_b = tan α_r` (docs/FORMULAS.md, "Line of
//! action"). Its polar angle, measured from the start of the involute on the
//! base circle, is `inv α_r = tan α_r − α_r`.

/// The involute function `inv α = tan α − α` of a pressure angle \[rad\].
pub fn inv(alpha: f64) -> f64 {
    alpha.tan() - alpha
}

/// Inverts the involute function by Newton's method: the pressure angle \[rad\]
/// whose involute is `value` (which must be non-negative).
pub fn inv_inverse(value: f64) -> f64 {
    // Start from the cubic expansion inv α ≈ α³/3, which is close for small α
    // and converges monotonically for larger ones.
    let mut alpha = (3.0 * value.max(0.0)).cbrt().min(1.4);
    for _ in 0..60 {
        let f = inv(alpha) - value;
        let df = alpha.tan().powi(2);
        if df <= 0.0 {
            break;
        }
        let step = f / df;
        alpha -= step;
        if step.abs() < 1e-15 {
            break;
        }
    }
    alpha
}

/// Roll angle \[rad\] of the flank point at radius `r` \[m\] of an involute with
/// base radius `r_b` \[m\]; zero inside the base circle.
pub fn roll_angle(r: f64, r_b: f64) -> f64 {
    if r <= r_b {
        0.0
    } else {
        (r * r - r_b * r_b).sqrt() / r_b
    }
}

/// Radius \[m\] of the involute point with roll angle `xi` \[rad\].
pub fn radius_at_roll(xi: f64, r_b: f64) -> f64 {
    r_b * (1.0 + xi * xi).sqrt()
}

/// Pressure angle \[rad\] of the involute at radius `r` \[m\] (zero inside the
/// base circle).
pub fn pressure_angle_at(r: f64, r_b: f64) -> f64 {
    if r <= r_b {
        0.0
    } else {
        (r_b / r).acos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_of_involute_round_trips() {
        for deg in [1.0_f64, 10.0, 20.0, 21.3, 35.0, 60.0] {
            let a = deg.to_radians();
            assert!((inv_inverse(inv(a)) - a).abs() < 1e-12, "{deg}");
        }
    }

    #[test]
    fn roll_angle_is_tangent_of_pressure_angle() {
        let r_b = 0.023758;
        let r = 0.0255;
        assert!((roll_angle(r, r_b) - pressure_angle_at(r, r_b).tan()).abs() < 1e-12);
        assert!((radius_at_roll(roll_angle(r, r_b), r_b) - r).abs() < 1e-15);
    }
}
