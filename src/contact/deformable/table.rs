//! The mesh force tabulated over one base pitch of s and a range of δ, for
//! the dynamics' hot path.
//!
//! F(s, δ) is periodic in s with the base pitch p_b (every tooth of a gear
//! has the same outline and deviations), and the two flanks add. Each
//! flank's part is tabulated in the coordinate that puts its onset of load on
//! a grid line: with σ = +1 on the drive flank and −1 on the back flank,
//! g(s) the smallest unloaded gap of the flank's pairs at s and
//! ξ = σδ − g(s), the flank's part is F = σ P(s, ξ) with P = 0 for ξ ≤ 0
//! exactly. The kink of F where the first pair starts to touch, which cuts
//! the cells of a plain (s, δ) grid obliquely, becomes the edge ξ = 0; what
//! remains inside the table are the kinks where a further pair joins.
//!
//! P is tabulated on a uniform (s, ξ) grid from ξ = 0 to several times the
//! nominal load's approach, with P, ∂P/∂ξ and ∂P/∂s from the exact solution
//! ([`DeformableMesh::solve`]) and the cross derivative ∂²P/∂s∂ξ by central
//! differences of the nodes' first derivatives; a bicubic Hermite patch per
//! cell (de Boor, *A Practical Guide to Splines*, 1978, ch. IV; the
//! tensor-product form, e.g. Press et al., *Numerical Recipes*, 3rd ed.,
//! §3.6.3) gives P, ∂P/∂ξ and ∂P/∂s continuous across cells. g(s) is
//! interpolated linearly between the s nodes, and the flank's event value
//! (where it starts or stops carrying load) is ξ itself, so the dynamics'
//! contact switches and the law's zero agree to the last bit. Beyond a
//! table's ξ range the exact solution is used. The peak pair force is
//! interpolated bilinearly.
//!
//! The stored energy of a flank is W(s, ξ) = ∫₀^ξ P(s, x) dx, exact on the
//! interpolant (two-point Gauss–Legendre per cell of a cubic).

use crate::contact::deformable::law::{check_finite, DeformableError, DeformableMesh, Flank, FlankProblem};
use crate::contact::ltca::{MeshForce, MeshLaw};

/// How to tabulate the mesh force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableSpec {
    /// Nodes per base pitch in s (≥ 4).
    pub positions: usize,
    /// Nodes in ξ per flank (≥ 4).
    pub approaches: usize,
    /// The table reaches this multiple of the nominal load's largest elastic
    /// approach (beyond the first contact) [-] (> 1).
    pub load_factor: f64,
}

impl Default for TableSpec {
    fn default() -> Self {
        Self { positions: 400, approaches: 96, load_factor: 3.0 }
    }
}

/// One flank's part of the mesh force on its grid.
#[derive(Clone, Debug)]
pub(crate) struct FlankTable {
    flank: Flank,
    s0: f64,
    hs: f64,
    inv_hs: f64,
    ns: usize,
    hx: f64,
    inv_hx: f64,
    nx: usize,
    /// The flank's smallest unloaded gap g(s) at each s node \[m\].
    touch: Vec<f64>,
    /// Per node (s-major: index j·nx + i): P, ∂P/∂ξ, ∂P/∂s, ∂²P/∂s∂ξ.
    nodes: Vec<[f64; 4]>,
    peak: Vec<f64>,
}

/// The mesh force tables of both flanks.
#[derive(Clone, Debug)]
pub struct ForceTable {
    flanks: [FlankTable; 2],
    /// The spec it was built with.
    pub spec: TableSpec,
}

/// Cubic Hermite basis on [0, 1] and its derivative: values h00, h10, h01, h11.
fn hermite(u: f64) -> ([f64; 4], [f64; 4]) {
    let (u2, u3) = (u * u, u * u * u);
    (
        [2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u, -2.0 * u3 + 3.0 * u2, u3 - u2],
        [6.0 * u2 - 6.0 * u, 3.0 * u2 - 4.0 * u + 1.0, -6.0 * u2 + 6.0 * u, 3.0 * u2 - 2.0 * u],
    )
}

/// The second derivatives of the cubic Hermite basis of [`hermite`] at u.
fn hermite_second(u: f64) -> [f64; 4] {
    [12.0 * u - 6.0, 6.0 * u - 4.0, -12.0 * u + 6.0, 6.0 * u - 2.0]
}

