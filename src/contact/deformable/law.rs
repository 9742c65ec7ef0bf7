//! The deformable mesh law: the contact of every tooth pair of one mesh
//! solved together, F(s, δ).
//!
//! A mesh with its reference pair at drive position s and approach δ along
//! the line of action (positive: drive flanks pressed, as in
//! [`crate::contact::ltca::MeshModel`]) has candidate pairs k at
//! s + k·p_b, on either flank, wherever the separation tables hold a finite
//! gap. On one flank (σ = +1 drive, −1 back) the pair forces p ≥ 0 satisfy
//!
//!   C p + φ(p) + g − σδ·1 ≥ 0  ⊥  p ≥ 0,
//!
//! C_ab = C¹_ab + C²_ab the two bodies' influence coefficients
//! ([`BodyInfluence`]) at the pairs' contact points, g_a the unloaded gap
//! (separation table, edge relief included, read exactly as the pair model
//! reads it) and φ the local approach of each contact's surfaces to the
//! reference depths, Johnson (*Contact Mechanics*, 1985, §5.6, the 2-D
//! approach of a point at depth d below a Hertzian line contact):
//!
//!   φ(P) = P/(πL) · Σ_k (1 − ν_k²)/E_k · (2 ln(2 d_k / b) − ν_k/(1 − ν_k)),
//!
//! b the Hertz half-width at the line load P/L with the pair's radii of
//! curvature ([`crate::contact::hertz`]), d_k the body's reference depth.
//! With b ∝ √P this is φ(P) = P (a − c ln P), c = Σ_k (1 − ν_k²)/(π E_k L)
//! ([`LocalLaw`]). The mesh force is F = Σ p_drive − Σ p_back.
//!
//! Pair index → tooth index. Gear 1 drives forward (counter-clockwise in
//! the canonical frame of [`crate::contact::separation`]); the contact
//! travels towards larger s, so the pair at s + p_b is the gear-1 tooth
//! that entered one pitch earlier, the one ahead in gear 1's rotation. Gear
//! 1's drive flank pushes, so it faces forward: pair k is gear-1 tooth +k in
//! the convention of [`BodyInfluence`]. Gear 2's drive flank is pushed, so it
//! faces backward against gear 2's rotation, while the pair further along
//! the path is again the gear-2 tooth ahead in rotation: pair k is gear-2
//! tooth −k. The back flanks face the other way: pair k is gear-1 tooth −k
//! and gear-2 tooth +k. (The same holds for the internal ring, which turns
//! the same way as the planet it meshes with.)
//!
//! The two flanks' problems are solved separately: a body's coefficients
//! between a drive and a back flank point are not part of
//! [`BodyInfluence`], and both flanks of one mesh touch at once only when
//! their gaps interfere (g_drive + g_back < 0), which unworn and worn
//! tables never show.
//!
//! Interpolation on the separation grid: the coefficients are sampled at the
//! grid's positions of the reference pair, per flank and tooth offset, and
//! read with the grid's cell and weights. A pair's own compliance is stored
//! as its reciprocal (a stiffness) and interpolated linearly, as the pair
//! model interpolates its pair stiffness: without coupling and with a linear
//! local term the law is then the pair model exactly.

use thiserror::Error;

use crate::contact::deformable::lcp::{
    solve_lcp, solve_with_local, LcpError, LcpSolution, LocalLaw, LocalSolution,
};
use crate::contact::deformable::BodyInfluence;
use crate::contact::hertz::{contact_modulus, line_contact, LineContact};
use crate::contact::ltca::{MeshLaw, TABLE_SAMPLES_PER_PITCH};
use crate::contact::separation::{MeshFlanks, MeshSeparation, NO_CONTACT};
use crate::model::gear::{GearKind, GearSet, MeshKind};
use crate::model::mesh::PathOfContact;

