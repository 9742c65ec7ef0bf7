//! `planetwear`: the command-line tool. A thin shell over the library: it
//! reads scenes, runs the analyses and writes reports.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use planetwear::physics::dynamics::PlanetaryDynamics;
use planetwear::physics::gear::GearSet;
use planetwear::physics::ltca::SetModel;
use planetwear::physics::lumped::LumpedSet;
use planetwear::physics::modes::{natural_modes, ModeClass};
use planetwear::report::ltca::LtcaStudy;
use planetwear::report::write_atomic;
use planetwear::scene::lumped::LumpedScene;
use planetwear::scene::Scene;

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
    /// Natural frequencies and mode shapes of the mean-stiffness linear model.
    Modes {
        /// A built-in scene (example-2004, lumped-benchmark) or a scene file.
        #[arg(long)]
        scene: String,
        /// Print the full result as JSON (SI units, frequencies in Hz).
        #[arg(long)]
        json: bool,
    },
    /// Quasi-static loaded tooth contact analysis of both meshes and of the whole set.
    Ltca {
        /// A built-in scene name (example-2004) or a scene file (TOML).
        #[arg(long)]
        scene: String,
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
    },
}

#[derive(Subcommand)]
enum SceneAction {
    /// Print a scene (built-in name or file) as TOML.
    Show {
        /// Built-in name or file.
        scene: String,
    },
    /// Validate a scene and list every problem.
    Check {
        /// Built-in name or file.
        scene: String,
    },
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

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Scene { action: SceneAction::Show { scene } } => match load_any(&scene)? {
            AnyScene::Gear(s) => print!("{}", s.to_toml()),
            AnyScene::Lumped(s) => print!("{}", s.to_toml()),
        },
        Command::Scene { action: SceneAction::Check { scene } } => match load_any(&scene)? {
            AnyScene::Gear(s) => {
                let set = validated(&s)?;
                println!("scene '{}' is valid: {} planets", set.name, set.planet_angles.len());
            }
            AnyScene::Lumped(s) => {
                let set = s.validate()?;
                println!("lumped scene '{}' is valid: {} planets", s.name, set.planet_angles.len());
            }
        },
        Command::Modes { scene, json } => {
            let (name, lumped) = match load_any(&scene)? {
                AnyScene::Gear(s) => {
                    let set = validated(&s)?;
                    let model = PlanetaryDynamics::new(&set, SetModel::new(&set))?;
                    (set.name.clone(), model.lumped)
                }
                AnyScene::Lumped(s) => (s.name.clone(), s.validate()?),
            };
            report_modes(&name, &lumped, json)?;
        }
        Command::Ltca { scene, torque, samples, json, out, plots } => {
            let mut scene = load_scene(&scene)?;
            if let Some(t) = torque {
                scene.operation.input_torque_nm = t;
            }
            if let Some(n) = samples {
                scene.analysis.positions_per_mesh_cycle = n as u32;
            }
            let set = validated(&scene)?;
            if set.input_torque <= 0.0 {
                bail!("--torque: the LTCA needs a positive input torque (got {} N·m)", set.input_torque);
            }
            let study = LtcaStudy::run(&set, set.analysis.positions_per_mesh_cycle);
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
        }
    }
    Ok(())
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
    println!("LTCA of {} at {} N·m", doc["scene"].as_str().unwrap_or("?"), doc["input_torque"]);
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
        "  planets: mean loads {} N/mm, load sharing factor {:.4}",
        loads.join(", "),
        p["load_sharing_factor"].as_f64().unwrap_or(f64::NAN)
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
