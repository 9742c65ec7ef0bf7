//! Unloaded separation of a tooth pair along the line of action, from the
//! real 2-D flank outlines.
//!
//! Canonical frame of a mesh: gear 1 centred at the origin with its tooth 0
//! on the +x axis; gear 2 centred at (a, 0) (external) or (−a, 0) (internal,
//! the ring surrounding gear 1), placed so that one of its spaces is centred
//! on the line of centres (the backlash split equally). Gear 1 turns by
//! λ / r_b1 counter-clockwise and gear 2 by the conjugate angle; λ is the
//! rigid-body travel along the line of action.
//!
//! The unloaded separation of a pair is the rotation of gear 1, with gear 2
//! held, that brings the two outlines into contact, times r_b1: a length
//! along the line of action. On the nominal path of perfect involutes it is
//! zero when the tables are indexed, as they are, by the position of the
//! drive-flank contact with the drive flanks touching; the back flank then
//! sits one normal backlash j_n away. Profile deviations add to it; outside the path it
//! is the gap to tip-corner (chamfer) contact. The first contact of two
//! polylines under a rotation is a vertex of one meeting an edge of the
//! other, so both directions are searched.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::geometry::profile::{FlankOutline, ProfileDeviation};
use crate::model::gear::{EdgeRelief, GearKind, GearSet, MeshKind, ToothForm};
use crate::model::mesh::PathOfContact;

/// Separation used where no contact is possible within half an angular
/// pitch \[m\]; far above any elastic approach.
pub const NO_CONTACT: f64 = 1.0e-3;

/// Profile deviations of the four flanks that meet in one mesh.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFlanks {
    /// Gear 1's flank loaded when gear 1 drives forward.
    pub gear1_drive: ProfileDeviation,
    /// Gear 1's other flank (back flank contact across the backlash).
    pub gear1_back: ProfileDeviation,
    /// Gear 2's flank that meets gear 1's drive flank.
    pub gear2_drive: ProfileDeviation,
    /// Gear 2's flank that meets gear 1's back flank.
    pub gear2_back: ProfileDeviation,
}

/// A separation sampled on a uniform grid of positions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeparationTable {
    /// Position of the first sample \[m\].
    pub start: f64,
    /// Spacing of the samples \[m\].
    pub step: f64,
    /// Separation at each sample \[m\].
    pub values: Vec<f64>,
}

impl SeparationTable {
    /// Separation at position `s` \[m\], linear between samples,
    /// [`NO_CONTACT`] outside the table.
    pub fn at(&self, s: f64) -> f64 {
        let x = (s - self.start) / self.step;
        if x.is_nan() || x < 0.0 || x > (self.values.len() - 1) as f64 {
            return NO_CONTACT;
        }
        let i = (x.floor() as usize).min(self.values.len() - 2);
        let t = x - i as f64;
        self.values[i] + t * (self.values[i + 1] - self.values[i])
    }

    /// The interpolation cell of position `s` \[m\], clamped to the table: the
    /// index i of its left sample and the fraction t across it. Tables that
    /// share this grid (the contact law's separations and stiffnesses) are
    /// all read with the same (i, t).
    #[inline(always)]
    pub fn cell(&self, s: f64) -> (usize, f64) {
        let last = self.values.len() - 1;
        let x = ((s - self.start) * (1.0 / self.step)).clamp(0.0, last as f64);
        let i = (x as usize).min(last - 1);
        (i, x - i as f64)
    }

    /// Slope d(separation)/ds [-] of the interpolant at `s`; zero outside.
    pub fn slope_at(&self, s: f64) -> f64 {
        let x = (s - self.start) / self.step;
        if x.is_nan() || x < 0.0 || x > (self.values.len() - 1) as f64 {
            return 0.0;
        }
        let i = (x.floor() as usize).min(self.values.len() - 2);
        (self.values[i + 1] - self.values[i]) / self.step
    }

