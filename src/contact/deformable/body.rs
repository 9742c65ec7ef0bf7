//! The influence coefficients of a gear body from its finite-element model
//! ([`super::fe`], [`super::mesher`]), condensed to the flank grid.
//!
//! A unit normal force on the centre tooth's upper flank at each grid roll
//! angle ξ_b is one load case: a point force at the exact flank point,
//! pressing on the flank, turned into consistent nodal forces by the flank
//! edge's quadratic shape functions (the edge nodes sit at involute points
//! evenly spaced in ξ², so the edge coordinate of ξ is
//! s = 2(ξ² − ξ_0²)/(ξ_2² − ξ_0²) − 1). All cases share one factorisation.
//! For every tooth k within reach and every grid roll angle ξ_a, the
//! displacement of the point at the reference depth d(ξ_a) below the flank
//! point, along its inward normal, is read from the shape functions of the
//! element that holds it: A_k(ξ_a, ξ_b).
//!
//! The reference depth is d(ξ) = f · h(ξ), h = r ψ(r) the half circular
//! tooth thickness at the flank point's radius and f the depth fraction
//! (0.5 by default): deep enough that the mesh, graded toward the flank,
//! resolves the field there (several element thicknesses), shallow enough
//! that the point belongs to the loaded tooth's flank region. The local term
//! added to these coefficients is Johnson's line-contact approach of the
//! surface to a point at depth d (*Contact Mechanics*, 1985, eq. 5.43 in 2-D
//! form), which holds while d is a few contact half-widths.
//!
//! Reading the displacement at depth d under a load at the surface is not
//! exactly reciprocal (Maxwell–Betti pairs the load point with itself), and
//! the sector's cut faces break the turn symmetry between teeth k and −k;
//! both differ by the body's field over d, a few per cent of the diagonal.
//! The coefficients served are therefore the symmetric part,
//! C_k(a, b) = ½ (A_k(a, b) + A_−k(b, a)), so that every matrix of them is
//! symmetric; [`BodyCompliance::asymmetry`] reports what was removed.
//!
//! Per unit thickness the model returns u for a load of 1 N/m; over the
//! face width L the coefficient for 1 N is u / L \[m/N\].

use thiserror::Error;

use super::fe::{
    element_energy, interpolate_displacement, lagrange3, locate, FeError, FeSystem, PlaneStrain, Point,
};
use super::mesher::{to_tooth, GearMesh, MeshDensity};
use super::BodyInfluence;
use crate::geometry::profile::{involute_normal, involute_point, ProfileDeviation};
use crate::model::gear::{GearSet, Material, ToothForm};
use crate::model::involute::radius_at_roll;

/// Why a body's coefficients could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BodyError {
    /// A setting out of its range.
    #[error("body settings: {parameter} = {value}; allowed: {allowed}")]
    Settings {
        /// The setting's name.
        parameter: &'static str,
        /// Its value.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
    /// The finite-element model failed (a degenerate element, the material,
    /// the factorisation).
    #[error(transparent)]
    Fe(#[from] FeError),
    /// A point at the reference depth lies in no element of its tooth.
    #[error("the point at depth {depth:e} m below roll angle {roll} rad of tooth {tooth} lies in no element; the depth fraction must keep it inside the tooth")]
    Outside {
        /// Tooth index.
        tooth: i32,
        /// Roll angle \[rad\].
        roll: f64,
        /// Depth \[m\].
        depth: f64,
    },
}

/// How a body's model is built and read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySettings {
    /// Teeth each side of the loaded one whose coefficients are kept [-].
    pub reach: i32,
    /// Teeth meshed beyond the reach on each side, between the teeth read
    /// and the sector's held cut faces [-].
    pub buffer: i32,
    /// Refinement level ℓ: element counts of [`MeshDensity`] times ℓ [-].
    pub level: usize,
    /// Element counts at level 1.
    pub density: MeshDensity,
    /// Grid points on the involute, form circle to the involute's end [-].
    pub grid_points: usize,
    /// Reference depth over the half circular tooth thickness [-].
    pub depth_fraction: f64,
}

impl Default for BodySettings {
    /// Reach 2 with one buffer tooth each side, level 2 (the centre tooth's
    /// coefficients within 1 % of the Richardson limit, docs/DEFORMABLE.md),
    /// 30 grid points, depth 0.5 of the half tooth thickness.
    fn default() -> Self {
        Self {
            reach: 2,
            buffer: 1,
            level: 2,
            density: MeshDensity::default(),
            grid_points: 30,
            depth_fraction: 0.5,
        }
    }
}

