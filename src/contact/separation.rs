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

fn rot(p: P, (s, c): (f64, f64)) -> P {
    [c * p[0] - s * p[1], s * p[0] + c * p[1]]
}

/// A monotone stand-in for the polar angle of (x, y) on (−π, π): in (−2, 2),
/// odd, and cheaper than `atan2` for comparing angles.
fn pseudo_angle(x: f64, y: f64) -> f64 {
    (1.0 - x / (x.abs() + y.abs())).copysign(y)
}

/// The segments of a polyline bucketed by their range of squared radius
/// about the origin, so a circle query touches only the few segments that can
/// cross it. The buckets are kept in one array (`segments[starts[k]..starts[k + 1]]`)
/// and rebuilt in place for each new placement of the polyline.
#[derive(Default)]
struct RadialIndex {
    pts: Vec<P>,
    /// Squared radius of each vertex.
    r2: Vec<f64>,
    r2_min: f64,
    inv_width: f64,
    starts: Vec<u32>,
    segments: Vec<u32>,
}

const BUCKETS: usize = 256;

impl RadialIndex {
    /// Indexes the polyline `pts` rotated by the angle whose sine and cosine
    /// are `sc` and then moved by `centre`.
    fn place(&mut self, pts: &[P], sc: (f64, f64), centre: P) {
        self.pts.clear();
        self.pts.extend(pts.iter().map(|&p| {
            let q = rot(p, sc);
            [q[0] + centre[0], q[1] + centre[1]]
        }));
        self.r2.clear();
        self.r2.extend(self.pts.iter().map(|p| p[0] * p[0] + p[1] * p[1]));
        let r2_min = self.r2.iter().cloned().fold(f64::INFINITY, f64::min);
        let r2_max = self.r2.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let inv_width = 1.0 / ((r2_max - r2_min) / BUCKETS as f64).max(1e-24);
        self.r2_min = r2_min;
        self.inv_width = inv_width;
        // The buckets segment i spans, first and last.
        let r2 = &self.r2;
        let span = |i: usize| {
            let bucket = |v: f64| (((v - r2_min) * inv_width) as usize).min(BUCKETS - 1);
            (bucket(r2[i].min(r2[i + 1])), bucket(r2[i].max(r2[i + 1])))
        };
        // Counting pass, then the fill pass into the slots the counts give.
        self.starts.clear();
        self.starts.resize(BUCKETS + 1, 0);
        let segments = self.pts.len().saturating_sub(1);
        for i in 0..segments {
            let (lo, hi) = span(i);
            for count in &mut self.starts[lo + 1..=hi + 1] {
                *count += 1;
            }
        }
        for k in 0..BUCKETS {
            self.starts[k + 1] += self.starts[k];
        }
        self.segments.clear();
        self.segments.resize(self.starts[BUCKETS] as usize, 0);
        let mut next: [u32; BUCKETS] = [0; BUCKETS];
        next.copy_from_slice(&self.starts[..BUCKETS]);
        for i in 0..segments {
            let (lo, hi) = span(i);
            for slot in &mut next[lo..=hi] {
                self.segments[*slot as usize] = i as u32;
                *slot += 1;
            }
        }
    }

    /// Calls `f` with each point where the circle of squared radius `r2`
    /// about the origin crosses the polyline.
    #[inline]
    fn crossings(&self, r2: f64, mut f: impl FnMut(P)) {
        let k = (r2 - self.r2_min) * self.inv_width;
        if !(0.0..BUCKETS as f64).contains(&k) {
            return;
        }
        let k = k as usize;
        for &i in &self.segments[self.starts[k] as usize..self.starts[k + 1] as usize] {
            let i = i as usize;
            let (q0, q1) = (self.pts[i], self.pts[i + 1]);
            let d = [q1[0] - q0[0], q1[1] - q0[1]];
            let a = d[0] * d[0] + d[1] * d[1];
            let b = 2.0 * (q0[0] * d[0] + q0[1] * d[1]);
            let c = self.r2[i] - r2;
            let disc = b * b - 4.0 * a * c;
            if a == 0.0 || disc < 0.0 {
                continue;
            }
            let sq = disc.sqrt();
            for t in [(-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)] {
                if (0.0..=1.0).contains(&t) {
                    f([q0[0] + t * d[0], q0[1] + t * d[1]]);
                }
            }
        }
    }
}