    /// Positions \[m\] of the samples.
    pub fn positions(&self) -> impl Iterator<Item = f64> + '_ {
        (0..self.values.len()).map(|i| self.start + i as f64 * self.step)
    }

    /// Last position of the table \[m\].
    pub fn end(&self) -> f64 {
        self.start + (self.values.len() - 1) as f64 * self.step
    }
}

/// Separation tables of one mesh, both indexed by the position `s` on the
/// drive line of action of one gear-1 tooth's drive-flank contact point
/// (with the drive flanks touching); the next tooth of gear 1 is at s − p_b.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshSeparation {
    /// The path of contact.
    pub path: PathOfContact,
    /// Drive flank separation vs position on the drive line of action \[m\].
    pub drive: SeparationTable,
    /// Back flank separation vs position on the back line of action \[m\].
    pub back: SeparationTable,
    /// Normal backlash j_n of the perfect involutes \[m\].
    pub normal_backlash: f64,
    /// Positions \[m\] (drive-position coordinate of the gear-1 tooth) between
    /// which that tooth's back flank is on the back path of contact.
    pub back_range: (f64, f64),
    /// The back flank of the tooth at drive position s touches the back line
    /// of action at position `back_mirror − s` \[m\].
    pub back_mirror: f64,
    /// Drive positions \[m\] beyond which the drive flanks are relieved (a
    /// tip chamfer whose edge carries no load); ±∞ without relief.
    #[serde(with = "float_pair_bits")]
    pub drive_window: (f64, f64),
    /// Drive positions \[m\] beyond which the back flanks are relieved.
    #[serde(with = "float_pair_bits")]
    pub back_window: (f64, f64),
    /// Reliefs before and after the drive window
    /// ([`crate::model::gear::ToothForm::edge_relief`] of gear 2 and
    /// gear 1), added to the separation beyond it.
    pub drive_relief: (Option<EdgeRelief>, Option<EdgeRelief>),
    /// Reliefs before and after the back window.
    pub back_relief: (Option<EdgeRelief>, Option<EdgeRelief>),
}

/// Relief \[m\] and its derivative along the drive position [-] at `pos` for
/// a window `w` of unrelieved positions and the reliefs `e` before and
/// after it.
#[inline(always)]
fn relief(w: (f64, f64), e: &(Option<EdgeRelief>, Option<EdgeRelief>), pos: f64) -> (f64, f64) {
    match e {
        (Some(r), _) if pos < w.0 => {
            let (v, dv) = r.at(w.0 - pos);
            (v, -dv)
        }
        (_, Some(r)) if pos > w.1 => r.at(pos - w.1),
        _ => (0.0, 0.0),
    }
}

type P = [f64; 2];

fn rot(p: P, a: f64) -> P {
    let (s, c) = a.sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1]]
}

fn wrap(a: f64) -> f64 {
    (a + PI).rem_euclid(2.0 * PI) - PI
}

/// Segments of a polyline bucketed by their radius range about the origin,
/// so a circle query touches only the few segments that can cross it.
struct RadialIndex<'a> {
    pts: &'a [P],
    r_min: f64,
    width: f64,
    buckets: Vec<Vec<usize>>,
}

impl<'a> RadialIndex<'a> {
    fn new(pts: &'a [P]) -> Self {
        let radii: Vec<f64> = pts.iter().map(|p| p[0].hypot(p[1])).collect();
        let r_min = radii.iter().cloned().fold(f64::INFINITY, f64::min);
        let r_max = radii.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let n = 256;
        let width = ((r_max - r_min) / n as f64).max(1e-12);
        let mut buckets = vec![Vec::new(); n];
        for i in 0..pts.len().saturating_sub(1) {
            let (a, b) = (radii[i].min(radii[i + 1]), radii[i].max(radii[i + 1]));
            let lo = (((a - r_min) / width).floor() as usize).min(n - 1);
            let hi = (((b - r_min) / width).floor() as usize).min(n - 1);
            for bucket in &mut buckets[lo..=hi] {
                bucket.push(i);
            }
        }
        Self { pts, r_min, width, buckets }
    }

