//! Generates, from `modelDescription/variables.toml` (the single source of
//! truth for the FMU's variables), the Rust value-reference table
//! (`$OUT_DIR/fmi_variables.rs`) and `modelDescription.xml`
//! (`$OUT_DIR/modelDescription.xml`). The GUID is a 128-bit FNV-1a hash of the
//! variable interface: names, value references, types, causality,
//! variability and units — it changes exactly when the interface does.
//! The table is checked here: a broken table fails the build with a message
//! naming the variable.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::PathBuf;

use quick_xml::events::{BytesDecl, Event};
use quick_xml::Writer;
use serde::Deserialize;

// The GUID's code and the hash it uses, under the library's module paths.
#[path = "src/fmi/guid.rs"]
mod guid;
#[path = "src/files/hash.rs"]
#[allow(dead_code)]
pub mod hash;
mod files {
    pub(crate) use super::hash;
}

#[derive(Deserialize)]
struct Table {
    model: Model,
    variable: Vec<Var>,
}

/// A unit: name, exponents of kg, m, s, rad, and display units (name, factor).
type UnitRow = (String, i32, i32, i32, i32, Vec<(String, f64)>);

#[derive(Deserialize)]
struct Model {
    model_name: String,
    model_identifier: String,
    description: String,
    author: String,
    license: String,
    log_categories: Vec<(String, String)>,
    units: Vec<UnitRow>,
}

#[derive(Deserialize)]
struct Var {
    vr: u32,
    name: String,
    #[serde(rename = "type")]
    ty: String,
    causality: String,
    variability: String,
    initial: Option<String>,
    unit: Option<String>,
    display: Option<String>,
    start: Option<toml::Value>,
    /// Inclusive lower bound (FMI 2.0 `min`), the same as the instance's
    /// validation accepts.
    min: Option<toml::Value>,
    /// Inclusive upper bound (FMI 2.0 `max`).
    max: Option<toml::Value>,
    /// An output's reading: the quantity and the planet, member, mesh or
    /// harmonic order it is read at.
    read: Option<Read>,
    /// A parameter's or input's place in the scene.
    scene: Option<ScenePlace>,
    description: String,
}

/// What an output reads (`read = { quantity = "mesh_force", planet = 1, mesh = "sun" }`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Read {
    quantity: String,
    planet: Option<u32>,
    member: Option<String>,
    mesh: Option<String>,
    order: Option<u32>,
}

/// Where a settable variable acts in the scene: `fields` it writes through
/// a `slot` (`real`, `count` or `derived`), and further scene keys (`names`)
/// by which a problem the scene reports is told as this variable's.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenePlace {
    slot: Option<String>,
    #[serde(default)]
    fields: Vec<String>,
    #[serde(default)]
    names: Vec<String>,
}

fn fail(msg: String) -> ! {
    panic!("modelDescription/variables.toml: {msg}");
}

fn const_name(name: &str) -> String {
    let mut out = String::new();
    let mut prev_lower = false;
    for c in name.chars() {
        if c.is_ascii_uppercase() && prev_lower {
            out.push('_');
        }
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_uppercase());
            prev_lower = c.is_ascii_lowercase() || c.is_ascii_digit();
        } else {
            if !out.ends_with('_') && !out.is_empty() {
                out.push('_');
            }
            prev_lower = false;
        }
    }
    out.trim_end_matches('_').to_string()
}

fn real_text(v: f64) -> String {
    let s = format!("{v:?}");
    s.replace("e-0", "e-").replace("e0", "e")
}

/// The start value of a variable as written in modelDescription.xml.
fn start_text(v: &Var) -> Option<String> {
    let s = v.start.as_ref()?;
    Some(match (v.ty.as_str(), s) {
        ("Real", toml::Value::Float(f)) => real_text(*f),
        ("Real", toml::Value::Integer(n)) => real_text(*n as f64),
        ("Integer", toml::Value::Integer(n)) => n.to_string(),
        ("Boolean", toml::Value::Boolean(b)) => b.to_string(),
        ("String", toml::Value::String(s)) => s.clone(),
        _ => fail(format!("{}: start value {s} does not fit type {}", v.name, v.ty)),
    })
}

