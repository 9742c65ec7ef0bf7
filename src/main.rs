//! `planetwear`: the command-line tool. A thin shell over the library: it
//! reads scenes, runs the analyses and writes reports.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use planetwear::analysis::modes::{natural_modes, ModeClass};
use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::{steady_state, sweep, Direction, SteadyState};
use planetwear::model::gear::GearSet;
use planetwear::model::lumped::LumpedSet;
use planetwear::report::ltca::LtcaStudy;
use planetwear::report::sweep::{
    find_peaks, sweep_csv, write_csv, write_forced_response, write_steady_state,
};
use planetwear::report::write_atomic;
use planetwear::scene::lumped::LumpedScene;
use planetwear::scene::Scene;
use planetwear::wear::archard::{Limit, PressureSource, WearError, WearSettings, WearingFlanks};
use planetwear::wear::compare::compare_sources;
use planetwear::wear::flank::Flank;
use planetwear::wear::stepper::WearModel;

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
}

#[derive(Subcommand)]
enum SceneAction {
    /// Print a scene (built-in name or file) as TOML.
    Show(SceneShowArgs),
    /// Validate a scene and list every problem.
    Check(SceneCheckArgs),
}

/// Natural frequencies and mode shapes of the mean-stiffness linear model.
#[derive(clap::Args)]
struct ModesArgs {
    /// A built-in scene (example-2004, lumped-benchmark) or a scene file.
    #[arg(long)]
    scene: String,
    /// Worn-profile state file (from `planetwear wear`): the flanks carry its wear.
    #[arg(long)]
    wear_state: Option<PathBuf>,
    /// Print the full result as JSON (SI units, frequencies in Hz).
    #[arg(long)]
    json: bool,
}

/// Time-domain run from the start, printing outputs at every communication point (JSON lines).
#[derive(clap::Args)]
struct SimulateArgs {
    /// A built-in scene name or a scene file.
    #[arg(long)]
    scene: String,
    /// Worn-profile state file (from `planetwear wear`): the flanks carry its wear.
    #[arg(long)]
    wear_state: Option<PathBuf>,
    /// End time [s].
    #[arg(long)]
    stop: f64,
    /// Communication step [s].
    #[arg(long)]
    step: f64,
}

/// Steady-state dynamic response at one input speed.
#[derive(clap::Args)]
struct RunArgs {
    /// A built-in scene name or a scene file.
    #[arg(long)]
    scene: String,
    /// Worn-profile state file (from `planetwear wear`): the flanks carry its wear.
    #[arg(long)]
    wear_state: Option<PathBuf>,
    /// Input speed [rpm]; default: the scene's dynamics.input_speed_rpm.
    #[arg(long)]
    speed: Option<f64>,
    /// Print the result as JSON (SI units; forces in N).
    #[arg(long)]
    json: bool,
    /// Write time-history and order-spectrum plots into this directory.
    #[arg(long)]
    plots: Option<PathBuf>,
}

/// Speed sweep with continuation: forced-response curves, CSV, plots.
#[derive(clap::Args)]
struct SweepArgs {
    /// A built-in scene name or a scene file.
    #[arg(long)]
    scene: String,
    /// Worn-profile state file (from `planetwear wear`): the flanks carry its wear.
    #[arg(long)]
    wear_state: Option<PathBuf>,
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
    /// The scene to validate (default the built-in example-2004).
    #[arg(long, default_value = "example-2004")]
    scene: String,
}

/// Quasi-static loaded tooth contact analysis of both meshes and of the whole set.
#[derive(clap::Args)]
struct LtcaArgs {
    /// A built-in scene name (example-2004) or a scene file (TOML).
    #[arg(long)]
    scene: String,
    /// Worn-profile state file (from `planetwear wear`): load sharing and loaded
    /// transmission error of the worn set.
    #[arg(long)]
    wear_state: Option<PathBuf>,
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
    /// The shared library; default: libplanetwear.so beside this executable.
    #[arg(long)]
    library: Option<PathBuf>,
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

/// modelDescription.xml, generated from modelDescription/variables.toml.
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
        let text = std::fs::read_to_string(arg).with_context(|| format!("reading scene file {arg}"))?;
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
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading scene file {}", path.display()))?;
    Scene::from_toml(&text).with_context(|| format!("in scene file {}", path.display()))
}

fn validated(scene: &Scene) -> Result<GearSet> {
    scene.validate().map_err(anyhow::Error::from)
}

/// The contact model of the set, unworn or with the flanks of a worn-profile state.
fn contact_model(set: &GearSet, wear_state: Option<&Path>) -> Result<SetModel> {
    match wear_state {
        None => Ok(SetModel::new(set)),
        Some(path) => {
            let state = planetwear::wear::state::read_worn_state(path, set)
                .with_context(|| format!("--wear-state {}", path.display()))?;
            Ok(state.set_model(set))
        }
    }
}