impl BodySettings {
    fn check(&self) -> Result<(), BodyError> {
        let bad = |parameter, value: String, allowed| Err(BodyError::Settings { parameter, value, allowed });
        if self.reach < 0 || self.buffer < 0 {
            return bad(
                "reach/buffer",
                format!("{}/{}", self.reach, self.buffer),
                "non-negative tooth counts",
            );
        }
        if self.level == 0 || self.level > 16 {
            return bad("level", self.level.to_string(), "1 to 16");
        }
        if self.grid_points < 2 {
            return bad("grid_points", self.grid_points.to_string(), "at least 2");
        }
        if !(self.depth_fraction > 0.0 && self.depth_fraction < 0.9) {
            return bad("depth_fraction", self.depth_fraction.to_string(), "in (0, 0.9)");
        }
        let d = &self.density;
        if [d.fillet, d.involute, d.across, d.land, d.root, d.rim].contains(&0)
            || !(d.flank_grading > 0.0 && d.rim_grading > 0.0)
        {
            return bad("density", format!("{d:?}"), "element counts of at least 1, positive gradings");
        }
        Ok(())
    }
}

/// A gear body's finite-element model, factorised, with the readings of its
/// flanks.
#[derive(Debug)]
pub struct BodyModel {
    /// The mesh.
    pub mesh: GearMesh,
    /// The factorised stiffness.
    pub system: FeSystem,
    /// The elastic constants.
    pub elastic: PlaneStrain,
    form: ToothForm,
}

/// Where a flank roll angle lies on the flank grid: the three nodes of its
/// edge (grid positions) and the shape-function values there.
fn flank_edge(rolls: &[Option<f64>], roll: f64) -> ([usize; 3], [f64; 3]) {
    let first = rolls.iter().position(Option::is_some).unwrap_or(0);
    let r = |k: usize| rolls[k].unwrap_or(0.0);
    let last = rolls.len() - 1;
    let (lo, hi) = (r(first).min(r(last)), r(first).max(r(last)));
    let x = roll.clamp(lo, hi);
    let mut start = first;
    while start + 2 < last && (x - r(start)) * (x - r(start + 2)) > 0.0 {
        start += 2;
    }
    let (a, b) = (r(start), r(start + 2));
    let s = (2.0 * (x * x - a * a) / (b * b - a * a) - 1.0).clamp(-1.0, 1.0);
    ([start, start + 1, start + 2], lagrange3(s).0)
}

impl BodyModel {
    /// The sector model of a body: teeth −`side`..=`side`, refinement `level`.
    pub fn sector(
        form: &ToothForm,
        material: &Material,
        density: &MeshDensity,
        level: usize,
        side: i32,
    ) -> Result<Self, BodyError> {
        let mesh = GearMesh::sector(form, density, level, side);
        Self::from_mesh(form, material, mesh)
    }

    /// Tooth 0 alone, held along its root chord, meshed as in the sector.
    pub fn tooth_alone(
        form: &ToothForm,
        material: &Material,
        density: &MeshDensity,
        level: usize,
    ) -> Result<Self, BodyError> {
        Self::from_mesh(form, material, GearMesh::tooth_alone(form, density, level))
    }

    /// The model of a given mesh (its held nodes as set in it).
    pub fn from_mesh(form: &ToothForm, material: &Material, mesh: GearMesh) -> Result<Self, BodyError> {
        let elastic = PlaneStrain::new(material.youngs_modulus, material.poisson_ratio)?;
        let system = FeSystem::new(&mesh.mesh, &elastic)?;
        Ok(Self { mesh, system, elastic, form: form.clone() })
    }

    /// Inward unit normal (the direction of a pressing load) of tooth `k`'s
    /// upper flank at roll angle `roll` \[rad\], gear frame.
    pub fn inward_normal(&self, k: i32, roll: f64) -> Point {
        // The inward normal points from the upper flank toward the tooth's
        // centreline (−y in the tooth frame), for external and internal teeth.
        let n = involute_normal(&self.form, roll);
        let s = if n[1] > 0.0 { -1.0 } else { 1.0 };
        to_tooth([s * n[0], s * n[1]], f64::from(k) * self.form.angular_pitch())
    }

    /// Nodal forces \[N/m\] of a unit normal force per unit thickness pressing
    /// on tooth `k`'s upper flank at roll angle `roll` \[rad\].
    pub fn unit_load(&self, k: i32, roll: f64) -> Vec<(usize, Point)> {
        let Some(tooth) = self.mesh.tooth(k) else { return Vec::new() };
        let (grid, weights) = flank_edge(&self.mesh.flank_rolls, roll);
        let n = self.inward_normal(k, roll);
        grid.iter().zip(weights).map(|(g, w)| (tooth.flank_nodes[*g], [w * n[0], w * n[1]])).collect()
    }