    /// Polar angles where the circle of radius `r` about the origin crosses
    /// the polyline.
    fn crossings(&self, r: f64, out: &mut Vec<f64>) {
        out.clear();
        let k = (r - self.r_min) / self.width;
        if k < 0.0 || k >= self.buckets.len() as f64 {
            return;
        }
        for &i in &self.buckets[k as usize] {
            let (q0, q1) = (self.pts[i], self.pts[i + 1]);
            let d = [q1[0] - q0[0], q1[1] - q0[1]];
            let a = d[0] * d[0] + d[1] * d[1];
            let b = 2.0 * (q0[0] * d[0] + q0[1] * d[1]);
            let c = q0[0] * q0[0] + q0[1] * q0[1] - r * r;
            let disc = b * b - 4.0 * a * c;
            if a == 0.0 || disc < 0.0 {
                continue;
            }
            let sq = disc.sqrt();
            for t in [(-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)] {
                if (0.0..=1.0).contains(&t) {
                    let x = [q0[0] + t * d[0], q0[1] + t * d[1]];
                    out.push(x[1].atan2(x[0]));
                }
            }
        }
    }
}

/// Smallest rotation (in direction `dir` = ±1, radians, within ±`window`)
/// of outline `a` about the origin, with `b` held, that brings them into
/// contact; `None` if none within the window.
fn contact_rotation(a: &[P], b: &[P], dir: f64, window: f64) -> Option<f64> {
    let ia = RadialIndex::new(a);
    let ib = RadialIndex::new(b);
    let mut best: Option<f64> = None;
    let mut xs = Vec::new();
    let mut consider = |d: f64| {
        if d.abs() < window && best.is_none_or(|b| d < b) {
            best = Some(d);
        }
    };
    for p in a {
        ib.crossings(p[0].hypot(p[1]), &mut xs);
        let psi = p[1].atan2(p[0]);
        for beta in &xs {
            consider(dir * wrap(beta - psi));
        }
    }
    for q in b {
        ia.crossings(q[0].hypot(q[1]), &mut xs);
        let psi = q[1].atan2(q[0]);
        for beta in &xs {
            consider(dir * wrap(psi - beta));
        }
    }
    best
}

fn place(outline: &[P], angle: f64, centre: P) -> Vec<P> {
    outline.iter().map(|p| rot(*p, angle)).map(|p| [p[0] + centre[0], p[1] + centre[1]]).collect()
}

/// Position on the line of action of gear 1's tooth-0 drive flank at travel 0:
/// the involute with base half angle ψ_b crosses the line of action at roll
/// angle ψ_b + α_w.
fn position_offset(g1: &ToothForm, path: &PathOfContact) -> f64 {
    g1.base_radius() * (g1.base_half_angle() + path.pressure_angle)
}

impl MeshSeparation {
    /// Relief of the drive flanks \[m\] at drive position `pos` \[m\] and its
    /// derivative along `pos` [-]: zero on the involute path or without a
    /// relieved edge.
    #[inline(always)]
    pub fn drive_relief_at(&self, pos: f64) -> (f64, f64) {
        relief(self.drive_window, &self.drive_relief, pos)
    }

    /// Relief of the back flanks \[m\] at drive position `pos` \[m\] and its
    /// derivative along `pos` [-].
    #[inline(always)]
    pub fn back_relief_at(&self, pos: f64) -> (f64, f64) {
        relief(self.back_window, &self.back_relief, pos)
    }

