//! The harmonic balance condensed onto the contact coordinates
//! (docs/PERIODIC.md §2, "Condensed onto the contact coordinates").
//!
//! In the frame of the rigid-body motion the model is linear but for its
//! meshes,
//!
//! M q̈ + C₀ q̇ + K₀ q = g(t) − Σ_j b_j F_j(s_j, δ_j, δ̇_j),
//!
//! with each mesh's approach δ_j = b_jᵀq and its position
//! s_j = s_j⁰ + v_j t + p_jᵀq (K₀, C₀ the supports, the carrier frame and the
//! drive, [`crate::dynamics::solver::LowRankJacobian`]'s constant part). Per
//! harmonic k the linear part is inverted once per speed on the unknowns'
//! coordinates P of [`HarmonicBalance`] (the free rotation's complement):
//! Q_k = P A_k⁻¹ Pᵀ (g_k − Σ_j b_j F_j,k), A_k = Pᵀ(K₀ − k²ν²M + ikνC₀)P.
//! Newton's unknowns are the harmonics of the contact coordinates z = Wᵀq
//! only: the approach of each computed mesh and the distinct positions pᵀq
//! (a mesh's law reads its position too). Their residual is
//!
//! z_k − WᵀP A_k⁻¹ Pᵀ g_k + Σ_j R_kj F_j,k,  R_kj = WᵀP A_k⁻¹ Pᵀ b_j,
//!
//! the mesh forces by alternating frequency–time over the mesh laws alone
//! ([`PlanetaryDynamics::mesh_at`]), so its size does not grow with the
//! bodies' coordinates. Its Jacobian is I + R C with C the Fourier
//! convolution of the laws' tangents (the full balance's identities). The
//! residual is the full balance's plain N-sample sums eliminated exactly: at
//! the same H and N both have the same root.
//!
//! With [`Symmetry::Cyclic`] only planet 1's two meshes are computed: planet
//! p's forces are planet 1's delayed by its mesh phase τ_p,
//! F_p,k = F_1,k e^{−ikντ_p}, folded into the receptances. That holds while
//! the orbit keeps the planets' symmetry; each cyclic solve measures it
//! (the full condensed residual at the expanded orbit) and its multipliers
//! are the full system's.

mod arc;

pub use arc::CondensedArc;

use faer::linalg::solvers::Solve;
use rustfft::num_complex::Complex;
use serde::{Deserialize, Serialize};

use super::jacobian::{newton_remainder, pair_entries, DenseLu, Newton, PairSpectrum};
use super::{HarmonicBalance, HarmonicOrbit, HarmonicSettings};
use crate::dynamics::equations::{MeshCoordinates, PlanetaryDynamics};
use crate::dynamics::periodic::series::derivative_coefficient;
use crate::dynamics::periodic::switches::{add_back, illinois, subtract, time_terms, Switch};
use crate::dynamics::periodic::{max_abs, PeriodicError, PeriodicProblem};
use crate::dynamics::solver::{SecondOrderSystem, TangentSystem};

/// On the projected sums a Newton iteration that lowers the residual by less than this
/// factor takes a fresh Jacobian at its point (the continuation's corrector's
/// [`super::ARC_CHORD_CONTRACTION`]).
const PROJECTED_CONTRACTION: f64 = 0.25;

/// On the projected sums a Newton run whose residual grows past this multiple of its first
/// has left the root's basin and is stopped. Measured on the κ = 6 example's restarts near
/// 11 300 rpm: runs that converge wander to at most about 200 times their first residual;
/// the runs that do not climb past it within a few iterations and on to 1e57 by their
/// 45th, about a second each.
const PROJECTED_DIVERGENCE: f64 = 1e3;

/// The most harmonics the condensed balance keeps: it holds the rule's H
/// ([`HarmonicSettings::for_frequency`], up to [`super::MAX_RULE_HARMONICS`]) at this, with
/// the rule's samples per harmonic. Below about 2600 rpm the rule's H on the
/// transverse–torsional example follows its 98–113 kHz planet-on-pin modes (201 to 512).
/// Measured against shooting's orbit (`cargo bench --bench condensed_balance -- --held`,
/// docs/PERFORMANCE.md), the cyclic condensed balance at H = 160 gives E_h 1.0e-4, 9.2e-5,
/// 2.2e-5, 4.5e-6 and 5.3e-6 at 500, 1000, 1500, 2000 and 2500 rpm, a tenth of the 1e-3
/// the periodic states are held to; H = 128 gives up to 8.5e-4 and H = 256 up to 6.8e-5 at
/// 4.5× the time of one solve.
pub const CONDENSED_MAX_HARMONICS: usize = 160;

/// Samples over one period of the mean tangents that make each computed mesh's reference
/// spring k̄, c̄ (`reference_springs`). A reference only: A_k holds it and the residual
/// takes it off again, so any k̄ has the same root; the mean over the balance's N samples
/// (up to 4096) cost a tenth of a linear part's build on the example.
const REFERENCE_SAMPLES: usize = 256;

/// `settings` with H held at [`CONDENSED_MAX_HARMONICS`] (N with it).
pub fn held(settings: HarmonicSettings) -> HarmonicSettings {
    if settings.harmonics <= CONDENSED_MAX_HARMONICS {
        return settings;
    }
    let per = settings.samples / settings.harmonics.max(1);
    HarmonicSettings {
        harmonics: CONDENSED_MAX_HARMONICS,
        samples: per * CONDENSED_MAX_HARMONICS,
        ..settings
    }
}

/// The most unknowns the condensed balance solves with its dense LU.
pub const CONDENSED_UNKNOWNS: usize = 9000;

/// Which meshes the condensed balance computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Symmetry {
    /// Every mesh.
    Full,
    /// Planet 1's two meshes; the other planets' forces are theirs delayed
    /// by the planets' mesh phases (equally spaced planets, one mesh cycle
    /// per period).
    Cyclic,
}

/// What a condensed solve did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CondensedReport {
    /// Which meshes were computed.
    pub symmetry: Symmetry,
    /// Contact coordinates (unknowns per time).
    pub coordinates: usize,
    /// Newton's unknowns, coordinates × (2H + 1).
    pub unknowns: usize,
    /// Newton iterations.
    pub iterations: usize,
    /// Largest residual coefficient at the root [static deflections].
    pub residual: f64,
    /// Mesh-law evaluations (one per computed mesh and sample).
    pub law_evaluations: u64,
    /// With [`Symmetry::Cyclic`]: the largest coefficient of the residual of
    /// every mesh at the orbit the cyclic solve gives the others (0 when the
    /// delays fall on the samples and the orbit keeps the symmetry).
    pub symmetry_residual: Option<f64>,
    /// Why a balance asked for cyclic symmetry solved with every mesh instead.
    pub cyclic_refused: Option<String>,
}

/// The largest residual coefficient [static deflections] of every mesh at a cyclic orbit
/// below which the orbit keeps the planets' symmetry: 100 times the default Newton
/// tolerance. Measured on the example (docs/PERIODIC.md §2): 1e-14 to 1e-7 where it keeps it
/// (the cyclic solve's own residual), while an orbit that breaks it leaves residuals of the
/// size of the planets' differences.
pub const SYMMETRY_TOLERANCE: f64 = 1e-5;

/// The contact coordinates and the meshes computed.
#[derive(Clone, Debug)]
struct Layout {
    /// Model mesh of each computed mesh.
    computed: Vec<usize>,
    /// For every model mesh: its computed mesh and its delay as a fraction of the period.
    copies: Vec<(usize, f64)>,
    /// The contact coordinates' vectors in the model's coordinates: the approach of each
    /// computed mesh, then the distinct positions.
    w: Vec<Vec<f64>>,
    /// For each computed mesh: the coordinate its position reads.
    position_column: Vec<usize>,
    /// For each computed mesh: s⁰ \[m\] and the rate of s under the rigid motion per unit
    /// input speed [m/rad].
    s0: Vec<f64>,
    rate: Vec<f64>,
    /// The mesh vector b of every model mesh.
    b: Vec<Vec<f64>>,
}

fn dense(n: usize, nz: &[(usize, f64)]) -> Vec<f64> {
    let mut v = vec![0.0; n];
    for (i, x) in nz {
        v[*i] += x;
    }
    v
}

impl Layout {
    fn new(
        model: &PlanetaryDynamics,
        symmetry: Symmetry,
        omega: f64,
        period: f64,
        cycles: usize,
    ) -> Result<Self, PeriodicError> {
        let n = model.dim();
        let meshes = model.mesh_count();
        let rigid = model.rigid_velocity_at(omega);
        let (mut b, mut p, mut s0, mut rate) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for i in 0..meshes {
            let MeshCoordinates { approach: b_nz, position: p_nz, offset } = model.mesh_coordinates(i);
            b.push(dense(n, b_nz));
            let pi = dense(n, p_nz);
            rate.push(pi.iter().zip(&rigid).map(|(a, r)| a * r).sum::<f64>() / omega);
            p.push(pi);
            s0.push(offset);
        }
        let (computed, copies) = match symmetry {
            Symmetry::Full => ((0..meshes).collect(), (0..meshes).map(|i| (i, 0.0)).collect()),
            Symmetry::Cyclic => cyclic_copies(model, &p, &s0, &rate, omega * period, cycles)?,
        };
        let mut w: Vec<Vec<f64>> = computed.iter().map(|i| b[*i].clone()).collect();
        let mut position_column = Vec::new();
        for i in &computed {
            let column = match w[computed.len()..].iter().position(|x| *x == p[*i]) {
                Some(k) => computed.len() + k,
                None => {
                    w.push(p[*i].clone());
                    w.len() - 1
                }
            };
            position_column.push(column);
        }
        let s0c = computed.iter().map(|i| s0[*i]).collect();
        let ratec = computed.iter().map(|i| rate[*i]).collect();
        // `copies` names computed meshes by their model index: renumber them.
        let copies = copies
            .into_iter()
            .map(|(i, d)| (computed.iter().position(|c| *c == i).expect("a computed mesh"), d))
            .collect();
        Ok(Self { computed, copies, w, position_column, s0: s0c, rate: ratec, b })
    }