/// The flank's smallest unloaded gap over its pairs at reference position
/// `s` \[m\]: where its first pair touches; `None` where no pair can touch.
fn touch_gap(mesh: &DeformableMesh, flank: Flank, s: f64) -> Option<f64> {
    let pb = mesh.path().base_pitch;
    mesh.pair_range(s).filter_map(|k| mesh.gap(flank, s + f64::from(k) * pb).map(|(g, _)| g)).reduce(f64::min)
}

/// Where a lookup falls: cell (j, u) in s, the gap g and its slope there,
/// and ξ.
#[derive(Clone, Copy, Debug)]
struct Site {
    j: usize,
    u: f64,
    slope: f64,
    xi: f64,
}

impl FlankTable {
    fn build(
        mesh: &DeformableMesh,
        flank: Flank,
        span: f64,
        spec: &TableSpec,
    ) -> Result<Self, DeformableError> {
        let p = mesh.path();
        let (ns, nx) = (spec.positions, spec.approaches);
        let hs = p.base_pitch / ns as f64;
        let hx = span / (nx - 1) as f64;
        let s0 = p.start;
        let sigma = flank.sign();
        let mut touch = Vec::with_capacity(ns);
        for j in 0..ns {
            let s = s0 + j as f64 * hs;
            touch.push(touch_gap(mesh, flank, s).ok_or(DeformableError::Setting {
                name: "mesh path",
                value: s,
                allowed: "positions where at least one tooth pair of each flank can touch",
            })?);
        }
        let mut nodes = vec![[0.0; 4]; ns * nx];
        let mut peak = vec![0.0; ns * nx];
        let mut work = FlankProblem::default();
        for j in 0..ns {
            let s = s0 + j as f64 * hs;
            let slope = (touch[(j + 1) % ns] - touch[(j + ns - 1) % ns]) / (2.0 * hs);
            for i in 0..nx {
                // At ξ = 0 the force is zero; its one-sided tangents are read just inside.
                let xi = if i == 0 { 1e-6 * hx } else { i as f64 * hx };
                let law = mesh.solve_flank(flank, s, sigma * (touch[j] + xi), &mut work)?;
                let force = if i == 0 { 0.0 } else { sigma * law.force };
                let ds = sigma * law.position_derivative + law.approach_stiffness * slope;
                nodes[j * nx + i] = [force, law.approach_stiffness, ds, 0.0];
                peak[j * nx + i] = if i == 0 { 0.0 } else { law.peak };
            }
        }
        // Cross derivative: the mean of the central differences of ∂P/∂s along ξ and of ∂P/∂ξ
        // along s (periodic in s, one-sided at the ξ ends).
        for j in 0..ns {
            let (jm, jp) = ((j + ns - 1) % ns, (j + 1) % ns);
            for i in 0..nx {
                let (im, ip) = (i.saturating_sub(1), (i + 1).min(nx - 1));
                let along_x = (nodes[j * nx + ip][2] - nodes[j * nx + im][2]) / ((ip - im) as f64 * hx);
                let along_s = (nodes[jp * nx + i][1] - nodes[jm * nx + i][1]) / (2.0 * hs);
                nodes[j * nx + i][3] = 0.5 * (along_x + along_s);
            }
        }
        Ok(Self { flank, s0, hs, inv_hs: 1.0 / hs, ns, hx, inv_hx: 1.0 / hx, nx, touch, nodes, peak })
    }

    /// The cell in s, the interpolated gap's slope and ξ at (s, δ).
    fn site(&self, s: f64, delta: f64) -> Site {
        self.site_in(self.cell(s), delta)
    }

    /// The cell (j, u) of position s on the periodic s grid (u in [0, 1]).
    #[inline]
    fn cell(&self, s: f64) -> (usize, f64) {
        let y = (s - self.s0) * self.inv_hs;
        let floor = y.floor();
        // Through i64: a NaN position gives cell 0 and a NaN fraction, which the caller's
        // comparisons send to the exact solution's finiteness check.
        let j = (floor as i64).rem_euclid(self.ns as i64) as usize;
        (j, y - floor)
    }

    /// [`Self::site`] at a cell found by [`Self::cell`].
    #[inline]
    fn site_in(&self, (j, u): (usize, f64), delta: f64) -> Site {
        let jp = if j + 1 == self.ns { 0 } else { j + 1 };
        let (g0, g1) = (self.touch[j], self.touch[jp]);
        let g = g0 + u * (g1 - g0);
        Site { j, u, slope: (g1 - g0) * self.inv_hs, xi: self.flank.sign() * delta - g }
    }

