//! What a run of a scene will cost, estimated from the scene alone before
//! anything is allocated or integrated, and the budgets it is held to
//! (docs/LIMITS.md). `Scene::validate` refuses a scene over a budget with the
//! figure, naming the keys that set it, so `scene check` and every command
//! agree: a valid scene is one that will run.
//!
//! The estimates are upper bounds of the dominant terms, not measurements:
//! - a steady state (`run`, each speed of a `sweep`, the dynamic wear
//!   source) integrates the run-in and the measured window, at most
//!   `(run_in_revolutions + measured_revolutions)` × the mesh cycles of one
//!   input revolution, and keeps the window's samples: time and every mesh's
//!   force, 8 bytes each, held twice while the spectrum is taken;
//! - internal steps per mesh cycle: `steps_per_mesh_cycle` for the
//!   generalized-α method; for RK 5(4) the example's measured 800 per mesh
//!   cycle at the default tolerance 3e-6, scaled by (3e-6 / tolerance)^(1/5)
//!   (fifth order);
//! - a worn-profile state holds six flanks × face slices × profile points ×
//!   two numbers, about [`STATE_BYTES_PER_NUMBER`] bytes each as written;
//!   a state over the state file's limit is a warning here (the dynamics
//!   need no state file) and is refused when written.
//!
//! May import: scene (stage 1), files (stage 0).

use crate::scene::{IntegratorKind, Member, Problem, Scene};

/// Most memory one run may plan for \[bytes\]: 4 GiB.
pub const MEMORY_BUDGET_BYTES: f64 = 4.0 * 1024.0 * 1024.0 * 1024.0;
/// Most internal integration steps one steady state may plan for: about
/// three hours at the example's rate (10 000 to 20 000 steps per second).
pub const STEP_BUDGET: f64 = 2.0e8;
/// Internal steps per mesh cycle of RK 5(4) at [`RK_REFERENCE_TOLERANCE`]
/// (the example at 3000 rpm: 80 924 steps over 102 mesh cycles).
pub const RK_STEPS_PER_MESH_CYCLE: f64 = 800.0;
/// The relative tolerance [`RK_STEPS_PER_MESH_CYCLE`] was measured at.
pub const RK_REFERENCE_TOLERANCE: f64 = 3e-6;
/// Most LTCA work one analysis may plan for, in mesh positions × face
/// slices of each mesh: about a minute at the measured 5–7 µs each (the
/// example: 2e6 take 11–14 s, 4e6 take 20 s); the wear stepper runs one
/// LTCA per update.
pub const LTCA_BUDGET: f64 = 1.0e7;
/// Most internal steps one speed sweep may plan for: every speed of every
/// direction a steady state at its longest; about 14 hours at the example's
/// rate (200 000 steps per second).
pub const SWEEP_STEP_BUDGET: f64 = 1.0e10;
/// Bytes one number of a worn-profile state takes as written (pretty JSON:
/// indentation, 17 significant digits, separators).
pub const STATE_BYTES_PER_NUMBER: f64 = 40.0;

/// The estimated cost of a scene's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct RunCost {
    /// Mesh cycles of one input revolution (from the teeth and which member
    /// is held and which driven).
    pub mesh_cycles_per_revolution: f64,
    /// Mesh cycles of one steady state, run-in at its longest and window.
    pub steady_state_mesh_cycles: f64,
    /// Samples of the window.
    pub window_samples: f64,
    /// Memory of the window's samples \[bytes\].
    pub window_bytes: f64,
    /// Internal steps of one steady state.
    pub internal_steps: f64,
    /// Size of a worn-profile state file of the scene's grid \[bytes\].
    pub worn_state_bytes: f64,
    /// LTCA work of one analysis: mesh positions × face slices per mesh.
    pub ltca_work: f64,
}