/// Why the deformable mesh law could not be built or evaluated.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum DeformableError {
    /// The complementarity problem of the pairs failed.
    #[error("pair contact: {0}")]
    Lcp(#[from] LcpError),
    /// An argument is NaN or infinite.
    #[error("{name} is {value}; it must be finite")]
    NotFinite {
        /// The argument's name.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A body's coefficient or reference depth is not usable.
    #[error(
        "the {gear} body gives {what} = {value} at roll angle {roll} rad; it must be finite and positive"
    )]
    BadBody {
        /// "gear 1" or "gear 2".
        gear: &'static str,
        /// "own coefficient" or "reference depth".
        what: &'static str,
        /// The value returned.
        value: f64,
        /// The roll angle asked \[rad\].
        roll: f64,
    },
    /// A setting is outside its range.
    #[error("{name} = {value}; allowed: {allowed}")]
    Setting {
        /// The setting's name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What is allowed.
        allowed: &'static str,
    },
    /// A finite-element body could not be built.
    #[error("gear body: {0}")]
    Body(String),
    /// The mesh never carries the asked load.
    #[error("the mesh does not carry {load} N at any approach up to {approach} m")]
    LoadNotReached {
        /// The load asked \[N\].
        load: f64,
        /// The largest approach tried \[m\].
        approach: f64,
    },
}

/// The local term on each pair's diagonal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LocalContact {
    /// A constant compliance [m/N], e.g. the pair model's
    /// [`crate::contact::stiffness::hertz_compliance`].
    Linear {
        /// The compliance [m/N].
        compliance: f64,
    },
    /// Johnson's 2-D approach of the surfaces to the bodies' reference
    /// depths (the module's equation).
    Johnson,
}

/// Which flank pair touches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flank {
    /// The drive flanks (positive force).
    Drive,
    /// The back flanks (negative force).
    Back,
}

impl Flank {
    fn slot(self) -> usize {
        match self {
            Flank::Drive => 0,
            Flank::Back => 1,
        }
    }

    /// The sign σ of the flank's force and approach [-].
    pub fn sign(self) -> f64 {
        match self {
            Flank::Drive => 1.0,
            Flank::Back => -1.0,
        }
    }
}

/// One candidate pair of a solved mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeformablePair {
    /// Pair index k; the pair sits at drive position s + k·p_b.
    pub index: i32,
    /// Drive position of the pair \[m\].
    pub position: f64,
    /// Position of its contact point on its own line of action \[m\] (the
    /// drive position, or `back_mirror − position` on the back flank).
    pub contact_position: f64,
    /// The flank the pair was solved on.
    pub flank: Flank,
    /// Force along the line of action \[N\]: positive on the drive flank,
    /// negative on the back flank, zero when open.
    pub force: f64,
    /// Unloaded gap, edge relief included \[m\].
    pub gap: f64,
    /// Remaining gap of an open pair, zero for a loaded one \[m\].
    pub separation: f64,
    /// Hertzian band of the pair's line load at its contact point.
    pub hertz: LineContact,
}

/// All pairs of a mesh at one (s, δ) and the mesh law there.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeformableState {
    /// The candidate pairs, drive flank first.
    pub pairs: Vec<DeformablePair>,
    /// Mesh force and its exact derivatives (active sets frozen).
    pub law: MeshLaw,
}

impl DeformableState {
    /// Pairs carrying load.
    pub fn loaded(&self) -> usize {
        self.pairs.iter().filter(|p| p.force != 0.0).count()
    }

    /// The force \[N\] of pair `index` (either flank; zero when absent or open).
    pub fn pair_force(&self, index: i32) -> f64 {
        self.pairs.iter().filter(|p| p.index == index).map(|p| p.force).sum()
    }
}

/// The coefficients of one flank sampled on the separation grid.
#[derive(Clone, Debug, Default)]
pub(crate) struct FlankCoefficients {
    /// Reciprocal of a pair's own compliance C¹_aa + C²_aa (+ a linear local
    /// compliance) [N/m], at each grid position.
    pub(crate) own_stiffness: Vec<f64>,
    /// Cross compliance of the pair at the grid position and the pair m
    /// pitches further along the path, `cross[m − 1]` [m/N].
    pub(crate) cross: Vec<Vec<f64>>,
    /// Constant part a of the local law [m/N] (Johnson only).
    pub(crate) local_a: Vec<f64>,
}

