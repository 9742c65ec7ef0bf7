//! Assembling the FMU archive: `modelDescription.xml` at the root, the
//! shared library as `binaries/linux64/planetwear.so`, the built-in scenes,
//! the example's worn-profile states and its regression references in
//! `resources/`, and `documentation/index.html` generated from the same
//! variable table. Written to a temporary file and renamed into place.
//!
//! Packed with a scene ([`pack_scene`]), the archive makes that scene its
//! default: `resources/default-scene.toml` (the instance reads it when it
//! is there), modelDescription.xml with sceneFile and every parameter's and
//! input's start value set to the scene's, its own worn-profile states in
//! `resources/wear/default-scene/` and the regression references computed
//! for it.

use std::io::Write;
use std::path::Path;

use zip::write::SimpleFileOptions;

use crate::fmi::instance::{scene_values, DEFAULT_SCENE};
use crate::fmi::variables::{Causality, Start, GUID, MODEL_DESCRIPTION_XML, MODEL_IDENTIFIER, VARIABLES};
use crate::package::regression::{
    scene_references, CASES, REFERENCE_RELATIVE_TOLERANCE, RESOURCE, STEPS_PER_MESH_CYCLE,
};
use crate::scene::lumped::LumpedScene;
use crate::scene::Scene;
use crate::wear::archard::{Limit, WearSettings};
use crate::wear::state::WornState;
use crate::wear::stepper::WearModel;

