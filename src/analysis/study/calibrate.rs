//! Calibration: chosen scene parameters fitted to target natural
//! frequencies and loaded double-contact shares.
//!
//! A [`Plan`] names a base scene, the targets (a natural frequency of a
//! given mode class and order in a given fidelity, or the loaded
//! double-contact share of a mesh) and the free parameters, each a real
//! scene key with bounds (several keys may share one value, e.g. the
//! chamfer heights of sun and planet). [`calibrate`] fits them by
//! Levenberg–Marquardt on the logarithms of the parameters, projected onto
//! their bounds, with the residual of each target its relative error over
//! its tolerance, and reports per target the value reached and per
//! parameter the start, the fitted value, the ratio and the sensitivity
//! ∂ln(target)/∂ln(parameter) of every target.
//!
//! A fit is refused when it is ill-posed: more free parameters than
//! targets, free parameters that no combination of the targets can tell
//! apart (a singular value of the scaled Jacobian below [`RANK_TOLERANCE`]
//! of the largest), or a parameter that ends on one of its bounds.
//!
//! Why a small hand-written solver: the Levenberg–Marquardt crates fit
//! unbounded problems; bounds by a change of variables would hide a
//! parameter that runs to its bound, which the calibration must report.

use std::collections::HashMap;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::analysis::modes::{natural_modes, ModeClass};
use crate::contact::deformable::set::DeformableSet;
use crate::contact::ltca::SetModel;
use crate::contact::mesh_law::MeshContact;
use crate::dynamics::equations::PlanetaryDynamics;
use crate::model::gear::MeshKind;
use crate::model::lumped::Fidelity;
use crate::scene::{KeyError, Scene, SceneError};

/// A singular value of the scaled Jacobian below this fraction of the
/// largest marks free parameters the targets cannot tell apart.
pub const RANK_TOLERANCE: f64 = 1e-4;

/// Relative distance (in ln p) from a bound at which a parameter counts as on it.
const AT_BOUND: f64 = 1e-6;

/// What a target measures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Measure {
    /// A natural frequency \[Hz\] of the mean-stiffness linear model: the
    /// `order`-th distinct frequency (1 = lowest) of the modes of `class`
    /// in the `fidelity` model.
    Frequency {
        /// Degrees of freedom of the model.
        fidelity: Fidelity,
        /// Mode class (rotational, translational, planet).
        class: ModeClass,
        /// 1 for the lowest distinct frequency of the class.
        order: usize,
    },
    /// The share of the mesh cycle with two or more pairs loaded under the
    /// scene's torque, from the loaded engagement of one pair [-].
    DoubleContact {
        /// The mesh.
        mesh: MeshKind,
    },
}

impl Measure {
    /// A short description for tables.
    pub fn describe(&self) -> String {
        match self {
            Measure::Frequency { fidelity, class, order } => {
                let f = match fidelity {
                    Fidelity::Torsional => "torsional",
                    Fidelity::TransverseTorsional => "transverse–torsional",
                };
                let class = format!("{class:?}").to_lowercase();
                format!("{f} {class} mode #{order} [Hz]")
            }
            Measure::DoubleContact { mesh } => format!("{} double-contact share [-]", mesh.name()),
        }
    }
}

/// One target of a calibration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Target {
    /// What is measured.
    pub measure: Measure,
    /// The value to reach [Hz or -].
    pub value: f64,
    /// Relative tolerance: the target is met when |value reached / value − 1| ≤ tolerance [-].
    pub tolerance: f64,
}

/// One free parameter: one or more scene keys that share a value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Free {
    /// Scene keys (dotted paths, file units); all take the same value.
    pub keys: Vec<String>,
    /// Lower bound (file units, > 0).
    pub min: f64,
    /// Upper bound (file units).
    pub max: f64,
}

impl Free {
    /// The parameter's name: its keys joined by " = ".
    pub fn name(&self) -> String {
        self.keys.join(" = ")
    }
}

/// A calibration: the base scene, the targets and the free parameters.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The scene to start from.
    pub base: Scene,
    /// Name of the calibrated scene.
    pub name: String,
    /// Targets.
    pub targets: Vec<Target>,
    /// Free parameters.
    pub free: Vec<Free>,
    /// Largest number of Levenberg–Marquardt iterations.
    pub max_iterations: usize,
}