/// The deformable contact law of one mesh.
#[derive(Clone, Debug)]
pub struct DeformableMesh {
    /// Separation tables (the unloaded gaps).
    pub separation: MeshSeparation,
    /// The local term.
    pub local: LocalContact,
    face_width: f64,
    reach: i32,
    flanks: [FlankCoefficients; 2],
    /// Logarithmic part c of Johnson's law [m/N] (0 for a linear term).
    local_c: f64,
    e_star: f64,
}

/// Pair loads below this fraction of the mesh's scale count as zero in the
/// nonlinear iteration, and open pairs' tangents are read there [-].
const FLOOR_FRACTION: f64 = 1e-9;

/// Relative step at which the nonlinear iteration stops [-].
pub const NEWTON_TOLERANCE: f64 = 1e-13;

/// Scale of the pair loads \[N\]: the load that closes 10 µm at a pair's own
/// stiffness (the floor of the nonlinear iteration is a fraction of it).
const LOAD_SCALE_APPROACH: f64 = 1e-5;

impl DeformableMesh {
    /// The law of mesh `mesh` of `set` with bodies `gear1`, `gear2`, flanks
    /// `flanks` (wear deviations) and local term `local`.
    pub fn new(
        set: &GearSet,
        mesh: MeshKind,
        gear1: &dyn BodyInfluence,
        gear2: &dyn BodyInfluence,
        flanks: &MeshFlanks,
        local: LocalContact,
    ) -> Result<Self, DeformableError> {
        let path = PathOfContact::new(set, mesh);
        let step = path.base_pitch / TABLE_SAMPLES_PER_PITCH as f64;
        let separation = crate::contact::cache::separation(set, mesh, flanks, step);
        let (g1, g2) = set.mesh_gears(mesh);
        let face_width = g1.face_width.min(g2.face_width);
        let m = set.material();
        let e_star = contact_modulus(m.youngs_modulus, m.poisson_ratio, m.youngs_modulus, m.poisson_ratio);
        let linear = match local {
            LocalContact::Linear { compliance } => {
                if !(compliance.is_finite() && compliance >= 0.0) {
                    return Err(DeformableError::Setting {
                        name: "linear local compliance",
                        value: compliance,
                        allowed: "finite and ≥ 0 m/N",
                    });
                }
                Some(compliance)
            }
            LocalContact::Johnson => None,
        };
        let local_c = if linear.is_some() { 0.0 } else { 1.0 / (std::f64::consts::PI * e_star * face_width) };
        // Pairs further apart than the tables hold never meet in one problem.
        let span = ((separation.drive.end() - separation.drive.start) / path.base_pitch).ceil() as i32;
        let reach = gear1.reach().max(gear2.reach()).clamp(0, span.max(0));
        let mut mesh_law =
            Self { separation, local, face_width, reach, flanks: Default::default(), local_c, e_star };
        for flank in [Flank::Drive, Flank::Back] {
            mesh_law.flanks[flank.slot()] = mesh_law.sample_flank(flank, gear1, gear2, linear, m)?;
        }
        Ok(mesh_law)
    }

    /// The path of contact.
    pub fn path(&self) -> &PathOfContact {
        &self.separation.path
    }

    /// Face width carried by the mesh \[m\].
    pub fn face_width(&self) -> f64 {
        self.face_width
    }

    /// Contact position on the flank's own line of action of a pair at drive position `pos` \[m\].
    fn contact_position(&self, flank: Flank, pos: f64) -> f64 {
        match flank {
            Flank::Drive => pos,
            Flank::Back => self.separation.back_mirror - pos,
        }
    }

