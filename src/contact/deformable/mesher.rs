//! A structured, mapped mesh of 9-node quadrilaterals over a sector of a
//! gear body, from the project's own tooth outline
//! ([`FlankOutline`]: root land, fillet, involute, chamfer, tip land).
//!
//! Frame: the gear centre at the origin, tooth 0's centreline on +x; tooth k
//! is tooth 0 turned by k·2π/Z. Each tooth half (the upper, +y, half; the
//! lower is its mirror image) is made of two mapped patches:
//!
//! - the *tooth*: bounded by its base line, the flank (fillet and
//!   involute), the tip (chamfer and tip land) and the centreline. The base
//!   line runs from the middle of the root chord (the chord between the
//!   points where the fillets meet the root circle) to the fillet point where
//!   the fillet has turned 30° away from the root circle's direction, a few
//!   hundredths of a millimetre above the chord's end: the chord itself
//!   meets the fillet at a zero angle, which no quadrilateral can fill. The
//!   fillet's foot below that point belongs to the root block. The
//!   lines across it run from the centreline to the flank; the element
//!   thickness shrinks geometrically toward the flank, so the field a few
//!   elements below the surface is resolved. Flank nodes on the involute sit
//!   at exact involute points, evenly spaced in arc length;
//! - the *root block*: below the chord and the root land, down to a circle
//!   of radius r_layer inside the root circle (outside it for the ring).
//!
//! Both are transfinite (Coons) maps of their four sides (Gordon & Hall,
//! Int. J. Numer. Meth. Eng. 7 (1973) 461). Below r_layer the rim is a polar
//! grid down to the bore (sun, planet) or out to the rim's outside (ring),
//! growing geometrically away from the teeth. Nodes shared by patches are
//! merged by position.
//!
//! Boundary conditions: the bore of an external gear and the outside of the
//! ring are held (the study takes the ring's outer diameter as rigid); so
//! are the sector's two radial cut faces, through the middle of a space.
//! The tooth alone ([`GearMesh::tooth_alone`]) is the tooth patches of one
//! tooth held along their base lines.

use super::fe::{FeMesh, Point};
use crate::geometry::profile::{FlankOutline, ProfileDeviation, Region};
use crate::model::gear::{GearKind, ToothForm};
use crate::model::involute::radius_at_roll;
use std::collections::HashMap;

/// Element counts of the mesh at refinement level 1; level ℓ multiplies
/// every count by ℓ (and takes the ℓ-th root of the grading ratios, so the
/// grading keeps its shape).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshDensity {
    /// Elements along the fillet, from its foot to the form circle.
    pub fillet: usize,
    /// Elements along the fillet's foot (root circle to where the fillet
    /// has turned 30° from it), part of the root block.
    pub foot: usize,
    /// Elements along the involute.
    pub involute: usize,
    /// Elements across a tooth half, centreline to flank.
    pub across: usize,
    /// Elements along the root land, fillet to the middle of the space.
    pub land: usize,
    /// Element layers of the root block, r_layer to the teeth's base lines.
    pub root: usize,
    /// Element layers of the rim, r_layer to the bore (or the ring's outside).
    pub rim: usize,
    /// Ratio of successive element thicknesses across a tooth half, toward
    /// the flank [-] (below 1: finer at the flank).
    pub flank_grading: f64,
    /// Ratio of successive rim layer thicknesses away from the teeth [-].
    pub rim_grading: f64,
}

impl Default for MeshDensity {
    fn default() -> Self {
        Self {
            fillet: 3,
            foot: 1,
            involute: 16,
            across: 5,
            land: 3,
            root: 3,
            rim: 5,
            flank_grading: 0.7,
            rim_grading: 1.3,
        }
    }
}

impl MeshDensity {
    /// The counts and gradings at refinement level `level` (≥ 1).
    pub fn at_level(&self, level: usize) -> Self {
        let l = level.max(1);
        let root = |q: f64| q.powf(1.0 / l as f64);
        Self {
            fillet: self.fillet * l,
            foot: self.foot * l,
            involute: self.involute * l,
            across: self.across * l,
            land: self.land * l,
            root: self.root * l,
            rim: self.rim * l,
            flank_grading: root(self.flank_grading),
            rim_grading: root(self.rim_grading),
        }
    }
}

/// Where one tooth of the mesh is and which of its entities the influence
/// coefficients read.
#[derive(Clone, Debug, PartialEq)]
pub struct ToothMesh {
    /// Tooth index, counted from the centre tooth toward +φ.
    pub index: i32,
    /// Angle of the tooth's centreline \[rad\].
    pub angle: f64,
    /// Elements of the upper half: its tooth patch, then its root block
    /// (where the points at the reference depth lie).
    pub upper_elements: Vec<usize>,
    /// Nodes of the upper flank, root to tip, on the flank grid.
    pub flank_nodes: Vec<usize>,
}