fn wear_model(
    set: &GearSet,
    ring: bool,
    threshold_um: Option<f64>,
    dynamic_rpm: Option<f64>,
) -> Result<WearModel> {
    let mut settings = WearSettings::for_set(set);
    if let Some(rpm) = dynamic_rpm {
        if !(rpm.is_finite() && rpm > 0.0) {
            bail!("--dynamic-speed {rpm}: must be a finite input speed > 0 rpm");
        }
        settings.source = PressureSource::Dynamic { speed_rpm: rpm };
    }
    if ring {
        settings.wearing = WearingFlanks::both_meshes();
    }
    if let Some(t) = threshold_um {
        settings.update_depth = t * 1e-6;
    }
    WearModel::new(set, settings).map_err(|e| match threshold_um {
        Some(t) => anyhow::anyhow!("--threshold {t} µm: {e}"),
        None => e.into(),
    })
}

fn wear_run(
    scene: &str,
    to_kappa: u32,
    out: &Path,
    ring: bool,
    dynamic: Option<f64>,
    json: bool,
) -> Result<()> {
    let set = validated(&load_scene(scene)?)?;
    let model = wear_model(&set, ring, None, dynamic)?;
    std::fs::create_dir_all(out.join("plots")).with_context(|| format!("creating {}", out.display()))?;
    let mut state = model.unworn();
    let mut states = vec![state.clone()];
    let mut seconds = vec![0.0];
    planetwear::wear::state::write_worn_state(&out.join("kappa-0.json"), &state)?;
    let bar = progress_bar(u64::from(to_kappa));
    let mut stopped = None;
    for _ in 0..to_kappa {
        let started = std::time::Instant::now();
        match model.step(&state, Limit::Update) {
            Ok(next) => state = next,
            Err(e @ WearError::TotalWearReached { .. }) => {
                stopped = Some(e.to_string());
                break;
            }
            Err(e) => return Err(e.into()),
        }
        seconds.push(started.elapsed().as_secs_f64());
        planetwear::wear::state::write_worn_state(&out.join(format!("kappa-{}.json", state.kappa)), &state)?;
        states.push(state.clone());
        bar.inc(1);
    }
    bar.finish_and_clear();
    let doc = planetwear::report::wear::summary(&set, &states, &seconds);
    write_atomic(&out.join("summary.json"), serde_json::to_string_pretty(&doc)?.as_bytes())?;
    let files = planetwear::report::wear::write_plots(&set, &states, &out.join("plots"))?;
    if json {
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    println!(
        "wear of {}: {} updates, states and summary.json in {}, {} plot files",
        set.name(),
        states.len() - 1,
        out.display(),
        files.len()
    );
    println!("   κ  cycles sun  cycles planet   input rev   sun max µm @ roll   planet max µm @ roll   time");
    for s in doc["states"].as_array().into_iter().flatten().skip(1) {
        let f = |m: &str, k: &str| s["flanks"][m][k].as_f64().unwrap_or(f64::NAN);
        println!(
            "  {:>2}  {:>10.4e}  {:>13.4e}  {:>10.4e}   {:>6.3} @ {:>6.2}°     {:>6.3} @ {:>6.2}°      {:.2} s",
            s["kappa"],
            s["cycles_sun"].as_f64().unwrap_or(f64::NAN),
            s["cycles_planet"].as_f64().unwrap_or(f64::NAN),
            s["input_revolutions"].as_f64().unwrap_or(f64::NAN),
            f("sun", "max_um"),
            f("sun", "max_roll_deg"),
            f("planet", "max_um"),
            f("planet", "max_roll_deg"),
            s["seconds"].as_f64().unwrap_or(0.0),
        );
    }
    if let Some(why) = stopped {
        println!("stopped before κ = {to_kappa}: {why}");
    }
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Scene { action: SceneAction::Show(SceneShowArgs { scene }) } => match load_any(&scene)? {
            AnyScene::Gear(s) => print!("{}", s.to_toml()),
            AnyScene::Lumped(s) => print!("{}", s.to_toml()),
        },
        Command::Scene { action: SceneAction::Check(SceneCheckArgs { scene }) } => match load_any(&scene)? {
            AnyScene::Gear(s) => {
                let set = validated(&s)?;
                println!("scene '{}' is valid: {} planets", set.name(), set.planet_angles().len());
            }
            AnyScene::Lumped(s) => {
                let set = s.validate()?;
                println!("lumped scene '{}' is valid: {} planets", s.name, set.planet_angles.len());
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
        Command::Validate(a) => validate_command(a)?,
        Command::Calibrate(a) => calibrate_command(a)?,
        Command::Fmu { action: FmuAction::Pack(a) } => fmu_pack_command(a)?,
        Command::Fmu { action: FmuAction::References(a) } => fmu_references_command(a)?,
        Command::Fmu { action: FmuAction::Xml(a) } => fmu_xml_command(a)?,
        Command::Modes(a) => modes_command(a)?,
        Command::Ltca(a) => ltca_command(a)?,
    }
    Ok(())
}

fn simulate_command(SimulateArgs { scene, wear_state, stop, step }: SimulateArgs) -> Result<()> {
    let set = validated(&load_scene(&scene)?)?;
    if !(step.is_finite() && step > 0.0 && stop.is_finite() && stop > 0.0) {
        bail!("--stop and --step must be finite and positive (got {stop} and {step})");
    }
    let model = PlanetaryDynamics::new(&set, contact_model(&set, wear_state.as_deref())?)?;
    let mut sim =
        planetwear::dynamics::simulation::Simulation::new(&set, model, 0.0, set.dynamics().input_speed)?;
    let n = (stop / step).round() as u64;
    for k in 0..n {
        // Communication points on the integer grid t_k = k·step, each
        // step t_{k+1} − t_k (as fmpy and most importers call doStep):
        // the adaptive integrator's steps depend on the last bit of
        // the step ends.
        let (t0, t1) = (k as f64 * step, (k + 1) as f64 * step);
        sim.do_step(t0, t1 - t0)?;
        let row = serde_json::json!({
            "time": sim.time(),
            "sun.speed": sim.speed(planetwear::model::gear::Member::Sun),
            "planet[1].sunMeshForce": sim.mesh_force(0, planetwear::model::gear::MeshKind::SunPlanet),
            "planet[1].ringMeshForce": sim.mesh_force(0, planetwear::model::gear::MeshKind::RingPlanet),
        });
        println!("{row}");
    }
    Ok(())
}

fn run_command(RunArgs { scene, wear_state, speed, json, plots }: RunArgs) -> Result<()> {
    let set = validated(&load_scene(&scene)?)?;
    let mut model = PlanetaryDynamics::new(&set, contact_model(&set, wear_state.as_deref())?)?;
    let rpm = speed.unwrap_or(set.dynamics().input_speed * 30.0 / std::f64::consts::PI);
    let ss = steady_state(&mut model, &set, rpm * std::f64::consts::PI / 30.0, None)?;
    if let Some(dir) = &plots {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        write_steady_state(&ss, &set, dir)?;
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&ss)?);
    } else {
        print_steady_state(&ss, set.sun().face_width * 1e3);
    }
    Ok(())
}