    /// Tooth index of pair offset `m` in gear 1's and gear 2's convention on `flank`.
    fn tooth_offsets(flank: Flank, m: i32) -> (i32, i32) {
        match flank {
            Flank::Drive => (m, -m),
            Flank::Back => (-m, m),
        }
    }

    /// Samples one flank's coefficients on the separation grid.
    fn sample_flank(
        &self,
        flank: Flank,
        gear1: &dyn BodyInfluence,
        gear2: &dyn BodyInfluence,
        linear: Option<f64>,
        material: &crate::model::gear::Material,
    ) -> Result<FlankCoefficients, DeformableError> {
        let path = self.path().clone();
        let pb = path.base_pitch;
        let rolls = |pos: f64| {
            let q = self.contact_position(flank, pos);
            (path.roll_1(q), path.roll_2(q))
        };
        // The symmetric part of the two bodies' coefficient between the pair at `pos` and the
        // pair m pitches further: each body read with the loaded tooth as 0 both ways.
        let coefficient = |pos: f64, m: i32| {
            let (a1, a2) = rolls(pos);
            let (b1, b2) = rolls(pos + f64::from(m) * pb);
            let (i1, i2) = Self::tooth_offsets(flank, m);
            let c1 = 0.5 * (gear1.coefficient(i1, b1, 0, a1) + gear1.coefficient(-i1, a1, 0, b1));
            let c2 = 0.5 * (gear2.coefficient(i2, b2, 0, a2) + gear2.coefficient(-i2, a2, 0, b2));
            c1 + c2
        };
        let positions: Vec<f64> = self.separation.drive.positions().collect();
        let mut out = FlankCoefficients::default();
        for &pos in &positions {
            let own = coefficient(pos, 0) + linear.unwrap_or(0.0);
            if !(own.is_finite() && own > 0.0) {
                let (r1, _) = rolls(pos);
                return Err(DeformableError::BadBody {
                    gear: "gear 1",
                    what: "own coefficient",
                    value: own,
                    roll: r1,
                });
            }
            out.own_stiffness.push(1.0 / own);
        }
        for m in 1..=self.reach {
            out.cross.push(positions.iter().map(|&pos| coefficient(pos, m)).collect());
        }
        if linear.is_none() {
            for &pos in &positions {
                out.local_a.push(self.johnson_constant(flank, pos, gear1, gear2, material)?);
            }
        }
        Ok(out)
    }

    /// Effective radius R' \[m\] of the pair at drive position `pos` on `flank`
    /// (the contact point clamped to the involutes, as the pair model's Hertz
    /// band is); infinite where the flanks are not convex towards each other.
    fn effective_radius(&self, flank: Flank, pos: f64) -> (f64, f64) {
        let p = self.path();
        let q = self.contact_position(flank, pos).clamp(p.start, p.end);
        (p.rho_1(q), p.rho_2(q))
    }

    /// The constant a [m/N] of Johnson's law at drive position `pos`:
    /// a = 1/(πL) [Σ_k A_k (2 ln 2d_k − ν/(1 − ν)) − (Σ_k A_k) ln(4R'/(π E* L))],
    /// A_k = (1 − ν²)/E.
    fn johnson_constant(
        &self,
        flank: Flank,
        pos: f64,
        gear1: &dyn BodyInfluence,
        gear2: &dyn BodyInfluence,
        material: &crate::model::gear::Material,
    ) -> Result<f64, DeformableError> {
        let q = self.contact_position(flank, pos);
        let p = self.path();
        let (r1, r2) = (p.roll_1(q), p.roll_2(q));
        let nu = material.poisson_ratio;
        let compliance = (1.0 - nu * nu) / material.youngs_modulus;
        let mut sum = 0.0;
        for (gear, body, roll) in [("gear 1", gear1, r1), ("gear 2", gear2, r2)] {
            let d = body.reference_depth(roll);
            if !(d.is_finite() && d > 0.0) {
                return Err(DeformableError::BadBody { gear, what: "reference depth", value: d, roll });
            }
            sum += compliance * (2.0 * (2.0 * d).ln() - nu / (1.0 - nu));
        }
        let (rho1, rho2) = self.effective_radius(flank, pos);
        let curvature = 1.0 / rho1 + if p.kind == GearKind::Internal { -1.0 / rho2 } else { 1.0 / rho2 };
        let r_eff = 1.0 / curvature.max(1e-300);
        let l = self.face_width;
        let log_term = (4.0 * r_eff / (std::f64::consts::PI * self.e_star * l)).ln();
        Ok((sum - 2.0 * compliance * log_term) / (std::f64::consts::PI * l))
    }