    /// The two ξ lines of the patch's cell at (j, u) in s and grid coordinate x
    /// = ξ/h_ξ: the fraction v of x in its ξ cell, the lines' values and ξ slopes
    /// [P₀, P_ξ₀, P₁, P_ξ₁] interpolated along s (Hermite in u with the nodes' s
    /// slopes and cross derivatives), and the same per unit of u.
    #[inline]
    fn lines(&self, j: usize, u: f64, x: f64) -> (f64, [f64; 4], [f64; 4]) {
        let i = (x as usize).min(self.nx - 2);
        let v = x - i as f64;
        let jp = if j + 1 == self.ns { 0 } else { j + 1 };
        let (hu, du) = hermite(u);
        let hs = self.hs;
        let (a0, a1) = (&self.nodes[j * self.nx + i], &self.nodes[j * self.nx + i + 1]);
        let (b0, b1) = (&self.nodes[jp * self.nx + i], &self.nodes[jp * self.nx + i + 1]);
        let along = |a: &[f64; 4], b: &[f64; 4], w: &[f64; 4]| {
            (
                w[0] * a[0] + w[1] * hs * a[2] + w[2] * b[0] + w[3] * hs * b[2],
                w[0] * a[1] + w[1] * hs * a[3] + w[2] * b[1] + w[3] * hs * b[3],
            )
        };
        let ((p0, x0), (p1, x1)) = (along(a0, b0, &hu), along(a1, b1, &hu));
        let ((ps0, xs0), (ps1, xs1)) = (along(a0, b0, &du), along(a1, b1, &du));
        (v, [p0, x0, p1, x1], [ps0, xs0, ps1, xs1])
    }

    /// Weights `w` of a Hermite basis in v along ξ applied to the lines `l` of
    /// [`Self::lines`] (the slopes scaled by h_ξ).
    #[inline]
    fn along_xi(&self, w: &[f64; 4], l: &[f64; 4]) -> f64 {
        let hx = self.hx;
        w[0] * l[0] + w[1] * hx * l[1] + w[2] * l[2] + w[3] * hx * l[3]
    }

    /// P, ∂P/∂s and ∂P/∂ξ of the Hermite patch at cell (j, u) in s and grid
    /// coordinate x = ξ/h_ξ (within the table).
    #[inline]
    fn patch(&self, j: usize, u: f64, x: f64) -> (f64, f64, f64) {
        let (v, line, line_s) = self.lines(j, u, x);
        let (hv, dv) = hermite(v);
        let (f, fs, fx) = (self.along_xi(&hv, &line), self.along_xi(&hv, &line_s), self.along_xi(&dv, &line));
        (f, fs / self.hs, fx / self.hx)
    }

    /// ∂²P/∂ξ² and ∂²P/∂ξ∂s of the Hermite patch at cell (j, u) in s and grid
    /// coordinate x = ξ/h_ξ (within the table): the derivatives of the
    /// patch's ∂P/∂ξ ([`Self::patch`]).
    fn patch_curvature(&self, j: usize, u: f64, x: f64) -> (f64, f64) {
        let (v, line, line_s) = self.lines(j, u, x);
        let (_, dv) = hermite(v);
        let hx = self.hx;
        let fxx = self.along_xi(&hermite_second(v), &line);
        let fxs = self.along_xi(&dv, &line_s);
        (fxx / (hx * hx), fxs / (hx * self.hs))
    }

    /// The flank's part of (∂K_t/∂δ, ∂K_t/∂s) at a cell found by
    /// [`Self::cell`], K_t = ∂P/∂ξ at ξ = σδ − g(s): (σ P_ξξ, P_ξs − P_ξξ g′);
    /// `None` beyond the ξ range.
    fn stiffness_derivatives_in(&self, cell: (usize, f64), delta: f64) -> Option<(f64, f64)> {
        let site = self.site_in(cell, delta);
        if site.xi <= 0.0 {
            return Some((0.0, 0.0));
        }
        let x = site.xi * self.inv_hx;
        if x.is_nan() || x > (self.nx - 1) as f64 {
            return None;
        }
        let (fxx, fxs) = self.patch_curvature(site.j, site.u, x);
        Some((self.flank.sign() * fxx, fxs - fxx * site.slope))
    }

    /// The largest ξ the table covers \[m\].
    fn span(&self) -> f64 {
        (self.nx - 1) as f64 * self.hx
    }

    /// The flank's part of the law at (s, δ), `None` beyond the ξ range.
    fn law(&self, s: f64, delta: f64) -> Option<MeshLaw> {
        self.law_in(self.cell(s), delta)
    }

