//! modelDescription.xml read back with an XML parser (quick-xml) and checked
//! against modelDescription/variables.toml and against the FMI 2.0 rules
//! this FMU relies on. Every check is also shown to catch a corrupted
//! description.

use std::collections::{BTreeMap, BTreeSet};

use planetwear::fmi::variables::{GUID, MODEL_DESCRIPTION_XML};
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

const VARIABLES_TOML: &str =
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/modelDescription/variables.toml"));

/// One ScalarVariable as written.
#[derive(Debug, Default)]
struct XmlVariable {
    /// 1-based index in ModelVariables.
    index: usize,
    /// Attributes of ScalarVariable.
    attrs: BTreeMap<String, String>,
    /// The type element (Real, Integer, Boolean, String, Enumeration).
    ty: String,
    /// Attributes of the type element.
    type_attrs: BTreeMap<String, String>,
}

impl XmlVariable {
    fn name(&self) -> &str {
        self.attrs.get("name").map_or("(unnamed)", String::as_str)
    }

    fn attr(&self, key: &str) -> Option<&str> {
        self.attrs.get(key).map(String::as_str)
    }

    fn type_attr(&self, key: &str) -> Option<&str> {
        self.type_attrs.get(key).map(String::as_str)
    }
}

/// What the checks need of modelDescription.xml.
#[derive(Debug, Default)]
struct Description {
    root: BTreeMap<String, String>,
    /// Declared units and their display units.
    units: BTreeMap<String, BTreeSet<String>>,
    variables: Vec<XmlVariable>,
    outputs: Vec<usize>,
    initial_unknowns: Vec<usize>,
}

fn attributes(e: &BytesStart) -> Result<BTreeMap<String, String>, String> {
    let mut out = BTreeMap::new();
    for a in e.attributes() {
        let a = a.map_err(|e| format!("attribute: {e}"))?;
        let key = String::from_utf8(a.key.as_ref().to_vec()).map_err(|e| e.to_string())?;
        let value = a.unescape_value().map_err(|e| format!("attribute {key}: {e}"))?;
        if out.insert(key.clone(), value.into_owned()).is_some() {
            return Err(format!("attribute {key} twice"));
        }
    }
    Ok(out)
}

fn parse(xml: &str) -> Result<Description, String> {
    let mut reader = Reader::from_str(xml);
    reader.config_mut().trim_text(true);
    let mut d = Description::default();
    // Open elements, outermost first.
    let mut path: Vec<String> = Vec::new();
    let mut unit: Option<String> = None;
    let mut variable: Option<XmlVariable> = None;
    loop {
        let event = reader.read_event().map_err(|e| format!("at {}: {e}", reader.buffer_position()))?;
        let (e, empty) = match &event {
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(e) => {
                let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
                if path.pop().as_deref() != Some(name.as_str()) {
                    return Err(format!("</{name}> closes no open element"));
                }
                match name.as_str() {
                    "ScalarVariable" => d.variables.extend(variable.take()),
                    "Unit" => unit = None,
                    _ => {}
                }
                continue;
            }
            Event::Eof => break,
            _ => continue,
        };
        let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
        let attrs = attributes(e)?;
        let parent = path.last().map(String::as_str);
        match (parent, name.as_str()) {
            (None, "fmiModelDescription") => d.root = attrs,
            (Some("UnitDefinitions"), "Unit") => {
                let n = attrs.get("name").cloned().ok_or("a Unit without a name")?;
                d.units.insert(n.clone(), BTreeSet::new());
                unit = Some(n);
            }
            (Some("Unit"), "DisplayUnit") => {
                let n = attrs.get("name").cloned().ok_or("a DisplayUnit without a name")?;
                if let Some(u) = d.units.get_mut(unit.as_deref().unwrap_or_default()) {
                    u.insert(n);
                }
            }
            (Some("ModelVariables"), "ScalarVariable") => {
                variable = Some(XmlVariable { index: d.variables.len() + 1, attrs, ..XmlVariable::default() })
            }
            (Some("ScalarVariable"), ty) => {
                let v = variable.as_mut().ok_or("a type element outside a ScalarVariable")?;
                if !v.ty.is_empty() {
                    return Err(format!("{}: two type elements", v.name()));
                }
                v.ty = ty.to_string();
                v.type_attrs = attrs;
            }
            (Some("Outputs" | "InitialUnknowns"), "Unknown") => {
                let i =
                    attrs.get("index").and_then(|i| i.parse().ok()).ok_or("an Unknown without an index")?;
                if parent == Some("Outputs") {
                    d.outputs.push(i);
                } else {
                    d.initial_unknowns.push(i);
                }
            }
            _ => {}
        }
        if empty {
            if name == "ScalarVariable" {
                d.variables.extend(variable.take());
            }
        } else {
            path.push(name);
        }
    }
    if !path.is_empty() {
        return Err(format!("unclosed elements: {path:?}"));
    }
    Ok(d)
}