    /// The local law of the pair at drive position `pos` on `flank` (zero for
    /// a linear term, which sits in the own stiffness).
    pub fn local_law(&self, flank: Flank, pos: f64) -> LocalLaw {
        let f = &self.flanks[flank.slot()];
        if f.local_a.is_empty() {
            return LocalLaw::default();
        }
        let (i, t) = self.separation.drive.cell(pos);
        LocalLaw { a: f.local_a[i] + t * (f.local_a[i + 1] - f.local_a[i]), c: self.local_c }
    }

    /// Hertzian band of a pair load `force` \[N\] at drive position `pos` on `flank`.
    pub fn hertz(&self, flank: Flank, pos: f64, force: f64) -> LineContact {
        let (rho1, rho2) = self.effective_radius(flank, pos);
        line_contact(
            force.abs() / self.face_width,
            rho1,
            rho2,
            self.path().kind == GearKind::Internal,
            self.e_star,
        )
    }

    /// Range of pair indices whose drive position s + k·p_b lies in the tables.
    pub(crate) fn pair_range(&self, s: f64) -> std::ops::RangeInclusive<i32> {
        let t = &self.separation.drive;
        let pb = self.path().base_pitch;
        let lo = -((s - t.start) / pb).floor();
        let hi = ((t.end() - s) / pb).floor();
        if !(lo.is_finite() && hi.is_finite()) || hi < lo {
            // An empty range (start above end): no pair lies in the tables.
            let (start, end) = (1, 0);
            return start..=end;
        }
        (lo as i32)..=(hi as i32)
    }

    /// The gap \[m\] of the pair at drive position `pos` on `flank` and its
    /// derivative along s [-], edge relief included; `None` where the table
    /// says no contact.
    pub fn gap(&self, flank: Flank, pos: f64) -> Option<(f64, f64)> {
        let grid = &self.separation.drive;
        let (i, t) = grid.cell(pos);
        let (values, (r, dr)) = match flank {
            Flank::Drive => (&self.separation.drive.values, self.separation.drive_relief_at(pos)),
            Flank::Back => (&self.separation.back.values, self.separation.back_relief_at(pos)),
        };
        let g = values[i] + t * (values[i + 1] - values[i]);
        if g < NO_CONTACT {
            Some((g + r, (values[i + 1] - values[i]) / grid.step + dr))
        } else {
            None
        }
    }

    /// Compliance C_ab [m/N] between the pairs at indices `ka`, `kb` (s the
    /// reference position) on `flank`, and its derivative along s [m/(N·m)].
    fn compliance(&self, flank: Flank, s: f64, ka: i32, kb: i32) -> (f64, f64) {
        let f = &self.flanks[flank.slot()];
        let grid = &self.separation.drive;
        let pb = self.path().base_pitch;
        let first = ka.min(kb);
        let m = (ka - kb).unsigned_abs() as usize;
        let (i, t) = grid.cell(s + f64::from(first) * pb);
        let inv_step = 1.0 / grid.step;
        if m == 0 {
            let v = &f.own_stiffness;
            let k = v[i] + t * (v[i + 1] - v[i]);
            let dk = (v[i + 1] - v[i]) * inv_step;
            (1.0 / k, -dk / (k * k))
        } else if m <= f.cross.len() {
            let v = &f.cross[m - 1];
            (v[i] + t * (v[i + 1] - v[i]), (v[i + 1] - v[i]) * inv_step)
        } else {
            (0.0, 0.0)
        }
    }