/// A meshed sector of a gear body (or one tooth alone).
#[derive(Clone, Debug, PartialEq)]
pub struct GearMesh {
    /// The elements, nodes and held nodes.
    pub mesh: FeMesh,
    /// The teeth, in increasing index.
    pub teeth: Vec<ToothMesh>,
    /// Roll angle of each flank grid point on the involute \[rad\]; `None`
    /// on the fillet.
    pub flank_rolls: Vec<Option<f64>>,
}

/// Nodes merged by position: points closer than `TOLERANCE` are one node.
struct Builder {
    mesh: FeMesh,
    cells: HashMap<(i64, i64), Vec<usize>>,
}

const CELL: f64 = 1e-7;
const TOLERANCE: f64 = 1e-9;

impl Builder {
    fn new() -> Self {
        Self { mesh: FeMesh::default(), cells: HashMap::new() }
    }

    fn node(&mut self, p: Point) -> usize {
        let c = ((p[0] / CELL).floor() as i64, (p[1] / CELL).floor() as i64);
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(list) = self.cells.get(&(c.0 + dx, c.1 + dy)) {
                    for &n in list {
                        let q = self.mesh.nodes[n];
                        if (q[0] - p[0]).abs() < TOLERANCE && (q[1] - p[1]).abs() < TOLERANCE {
                            return n;
                        }
                    }
                }
            }
        }
        let n = self.mesh.nodes.len();
        self.mesh.nodes.push(p);
        self.mesh.fixed.push(false);
        self.cells.entry(c).or_default().push(n);
        n
    }

    /// Adds the elements of a (2m+1) × (2n+1) point grid; returns the node
    /// ids of the grid and the element ids, element (i, j) at i·n + j.
    fn patch(&mut self, grid: &[Vec<Point>]) -> (Vec<Vec<usize>>, Vec<usize>) {
        let ids: Vec<Vec<usize>> =
            grid.iter().map(|col| col.iter().map(|p| self.node(*p)).collect()).collect();
        let (m, n) = ((ids.len() - 1) / 2, (ids[0].len() - 1) / 2);
        let mut elements = Vec::with_capacity(m * n);
        for ei in 0..m {
            for ej in 0..n {
                let at = |a: usize, b: usize| ids[2 * ei + a][2 * ej + b];
                let c = [at(0, 0), at(2, 0), at(2, 2), at(0, 2)].map(|k| self.mesh.nodes[k]);
                let area: f64 =
                    (0..4).map(|k| c[k][0] * c[(k + 1) % 4][1] - c[(k + 1) % 4][0] * c[k][1]).sum();
                // A mirrored patch runs clockwise: swap ξ and η to keep det J > 0.
                let mut e = [0; 9];
                for b in 0..3 {
                    for a in 0..3 {
                        let local = if area > 0.0 { 3 * b + a } else { 3 * a + b };
                        e[local] = at(a, b);
                    }
                }
                elements.push(self.mesh.elements.len());
                self.mesh.elements.push(e);
            }
        }
        (ids, elements)
    }
}

fn polar(r: f64, phi: f64) -> Point {
    [r * phi.cos(), r * phi.sin()]
}

fn turn(p: Point, angle: f64) -> Point {
    let (s, c) = angle.sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1]]
}

fn lerp(a: Point, b: Point, t: f64) -> Point {
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

/// Grid parameters (2n + 1 of them) of n elements whose sizes form a
/// geometric series of ratio q from 0 to 1; odd points are element middles.
fn graded(n: usize, q: f64) -> Vec<f64> {
    let sizes: Vec<f64> = (0..n).map(|k| q.powi(k as i32)).collect();
    let total: f64 = sizes.iter().sum();
    let mut t = vec![0.0; 2 * n + 1];
    for k in 0..n {
        t[2 * k + 1] = t[2 * k] + 0.5 * sizes[k] / total;
        t[2 * k + 2] = t[2 * k] + sizes[k] / total;
    }
    t[2 * n] = 1.0;
    t
}

/// The point at arc-length fraction `t` along a polyline.
fn along(poly: &[Point], t: f64) -> Point {
    let lengths: Vec<f64> = poly.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).collect();
    let mut rest = t.clamp(0.0, 1.0) * lengths.iter().sum::<f64>();
    for (k, l) in lengths.iter().enumerate() {
        if rest <= *l || k + 1 == lengths.len() {
            return lerp(poly[k], poly[k + 1], if *l > 0.0 { (rest / l).min(1.0) } else { 0.0 });
        }
        rest -= l;
    }
    poly[0]
}

