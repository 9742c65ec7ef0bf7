//! `planetwear`: the command-line tool. A thin shell over the library: it
//! reads scenes, runs the analyses and writes reports.

// Standard output is written through `out!`/`outln!` (src/cli/mod.rs), whose
// failures are errors, never through a `print!` that panics on a closed pipe.
#![deny(clippy::print_stdout)]
#![forbid(unsafe_code)]

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use planetwear::analysis::modes::{natural_modes, rotating_modes, ModeClass};
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::{steady_state, sweep, Direction, SteadyState};
use planetwear::files::InputKind;
use planetwear::model::gear::GearSet;
use planetwear::model::kinematics::Kinematics;
use planetwear::model::lumped::LumpedSet;
use planetwear::model::run::RunSettings;
use planetwear::report::ltca::LtcaStudy;
use planetwear::report::sweep::{
    find_peaks, sweep_csv, write_csv, write_forced_response, write_steady_state,
};
use planetwear::report::write_atomic;
use planetwear::scene::lumped::LumpedScene;
use planetwear::scene::units::{rad_per_s_to_rpm, rpm_to_rad_per_s};
use planetwear::scene::Scene;
use planetwear::wear::archard::{Limit, PressureSource, WearError, WearSettings, WearingFlanks};
use planetwear::wear::compare::compare_sources;
use planetwear::wear::flank::Flank;
use planetwear::wear::state::{StateDifference, WornState};
use planetwear::wear::stepper::WearModel;

mod cli;
use cli::{continuation::*, dynamics::*, fmu::*, out, outln, study::*, wear::*};

#[derive(Parser)]
#[command(name = "planetwear", version, about = "Planetary gear dynamics with tooth wear")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Scenes: print a built-in one as an editable file, or check a file.
    Scene {
        #[command(subcommand)]
        action: SceneAction,
    },
    /// The FMU's generated files.
    Fmu {
        #[command(subcommand)]
        action: FmuAction,
    },
    /// Natural frequencies and mode shapes of the mean-stiffness linear model.
    Modes(ModesArgs),
    /// Time-domain run from the start, printing outputs at every communication point (JSON lines).
    Simulate(SimulateArgs),
    /// Steady-state dynamic response at one input speed.
    ///
    /// The harmonics are measured over the scene's dynamics.measured_revolutions (2 input
    /// revolutions: 68 mesh cycles for example-2004); the FMU's harmonicWindowCycles starts at
    /// one revolution (34) so that its windowed outputs are valid sooner in a co-simulation.
    /// Planets are numbered from 1, as the FMU's planet[1].
    Run(RunArgs),
    /// Speed sweep with continuation: forced-response curves, CSV, plots.
    Sweep(SweepArgs),
    /// Archard wear of the tooth flanks: the wear stepper and the wear run.
    Wear {
        #[command(subcommand)]
        action: WearAction,
    },
    /// Work-precision study of the integrators: E_h of the mesh-force harmonics against CPU time
    /// and work at four operating points and both fidelity levels (docs/ACCURACY.md).
    WorkPrecision(WorkPrecisionArgs),
    /// E_h of the steady response (fidelity 2 and 3) against the time-domain reference at
    /// the work-precision study's operating points, at a node and mid-cell of its cache, and
    /// its error on speed ramps of increasing rate (docs/STEADY.md)
    SteadyAccuracy(SteadyAccuracyArgs),
    /// Fit chosen scene parameters (by their scene keys, with bounds) to target natural
    /// frequencies and loaded double-contact shares; writes the calibrated scene.
    Calibrate(CalibrateArgs),
    /// Every claim of the study beside ours, with tolerance and verdict, and the published
    /// benchmarks: writes DIR/VALIDATION.md and DIR/validation/ (figures, JSON).
    Validate(ValidateArgs),
    /// Quasi-static loaded tooth contact analysis of both meshes and of the whole set.
    Ltca(LtcaArgs),
}

#[derive(Subcommand)]
enum WearAction {
    /// Advance a worn-profile state by one update (the largest new wear reaches
    /// the threshold) or by a number of input revolutions.
    Step(WearStepArgs),
    /// Compare the wear per cycle driven by quasi-static and by dynamic tooth
    /// loads at the given speeds.
    Compare(WearCompareArgs),
    /// Controlled experiments on the cause of the wear effect: each variant changes one
    /// modelling factor, runs the wear model to κ and compares the static and dynamic
    /// figures at κ = 0 and κ.
    Effect(WearEffectArgs),
    /// Run the wear model from the unworn set to κ: states kappa-<κ>.json,
    /// summary.json and plots of wear depth against roll angle.
    Run(WearRunArgs),
}