/// A bound (`min` or `max`) of a variable as a number and as written in
/// modelDescription.xml.
fn bound(v: &Var, which: &str, b: &Option<toml::Value>) -> Option<(f64, String)> {
    let b = b.as_ref()?;
    Some(match (v.ty.as_str(), b) {
        ("Real", toml::Value::Float(f)) => (*f, real_text(*f)),
        ("Real", toml::Value::Integer(n)) => (*n as f64, real_text(*n as f64)),
        ("Integer", toml::Value::Integer(n)) => (*n as f64, n.to_string()),
        _ => fail(format!(
            "{}: {which} {b} does not fit type {} (only Real and Integer have bounds)",
            v.name, v.ty
        )),
    })
}

/// modelDescription.xml of the table: written with quick-xml (which escapes
/// the attribute values), two spaces of indentation.
fn model_description_xml(table: &Table, guid: &str) -> std::io::Result<String> {
    let m = &table.model;
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))?;
    w.create_element("fmiModelDescription")
        .with_attributes([
            ("fmiVersion", "2.0"),
            ("modelName", m.model_name.as_str()),
            ("guid", guid),
            ("description", m.description.as_str()),
            ("author", m.author.as_str()),
            ("version", env!("CARGO_PKG_VERSION")),
            ("license", m.license.as_str()),
            ("generationTool", "planetwear build.rs"),
            ("variableNamingConvention", "structured"),
            ("numberOfEventIndicators", "0"),
        ])
        .write_inner_content(|w| {
            w.create_element("CoSimulation")
                .with_attributes([
                    ("modelIdentifier", m.model_identifier.as_str()),
                    ("needsExecutionTool", "false"),
                    ("canHandleVariableCommunicationStepSize", "true"),
                    ("canInterpolateInputs", "false"),
                    ("maxOutputDerivativeOrder", "0"),
                    ("canRunAsynchronuously", "false"),
                    ("canBeInstantiatedOnlyOncePerProcess", "false"),
                    ("canNotUseMemoryManagementFunctions", "true"),
                    ("canGetAndSetFMUstate", "true"),
                    ("canSerializeFMUstate", "true"),
                    ("providesDirectionalDerivative", "false"),
                ])
                .write_empty()?;
            w.create_element("UnitDefinitions").write_inner_content(|w| {
                for (name, kg, mm, s, rad, displays) in &m.units {
                    w.create_element("Unit").with_attribute(("name", name.as_str())).write_inner_content(
                        |w| {
                            let base: Vec<(&str, String)> = [("kg", kg), ("m", mm), ("s", s), ("rad", rad)]
                                .into_iter()
                                .filter(|(_, e)| **e != 0)
                                .map(|(k, e)| (k, e.to_string()))
                                .collect();
                            if !base.is_empty() {
                                w.create_element("BaseUnit")
                                    .with_attributes(base.iter().map(|(k, e)| (*k, e.as_str())))
                                    .write_empty()?;
                            }
                            for (d, f) in displays {
                                w.create_element("DisplayUnit")
                                    .with_attributes([
                                        ("name", d.as_str()),
                                        ("factor", real_text(*f).as_str()),
                                    ])
                                    .write_empty()?;
                            }
                            Ok(())
                        },
                    )?;
                }
                Ok(())
            })?;
            w.create_element("LogCategories").write_inner_content(|w| {
                for (name, desc) in &m.log_categories {
                    w.create_element("Category")
                        .with_attributes([("name", name.as_str()), ("description", desc.as_str())])
                        .write_empty()?;
                }
                Ok(())
            })?;
            w.create_element("DefaultExperiment")
                .with_attributes([("startTime", "0.0"), ("stopTime", "0.05"), ("stepSize", "0.0001")])
                .write_empty()?;
            w.create_element("ModelVariables").write_inner_content(|w| {
                for v in &table.variable {
                    let vr = v.vr.to_string();
                    let mut attrs = vec![
                        ("name", v.name.as_str()),
                        ("valueReference", vr.as_str()),
                        ("description", v.description.as_str()),
                        ("causality", v.causality.as_str()),
                        ("variability", v.variability.as_str()),
                    ];
                    attrs.extend(v.initial.as_deref().map(|i| ("initial", i)));
                    let start = start_text(v);
                    let (min, max) = (bound(v, "min", &v.min), bound(v, "max", &v.max));
                    let mut typed = Vec::new();
                    typed.extend(v.unit.as_deref().map(|u| ("unit", u)));
                    typed.extend(v.display.as_deref().map(|d| ("displayUnit", d)));
                    typed.extend(min.as_ref().map(|(_, t)| ("min", t.as_str())));
                    typed.extend(max.as_ref().map(|(_, t)| ("max", t.as_str())));
                    typed.extend(start.as_deref().map(|s| ("start", s)));
                    w.create_element("ScalarVariable").with_attributes(attrs).write_inner_content(|w| {
                        w.create_element(v.ty.as_str()).with_attributes(typed).write_empty()?;
                        Ok(())
                    })?;
                }
                Ok(())
            })?;
            // Every output is an output and an initial unknown, by its
            // 1-based index in ModelVariables.
            let outputs: Vec<String> = (1..)
                .zip(&table.variable)
                .filter(|(_, v)| v.causality == "output")
                .map(|(i, _): (usize, _)| i.to_string())
                .collect();
            let unknowns = |w: &mut Writer<Vec<u8>>| -> std::io::Result<()> {
                for i in &outputs {
                    w.create_element("Unknown").with_attribute(("index", i.as_str())).write_empty()?;
                }
                Ok(())
            };
            w.create_element("ModelStructure").write_inner_content(|w| {
                w.create_element("Outputs").write_inner_content(unknowns)?;
                w.create_element("InitialUnknowns").write_inner_content(unknowns)?;
                Ok(())
            })?;
            Ok(())
        })?;
    let mut text = String::from_utf8(w.into_inner()).expect("the table is UTF-8");
    text.push('\n');
    Ok(text)
}

