//! The 2-D outline of one tooth flank: root land, root fillet, involute
//! (carrying a profile-deviation grid), tip chamfer and tip land.
//!
//! Frame: the gear centre at the origin, the tooth centreline on the +x axis,
//! the flank on the +y side ("upper" flank). The outline runs from the middle
//! of the space at the root circle to the tooth centreline at the tip circle.
//! The lower flank is the mirror image (y → −y), with its own deviations.
//!
//! Hob fillet: the envelope of the hob tip rounding (radius ρ) of a rack whose
//! reference line rolls on the reference circle, with the rack space width on
//! the reference line equal to the gear's tooth thickness (so the generated
//! involute is exactly the gear's). Parametrised by the direction β of the
//! rounding's normal: the envelope point is where that normal passes through
//! the pitch point (Litvin, Gear Geometry and Applied Theory, §6).
//! Ring fillet: a circle of the given radius tangent to the root circle and
//! to the involute, found by bisection on its polar angle.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::model::gear::{GearKind, RootForm, ToothForm};
use crate::model::involute::radius_at_roll;

/// What part of the outline a point belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Region {
    /// Root circle between the fillet and the middle of the space.
    RootLand,
    /// Root fillet.
    Fillet,
    /// Involute, with the point's roll angle \[rad\].
    Involute(f64),
    /// Tip chamfer.
    Chamfer,
    /// Tip circle.
    TipLand,
}

/// What a deviation grid means beyond its ends (below the start of active
/// profile, toward the root; above its last point, toward the tip).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ProfileEnds {
    /// The end value continues: a worn band leaves no step where it ends.
    #[default]
    Hold,
    /// Nothing is removed beyond the grid: the surface the mating flank
    /// never touched keeps its form, leaving a step at each end of a worn band.
    Unworn,
}

impl ProfileEnds {
    /// True for the default ([`ProfileEnds::Hold`]), which files omit.
    pub fn is_hold(&self) -> bool {
        *self == ProfileEnds::Hold
    }
}

/// A profile deviation along the roll angle: material removed normal to the
/// involute (wear, tip relief) is positive \[m\]. Linear between grid points;
/// beyond the ends as `ends` says (the end value by default).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ProfileDeviation {
    /// Roll angles of the grid points, increasing \[rad\].
    pub roll: Vec<f64>,
    /// Deviation at each grid point \[m\].
    pub depth: Vec<f64>,
    /// What the deviation is beyond the grid's ends.
    #[serde(default, skip_serializing_if = "ProfileEnds::is_hold")]
    pub ends: ProfileEnds,
}

impl ProfileDeviation {
    /// No deviation.
    pub fn none() -> Self {
        Self::default()
    }

    /// A deviation grid whose end values continue beyond it.
    pub fn new(roll: Vec<f64>, depth: Vec<f64>) -> Self {
        Self { roll, depth, ends: ProfileEnds::Hold }
    }

    /// Deviation \[m\] at roll angle `xi` \[rad\].
    pub fn at(&self, xi: f64) -> f64 {
        if self.ends == ProfileEnds::Unworn {
            match (self.roll.first(), self.roll.last()) {
                (Some(lo), Some(hi)) if xi < *lo || xi > *hi => return 0.0,
                _ => {}
            }
        }
        interpolate(&self.roll, &self.depth, xi)
    }

    /// True when every grid value is zero (or there is no grid).
    pub fn is_zero(&self) -> bool {
        self.depth.iter().all(|d| *d == 0.0)
    }
}

/// Linear interpolation on an increasing grid, constant beyond its ends;
/// zero for an empty grid.
pub fn interpolate(x: &[f64], y: &[f64], at: f64) -> f64 {
    match x.len() {
        0 => 0.0,
        1 => y[0],
        n => {
            if at <= x[0] {
                return y[0];
            }
            if at >= x[n - 1] {
                return y[n - 1];
            }
            let i = x.partition_point(|v| *v <= at).clamp(1, n - 1);
            let t = (at - x[i - 1]) / (x[i] - x[i - 1]);
            y[i - 1] + t * (y[i] - y[i - 1])
        }
    }
}

/// The outline of the upper flank of one tooth, root to tip.
#[derive(Clone, Debug, PartialEq)]
pub struct FlankOutline {
    /// Points \[m\], gear frame, tooth centreline on +x.
    pub points: Vec<[f64; 2]>,
    /// Region of each point.
    pub regions: Vec<Region>,
    /// Polar angle of the point where the fillet meets the root circle \[rad\]:
    /// half the angle the tooth's root chord subtends.
    pub root_half_angle: f64,
    /// Radius where the fillet meets the involute \[m\].
    pub form_radius: f64,
    /// Roll angles \[rad\] of the ends of the involute: form circle and chamfer start.
    pub involute_roll_range: (f64, f64),
}