fn sweep_command(
    SweepArgs { scene, wear_state, from, to, step, direction, out, histories, json }: SweepArgs,
) -> Result<()> {
    let set = validated(&load_scene(&scene)?)?;
    let speeds = speed_grid(from, to, step)?;
    let dirs: Vec<Direction> = match direction.as_str() {
        "up" => vec![Direction::Up],
        "down" => vec![Direction::Down],
        "both" => vec![Direction::Up, Direction::Down],
        other => bail!("--direction {other}: allowed are up, down, both"),
    };
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let model = PlanetaryDynamics::new(&set, contact_model(&set, wear_state.as_deref())?)?;
    let modes = natural_modes(&model.lumped);
    let bar = progress_bar((speeds.len() * dirs.len()) as u64);
    let started = std::time::Instant::now();
    let run = |d: Direction| {
        let mut m = model.clone();
        let mut grid = speeds.clone();
        if d == Direction::Down {
            grid.reverse();
        }
        sweep(&set, &mut m, d, &grid, &histories, |_| bar.inc(1))
    };
    let results: Vec<_> = if dirs.len() == 2 {
        let (a, b) = rayon::join(|| run(Direction::Up), || run(Direction::Down));
        vec![a?, b?]
    } else {
        vec![run(dirs[0])?]
    };
    bar.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();
    let width_mm = set.sun().face_width * 1e3;
    let mut files = Vec::new();
    for sw in &results {
        let name = if sw.direction == Direction::Up { "sweep_up.csv" } else { "sweep_down.csv" };
        let path = out.join(name);
        write_csv(&path, &sweep_csv(sw, width_mm))?;
        files.push(path);
        for p in sw.points.iter().filter(|p| !p.time.is_empty()) {
            files.extend(write_steady_state(p, &set, &out)?);
        }
    }
    files.extend(write_forced_response(&results, &set, &modes, &out)?);
    let peaks: Vec<_> = results
        .iter()
        .flat_map(|sw| {
            let mut v = find_peaks(sw, 0, width_mm, &modes, &set);
            v.extend(find_peaks(sw, 1, width_mm, &modes, &set));
            v
        })
        .collect();
    let steps: u64 = results.iter().flat_map(|s| &s.points).map(|p| p.stats.steps).sum();
    let summary = serde_json::json!({
        "scene": set.name(),
        "speeds": speeds.len(),
        "directions": dirs,
        "wall_time_s": wall,
        "internal_steps": steps,
        "steps_per_second": steps as f64 / wall,
        "peaks": peaks,
        "files": files,
    });
    write_atomic(&out.join("sweep.json"), serde_json::to_string_pretty(&summary)?.as_bytes())?;
    if json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "swept {} speeds × {} directions in {wall:.2} s ({steps} steps, {:.0} steps/s); {} files in {}",
            speeds.len(),
            dirs.len(),
            steps as f64 / wall,
            files.len(),
            out.display()
        );
        for p in &peaks {
            println!(
                "  peak {:?} {} at {:.0} rpm: F(rms) {:.1} N/mm; {}×f_m = {:.0} Hz ≈ {:?} mode at {:.0} Hz ({:.1} %)",
                p.direction,
                p.mesh.name(),
                p.speed_rpm,
                p.rms_n_per_mm,
                p.harmonic,
                f64::from(p.harmonic) * p.mesh_frequency,
                p.family,
                p.natural_frequency,
                100.0 * p.mismatch
            );
        }
    }
    Ok(())
}