/// A description as one line of a doc comment: brackets escaped, so that
/// `planet[1]` in a description is text and not a link.
fn doc_text(description: &str) -> String {
    description.replace('\n', " ").replace('[', "\\[").replace(']', "\\]")
}

/// The CamelCase variant name of a variable: `planet[1].sunMeshForce` is
/// `Planet1SunMeshForce`.
fn variant_name(name: &str) -> String {
    const_name(name)
        .split('_')
        .map(|part| {
            let lower = part.to_ascii_lowercase();
            let mut c = lower.chars();
            c.next().map(|f| f.to_ascii_uppercase().to_string() + c.as_str()).unwrap_or_default()
        })
        .collect()
}

/// `enum Variable`: one variant per variable, with its value reference,
/// name and table row, and the variable of a (base type, value reference).
fn enum_source(table: &Table, r: &mut String) {
    let variants: Vec<String> = table.variable.iter().map(|v| variant_name(&v.name)).collect();
    let mut seen = BTreeMap::new();
    for (v, variant) in table.variable.iter().zip(&variants) {
        if let Some(other) = seen.insert(variant.as_str(), v.name.as_str()) {
            fail(format!("{} and {other} both make the enum variant {variant}", v.name));
        }
    }
    r.push_str(
        "/// Every variable of the FMU, one variant each, in modelDescription.xml order.\n\
         #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]\npub enum Variable {\n",
    );
    for (v, variant) in table.variable.iter().zip(&variants) {
        let _ = writeln!(r, "    /// `{}`: {}\n    {variant},", v.name, doc_text(&v.description));
    }
    r.push_str("}\n\nimpl Variable {\n    /// Every variable, in modelDescription.xml order.\n    pub const ALL: &'static [Variable] = &[\n");
    for variant in &variants {
        let _ = writeln!(r, "        Variable::{variant},");
    }
    r.push_str(
        "    ];\n\n    /// The variable of base type `kind` with value reference `vr`.\n    \
         pub fn from_value_reference(kind: Kind, vr: u32) -> Option<Variable> {\n        match (kind, vr) {\n",
    );
    for (v, variant) in table.variable.iter().zip(&variants) {
        let _ = writeln!(r, "            (Kind::{}, {}) => Some(Variable::{variant}),", v.ty, v.vr);
    }
    r.push_str(
        "            _ => None,\n        }\n    }\n\n    /// Its value reference (unique within its base type).\n    \
         pub fn value_reference(self) -> u32 {\n        match self {\n",
    );
    for (v, variant) in table.variable.iter().zip(&variants) {
        let _ = writeln!(r, "            Variable::{variant} => {},", v.vr);
    }
    r.push_str("        }\n    }\n\n    /// Its structured name.\n    pub fn name(self) -> &'static str {\n        match self {\n");
    for (v, variant) in table.variable.iter().zip(&variants) {
        let _ = writeln!(r, "            Variable::{variant} => {:?},", v.name);
    }
    r.push_str(
        "        }\n    }\n\n    /// Its row of [`VARIABLES`].\n    pub fn info(self) -> &'static VariableInfo {\n        \
         &VARIABLES[self as usize]\n    }\n}\n",
    );
    settable_source(table, r);
}