    /// Scale of the pair loads \[N\] (the floor of the nonlinear iteration is a fraction of it).
    fn load_scale(&self) -> f64 {
        let k = self.flanks[0].own_stiffness.iter().cloned().fold(0.0, f64::max);
        k * LOAD_SCALE_APPROACH
    }
}

/// One flank's problem at one (s, δ), with its workspace.
#[derive(Clone, Debug, Default)]
pub(crate) struct FlankProblem {
    pub(crate) index: Vec<i32>,
    pub(crate) position: Vec<f64>,
    pub(crate) gap: Vec<f64>,
    pub(crate) gap_slope: Vec<f64>,
    pub(crate) a: Vec<f64>,
    pub(crate) q: Vec<f64>,
    pub(crate) local: Vec<LocalLaw>,
    pub(crate) linear: LcpSolution,
    pub(crate) nonlinear: LocalSolution,
}

/// One flank's solution: mesh-force contribution and its derivatives.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct FlankLaw {
    pub(crate) force: f64,
    pub(crate) approach_stiffness: f64,
    pub(crate) position_derivative: f64,
    pub(crate) peak: f64,
}

impl DeformableMesh {
    /// Sets up and solves one flank's problem at (s, δ) in `work`; the pair
    /// forces (≥ 0) are left in `work.linear.p` or `work.nonlinear.lcp.p`.
    pub(crate) fn solve_flank(
        &self,
        flank: Flank,
        s: f64,
        delta: f64,
        work: &mut FlankProblem,
    ) -> Result<FlankLaw, DeformableError> {
        let pb = self.path().base_pitch;
        work.index.clear();
        work.position.clear();
        work.gap.clear();
        work.gap_slope.clear();
        for k in self.pair_range(s) {
            let pos = s + f64::from(k) * pb;
            if let Some((g, dg)) = self.gap(flank, pos) {
                work.index.push(k);
                work.position.push(pos);
                work.gap.push(g);
                work.gap_slope.push(dg);
            }
        }
        let n = work.index.len();
        work.a.clear();
        work.q.clear();
        work.local.clear();
        for r in 0..n {
            for c in 0..n {
                work.a.push(self.compliance(flank, s, work.index[r], work.index[c]).0);
            }
            work.q.push(work.gap[r] - flank.sign() * delta);
            work.local.push(self.local_law(flank, work.position[r]));
        }
        let nonlinear = self.local_c > 0.0;
        if nonlinear {
            // Warm start from the linear problem's active set is not needed: J is convex.
            work.nonlinear.lcp.p.clear();
            let floor = FLOOR_FRACTION * self.load_scale();
            solve_with_local(&work.a, &work.q, &work.local, NEWTON_TOLERANCE, floor, &mut work.nonlinear)?;
        } else {
            work.linear.active.clear();
            solve_lcp(&work.a, &work.q, &mut work.linear)?;
        }
        Ok(self.flank_derivatives(flank, s, work))
    }