/// Why the FMU could not be assembled.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// The shared library is missing.
    #[error("the FMU's shared library {path} does not exist: build it with `cargo build --release`")]
    MissingLibrary {
        /// Where it was looked for.
        path: String,
    },
    /// Reading or writing failed.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The archive could not be written.
    #[error("writing the FMU archive: {0}")]
    Zip(#[from] zip::result::ZipError),
    /// The example's worn-profile states could not be computed.
    #[error("computing the example's worn-profile states: {0}")]
    Wear(String),
    /// The regression references could not be computed.
    #[error("computing the regression references: {0}")]
    References(String),
    /// The scene to pack cannot be the FMU's default.
    #[error("--scene: {0}")]
    Scene(String),
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// documentation/index.html: the model summary and the variable table;
/// with `scene`, what packing with that scene as the default changed.
pub fn documentation(scene: Option<&Scene>) -> String {
    let mut h = String::from(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>planetwear FMU</title></head><body>\n",
    );
    h.push_str("<h1>planetwear</h1>\n<p>Nonlinear tooth-by-tooth dynamics of a spur planetary gear set (sun, ring, carrier, up to 8 planets) with time-varying mesh stiffness, tooth separation, back-flank contact and tip-corner contact, in Lin &amp; Parker's transverse-torsional or the torsional model. FMI 2.0 co-simulation; internal time integration by generalized-alpha or adaptive Runge-Kutta 5(4).</p>\n");
    h.push_str(&format!("<p>GUID {GUID}. The parameters default to the automatic-transmission planetary set of a 2004 tooth-wear study (sun 34, planet 18, ring 70 teeth, module 1.5 mm, 4 planets, carrier held, 750 N·m on the sun). With <code>sceneFile</code> empty every parameter defines the set; with a scene file (a path or a file in resources/), only the parameters the importer sets override it. <code>wearStateFile</code> names a worn-profile state written by <code>planetwear wear</code> (a path, or a file in resources/): the example's states after 0 to 6 wear updates are shipped as <code>wear/example-2004/kappa-0.json</code> … <code>kappa-6.json</code>; a state of another gear set is refused.</p>\n"));
    if let Some(scene) = scene {
        h.push_str(&format!("<p><b>This FMU is packed with the scene '{}' as its default</b> (<code>planetwear fmu pack --scene</code>): <code>sceneFile</code> starts at <code>{DEFAULT_SCENE}</code> (in resources/), every parameter and input starts at that scene's value, its worn-profile states are <code>wear/default-scene/kappa-0.json</code> … <code>kappa-6.json</code> and the regression references are computed for it. The built-in example stays available as <code>example-2004.toml</code>.</p>\n", html_escape(&scene.name)));
    }
    h.push_str(&format!("<p>Regression references: <code>{RESOURCE}</code> holds, for a few speeds and worn states of the example, the values of the <code>window.*</code> outputs that a run through the protocol stated in the file (RK 5(4) at relative tolerance 3e-6, {STEPS_PER_MESH_CYCLE} internal grid points per mesh cycle, torques held, doStep of one mesh period) reproduces within the tolerance given per output; the Python package planetwear-fmu (<code>planetwear_fmu.regression</code>, pytest fixture <code>planetwear_reference</code>) runs and checks them.</p>\n"));
    for (title, causality) in
        [("Parameters", Causality::Parameter), ("Inputs", Causality::Input), ("Outputs", Causality::Output)]
    {
        h.push_str(&format!("<h2>{title}</h2>\n<table border=\"1\" cellpadding=\"3\"><tr><th>name</th><th>value reference</th><th>type</th><th>unit</th><th>min</th><th>max</th><th>description</th></tr>\n"));
        for v in VARIABLES.iter().filter(|v| v.causality == causality) {
            h.push_str(&format!(
                "<tr><td>{}</td><td>{}</td><td>{:?}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                html_escape(v.name),
                v.vr,
                v.kind,
                html_escape(v.unit),
                v.min.map_or(String::new(), |x| x.to_string()),
                v.max.map_or(String::new(), |x| x.to_string()),
                html_escape(v.description)
            ));
        }
        h.push_str("</table>\n");
    }
    h.push_str("</body></html>\n");
    h
}

/// The worn-profile states κ = 0..6 of the example with the default wear settings.
pub fn example_wear_states() -> Result<Vec<WornState>, PackError> {
    wear_states(&Scene::example_2004())
}

/// The worn-profile states κ = 0..6 of `scene` with the default wear settings.
pub fn wear_states(scene: &Scene) -> Result<Vec<WornState>, PackError> {
    let set = scene.validate().map_err(|e| PackError::Wear(e.to_string()))?;
    let model =
        WearModel::new(&set, WearSettings::for_set(&set)).map_err(|e| PackError::Wear(e.to_string()))?;
    let mut states = vec![model.unworn()];
    for _ in 0..6 {
        let next = model
            .step(&states[states.len() - 1], Limit::Update)
            .map_err(|e| PackError::Wear(e.to_string()))?;
        states.push(next);
    }
    Ok(states)
}

impl From<crate::files::FileError> for PackError {
    fn from(e: crate::files::FileError) -> Self {
        PackError::Io { path: e.path.display().to_string(), source: e.error }
    }
}

/// modelDescription.xml of an FMU whose default is `scene`: sceneFile
/// starts at [`DEFAULT_SCENE`] and every parameter and input with a
/// counterpart in the scene at its value ([`scene_values`], the start values
/// the instance takes from the same file). The interface, and so the GUID,
/// is unchanged. Refuses a scene the FMU's bounds (min, max) refuse.
pub fn model_description_for(scene: &Scene) -> Result<String, PackError> {
    let values = scene_values(scene).map_err(|e| PackError::Scene(e.to_string()))?;
    let mut xml = MODEL_DESCRIPTION_XML.to_string();
    let mut set_start = |name: &str, text: String| -> Result<(), PackError> {
        let head = format!("<ScalarVariable name=\"{name}\"");
        let at = xml
            .find(&head)
            .ok_or_else(|| PackError::Scene(format!("{name} is not in modelDescription.xml")))?;
        let len = xml[at..].find("</ScalarVariable>").unwrap_or(0);
        let block = &xml[at..at + len];
        let s =
            block.find(" start=\"").ok_or_else(|| PackError::Scene(format!("{name} has no start value")))?;
        let e = block[s + 8..].find('"').map(|e| s + 8 + e).unwrap_or(s + 8);
        let replaced = format!("{} start=\"{text}\"{}", &block[..s], &block[e + 1..]);
        xml.replace_range(at..at + len, &replaced);
        Ok(())
    };
    set_start("sceneFile", DEFAULT_SCENE.to_string())?;
    for (p, value) in values {
        let v = p.variable();
        let info = v.info();
        let x = match value {
            Start::Real(x) => x,
            Start::Integer(n) => f64::from(n),
            _ => continue,
        };
        if info.min.is_some_and(|lo| x < lo) || info.max.is_some_and(|hi| x > hi) {
            return Err(PackError::Scene(format!(
                "{} = {x}: this FMU allows {} to {}",
                v.name(),
                info.min.map_or("-inf".to_string(), |m| m.to_string()),
                info.max.map_or("inf".to_string(), |m| m.to_string())
            )));
        }
        let text = match value {
            Start::Real(x) => format!("{x:?}"),
            Start::Integer(n) => n.to_string(),
            _ => continue,
        };
        set_start(v.name(), text)?;
    }
    Ok(xml)
}

/// Writes the FMU archive to `out` from the shared library at `library`,
/// with the built-in example as its default set.
pub fn pack(library: &Path, out: &Path) -> Result<(), PackError> {
    pack_scene(library, out, None, &CASES)
}

/// Writes the FMU archive to `out` from the shared library at `library`:
/// with `scene` as its default set (resources/default-scene.toml, the start
/// values, its worn-profile states and the regression references of
/// `cases` computed for it), or the built-in example when `None`.
pub fn pack_scene(
    library: &Path,
    out: &Path,
    scene: Option<&Scene>,
    cases: &[(usize, f64)],
) -> Result<(), PackError> {
    let io = |path: &Path| {
        let path = path.display().to_string();
        move |source| PackError::Io { path, source }
    };
    if !library.is_file() {
        return Err(PackError::MissingLibrary { path: library.display().to_string() });
    }
    let so = crate::files::read_input(library, crate::files::InputKind::Library)
        .map_err(|e| PackError::Io { path: library.display().to_string(), source: e.error })?;
    let dir = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    // Written durably: on any failure (here or while packing) the temporary
    // archive is removed and `out` is untouched.
    // The default set: its description, states and references, computed
    // before anything is written.
    let (base, description, state_dir) = match scene {
        None => (Scene::example_2004(), MODEL_DESCRIPTION_XML.to_string(), "wear/example-2004"),
        Some(s) => {
            let set = s.validate().map_err(|e| PackError::Scene(e.to_string()))?;
            if set.planet_angles().len() > 8 {
                return Err(PackError::Scene(format!(
                    "planets.count = {}: this FMU has outputs for at most 8 planets",
                    set.planet_angles().len()
                )));
            }
            (s.clone(), model_description_for(s)?, "wear/default-scene")
        }
    };
    let states = wear_states(&base)?;
    let mut texts = Vec::new();
    for state in &states {
        texts.push(state.to_json().map_err(|e| PackError::Wear(e.to_string()))?);
    }
    // Reference results for regression tests (docs/REGRESSION.md), computed
    // from the shipped states' text as the FMU reads it.
    let references = scene_references(&base, state_dir, &texts, cases, REFERENCE_RELATIVE_TOLERANCE)
        .and_then(|r| r.to_json())
        .map_err(|e| PackError::References(e.to_string()))?;
    crate::files::write_durable_with(out, "", |tmp| {
        let file = std::fs::OpenOptions::new().write(true).truncate(true).open(tmp).map_err(io(tmp))?;
        let mut zip = zip::ZipWriter::new(file);
        let opts = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
        let mut add = |name: &str, data: &[u8]| -> Result<(), PackError> {
            zip.start_file(name, opts)?;
            zip.write_all(data).map_err(io(Path::new(name)))
        };
        add("modelDescription.xml", description.as_bytes())?;
        add(&format!("binaries/linux64/{MODEL_IDENTIFIER}.so"), &so)?;
        add("resources/example-2004.toml", Scene::example_2004().to_toml().as_bytes())?;
        // The kinematics the Python package reads beside each gear scene.
        add("resources/example-2004.kinematics.json", &kinematics_json(&Scene::example_2004())?)?;
        add("resources/lumped-benchmark.toml", LumpedScene::lumped_benchmark().to_toml().as_bytes())?;
        if scene.is_some() {
            add(&format!("resources/{DEFAULT_SCENE}"), base.to_toml().as_bytes())?;
            let stem = DEFAULT_SCENE.trim_end_matches(".toml");
            add(&format!("resources/{stem}.kinematics.json"), &kinematics_json(&base)?)?;
        }
        // The default set's worn-profile states κ = 0..6 (the wear model's
        // run, about 5 s for the example), for the wearStateFile parameter.
        for (kappa, text) in texts.iter().enumerate() {
            add(&format!("resources/{state_dir}/kappa-{kappa}.json"), text.as_bytes())?;
        }
        add(RESOURCE, references.as_bytes())?;
        add("documentation/index.html", documentation(scene).as_bytes())?;
        zip.finish()?;
        Ok(())
    })
}

/// The kinematics of a scene's gear set as the JSON the Python package reads
/// from resources/ (`planetwear scene show --json` prints the same).
fn kinematics_json(scene: &Scene) -> Result<Vec<u8>, PackError> {
    let set = scene.validate().map_err(|e| PackError::Scene(e.to_string()))?;
    let kinematics = crate::model::kinematics::Kinematics::of(&set);
    serde_json::to_vec_pretty(&kinematics).map_err(|e| PackError::Scene(e.to_string()))
}