/// The smallest of candidate rotations, kept as (sine, cosine) pairs scaled
/// by the squared radius and compared by a monotone stand-in for the angle:
/// one `atan2` at the end instead of one per candidate.
struct Closest {
    /// Rotation sense: +1 counter-clockwise, −1 clockwise.
    dir: f64,
    /// The stand-in of the search window's half width.
    limit: f64,
    best: Option<(f64, f64, f64)>,
}

impl Closest {
    fn new(dir: f64, window: f64) -> Self {
        let (s, c) = window.sin_cos();
        Self { dir, limit: if window < PI { pseudo_angle(c, s) } else { 2.0 }, best: None }
    }

    /// Considers the rotation that carries `from` onto `to` (equal radii).
    #[inline]
    fn consider(&mut self, from: P, to: P) {
        let y = self.dir * (from[0] * to[1] - from[1] * to[0]);
        let x = from[0] * to[0] + from[1] * to[1];
        let key = pseudo_angle(x, y);
        if key.abs() < self.limit && self.best.is_none_or(|(k, _, _)| key < k) {
            self.best = Some((key, y, x));
        }
    }

    /// The smallest rotation found \[rad\], in the sense `dir`.
    fn angle(&self) -> Option<f64> {
        self.best.map(|(_, y, x)| y.atan2(x))
    }
}