    /// The layout of every mesh with the same coordinates' order for planet 1.
    fn coordinates(&self) -> usize {
        self.w.len()
    }
}

/// The computed meshes (model indices) and, for every mesh, its computed mesh and delay.
type Copies = (Vec<usize>, Vec<(usize, f64)>);

/// The computed meshes (planet 1's) and every mesh's delay under cyclic
/// symmetry, or why the set has none.
fn cyclic_copies(
    model: &PlanetaryDynamics,
    p: &[Vec<f64>],
    s0: &[f64],
    rate: &[f64],
    angle: f64,
    cycles: usize,
) -> Result<Copies, PeriodicError> {
    let refuse = |reason: &str| PeriodicError::InvalidRequest {
        name: "symmetry".into(),
        value: "cyclic".into(),
        reason: format!("{reason}; solve with every mesh (symmetry full)"),
    };
    if cycles != 1 {
        return Err(refuse("the excitation repeats after more than one mesh cycle"));
    }
    let meshes = p.len();
    let first = |kind| (0..meshes).find(|i| model.mesh_identity(*i) == (0, kind));
    let mut copies = Vec::with_capacity(meshes);
    let mut delays: Vec<Option<f64>> = vec![None; meshes];
    for i in 0..meshes {
        let (planet, kind) = model.mesh_identity(i);
        let rep = first(kind).ok_or_else(|| refuse("planet 1 lacks a mesh"))?;
        if p[i] != p[rep] || (rate[i] - rate[rep]).abs() > 1e-12 * rate[rep].abs() || rate[rep] == 0.0 {
            return Err(refuse("the meshes of one kind read different positions"));
        }
        // s_i(t) = s_rep(t − τ) modulo the base pitch, which the rigid motion covers in one
        // period (the input turning through `angle`).
        let tau = ((s0[rep] - s0[i]) / rate[rep] / angle).rem_euclid(1.0);
        if let Some(other) = delays[planet] {
            let apart = (tau - other).rem_euclid(1.0);
            if apart.min(1.0 - apart) > 1e-9 {
                return Err(refuse(
                    "a planet's two meshes are not delayed alike (planets not equally spaced)",
                ));
            }
        }
        delays[planet] = Some(tau);
        copies.push((rep, tau));
    }
    let mut computed: Vec<usize> = copies.iter().map(|c| c.0).collect();
    computed.sort_unstable();
    computed.dedup();
    Ok((computed, copies))
}

/// The linear part at one speed.
struct Linear {
    omega: f64,
    harmonics: usize,
    samples: usize,
    /// Pᵀ(K₀, C₀, M)P, m × m column-major.
    stiffness: Vec<f64>,
    damping: Vec<f64>,
    mass: Vec<f64>,
    /// Each computed mesh's reference stiffness k̄ [N/m] and damping c̄ [N·s/m].
    reference: Vec<(f64, f64)>,
    /// Pᵀb_j of every mesh (m each) and Pᵀg_k per harmonic (complex amplitudes, m each).
    pb: Vec<Vec<f64>>,
    pg: Vec<Vec<Complex<f64>>>,
    /// Per harmonic: the computed forces' receptances onto the contact coordinates,
    /// coordinates × computed row-major, in static deflections per newton, delays folded in.
    receptance: Vec<Vec<Complex<f64>>>,
    /// The forcing's contact coordinates (blocks as the unknowns).
    forcing: Vec<f64>,
}

/// The harmonic balance condensed onto the contact coordinates of a
/// [`HarmonicBalance`]'s problem (module documentation).
pub struct CondensedBalance {
    balance: HarmonicBalance,
    symmetry: Symmetry,
    /// Whether the solve goes on from the plain sums' root to the sums with the contact
    /// switches projected (module `switches`).
    projected: bool,
    layout: Option<Layout>,
    linear: Option<Linear>,
    /// The linear part built before `linear`, kept for a return to its speed (a
    /// linearization's difference in speed, then the point again).
    spare: Option<Linear>,
    /// The last symmetry check's orbit with every mesh (contact coordinates).
    expanded: Option<Vec<f64>>,
    /// The fewest harmonics [`Self::arc_fit`] takes whatever the rule: what the last
    /// branch point's spectrum asked ([`HarmonicOrbit::spectral_harmonics`]); 0 at first.
    floor: usize,
}

/// A solve's work: mesh-law evaluations, Newton iterations and factorisations.
#[derive(Default)]
struct Count {
    evaluations: u64,
    iterations: usize,
    factorizations: usize,
}

/// A residual evaluation: the residual, the computed forces' coefficients and, when asked, the
/// Fourier convolution C of the laws' tangents (computed forces' coefficients × unknowns,
/// column-major): the Jacobian is I + R C.
struct Evaluation {
    residual: Vec<f64>,
    forces: Vec<Vec<f64>>,
    convolution: Option<Vec<f64>>,
}

/// Newton's steps on J = I + R C (R the receptances, block-diagonal in the harmonics, C the
/// convolution) by the Woodbury identity, J⁻¹ = I − R (I + C R)⁻¹ C: one LU of the computed
/// forces' coefficients (2 × (2H + 1) under cyclic symmetry) instead of the contact
/// coordinates'.
struct Steps {
    convolution: Vec<f64>,
    lu: DenseLu,
    forces: usize,
    /// The receptances J was taken with, and the contact coordinates and computed forces.
    receptance: Vec<Vec<Complex<f64>>>,
    dims: (usize, usize),
}

impl Steps {
    /// Factorises I + C R for the convolution `convolution` on `linear`'s receptances.
    fn new(linear: &Linear, convolution: Vec<f64>, (mz, mf): (usize, usize), lu: DenseLu) -> Self {
        let h = linear.harmonics;
        let (rows, size) = (mf * (2 * h + 1), mz * (2 * h + 1));
        debug_assert_eq!(convolution.len(), rows * size);
        let mut lu = lu;
        let mut inner = vec![0.0; rows * rows];
        for d in inner.iter_mut().step_by(rows + 1) {
            *d = 1.0;
        }
        let c = faer::MatRef::from_column_major_slice(&convolution, rows, size);
        let mut out = faer::MatMut::from_column_major_slice_mut(&mut inner, rows, rows);
        // R is block-diagonal in the harmonics: harmonic k's force coefficients (its cosine
        // and sine blocks of mf columns) reach its contact coordinates' cosine and sine
        // blocks (mz rows each) only, so C R is one product per harmonic.
        for k in 0..=h {
            let r = &linear.receptance[k];
            let at = |a: usize, g: usize| r[a * mf + g];
            let (block, width) = if k == 0 { (0, 1) } else { (2 * k - 1, 2) };
            // A force coefficient's unit amplitude: a₀ = 1, a_k = 1 (1), b_k = 1 (−i); the
            // response's cosine and sine coefficients are (Re, −Im) of the amplitude.
            let r_block = faer::Mat::<f64>::from_fn(width * mz, width * mf, |row, col| {
                let (side, a) = (row / mz, row % mz);
                let (unit, g) = (col / mf, col % mf);
                let z = if unit == 0 { at(a, g) } else { at(a, g) * Complex::new(0.0, -1.0) };
                if side == 0 {
                    z.re
                } else {
                    -z.im
                }
            });
            faer::linalg::matmul::matmul(
                out.as_mut().subcols_mut(block * mf, width * mf),
                faer::Accum::Add,
                c.subcols(block * mz, width * mz),
                r_block.as_ref(),
                1.0,
                faer::Par::Seq,
            );
        }
        lu.factorize(&inner, rows);
        Self { convolution, lu, forces: rows, receptance: linear.receptance.clone(), dims: (mz, mf) }
    }

    /// The Newton step −J⁻¹r.
    fn step(&self, r: &[f64]) -> Vec<f64> {
        let rows = self.forces;
        let mut cr = vec![0.0; rows];
        for (j, v) in r.iter().enumerate().filter(|(_, v)| **v != 0.0) {
            for (o, x) in cr.iter_mut().zip(&self.convolution[j * rows..(j + 1) * rows]) {
                *o += v * x;
            }
        }
        // step(v) = −(I + CR)⁻¹v, so w = (I + CR)⁻¹ C r = −step(C r).
        let w: Vec<f64> = self.lu.step(&cr).iter().map(|v| -v).collect();
        let rw = respond(&self.receptance, &w, self.dims);
        r.iter().zip(&rw).map(|(r, x)| x - r).collect()
    }
}

impl CondensedBalance {
    /// The condensed balance of `balance`'s problem and settings (H, N, tolerance, iterations).
    /// H is held at [`CONDENSED_MAX_HARMONICS`].
    pub fn new(mut balance: HarmonicBalance, symmetry: Symmetry) -> Self {
        let settings = held(balance.settings);
        if settings != balance.settings {
            balance.set_settings(settings).expect("fewer harmonics of valid settings are valid");
        }
        Self {
            balance,
            symmetry,
            projected: true,
            layout: None,
            linear: None,
            spare: None,
            expanded: None,
            floor: 0,
        }
    }