    /// Displacement \[m\] along the inward normal of the flank point of tooth
    /// `k` at `roll` \[rad\] (the load's work conjugate) in load case `case`.
    pub fn surface_displacement(&self, solution: &faer::Mat<f64>, case: usize, k: i32, roll: f64) -> f64 {
        self.unit_load(k, roll)
            .iter()
            .map(|(node, f)| {
                let u = self.system.displacement(solution, case, *node);
                u[0] * f[0] + u[1] * f[1]
            })
            .sum()
    }

    /// The element and local coordinates of the point `depth` \[m\] below the
    /// flank point of tooth `k` at `roll` \[rad\].
    pub fn depth_point(&self, k: i32, roll: f64, depth: f64) -> Result<(usize, f64, f64), BodyError> {
        let outside = BodyError::Outside { tooth: k, roll, depth };
        let tooth = self.mesh.tooth(k).ok_or(outside.clone())?;
        let p = to_tooth(involute_point(&self.form, roll, &ProfileDeviation::none()), tooth.angle);
        let n = self.inward_normal(k, roll);
        let q = [p[0] + depth * n[0], p[1] + depth * n[1]];
        for &e in &tooth.upper_elements {
            let x = self.mesh.mesh.element_nodes(e);
            let (lo, hi) = x.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), p| {
                ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
            });
            let pad = 0.1 * (hi[0] - lo[0] + hi[1] - lo[1]);
            if q[0] < lo[0] - pad || q[0] > hi[0] + pad || q[1] < lo[1] - pad || q[1] > hi[1] + pad {
                continue;
            }
            if let Some((xi, eta)) = locate(&x, q) {
                return Ok((e, xi, eta));
            }
        }
        Err(outside)
    }

    /// Displacement \[m\] of a located point along `direction` in load case `case`.
    pub fn point_displacement(
        &self,
        solution: &faer::Mat<f64>,
        case: usize,
        at: (usize, f64, f64),
        direction: Point,
    ) -> f64 {
        let u = self.system.element_displacements(&self.mesh.mesh, solution, case, at.0);
        let v = interpolate_displacement(&u, at.1, at.2);
        v[0] * direction[0] + v[1] * direction[1]
    }

    /// Strain energy of load case `case` per unit thickness \[J/m\], summed
    /// element by element from the Gauss-point strains and stresses.
    pub fn strain_energy(&self, solution: &faer::Mat<f64>, case: usize) -> f64 {
        (0..self.mesh.mesh.elements.len())
            .map(|e| {
                let x = self.mesh.mesh.element_nodes(e);
                let u = self.system.element_displacements(&self.mesh.mesh, solution, case, e);
                element_energy(&x, &u, &self.elastic)
            })
            .sum()
    }
}

/// A gear body's influence coefficients on its flank grid.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyCompliance {
    rolls: Vec<f64>,
    depths: Vec<f64>,
    reach: i32,
    /// Symmetric part, per offset −reach..=reach, row-major (read, load) \[m/N\].
    table: Vec<Vec<f64>>,
    /// As read, same layout \[m/N\].
    raw: Vec<Vec<f64>>,
    dofs: usize,
}

/// The half circular tooth thickness at the radius of roll angle `roll` \[m\].
fn half_thickness(form: &ToothForm, roll: f64) -> f64 {
    let r = radius_at_roll(roll, form.base_radius());
    r * form.involute_half_angle(r)
}

impl BodyCompliance {
    /// Builds the coefficients of the body of `form` in `material`.
    pub fn new(form: &ToothForm, material: &Material, settings: &BodySettings) -> Result<Self, BodyError> {
        settings.check()?;
        let side = settings.reach + settings.buffer;
        if 2 * side + 1 > form.teeth as i32 {
            return Err(BodyError::Settings {
                parameter: "reach + buffer",
                value: side.to_string(),
                allowed: "at most (teeth - 1)/2: the sector holds 2(reach + buffer) + 1 teeth",
            });
        }
        let model = BodyModel::sector(form, material, &settings.density, settings.level, side)?;
        let m = settings.grid_points;
        let (x0, x1) = model_roll_range(&model);
        let rolls: Vec<f64> = (0..m).map(|k| x0 + (x1 - x0) * k as f64 / (m - 1) as f64).collect();
        let depths: Vec<f64> =
            rolls.iter().map(|x| settings.depth_fraction * half_thickness(form, *x)).collect();
        let cases: Vec<_> = rolls.iter().map(|x| model.unit_load(0, *x)).collect();
        let solution = model.system.solve(&cases);
        let width = form.face_width;
        let reach = settings.reach;
        let mut raw = Vec::with_capacity(2 * reach as usize + 1);
        for k in -reach..=reach {
            let mut t = vec![0.0; m * m];
            for (a, (x, d)) in rolls.iter().zip(&depths).enumerate() {
                let at = model.depth_point(k, *x, *d)?;
                let n = model.inward_normal(k, *x);
                for b in 0..m {
                    t[a * m + b] = model.point_displacement(&solution, b, at, n) / width;
                }
            }
            raw.push(t);
        }
        let table = (0..raw.len())
            .map(|k| {
                let mirror = &raw[raw.len() - 1 - k];
                (0..m * m).map(|ab| 0.5 * (raw[k][ab] + mirror[(ab % m) * m + ab / m])).collect()
            })
            .collect();
        Ok(Self { rolls, depths, reach, table, raw, dofs: model.system.free_dofs() })
    }