fn wear_run_command(
    WearRunArgs { scene, to_kappa, out, ring, dynamic_speed, json }: WearRunArgs,
) -> Result<()> {
    wear_run(&scene, to_kappa, &out, ring, dynamic_speed, json)?;
    Ok(())
}

fn wear_compare_command(WearCompareArgs { scene, state, speeds, json }: WearCompareArgs) -> Result<()> {
    let set = validated(&load_scene(&scene)?)?;
    let model = wear_model(&set, false, None, None)?;
    let state = match &state {
        Some(path) => planetwear::wear::state::read_worn_state(path, &set)
            .with_context(|| format!("--state {}", path.display()))?,
        None => model.unworn(),
    };
    let face_mm = set.sun().face_width * 1e3;
    let mut docs = Vec::new();
    for rpm in speeds {
        if !(rpm.is_finite() && rpm > 0.0) {
            bail!("--speeds {rpm}: speeds must be finite and > 0 rpm");
        }
        let c = compare_sources(&model, &state, rpm)?;
        if json {
            docs.push(serde_json::json!({
                "speed_rpm": rpm,
                "flanks": c.flanks.iter().map(|f| serde_json::json!({
                    "flank": f.flank.name(), "roll": f.roll, "quasi_static": f.quasi_static,
                    "dynamic": f.dynamic, "ratio": f.ratio,
                    "quasi_static_max_roll": f.quasi_static_max_roll, "dynamic_max_roll": f.dynamic_max_roll,
                })).collect::<Vec<_>>(),
                "meshes": c.meshes.iter().map(|m| serde_json::json!({
                    "mesh": m.mesh.name(), "mean_force": m.mean_mesh_force, "rms_force": m.rms_mesh_force,
                    "quasi_static_max_pair_load": m.quasi_static_max_pair_load,
                    "dynamic_max_pair_load": m.dynamic_max_pair_load,
                })).collect::<Vec<_>>(),
            }));
            continue;
        }
        println!("{rpm:.0} rpm (κ = {}):", state.kappa);
        for m in &c.meshes {
            println!(
                "  {}: F(rms) {:.1} N/mm; largest pair load quasi-static {:.1}, dynamic {:.1} N/mm ({:.3}×)",
                m.mesh.name(),
                m.rms_mesh_force / face_mm,
                m.quasi_static_max_pair_load / face_mm,
                m.dynamic_max_pair_load / face_mm,
                m.dynamic_max_pair_load / m.quasi_static_max_pair_load
            );
        }
        for f in &c.flanks {
            println!(
                "  {}: largest wear per cycle quasi-static {:.4} pm at {:.2}°, dynamic {:.4} pm at {:.2}° ({:.3}×)",
                f.flank.name(),
                f.quasi_static_max * 1e12,
                f.quasi_static_max_roll.to_degrees(),
                f.dynamic_max * 1e12,
                f.dynamic_max_roll.to_degrees(),
                f.ratio
            );
        }
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&docs)?);
    }
    Ok(())
}