    /// Whether solves project the contact switches (the default) or stop at the plain
    /// N-sample sums' root.
    pub fn set_projected(&mut self, projected: bool) {
        self.projected = projected;
    }

    /// The full balance it condenses, given back (its settings hold the condensed H).
    pub fn into_balance(self) -> HarmonicBalance {
        self.balance
    }

    /// The meshes it computes now: [`Symmetry::Full`] once a cyclic solve was refused.
    pub fn symmetry(&self) -> Symmetry {
        self.symmetry
    }

    /// The full balance it condenses (settings, problem, multipliers, steady state).
    pub fn balance(&mut self) -> &mut HarmonicBalance {
        &mut self.balance
    }

    /// The shooting problem it solves.
    pub fn problem(&self) -> &PeriodicProblem {
        &self.balance.problem
    }

    /// Contact coordinates at `omega` [rad/s] (per time), once the layout is built.
    fn layout_at(&mut self, omega: f64) -> Result<&Layout, PeriodicError> {
        if self.layout.is_none() {
            let problem = &self.balance.problem;
            let period = problem.period(omega);
            let cycles = problem.cycles();
            self.layout = Some(Layout::new(&problem.model, self.symmetry, omega, period, cycles)?);
        }
        Ok(self.layout.as_ref().expect("built above"))
    }

    /// Builds the linear part at `omega` unless it is the one kept or the one before it.
    fn prepare(&mut self, omega: f64) -> Result<(), PeriodicError> {
        let (h, samples) = (self.balance.settings.harmonics, self.balance.settings.samples);
        let fits = |l: &Option<Linear>| {
            l.as_ref().is_some_and(|l| l.omega == omega && l.harmonics == h && l.samples == samples)
        };
        if fits(&self.linear) {
            return Ok(());
        }
        if fits(&self.spare) {
            std::mem::swap(&mut self.linear, &mut self.spare);
            return Ok(());
        }
        self.layout_at(omega)?;
        let linear = self.linear_part(omega)?;
        self.spare = self.linear.replace(linear);
        Ok(())
    }

    fn linear_part(&mut self, omega: f64) -> Result<Linear, PeriodicError> {
        let (m, n, h) = (self.balance.m, self.balance.n, self.balance.settings.harmonics);
        let samples = self.balance.settings.samples;
        let q_scale = self.balance.problem.q_scale;
        let period = self.balance.problem.period(omega);
        let nu = 2.0 * std::f64::consts::PI / period;
        let p = self.balance.p.clone();
        let y0 = self.balance.cold_start(omega);
        let q0: Vec<f64> =
            (0..n).map(|i| q_scale * (0..m).map(|a| p[i + n * a] * y0[a]).sum::<f64>()).collect();
        let layout = self.layout.as_ref().expect("prepared");
        let model = &mut self.balance.problem.model;
        model.set_drive_speed(omega);
        let reference =
            reference_springs(model, layout, &q0, (omega, period), samples.min(REFERENCE_SAMPLES));
        let structure = model.low_rank_jacobian().ok_or_else(|| {
            PeriodicError::invalid("condensed balance", 0.0, "needs the model's constant tangents")
        })?;
        let mass_diag = model.mass().to_vec();
        let reduce = |mat: &dyn Fn(usize, usize) -> f64| -> Vec<f64> {
            let mut out = vec![0.0; m * m];
            for a in 0..m {
                for b in 0..m {
                    let mut sum = 0.0;
                    for i in 0..n {
                        let pia = p[i + n * a];
                        if pia == 0.0 {
                            continue;
                        }
                        for j in 0..n {
                            sum += pia * mat(i, j) * p[j + n * b];
                        }
                    }
                    out[a + m * b] = sum;
                }
            }
            out
        };
        let mut stiffness = reduce(&|i, j| structure.k0[(i, j)]);
        let mut damping = reduce(&|i, j| structure.c0[(i, j)]);
        let mass = reduce(&|i, j| if i == j { mass_diag[i] } else { 0.0 });
        let project =
            |v: &[f64]| -> Vec<f64> { (0..m).map(|a| (0..n).map(|i| p[i + n * a] * v[i]).sum()).collect() };
        let pb: Vec<Vec<f64>> = layout.b.iter().map(|b| project(b)).collect();
        for (pbj, (g, _)) in pb.iter().zip(&layout.copies) {
            let (k, c) = reference[*g];
            for a in 0..m {
                for b in 0..m {
                    stiffness[a + m * b] += k * pbj[a] * pbj[b];
                    damping[a + m * b] += c * pbj[a] * pbj[b];
                }
            }
        }
        let pg = self.forcing(omega, &p);
        let layout = self.layout.as_ref().expect("prepared");
        let mut linear = Linear {
            omega,
            harmonics: h,
            samples,
            reference,
            stiffness,
            damping,
            mass,
            pb,
            pg,
            receptance: Vec::with_capacity(h + 1),
            forcing: vec![0.0; layout.coordinates() * (2 * h + 1)],
        };
        let wp: Vec<Vec<f64>> = layout.w.iter().map(|w| project_row(w, &p, n, m)).collect();
        let (mz, mf) = (layout.coordinates(), layout.computed.len());
        let mut rows = vec![Complex::new(0.0, 0.0); mz * m];
        for k in 0..=h {
            // Y = A_k⁻ᵀ (WᵀP)ᵀ: row a of WᵀP A_k⁻¹ is Y's column a, so that the receptance of
            // mesh j on coordinate a is Y_aᵀ Pᵀb_j and the forcing's Y_aᵀ Pᵀg_k.
            linear.contact_rows(k, nu, &wp, &mut rows)?;
            let mut r = vec![Complex::new(0.0, 0.0); mz * mf];
            for (j, (g, delay)) in layout.copies.iter().enumerate() {
                let shift =
                    Complex::from_polar(1.0 / q_scale, -(k as f64) * 2.0 * std::f64::consts::PI * delay);
                for a in 0..mz {
                    r[a * mf + g] += real_dot(&linear.pb[j], &rows[a * m..(a + 1) * m]) * shift;
                }
            }
            linear.receptance.push(r);
            for a in 0..mz {
                let forced: Complex<f64> =
                    rows[a * m..(a + 1) * m].iter().zip(&linear.pg[k]).map(|(y, g)| y * g).sum();
                put_complex(&mut linear.forcing, mz, k, a, forced / q_scale);
            }
        }
        Ok(linear)
    }

    /// Pᵀg_k per harmonic (complex amplitudes, m each): g(t) the force at the rigid motion
    /// itself with the meshes' forces added back, sampled at the settings' N; each coordinate's
    /// samples analysed (a constant one read off, one that is zero or that `p` does not
    /// project skipped) and the coefficients projected by `p` (n × m, column-major).
    fn forcing(&mut self, omega: f64, p: &[f64]) -> Vec<Vec<Complex<f64>>> {
        let (m, n, h) = (self.balance.m, self.balance.n, self.balance.settings.harmonics);
        let samples = self.balance.settings.samples;
        let period = self.balance.problem.period(omega);
        let model = &self.balance.problem.model;
        let rigid = model.rigid_velocity_at(omega);
        let mut f = vec![0.0; n];
        let mut q = vec![0.0; n];
        let mut g_samples = vec![vec![0.0; samples]; n];
        for j in 0..samples {
            let t = period * j as f64 / samples as f64;
            for (qi, r) in q.iter_mut().zip(&rigid) {
                *qi = r * t;
            }
            model.force_but_meshes(t, &q, &rigid, &mut f);
            for (samples_i, g) in g_samples.iter_mut().zip(&f) {
                samples_i[j] = *g;
            }
        }
        let mut pg = vec![vec![Complex::new(0.0, 0.0); m]; h + 1];
        let mut buffer = vec![Complex::new(0.0, 0.0); samples];
        let mut coefficients = vec![0.0; 2 * h + 1];
        for (i, g) in g_samples.iter().enumerate() {
            let column: Vec<(usize, f64)> =
                (0..m).map(|a| (a, p[i + n * a])).filter(|(_, v)| *v != 0.0).collect();
            if column.is_empty() || g.iter().all(|v| *v == 0.0) {
                continue;
            }
            if g.iter().all(|v| *v == g[0]) {
                coefficients.fill(0.0);
                coefficients[0] = g[0];
            } else {
                self.balance.analyse(g, &mut buffer, &mut coefficients);
            }
            for (k, pg_k) in pg.iter_mut().enumerate() {
                let z = if k == 0 {
                    Complex::new(coefficients[0], 0.0)
                } else {
                    Complex::new(coefficients[2 * k - 1], -coefficients[2 * k])
                };
                for &(a, v) in &column {
                    pg_k[a] += z * v;
                }
            }
        }
        pg
    }