/// Points per region of an outline.
const INVOLUTE_POINTS: usize = 400;
const FILLET_POINTS: usize = 80;
const LAND_POINTS: usize = 12;
const CHAMFER_POINTS: usize = 24;

fn polar(r: f64, phi: f64) -> [f64; 2] {
    [r * phi.cos(), r * phi.sin()]
}

fn rotate(p: [f64; 2], angle: f64) -> [f64; 2] {
    let (s, c) = angle.sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1]]
}

/// Outward unit normal of the upper involute flank at roll angle `xi`
/// \[rad\] (pointing out of the material, into the space).
pub fn involute_normal(form: &ToothForm, xi: f64) -> [f64; 2] {
    let r = radius_at_roll(xi, form.base_radius());
    let phi = form.involute_half_angle(r);
    let alpha = xi.atan();
    match form.kind {
        // The generating line touches the base circle at φ − α_r and points
        // toward the space.
        GearKind::External => polar(1.0, phi - alpha + PI / 2.0),
        // Internal: the space lies on the +φ side; the generating line from
        // the tangency point at φ + α_r points into the tooth, so the
        // outward normal is its reverse, at φ + α_r + π/2.
        GearKind::Internal => polar(1.0, phi + alpha + PI / 2.0),
    }
}

/// Point of the upper involute at roll angle `xi` \[rad\], shifted by the
/// deviation \[m\].
pub fn involute_point(form: &ToothForm, xi: f64, dev: &ProfileDeviation) -> [f64; 2] {
    let r = radius_at_roll(xi, form.base_radius());
    let p = polar(r, form.involute_half_angle(r));
    let e = dev.at(xi);
    if e == 0.0 {
        return p;
    }
    let n = involute_normal(form, xi);
    [p[0] - e * n[0], p[1] - e * n[1]]
}

/// Hob fillet of an external gear: points from the root circle up to the
/// form point, and the polar angle of the root point.
fn hob_fillet(form: &ToothForm, rho: f64) -> (Vec<[f64; 2]>, f64) {
    let rp = form.reference_radius();
    let a = form.pressure_angle;
    let h = rp - form.root_radius;
    let vc = h - rho;
    let uc = form.tooth_thickness / 2.0 + vc * a.tan() + rho / a.cos();
    let mut pts = Vec::with_capacity(FILLET_POINTS + 1);
    for k in 0..=FILLET_POINTS {
        // Normal direction of the rounding from the tip (π/2) to the flank (π − α).
        let beta = PI / 2.0 + (PI / 2.0 - a) * k as f64 / FILLET_POINTS as f64;
        let (qu, qv) = (uc + rho * beta.cos(), vc + rho * beta.sin());
        // The normal through Q meets the reference line (v = 0) at the pitch point.
        let phi = (qv * beta.cos() / beta.sin() - qu) / rp;
        let p = rotate([rp - qv, qu + rp * phi], -phi);
        pts.push(p);
    }
    (pts, uc / rp)
}

