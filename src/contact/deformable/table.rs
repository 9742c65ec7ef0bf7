//! The mesh force tabulated over one base pitch of s and a range of δ, for
//! the dynamics' hot path.
//!
//! F(s, δ) is periodic in s with the base pitch p_b (every tooth of a gear
//! has the same outline and deviations), and the two flanks add:
//! F = F_drive + F_back, F_drive zero below the smallest drive gap, F_back
//! zero above minus the smallest back gap. Each flank's part is tabulated on
//! a uniform (s, δ) grid from where it starts to several times the nominal
//! load's approach, with F, ∂F/∂δ and ∂F/∂s from the exact solution
//! ([`DeformableMesh::solve`]) and the cross derivative ∂²F/∂s∂δ by central
//! differences of the nodes' first derivatives; a bicubic Hermite patch per
//! cell (de Boor, *A Practical Guide to Splines*, 1978, ch. IV; the
//! tensor-product form, e.g. Press et al., *Numerical Recipes*, 3rd ed.,
//! §3.6.3) gives F, ∂F/∂δ and ∂F/∂s continuous across cells. Beyond a
//! table's δ range the exact solution is used. The peak pair force is
//! interpolated bilinearly.

use crate::contact::deformable::law::{check_finite, DeformableError, DeformableMesh, Flank, FlankProblem};
use crate::contact::ltca::MeshLaw;

/// How to tabulate the mesh force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableSpec {
    /// Nodes per base pitch in s (≥ 4).
    pub positions: usize,
    /// Nodes in δ per flank (≥ 4).
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
    ns: usize,
    d0: f64,
    hd: f64,
    nd: usize,
    /// Per node (s-major: index j·nd + i): F, ∂F/∂δ, ∂F/∂s, ∂²F/∂s∂δ.
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

impl FlankTable {
    fn build(
        mesh: &DeformableMesh,
        flank: Flank,
        d0: f64,
        d1: f64,
        spec: &TableSpec,
    ) -> Result<Self, DeformableError> {
        let p = mesh.path();
        let (ns, nd) = (spec.positions, spec.approaches);
        let hs = p.base_pitch / ns as f64;
        let hd = (d1 - d0) / (nd - 1) as f64;
        let s0 = p.start;
        let mut nodes = vec![[0.0; 4]; ns * nd];
        let mut peak = vec![0.0; ns * nd];
        let mut work = FlankProblem::default();
        for j in 0..ns {
            for i in 0..nd {
                let law = mesh.solve_flank(flank, s0 + j as f64 * hs, d0 + i as f64 * hd, &mut work)?;
                nodes[j * nd + i] = [law.force, law.approach_stiffness, law.position_derivative, 0.0];
                peak[j * nd + i] = law.peak;
            }
        }
        // Cross derivative: the mean of the central differences of ∂F/∂s along δ and of ∂F/∂δ
        // along s (periodic in s, one-sided at the δ ends).
        for j in 0..ns {
            let (jm, jp) = ((j + ns - 1) % ns, (j + 1) % ns);
            for i in 0..nd {
                let (im, ip) = (i.saturating_sub(1), (i + 1).min(nd - 1));
                let along_d = (nodes[j * nd + ip][2] - nodes[j * nd + im][2]) / ((ip - im) as f64 * hd);
                let along_s = (nodes[jp * nd + i][1] - nodes[jm * nd + i][1]) / (2.0 * hs);
                nodes[j * nd + i][3] = 0.5 * (along_d + along_s);
            }
        }
        Ok(Self { flank, s0, hs, ns, d0, hd, nd, nodes, peak })
    }

    /// Whether δ is below (drive) or above (back) where the flank's table starts: no force there.
    fn open(&self, delta: f64) -> bool {
        match self.flank {
            Flank::Drive => delta <= self.d0,
            Flank::Back => delta >= self.d0 + (self.nd - 1) as f64 * self.hd,
        }
    }