/// `enum Settable`: the variables an importer sets (parameters and
/// inputs), one variant each, so that the code that turns them into a
/// scene is a `match` the compiler checks for every one of them.
fn settable_source(table: &Table, r: &mut String) {
    let settable: Vec<(&Var, String)> = table
        .variable
        .iter()
        .filter(|v| v.causality == "parameter" || v.causality == "input")
        .map(|v| (v, variant_name(&v.name)))
        .collect();
    r.push_str(
        "\n/// Every variable the importer sets (parameters and inputs), one variant\n\
         /// each, in modelDescription.xml order.\n\
         #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]\npub enum Settable {\n",
    );
    for (v, variant) in &settable {
        let _ = writeln!(r, "    /// `{}` ({}).\n    {variant},", v.name, v.causality);
    }
    r.push_str("}\n\nimpl Settable {\n    /// Every settable variable, in modelDescription.xml order.\n    pub const ALL: &'static [Settable] = &[\n");
    for (_, variant) in &settable {
        let _ = writeln!(r, "        Settable::{variant},");
    }
    r.push_str(
        "    ];\n\n    /// The variable.\n    pub fn variable(self) -> Variable {\n        match self {\n",
    );
    for (_, variant) in &settable {
        let _ = writeln!(r, "            Settable::{variant} => Variable::{variant},");
    }
    r.push_str("        }\n    }\n}\n");
    reading_source(table, r);
    scene_source(table, r);
}

/// The Rust expression of an output's [`Read`]: `Reading::MeshForce { planet: 0, mesh: MeshKind::SunPlanet }`.
fn reading_expr(v: &Var, read: &Read) -> String {
    let member = |m: &str| match m {
        "sun" => "Member::Sun",
        "ring" => "Member::Ring",
        "carrier" => "Member::Carrier",
        other => fail(format!("{}: read.member {other} is not sun, ring or carrier", v.name)),
    };
    let mesh = |m: &str| match m {
        "sun" => "MeshKind::SunPlanet",
        "ring" => "MeshKind::RingPlanet",
        other => fail(format!("{}: read.mesh {other} is not sun or ring", v.name)),
    };
    let mut fields = Vec::new();
    if let Some(p) = read.planet {
        if !(1..=8).contains(&p) {
            fail(format!("{}: read.planet {p} is not 1 to 8", v.name));
        }
        fields.push(format!("planet: {}", p - 1));
    }
    fields.extend(read.member.as_deref().map(|m| format!("member: {}", member(m))));
    fields.extend(read.mesh.as_deref().map(|m| format!("mesh: {}", mesh(m))));
    if let Some(o) = read.order {
        if !(1..=6).contains(&o) {
            fail(format!("{}: read.order {o} is not 1 to 6 (the window's harmonics)", v.name));
        }
        fields.push(format!("order: {o}"));
    }
    let variant = variant_name(&read.quantity.replace('_', "."));
    if fields.is_empty() {
        format!("Reading::{variant}")
    } else {
        format!("Reading::{variant} {{ {} }}", fields.join(", "))
    }
}

/// `Variable::reading`: what each output reads, from its `read`.
fn reading_source(table: &Table, r: &mut String) {
    r.push_str(
        "\nimpl Variable {\n    /// What the variable reads from the simulation: an output's quantity and \
         where it is read; `None` for parameters and inputs.\n    pub fn reading(self) -> Option<Reading> {\n        \
         match self {\n",
    );
    for v in &table.variable {
        if let Some(read) = &v.read {
            let _ = writeln!(
                r,
                "            Variable::{} => Some({}),",
                variant_name(&v.name),
                reading_expr(v, read)
            );
        }
    }
    r.push_str("            _ => None,\n        }\n    }\n}\n");
}

/// The file units a scene key's suffix names, each with the Rust field that
/// holds the key: the key without the suffix, in the SI unit
/// (src/scene/units.rs converts as the file is read and written).
const FILE_UNITS: &[(&str, &str)] = &[("_mm", "m"), ("_deg", "rad"), ("_gpa", "Pa"), ("_rpm", "rad/s")];