    /// The three bodies of a gear set (sun, planet, ring), built in parallel.
    pub fn of_gear_set(set: &GearSet, settings: &BodySettings) -> Result<[Self; 3], BodyError> {
        let m = set.material();
        let build = |f: &ToothForm| Self::new(f, m, settings);
        let (sun, (planet, ring)) =
            rayon::join(|| build(set.sun()), || rayon::join(|| build(set.planet()), || build(set.ring())));
        Ok([sun?, planet?, ring?])
    }

    /// The grid's roll angles, increasing \[rad\].
    pub fn rolls(&self) -> &[f64] {
        &self.rolls
    }

    /// Free degrees of freedom of the finite-element model [-].
    pub fn degrees_of_freedom(&self) -> usize {
        self.dofs
    }

    /// The coefficient as read, before symmetrisation, on the grid: tooth
    /// offset `k`, read at grid point `a`, loaded at grid point `b` \[m/N\].
    pub fn raw_coefficient(&self, k: i32, a: usize, b: usize) -> f64 {
        let m = self.rolls.len();
        self.raw[(k + self.reach) as usize][a * m + b]
    }

    /// The largest removed asymmetry, |A_k(a, b) − A_−k(b, a)| over
    /// √(A_0(a, a) A_0(b, b)), over the grid and the offsets [-].
    pub fn asymmetry(&self) -> f64 {
        let m = self.rolls.len();
        let mut worst: f64 = 0.0;
        for k in -self.reach..=self.reach {
            for a in 0..m {
                for b in 0..m {
                    let d = self.raw_coefficient(k, a, b) - self.raw_coefficient(-k, b, a);
                    let scale = (self.raw_coefficient(0, a, a) * self.raw_coefficient(0, b, b)).sqrt();
                    worst = worst.max(d.abs() / scale);
                }
            }
        }
        worst
    }

    /// Position of `roll` on the grid: the lower index and the fraction.
    fn cell(&self, roll: f64) -> (usize, f64) {
        let m = self.rolls.len();
        let x = roll.clamp(self.rolls[0], self.rolls[m - 1]);
        let i = self.rolls.partition_point(|r| *r <= x).clamp(1, m - 1) - 1;
        (i, (x - self.rolls[i]) / (self.rolls[i + 1] - self.rolls[i]))
    }
}

/// The involute's roll-angle range of a model's flank grid, increasing \[rad\].
fn model_roll_range(model: &BodyModel) -> (f64, f64) {
    let rolls: Vec<f64> = model.mesh.flank_rolls.iter().flatten().copied().collect();
    let (a, b) = (rolls[0], rolls[rolls.len() - 1]);
    (a.min(b), a.max(b))
}

impl BodyInfluence for BodyCompliance {
    fn coefficient(&self, i: i32, roll_i: f64, j: i32, roll_j: f64) -> f64 {
        let k = i - j;
        if k.abs() > self.reach {
            return 0.0;
        }
        let t = &self.table[(k + self.reach) as usize];
        let m = self.rolls.len();
        let (a, s) = self.cell(roll_i);
        let (b, u) = self.cell(roll_j);
        let at = |a: usize, b: usize| t[a * m + b];
        (1.0 - s) * ((1.0 - u) * at(a, b) + u * at(a, b + 1))
            + s * ((1.0 - u) * at(a + 1, b) + u * at(a + 1, b + 1))
    }

    fn reference_depth(&self, roll: f64) -> f64 {
        let (i, s) = self.cell(roll);
        (1.0 - s) * self.depths[i] + s * self.depths[i + 1]
    }

    fn reach(&self) -> i32 {
        self.reach
    }
}