    /// Separation tables of a mesh with the given flank deviations, sampled
    /// every `step` metres over the path of contact plus one base pitch on
    /// each side.
    pub fn new(set: &GearSet, mesh: MeshKind, flanks: &MeshFlanks, step: f64) -> Self {
        let (g1, g2) = set.mesh_gears(mesh);
        let path = PathOfContact::new(set, mesh);
        let a = set.centre_distance();
        let rb1 = g1.base_radius();
        let rb2 = g2.base_radius();
        let jn = set.normal_backlash(mesh);
        let offset = position_offset(g1, &path);

        let g1_drive = FlankOutline::new(g1, &flanks.gear1_drive).points;
        let g1_back = FlankOutline::new(g1, &flanks.gear1_back).mirrored().points;
        let up2_drive = FlankOutline::new(g2, &flanks.gear2_drive);
        let up2_back = FlankOutline::new(g2, &flanks.gear2_back);
        let p2 = g2.angular_pitch();
        // (outline, tooth angle in gear 2's frame, centre, rotation sign)
        let (g2_drive, g2_back, centre, ratio) = match g2.kind {
            GearKind::External => (
                (up2_drive.points, PI - p2 / 2.0),
                (up2_back.mirrored().points, PI + p2 / 2.0),
                [a, 0.0],
                -rb1 / rb2,
            ),
            GearKind::Internal => {
                ((up2_drive.mirrored().points, p2 / 2.0), (up2_back.points, -p2 / 2.0), [-a, 0.0], rb1 / rb2)
            }
        };
        let window = g1.angular_pitch() / 2.0;
        // Tooth 0's back flank meets the back line of action where its drive
        // flank position is mirrored about the centred position.
        let mirror = |x: f64| 2.0 * offset + jn - x;
        let lo = path.start_sharp.min(mirror(path.end_sharp)) - path.base_pitch;
        let hi = path.end_sharp.max(mirror(path.start_sharp)) + path.base_pitch;
        let n = ((hi - lo) / step).ceil() as usize + 1;
        let table = |dir: f64, g1_outline: &[P], g2_outline: &(Vec<P>, f64)| {
            let values = (0..n)
                .map(|i| {
                    let s = lo + i as f64 * step;
                    // Drive-contact configuration of perfect involutes at s:
                    // gear 2 at the conjugate angle of the centred travel
                    // s − offset − j_n/2, gear 1 half a backlash further on.
                    let theta1 = (s - offset) / rb1;
                    let theta2 = ratio * (s - offset - jn / 2.0) / rb1;
                    let pa = place(g1_outline, theta1, [0.0, 0.0]);
                    let pb = place(&g2_outline.0, g2_outline.1 + theta2, centre);
                    match contact_rotation(&pa, &pb, dir, window) {
                        Some(d) => (rb1 * d).min(NO_CONTACT),
                        None => NO_CONTACT,
                    }
                })
                .collect();
            SeparationTable { start: lo, step, values }
        };
        let drive = table(1.0, &g1_drive, &g2_drive);
        let back = table(-1.0, &g1_back, &g2_back);
        let back_range = (mirror(path.end), mirror(path.start));
        // A chamfer whose edge carries no load relieves the tip: before the
        // involute path the tip corner of gear 2 would touch gear 1, after it
        // that of gear 1 would touch gear 2; beyond the path's ends the
        // chamfer's relief (`ToothForm::edge_relief`) is
        // added to the corner's geometric separation, which the tables keep:
        // the force falls to zero continuously over about one elastic
        // approach divided by the relief's slope. The back path runs the other way,
        // mirrored about `back_mirror`.
        let back_mirror = 2.0 * offset + jn;
        let (e2, e1) = (g2.edge_relief(), g1.edge_relief());
        let lo = if e2.is_some() { path.start } else { f64::NEG_INFINITY };
        let hi = if e1.is_some() { path.end } else { f64::INFINITY };
        Self {
            path,
            drive,
            back,
            normal_backlash: jn,
            back_range,
            back_mirror,
            drive_window: (lo, hi),
            back_window: (back_mirror - hi, back_mirror - lo),
            drive_relief: (e2, e1),
            back_relief: (e1, e2),
        }
    }
}

/// Serde for a pair of floats that may be infinite (JSON has no infinity):
/// written as their bit patterns.
mod float_pair_bits {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Writes the pair as two u64 bit patterns.
    pub fn serialize<S: Serializer>(v: &(f64, f64), s: S) -> Result<S::Ok, S::Error> {
        (v.0.to_bits(), v.1.to_bits()).serialize(s)
    }

    /// Reads the pair from two u64 bit patterns.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<(f64, f64), D::Error> {
        let (a, b) = <(u64, u64)>::deserialize(d)?;
        Ok((f64::from_bits(a), f64::from_bits(b)))
    }
}