#[derive(Subcommand)]
enum FmuAction {
    /// Assemble the FMU archive (fmu/planetwear.fmu) from the release library.
    Pack(FmuPackArgs),
    /// The regression references the FMU ships (resources/regression/example-2004.json),
    /// computed alone, e.g. at another tolerance to check their own accuracy.
    References(FmuReferencesArgs),
    /// modelDescription.xml, generated from modelDescription/variables.toml.
    Xml(FmuXmlArgs),
    /// The variables' reference page (Markdown: docs/FMU_VARIABLES.md), from the same table.
    Variables(FmuXmlArgs),
}

#[derive(Subcommand)]
enum SceneAction {
    /// Print a scene (built-in name or file) as TOML.
    Show(SceneShowArgs),
    /// Validate a scene and list every problem.
    Check(SceneCheckArgs),
}

/// The gear set a command works on: a scene and, optionally, the worn
/// flanks of a worn-profile state.
#[derive(clap::Args)]
struct SetArgs {
    /// A built-in scene name (example-2004, …; `modes` also takes lumped-benchmark) or a scene
    /// file (TOML).
    #[arg(long)]
    scene: String,
    /// Worn-profile state file (from `planetwear wear`): the flanks carry its wear.
    #[arg(long)]
    wear_state: Option<PathBuf>,
    #[command(flatten)]
    accept: AcceptArgs,
}

/// Which differences of a worn-profile state's gear set are accepted.
#[derive(clap::Args)]
struct AcceptArgs {
    /// Accept a worn-profile state whose gear set differs from this one only in these kinds,
    /// comma-separated: material (E, ν), mesh_stiffness (the scene's stiffness corrections).
    /// Geometry is never accepted; the load and speeds are not part of a state's gear set.
    /// Each accepted difference is printed as a warning (and recorded by `wear step`).
    #[arg(long, value_name = "KINDS")]
    accept_state_difference: Option<String>,
}

/// Natural frequencies and mode shapes of the mean-stiffness linear model.
#[derive(clap::Args)]
struct ModesArgs {
    #[command(flatten)]
    set: SetArgs,
    /// Print the full result as JSON (SI units, frequencies in Hz).
    #[arg(long)]
    json: bool,
}

/// Time-domain run from the start, printing outputs at every communication point (JSON lines).
#[derive(clap::Args)]
struct SimulateArgs {
    #[command(flatten)]
    set: SetArgs,
    /// End time [s].
    #[arg(long)]
    stop: f64,
    /// Communication step [s].
    #[arg(long)]
    step: f64,
    /// Write the run's load duty to this JSON file (atomically): for each mesh, the input
    /// revolutions in each bin of load torque × input speed, with the gear set (docs/DUTY.md).
    #[arg(long, value_name = "FILE")]
    duty_cycle: Option<PathBuf>,
    /// With --duty-cycle: the load-torque bin edges [N·m], comma-separated, increasing (a mesh's
    /// mean force over a step as the input torque it balances). Default: 0 to twice the scene's
    /// input torque in 11 bins (the scene's torque mid-bin).
    #[arg(long, value_delimiter = ',', value_name = "N·m,…", requires = "duty_cycle")]
    duty_torque_edges: Vec<f64>,
    /// With --duty-cycle: the input-speed bin edges [rpm], comma-separated, increasing.
    /// Default: 0 to twice the scene's input speed in 11 bins.
    #[arg(long, value_delimiter = ',', value_name = "RPM,…", requires = "duty_cycle")]
    duty_speed_edges: Vec<f64>,
}