    /// [`Self::law`] at a cell found by [`Self::cell`].
    #[inline]
    fn law_in(&self, cell: (usize, f64), delta: f64) -> Option<MeshLaw> {
        let site = self.site_in(cell, delta);
        if site.xi <= 0.0 {
            return Some(MeshLaw::default());
        }
        let x = site.xi * self.inv_hx;
        if x.is_nan() || x > (self.nx - 1) as f64 {
            return None;
        }
        let (pf, ps, px) = self.patch(site.j, site.u, x);
        let sigma = self.flank.sign();
        let i = (x as usize).min(self.nx - 2);
        let v = x - i as f64;
        let (j, u) = (site.j, site.u);
        let jp = if j + 1 == self.ns { 0 } else { j + 1 };
        let pk = |jj: usize, ii: usize| self.peak[jj * self.nx + ii];
        let peak = (1.0 - u) * ((1.0 - v) * pk(j, i) + v * pk(j, i + 1))
            + u * ((1.0 - v) * pk(jp, i) + v * pk(jp, i + 1));
        Some(MeshLaw {
            force: sigma * pf,
            approach_stiffness: px,
            position_derivative: sigma * (ps - px * site.slope),
            peak_pair_force: peak,
        })
    }

    /// The flank's stored energy W and ∂W/∂s at fixed δ at (s, δ), over the
    /// table's range of ξ (the part beyond is added by the caller) [J, N],
    /// with the ξ it reached.
    fn energy(&self, s: f64, delta: f64) -> (f64, f64, f64, Site) {
        let site = self.site(s, delta);
        if site.xi <= 0.0 {
            return (0.0, 0.0, 0.0, site);
        }
        let top = site.xi.min(self.span());
        let (mut w, mut ws) = (0.0, 0.0);
        // Two-point Gauss–Legendre per cell: exact for the cubic in ξ.
        let g = 0.5 / 3f64.sqrt();
        let mut a = 0.0;
        while a < top {
            let b = (a + self.hx).min(top);
            for t in [0.5 - g, 0.5 + g] {
                let x = (a + t * (b - a)) / self.hx;
                let (pf, ps, _) = self.patch(site.j, site.u, x.min((self.nx - 1) as f64));
                w += 0.5 * (b - a) * pf;
                ws += 0.5 * (b - a) * ps;
            }
            a = b;
        }
        (w, ws, top, site)
    }
}

/// A deformable mesh law with its force table: the form the dynamics reads.
#[derive(Clone, Debug)]
pub struct TabulatedMesh {
    /// The exact law.
    pub mesh: DeformableMesh,
    table: ForceTable,
}

impl TabulatedMesh {
    /// Tabulates `mesh` for a nominal mesh load `load` \[N\] with `spec`.
    pub fn new(mesh: DeformableMesh, load: f64, spec: TableSpec) -> Result<Self, DeformableError> {
        check_finite("nominal load", load)?;
        if !(spec.positions >= 4 && spec.approaches >= 4 && spec.load_factor > 1.0 && load > 0.0) {
            return Err(DeformableError::Setting {
                name: "table spec",
                value: spec.load_factor,
                allowed: "positions ≥ 4, approaches ≥ 4, load factor > 1, nominal load > 0 N",
            });
        }
        let p = mesh.path().clone();
        // The largest approach the nominal load needs over one cycle, beyond the first contact.
        let mut reach: f64 = 0.0;
        for j in 0..spec.positions {
            let s = p.start + p.base_pitch * j as f64 / spec.positions as f64;
            let first = touch_gap(&mesh, Flank::Drive, s).unwrap_or(f64::INFINITY);
            reach = reach.max(mesh.approach_for(s, load)? - first);
        }
        let span = spec.load_factor * reach;
        let drive = FlankTable::build(&mesh, Flank::Drive, span, &spec)?;
        let back = FlankTable::build(&mesh, Flank::Back, span, &spec)?;
        Ok(Self { mesh, table: ForceTable { flanks: [drive, back], spec } })
    }