impl Plan {
    /// A plan on `base` with `targets` and `free` parameters, at most 100 iterations.
    pub fn new(base: Scene, name: &str, targets: Vec<Target>, free: Vec<Free>) -> Self {
        Self { base, name: name.into(), targets, free, max_iterations: 100 }
    }
}

/// Why a calibration was refused.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationError {
    /// The plan cannot be used as written.
    #[error("calibration plan: {0}")]
    Plan(String),
    /// A scene key cannot be read or set.
    #[error("calibration plan: {0}")]
    Key(#[from] KeyError),
    /// The base scene, or the scene at some parameter values, is invalid.
    #[error("the scene at the parameter values {values} is invalid: {source}")]
    Scene {
        /// The parameter values tried.
        values: String,
        /// The scene's problems.
        source: SceneError,
    },
    /// A target cannot be measured on the scene.
    #[error("target {target}: {why}")]
    Measure {
        /// The target.
        target: String,
        /// Why.
        why: String,
    },
    /// The fit is ill-posed; the report says where it stopped.
    #[error("ill-posed calibration: {why}")]
    IllPosed {
        /// What makes it ill-posed, naming the parameters.
        why: String,
        /// The state of the fit when it was refused.
        report: Box<Report>,
    },
}

/// The outcome for one target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TargetResult {
    /// The target.
    pub target: Target,
    /// Value at the start.
    pub start: f64,
    /// Value reached.
    pub reached: f64,
    /// Relative residual, reached / target − 1 [-].
    pub residual: f64,
    /// Whether |residual| ≤ tolerance.
    pub met: bool,
}

/// The outcome for one free parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParameterResult {
    /// The parameter.
    pub free: Free,
    /// Start value (file units).
    pub start: f64,
    /// Fitted value (file units).
    pub fitted: f64,
    /// fitted / start [-].
    pub ratio: f64,
    /// ∂ln(target)/∂ln(parameter) at the fitted values, one per target [-].
    pub sensitivity: Vec<f64>,
    /// `Some("min")` or `Some("max")` when the parameter ended on a bound.
    pub at_bound: Option<String>,
}

/// What a calibration gives.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Name of the calibrated scene.
    pub name: String,
    /// Per target.
    pub targets: Vec<TargetResult>,
    /// Per free parameter.
    pub parameters: Vec<ParameterResult>,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// Scene evaluations (each a set of modal analyses and LTCAs).
    pub evaluations: usize,
    /// Contact models built (a chamfer or stiffness change needs a new one).
    pub contact_models: usize,
    /// Singular values of the scaled Jacobian at the fit, largest first.
    pub singular_values: Vec<f64>,
    /// Wall time \[s\].
    pub seconds: f64,
}

/// The calibrated scene and its report.
#[derive(Clone, Debug)]
pub struct Calibrated {
    /// The scene with the fitted values, derived defaults written out.
    pub scene: Scene,
    /// The report.
    pub report: Report,
}

/// Evaluates targets on scenes, caching contact models by geometry.
struct Evaluator<'a> {
    plan: &'a Plan,
    base: Scene,
    contact: HashMap<String, SetModel>,
    evaluations: usize,
}

impl<'a> Evaluator<'a> {
    fn scene_at(&self, p: &[f64]) -> Result<Scene, CalibrationError> {
        let mut s = self.base.clone();
        for (free, v) in self.plan.free.iter().zip(p) {
            for key in &free.keys {
                s = s.with_value(key, *v)?;
            }
        }
        Ok(s)
    }

    /// The contact-relevant part of a scene: what the contact models depend on.
    fn contact_key(scene: &Scene) -> String {
        serde_json::json!({
            "sun": scene.sun, "planet": scene.planet, "ring": scene.ring, "planets": scene.planets,
            "centre_distance_mm": crate::scene::units::m_to_mm(scene.centre_distance), "material": scene.material,
            "analysis": scene.analysis, "mesh_stiffness": scene.mesh_stiffness,
        })
        .to_string()
    }