    /// The residual at the contact coordinates' coefficients `x` at `omega`, with its
    /// Jacobian when `jacobian`.
    fn evaluate(
        &mut self,
        omega: f64,
        x: &[f64],
        (jacobian, switches): (bool, bool),
        evaluations: &mut u64,
    ) -> Result<Evaluation, PeriodicError> {
        let (h, ns) = (self.balance.settings.harmonics, self.balance.samples);
        let q_scale = self.balance.problem.q_scale;
        let period = self.balance.problem.period(omega);
        let nu = 2.0 * std::f64::consts::PI / period;
        let layout = self.layout.as_ref().expect("prepared");
        let linear = self.linear.as_ref().expect("prepared");
        let (mz, mf) = (layout.coordinates(), layout.computed.len());
        let top = 2 * h + 1;
        // Samples of each coordinate and its rate.
        let mut buffer = vec![Complex::new(0.0, 0.0); ns];
        let (mut value, mut rate) = (vec![vec![0.0; ns]; mz], vec![vec![0.0; ns]; mz]);
        for a in 0..mz {
            self.balance.synthesize(|c| x[c * mz + a], &mut buffer, &mut value[a]);
            self.balance.synthesize(
                |c| derivative_coefficient(|c| x[c * mz + a], c, nu),
                &mut buffer,
                &mut rate[a],
            );
        }
        let model = &self.balance.problem.model;
        let mut forces = Vec::with_capacity(mf);
        let mut tangents = Vec::new();
        let mut switch_terms = Vec::new();
        let mut samples = vec![0.0; ns];
        let (mut kt, mut ct, mut gt) = (vec![0.0; ns], vec![0.0; ns], vec![0.0; ns]);
        let mut events = Vec::new();
        for g in 0..mf {
            let i = layout.computed[g];
            let (k_ref, c_ref) = linear.reference[g];
            let sigma = &value[layout.position_column[g]];
            // The event values at the samples, with the law, where the switches are sought.
            let count = if switches { model.mesh_event_count(i) } else { 0 };
            events.resize(count * (ns + 1), 0.0);
            for j in 0..ns {
                let t = period * j as f64 / ns as f64;
                let delta = q_scale * value[g][j];
                let s = layout.s0[g] + layout.rate[g] * omega * t + q_scale * sigma[j];
                let approach_rate = q_scale * rate[g][j];
                let (state, c) = if switches {
                    let at = (s, delta, approach_rate);
                    model.mesh_at_with_events(i, at, &mut events[j * count..(j + 1) * count])
                } else {
                    model.mesh_at(i, s, delta, approach_rate)
                };
                let total = state.force + state.damping_force - k_ref * delta - c_ref * approach_rate;
                if !total.is_finite() {
                    return Err(PeriodicError::invalid(
                        "condensed harmonic-balance iterate",
                        total,
                        "gives a non-finite mesh force: the iterate diverged",
                    ));
                }
                samples[j] = total;
                kt[j] = (state.stiffness - k_ref) * q_scale;
                ct[j] = (c - c_ref) * q_scale * nu;
                gt[j] = state.position_derivative * q_scale;
            }
            *evaluations += ns as u64;
            let found = if switches {
                self.mesh_switches(g, x, &mut events, (omega, period), jacobian, evaluations)?
            } else {
                Vec::new()
            };
            subtract(&found, period, &mut samples);
            if jacobian {
                switch_terms.push((g, time_terms(&found, period, h)));
            }
            let mut coefficients = vec![0.0; top];
            self.balance.analyse(&samples, &mut buffer, &mut coefficients);
            add_back(&found, nu, h, &mut coefficients);
            forces.push(coefficients);
            if jacobian {
                let (kc, ks) = self.spectrum(&kt, &mut buffer, h);
                let (cc, cs) = self.spectrum(&ct, &mut buffer, h);
                let (pc, ps) = self.spectrum(&gt, &mut buffer, h);
                let zeros = vec![0.0; 2 * h + 1];
                tangents.push((g, PairSpectrum { kc, ks, cc, cs }));
                tangents.push((
                    layout.position_column[g],
                    PairSpectrum { kc: pc, ks: ps, cc: zeros.clone(), cs: zeros },
                ));
            }
        }
        let flat: Vec<f64> = (0..top).flat_map(|c| forces.iter().map(move |f| f[c])).collect();
        let responded = linear.apply(&flat, (mz, mf));
        let residual: Vec<f64> =
            x.iter().zip(&linear.forcing).zip(&responded).map(|((x, g), z)| x - g + z).collect();
        let convolution = jacobian.then(|| {
            // C = ∂(force coefficients)/∂x, computed forces × unknowns, column-major.
            let (rows, size) = (mf * top, mz * top);
            let mut conv = vec![0.0; rows * size];
            for (pair, (column, spectrum)) in tangents.iter().enumerate() {
                let g = pair / 2;
                pair_entries(h, h, spectrum, |rb, cb, v| {
                    conv[(rb * mf + g) + rows * (cb * mz + column)] += v
                });
            }
            // With the switches projected: what their jumps contribute through their times.
            for (g, terms) in &switch_terms {
                for (u, v) in terms {
                    for (c, column) in v.iter().enumerate().filter(|(_, v)| **v != 0.0) {
                        for (rb, weight) in u.iter().enumerate() {
                            conv[(rb * mf + g) + rows * c] += weight * column;
                        }
                    }
                }
            }
            conv
        });
        Ok(Evaluation { residual, forces, convolution })
    }

    /// Computed mesh `g`'s contact switches on the series `x` of period `period` \[s\], from
    /// its event values at the N samples (`values`, sample-major, N + 1 rows: the last is
    /// filled here, at t = T): each
    /// sign change of its event values between two samples (and between the last sample and
    /// t = T, where the pairs' slots have moved on by one base pitch) located by the Illinois
    /// method to 1e-6 of the sample interval, and its force's jump and slope jump measured
    /// by one-sided differences 1e-4 of a sample interval away (as the full balance's, module
    /// `switches`; changes within the stencil of each other are one switch, measured whole).
    fn mesh_switches(
        &self,
        g: usize,
        x: &[f64],
        values: &mut [f64],
        (omega, period): (f64, f64),
        gradients: bool,
        evaluations: &mut u64,
    ) -> Result<Vec<Switch>, PeriodicError> {
        let layout = self.layout.as_ref().expect("prepared");
        let linear = self.linear.as_ref().expect("prepared");
        let (h, ns) = (self.balance.settings.harmonics, self.balance.samples);
        let (mz, q_scale) = (layout.coordinates(), self.balance.problem.q_scale);
        let nu = 2.0 * std::f64::consts::PI / period;
        let model = &self.balance.problem.model;
        let i = layout.computed[g];
        let (k_ref, c_ref) = linear.reference[g];
        let count = model.mesh_event_count(i);
        let at = |t: f64| {
            let (delta, rate) = series_at(x, mz, g, h, nu, t);
            let (sigma, _) = series_at(x, mz, layout.position_column[g], h, nu, t);
            (layout.s0[g] + layout.rate[g] * omega * t + q_scale * sigma, q_scale * delta, q_scale * rate)
        };
        let event = |t: f64, e: usize, out: &mut Vec<f64>| {
            let (s, delta, _) = at(t);
            model.mesh_events_at(i, s, delta, out);
            out[e]
        };
        let force = |t: f64| {
            let (s, delta, rate) = at(t);
            let (state, _) = model.mesh_at(i, s, delta, rate);
            state.force + state.damping_force - k_ref * delta - c_ref * rate
        };
        let dt = period / ns as f64;
        let mut scratch = vec![0.0; count];
        debug_assert_eq!(values.len(), count * (ns + 1));
        // At t = T from the series.
        event(period, 0, &mut scratch);
        values[ns * count..].copy_from_slice(&scratch);
        *evaluations += 1;
        let mut located = Vec::new();
        for j in 0..ns {
            for e in 0..count {
                let (ga, gb) = (values[j * count + e], values[(j + 1) * count + e]);
                if (ga > 0.0) == (gb > 0.0) {
                    continue;
                }
                let [(ta, ha), (tb, hb)] = illinois(
                    |t| {
                        *evaluations += 1;
                        event(t, e, &mut scratch)
                    },
                    [(j as f64 * dt, ga), ((j + 1) as f64 * dt, gb)],
                    1e-6 * dt,
                    50,
                );
                located.push((0.5 * (ta + tb), e, (hb - ha) / (tb - ta)));
            }
        }
        located.sort_by(|a, b| a.0.total_cmp(&b.0));
        let eps = 1e-4 * dt;
        let mut found = Vec::new();
        let mut first = 0;
        while first < located.len() {
            let mut end = first + 1;
            while end < located.len() && located[end].0 - located[end - 1].0 <= 2.5 * eps {
                end += 1;
            }
            let ((time, e, rate), last) = (located[first], located[end - 1].0);
            first = end;
            let (left, left2, right, right2) =
                (force(time - eps), force(time - 2.0 * eps), force(last + eps), force(last + 2.0 * eps));
            *evaluations += 4;
            let reach = (last + eps - time) / eps;
            let jump = (right - reach * (right2 - right)) - (2.0 * left - left2);
            let kink = ((right2 - right) - (left - left2)) / eps;
            if !jump.is_finite() || !kink.is_finite() {
                return Err(PeriodicError::invalid(
                    "condensed harmonic-balance iterate",
                    jump,
                    "gives a non-finite mesh force at a contact switch: the iterate diverged",
                ));
            }
            let time = time.rem_euclid(period);
            if !gradients {
                found.push(Switch::new(time, vec![jump], vec![kink]));
                continue;
            }
            // ∂t*/∂x = −(∂h/∂z_b)/ḣ times the basis at t*, for the two coordinates the
            // event reads: the approach and the position (differences of 1e-7 of the static
            // deflection).
            let (s, delta, _) = at(time);
            let step = 1e-7 * q_scale;
            let mut h = |s: f64, d: f64| {
                model.mesh_events_at(i, s, d, &mut scratch);
                scratch[e]
            };
            let base = h(s, delta);
            let (by_approach, by_position) =
                ((h(s, delta + step) - base) / step, (h(s + step, delta) - base) / step);
            *evaluations += 3;
            let mut gradient = vec![0.0; mz];
            if rate.is_finite() && rate != 0.0 {
                gradient[g] = -by_approach * q_scale / rate;
                gradient[layout.position_column[g]] = -by_position * q_scale / rate;
            }
            if gradient.iter().any(|v| !v.is_finite()) {
                gradient.iter_mut().for_each(|v| *v = 0.0);
            }
            found.push(Switch::with_gradient(time, vec![jump], vec![kink], gradient));
        }
        Ok(found)
    }