/// A row of variables.toml.
struct Row<'a> {
    name: &'a str,
    vr: i64,
    ty: &'a str,
    causality: &'a str,
    variability: &'a str,
    initial: Option<&'a str>,
    unit: Option<&'a str>,
    display: Option<&'a str>,
    start: Option<&'a toml::Value>,
    min: Option<&'a toml::Value>,
    max: Option<&'a toml::Value>,
    description: &'a str,
}

fn s<'a>(v: &'a toml::Table, key: &str) -> Option<&'a str> {
    v.get(key).and_then(toml::Value::as_str)
}

fn rows(table: &toml::Table) -> Vec<Row<'_>> {
    table["variable"]
        .as_array()
        .expect("variables.toml has [[variable]] rows")
        .iter()
        .map(|v| {
            let v = v.as_table().expect("a [[variable]] row is a table");
            Row {
                name: s(v, "name").expect("a variable has a name"),
                vr: v["vr"].as_integer().expect("a variable has an integer vr"),
                ty: s(v, "type").expect("a variable has a type"),
                causality: s(v, "causality").expect("a variable has a causality"),
                variability: s(v, "variability").expect("a variable has a variability"),
                initial: s(v, "initial"),
                unit: s(v, "unit"),
                display: s(v, "display"),
                start: v.get("start"),
                min: v.get("min"),
                max: v.get("max"),
                description: s(v, "description").unwrap_or_default(),
            }
        })
        .collect()
}

/// Whether the start attribute `xml` says what the table's start value does.
fn same_start(ty: &str, table: Option<&toml::Value>, xml: Option<&str>) -> bool {
    match (table, xml) {
        (None, None) => true,
        (Some(t), Some(x)) => match (ty, t) {
            ("Real", toml::Value::Float(f)) => x.parse::<f64>() == Ok(*f),
            ("Real", toml::Value::Integer(n)) => x.parse::<f64>() == Ok(*n as f64),
            ("Integer", toml::Value::Integer(n)) => x.parse::<i64>() == Ok(*n),
            ("Boolean", toml::Value::Boolean(b)) => x == if *b { "true" } else { "false" },
            ("String", toml::Value::String(s)) => x == s,
            _ => false,
        },
        _ => false,
    }
}

/// Differences between modelDescription.xml and variables.toml, each naming
/// the variable.
fn against_table(d: &Description, toml_text: &str) -> Vec<String> {
    let table: toml::Table = toml_text.parse().expect("variables.toml parses");
    let rows = rows(&table);
    let mut problems = Vec::new();
    let by_name: BTreeMap<&str, &XmlVariable> = d.variables.iter().map(|v| (v.name(), v)).collect();
    let table_names: BTreeSet<&str> = rows.iter().map(|r| r.name).collect();
    for v in &d.variables {
        if !table_names.contains(v.name()) {
            problems.push(format!("{}: in modelDescription.xml but not in variables.toml", v.name()));
        }
    }
    for (i, r) in rows.iter().enumerate() {
        let Some(v) = by_name.get(r.name) else {
            problems.push(format!("{}: in variables.toml but not in modelDescription.xml", r.name));
            continue;
        };
        let n = r.name;
        if v.index != i + 1 {
            problems.push(format!(
                "{n}: variable {} in modelDescription.xml, {} in variables.toml",
                v.index,
                i + 1
            ));
        }
        let vr = r.vr.to_string();
        let expected = [
            ("valueReference", Some(vr.as_str()), v.attr("valueReference")),
            ("type", Some(r.ty), Some(v.ty.as_str())),
            ("causality", Some(r.causality), v.attr("causality")),
            ("variability", Some(r.variability), v.attr("variability")),
            ("initial", r.initial, v.attr("initial")),
            ("unit", r.unit, v.type_attr("unit")),
            ("displayUnit", r.display, v.type_attr("displayUnit")),
            ("description", Some(r.description), v.attr("description")),
        ];
        for (what, table, xml) in expected {
            if table != xml {
                problems.push(format!(
                    "{n}: {what} is {xml:?} in modelDescription.xml, {table:?} in variables.toml"
                ));
            }
        }
        for (what, bound) in [("min", r.min), ("max", r.max)] {
            if !same_start(r.ty, bound, v.type_attr(what)) {
                problems.push(format!(
                    "{n}: {what} is {:?} in modelDescription.xml, {:?} in variables.toml",
                    v.type_attr(what),
                    bound.map(ToString::to_string)
                ));
            }
        }
        if !same_start(r.ty, r.start, v.type_attr("start")) {
            problems.push(format!(
                "{n}: start is {:?} in modelDescription.xml, {:?} in variables.toml",
                v.type_attr("start"),
                r.start.map(ToString::to_string)
            ));
        }
    }
    problems
}