impl RunCost {
    /// The figures in one line for `scene check`.
    pub fn summary(&self) -> String {
        format!(
            "one steady state: {:.3e} mesh cycles, {:.3e} internal steps (budget {:.0e}), window {} \
             (budget {}); one LTCA: {:.3e} mesh positions × face slices (budget {:.0e}); a worn-profile \
             state file {}",
            self.steady_state_mesh_cycles,
            self.internal_steps,
            STEP_BUDGET,
            mib(self.window_bytes),
            mib(MEMORY_BUDGET_BYTES),
            self.ltca_work,
            LTCA_BUDGET,
            mib(self.worn_state_bytes)
        )
    }
}

/// A size in the unit that reads best (kiB to TiB, three digits).
fn mib(bytes: f64) -> String {
    let mut v = bytes;
    for unit in ["bytes", "kiB", "MiB", "GiB"] {
        if v < 1024.0 {
            return if unit == "bytes" { format!("{v:.0} {unit}") } else { format!("{v:.3} {unit}") };
        }
        v /= 1024.0;
    }
    format!("{v:.3e} TiB")
}

/// Mesh cycles per input revolution: the sun's teeth times its speed
/// relative to the carrier when the input turns once and the held member
/// stands (Willis: Z_s ω_s + Z_r ω_r = (Z_s + Z_r) ω_c).
pub fn mesh_cycles_per_revolution(sun_teeth: f64, ring_teeth: f64, held: Member, input: Member) -> f64 {
    let (zs, zr) = (sun_teeth, ring_teeth);
    let relative = match (held, input) {
        (Member::Carrier, Member::Sun) => 1.0,
        (Member::Carrier, Member::Ring) => zr / zs,
        (Member::Ring, Member::Sun) => zr / (zs + zr),
        (Member::Ring, Member::Carrier) => zr / zs,
        (Member::Sun, Member::Ring) => zr / (zs + zr),
        (Member::Sun, Member::Carrier) => 1.0,
        // Held and driven the same member: refused by the rules; the
        // largest figure of the other cases stands in.
        _ => zr / zs,
    };
    (relative * zs).abs()
}

/// The estimate for a scene (values as written; a non-finite figure means
/// the rules refuse the scene anyway).
pub fn estimate(scene: &Scene) -> RunCost {
    let d = &scene.dynamics;
    let a = &scene.analysis;
    let cpr = mesh_cycles_per_revolution(
        f64::from(scene.sun.teeth),
        f64::from(scene.ring.teeth),
        scene.operation.held,
        scene.operation.input,
    );
    let window_cycles = (d.measured_revolutions * cpr).round().max(1.0);
    let cycles = (d.run_in_revolutions * cpr).ceil() + window_cycles;
    let window_samples = window_cycles * f64::from(d.samples_per_mesh_cycle);
    let meshes = 2.0 * f64::from(scene.planets.count);
    let window_bytes = 2.0 * 8.0 * window_samples * (1.0 + meshes);
    let per_cycle = match d.integrator {
        IntegratorKind::Rk45 => {
            RK_STEPS_PER_MESH_CYCLE * (RK_REFERENCE_TOLERANCE / d.relative_tolerance).powf(0.2)
        }
        _ => f64::from(d.steps_per_mesh_cycle),
    };
    let internal_steps = cycles * per_cycle.max(f64::from(d.samples_per_mesh_cycle));
    let worn_state_bytes =
        6.0 * f64::from(a.face_slices) * f64::from(a.profile_points) * 2.0 * STATE_BYTES_PER_NUMBER;
    RunCost {
        mesh_cycles_per_revolution: cpr,
        steady_state_mesh_cycles: cycles,
        window_samples,
        window_bytes,
        internal_steps,
        worn_state_bytes,
        ltca_work: f64::from(a.positions_per_mesh_cycle) * f64::from(a.face_slices),
    }
}