/// The chamfer from the involute point at `start` to the tip circle, at
/// `angle` to the tip circle's tangent; returns the tip-circle end point.
fn chamfer_end(form: &ToothForm, start: [f64; 2], angle: f64) -> [f64; 2] {
    let rt = form.tip_radius;
    let phi_a = start[1].atan2(start[0]);
    let r_a = (start[0] * start[0] + start[1] * start[1]).sqrt();
    // Angle of the chamfer (from B to A) to the tip circle's tangent.
    let incline = |phi_b: f64| {
        let b = polar(rt, phi_b);
        let d = [start[0] - b[0], start[1] - b[1]];
        let radial = d[0] * phi_b.cos() + d[1] * phi_b.sin();
        let tangential = -d[0] * phi_b.sin() + d[1] * phi_b.cos();
        let inward = if rt > r_a { -radial } else { radial };
        inward.atan2(tangential)
    };
    let (mut lo, mut hi) = (0.0, phi_a);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if incline(mid) > angle {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    polar(rt, 0.5 * (lo + hi))
}

impl FlankOutline {
    /// The upper-flank outline of a tooth form with a profile deviation.
    pub fn new(form: &ToothForm, dev: &ProfileDeviation) -> Self {
        let mut points = Vec::new();
        let mut regions = Vec::new();
        let half_space = form.angular_pitch() / 2.0;

        // Root land and fillet.
        let (fillet, root_half_angle, xi_form) = match (form.kind, form.root_form) {
            (GearKind::External, RootForm::Hob { tip_radius: rho }) => {
                let (pts, phi_root) = hob_fillet(form, rho);
                let last = *pts.last().unwrap_or(&[form.root_radius, 0.0]);
                let r_form = (last[0].powi(2) + last[1].powi(2)).sqrt();
                (pts, phi_root, form.roll_at(r_form))
            }
            (_, RootForm::Fillet { radius: rho } | RootForm::Hob { tip_radius: rho }) => {
                let (phi_c, xi_t) = if form.kind == GearKind::Internal {
                    form.ring_fillet(rho)
                } else {
                    // External gear with a circular fillet: tangent to the root
                    // circle from outside (centre at r_f + ρ).
                    let r_form = form.form_radius();
                    (form.involute_half_angle(r_form) + rho / form.root_radius, form.roll_at(r_form))
                };
                // The fillet's centre lies in the space, tangent to the root
                // circle from inside it: r_f − ρ for an internal gear (where
                // `ToothForm::ring_fillet` places it), r_f + ρ for an external one.
                let sign = if form.kind == GearKind::Internal { -1.0 } else { 1.0 };
                let rc = form.root_radius + sign * rho;
                let c = polar(rc, phi_c);
                let t = polar(radius_at_roll(xi_t, form.base_radius()), {
                    let r = radius_at_roll(xi_t, form.base_radius());
                    form.involute_half_angle(r)
                });
                let root_pt = polar(form.root_radius, phi_c);
                let a0 = (root_pt[1] - c[1]).atan2(root_pt[0] - c[0]);
                let mut a1 = (t[1] - c[1]).atan2(t[0] - c[0]);
                while a1 - a0 > PI {
                    a1 -= 2.0 * PI;
                }
                while a0 - a1 > PI {
                    a1 += 2.0 * PI;
                }
                let pts = (0..=FILLET_POINTS)
                    .map(|k| {
                        let a = a0 + (a1 - a0) * k as f64 / FILLET_POINTS as f64;
                        [c[0] + rho * a.cos(), c[1] + rho * a.sin()]
                    })
                    .collect();
                (pts, phi_c, xi_t)
            }
        };
        for k in 0..LAND_POINTS {
            let phi = half_space + (root_half_angle - half_space) * k as f64 / LAND_POINTS as f64;
            points.push(polar(form.root_radius, phi));
            regions.push(Region::RootLand);
        }
        for p in fillet.iter().take(fillet.len().saturating_sub(1)) {
            points.push(*p);
            regions.push(Region::Fillet);
        }

        // Involute from the form circle to the chamfer start (or the tip).
        let xi_end = form.roll_at(form.involute_tip_radius());
        for k in 0..=INVOLUTE_POINTS {
            let xi = xi_form + (xi_end - xi_form) * k as f64 / INVOLUTE_POINTS as f64;
            points.push(involute_point(form, xi, dev));
            regions.push(Region::Involute(xi));
        }

        // Chamfer and tip land.
        let mut tip_start = *points.last().unwrap_or(&[form.tip_radius, 0.0]);
        if let Some(ch) = form.chamfer {
            let end = chamfer_end(form, tip_start, ch.angle);
            for k in 1..=CHAMFER_POINTS {
                let t = k as f64 / CHAMFER_POINTS as f64;
                points.push([
                    tip_start[0] + t * (end[0] - tip_start[0]),
                    tip_start[1] + t * (end[1] - tip_start[1]),
                ]);
                regions.push(Region::Chamfer);
            }
            tip_start = end;
        }
        let phi_tip = tip_start[1].atan2(tip_start[0]);
        for k in 1..=LAND_POINTS {
            let phi = phi_tip * (1.0 - k as f64 / LAND_POINTS as f64);
            points.push(polar(form.tip_radius, phi));
            regions.push(Region::TipLand);
        }
        let form_radius = radius_at_roll(xi_form, form.base_radius());
        Self { points, regions, root_half_angle, form_radius, involute_roll_range: (xi_form, xi_end) }
    }

    /// The same outline mirrored to the lower (−y) flank.
    pub fn mirrored(&self) -> Self {
        let mut m = self.clone();
        for p in &mut m.points {
            p[1] = -p[1];
        }
        m
    }

    /// Lateral half-thickness y of the outline at distance x along the
    /// centreline, by linear interpolation over the outline's monotone part
    /// between the root point and the tip.
    pub fn half_thickness_at(&self, x: f64) -> f64 {
        let pts = &self.points[self.root_index().saturating_sub(1)..];
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            if (a[0] - x) * (b[0] - x) <= 0.0 && a[0] != b[0] {
                let t = (x - a[0]) / (b[0] - a[0]);
                return a[1] + t * (b[1] - a[1]);
            }
        }
        0.0
    }

    /// Index of the first fillet point (the root chord end).
    pub fn root_index(&self) -> usize {
        self.regions.iter().position(|r| *r == Region::Fillet).unwrap_or(0)
    }
}
