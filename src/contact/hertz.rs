//! Hertzian line contact of two cylinders (docs/FORMULAS.md): load per length
//! w = F/L; 1/E* = (1−ν1²)/E1 + (1−ν2²)/E2; 1/R' = 1/ρ1 ± 1/ρ2 (minus for a
//! concave flank); half-width b = sqrt(4 w R' / (π E*)); peak pressure
//! p0 = 2w/(π b); p(x) = p0 sqrt(1 − x²/b²).

use serde::{Deserialize, Serialize};

/// Result of a Hertzian line contact.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LineContact {
    /// Half-width of the contact band \[m\].
    pub half_width: f64,
    /// Peak pressure \[Pa\].
    pub peak_pressure: f64,
}

/// Contact modulus E* of two materials \[Pa\].
pub fn contact_modulus(e1: f64, nu1: f64, e2: f64, nu2: f64) -> f64 {
    1.0 / ((1.0 - nu1 * nu1) / e1 + (1.0 - nu2 * nu2) / e2)
}

/// Line contact under load per length `w` [N/m] between curvature radii
/// `rho1`, `rho2` \[m\] (`concave2` for an internal flank), contact modulus
/// `e_star` \[Pa\]. Zero load gives a zero band.
pub fn line_contact(w: f64, rho1: f64, rho2: f64, concave2: bool, e_star: f64) -> LineContact {
    let curvature = 1.0 / rho1 + if concave2 { -1.0 / rho2 } else { 1.0 / rho2 };
    if w <= 0.0 || curvature <= 0.0 {
        return LineContact { half_width: 0.0, peak_pressure: 0.0 };
    }
    let r = 1.0 / curvature;
    let b = (4.0 * w * r / (std::f64::consts::PI * e_star)).sqrt();
    LineContact { half_width: b, peak_pressure: 2.0 * w / (std::f64::consts::PI * b) }
}

/// Pressure \[Pa\] at distance `x` \[m\] from the band's centre.
pub fn pressure_at(contact: &LineContact, x: f64) -> f64 {
    if contact.half_width == 0.0 || x.abs() >= contact.half_width {
        0.0
    } else {
        contact.peak_pressure * (1.0 - (x / contact.half_width).powi(2)).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integral_of_the_pressure_is_the_load() {
        let e = contact_modulus(207e9, 0.3, 207e9, 0.3);
        let c = line_contact(263_000.0, 8e-3, 6e-3, false, e);
        let n = 20_000;
        let h = 2.0 * c.half_width / n as f64;
        let sum: f64 = (0..n).map(|i| pressure_at(&c, -c.half_width + (i as f64 + 0.5) * h) * h).sum();
        assert!((sum / 263_000.0 - 1.0).abs() < 1e-4, "{sum}");
    }
}