    fn values(&mut self, p: &[f64]) -> Result<Vec<f64>, CalibrationError> {
        self.evaluations += 1;
        let scene = self.scene_at(p)?;
        let describe = || {
            self.plan
                .free
                .iter()
                .zip(p)
                .map(|(f, v)| format!("{} = {v:.6e}", f.name()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let set =
            scene.validate().map_err(|source| CalibrationError::Scene { values: describe(), source })?;
        let key = Self::contact_key(&scene);
        let contact = self.contact.entry(key).or_insert_with(|| SetModel::new(&set)).clone();
        let mut lumped: HashMap<String, Vec<crate::analysis::modes::Mode>> = HashMap::new();
        let mut out = Vec::with_capacity(self.plan.targets.len());
        for t in &self.plan.targets {
            let fail = |why: String| CalibrationError::Measure { target: t.measure.describe(), why };
            let v = match &t.measure {
                Measure::Frequency { fidelity, class, order } => {
                    let fkey = format!("{fidelity:?}");
                    if !lumped.contains_key(&fkey) {
                        // The fidelity is a term of the equations, so of the
                        // gear set: this fidelity's set from the scene.
                        let mut at = scene.clone();
                        at.dynamics.fidelity = *fidelity;
                        let s = at.validate().map_err(|e| fail(e.to_string()))?;
                        let model =
                            PlanetaryDynamics::new(&s, contact.clone()).map_err(|e| fail(e.to_string()))?;
                        lumped.insert(fkey.clone(), natural_modes(&model.lumped));
                    }
                    let modes = &lumped[&fkey];
                    let mut distinct: Vec<f64> = Vec::new();
                    for m in modes.iter().filter(|m| m.class == *class) {
                        if distinct.last().is_none_or(|f| (m.frequency - f).abs() > 1e-6 * m.frequency) {
                            distinct.push(m.frequency);
                        }
                    }
                    *distinct.get(order.saturating_sub(1)).ok_or_else(|| {
                        fail(format!("the model has {} distinct {class:?} frequencies", distinct.len()))
                    })?
                }
                Measure::DoubleContact { mesh } => {
                    // The law the scene chose, on the unworn set (kept once built).
                    let law = DeformableSet::of_set_model(&set, &contact).map_err(|e| fail(e.to_string()))?;
                    match MeshContact::of(&contact, law.as_deref(), *mesh) {
                        MeshContact::Pair(m) => m.double_contact_share(set.mesh_load_per_planet()),
                        MeshContact::Deformable(t) => t
                            .mesh
                            .double_contact_share(set.mesh_load_per_planet())
                            .map_err(|e| fail(e.to_string()))?,
                    }
                }
            };
            if !(v.is_finite() && v > 0.0) {
                return Err(fail(format!("measured {v}, which cannot be fitted (it must be positive)")));
            }
            out.push(v);
        }
        Ok(out)
    }
}

/// Scaled residuals (v / target − 1) / tolerance.
fn residuals(targets: &[Target], values: &[f64]) -> DVector<f64> {
    DVector::from_iterator(
        targets.len(),
        targets.iter().zip(values).map(|(t, v)| (v / t.value - 1.0) / t.tolerance),
    )
}

fn check_plan(plan: &Plan) -> Result<(), CalibrationError> {
    let bad = |s: String| Err(CalibrationError::Plan(s));
    if plan.targets.is_empty() {
        return bad("no target: give at least one [[target]]".into());
    }
    if plan.free.is_empty() {
        return bad("no free parameter: give at least one [[free]]".into());
    }
    for t in &plan.targets {
        if !(t.value.is_finite() && t.value > 0.0) {
            return bad(format!(
                "target {}: value {} must be finite and positive",
                t.measure.describe(),
                t.value
            ));
        }
        if !(t.tolerance.is_finite() && t.tolerance > 0.0 && t.tolerance < 1.0) {
            return bad(format!(
                "target {}: tolerance {} must lie between 0 and 1 (a relative error)",
                t.measure.describe(),
                t.tolerance
            ));
        }
        if let Measure::Frequency { order: 0, .. } = t.measure {
            return bad(format!("target {}: order counts from 1 (the lowest)", t.measure.describe()));
        }
    }
    for f in &plan.free {
        if f.keys.is_empty() {
            return bad("a [[free]] parameter without keys".into());
        }
        if !(f.min.is_finite() && f.max.is_finite() && f.min > 0.0 && f.max > f.min) {
            return bad(format!(
                "free parameter {}: bounds min = {}, max = {} must be finite with 0 < min < max",
                f.name(),
                f.min,
                f.max
            ));
        }
    }
    if plan.free.len() > plan.targets.len() {
        return bad(format!(
            "{} free parameters ({}) but only {} targets: free at most as many parameters as there are targets",
            plan.free.len(),
            plan.free.iter().map(Free::name).collect::<Vec<_>>().join(", "),
            plan.targets.len()
        ));
    }
    Ok(())
}

/// Jacobian of the scaled residuals with respect to ln p, by forward differences.
fn jacobian(
    ev: &mut Evaluator,
    x: &[f64],
    r: &DVector<f64>,
    bounds: &[(f64, f64)],
) -> Result<DMatrix<f64>, CalibrationError> {
    let mut j = DMatrix::zeros(r.len(), x.len());
    for k in 0..x.len() {
        // Step into the box: backwards at the upper bound.
        let h = if x[k] + 1e-6 > bounds[k].1 { -1e-6 } else { 1e-6 };
        let mut xp = x.to_vec();
        xp[k] += h;
        let p: Vec<f64> = xp.iter().map(|v| v.exp()).collect();
        let rp = residuals(&ev.plan.targets, &ev.values(&p)?);
        for i in 0..r.len() {
            j[(i, k)] = (rp[i] - r[i]) / h;
        }
    }
    Ok(j)
}

fn singular_values(j: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>) {
    let svd = j.clone().svd(false, true);
    let mut pairs: Vec<(f64, usize)> = svd.singular_values.iter().copied().zip(0..).collect();
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
    let vt = svd.v_t.unwrap_or_else(|| DMatrix::zeros(0, 0));
    let mut sorted = DMatrix::zeros(vt.nrows(), vt.ncols());
    for (row, (_, i)) in pairs.iter().enumerate() {
        if *i < vt.nrows() {
            sorted.set_row(row, &vt.row(*i));
        }
    }
    (pairs.into_iter().map(|p| p.0).collect(), sorted)
}

/// Runs the calibration of `plan`.
pub fn calibrate(plan: &Plan) -> Result<Calibrated, CalibrationError> {
    let started = std::time::Instant::now();
    check_plan(plan)?;
    let base = plan
        .base
        .explicit()
        .map_err(|source| CalibrationError::Scene { values: "of the base scene".into(), source })?;
    let mut start = Vec::new();
    for f in &plan.free {
        let v = base.value_at(&f.keys[0])?;
        for k in &f.keys[1..] {
            base.value_at(k)?;
        }
        if v.is_nan() || v <= 0.0 {
            return Err(CalibrationError::Plan(format!(
                "free parameter {}: start value {v} must be positive (parameters are fitted on a log scale)",
                f.name()
            )));
        }
        start.push(v.clamp(f.min, f.max));
    }
    let mut ev = Evaluator { plan, base, contact: HashMap::new(), evaluations: 0 };
    let bounds: Vec<(f64, f64)> = plan.free.iter().map(|f| (f.min.ln(), f.max.ln())).collect();
    let mut x: Vec<f64> = start.iter().map(|v| v.ln()).collect();
    let start_values = ev.values(&start)?;
    let mut r = residuals(&plan.targets, &start_values);
    let mut cost = r.norm_squared();
    let mut j = jacobian(&mut ev, &x, &r, &bounds)?;
    // Refuse a plan whose free parameters the targets cannot tell apart at the start.
    let (sv, vt) = singular_values(&j);
    if let Some(why) = rank_problem(&sv, &vt, plan) {
        let report = make_report(plan, &mut ev, &start, &start_values, &x, &j, 0, started)?;
        return Err(CalibrationError::IllPosed { why, report: Box::new(report) });
    }
    let mut lambda = 1e-3;
    let mut iterations = 0;
    while iterations < plan.max_iterations {
        iterations += 1;
        let jtj = j.transpose() * &j;
        let g = j.transpose() * &r;
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj.clone();
            for k in 0..x.len() {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.lu().solve(&(-&g)) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = x
                .iter()
                .zip(step.iter())
                .zip(&bounds)
                .map(|((xi, d), (lo, hi))| (xi + d).clamp(*lo, *hi))
                .collect();
            let p: Vec<f64> = trial.iter().map(|v| v.exp()).collect();
            let rt = residuals(&plan.targets, &ev.values(&p)?);
            let ct = rt.norm_squared();
            if ct < cost {
                let moved = trial.iter().zip(&x).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                let gain = cost - ct;
                x = trial;
                r = rt;
                cost = ct;
                lambda = (lambda / 3.0).max(1e-12);
                improved = true;
                if moved < 1e-12 || gain < 1e-16 * (1.0 + cost) {
                    lambda = f64::NAN;
                }
                break;
            }
            lambda *= 4.0;
        }
        if !improved || lambda.is_nan() {
            break;
        }
        j = jacobian(&mut ev, &x, &r, &bounds)?;
    }
    let p: Vec<f64> = x.iter().map(|v| v.exp()).collect();
    let report = make_report(plan, &mut ev, &start, &start_values, &x, &j, iterations, started)?;
    let on_bound: Vec<String> = report
        .parameters
        .iter()
        .filter_map(|pr| {
            pr.at_bound.as_ref().map(|b| format!("{} at its {b} ({:.6e})", pr.free.name(), pr.fitted))
        })
        .collect();
    if !on_bound.is_empty() {
        return Err(CalibrationError::IllPosed {
            why: format!(
                "{}: the targets pull it beyond its bounds; widen them if that is physical, or fix the parameter",
                on_bound.join("; ")
            ),
            report: Box::new(report),
        });
    }
    let (sv, vt) = singular_values(&j);
    if let Some(why) = rank_problem(&sv, &vt, plan) {
        return Err(CalibrationError::IllPosed { why, report: Box::new(report) });
    }
    let mut scene = ev.scene_at(&p)?;
    scene.name = plan.name.clone();
    Ok(Calibrated { scene, report })
}

/// Names the free parameters that the targets cannot tell apart, if any.
fn rank_problem(sv: &[f64], vt: &DMatrix<f64>, plan: &Plan) -> Option<String> {
    let largest = sv.first().copied().unwrap_or(0.0);
    let weak: Vec<usize> =
        (0..sv.len()).filter(|i| !(sv[*i] > RANK_TOLERANCE * largest && sv[*i] > 0.0)).collect();
    if weak.is_empty() {
        return None;
    }
    let mut names = Vec::new();
    for i in &weak {
        if *i >= vt.nrows() {
            continue;
        }
        let row = vt.row(*i);
        let big = row.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let involved: Vec<String> = (0..row.len())
            .filter(|k| row[*k].abs() >= 0.3 * big)
            .map(|k| format!("{} ({:+.2})", plan.free[k].name(), row[k]))
            .collect();
        names.push(involved.join(" with "));
    }
    Some(format!(
        "{} of {} free parameters are not independently sensitive to the targets (singular values {}): the targets cannot tell apart {}; fix one of them or add a target that separates them",
        weak.len(),
        plan.free.len(),
        sv.iter().map(|v| format!("{v:.3e}")).collect::<Vec<_>>().join(", "),
        names.join("; ")
    ))
}

#[allow(clippy::too_many_arguments)]
fn make_report(
    plan: &Plan,
    ev: &mut Evaluator,
    start: &[f64],
    start_values: &[f64],
    x: &[f64],
    j: &DMatrix<f64>,
    iterations: usize,
    started: std::time::Instant,
) -> Result<Report, CalibrationError> {
    let p: Vec<f64> = x.iter().map(|v| v.exp()).collect();
    let reached = ev.values(&p)?;
    let targets = plan
        .targets
        .iter()
        .zip(start_values)
        .zip(&reached)
        .map(|((t, s), v)| {
            let residual = v / t.value - 1.0;
            TargetResult {
                target: t.clone(),
                start: *s,
                reached: *v,
                residual,
                met: residual.abs() <= t.tolerance,
            }
        })
        .collect();
    let parameters = plan
        .free
        .iter()
        .enumerate()
        .map(|(k, f)| {
            // ∂ln v/∂ln p = J · tolerance · target / v.
            let sensitivity = plan
                .targets
                .iter()
                .zip(&reached)
                .enumerate()
                .map(|(i, (t, v))| j[(i, k)] * t.tolerance * t.value / v)
                .collect();
            let (lo, hi) = (f.min.ln(), f.max.ln());
            let at_bound = if x[k] <= lo + AT_BOUND {
                Some("minimum".to_string())
            } else if x[k] >= hi - AT_BOUND {
                Some("maximum".to_string())
            } else {
                None
            };
            ParameterResult {
                free: f.clone(),
                start: start[k],
                fitted: p[k],
                ratio: p[k] / start[k],
                sensitivity,
                at_bound,
            }
        })
        .collect();
    Ok(Report {
        name: plan.name.clone(),
        targets,
        parameters,
        iterations,
        evaluations: ev.evaluations,
        contact_models: ev.contact.len(),
        singular_values: singular_values(j).0,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// A target as written in a plan file: `kind = "frequency"` with
/// `fidelity`, `class` and `order`, or `kind = "double_contact"` with `mesh`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetSpec {
    /// `frequency` or `double_contact`.
    pub kind: String,
    /// Fidelity of a frequency target.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fidelity: Option<Fidelity>,
    /// Mode class of a frequency target.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub class: Option<ModeClass>,
    /// Order within the class of a frequency target (1 = lowest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<usize>,
    /// Mesh of a double-contact target.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshKind>,
    /// The value to reach [Hz or -].
    pub value: f64,
    /// Relative tolerance [-].
    pub tolerance: f64,
}

impl TargetSpec {
    /// The spec of a target.
    pub fn of(t: &Target) -> Self {
        let mut spec = TargetSpec {
            kind: String::new(),
            fidelity: None,
            class: None,
            order: None,
            mesh: None,
            value: t.value,
            tolerance: t.tolerance,
        };
        match &t.measure {
            Measure::Frequency { fidelity, class, order } => {
                spec.kind = "frequency".into();
                spec.fidelity = Some(*fidelity);
                spec.class = Some(*class);
                spec.order = Some(*order);
            }
            Measure::DoubleContact { mesh } => {
                spec.kind = "double_contact".into();
                spec.mesh = Some(*mesh);
            }
        }
        spec
    }

    /// The target, or what is missing or extra (target number `i`, from 1).
    pub fn target(&self, i: usize) -> Result<Target, CalibrationError> {
        let bad =
            |why: &str| Err(CalibrationError::Plan(format!("target {i} (kind = {:?}): {why}", self.kind)));
        let measure = match self.kind.as_str() {
            "frequency" => {
                if self.mesh.is_some() {
                    return bad("a frequency target takes fidelity, class and order, not mesh");
                }
                match (self.fidelity, self.class, self.order) {
                    (Some(fidelity), Some(class), Some(order)) => Measure::Frequency { fidelity, class, order },
                    _ => {
                        return bad("a frequency target needs fidelity (torsional, transverse_torsional), class (rotational, translational, planet) and order (1 = lowest)")
                    }
                }
            }
            "double_contact" => {
                if self.fidelity.is_some() || self.class.is_some() || self.order.is_some() {
                    return bad("a double_contact target takes mesh, not fidelity, class or order");
                }
                match self.mesh {
                    Some(mesh) => Measure::DoubleContact { mesh },
                    None => return bad("a double_contact target needs mesh (sun_planet or ring_planet)"),
                }
            }
            _ => return bad("kind must be frequency or double_contact"),
        };
        Ok(Target { measure, value: self.value, tolerance: self.tolerance })
    }
}

/// A calibration plan as written in a TOML file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanFile {
    /// The base scene: a built-in name or a scene file (relative to the plan file).
    pub base: String,
    /// Name of the calibrated scene.
    pub name: String,
    /// Largest number of iterations (default 100).
    #[serde(default = "default_iterations")]
    pub max_iterations: usize,
    /// Targets.
    #[serde(rename = "target")]
    pub targets: Vec<TargetSpec>,
    /// Free parameters.
    #[serde(rename = "free")]
    pub free: Vec<Free>,
    /// Values set on the base scene before the fit (choices made for a
    /// reason, not fitted): scene key → value, any type.
    #[serde(default, skip_serializing_if = "toml::Table::is_empty")]
    pub set: toml::Table,
}

fn default_iterations() -> usize {
    100
}

impl PlanFile {
    /// Parses a plan file's text.
    pub fn from_toml(text: &str) -> Result<Self, CalibrationError> {
        toml::from_str(text).map_err(|e| CalibrationError::Plan(e.to_string()))
    }

    /// The plan file as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// The plan on its base scene: the derived defaults written out
    /// ([`Scene::explicit`]), then the `set` values; every target is checked.
    pub fn plan(&self, base: &Scene) -> Result<Plan, CalibrationError> {
        let targets =
            self.targets.iter().enumerate().map(|(i, t)| t.target(i + 1)).collect::<Result<_, _>>()?;
        let mut scene = base
            .explicit()
            .map_err(|source| CalibrationError::Scene { values: "of the base scene".into(), source })?;
        for (key, value) in &self.set {
            scene = scene.with_toml(key, value.clone())?;
        }
        Ok(Plan {
            base: scene,
            name: self.name.clone(),
            targets,
            free: self.free.clone(),
            max_iterations: self.max_iterations,
        })
    }
}