/// The transfinite map of four sides sampled on a grid: `bottom` (v = 0)
/// and `top` (v = 1) at the u parameters `u`, `left` (u = 0) and `right`
/// (u = 1) at the v parameters `v`; corners shared.
fn coons(
    u: &[f64],
    v: &[f64],
    bottom: &[Point],
    top: &[Point],
    left: &[Point],
    right: &[Point],
) -> Vec<Vec<Point>> {
    let (b0, b1, t0, t1) = (bottom[0], bottom[u.len() - 1], top[0], top[u.len() - 1]);
    (0..u.len())
        .map(|i| {
            (0..v.len())
                .map(|j| {
                    let (s, t) = (u[i], v[j]);
                    let f = |k: usize| {
                        (1.0 - t) * bottom[i][k] + t * top[i][k] + (1.0 - s) * left[j][k] + s * right[j][k]
                            - (1.0 - s) * (1.0 - t) * b0[k]
                            - s * (1.0 - t) * b1[k]
                            - (1.0 - s) * t * t0[k]
                            - s * t * t1[k]
                    };
                    [f(0), f(1)]
                })
                .collect()
        })
        .collect()
}

/// The grids of one upper tooth half in the tooth's frame: the tooth patch
/// and the root block, and the flank grid's roll angles.
struct HalfGrids {
    tooth: Vec<Vec<Point>>,
    root: Vec<Vec<Point>>,
    rolls: Vec<Option<f64>>,
}

/// Index of the outline point where the fillet has turned 30° from its
/// direction at the root circle (the root circle's tangent): the tooth
/// patch starts there, so that its corner between the base line and the
/// flank is not a sliver.
fn foot_end(outline: &FlankOutline, root: usize, first_involute: usize) -> usize {
    let p = &outline.points;
    let unit = |a: Point, b: Point| {
        let d = [b[0] - a[0], b[1] - a[1]];
        let l = d[0].hypot(d[1]);
        [d[0] / l, d[1] / l]
    };
    let t0 = unit(p[root], p[root + 1]);
    (root + 1..first_involute)
        .find(|&k| {
            let d = unit(p[k], p[k + 1]);
            (d[0] * t0[0] + d[1] * t0[1]).clamp(-1.0, 1.0).acos() >= 30f64.to_radians()
        })
        .unwrap_or(root + 1)
}

/// The flank grid (fillet above its foot by arc length, involute evenly in
/// arc length, i.e. in ξ²) with its roll angles; the tip polyline from the
/// tip's centre to the involute's end; the foot polyline from its end down
/// to the root circle.
#[allow(clippy::type_complexity)]
fn flank_grid(
    form: &ToothForm,
    outline: &FlankOutline,
    d: &MeshDensity,
) -> (Vec<Point>, Vec<Option<f64>>, Vec<Point>, Vec<Point>) {
    let root = outline.root_index();
    let first_involute =
        outline.regions.iter().position(|r| matches!(r, Region::Involute(_))).unwrap_or(root);
    let last_involute =
        outline.regions.iter().rposition(|r| matches!(r, Region::Involute(_))).unwrap_or(root);
    let foot_top = foot_end(outline, root, first_involute);
    let fillet = &outline.points[foot_top..=first_involute];
    let mut points: Vec<Point> =
        (0..2 * d.fillet).map(|k| along(fillet, k as f64 / (2 * d.fillet) as f64)).collect();
    let mut rolls = vec![None; points.len()];
    let (x0, x1) = outline.involute_roll_range;
    for k in 0..=2 * d.involute {
        let xi = (x0 * x0 + (x1 * x1 - x0 * x0) * k as f64 / (2 * d.involute) as f64).sqrt();
        let r = radius_at_roll(xi, form.base_radius());
        points.push(polar(r, form.involute_half_angle(r)));
        rolls.push(Some(xi));
    }
    let mut tip: Vec<Point> = outline.points[last_involute..].to_vec();
    tip.reverse();
    let mut foot: Vec<Point> = outline.points[root..=foot_top].to_vec();
    foot.reverse();
    (points, rolls, tip, foot)
}