    /// The cosine and sine sums (1/N) Σ x_j (cos, sin) pθ_j, p = 0 ..= 2H, of N samples `x`.
    fn spectrum(&self, x: &[f64], buffer: &mut [Complex<f64>], h: usize) -> (Vec<f64>, Vec<f64>) {
        let ns = x.len();
        for (z, v) in buffer.iter_mut().zip(x) {
            *z = Complex::new(*v, 0.0);
        }
        self.balance.plans().forward(buffer);
        let (mut c, mut s) = (vec![0.0; 2 * h + 1], vec![0.0; 2 * h + 1]);
        for p in 0..=2 * h {
            let z = buffer[p % ns];
            c[p] = z.re / ns as f64;
            s[p] = -z.im / ns as f64;
        }
        (c, s)
    }

    /// The periodic state at `omega` [rad/s] by Newton's method with a
    /// backtracking line search on the contact coordinates, from `guess`
    /// (their coefficients at the settings' H, of the symmetry the balance
    /// solves with) or the static state. The orbit comes back in the full
    /// balance's coordinates. Under [`Symmetry::Cyclic`], where the set has no
    /// cyclic symmetry or the orbit does not keep it (every mesh's residual at
    /// the orbit above [`SYMMETRY_TOLERANCE`]), the balance solves with every
    /// mesh from then on, from the cyclic orbit where there is one; the report
    /// says so.
    pub fn solve(
        &mut self,
        omega: f64,
        guess: Option<&[f64]>,
    ) -> Result<(HarmonicOrbit, CondensedReport), PeriodicError> {
        if self.symmetry == Symmetry::Full {
            return self.solve_started(omega, guess);
        }
        match self.solve_started(omega, guess) {
            Ok((orbit, report)) if report.symmetry_residual.is_some_and(|r| r <= SYMMETRY_TOLERANCE) => {
                Ok((orbit, report))
            }
            Ok((_, report)) => {
                let expanded = self.expanded.take().expect("kept by the symmetry check");
                let broken = report.symmetry_residual;
                self.set_symmetry(Symmetry::Full);
                let (orbit, mut report) = self.solve_here(omega, Some(&expanded))?;
                report.symmetry_residual = broken;
                report.cyclic_refused = Some("the orbit does not keep the planets' symmetry".into());
                Ok((orbit, report))
            }
            Err(PeriodicError::InvalidRequest { name, reason, .. }) if name == "symmetry" => {
                self.set_symmetry(Symmetry::Full);
                let (orbit, mut report) = self.solve_started(omega, None)?;
                report.cyclic_refused = Some(reason);
                Ok((orbit, report))
            }
            Err(e) => Err(e),
        }
    }

    /// [`Self::solve_here`]; where Newton does not converge from the static state, again from
    /// the period the march reaches after shooting's run-in (the full balance's cold start).
    fn solve_started(
        &mut self,
        omega: f64,
        guess: Option<&[f64]>,
    ) -> Result<(HarmonicOrbit, CondensedReport), PeriodicError> {
        match self.solve_here(omega, guess) {
            Err(PeriodicError::NotConverged { .. }) if guess.is_none() => {
                let mut newton = Newton::default();
                let y = self.balance.marched_start(omega, &mut newton)?;
                let marched = self.series(omega, y);
                let start = self.coordinates_of(&marched)?;
                let (mut orbit, report) = self.solve_here(omega, Some(&start))?;
                orbit.march_steps = newton.march_steps;
                orbit.force_evaluations += newton.evaluations;
                Ok((orbit, report))
            }
            other => other,
        }
    }

    /// The series `coefficients` (the full balance's blocks at the settings' H) at `omega`
    /// [rad/s] as an orbit without work.
    fn series(&self, omega: f64, coefficients: Vec<f64>) -> HarmonicOrbit {
        let problem = &self.balance.problem;
        HarmonicOrbit::of_coefficients(
            omega,
            (problem.period(omega), problem.cycles()),
            self.balance.settings.harmonics,
            coefficients,
        )
    }

    /// Solves with `symmetry` from now on: the layout and linear parts of another are dropped.
    fn set_symmetry(&mut self, symmetry: Symmetry) {
        if self.symmetry != symmetry {
            self.symmetry = symmetry;
            self.layout = None;
            self.linear = None;
            self.spare = None;
        }
    }

    /// [`Self::solve`] with the symmetry the balance holds.
    fn solve_here(
        &mut self,
        omega: f64,
        guess: Option<&[f64]>,
    ) -> Result<(HarmonicOrbit, CondensedReport), PeriodicError> {
        self.balance.samples = self.balance.settings.samples;
        self.prepare(omega)?;
        let h = self.balance.settings.harmonics;
        let mz = self.layout.as_ref().expect("prepared").coordinates();
        let size = mz * (2 * h + 1);
        if size > CONDENSED_UNKNOWNS {
            return Err(PeriodicError::InvalidRequest {
                name: "harmonics".into(),
                value: h.to_string(),
                reason: format!(
                    "{mz} contact coordinates × (2H + 1) = {size} unknowns, more than the {CONDENSED_UNKNOWNS} the \
                     condensed balance's dense LU takes"
                ),
            });
        }
        let mut x = match guess {
            Some(g) if g.len() == size => g.to_vec(),
            Some(g) => {
                return Err(PeriodicError::invalid(
                    "condensed harmonic-balance guess",
                    g.len() as f64,
                    &format!("must hold {size} coefficients"),
                ))
            }
            None => self.cold_start(omega),
        };
        let dims = (mz, self.layout.as_ref().expect("prepared").computed.len());
        let mut count = Count::default();
        // From a given guess (an orbit near, of the projected sums) straight to the projected
        // sums: where the teeth separate the plain sums' root lies several per cent away.
        let (mut last, mut steps) = (None, None);
        if guess.is_none() || !self.projected {
            let (evaluation, factorised) = self.plain_newton(omega, &mut x, dims, &mut count)?;
            (last, steps) = (Some(evaluation), factorised);
        }
        if self.projected {
            last = Some(self.projected_newton(omega, &mut x, dims, steps, &mut count)?);
        }
        let last = last.expect("the plain or the projected run");
        let Count { evaluations, iterations, factorizations } = count;
        let residual = max_abs(&last.residual);
        let symmetry_residual = match self.symmetry {
            Symmetry::Full => None,
            Symmetry::Cyclic => Some(self.symmetry_check(omega, &x)?),
        };
        let coefficients = self.expand(omega, &last.forces);
        let problem = &self.balance.problem;
        let orbit = HarmonicOrbit {
            speed: omega,
            period: problem.period(omega),
            cycles: problem.cycles(),
            harmonics: h,
            coefficients,
            iterations,
            residual,
            last_step: 0.0,
            factorizations,
            products: 0,
            force_evaluations: evaluations,
            march_steps: 0,
            neighbour: None,
            crossings: Vec::new(),
        };
        let report = CondensedReport {
            symmetry: self.symmetry,
            coordinates: mz,
            unknowns: size,
            iterations,
            residual,
            law_evaluations: evaluations,
            symmetry_residual,
            cyclic_refused: None,
        };
        Ok((orbit, report))
    }

    /// Newton on the plain sums from `x` (to their root, in place), with a backtracking line
    /// search; the factorised Jacobian kept as a chord while an iteration lowers the residual
    /// by the settings' `chord_contraction` or more. The last evaluation and factorisation.
    fn plain_newton(
        &mut self,
        omega: f64,
        x: &mut Vec<f64>,
        dims: (usize, usize),
        count: &mut Count,
    ) -> Result<(Evaluation, Option<Steps>), PeriodicError> {
        let settings = self.balance.settings;
        let mut steps: Option<Steps> = None;
        let mut last = self.evaluate(omega, x, (true, false), &mut count.evaluations)?;
        loop {
            let norm = max_abs(&last.residual);
            let scale = max_abs(x).max(1.0);
            if norm <= settings.tolerance * scale {
                return Ok((last, steps));
            }
            if count.iterations == settings.max_iterations {
                return Err(PeriodicError::NotConverged {
                    speed: omega,
                    iterations: count.iterations,
                    residual: norm,
                });
            }
            count.iterations += 1;
            let linear = self.linear.as_ref().expect("prepared");
            if let Some(conv) = last.convolution.take() {
                let storage = steps.take().map(|s| s.lu).unwrap_or_default();
                steps = Some(Steps::new(linear, conv, dims, storage));
                count.factorizations += 1;
            }
            let step = steps.as_ref().expect("factorised").step(&last.residual);
            let mut lambda = 1.0;
            let (trial, at) = loop {
                let xt: Vec<f64> = x.iter().zip(&step).map(|(x, d)| x + lambda * d).collect();
                let t = self.evaluate(omega, &xt, (false, false), &mut count.evaluations)?;
                if max_abs(&t.residual) < norm || lambda < 1.0 / 64.0 {
                    break (xt, t);
                }
                lambda *= 0.5;
            };
            *x = trial;
            let contracted = max_abs(&at.residual) <= settings.chord_contraction * norm;
            last =
                if contracted { at } else { self.evaluate(omega, x, (true, false), &mut count.evaluations)? };
            if lambda * max_abs(&step) <= settings.tolerance * scale && max_abs(&last.residual) <= norm {
                return Ok((last, steps));
            }
        }
    }