/// Violations of the FMI 2.0 rules, each naming the variable.
fn fmi_rules(d: &Description) -> Vec<String> {
    let mut problems = Vec::new();
    if d.root.get("fmiVersion").map(String::as_str) != Some("2.0") {
        problems.push("fmiModelDescription: fmiVersion is not 2.0".to_string());
    }
    if d.root.get("guid").map(String::as_str) != Some(GUID) {
        problems.push(format!("fmiModelDescription: guid is not {GUID}"));
    }
    let mut names = BTreeSet::new();
    let mut refs: BTreeMap<(&str, &str), &str> = BTreeMap::new();
    for v in &d.variables {
        let n = v.name();
        if !names.insert(n) {
            problems.push(format!("{n}: the name is used twice"));
        }
        let vr = v.attr("valueReference").unwrap_or_default();
        if vr.parse::<u32>().is_err() {
            problems.push(format!("{n}: valueReference {vr:?} is not an unsigned integer"));
        }
        if let Some(other) = refs.insert((v.ty.as_str(), vr), n) {
            problems.push(format!("{n}: valueReference {vr} of type {} is also {other}'s", v.ty));
        }
        if !["Real", "Integer", "Boolean", "String", "Enumeration"].contains(&v.ty.as_str()) {
            problems.push(format!("{n}: type element {:?} is not an FMI 2.0 type", v.ty));
        }
        // FMI 2.0, section 2.2.7: the allowed combinations of causality and
        // variability, and for each the allowed values of initial and its
        // default.
        let causality = v.attr("causality").unwrap_or("local");
        let variability = v.attr("variability").unwrap_or("continuous");
        let (allowed, default): (&[&str], Option<&str>) = match (causality, variability) {
            ("parameter", "fixed" | "tunable") => (&["exact"], Some("exact")),
            ("calculatedParameter", "fixed" | "tunable") => (&["calculated", "approx"], Some("calculated")),
            ("input", "discrete" | "continuous") => (&[], None),
            ("output" | "local", "constant") => (&["exact"], Some("exact")),
            ("output" | "local", "discrete" | "continuous") => {
                (&["calculated", "exact", "approx"], Some("calculated"))
            }
            ("local", "fixed" | "tunable") => (&["calculated", "approx"], Some("calculated")),
            ("independent", "continuous") => (&[], None),
            (c, va) => {
                problems.push(format!("{n}: causality {c} with variability {va} is not allowed"));
                continue;
            }
        };
        let initial = match v.attr("initial") {
            Some(i) if allowed.is_empty() => {
                problems.push(format!("{n}: {causality} must not have initial (it has {i})"));
                None
            }
            Some(i) if !allowed.contains(&i) => {
                problems.push(format!(
                    "{n}: initial {i} is not allowed for a {variability} {causality}: allowed are {allowed:?}"
                ));
                Some(i)
            }
            Some(i) => Some(i),
            None => default,
        };
        let start = v.type_attr("start");
        let needs_start = matches!(initial, Some("exact" | "approx")) || causality == "input";
        if needs_start && start.is_none() {
            problems.push(format!("{n}: {causality} with initial {initial:?}: needs a start value"));
        }
        if !needs_start && start.is_some() {
            problems.push(format!("{n}: {causality} with initial {initial:?}: must not have a start value"));
        }
        if variability == "continuous" && v.ty != "Real" {
            problems.push(format!("{n}: only Real variables may be continuous, this is {}", v.ty));
        }
        if let Some(u) = v.type_attr("unit") {
            match d.units.get(u) {
                None => problems.push(format!("{n}: unit {u} is not declared in UnitDefinitions")),
                Some(displays) => {
                    if let Some(du) = v.type_attr("displayUnit") {
                        if !displays.contains(du) {
                            problems.push(format!("{n}: display unit {du} is not declared for unit {u}"));
                        }
                    }
                }
            }
        }
        // min <= start <= max (FMI 2.0: the bounds are inclusive), on Real
        // and Integer only.
        let number = |what: &str| v.type_attr(what).map(|x| x.parse::<f64>().map_err(|_| x.to_string()));
        for what in ["min", "max"] {
            if v.type_attr(what).is_some() && !["Real", "Integer"].contains(&v.ty.as_str()) {
                problems.push(format!("{n}: {what} on a {} variable", v.ty));
            }
        }
        match (number("min"), number("start"), number("max")) {
            (Some(Err(x)), _, _) | (_, _, Some(Err(x))) => {
                problems.push(format!("{n}: bound {x:?} is not a number"))
            }
            (lo, start, hi) => {
                let (lo, hi) = (lo.and_then(Result::ok), hi.and_then(Result::ok));
                if let (Some(a), Some(b)) = (lo, hi) {
                    if a > b {
                        problems.push(format!("{n}: min {a} is above max {b}"));
                    }
                }
                if let Some(Ok(x)) = start {
                    if lo.is_some_and(|a| x < a) || hi.is_some_and(|b| x > b) {
                        problems.push(format!("{n}: start {x} lies outside min {lo:?}, max {hi:?}"));
                    }
                }
            }
        }
        if v.type_attr("displayUnit").is_some() && v.type_attr("unit").is_none() {
            problems.push(format!("{n}: a display unit without a unit"));
        }
    }
    // ModelStructure/Outputs: exactly the outputs, by 1-based index, in
    // ModelVariables order.
    let name_at = |i: usize| d.variables.get(i.wrapping_sub(1)).map_or("no variable", XmlVariable::name);
    let outputs: Vec<usize> =
        d.variables.iter().filter(|v| v.attr("causality") == Some("output")).map(|v| v.index).collect();
    for v in d.variables.iter().filter(|v| outputs.contains(&v.index)) {
        if !d.outputs.contains(&v.index) {
            problems.push(format!(
                "{}: an output (index {}) missing from ModelStructure/Outputs",
                v.name(),
                v.index
            ));
        }
    }
    for &i in &d.outputs {
        if !outputs.contains(&i) {
            problems.push(format!("ModelStructure/Outputs lists index {i} ({}), not an output", name_at(i)));
        }
    }
    if d.outputs != outputs && problems.iter().all(|p| !p.contains("ModelStructure/Outputs")) {
        problems.push(format!(
            "ModelStructure/Outputs {:?} is not the outputs in ModelVariables order",
            d.outputs
        ));
    }
    // InitialUnknowns: the outputs whose initial is calculated or approx.
    let initial_unknowns: Vec<usize> = d
        .variables
        .iter()
        .filter(|v| {
            (v.attr("causality") == Some("output") && v.attr("initial") != Some("exact"))
                || v.attr("causality") == Some("calculatedParameter")
        })
        .map(|v| v.index)
        .collect();
    if d.initial_unknowns != initial_unknowns {
        let missing: Vec<&str> = initial_unknowns
            .iter()
            .filter(|i| !d.initial_unknowns.contains(i))
            .map(|&i| name_at(i))
            .collect();
        let extra: Vec<&str> = d
            .initial_unknowns
            .iter()
            .filter(|i| !initial_unknowns.contains(i))
            .map(|&i| name_at(i))
            .collect();
        problems.push(format!(
            "ModelStructure/InitialUnknowns: missing {missing:?}, not initial unknowns {extra:?} (or out of order)"
        ));
    }
    problems
}