/// Steady-state dynamic response at one input speed.
#[derive(clap::Args)]
struct RunArgs {
    #[command(flatten)]
    set: SetArgs,
    /// Input speed [rpm]; default: the scene's dynamics.input_speed_rpm.
    #[arg(long)]
    speed: Option<f64>,
    /// Print the result as JSON (SI units; forces in N).
    #[arg(long)]
    json: bool,
    /// Write time-history and order-spectrum plots into this directory.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// march (time marching from the static state: the scene's run-in, then its measured
    /// revolutions), shooting (the periodic orbit by Newton's method on the flow over one mesh
    /// cycle, measured over that cycle, with its Floquet multipliers) or harmonic-balance (the
    /// periodic orbit as a Fourier series, measured over one mesh cycle: the fastest off
    /// resonance, its Floquet multipliers from the tangents along the series; docs/PERIODIC.md
    /// §2). With --json the last two add `solver`: the method and its work, the Floquet
    /// multipliers as [re, im] and whether the orbit is stable.
    #[arg(long, default_value = "march")]
    method: String,
    /// With --method harmonic-balance: condensed (Newton on the contact coordinates' harmonics
    /// only, one planet's meshes where the planets are equally spaced and the orbit keeps their
    /// symmetry; docs/PERIODIC.md §2) or full (every coordinate's harmonics).
    #[arg(long, default_value = "condensed")]
    balance: String,
}

/// Speed sweep with continuation: forced-response curves, CSV, plots.
#[derive(clap::Args)]
struct SweepArgs {
    #[command(flatten)]
    set: SetArgs,
    /// First speed [rpm].
    #[arg(long)]
    from: f64,
    /// Last speed [rpm].
    #[arg(long)]
    to: f64,
    /// Speed step [rpm].
    #[arg(long)]
    step: f64,
    /// up, down or both (both run in parallel).
    #[arg(long, default_value = "both")]
    direction: String,
    /// Output directory (CSV, plots, sweep.json).
    #[arg(long)]
    out: PathBuf,
    /// Speeds [rpm] whose time histories and order spectra are plotted.
    #[arg(long, value_delimiter = ',')]
    histories: Vec<f64>,
    /// Print the summary (peaks, figures) as JSON.
    #[arg(long)]
    json: bool,
    /// march (time marching at every speed of the grid, up and down) or
    /// continuation (periodic states by shooting, followed by pseudo-arclength
    /// continuation through folds, with stability: up from --from to --to,
    /// down from --to to --from, as --direction says; --step is the nominal step).
    #[arg(long, default_value = "march")]
    method: String,
    /// Continuation only: how far [rpm] a branch may run back below the furthest speed reached
    /// (and twice this is the most it may travel without reaching further) before the run
    /// restarts past it by marching; default 10 nominal steps.
    #[arg(long, value_name = "RPM")]
    max_back: Option<f64>,
    /// Continuation only: the periodic states by shooting (the default) or by
    /// harmonic-balance (the Fourier coefficients at the rule's harmonics, each point's
    /// multipliers from the balance's own monodromy; docs/PERIODIC.md §3).
    #[arg(long, value_name = "SOLVER")]
    solver: Option<String>,
    /// Continuation only, both directions: run the down run after the up run and end it where it
    /// joins the up run's branch on the stretch the up run followed without a restart from
    /// --from (below, it would retrace that stretch): less work, but the two runs no longer
    /// run side by side (docs/PERIODIC.md §3)
    #[arg(long)]
    join: bool,
    /// Continuation only: also run the marching sweep up and down on the same grid and set
    /// each of its jumps beside the nearest fold, period doubling or change of stability
    /// (jumps.md, and "jumps" in sweep.json).
    #[arg(long)]
    against_march: bool,
    /// Continuation with --solver condensed only: where a restart's march reaches a state
    /// that breaks the planets' symmetry, go on with every mesh along that symmetry-broken
    /// branch (about four times the unknowns) instead of along the symmetric branch, unstable
    /// there (docs/PERIODIC.md §3).
    #[arg(long)]
    broken_symmetry: bool,
}

/// Work-precision study of the integrators: E_h of the mesh-force harmonics against CPU time
/// and work at four operating points and both fidelity levels (docs/ACCURACY.md).
#[derive(clap::Args)]
struct WorkPrecisionArgs {
    /// Output directory (charts, CSV, tables, JSON).
    #[arg(long)]
    out: PathBuf,
    /// Reduced grid (torsional points, ρ∞ = 0.9 at 16…256 steps, RK 5(4) to 1e-7, shorter runs,
    /// one repeat): seconds instead of minutes.
    #[arg(long)]
    quick: bool,
}

/// E_h of the steady response against the time-domain reference, and its ramp errors.
#[derive(clap::Args)]
struct SteadyAccuracyArgs {
    /// Write the tables (Markdown) and the figures (JSON) into this directory.
    #[arg(long)]
    out: PathBuf,
    /// Only the torsional points and no ramps: a minute instead of ten.
    #[arg(long)]
    quick: bool,
}