    /// Newton on the projected sums from `x` (in place): their Jacobian is the plain sums'
    /// with the switches' time terms, kept as a chord while an iteration lowers the residual
    /// by [`PROJECTED_CONTRACTION`] or more; stopped on the steps' contraction, or with an error
    /// where the residual grows past [`PROJECTED_DIVERGENCE`] times its first. `steps` lends
    /// its storage. The last evaluation.
    fn projected_newton(
        &mut self,
        omega: f64,
        x: &mut [f64],
        dims: (usize, usize),
        steps: Option<Steps>,
        count: &mut Count,
    ) -> Result<Evaluation, PeriodicError> {
        let tolerance = self.balance.settings.tolerance;
        let limit = 3 * self.balance.settings.max_iterations;
        let mut storage = steps.map(|s| s.lu).unwrap_or_default();
        let mut previous = None;
        let mut fresh = true;
        let mut last = self.evaluate(omega, x, (true, true), &mut count.evaluations)?;
        let first = max_abs(&last.residual);
        let mut steps = None;
        loop {
            if fresh {
                let conv = last.convolution.take().expect("asked for");
                let taken: Option<Steps> = steps.take();
                let lu = taken.map(|s| s.lu).unwrap_or_else(|| std::mem::take(&mut storage));
                steps = Some(Steps::new(self.linear.as_ref().expect("prepared"), conv, dims, lu));
                count.factorizations += 1;
                previous = None;
            }
            let norm = max_abs(&last.residual);
            let step = steps.as_ref().expect("factorised").step(&last.residual);
            x.iter_mut().zip(&step).for_each(|(x, d)| *x += d);
            last = self.evaluate(omega, x, (false, true), &mut count.evaluations)?;
            count.iterations += 1;
            let length = max_abs(&step) / max_abs(x).max(1.0);
            if length <= tolerance || newton_remainder(previous, length) <= tolerance {
                return Ok(last);
            }
            let diverged = max_abs(&last.residual) > PROJECTED_DIVERGENCE * first;
            if count.iterations >= limit || !length.is_finite() || diverged {
                let residual = max_abs(&last.residual);
                return Err(PeriodicError::NotConverged {
                    speed: omega,
                    iterations: count.iterations,
                    residual,
                });
            }
            previous = Some(length);
            fresh = max_abs(&last.residual) > PROJECTED_CONTRACTION * norm;
            if fresh {
                last = self.evaluate(omega, x, (true, true), &mut count.evaluations)?;
            }
        }
    }

    /// The static state's contact coordinates, no harmonics.
    fn cold_start(&self, omega: f64) -> Vec<f64> {
        let (m, n) = (self.balance.m, self.balance.n);
        let y = self.balance.cold_start(omega);
        let layout = self.layout.as_ref().expect("prepared");
        let mz = layout.coordinates();
        let mut x = vec![0.0; mz * (2 * self.balance.settings.harmonics + 1)];
        for (a, w) in layout.w.iter().enumerate() {
            x[a] = project_row(w, &self.balance.p, n, m).iter().zip(&y[..m]).map(|(u, v)| u * v).sum();
        }
        x
    }

    /// The contact coordinates of `orbit` (a full balance's, at the settings' H).
    pub fn coordinates_of(&mut self, orbit: &HarmonicOrbit) -> Result<Vec<f64>, PeriodicError> {
        self.prepare(orbit.speed)?;
        let (m, n) = (self.balance.m, self.balance.n);
        let layout = self.layout.as_ref().expect("prepared");
        let mz = layout.coordinates();
        let blocks = orbit.coefficients.len() / m;
        let wp: Vec<Vec<f64>> = layout.w.iter().map(|w| project_row(w, &self.balance.p, n, m)).collect();
        let mut x = vec![0.0; mz * (2 * self.balance.settings.harmonics + 1)];
        for c in 0..blocks.min(2 * self.balance.settings.harmonics + 1) {
            for (a, row) in wp.iter().enumerate() {
                x[c * mz + a] =
                    row.iter().zip(&orbit.coefficients[c * m..(c + 1) * m]).map(|(u, v)| u * v).sum();
            }
        }
        Ok(x)
    }

    /// The unknowns' coordinates (the full balance's blocks) of the orbit whose computed
    /// forces have the coefficients `forces`: y_k = A_k⁻¹ Pᵀ(g_k − Σ_j b_j F_j,k).
    fn expand(&self, omega: f64, forces: &[Vec<f64>]) -> Vec<f64> {
        let m = self.balance.m;
        let h = self.balance.settings.harmonics;
        let q_scale = self.balance.problem.q_scale;
        let nu = 2.0 * std::f64::consts::PI / self.balance.problem.period(omega);
        let layout = self.layout.as_ref().expect("prepared");
        let linear = self.linear.as_ref().expect("prepared");
        let mut y = vec![0.0; m * (2 * h + 1)];
        for k in 0..=h {
            let mut rhs = linear.pg[k].clone();
            for (j, (g, delay)) in layout.copies.iter().enumerate() {
                let f = if k == 0 {
                    Complex::new(forces[*g][0], 0.0)
                } else {
                    Complex::new(forces[*g][2 * k - 1], -forces[*g][2 * k])
                } * Complex::from_polar(1.0, -(k as f64) * 2.0 * std::f64::consts::PI * delay);
                for (r, pb) in rhs.iter_mut().zip(&linear.pb[j]) {
                    *r -= f * pb;
                }
            }
            let x = linear.solve(k, nu, vec![rhs]).expect("factorised at this speed before");
            for (a, v) in x[0].iter().enumerate() {
                put_complex(&mut y, m, k, a, v / q_scale);
            }
        }
        y
    }

    /// How far the coordinates `x` of an orbit with every mesh (the balance holds
    /// [`Symmetry::Full`]) lie from the planets' symmetry: the largest difference between a
    /// mesh's approach and the approach of the mesh it copies under cyclic symmetry, delayed
    /// by its phase, over every harmonic, relative to the largest coefficient. 0 for an orbit
    /// that keeps the symmetry; an error where the planets are not equally spaced copies.
    pub fn asymmetry(&mut self, omega: f64, x: &[f64]) -> Result<f64, PeriodicError> {
        if self.symmetry != Symmetry::Full {
            return Err(PeriodicError::invalid(
                "symmetry",
                0.0,
                "the asymmetry is measured on an orbit with every mesh (Symmetry::Full)",
            ));
        }
        self.layout_at(omega)?;
        let h = self.balance.settings.harmonics;
        let problem = &self.balance.problem;
        let cyclic =
            Layout::new(&problem.model, Symmetry::Cyclic, omega, problem.period(omega), problem.cycles())?;
        let fz = self.layout.as_ref().expect("built above").coordinates();
        if x.len() != fz * (2 * h + 1) {
            return Err(PeriodicError::invalid(
                "condensed harmonic-balance coefficients",
                x.len() as f64,
                "must hold every mesh's contact coordinates × (2H + 1) values",
            ));
        }
        let mut worst: f64 = 0.0;
        // In the full layout mesh i's approach is coordinate i.
        for (j, (g, delay)) in cyclic.copies.iter().enumerate() {
            let source = cyclic.computed[*g];
            for k in 0..=h {
                let shift = Complex::from_polar(1.0, -(k as f64) * 2.0 * std::f64::consts::PI * delay);
                worst =
                    worst.max((amplitude_of(x, fz, k, j) - amplitude_of(x, fz, k, source) * shift).norm());
            }
        }
        Ok(worst / max_abs(x).max(f64::MIN_POSITIVE))
    }

    /// Under cyclic symmetry: the largest residual coefficient of every mesh at the orbit
    /// whose planet-1 coordinates are `x`, the others delayed copies.
    fn symmetry_check(&mut self, omega: f64, x: &[f64]) -> Result<f64, PeriodicError> {
        let h = self.balance.settings.harmonics;
        let cyclic_layout = self.layout.take().expect("prepared");
        let cyclic_linear = self.linear.take();
        let cyclic_spare = self.spare.take();
        let result = (|| {
            let problem = &self.balance.problem;
            let full =
                Layout::new(&problem.model, Symmetry::Full, omega, problem.period(omega), problem.cycles())?;
            let (mz, fz) = (cyclic_layout.coordinates(), full.coordinates());
            let mut xf = vec![0.0; fz * (2 * h + 1)];
            // Approaches: each mesh its computed mesh's, delayed; positions as they are.
            for (j, (g, delay)) in cyclic_layout.copies.iter().enumerate() {
                for k in 0..=h {
                    let z = amplitude_of(x, mz, k, *g)
                        * Complex::from_polar(1.0, -(k as f64) * 2.0 * std::f64::consts::PI * delay);
                    put_complex(&mut xf, fz, k, j, z);
                }
            }
            for g in 0..cyclic_layout.computed.len() {
                let (from, to) =
                    (cyclic_layout.position_column[g], full.position_column[cyclic_layout.computed[g]]);
                for c in 0..2 * h + 1 {
                    xf[c * fz + to] = x[c * mz + from];
                }
            }
            self.layout = Some(full);
            self.prepare(omega)?;
            let mut evaluations = 0;
            let e = self.evaluate(omega, &xf, (false, self.projected), &mut evaluations)?;
            self.expanded = Some(xf);
            Ok(max_abs(&e.residual))
        })();
        self.layout = Some(cyclic_layout);
        self.linear = cyclic_linear;
        self.spare = cyclic_spare;
        result
    }
}