fn all_problems(xml: &str) -> Vec<String> {
    match parse(xml) {
        Ok(d) => {
            let mut p = against_table(&d, VARIABLES_TOML);
            p.extend(fmi_rules(&d));
            p
        }
        Err(e) => vec![format!("modelDescription.xml does not parse: {e}")],
    }
}

#[test]
fn the_generated_xml_says_what_variables_toml_says() {
    let d = parse(MODEL_DESCRIPTION_XML).expect("modelDescription.xml parses");
    let table: toml::Table = VARIABLES_TOML.parse().unwrap();
    assert_eq!(d.variables.len(), table["variable"].as_array().unwrap().len());
    let problems = against_table(&d, VARIABLES_TOML);
    assert!(
        problems.is_empty(),
        "modelDescription.xml differs from variables.toml:\n{}",
        problems.join("\n")
    );
}

#[test]
fn the_generated_xml_keeps_the_fmi_rules() {
    let d = parse(MODEL_DESCRIPTION_XML).expect("modelDescription.xml parses");
    let problems = fmi_rules(&d);
    assert!(problems.is_empty(), "modelDescription.xml breaks FMI 2.0 rules:\n{}", problems.join("\n"));
}

/// The description with, in the ScalarVariable of `variable`, `from`
/// replaced by `to` once.
fn corrupt(variable: &str, from: &str, to: &str) -> String {
    let at = MODEL_DESCRIPTION_XML
        .find(&format!("<ScalarVariable name=\"{variable}\""))
        .unwrap_or_else(|| panic!("{variable} is in modelDescription.xml"));
    let len = MODEL_DESCRIPTION_XML[at..].find("</ScalarVariable>").unwrap();
    let block = &MODEL_DESCRIPTION_XML[at..at + len];
    assert!(block.contains(from), "{variable}'s ScalarVariable contains {from}");
    format!(
        "{}{}{}",
        &MODEL_DESCRIPTION_XML[..at],
        block.replacen(from, to, 1),
        &MODEL_DESCRIPTION_XML[at + len..]
    )
}