    /// The flank's force and its derivatives with the active set frozen:
    /// H = C_SS + diag(φ'(p_S)); ∂p_S/∂δ = σ H⁻¹1; ∂p_S/∂s = −H⁻¹(C' p + ∂φ/∂s + g')_S.
    fn flank_derivatives(&self, flank: Flank, s: f64, work: &FlankProblem) -> FlankLaw {
        let nonlinear = self.local_c > 0.0;
        let p: &[f64] = if nonlinear { &work.nonlinear.lcp.p } else { &work.linear.p };
        let n = p.len();
        let set: Vec<usize> = (0..n).filter(|&i| p[i] > 0.0).collect();
        let mut law = FlankLaw {
            force: flank.sign() * p.iter().sum::<f64>(),
            peak: p.iter().cloned().fold(0.0, f64::max),
            ..FlankLaw::default()
        };
        if set.is_empty() {
            return law;
        }
        let m = set.len();
        let mut h = vec![0.0; m * m];
        let mut rhs_s = vec![0.0; m];
        for (r, &i) in set.iter().enumerate() {
            for (c, &j) in set.iter().enumerate() {
                h[r * m + c] = work.a[i * n + j];
            }
            if nonlinear {
                h[r * m + r] += work.local[i].tangent(p[i]);
            }
            let mut v = work.gap_slope[i];
            for &j in &set {
                v += self.compliance(flank, s, work.index[i], work.index[j]).1 * p[j];
            }
            if nonlinear {
                // ∂φ/∂s = p·a'(s): the constant a follows the contact point; c does not.
                let (ci, _) = self.separation.drive.cell(work.position[i]);
                let a = &self.flanks[flank.slot()].local_a;
                v += p[i] * (a[ci + 1] - a[ci]) / self.separation.drive.step;
            }
            rhs_s[r] = -v;
        }
        let mut ones = vec![1.0; m];
        let mut work_chol = Vec::new();
        let all: Vec<usize> = (0..m).collect();
        // H is SPD (C_SS is, and φ' > 0 where the solver accepted the loads).
        if crate::contact::deformable::lcp::solve_spd(&h, &all, &mut ones, &mut work_chol).is_err()
            || crate::contact::deformable::lcp::solve_spd(&h, &all, &mut rhs_s, &mut work_chol).is_err()
        {
            return law;
        }
        law.approach_stiffness = ones.iter().sum();
        law.position_derivative = flank.sign() * rhs_s.iter().sum::<f64>();
        law
    }

    /// Every pair's force and the mesh law at reference position `s` \[m\]
    /// and approach `delta` \[m\], solved exactly (no table).
    pub fn solve(&self, s: f64, delta: f64) -> Result<DeformableState, DeformableError> {
        check_finite("position s", s)?;
        check_finite("approach delta", delta)?;
        let mut out = DeformableState::default();
        let mut work = FlankProblem::default();
        for flank in [Flank::Drive, Flank::Back] {
            let law = self.solve_flank(flank, s, delta, &mut work)?;
            out.law.force += law.force;
            out.law.approach_stiffness += law.approach_stiffness;
            out.law.position_derivative += law.position_derivative;
            out.law.peak_pair_force = out.law.peak_pair_force.max(law.peak);
            let nonlinear = self.local_c > 0.0;
            let (p, w): (&[f64], &[f64]) = if nonlinear {
                (&work.nonlinear.lcp.p, &work.nonlinear.lcp.w)
            } else {
                (&work.linear.p, &work.linear.w)
            };
            for r in 0..work.index.len() {
                let pos = work.position[r];
                // The linearised problem's w of an open pair is its remaining gap (φ(0) = 0).
                out.pairs.push(DeformablePair {
                    index: work.index[r],
                    position: pos,
                    contact_position: self.contact_position(flank, pos),
                    flank,
                    force: flank.sign() * p[r],
                    gap: work.gap[r],
                    separation: if p[r] > 0.0 { 0.0 } else { w[r] },
                    hertz: self.hertz(flank, pos, p[r]),
                });
            }
        }
        Ok(out)
    }

    /// The forces \[N\] of the pairs at indices `first..` (pair k at s + k·p_b)
    /// at (s, δ), summed over both flanks: `out[j]` is pair `first + j`.
    /// Returns `first`.
    pub fn pair_forces(&self, s: f64, delta: f64, out: &mut Vec<f64>) -> Result<i32, DeformableError> {
        let state = self.solve(s, delta)?;
        let range = self.pair_range(s);
        let first = *range.start();
        out.clear();
        out.extend(range.map(|k| state.pair_force(k)));
        Ok(first)
    }
}