impl Linear {
    /// R f: the contact coordinates' response (blocks of `mz`) to the computed forces'
    /// coefficients `f` (blocks of `mf`).
    fn apply(&self, f: &[f64], dims: (usize, usize)) -> Vec<f64> {
        respond(&self.receptance, f, dims)
    }

    /// A_k at harmonic `k` (ν = `nu`), transposed when `transposed`.
    fn matrix(&self, k: usize, nu: f64, transposed: bool) -> faer::Mat<faer::c64> {
        let m = self.mass.len().isqrt();
        let w = k as f64 * nu;
        faer::Mat::<faer::c64>::from_fn(m, m, |i, j| {
            let e = if transposed { j + m * i } else { i + m * j };
            faer::c64::new(self.stiffness[e] - w * w * self.mass[e], w * self.damping[e])
        })
    }

    /// Solves A_k X = B for the complex columns `columns` (m each).
    fn solve(
        &self,
        k: usize,
        nu: f64,
        columns: Vec<Vec<Complex<f64>>>,
    ) -> Result<Vec<Vec<Complex<f64>>>, PeriodicError> {
        let m = self.mass.len().isqrt();
        let b = faer::Mat::<faer::c64>::from_fn(m, columns.len(), |i, j| columns[j][i]);
        let x = self.matrix(k, nu, false).partial_piv_lu().solve(&b);
        let out: Vec<Vec<Complex<f64>>> =
            (0..columns.len()).map(|j| (0..m).map(|i| x[(i, j)]).collect()).collect();
        if out.iter().flatten().any(|z| !z.re.is_finite() || !z.im.is_finite()) {
            return Err(singular(k));
        }
        Ok(out)
    }

    /// Y = A_k⁻ᵀ (WᵀP)ᵀ at harmonic `k` (ν = `nu`) into `out`, column a (m values) for the
    /// contact coordinate a of `wp` (its row of WᵀP): one LU of A_kᵀ, as many right-hand
    /// sides as contact coordinates (fewer than the meshes and the forcing).
    fn contact_rows(
        &self,
        k: usize,
        nu: f64,
        wp: &[Vec<f64>],
        out: &mut [Complex<f64>],
    ) -> Result<(), PeriodicError> {
        let m = self.mass.len().isqrt();
        let b = faer::Mat::<faer::c64>::from_fn(m, wp.len(), |i, j| faer::c64::new(wp[j][i], 0.0));
        let y = self.matrix(k, nu, true).partial_piv_lu().solve(&b);
        for (c, column) in out.chunks_mut(m).enumerate() {
            for (i, o) in column.iter_mut().enumerate() {
                *o = y[(i, c)];
            }
        }
        if out.iter().any(|z| !z.re.is_finite() || !z.im.is_finite()) {
            return Err(singular(k));
        }
        Ok(())
    }
}

/// A linear part singular at harmonic `k`.
fn singular(k: usize) -> PeriodicError {
    PeriodicError::invalid(
        "condensed balance",
        k as f64,
        "meets a singular linear part at this harmonic (a support-free coordinate)",
    )
}

/// Each computed mesh's mean tangent stiffness and damping over one period at the state `q0`.
fn reference_springs(
    model: &PlanetaryDynamics,
    layout: &Layout,
    q0: &[f64],
    (omega, period): (f64, f64),
    samples: usize,
) -> Vec<(f64, f64)> {
    layout
        .computed
        .iter()
        .enumerate()
        .map(|(g, i)| {
            let MeshCoordinates { approach: b, position: p, .. } = model.mesh_coordinates(*i);
            let delta: f64 = b.iter().map(|(j, x)| x * q0[*j]).sum();
            let position: f64 = p.iter().map(|(j, x)| x * q0[*j]).sum();
            let mean_at = |delta: f64| {
                let (mut k, mut c) = (0.0, 0.0);
                for j in 0..samples {
                    let t = period * j as f64 / samples as f64;
                    let (state, damping) =
                        model.mesh_at(*i, layout.s0[g] + layout.rate[g] * omega * t + position, delta, 0.0);
                    if state.stiffness.is_finite() && damping.is_finite() {
                        k += state.stiffness;
                        c += damping;
                    }
                }
                (k / samples as f64, c / samples as f64)
            };
            // A static state inside the backlash (a negative load: the mean-stiffness model
            // puts the coast flanks' approach inside the gap) has no tangent; any reference
            // has the same root, so the drive flanks' at the same approach serves.
            match mean_at(delta) {
                (0.0, _) => mean_at(delta.abs()),
                springs => springs,
            }
        })
        .collect()
}

/// R f for the receptances `receptance` (one per harmonic): the contact coordinates'
/// response (blocks of `mz`) to the computed forces' coefficients `f` (blocks of `mf`).
fn respond(receptance: &[Vec<Complex<f64>>], f: &[f64], (mz, mf): (usize, usize)) -> Vec<f64> {
    let mut out = vec![0.0; mz * (2 * receptance.len() - 1)];
    for (k, r) in receptance.iter().enumerate() {
        for g in 0..mf {
            let fg = amplitude_of(f, mf, k, g);
            if fg == Complex::new(0.0, 0.0) {
                continue;
            }
            for a in 0..mz {
                add_complex(&mut out, mz, k, a, r[a * mf + g] * fg);
            }
        }
    }
    out
}

/// Coordinate `a`'s value and rate at `t` \[s\] on the series `x` (blocks of `width`, `h`
/// harmonics, ν = `nu`).
fn series_at(x: &[f64], width: usize, a: usize, h: usize, nu: f64, t: f64) -> (f64, f64) {
    let (mut value, mut rate) = (x[a], 0.0);
    let (step_sin, step_cos) = (nu * t).sin_cos();
    let (mut sin, mut cos) = (0.0, 1.0);
    for k in 1..=h {
        (sin, cos) = (sin * step_cos + cos * step_sin, cos * step_cos - sin * step_sin);
        let (ak, bk) = (x[(2 * k - 1) * width + a], x[2 * k * width + a]);
        let w = k as f64 * nu;
        value += ak * cos + bk * sin;
        rate += w * (bk * cos - ak * sin);
    }
    (value, rate)
}

/// wᵀP: a model-coordinate vector seen from the unknowns' coordinates.
fn project_row(w: &[f64], p: &[f64], n: usize, m: usize) -> Vec<f64> {
    (0..m).map(|a| (0..n).map(|i| w[i] * p[i + n * a]).sum()).collect()
}

fn real_dot(row: &[f64], x: &[Complex<f64>]) -> Complex<f64> {
    row.iter().zip(x).map(|(r, z)| z * r).sum()
}

/// The complex amplitude Y_k = a_k − i b_k of coordinate `a` of the blocks `x` of width `width`.
fn amplitude_of(x: &[f64], width: usize, k: usize, a: usize) -> Complex<f64> {
    if k == 0 {
        Complex::new(x[a], 0.0)
    } else {
        Complex::new(x[(2 * k - 1) * width + a], -x[2 * k * width + a])
    }
}

/// Writes the amplitude `z` of harmonic `k` of coordinate `a` into the blocks `x`.
fn put_complex(x: &mut [f64], width: usize, k: usize, a: usize, z: Complex<f64>) {
    if k == 0 {
        x[a] = z.re;
    } else {
        x[(2 * k - 1) * width + a] = z.re;
        x[2 * k * width + a] = -z.im;
    }
}

/// Adds the amplitude `z` of harmonic `k` of coordinate `a` to the blocks `x`.
fn add_complex(x: &mut [f64], width: usize, k: usize, a: usize, z: Complex<f64>) {
    if k == 0 {
        x[a] += z.re;
    } else {
        x[(2 * k - 1) * width + a] += z.re;
        x[2 * k * width + a] -= z.im;
    }
}

#[cfg(test)]
mod tests_support {
    use super::super::HarmonicSettings;
    use super::*;
    use crate::contact::ltca::SetModel;
    use crate::dynamics::periodic::{PeriodicProblem, ShootingSettings};
    use crate::scene::{Fidelity, Scene};