#[test]
fn every_check_catches_a_corrupted_description() {
    let removed = {
        let at = MODEL_DESCRIPTION_XML.find("<ScalarVariable name=\"window.cycles\"").unwrap();
        let end =
            at + MODEL_DESCRIPTION_XML[at..].find("</ScalarVariable>").unwrap() + "</ScalarVariable>".len();
        format!("{}{}", &MODEL_DESCRIPTION_XML[..at], &MODEL_DESCRIPTION_XML[end..])
    };
    let first_output = MODEL_DESCRIPTION_XML.find("<Unknown index=").unwrap();
    let mut cases: Vec<(&str, String, &[&str])> = vec![
        (
            "a renamed variable",
            corrupt("fidelity", r#"name="fidelity""#, r#"name="fidelityLevel""#),
            &[
                "fidelityLevel: in modelDescription.xml but not in variables.toml",
                "fidelity: in variables.toml but not",
            ],
        ),
        (
            "a missing variable",
            removed,
            &["window.cycles: in variables.toml but not in modelDescription.xml"],
        ),
        (
            "another valueReference",
            corrupt("fidelity", r#"valueReference="3""#, r#"valueReference="13""#),
            &["fidelity: valueReference"],
        ),
        ("another type", corrupt("fidelity", "<Integer", "<Real"), &["fidelity: type"]),
        (
            "another causality",
            corrupt("sunTorque", r#"causality="input""#, r#"causality="output""#),
            &["sunTorque: causality"],
        ),
        (
            "another variability",
            corrupt("ring.speed", r#"variability="continuous""#, r#"variability="discrete""#),
            &["ring.speed: variability"],
        ),
        ("another unit", corrupt("ring.speed", r#"unit="rad/s""#, r#"unit="rad""#), &["ring.speed: unit"]),
        ("another start", corrupt("fidelity", r#"start="1""#, r#"start="0""#), &["fidelity: start"]),
        ("another max", corrupt("fidelity", r#"max="3""#, r#"max="4""#), &["fidelity: max"]),
        ("a min dropped", corrupt("planets", r#" min="1""#, ""), &["planets: min"]),
        (
            "a start past its max",
            corrupt("planets", r#"start="4""#, r#"start="9""#),
            &["planets: start 9 lies outside min Some(1.0), max Some(8.0)"],
        ),
        (
            "a name used twice",
            corrupt("ring.speed", r#"name="ring.speed""#, r#"name="sun.speed""#),
            &["sun.speed: the name is used twice"],
        ),
        (
            "a valueReference used twice",
            corrupt("ring.speed", r#"valueReference="201""#, r#"valueReference="200""#),
            &["ring.speed: valueReference 200 of type Real is also sun.speed's"],
        ),
        (
            "a continuous parameter",
            corrupt("rhoInfinity", r#"variability="fixed""#, r#"variability="continuous""#),
            &["rhoInfinity: causality parameter with variability continuous is not allowed"],
        ),
        (
            "a calculated parameter",
            corrupt("rhoInfinity", r#"initial="exact""#, r#"initial="calculated""#),
            &["rhoInfinity: initial calculated is not allowed"],
        ),
        (
            "a fixed output",
            corrupt("sun.speed", r#"variability="continuous""#, r#"variability="fixed""#),
            &["sun.speed: causality output with variability fixed is not allowed"],
        ),
        (
            "an output with a start",
            corrupt("sun.speed", r#"<Real unit="rad/s""#, r#"<Real start="1.0" unit="rad/s""#),
            &["sun.speed: output with initial Some(\"calculated\"): must not have a start value"],
        ),
        (
            "an input with initial",
            corrupt(
                "sunTorque",
                r#"variability="continuous""#,
                r#"variability="continuous" initial="exact""#,
            ),
            &["sunTorque: input must not have initial"],
        ),
        (
            "an input without start",
            corrupt("sunTorque", r#" start="750.0""#, ""),
            &["sunTorque: input with initial None: needs a start value"],
        ),
        (
            "a parameter without start",
            corrupt("fidelity", r#" start="1""#, ""),
            &["fidelity: parameter with initial Some(\"exact\"): needs a start value"],
        ),
        (
            "a continuous Integer",
            corrupt("window.cycles", r#"variability="discrete""#, r#"variability="continuous""#),
            &["window.cycles: only Real variables may be continuous"],
        ),
        (
            "an undeclared unit",
            MODEL_DESCRIPTION_XML.replacen(r#"<Unit name="N.m">"#, r#"<Unit name="Nm">"#, 1),
            &["sunTorque: unit N.m is not declared in UnitDefinitions"],
        ),
        (
            "an undeclared display unit",
            corrupt("sun.speed", r#"displayUnit="rpm""#, r#"displayUnit="deg""#),
            &["sun.speed: display unit deg is not declared for unit rad/s"],
        ),
        (
            "an output left out of ModelStructure",
            {
                let (a, b) = MODEL_DESCRIPTION_XML.split_at(first_output);
                format!("{a}{}", b.replacen(r#"<Unknown index="60"/>"#, "", 1))
            },
            &["sun.speed: an output (index 60) missing from ModelStructure/Outputs"],
        ),
        (
            "a parameter in ModelStructure",
            {
                let (a, b) = MODEL_DESCRIPTION_XML.split_at(first_output);
                format!("{a}{}", b.replacen(r#"<Unknown index="60"/>"#, r#"<Unknown index="3"/>"#, 1))
            },
            &["ModelStructure/Outputs lists index 3 (fidelity), not an output"],
        ),
        (
            "outputs out of order",
            {
                let (a, b) = MODEL_DESCRIPTION_XML.split_at(first_output);
                format!(
                    "{a}{}",
                    b.replacen(r#"<Unknown index="60"/>"#, "", 1).replacen(
                        r#"<Unknown index="61"/>"#,
                        r#"<Unknown index="61"/><Unknown index="60"/>"#,
                        1
                    )
                )
            },
            &["ModelStructure/Outputs [61, 60"],
        ),
    ];
    let initial_unknowns = MODEL_DESCRIPTION_XML.find("<InitialUnknowns>").unwrap();
    let (head, tail) = MODEL_DESCRIPTION_XML.split_at(initial_unknowns);
    cases.push((
        "an output left out of InitialUnknowns",
        format!("{head}{}", tail.replacen(r#"<Unknown index="60"/>"#, "", 1)),
        &["ModelStructure/InitialUnknowns: missing [\"sun.speed\"]"],
    ));
    for (what, xml, expected) in cases {
        assert_ne!(xml, MODEL_DESCRIPTION_XML, "{what}: the corruption changes nothing");
        let problems = all_problems(&xml);
        for e in expected {
            assert!(
                problems.iter().any(|p| p.contains(e)),
                "{what}: expected a problem containing {e:?}, got:\n{}",
                problems.join("\n")
            );
        }
    }
}