/// The Rust field path of a real scene key (`sun.module_mm` is held, in m,
/// by `sun.module`), whose SI unit must be the variable's: a key in a file
/// unit by the field without the suffix, in that unit's SI unit; any other
/// key by the field of its name, in a unit of its own, never one of those.
fn real_field(v: &Var, key: &str) -> String {
    let unit = v.unit.as_deref().unwrap_or("1");
    match FILE_UNITS.iter().find(|(suffix, _)| key.ends_with(suffix)) {
        Some((suffix, si)) => {
            if unit != *si {
                fail(format!("{}: scene key {key} is held in {si}, the variable is in {unit}", v.name));
            }
            key.trim_end_matches(suffix).to_string()
        }
        None => {
            if FILE_UNITS.iter().any(|(_, si)| *si == unit) {
                fail(format!("{}: scene key {key} of a variable in {unit} names no file unit", v.name));
            }
            key.to_string()
        }
    }
}

/// `Settable::scene_keys` and `Settable::target`: the scene keys each
/// settable variable writes or answers for, the field accessors of those
/// written through a slot, and `enum Special` for the rest.
fn scene_source(table: &Table, r: &mut String) {
    let settable: Vec<&Var> =
        table.variable.iter().filter(|v| v.causality == "parameter" || v.causality == "input").collect();
    let mut accessors = String::new();
    let mut keys = String::new();
    let mut targets = String::new();
    let mut special = Vec::new();
    for v in &settable {
        let variant = variant_name(&v.name);
        let place = v.scene.as_ref();
        let all: Vec<&String> = place.map(|p| p.fields.iter().chain(&p.names).collect()).unwrap_or_default();
        let _ = writeln!(keys, "            Settable::{variant} => &{all:?},");
        let Some((slot, place)) = place.and_then(|p| p.slot.as_deref().map(|s| (s, p))) else {
            if place.is_some_and(|p| !p.fields.is_empty()) {
                fail(format!("{}: scene.fields needs a scene.slot", v.name));
            }
            special.push(variant.clone());
            let _ =
                writeln!(targets, "            Settable::{variant} => Target::Special(Special::{variant}),");
            continue;
        };
        if place.fields.is_empty() {
            fail(format!("{}: scene.slot {slot} needs scene.fields", v.name));
        }
        let (ty, kind) = match (slot, v.ty.as_str()) {
            ("real", "Real") => ("f64", "Real"),
            ("count", "Integer") => ("u32", "Count"),
            ("derived", "Real") => ("Option<f64>", "Derived"),
            _ => fail(format!("{}: scene.slot {slot} does not fit type {}", v.name, v.ty)),
        };
        let mut names = Vec::new();
        for (i, key) in place.fields.iter().enumerate() {
            let f = format!("{}_{i}", const_name(&v.name).to_ascii_lowercase());
            let field = if kind == "Real" { real_field(v, key) } else { key.clone() };
            let _ = writeln!(accessors, "fn {f}(s: &mut Scene) -> &mut {ty} {{\n    &mut s.{field}\n}}");
            names.push(f);
        }
        let list = names.join(", ");
        let target = match kind {
            "Real" => format!("SceneField::Real(&[{list}])"),
            "Count" => format!("SceneField::Count(&[{list}])"),
            _ if names.len() == 1 => format!("SceneField::Derived({list})"),
            _ => fail(format!("{}: a derived slot writes one field", v.name)),
        };
        let _ = writeln!(targets, "            Settable::{variant} => Target::Field({target}),");
    }
    r.push_str("\n// The scene fields the slots write.\n");
    r.push_str(&accessors);
    r.push_str(
        "\n/// The settable variables whose effect on the scene is written by hand \
         (not through a [`SceneField`]), one variant each.\n\
         #[derive(Clone, Copy, Debug, PartialEq, Eq)]\npub enum Special {\n",
    );
    for variant in &special {
        let _ = writeln!(r, "    /// [`Settable::{variant}`].\n    {variant},");
    }
    r.push_str(
        "}\n\nimpl From<Special> for Settable {\n    fn from(s: Special) -> Settable {\n        match s {\n",
    );
    for variant in &special {
        let _ = writeln!(r, "            Special::{variant} => Settable::{variant},");
    }
    r.push_str(
        "        }\n    }\n}\n\nimpl Settable {\n    /// The scene keys the variable writes, as `Scene::validate` names its \
         problems.\n    pub fn scene_keys(self) -> &'static [&'static str] {\n        match self {\n",
    );
    r.push_str(&keys);
    r.push_str(
        "        }\n    }\n\n    /// How the variable acts on the scene: through a field, or by hand.\n    \
         pub fn target(self) -> Target {\n        match self {\n",
    );
    r.push_str(&targets);
    r.push_str("        }\n    }\n}\n");
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let source = manifest.join("modelDescription/variables.toml");
    println!("cargo:rerun-if-changed={}", source.display());
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/fmi/guid.rs");
    println!("cargo:rerun-if-changed=src/files/hash.rs");
    let text = std::fs::read_to_string(&source).unwrap_or_else(|e| fail(format!("cannot read: {e}")));
    let table: Table = toml::from_str(&text).unwrap_or_else(|e| fail(format!("{e}")));

    // Checks.
    let units: BTreeSet<&str> = table.model.units.iter().map(|u| u.0.as_str()).collect();
    let mut names = BTreeSet::new();
    let mut refs: BTreeMap<(&str, u32), &str> = BTreeMap::new();
    for v in &table.variable {
        if !names.insert(v.name.as_str()) {
            fail(format!("variable name {} is used twice", v.name));
        }
        if let Some(other) = refs.insert((v.ty.as_str(), v.vr), &v.name) {
            fail(format!("value reference {} of type {} is used by {} and {}", v.vr, v.ty, other, v.name));
        }
        if !["Real", "Integer", "Boolean", "String"].contains(&v.ty.as_str()) {
            fail(format!("{}: type {} is not Real, Integer, Boolean or String", v.name, v.ty));
        }
        if let Some(u) = &v.unit {
            if !units.contains(u.as_str()) {
                fail(format!("{}: unit {u} is not in [model] units", v.name));
            }
            if v.ty != "Real" {
                fail(format!("{}: only Real variables carry a unit", v.name));
            }
        }
        if let (Some(d), Some(u)) = (&v.display, &v.unit) {
            let unit = table.model.units.iter().find(|x| &x.0 == u).expect("checked");
            if !unit.5.iter().any(|x| &x.0 == d) {
                fail(format!("{}: display unit {d} is not defined for {u}", v.name));
            }
        }
        match v.causality.as_str() {
            "parameter" => {
                if v.start.is_none() || v.initial.as_deref() != Some("exact") {
                    fail(format!("{}: a parameter needs a start value and initial = \"exact\"", v.name));
                }
                if !["fixed", "tunable"].contains(&v.variability.as_str()) {
                    fail(format!("{}: a parameter is fixed or tunable", v.name));
                }
            }
            "input" => {
                if v.start.is_none() || v.initial.is_some() {
                    fail(format!("{}: an input needs a start value and no initial", v.name));
                }
            }
            "output" => {
                if v.start.is_some() || v.initial.as_deref() != Some("calculated") {
                    fail(format!("{}: an output here is initial = \"calculated\" with no start", v.name));
                }
            }
            other => fail(format!("{}: causality {other} is not used by this FMU", v.name)),
        }
        if (v.causality == "output") != v.read.is_some() {
            fail(format!("{}: an output, and only an output, has a read", v.name));
        }
        if v.causality == "output" && v.scene.is_some() {
            fail(format!("{}: an output has no scene place", v.name));
        }
        if v.ty != "Real" && v.variability == "continuous" {
            fail(format!("{}: only Real variables may be continuous", v.name));
        }
        let (min, max) = (bound(v, "min", &v.min), bound(v, "max", &v.max));
        if (min.is_some() || max.is_some()) && v.causality == "output" {
            fail(format!("{}: only parameters and inputs carry min and max here", v.name));
        }
        let start = match &v.start {
            Some(toml::Value::Float(f)) => Some(*f),
            Some(toml::Value::Integer(n)) => Some(*n as f64),
            _ => None,
        };
        if let (Some((lo, _)), Some((hi, _))) = (&min, &max) {
            if lo > hi {
                fail(format!("{}: min {lo} is above max {hi}", v.name));
            }
        }
        if let Some(x) = start {
            if min.as_ref().is_some_and(|(lo, _)| x < *lo) || max.as_ref().is_some_and(|(hi, _)| x > *hi) {
                fail(format!("{}: start {x} lies outside [min, max]", v.name));
            }
        }
    }

    // GUID from the interface.
    let guid = guid::interface_guid(
        &table.model.model_name,
        &table.model.model_identifier,
        table.variable.iter().map(|v| {
            (
                v.name.as_str(),
                v.vr,
                v.ty.as_str(),
                v.causality.as_str(),
                v.variability.as_str(),
                v.unit.as_deref().unwrap_or(""),
            )
        }),
    );

    // modelDescription.xml
    let m = &table.model;
    let x = model_description_xml(&table, &guid).unwrap_or_else(|e| fail(format!("writing XML: {e}")));

    // The Rust table.
    let mut r = String::new();
    let _ = writeln!(r, "// Generated by build.rs from modelDescription/variables.toml. Do not edit.");
    let _ = writeln!(r, "/// GUID of this variable interface.\npub const GUID: &str = \"{guid}\";");
    let _ = writeln!(
        r,
        "/// The FMU's model identifier.\npub const MODEL_IDENTIFIER: &str = \"{}\";",
        m.model_identifier
    );
    let _ = writeln!(
        r,
        "/// Log categories (name, description).\npub const LOG_CATEGORIES: &[(&str, &str)] = &["
    );
    for (n, d) in &m.log_categories {
        let _ = writeln!(r, "    ({n:?}, {d:?}),");
    }
    r.push_str(
        "];\n/// Every variable, in modelDescription.xml order.\npub const VARIABLES: &[VariableInfo] = &[\n",
    );
    for v in &table.variable {
        let start = match (v.ty.as_str(), &v.start) {
            (_, None) => "Start::None".to_string(),
            ("Real", Some(toml::Value::Float(f))) => format!("Start::Real({f:?})"),
            ("Real", Some(toml::Value::Integer(n))) => format!("Start::Real({:?})", *n as f64),
            ("Integer", Some(toml::Value::Integer(n))) => format!("Start::Integer({n})"),
            ("Boolean", Some(toml::Value::Boolean(b))) => format!("Start::Boolean({b})"),
            ("String", Some(toml::Value::String(s))) => format!("Start::String({s:?})"),
            _ => fail(format!("{}: start value does not fit", v.name)),
        };
        let cap = |s: &str| {
            let mut c = s.chars();
            c.next().map(|f| f.to_ascii_uppercase().to_string() + c.as_str()).unwrap_or_default()
        };
        let opt = |b: Option<(f64, String)>| b.map_or("None".to_string(), |(x, _)| format!("Some({x:?})"));
        let (min, max) = (opt(bound(v, "min", &v.min)), opt(bound(v, "max", &v.max)));
        let _ = writeln!(
            r,
            "    VariableInfo {{ name: {:?}, vr: {}, kind: Kind::{}, causality: Causality::{}, variability: Variability::{}, unit: {:?}, start: {start}, min: {min}, max: {max}, description: {:?} }},",
            v.name,
            v.vr,
            v.ty,
            cap(&v.causality),
            cap(&v.variability),
            v.unit.as_deref().unwrap_or(""),
            v.description
        );
    }
    r.push_str("];\n/// Value references by name.\npub mod vr {\n");
    for v in &table.variable {
        let _ = writeln!(
            r,
            "    /// `{}`: {}\n    pub const {}: u32 = {};",
            v.name,
            doc_text(&v.description),
            const_name(&v.name),
            v.vr
        );
    }
    r.push_str("}\n");
    enum_source(&table, &mut r);

    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets it"));
    // The FMU's shared library exports the fmi2* functions and nothing else.
    let map = out.join("exports.map");
    std::fs::write(&map, "{\n  global: fmi2*;\n  local: *;\n};\n")
        .unwrap_or_else(|e| fail(format!("writing {}: {e}", map.display())));
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo:rustc-cdylib-link-arg=-Wl,--version-script={}", map.display());
        // fmi-sys links an importer-side C logger (callback_log) from a static
        // archive: keep every archive's symbols local. Zig's linker (the
        // portable FMU library, scripts/fmu.sh) has no --exclude-libs.
        let linker = std::env::var("RUSTC_LINKER").unwrap_or_default();
        if !linker.contains("zigcc") {
            println!("cargo:rustc-cdylib-link-arg=-Wl,--exclude-libs,ALL");
        }
    }
    std::fs::write(out.join("modelDescription.xml"), x).unwrap_or_else(|e| fail(format!("writing XML: {e}")));
    std::fs::write(out.join("fmi_variables.rs"), r).unwrap_or_else(|e| fail(format!("writing table: {e}")));
}