    /// The example at `fidelity` condensed at `harmonics` (16 samples each) and `rpm`.
    pub(super) fn condensed(
        fidelity: Fidelity,
        harmonics: usize,
        rpm: f64,
        symmetry: Symmetry,
    ) -> (CondensedBalance, f64) {
        let mut scene = Scene::example_2004_stiff_pins();
        scene.dynamics.fidelity = fidelity;
        let set = scene.validate().unwrap();
        let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
        let omega = rpm * std::f64::consts::PI / 30.0;
        let problem = PeriodicProblem::new(model, ShootingSettings::default(), omega).unwrap();
        let settings = HarmonicSettings {
            harmonics,
            samples: 16 * harmonics,
            tolerance: 1e-11,
            ..HarmonicSettings::default()
        };
        (CondensedBalance::new(HarmonicBalance::new(problem, settings).unwrap(), symmetry), omega)
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::condensed;
    use super::Newton;
    use super::*;
    use crate::dynamics::rigid_frame::RigidFrame;
    use crate::scene::Fidelity;

    /// The model is its constant tangents plus its meshes: f(t, q, v) = g(t) − K₀q − C₀v
    /// − Σ b_j (F_j + D_j) in the rigid frame, at random states, to 1e-9 of the force.
    #[test]
    fn the_model_is_linear_but_for_its_meshes() {
        for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
            let (mut cb, omega) = condensed(fidelity, 8, 4000.0, Symmetry::Full);
            cb.prepare(omega).unwrap();
            let model = &mut cb.balance.problem.model;
            model.set_drive_speed(omega);
            let structure = model.low_rank_jacobian().unwrap();
            let n = model.dim();
            let rigid = model.rigid_velocity_at(omega);
            let b: Vec<Vec<f64>> =
                (0..model.mesh_count()).map(|i| dense(n, model.mesh_coordinates(i).approach)).collect();
            let mut frame = RigidFrame::new(model, rigid);
            let zero = vec![0.0; n];
            let (mut f0, mut f) = (vec![0.0; n], vec![0.0; n]);
            for trial in 0..3 {
                let t = 1e-5 * trial as f64;
                let q: Vec<f64> = (0..n).map(|i| 1e-6 * ((i * 7 + trial) as f64).sin()).collect();
                let v: Vec<f64> = (0..n).map(|i| 1e-3 * ((i * 5 + trial) as f64).cos()).collect();
                frame.force(t, &zero, &zero, &mut f0);
                let meshes0: Vec<f64> =
                    frame.model().meshes.iter().map(|s| s.force + s.damping_force).collect();
                frame.force(t, &q, &v, &mut f);
                let meshes: Vec<f64> =
                    frame.model().meshes.iter().map(|s| s.force + s.damping_force).collect();
                let scale = max_abs(&f).max(max_abs(&f0));
                for i in 0..n {
                    let mut expected = f0[i];
                    for j in 0..n {
                        expected -= structure.k0[(i, j)] * q[j] + structure.c0[(i, j)] * v[j];
                    }
                    for (bj, (now, before)) in b.iter().zip(meshes.iter().zip(&meshes0)) {
                        expected -= bj[i] * (now - before);
                    }
                    assert!(
                        (f[i] - expected).abs() <= 1e-9 * scale,
                        "{fidelity:?}, coordinate {i}: {} against {expected}",
                        f[i]
                    );
                }
            }
        }
    }

    /// The Jacobian I + R C is the derivative of the residual: central differences along three
    /// directions agree to 1e-5 of the product (the laws' kinks lie between the samples).
    #[test]
    fn the_condensed_jacobian_is_the_derivative_of_its_residual() {
        let (mut cb, omega) = condensed(Fidelity::TransverseTorsional, 16, 6000.0, Symmetry::Full);
        cb.prepare(omega).unwrap();
        let x = cb.cold_start(omega);
        for (k, off) in jacobian_against_differences(&mut cb, omega, &x, false).into_iter().enumerate() {
            assert!(off <= 1e-5, "direction {k}: off by {off:.3e} of the product");
        }
    }

    /// With the switches projected, on the separating orbit at 10 200 rpm (the sun–planet mesh
    /// apart for 4.7 % of the period), the Jacobian with the switches' time terms is the
    /// derivative of the projected residual to 1.5e-2 of the product (central differences of
    /// steps 1e-2 to 1e-3 agree with each other): measured 1.17e-2, against 1.48e-2 without
    /// the time terms. What it leaves out is the jumps' sizes moving with x times the
    /// difference between the sawtooth's exact and sampled coefficients (1.3 % at k = H with
    /// N = 16 H), so Newton on the projected sums contracts by about 1e-2 per iteration.
    #[test]
    fn the_projected_jacobian_carries_the_switches_times() {
        let (mut cb, omega) = condensed(Fidelity::TransverseTorsional, 50, 10200.0, Symmetry::Cyclic);
        let (orbit, _) = cb.solve(omega, None).unwrap();
        let x = cb.coordinates_of(&orbit).unwrap();
        let offs = jacobian_against_differences(&mut cb, omega, &x, true);
        for (k, off) in offs.into_iter().enumerate() {
            assert!(off <= 1.5e-2, "direction {k}: off by {off:.3e} of the product");
        }
    }

    /// The largest difference, relative to the product's largest entry, between J d and
    /// central differences of the residual along three directions d at `x`.
    fn jacobian_against_differences(
        cb: &mut CondensedBalance,
        omega: f64,
        x: &[f64],
        switches: bool,
    ) -> Vec<f64> {
        let size = x.len();
        let mut evaluations = 0;
        cb.prepare(omega).unwrap();
        let at = cb.evaluate(omega, x, (true, switches), &mut evaluations).unwrap();
        let conv = at.convolution.unwrap();
        let layout = cb.layout.as_ref().unwrap();
        let dims = (layout.coordinates(), layout.computed.len());
        let rows = conv.len() / size;
        // J d = d + R (C d).
        let times = |d: &[f64]| -> Vec<f64> {
            let cd: Vec<f64> =
                (0..rows).map(|r| (0..size).map(|c| conv[r + rows * c] * d[c]).sum()).collect();
            let rcd = cb.linear.as_ref().unwrap().apply(&cd, dims);
            d.iter().zip(&rcd).map(|(a, b)| a + b).collect()
        };
        let directions: Vec<Vec<f64>> =
            (0..3).map(|k| (0..size).map(|i| 1e-3 * ((i * (k + 3)) as f64 * 0.37).sin()).collect()).collect();
        let products: Vec<Vec<f64>> = directions.iter().map(|d| times(d)).collect();
        let mut offs = Vec::new();
        for (d, product) in directions.iter().zip(&products) {
            let mut shifted = |sign: f64| {
                let xs: Vec<f64> = x.iter().zip(d.iter()).map(|(x, d)| x + sign * 1e-4 * d).collect();
                cb.evaluate(omega, &xs, (false, switches), &mut evaluations).unwrap().residual
            };
            let (rp, rm) = (shifted(1.0), shifted(-1.0));
            let difference: Vec<f64> = rp.iter().zip(&rm).map(|(p, m)| (p - m) / 2e-4).collect();
            let off = product.iter().zip(&difference).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            offs.push(off / max_abs(product));
        }
        offs
    }

    /// Condensed and full: the condensed root, expanded to every coordinate, is the full
    /// balance's root of the plain sums at the same H and N (residual below the full solve's
    /// tolerance), and the coefficients agree to 1e-8 of the static deflection.
    #[test]
    fn the_condensed_root_is_the_full_balances() {
        for (fidelity, rpm) in [(Fidelity::Torsional, 3000.0), (Fidelity::TransverseTorsional, 6000.0)] {
            let (mut cb, omega) = condensed(fidelity, 32, rpm, Symmetry::Full);
            cb.set_projected(false);
            let (orbit, report) = cb.solve(omega, None).unwrap();
            assert!(report.residual <= 1e-10, "{fidelity:?}: residual {:.3e}", report.residual);
            let hb = cb.balance();
            let mut evaluations = 0;
            hb.samples = hb.settings.samples;
            let residual = hb.evaluate(omega, &orbit.coefficients, None, &mut evaluations, false).unwrap();
            // The full balance's residual (accelerations per static deflection times ν²).
            assert!(max_abs(&residual) <= 1e-9, "{fidelity:?}: full residual {:.3e}", max_abs(&residual));
            let mut newton = Newton::default();
            let x = orbit.coefficients.clone();
            newton.jacobian = hb.take_jacobian(x.len());
            let r =
                hb.evaluate(omega, &x, Some(&mut newton.jacobian), &mut newton.evaluations, false).unwrap();
            newton.factorize(x.len());
            let (full, _, _) = hb.newton(omega, x, r, false, &mut newton).unwrap();
            let moved = full.iter().zip(&orbit.coefficients).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(moved <= 1e-8, "{fidelity:?}: the full balance moved the root by {moved:.3e}");
        }
    }
}

#[cfg(test)]
mod symmetry_tests {
    use super::tests_support::condensed;
    use super::*;
    use crate::scene::Fidelity;

    /// Symmetric and full: on the example's equally spaced planets the cyclic solve (planet 1's
    /// two meshes) gives the full condensed solve's orbit, and every mesh's residual at it
    /// vanishes.
    #[test]
    fn the_cyclic_solve_is_the_full_solve_while_the_orbit_keeps_the_symmetry() {
        for (fidelity, rpm) in
            [(crate::scene::Fidelity::Torsional, 3000.0), (Fidelity::TransverseTorsional, 6000.0)]
        {
            let (mut full, omega) = condensed(fidelity, 32, rpm, Symmetry::Full);
            let (mut cyclic, _) = condensed(fidelity, 32, rpm, Symmetry::Cyclic);
            let (a, ra) = full.solve(omega, None).unwrap();
            let (b, rb) = cyclic.solve(omega, None).unwrap();
            let apart =
                a.coefficients.iter().zip(&b.coefficients).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
            assert!(rb.unknowns < ra.unknowns);
            assert!(rb.symmetry_residual.unwrap() <= 1e-9, "symmetry residual {:?}", rb.symmetry_residual);
            assert!(apart <= 1e-8, "{fidelity:?}: {apart:.3e} apart");
        }
    }
}