/// Smallest rotation \[rad\] (in direction `dir` = ±1, within ±`window`) of
/// polyline `a` about the origin, with `b` held, that brings them into
/// contact; `None` if none within the window. The first contact of two
/// polylines under a rotation is a vertex of one meeting an edge of the
/// other, so both directions are searched.
fn contact_rotation(a: &RadialIndex, b: &RadialIndex, dir: f64, window: f64) -> Option<f64> {
    let mut closest = Closest::new(dir, window);
    for (&p, &r2) in a.pts.iter().zip(&a.r2) {
        b.crossings(r2, |x| closest.consider(p, x));
    }
    for (&q, &r2) in b.pts.iter().zip(&b.r2) {
        a.crossings(r2, |x| closest.consider(x, q));
    }
    closest.angle()
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
        Self::with_search(set, mesh, flanks, step, contact_rotation)
    }

    /// [`MeshSeparation::new`] with the contact search `search(a, b, dir,
    /// window)` of [`contact_rotation`]'s signature.
    fn with_search(
        set: &GearSet,
        mesh: MeshKind,
        flanks: &MeshFlanks,
        step: f64,
        search: fn(&RadialIndex, &RadialIndex, f64, f64) -> Option<f64>,
    ) -> Self {
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
            // Gear 1 stays put: the rotation that closes the gap is the same
            // when both gears are turned back by gear 1's angle θ1, so gear 1's
            // index is built once and gear 2 is placed in its frame.
            let mut a = RadialIndex::default();
            a.place(g1_outline, (0.0, 1.0), [0.0, 0.0]);
            let mut b = RadialIndex::default();
            let values = (0..n)
                .map(|i| {
                    let s = lo + i as f64 * step;
                    // Drive-contact configuration of perfect involutes at s:
                    // gear 2 at the conjugate angle of the centred travel
                    // s − offset − j_n/2, gear 1 half a backlash further on.
                    let theta1 = (s - offset) / rb1;
                    let theta2 = ratio * (s - offset - jn / 2.0) / rb1;
                    let centre = rot(centre, (-theta1).sin_cos());
                    b.place(&g2_outline.0, (g2_outline.1 + theta2 - theta1).sin_cos(), centre);
                    match search(&a, &b, dir, window) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::profile::ProfileDeviation;
    use crate::scene::Scene;

    fn wrap(a: f64) -> f64 {
        (a + PI).rem_euclid(2.0 * PI) - PI
    }

    /// The contact search without the index or the stand-in angles: every
    /// vertex against every edge of the other polyline, each candidate by
    /// `atan2`.
    fn exhaustive(a: &RadialIndex, b: &RadialIndex, dir: f64, window: f64) -> Option<f64> {
        let mut best: Option<f64> = None;
        let mut search = |from: &[P], to: &[P], sign: f64| {
            for p in from {
                let r = p[0].hypot(p[1]);
                let psi = p[1].atan2(p[0]);
                for w in to.windows(2) {
                    let d = [w[1][0] - w[0][0], w[1][1] - w[0][1]];
                    let qa = d[0] * d[0] + d[1] * d[1];
                    let qb = 2.0 * (w[0][0] * d[0] + w[0][1] * d[1]);
                    let qc = w[0][0] * w[0][0] + w[0][1] * w[0][1] - r * r;
                    let disc = qb * qb - 4.0 * qa * qc;
                    if qa == 0.0 || disc < 0.0 {
                        continue;
                    }
                    for t in [(-qb - disc.sqrt()) / (2.0 * qa), (-qb + disc.sqrt()) / (2.0 * qa)] {
                        if (0.0..=1.0).contains(&t) {
                            let beta = (w[0][1] + t * d[1]).atan2(w[0][0] + t * d[0]);
                            let rotation = dir * sign * wrap(beta - psi);
                            if rotation.abs() < window && best.is_none_or(|b| rotation < b) {
                                best = Some(rotation);
                            }
                        }
                    }
                }
            }
        };
        search(&a.pts, &b.pts, 1.0);
        search(&b.pts, &a.pts, -1.0);
        best
    }

    /// The indexed search with its stand-in angles gives the exhaustive
    /// search's tables, external and internal mesh, perfect and worn flanks
    /// (worn bands on all four flanks), on a grid of 20 samples
    /// per base pitch, to 1e-15 m (the tables' values reach 1e-3 m; a
    /// missed or wrongly chosen contact would differ by a sample's change
    /// in separation, some 1e-7 m and more).
    #[test]
    fn the_indexed_search_equals_the_exhaustive_one() {
        let set = Scene::example_2004().validate().expect("the example is valid");
        // Worn bands of 5 to 30 µm over the roll angles of the flanks, kinked
        // where the grid's slopes change.
        let band = |scale: f64| {
            ProfileDeviation::new(
                vec![0.1, 0.3, 0.45, 0.6, 0.9],
                vec![0.0, 30e-6 * scale, 5e-6, 20e-6 * scale, 0.0],
            )
        };
        let worn = MeshFlanks {
            gear1_drive: band(1.0),
            gear1_back: band(0.5),
            gear2_drive: band(0.7),
            gear2_back: band(0.3),
        };
        for mesh in [MeshKind::SunPlanet, MeshKind::RingPlanet] {
            for flanks in [MeshFlanks::default(), worn.clone()] {
                let step = PathOfContact::new(&set, mesh).base_pitch / 20.0;
                let fast = MeshSeparation::new(&set, mesh, &flanks, step);
                let slow = MeshSeparation::with_search(&set, mesh, &flanks, step, exhaustive);
                let mut contacts = 0;
                for (fast, slow) in [(&fast.drive, &slow.drive), (&fast.back, &slow.back)] {
                    assert_eq!(fast.values.len(), slow.values.len());
                    for (i, (f, s)) in fast.values.iter().zip(&slow.values).enumerate() {
                        assert!((f - s).abs() <= 1e-15, "{mesh:?} sample {i}: {f:e} against {s:e}");
                        contacts += usize::from(*s < NO_CONTACT);
                    }
                }
                assert!(contacts > 20, "{mesh:?}: only {contacts} samples within reach of contact");
            }
        }
    }
}