fn wear_effect_command(WearEffectArgs { scene, kappa, speeds, only, out }: WearEffectArgs) -> Result<()> {
    use planetwear::analysis::study::wear_effect::{run_all, variants};
    let base = load_scene(&scene)?;
    validated(&base)?;
    for rpm in &speeds {
        if !(rpm.is_finite() && *rpm > 0.0) {
            bail!("--speeds {rpm}: every speed must be a finite positive input speed in rpm");
        }
    }
    let mut list = variants(&base);
    if !only.is_empty() {
        let keys: Vec<String> = list.iter().map(|v| v.key.clone()).collect();
        if let Some(bad) = only.iter().find(|k| !keys.contains(k)) {
            bail!("--only {bad}: not a variant; the variants are {}", keys.join(", "));
        }
        list.retain(|v| only.contains(&v.key));
    }
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let started = std::time::Instant::now();
    let results: Vec<_> = run_all(&list, kappa, &speeds)
        .into_iter()
        .collect::<Result<_, _>>()
        .map_err(|e| anyhow::anyhow!("wear effect: {e}"))?;
    let table = planetwear::report::wear_effect::markdown(&results);
    write_atomic(&out.join("effect.md"), table.as_bytes())?;
    write_atomic(&out.join("effect.json"), serde_json::to_string_pretty(&results)?.as_bytes())?;
    for v in &list {
        println!("{}: {}", v.key, v.description);
    }
    println!("\n{table}");
    println!(
        "{} variants in {:.1} s; effect.md and effect.json in {}",
        results.len(),
        started.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}

fn wear_step_command(
    WearStepArgs { scene, state, out, threshold, revolutions, ring, dynamic_speed }: WearStepArgs,
) -> Result<()> {
    let set = validated(&load_scene(&scene)?)?;
    let model = wear_model(&set, ring, threshold, dynamic_speed)?;
    let before = match &state {
        Some(path) => planetwear::wear::state::read_worn_state(path, &set)
            .with_context(|| format!("--state {}", path.display()))?,
        None => model.unworn(),
    };
    let limit = match revolutions {
        Some(n) if n.is_finite() && n > 0.0 => Limit::Revolutions(n),
        Some(n) => bail!("--revolutions {n}: must be a finite number of input revolutions > 0"),
        None => Limit::Update,
    };
    let after = model.step(&before, limit)?;
    planetwear::wear::state::write_worn_state(&out, &after)?;
    let deepest = |s: &planetwear::wear::state::WornState, f| s.deepest_on(f);
    let (sun, planet) = (Flank::SunDrive, Flank::PlanetSunSide);
    println!(
        "κ {} → {}: {:.4e} input revolutions ({:.4e} in all); deepest wear sun {:.3} µm at {:.2}°, planet {:.3} µm at {:.2}°; wrote {}",
        before.kappa,
        after.kappa,
        after.revolutions - before.revolutions,
        after.revolutions,
        deepest(&after, sun).depth * 1e6,
        deepest(&after, sun).roll.to_degrees(),
        deepest(&after, planet).depth * 1e6,
        deepest(&after, planet).roll.to_degrees(),
        out.display()
    );
    Ok(())
}

fn validate_command(ValidateArgs { out, quick, scene }: ValidateArgs) -> Result<()> {
    use planetwear::analysis::study::validation::{validate, ValidationPlan};
    let s = load_scene(&scene)?;
    let set = validated(&s)?;
    let plan = if quick { ValidationPlan::quick() } else { ValidationPlan::full() };
    let v = validate(&s, &plan).map_err(|e| anyhow::anyhow!("validation of {scene}: {e}"))?;
    let command = format!(
        "planetwear validate --out {}{}{}",
        out.display(),
        if quick { " --quick" } else { "" },
        if scene == "example-2004" { String::new() } else { format!(" --scene {scene}") }
    );
    planetwear::report::validation::write_report(&v, &out, set.sun().face_width, &command)?;
    for r in &v.rows {
        println!(
            "{:<5} {:<40} ours {}",
            if r.verdict == planetwear::analysis::study::validation::Verdict::Pass { "pass" } else { "FAIL" },
            r.id,
            r.ours
        );
    }
    let failing = planetwear::report::validation::failing(&v);
    println!(
        "{} of {} rows pass ({:.0} s); report {}",
        v.rows.len() - failing.len(),
        v.rows.len(),
        v.seconds,
        out.join("VALIDATION.md").display()
    );
    Ok(())
}

fn calibrate_command(CalibrateArgs { plan, out, show_plan, json }: CalibrateArgs) -> Result<()> {
    calibrate(&plan, out.as_deref(), show_plan, json)?;
    Ok(())
}

fn fmu_pack_command(FmuPackArgs { out, library }: FmuPackArgs) -> Result<()> {
    let library = match library {
        Some(l) => l,
        None => std::env::current_exe()?
            .parent()
            .map(|d| d.join("libplanetwear.so"))
            .context("locating the executable's directory")?,
    };
    planetwear::package::pack::pack(&library, &out)?;
    println!("wrote {} (library {})", out.display(), library.display());
    Ok(())
}

fn fmu_references_command(FmuReferencesArgs { out, relative_tolerance }: FmuReferencesArgs) -> Result<()> {
    use planetwear::package::regression::{example_references, CASES};
    let started = std::time::Instant::now();
    let mut texts = Vec::new();
    for state in planetwear::package::pack::example_wear_states()? {
        texts.push(state.to_json()?);
    }
    let refs = example_references(&texts, &CASES, relative_tolerance)?;
    write_atomic(&out, refs.to_json()?.as_bytes())?;
    for c in &refs.cases {
        println!(
            "{:<18} sun F1 {:9.3} N  ring F1 {:9.3} N  drift {:.2e}  tolerance {:.1e} of F1  ({} steps)",
            c.name,
            c.values["window.sunMeshF1"],
            c.values["window.ringMeshF1"],
            c.budget.drift,
            c.budget.fraction_of_f1,
            c.work.steps
        );
    }
    println!(
        "wrote {} ({} cases, {:.1} s)",
        out.display(),
        refs.cases.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn fmu_xml_command(FmuXmlArgs { out }: FmuXmlArgs) -> Result<()> {
    let xml = planetwear::fmi::variables::MODEL_DESCRIPTION_XML;
    match out {
        Some(path) => write_atomic(&path, xml.as_bytes())?,
        None => print!("{xml}"),
    }
    Ok(())
}

fn modes_command(ModesArgs { scene, wear_state, json }: ModesArgs) -> Result<()> {
    let (name, lumped) = match load_any(&scene)? {
        AnyScene::Gear(s) => {
            let set = validated(&s)?;
            let model = PlanetaryDynamics::new(&set, contact_model(&set, wear_state.as_deref())?)?;
            (set.name().to_string(), model.lumped)
        }
        AnyScene::Lumped(_) if wear_state.is_some() => {
            bail!("--wear-state: a lumped-parameter scene has no tooth flanks to wear")
        }
        AnyScene::Lumped(s) => (s.name.clone(), s.validate()?),
    };
    report_modes(&name, &lumped, json)?;
    Ok(())
}

fn ltca_command(LtcaArgs { scene, wear_state, torque, samples, json, out, plots }: LtcaArgs) -> Result<()> {
    let mut scene = load_scene(&scene)?;
    if let Some(t) = torque {
        scene.operation.input_torque_nm = t;
    }
    if let Some(n) = samples {
        scene.analysis.positions_per_mesh_cycle = n as u32;
    }
    let set = validated(&scene)?;
    if set.input_torque() <= 0.0 {
        bail!("--torque: the LTCA needs a positive input torque (got {} N·m)", set.input_torque());
    }
    let state = match &wear_state {
        Some(path) => Some(
            planetwear::wear::state::read_worn_state(path, &set)
                .with_context(|| format!("--wear-state {}", path.display()))?,
        ),
        None => None,
    };
    let model = state.as_ref().map_or_else(|| SetModel::new(&set), |s| s.set_model(&set));
    let kappa = state.as_ref().map(|s| s.kappa);
    let study = LtcaStudy::run_on(&set, &model, set.analysis().positions_per_mesh_cycle, kappa);
    let doc = study.to_json();
    let text = serde_json::to_string_pretty(&doc)?;
    if let Some(path) = &out {
        write_atomic(path, text.as_bytes()).map_err(anyhow::Error::from)?;
    }
    if let Some(dir) = &plots {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let files = study.write_plots(dir).map_err(anyhow::Error::from)?;
        if !json {
            println!("wrote {} plot files to {}", files.len(), dir.display());
        }
    }
    if json {
        println!("{text}");
    } else {
        print_summary(&doc);
    }
    Ok(())
}

fn calibrate(plan: &str, out: Option<&Path>, show_plan: bool, json: bool) -> Result<()> {
    use planetwear::analysis::study::calibrate::{calibrate, CalibrationError, PlanFile};
    let (text, dir) = match Scene::builtin_plan(plan) {
        Some(t) => (t.to_string(), PathBuf::from(".")),
        None => {
            let path = Path::new(plan);
            if !path.is_file() {
                bail!("--plan {plan}: neither a built-in scene with a calibration (example-2004) nor a plan file");
            }
            let text = std::fs::read_to_string(path).with_context(|| format!("reading plan file {plan}"))?;
            (text, path.parent().map(Path::to_path_buf).unwrap_or_default())
        }
    };
    if show_plan {
        print!("{text}");
        return Ok(());
    }
    let file = PlanFile::from_toml(&text).with_context(|| format!("--plan {plan}"))?;
    let base_name = if Scene::builtin(&file.base).is_some() {
        file.base.clone()
    } else {
        dir.join(&file.base).to_string_lossy().into_owned()
    };
    let base = load_scene(&base_name).with_context(|| format!("base = {} in --plan {plan}", file.base))?;
    let plan_value = file.plan(&base).with_context(|| format!("--plan {plan}"))?;
    match calibrate(&plan_value) {
        Ok(done) => {
            if json {
                println!("{}", serde_json::to_string_pretty(&done.report)?);
            } else {
                print_calibration(&done.report, &file.base);
            }
            if let Some(path) = out {
                write_atomic(path, done.scene.to_toml().as_bytes())?;
                if !json {
                    println!("wrote the calibrated scene {} to {}", done.scene.name, path.display());
                }
            }
            Ok(())
        }
        Err(CalibrationError::IllPosed { why, report }) => {
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print_calibration(&report, &file.base);
            }
            bail!("ill-posed calibration, no scene written: {why}")
        }
        Err(e) => Err(e.into()),
    }
}

fn print_calibration(r: &planetwear::analysis::study::calibrate::Report, base: &str) {
    println!(
        "calibration of {} from {base}: {} iterations, {} evaluations, {} contact models, {:.1} s",
        r.name, r.iterations, r.evaluations, r.contact_models, r.seconds
    );
    println!("targets:");
    println!(
        "  {:<3} {:<44} {:>11} {:>8} {:>11} {:>11} {:>9}  met",
        "#", "measure", "target", "tol", "start", "reached", "residual"
    );
    for (i, t) in r.targets.iter().enumerate() {
        println!(
            "  {:<3} {:<44} {:>11.4} {:>7.2}% {:>11.4} {:>11.4} {:>+8.3}%  {}",
            i + 1,
            t.target.measure.describe(),
            t.target.value,
            100.0 * t.target.tolerance,
            t.start,
            t.reached,
            100.0 * t.residual,
            if t.met { "yes" } else { "NO" }
        );
    }
    println!("parameters (file units):");
    for (k, p) in r.parameters.iter().enumerate() {
        println!(
            "  p{} {}: bounds [{:.4e}, {:.4e}], start {:.5e}, fitted {:.5e}, ratio {:.4}{}",
            k + 1,
            p.free.name(),
            p.free.min,
            p.free.max,
            p.start,
            p.fitted,
            p.ratio,
            p.at_bound.as_ref().map(|b| format!("  AT ITS {}", b.to_uppercase())).unwrap_or_default()
        );
    }
    print!("sensitivity ∂ln(target)/∂ln(parameter) at the fit:\n  {:<3}", "#");
    for k in 0..r.parameters.len() {
        print!(" {:>9}", format!("p{}", k + 1));
    }
    println!();
    for (i, _) in r.targets.iter().enumerate() {
        print!("  {:<3}", i + 1);
        for p in &r.parameters {
            print!(" {:>+9.4}", p.sensitivity[i]);
        }
        println!();
    }
    println!(
        "singular values of the scaled Jacobian: {}",
        r.singular_values.iter().map(|v| format!("{v:.3e}")).collect::<Vec<_>>().join(", ")
    );
}

fn work_precision(out: &Path, quick: bool) -> Result<()> {
    use planetwear::analysis::accuracy::StudyPlan;
    use planetwear::model::lumped::Fidelity;
    use planetwear::report::accuracy::{operating_points, run_study, tables_markdown, write_study};
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let (plan, mut points) = if quick {
        (StudyPlan::quick(), operating_points(Fidelity::Torsional)?)
    } else {
        (StudyPlan::full(), operating_points(Fidelity::Torsional)?)
    };
    if !quick {
        points.extend(operating_points(Fidelity::TransverseTorsional)?);
    }
    let study = run_study(&points, &plan, None, |point, run| {
        if run == "reference checks" {
            eprintln!("{point}: reference done; running the methods");
        }
    })?;
    let context = serde_json::json!({
        "command": std::env::args().collect::<Vec<_>>().join(" "),
        "machine": planetwear::report::accuracy::machine(),
        "independent_integrator": "none in the CLI (cargo bench --bench work_precision adds DOP853)",
    });
    let files = write_study(&study, out, context)?;
    print!("{}", tables_markdown(&study));
    println!("\nstudy took {:.1} s; {} files in {}", study.wall_seconds, files.len(), out.display());
    Ok(())
}

fn speed_grid(from: f64, to: f64, step: f64) -> Result<Vec<f64>> {
    if !(from.is_finite() && to.is_finite() && from > 0.0 && to > 0.0) {
        bail!("--from/--to: speeds must be finite and positive (got {from} and {to} rpm)");
    }
    if !(step.is_finite() && step > 0.0) {
        bail!("--step: must be a finite positive speed step (got {step} rpm)");
    }
    let (lo, hi) = (from.min(to), from.max(to));
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

fn print_steady_state(ss: &SteadyState, width_mm: f64) {
    println!(
        "steady state at {:.1} rpm (mesh frequency {:.1} Hz, {} mesh cycles; {} steps, {} Newton iterations)",
        ss.input_speed_rpm, ss.mesh_frequency, ss.cycles, ss.stats.steps, ss.stats.newton_iterations
    );
    println!(
        "  {:<16} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7}",
        "mesh", "mean", "F1", "F2", "F3", "F4", "F5", "F6", "rms", "sep"
    );
    for m in &ss.meshes {
        let h = &m.harmonics;
        print!(
            "  planet {} {:<7} {:>9.2}",
            m.planet,
            format!("{:?}", m.mesh).replace("Planet", ""),
            h.mean / width_mm
        );
        for a in &h.amplitude {
            print!(" {:>9.2}", a / width_mm);
        }
        println!(" {:>9.2} {:>7.3}", h.rms / width_mm, m.separation);
    }
    println!("  (forces in N/mm of face width)");
}

fn report_modes(name: &str, set: &LumpedSet, json: bool) -> Result<()> {
    let modes = natural_modes(set);
    let red = set.reduction();
    if json {
        let doc = serde_json::json!({
            "scene": name,
            "fidelity": set.fidelity,
            "held": set.held,
            "mean_mesh_stiffness": {"sun_planet": set.sun_mesh, "ring_planet": set.ring_mesh},
            "coordinates": red.coordinates.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>(),
            "modes": modes,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    println!(
        "natural modes of {name} ({:?}, held {:?}); mean mesh stiffness sun–planet {:.4e} N/m, ring–planet {:.4e} N/m",
        set.fidelity, set.held, set.sun_mesh, set.ring_mesh
    );
    println!("  {:>12}  {:<14} {:>12}", "frequency Hz", "class", "multiplicity");
    let mut i = 0;
    while i < modes.len() {
        let m = &modes[i];
        let class = match m.class {
            ModeClass::RigidBody => "rigid body",
            ModeClass::Rotational => "rotational",
            ModeClass::Translational => "translational",
            ModeClass::Planet => "planet",
            ModeClass::Mixed => "mixed",
        };
        println!("  {:>12.1}  {:<14} {:>12}", m.frequency, class, m.multiplicity);
        i += m.multiplicity.max(1);
    }
    Ok(())
}

fn print_summary(doc: &serde_json::Value) {
    let width_mm = doc["face_width"].as_f64().unwrap_or(1.0) * 1e3;
    println!(
        "LTCA of {} at {} N·m (κ = {})",
        doc["scene"].as_str().unwrap_or("?"),
        doc["input_torque"],
        doc["kappa"]
    );
    for m in doc["meshes"].as_array().into_iter().flatten() {
        let f = |k: &str| m[k].as_f64().unwrap_or(f64::NAN);
        let g = |k: &str, s: &str| m[k][s].as_f64().unwrap_or(f64::NAN);
        println!("  {}:", m["name"].as_str().unwrap_or("?"));
        println!("    load {:.1} N/mm along the line of action", f("load") / width_mm);
        println!(
            "    contact ratio: nominal {:.4}, on the involutes {:.4}, loaded {:.4} (1 pair {:.1} %, 2 pairs {:.1} %, 3 pairs {:.1} %)",
            f("contact_ratio_nominal"),
            f("contact_ratio_involute"),
            f("contact_ratio_loaded"),
            100.0 * m["pairs_in_contact_fraction"]["1"].as_f64().unwrap_or(0.0),
            100.0 * m["pairs_in_contact_fraction"]["2"].as_f64().unwrap_or(0.0),
            100.0 * m["pairs_in_contact_fraction"]["3"].as_f64().unwrap_or(0.0),
        );
        let k = |v: f64| v / width_mm * 1e-6;
        println!(
            "    mesh stiffness N/(mm·µm): nominal mean {:.3} p-p {:.3}; loaded mean {:.3} p-p {:.3}; ISO c_γα {:.3}",
            k(g("mesh_stiffness_nominal", "mean")),
            k(g("mesh_stiffness_nominal", "peak_to_peak")),
            k(g("mesh_stiffness_loaded", "mean")),
            k(g("mesh_stiffness_loaded", "peak_to_peak")),
            m["iso6336"]["mesh_stiffness_per_width_N_per_mm_um"].as_f64().unwrap_or(f64::NAN),
        );
        println!(
            "    static TE: mean {:.3} µm, peak-to-peak {:.3} µm; peak Hertz pressure {:.0} MPa, half-width up to {:.1} µm",
            g("static_transmission_error", "mean") * 1e6,
            g("static_transmission_error", "peak_to_peak") * 1e6,
            f("peak_hertz_pressure") * 1e-6,
            f("max_hertz_half_width") * 1e6,
        );
    }
    let p = &doc["planets"];
    let loads: Vec<String> = p["mean_load"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|v| format!("{:.2}", v.as_f64().unwrap_or(f64::NAN) / width_mm))
        .collect();
    println!(
        "  planets: mean loads {} N/mm, load sharing factor {:.4}; sun rotation along the line of action peak-to-peak {:.3} µm",
        loads.join(", "),
        p["load_sharing_factor"].as_f64().unwrap_or(f64::NAN),
        p["sun_transmission_error"]["peak_to_peak"].as_f64().unwrap_or(f64::NAN) * 1e6
    );
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