/// Fit chosen scene parameters (by their scene keys, with bounds) to target natural
/// frequencies and loaded double-contact shares; writes the calibrated scene.
#[derive(clap::Args)]
struct CalibrateArgs {
    /// A plan file (TOML: base, name, [set], [[target]], [[free]]) or a built-in scene
    /// whose calibration to run (example-2004).
    #[arg(long)]
    plan: String,
    /// Write the calibrated scene (TOML, editable) to this file, atomically.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the plan (to edit as a starting point) instead of running it.
    #[arg(long)]
    show_plan: bool,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

/// Every claim of the study beside ours, with tolerance and verdict, and the published
/// benchmarks: writes DIR/VALIDATION.md and DIR/validation/ (figures, JSON).
#[derive(clap::Args)]
struct ValidateArgs {
    /// Output directory (`--out docs` regenerates docs/VALIDATION.md).
    #[arg(long)]
    out: PathBuf,
    /// Reduced grid (3000–14000 rpm in 250 rpm steps, 100 rpm from 6000 to 10000; no wear-resolution check).
    #[arg(long)]
    quick: bool,
    /// The forced-response rows from marching sweeps up and down on the grid, read a second
    /// time at a third of the tolerance where attractors coexist (the exhaustive reading),
    /// instead of from the continuation's branches (the default).
    #[arg(long)]
    full: bool,
    /// The scene to validate (default the built-in example-2004).
    #[arg(long, default_value = "example-2004")]
    scene: String,
    /// A second scene whose validation is set beside the first in the report (its rows read
    /// differently, both verdicts): e.g. example-2004-deformable, the example on the
    /// deformable-tooth contact law. Its sweeps are read once (no second reading at a third of
    /// the tolerance) and its wear without the resolution check.
    #[arg(long)]
    compare: Option<String>,
}

/// Quasi-static loaded tooth contact analysis of both meshes and of the whole set.
#[derive(clap::Args)]
struct LtcaArgs {
    #[command(flatten)]
    set: SetArgs,
    /// Input torque [N·m], overriding the scene's.
    #[arg(long)]
    torque: Option<f64>,
    /// Positions per mesh cycle, overriding the scene's.
    #[arg(long)]
    samples: Option<usize>,
    /// Print the full result as JSON (SI units) on standard output.
    #[arg(long)]
    json: bool,
    /// Also write the JSON to this file (atomically).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write SVG and PNG plots into this directory.
    #[arg(long)]
    plots: Option<PathBuf>,
}

/// Advance a worn-profile state by one update (the largest new wear reaches
/// the threshold) or by a number of input revolutions.
#[derive(clap::Args)]
struct WearStepArgs {
    /// A built-in scene name or a scene file.
    #[arg(long)]
    scene: String,
    /// The state to advance; default: the unworn set (κ = 0).
    #[arg(long)]
    state: Option<PathBuf>,
    #[command(flatten)]
    accept: AcceptArgs,
    /// Where to write the new state (atomically).
    #[arg(long)]
    out: PathBuf,
    /// Largest new wear of the update [µm] (default 2.5).
    #[arg(long, conflicts_with = "revolutions")]
    threshold: Option<f64>,
    /// Advance by this many input revolutions instead of one whole update.
    #[arg(long)]
    revolutions: Option<f64>,
    /// Wear the ring–planet mesh's flanks as well as the sun–planet mesh's.
    #[arg(long)]
    ring: bool,
    /// Drive the wear by the tooth loads of a dynamic steady state at this
    /// input speed [rpm] instead of the quasi-static LTCA.
    #[arg(long)]
    dynamic_speed: Option<f64>,
    /// Wear by this duty-cycle file (`simulate --duty-cycle`, the FMU's dutyCycle): the Archard
    /// wear of each load bin's revolutions, summed, for the revolutions the duty stands for
    /// (once, or --repeat/--hours), over as many updates as the update depth asks (docs/DUTY.md).
    /// Given more than once, the duties (on the same bins) are added: one pass is all of them.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["revolutions", "dynamic_speed"])]
    duty_cycle: Vec<PathBuf>,
    /// With --duty-cycle: wear this many passes of the duty (default 1).
    #[arg(long, requires = "duty_cycle", conflicts_with = "hours")]
    repeat: Option<f64>,
    /// With --duty-cycle: wear this many hours of operation (the duty's passes that last so long).
    #[arg(long, requires = "duty_cycle")]
    hours: Option<f64>,
    /// With --duty-cycle: the steady dynamic tooth loads of each torque × speed bin (at its mid
    /// speed) instead of the quasi-static loads of each torque bin.
    #[arg(long, requires = "duty_cycle")]
    dynamic: bool,
}

/// Compare the wear per cycle driven by quasi-static and by dynamic tooth
/// loads at the given speeds.
#[derive(clap::Args)]
struct WearCompareArgs {
    /// A built-in scene name or a scene file.
    #[arg(long)]
    scene: String,
    /// The worn-profile state to compare on; default: the unworn set.
    #[arg(long)]
    state: Option<PathBuf>,
    #[command(flatten)]
    accept: AcceptArgs,
    /// Input speeds [rpm].
    #[arg(long, value_delimiter = ',', required = true)]
    speeds: Vec<f64>,
    /// Print the comparison as JSON (SI units).
    #[arg(long)]
    json: bool,
}

/// Controlled experiments on the cause of the wear effect: each variant changes one
/// modelling factor, runs the wear model to κ and compares the static and dynamic
/// figures at κ = 0 and κ.
#[derive(clap::Args)]
struct WearEffectArgs {
    /// A built-in scene name or a scene file: the base of the experiments.
    #[arg(long)]
    scene: String,
    /// Geometry state κ to wear to.
    #[arg(long, default_value_t = 6)]
    kappa: u32,
    /// Input speeds [rpm] of the dynamic figures (off resonance).
    #[arg(long, value_delimiter = ',', default_value = "1500,2000,2750,3000")]
    speeds: Vec<f64>,
    /// Only these variants (keys as printed), comma-separated; default: all.
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Output directory (effect.md, effect.json).
    #[arg(long)]
    out: PathBuf,
}

/// Run the wear model from the unworn set to κ: states kappa-<κ>.json,
/// summary.json and plots of wear depth against roll angle.
#[derive(clap::Args)]
struct WearRunArgs {
    /// A built-in scene name or a scene file.
    #[arg(long)]
    scene: String,
    /// Last geometry state κ (the run stops earlier at the total wear limit).
    #[arg(long, default_value_t = 6)]
    to_kappa: u32,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Wear the ring–planet mesh's flanks as well as the sun–planet mesh's.
    #[arg(long)]
    ring: bool,
    /// Drive the wear by the tooth loads of a dynamic steady state at this
    /// input speed [rpm] instead of the quasi-static LTCA.
    #[arg(long)]
    dynamic_speed: Option<f64>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Assemble the FMU archive (fmu/planetwear.fmu) from the release library.
#[derive(clap::Args)]
struct FmuPackArgs {
    /// Output file.
    #[arg(long, default_value = "fmu/planetwear.fmu")]
    out: PathBuf,
    /// The shared library. Default: the portable one where `bash scripts/fmu.sh` built it
    /// (target/x86_64-unknown-linux-gnu/fmu/libplanetwear.so, glibc 2.17 or newer), otherwise
    /// libplanetwear.so beside this executable, with a warning naming the glibc it needs.
    #[arg(long)]
    library: Option<PathBuf>,
    /// Make this scene (a built-in name or a scene file) the FMU's default set:
    /// resources/default-scene.toml, every parameter's and input's start value, its own
    /// worn-profile states and regression references. Default: the built-in example-2004.
    #[arg(long)]
    scene: Option<String>,
}

/// The regression references the FMU ships (resources/regression/example-2004.json),
/// computed alone, e.g. at another tolerance to check their own accuracy.
#[derive(clap::Args)]
struct FmuReferencesArgs {
    /// Output file (JSON, written atomically).
    #[arg(long)]
    out: PathBuf,
    /// Relative tolerance of the references' RK 5(4) run (at most 1e-6).
    #[arg(long, default_value_t = planetwear::package::regression::REFERENCE_RELATIVE_TOLERANCE)]
    relative_tolerance: f64,
}

/// A generated file of the FMU: modelDescription.xml or the variables' page.
#[derive(clap::Args)]
struct FmuXmlArgs {
    /// Write it to this file (atomically) instead of standard output.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Print a scene (built-in name or file) as TOML.
#[derive(clap::Args)]
struct SceneShowArgs {
    /// Built-in name or file.
    scene: String,
    /// Print JSON instead: the scene's TOML text (`toml`) and the gear set's kinematics
    /// (`kinematics`: teeth, members, the balanced torques per unit input torque, mesh cycles
    /// per input revolution, face width and base radii, SI), which the Python package reads.
    #[arg(long)]
    json: bool,
}

/// Validate a scene and list every problem.
#[derive(clap::Args)]
struct SceneCheckArgs {
    /// Built-in name or file.
    scene: String,
}

/// A gear scene or a lumped-parameter scene.
enum AnyScene {
    Gear(Box<Scene>),
    Lumped(Box<LumpedScene>),
}

fn load_any(arg: &str) -> Result<AnyScene> {
    if arg == "lumped-benchmark" {
        return Ok(AnyScene::Lumped(Box::new(LumpedScene::lumped_benchmark())));
    }
    if Scene::builtin(arg).is_none() && Path::new(arg).exists() {
        let text = read_text(Path::new(arg), InputKind::Scene, "scene")?;
        let is_lumped =
            toml::from_str::<toml::Table>(&text).map(|t| t.contains_key("lumped")).unwrap_or(false);
        if is_lumped {
            let scene = LumpedScene::from_toml(&text).with_context(|| format!("in scene file {arg}"))?;
            return Ok(AnyScene::Lumped(Box::new(scene)));
        }
    }
    Ok(AnyScene::Gear(Box::new(load_scene(arg)?)))
}

fn load_scene(arg: &str) -> Result<Scene> {
    if let Some(s) = Scene::builtin(arg) {
        return Ok(s);
    }
    let path = Path::new(arg);
    if !path.exists() {
        bail!(
            "scene '{arg}' is neither a built-in scene ({}) nor an existing file",
            Scene::BUILTIN.join(", ")
        );
    }
    let text = read_text(path, InputKind::Scene, "scene")?;
    Scene::from_toml(&text).with_context(|| format!("in scene file {}", path.display()))
}

/// A text input file through the one reader (`files::read_input`: regular
/// files only, the kind's size limit); `what` names the option in messages.
fn read_text(path: &Path, kind: InputKind, what: &str) -> Result<String> {
    let bytes = planetwear::files::read_input(path, kind).map_err(|e| anyhow::anyhow!("{what}: {e}"))?;
    String::from_utf8(bytes)
        .map_err(|_| anyhow::anyhow!("{what}: {} '{}' is not UTF-8 text", kind.name(), path.display()))
}

fn validated(scene: &Scene) -> Result<GearSet> {
    scene.validate().map_err(anyhow::Error::from)
}

/// The gear set and the run settings of a scene.
fn validated_with_run(scene: &Scene) -> Result<(GearSet, RunSettings)> {
    scene.validate_with_run().map_err(anyhow::Error::from)
}

/// The contact model of the set, unworn or with the flanks of a worn-profile state.
fn contact_model(set: &GearSet, wear_state: Option<&Path>, accept: Option<&str>) -> Result<SetModel> {
    match wear_state {
        None => Ok(SetModel::new(set)),
        Some(path) => Ok(read_state("--wear-state", path, set, accept)?.set_model(set)),
    }
}

/// The worn-profile state at `path` (given by `flag`) for `set`, accepting a
/// gear set that differs only in the kinds `accept` names
/// (--accept-state-difference); an accepted difference is printed as a
/// warning line.
fn read_state(flag: &str, path: &Path, set: &GearSet, accept: Option<&str>) -> Result<WornState> {
    let text = accept.unwrap_or("");
    let kinds = StateDifference::parse_list(text)
        .map_err(|e| anyhow::anyhow!("--accept-state-difference {text}: {e}"))?;
    let (state, accepted) = planetwear::wear::state::read_worn_state_accepting(path, set, &kinds)
        .with_context(|| format!("{flag} {}", path.display()))?;
    if !accepted.is_empty() {
        eprintln!(
            "warning: {flag} {}: {} (--accept-state-difference {text})",
            path.display(),
            planetwear::wear::state::describe_accepted(&accepted)
        );
    }
    Ok(state)
}

/// Every output path of a command checked before any computation
/// (`files::prepare_output_file`/`prepare_output_dir`: an existing path
/// that is not a regular file, or not a directory, is refused; symbolic
/// links are followed; temporary files a killed run left are removed).
fn check_outputs(command: &Command) -> Result<()> {
    let file = |flag: &str, p: &Path| {
        planetwear::files::prepare_output_file(p).with_context(|| format!("{flag} {}", p.display()))
    };
    let dir = |flag: &str, p: &Path| {
        planetwear::files::prepare_output_dir(p).with_context(|| format!("{flag} {}", p.display()))
    };
    match command {
        Command::Run(a) => a.plots.iter().try_for_each(|p| dir("--plots", p)),
        Command::Simulate(a) => a.duty_cycle.iter().try_for_each(|p| file("--duty-cycle", p)),
        Command::Sweep(a) => dir("--out", &a.out),
        Command::Ltca(a) => {
            a.out.iter().try_for_each(|p| file("--out", p))?;
            a.plots.iter().try_for_each(|p| dir("--plots", p))
        }
        Command::Wear { action: WearAction::Step(a) } => file("--out", &a.out),
        Command::Wear { action: WearAction::Run(a) } => {
            dir("--out", &a.out)?;
            dir("--out", &a.out.join("plots"))
        }
        Command::Wear { action: WearAction::Effect(a) } => dir("--out", &a.out),
        Command::WorkPrecision(a) => dir("--out", &a.out),
        Command::SteadyAccuracy(a) => dir("--out", &a.out),
        Command::Validate(a) => {
            dir("--out", &a.out)?;
            dir("--out", &a.out.join("validation"))
        }
        Command::Calibrate(a) => a.out.iter().try_for_each(|p| file("--out", p)),
        Command::Fmu { action: FmuAction::Pack(a) } => file("--out", &a.out),
        Command::Fmu { action: FmuAction::References(a) } => file("--out", &a.out),
        Command::Fmu { action: FmuAction::Xml(a) | FmuAction::Variables(a) } => {
            a.out.iter().try_for_each(|p| file("--out", p))
        }
        Command::Scene { .. } | Command::Modes(_) | Command::Wear { action: WearAction::Compare(_) } => {
            Ok(())
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    check_outputs(&cli.command)?;
    match cli.command {
        Command::Scene { action: SceneAction::Show(SceneShowArgs { scene, json }) } => {
            match load_any(&scene)? {
                AnyScene::Gear(s) if json => {
                    let kinematics = Kinematics::of(&validated(&s)?);
                    let doc = serde_json::json!({ "toml": s.to_toml(), "kinematics": kinematics });
                    outln!("{}", serde_json::to_string_pretty(&doc)?)?
                }
                AnyScene::Gear(s) => out!("{}", s.to_toml())?,
                AnyScene::Lumped(_) if json => {
                    bail!("--json: {scene} is a lumped-parameter scene, which has no gear kinematics")
                }
                AnyScene::Lumped(s) => out!("{}", s.to_toml())?,
            }
        }
        Command::Scene { action: SceneAction::Check(SceneCheckArgs { scene }) } => match load_any(&scene)? {
            AnyScene::Gear(s) => {
                let set = validated(&s)?;
                outln!("scene '{}' is valid: {} planets", set.name(), set.planet_angles().len())?;
                // The radii that gear data gave (docs/GEAR_DATA.md).
                for (key, given, g) in [
                    ("sun", s.sun.gear_data.is_some(), set.sun()),
                    ("planet", s.planet.gear_data.is_some(), set.planet()),
                    ("ring", s.ring.gear_data.is_some(), set.ring()),
                ] {
                    if given {
                        outln!(
                            "  {key} from gear data: tip radius {:.4} mm, root radius {:.4} mm, base radius {:.4} mm, \
                             tooth thickness {:.4} mm, {} {:.4} mm",
                            g.tip_radius * 1e3,
                            g.root_radius * 1e3,
                            g.base_radius() * 1e3,
                            g.tooth_thickness * 1e3,
                            if key == "ring" { "fillet radius" } else { "hob tip radius" },
                            match g.root_form {
                                planetwear::model::gear::RootForm::Hob { tip_radius: r }
                                | planetwear::model::gear::RootForm::Fillet { radius: r } => r * 1e3,
                            }
                        )?;
                    }
                }
                // The estimate every run is held to (docs/LIMITS.md), and what
                // a command refuses beyond the scene's rules.
                outln!("  cost: {}", planetwear::model::cost::estimate(&s).summary())?;
                for w in planetwear::model::cost::warnings(&s) {
                    outln!("  warning: {w}")?;
                }
                if let Err(p) =
                    planetwear::model::cost::ltca_torque(set.input_torque(), "operation.input_torque_nm")
                {
                    outln!("  warning: `ltca` will refuse it: {p}")?;
                }
            }
            AnyScene::Lumped(s) => {
                let set = s.validate()?;
                outln!("lumped scene '{}' is valid: {} planets", s.name, set.planet_angles.len())?;
            }
        },
        Command::Simulate(a) => simulate_command(a)?,
        Command::Run(a) => run_command(a)?,
        Command::Sweep(a) => sweep_command(a)?,
        Command::Wear { action: WearAction::Run(a) } => wear_run_command(a)?,
        Command::Wear { action: WearAction::Compare(a) } => wear_compare_command(a)?,
        Command::Wear { action: WearAction::Effect(a) } => wear_effect_command(a)?,
        Command::Wear { action: WearAction::Step(a) } => wear_step_command(a)?,
        Command::WorkPrecision(WorkPrecisionArgs { out, quick }) => work_precision(&out, quick)?,
        Command::SteadyAccuracy(SteadyAccuracyArgs { out, quick }) => steady_accuracy(&out, quick)?,
        Command::Validate(a) => validate_command(a)?,
        Command::Calibrate(a) => calibrate_command(a)?,
        Command::Fmu { action: FmuAction::Pack(a) } => fmu_pack_command(a)?,
        Command::Fmu { action: FmuAction::References(a) } => fmu_references_command(a)?,
        Command::Fmu { action: FmuAction::Xml(a) } => fmu_xml_command(a)?,
        Command::Fmu { action: FmuAction::Variables(a) } => fmu_variables_command(a)?,
        Command::Modes(a) => modes_command(a)?,
        Command::Ltca(a) => ltca_command(a)?,
    }
    Ok(())
}

fn speed_grid(from: f64, to: f64, step: f64) -> Result<Vec<f64>> {
    if !(from.is_finite() && to.is_finite() && from > 0.0 && to > 0.0) {
        bail!("--from/--to: speeds must be finite and positive (got {from} and {to} rpm)");
    }
    if !(step.is_finite() && step > 0.0) {
        bail!("--step: must be a finite positive speed step (got {step} rpm)");
    }
    if from > to {
        bail!(
            "--from {from} rpm is above --to {to} rpm: give the lower speed as --from; \
             --direction (up, down, both) sets which way the sweep runs"
        );
    }
    let (lo, hi) = (from, to);
    let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
    if n > 100_000 {
        bail!("--step: {n} speeds is more than 100000; use a larger step");
    }
    Ok((0..n).map(|i| lo + step * i as f64).collect())
}

fn progress_bar(len: u64) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} speeds, {elapsed} elapsed, eta {eta}")
    {
        bar.set_style(style);
    }
    bar
}

/// An error with its causes, each said once: a cause whose text its
/// parent's message already ends with (an error that prints its source
/// and also names it as its source) is not repeated.
fn error_report(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.ends_with(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

/// The set-up cache's directory (docs/PERFORMANCE.md, "The set-up cache"):
/// `PLANETWEAR_CACHE` when set (`off` or empty turns the cache off), else
/// `$XDG_CACHE_HOME/planetwear`, else `$HOME/.cache/planetwear`; none when
/// neither variable is set.
fn cache_directory() -> Option<PathBuf> {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    match std::env::var_os("PLANETWEAR_CACHE") {
        Some(v) if v.is_empty() || v == "off" => None,
        Some(v) => Some(PathBuf::from(v)),
        None => var("XDG_CACHE_HOME")
            .map(|d| PathBuf::from(d).join("planetwear"))
            .or_else(|| var("HOME").map(|h| PathBuf::from(h).join(".cache").join("planetwear"))),
    }
}

fn main() -> ExitCode {
    if let Some(dir) = cache_directory() {
        planetwear::contact::cache::enable(&dir);
    }
    // A reader that closes the pipe early (`planetwear simulate … | head`)
    // ends the tool quietly, as any Unix filter (src/cli/mod.rs).
    match run(Cli::parse()).and_then(|()| cli::flush_stdout()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if cli::stdout_closed(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_report(&e));
            ExitCode::from(2)
        }
    }
}