    /// The mesh force and its derivatives at (s, δ), from the table where it
    /// covers δ and exactly otherwise: the dynamics' entry, as
    /// [`crate::contact::ltca::MeshModel::force_tangents`].
    pub fn force_tangents(&self, s: f64, delta: f64) -> Result<MeshLaw, DeformableError> {
        check_finite("position s", s)?;
        check_finite("approach delta", delta)?;
        let mut out = MeshLaw::default();
        // Both flanks share the s grid.
        let cell = self.table.flanks[0].cell(s);
        for t in &self.table.flanks {
            let law = match t.law_in(cell, delta) {
                Some(law) => law,
                None => {
                    let mut work = FlankProblem::default();
                    let f = self.mesh.solve_flank(t.flank, s, delta, &mut work)?;
                    MeshLaw {
                        force: f.force,
                        approach_stiffness: f.approach_stiffness,
                        position_derivative: f.position_derivative,
                        peak_pair_force: f.peak,
                    }
                }
            };
            out.force += law.force;
            out.approach_stiffness += law.approach_stiffness;
            out.position_derivative += law.position_derivative;
            out.peak_pair_force = out.peak_pair_force.max(law.peak_pair_force);
        }
        Ok(out)
    }

    /// The derivatives of the tangent stiffness K_t = ∂F/∂δ at (s, δ):
    /// (∂K_t/∂δ, ∂K_t/∂s) [N/m², N/m²], the exact derivatives of the
    /// interpolated law, which Rayleigh damping's tangent reads; `None` where
    /// δ lies beyond the table (the law there is solved, not interpolated).
    pub fn stiffness_derivatives(&self, s: f64, delta: f64) -> Result<Option<(f64, f64)>, DeformableError> {
        check_finite("position s", s)?;
        check_finite("approach delta", delta)?;
        let cell = self.table.flanks[0].cell(s);
        let mut out = (0.0, 0.0);
        for t in &self.table.flanks {
            let Some((d_delta, d_s)) = t.stiffness_derivatives_in(cell, delta) else {
                return Ok(None);
            };
            out.0 += d_delta;
            out.1 += d_s;
        }
        Ok(Some(out))
    }

    /// The event values of the two flanks at (s, δ) \[m\]: σδ − g(s) for the
    /// drive flank (σ = 1) and the back flank (σ = −1), positive exactly where
    /// the flank carries load in [`Self::force_tangents`].
    pub fn events(&self, s: f64, delta: f64) -> [f64; 2] {
        let cell = self.table.flanks[0].cell(s);
        [self.table.flanks[0].site_in(cell, delta).xi, self.table.flanks[1].site_in(cell, delta).xi]
    }

    /// Elastic energy stored in the mesh V(s, δ) = Σ_flanks ∫₀^ξ P dx \[J\] and
    /// its partial derivative ∂V/∂s at fixed δ \[N\], on the interpolated law
    /// (exactly its integral: ∂V/∂δ is [`Self::force_tangents`]' force).
    pub fn contact_energy(&self, s: f64, delta: f64) -> Result<(f64, f64), DeformableError> {
        check_finite("position s", s)?;
        check_finite("approach delta", delta)?;
        let (mut v, mut vs) = (0.0, 0.0);
        let mut work = FlankProblem::default();
        let g = 0.5 / 3f64.sqrt();
        for t in &self.table.flanks {
            let (mut w, mut ws, top, site) = t.energy(s, delta);
            if site.xi <= 0.0 {
                continue;
            }
            let sigma = t.flank.sign();
            let gap = sigma * delta - site.xi;
            // Beyond the table: the exact law, two Gauss points per table step.
            let mut a = top;
            while a < site.xi {
                let b = (a + t.hx).min(site.xi);
                for x in [a + (0.5 - g) * (b - a), a + (0.5 + g) * (b - a)] {
                    let f = self.mesh.solve_flank(t.flank, s, sigma * (gap + x), &mut work)?;
                    w += 0.5 * (b - a) * sigma * f.force;
                    ws += 0.5 * (b - a) * (sigma * f.position_derivative + f.approach_stiffness * site.slope);
                }
                a = b;
            }
            let end = match t.law(s, delta) {
                Some(law) => sigma * law.force,
                None => sigma * self.mesh.solve_flank(t.flank, s, delta, &mut work)?.force,
            };
            v += w;
            vs += ws - end * site.slope;
        }
        Ok((v, vs))
    }

    /// The table.
    pub fn table(&self) -> &ForceTable {
        &self.table
    }
}

impl MeshForce for TabulatedMesh {
    /// The table's force and tangent stiffness (NaN where the law cannot be
    /// evaluated: a non-finite state).
    fn force_stiffness(&self, s: f64, delta: f64) -> (f64, f64) {
        self.force_tangents(s, delta).map_or((f64::NAN, f64::NAN), |l| (l.force, l.approach_stiffness))
    }
}