/// The scene's runs over a budget, each a problem naming the keys that set
/// the figure: what `Scene::validate` refuses.
pub fn problems(scene: &Scene) -> Vec<Problem> {
    let c = estimate(scene);
    let d = &scene.dynamics;
    let mut out = Vec::new();
    // `!(x <= budget)` also refuses a NaN figure.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(c.window_bytes <= MEMORY_BUDGET_BYTES) {
        out.push(Problem {
            name: "dynamics.measured_revolutions".into(),
            value: d.measured_revolutions.to_string(),
            reason: format!(
                "the measured window of {:.3e} mesh cycles × {} samples (dynamics.samples_per_mesh_cycle) \
                 would hold {} of samples, more than the budget of {} (docs/LIMITS.md)",
                (d.measured_revolutions * c.mesh_cycles_per_revolution).round().max(1.0),
                d.samples_per_mesh_cycle,
                mib(c.window_bytes),
                mib(MEMORY_BUDGET_BYTES)
            ),
        });
    }
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(c.internal_steps <= STEP_BUDGET) {
        out.push(Problem {
            name: "dynamics.run_in_revolutions + dynamics.measured_revolutions".into(),
            value: format!("{} + {}", d.run_in_revolutions, d.measured_revolutions),
            reason: format!(
                "one steady state would take about {:.3e} internal steps ({:.3e} mesh cycles), more than \
                 the budget of {:.0e} (docs/LIMITS.md)",
                c.internal_steps, c.steady_state_mesh_cycles, STEP_BUDGET
            ),
        });
    }
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(c.ltca_work <= LTCA_BUDGET) {
        let a = &scene.analysis;
        out.push(Problem {
            name: "analysis.positions_per_mesh_cycle × analysis.face_slices".into(),
            value: format!("{} × {}", a.positions_per_mesh_cycle, a.face_slices),
            reason: format!(
                "one loaded tooth contact analysis would solve {:.3e} mesh positions × face slices per mesh, \
                 more than the budget of {:.0e} (about a minute; docs/LIMITS.md)",
                c.ltca_work, LTCA_BUDGET
            ),
        });
    }
    out
}

/// The cost of a speed sweep of `speeds` speeds in `directions` directions
/// (each speed a steady state at its longest), refused over
/// [`SWEEP_STEP_BUDGET`] with the figure: the internal steps it plans for.
/// `key` names where the user set the grid.
pub fn sweep(scene: &Scene, speeds: usize, directions: usize, key: &str) -> Result<f64, Problem> {
    let per_steady_state = estimate(scene).internal_steps;
    let steps = per_steady_state * speeds as f64 * directions as f64;
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(steps <= SWEEP_STEP_BUDGET) {
        return Err(Problem {
            name: key.into(),
            value: format!("{speeds} speeds × {directions} directions"),
            reason: format!(
                "the sweep would take about {steps:.3e} internal steps ({:.3e} per steady state), more than \
                 the budget of {SWEEP_STEP_BUDGET:.0e} (docs/LIMITS.md); use a larger step or fewer revolutions",
                per_steady_state
            ),
        });
    }
    Ok(steps)
}

/// What the scene's runs may exceed without being refused: a worn-profile
/// state larger than a state file may be (it is refused when written).
pub fn warnings(scene: &Scene) -> Vec<Problem> {
    let c = estimate(scene);
    let limit = crate::files::InputKind::WornState.limit() as f64;
    let mut out = Vec::new();
    if c.worn_state_bytes > limit {
        out.push(Problem {
            name: "analysis.profile_points × analysis.face_slices".into(),
            value: format!("{} × {}", scene.analysis.profile_points, scene.analysis.face_slices),
            reason: format!(
                "a worn-profile state would be about {}, more than the {} a state file may have: \
                 `wear step` and `wear run` will refuse to write it",
                mib(c.worn_state_bytes),
                mib(limit)
            ),
        });
    }
    out
}

/// The LTCA's requirement beyond the scene's rules: a positive input torque
/// (it loads the drive flanks; the coast side is not analysed). `key` names
/// where the user wrote the torque (`--torque` or the scene key).
pub fn ltca_torque(torque: f64, key: &str) -> Result<(), Problem> {
    if torque > 0.0 {
        return Ok(());
    }
    Err(Problem {
        name: key.into(),
        value: format!("{torque} N·m"),
        reason: "the LTCA needs a positive input torque (it loads the drive flanks)".into(),
    })
}