    /// The flank's part of the law at (s, δ), `None` outside the δ range.
    fn law(&self, s: f64, delta: f64) -> Option<MeshLaw> {
        if self.open(delta) {
            return Some(MeshLaw::default());
        }
        let x = (delta - self.d0) / self.hd;
        if !(x >= 0.0 && x <= (self.nd - 1) as f64) {
            return None;
        }
        let i = (x as usize).min(self.nd - 2);
        let v = x - i as f64;
        let y = ((s - self.s0) / self.hs).rem_euclid(self.ns as f64);
        let j = (y as usize).min(self.ns - 1);
        let u = (y - j as f64).clamp(0.0, 1.0);
        let jp = (j + 1) % self.ns;
        let (hu, du) = hermite(u);
        let (hv, dv) = hermite(v);
        let corner = |jj: usize, ii: usize| self.nodes[jj * self.nd + ii];
        let c = [corner(j, i), corner(j, i + 1), corner(jp, i), corner(jp, i + 1)];
        // Corner (a, b): a = 0/1 in s, b = 0/1 in δ; basis index 2a (value) or 2a+1 (slope).
        let (mut f, mut fs, mut fd) = (0.0, 0.0, 0.0);
        for (k, n) in c.iter().enumerate() {
            let (a, b) = (k / 2, k % 2);
            let terms = [
                (2 * a, 2 * b, n[0]),
                (2 * a + 1, 2 * b, n[2] * self.hs),
                (2 * a, 2 * b + 1, n[1] * self.hd),
                (2 * a + 1, 2 * b + 1, n[3] * self.hs * self.hd),
            ];
            for (bs, bd, value) in terms {
                f += hu[bs] * hv[bd] * value;
                fs += du[bs] * hv[bd] * value;
                fd += hu[bs] * dv[bd] * value;
            }
        }
        let pk = |jj: usize, ii: usize| self.peak[jj * self.nd + ii];
        let peak = (1.0 - u) * ((1.0 - v) * pk(j, i) + v * pk(j, i + 1))
            + u * ((1.0 - v) * pk(jp, i) + v * pk(jp, i + 1));
        Some(MeshLaw {
            force: f,
            approach_stiffness: fd / self.hd,
            position_derivative: fs / self.hs,
            peak_pair_force: peak,
        })
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
        let min_gap = |values: &[f64]| values.iter().cloned().fold(f64::INFINITY, f64::min);
        let drive_start = min_gap(&mesh.separation.drive.values);
        let back_start = -min_gap(&mesh.separation.back.values);
        // The largest approach the nominal load needs over one cycle, beyond the first contact.
        let mut reach: f64 = 0.0;
        for j in 0..spec.positions {
            let s = p.start + p.base_pitch * j as f64 / spec.positions as f64;
            reach = reach.max(mesh.approach_for(s, load)? - drive_start);
        }
        let span = spec.load_factor * reach;
        let drive = FlankTable::build(&mesh, Flank::Drive, drive_start, drive_start + span, &spec)?;
        let back = FlankTable::build(&mesh, Flank::Back, back_start - span, back_start, &spec)?;
        Ok(Self { mesh, table: ForceTable { flanks: [drive, back], spec } })
    }

    /// The mesh force and its derivatives at (s, δ), from the table where it
    /// covers δ and exactly otherwise: the dynamics' entry, as
    /// [`crate::contact::ltca::MeshModel::force_tangents`].
    pub fn force_tangents(&self, s: f64, delta: f64) -> Result<MeshLaw, DeformableError> {
        check_finite("position s", s)?;
        check_finite("approach delta", delta)?;
        let mut out = MeshLaw::default();
        let mut work = FlankProblem::default();
        for t in &self.table.flanks {
            let law = match t.law(s, delta) {
                Some(law) => law,
                None => {
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

    /// The table.
    pub fn table(&self) -> &ForceTable {
        &self.table
    }
}