/// Where the tooth patch ends toward the body: the line along which the
/// tooth alone ([`GearMesh::tooth_alone`]) is held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BaseLine {
    /// From the middle of the root chord (the chord between the points where
    /// the fillets meet the root circle) straight to the foot's end.
    #[default]
    RootChord,
    /// Along the root circle from the centreline, rising to the foot's end
    /// (a few hundredths of a millimetre above the root circle) in its last
    /// part: the tooth of Sainsot, Velex & Duverger (2004), built in at the
    /// root circle.
    RootCircle,
}

/// The two patches of the upper half of a tooth, tooth frame.
fn half_grids(form: &ToothForm, d: &MeshDensity, r_layer: f64, base: BaseLine) -> HalfGrids {
    let outline = FlankOutline::new(form, &ProfileDeviation::none());
    let (flank, rolls, tip, foot) = flank_grid(form, &outline, d);
    let f0 = flank[0];
    let t = tip[0];
    // The chord side runs from the root chord's middle (on the centreline)
    // to the foot's end: the root chord itself meets the fillet at a zero
    // angle (both tangent to the root circle there).
    let c0 = match base {
        BaseLine::RootChord => [foot[foot.len() - 1][0], 0.0],
        BaseLine::RootCircle => [form.root_radius, 0.0],
    };
    // The centreline side follows the flank's arc length from the base line
    // to the tip, so the lines across stay short and never cross.
    let arc: Vec<f64> = std::iter::once(0.0)
        .chain(flank.windows(2).scan(0.0, |s, w| {
            *s += (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
            Some(*s)
        }))
        .collect();
    let total = arc[arc.len() - 1];
    let u: Vec<f64> = arc.iter().map(|s| s / total).collect();
    let centre: Vec<Point> = u.iter().map(|s| [c0[0] + s * (t[0] - c0[0]), 0.0]).collect();
    let v = graded(d.across, d.flank_grading);
    let (rf0, af0) = (f0[0].hypot(f0[1]), f0[1].atan2(f0[0]));
    let chord: Vec<Point> = v
        .iter()
        .map(|s| match base {
            BaseLine::RootChord => lerp(c0, f0, *s),
            BaseLine::RootCircle => polar(c0[0] + s.powi(4) * (rf0 - c0[0]), s * af0),
        })
        .collect();
    let tip_side: Vec<Point> = v.iter().map(|s| along(&tip, *s)).collect();
    let tooth = coons(&u, &v, &centre, &flank, &chord, &tip_side);

    // Root block: u from the centreline (0) to the middle of the space (1),
    // v from r_layer (0) to the chord and root land (1).
    let half_space = form.angular_pitch() / 2.0;
    let g0 = foot[foot.len() - 1];
    // On the root chord's base line the chord side starts at the foot's end's radius.
    debug_assert!(base != BaseLine::RootChord || (g0[0] - c0[0]).abs() < 1e-15);
    let (r0, a0) = (g0[0].hypot(g0[1]), g0[1].atan2(g0[0]));
    let mut top = chord.clone();
    for k in 1..=2 * d.foot {
        top.push(along(&foot, k as f64 / (2 * d.foot) as f64));
    }
    for k in 1..=2 * d.land {
        let s = k as f64 / (2 * d.land) as f64;
        top.push(polar(r0 + s * (form.root_radius - r0), a0 + s * (half_space - a0)));
    }
    let n = top.len() - 1;
    let ur: Vec<f64> = (0..=n).map(|k| k as f64 / n as f64).collect();
    let vr: Vec<f64> = (0..=2 * d.root).map(|k| k as f64 / (2 * d.root) as f64).collect();
    let bottom: Vec<Point> = ur.iter().map(|s| polar(r_layer, s * half_space)).collect();
    let left: Vec<Point> = vr.iter().map(|s| lerp([r_layer, 0.0], c0, *s)).collect();
    let right: Vec<Point> = vr.iter().map(|s| lerp(polar(r_layer, half_space), top[n], *s)).collect();
    let root = coons(&ur, &vr, &bottom, &top, &left, &right);
    HalfGrids { tooth, root, rolls }
}

/// The grid turned by `angle`, mirrored first (y → −y) when `lower`.
fn placed(grid: &[Vec<Point>], angle: f64, lower: bool) -> Vec<Vec<Point>> {
    grid.iter()
        .map(|col| col.iter().map(|p| turn(if lower { [p[0], -p[1]] } else { *p }, angle)).collect())
        .collect()
}

/// Radius of the circle between the root blocks and the rim \[m\]: half a
/// tooth height below the root (above it for the ring), at most 40 % of the
/// way to the body radius.
fn layer_radius(form: &ToothForm) -> f64 {
    let height = (form.tip_radius - form.root_radius).abs();
    let rim = (form.root_radius - form.body_radius).abs();
    let depth = (0.5 * height).min(0.4 * rim);
    match form.kind {
        GearKind::External => form.root_radius - depth,
        GearKind::Internal => form.root_radius + depth,
    }
}

impl GearMesh {
    /// The sector of teeth −`side`..=`side` of a gear body at refinement
    /// `level`, its bore (or outside) and radial cut faces held.
    pub fn sector(form: &ToothForm, density: &MeshDensity, level: usize, side: i32) -> Self {
        Self::sector_on(form, density, level, side, BaseLine::RootChord)
    }

    /// [`Self::sector`] with the teeth's patches ending on `base`.
    pub fn sector_on(
        form: &ToothForm,
        density: &MeshDensity,
        level: usize,
        side: i32,
        base: BaseLine,
    ) -> Self {
        let d = density.at_level(level);
        let r_layer = layer_radius(form);
        let half = half_grids(form, &d, r_layer, base);
        let pitch = form.angular_pitch();
        let mut b = Builder::new();
        let mut teeth = Vec::new();
        for k in -side..=side {
            let angle = f64::from(k) * pitch;
            let (tooth_ids, mut upper_elements) = b.patch(&placed(&half.tooth, angle, false));
            b.patch(&placed(&half.tooth, angle, true));
            let (root_up, root_elements) = b.patch(&placed(&half.root, angle, false));
            upper_elements.extend(root_elements);
            let (root_low, _) = b.patch(&placed(&half.root, angle, true));
            // The cut faces through the middle of the outer spaces.
            let cut = if k == side {
                Some(&root_up)
            } else if k == -side {
                Some(&root_low)
            } else {
                None
            };
            if let Some(ids) = cut {
                for n in &ids[ids.len() - 1] {
                    b.mesh.fixed[*n] = true;
                }
            }
            let flank_nodes = tooth_ids.iter().map(|col| col[col.len() - 1]).collect();
            teeth.push(ToothMesh { index: k, angle, upper_elements, flank_nodes });
        }
        let span = (f64::from(side) + 0.5) * pitch;
        let per_tooth = 4 * (d.across + d.foot + d.land);
        let columns = (2 * side as usize + 1) * per_tooth;
        let radii = graded(d.rim, d.rim_grading)
            .iter()
            .map(|s| r_layer + s * (form.body_radius - r_layer))
            .collect::<Vec<_>>();
        let rim: Vec<Vec<Point>> = (0..=columns)
            .map(|k| {
                let phi = -span + 2.0 * span * k as f64 / columns as f64;
                radii.iter().map(|r| polar(*r, phi)).collect()
            })
            .collect();
        let (rim_ids, _) = b.patch(&rim);
        for (k, col) in rim_ids.iter().enumerate() {
            for (j, n) in col.iter().enumerate() {
                if k == 0 || k == columns || j == col.len() - 1 {
                    b.mesh.fixed[*n] = true;
                }
            }
        }
        Self { mesh: b.mesh, teeth, flank_rolls: half.rolls }
    }

    /// Tooth 0 alone, held along its base lines (both halves):
    /// the tooth as a cantilever on a rigid foundation, meshed as in
    /// [`Self::sector`].
    pub fn tooth_alone(form: &ToothForm, density: &MeshDensity, level: usize) -> Self {
        Self::tooth_alone_on(form, density, level, BaseLine::RootChord)
    }

    /// [`Self::tooth_alone`] held along `base`.
    pub fn tooth_alone_on(form: &ToothForm, density: &MeshDensity, level: usize, base: BaseLine) -> Self {
        let d = density.at_level(level);
        let half = half_grids(form, &d, layer_radius(form), base);
        let mut b = Builder::new();
        let (ids, upper_elements) = b.patch(&half.tooth);
        let (low, _) = b.patch(&placed(&half.tooth, 0.0, true));
        for n in ids[0].iter().chain(&low[0]) {
            b.mesh.fixed[*n] = true;
        }
        let flank_nodes = ids.iter().map(|col| col[col.len() - 1]).collect();
        let teeth = vec![ToothMesh { index: 0, angle: 0.0, upper_elements, flank_nodes }];
        Self { mesh: b.mesh, teeth, flank_rolls: half.rolls }
    }

    /// The tooth with index `k`, if meshed.
    pub fn tooth(&self, k: i32) -> Option<&ToothMesh> {
        self.teeth.iter().find(|t| t.index == k)
    }
}

/// Turns a tooth-frame point or vector to the frame of a tooth at `angle` \[rad\].
pub fn to_tooth(p: Point, angle: f64) -> Point {
    turn(p, angle)
}