/// `Ok` when `value` is finite.
pub(crate) fn check_finite(name: &'static str, value: f64) -> Result<(), DeformableError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(DeformableError::NotFinite { name, value })
    }
}

impl DeformableMesh {
    /// The two parts of each pair's approach in `state` (solved at reference
    /// position `s` \[m\]), in its order: the bodies' Σ_b C_ab p_b \[m\] over the
    /// pairs of the same flank (a linear local term included) and the local
    /// term φ_a(p_a) \[m\] (zero for a linear one). A loaded pair's two add up
    /// to σδ − g_a; the energy checks read them.
    pub fn pair_approaches(&self, s: f64, state: &DeformableState) -> Vec<[f64; 2]> {
        state
            .pairs
            .iter()
            .map(|a| {
                let body: f64 = state
                    .pairs
                    .iter()
                    .filter(|b| b.flank == a.flank)
                    .map(|b| self.compliance(a.flank, s, a.index, b.index).0 * b.force.abs())
                    .sum();
                [body, self.local_law(a.flank, a.position).approach(a.force.abs())]
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    /// A body whose coefficient between neighbours depends on the roll angle
    /// of the tooth on the loaded tooth's facing side (+1): reciprocal
    /// (coefficient(+1, r, 0, r') = coefficient(−1, r', 0, r)) but different
    /// towards the two neighbours, so that it tells the tooth directions apart.
    struct Facing {
        slope: f64,
    }

    impl Facing {
        fn h(&self, roll: f64) -> f64 {
            1e-10 + self.slope * roll
        }
    }

    impl BodyInfluence for Facing {
        fn coefficient(&self, i: i32, roll_i: f64, j: i32, roll_j: f64) -> f64 {
            match i - j {
                0 => 1e-9,
                1 => self.h(roll_i),
                -1 => self.h(roll_j),
                _ => 0.0,
            }
        }
        fn reference_depth(&self, _roll: f64) -> f64 {
            1e-3
        }
        fn reach(&self) -> i32 {
            1
        }
    }

    /// The cross-compliance of pair k and pair k + 1 (further along the path)
    /// reads gear 1's tooth +1 and gear 2's tooth −1 on the drive flanks, and
    /// the reverse on the back flanks: with the body above, C = h₁(roll₁ of
    /// the gear-1 tooth on the +1 side) + h₂(roll₂ of the gear-2 tooth on its
    /// +1 side), to 1e-12 at grid positions.
    #[test]
    fn pair_offsets_map_to_the_documented_tooth_offsets() {
        let set = Scene::example_2004().validate().unwrap();
        for mesh in MeshKind::ALL {
            let (b1, b2) = (Facing { slope: 1e-11 }, Facing { slope: 3e-11 });
            let law = DeformableMesh::new(
                &set,
                mesh,
                &b1,
                &b2,
                &MeshFlanks::default(),
                LocalContact::Linear { compliance: 0.0 },
            )
            .unwrap();
            let p = law.path().clone();
            let pb = p.base_pitch;
            let grid: Vec<f64> = law.separation.drive.positions().collect();
            for &s in grid.iter().step_by(53) {
                for flank in [Flank::Drive, Flank::Back] {
                    let (qa, qb) = (law.contact_position(flank, s), law.contact_position(flank, s + pb));
                    let want = match flank {
                        // Pair k + 1 is gear-1 tooth +1 and gear-2 tooth −1 of pair k: gear 1's +1
                        // side holds pair k + 1, gear 2's holds pair k.
                        Flank::Drive => b1.h(p.roll_1(qb)) + b2.h(p.roll_2(qa)),
                        Flank::Back => b1.h(p.roll_1(qa)) + b2.h(p.roll_2(qb)),
                    };
                    let got = law.compliance(flank, s, 0, 1).0;
                    assert!((got / want - 1.0).abs() < 1e-12, "{mesh:?} {flank:?} {s}: {got} vs {want}");
                    assert_eq!(got, law.compliance(flank, s, 1, 0).0);
                }
            }
        }
    }
}
