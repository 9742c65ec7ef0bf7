//! The example's figures are unchanged by a change of structure.
//!
//! The figures of the built-in example — the loaded tooth contact analysis,
//! the natural frequencies and mode shapes, a speed sweep at three speeds,
//! the wear run to κ = 2 (summary and the κ = 2 state) and the FMU's outputs
//! after 200 communication steps — were recorded in `tests/behaviour/` before
//! the source tree was reorganized into pipeline stages. This test computes
//! them again through the public interfaces (the command-line tool and the
//! exported FMI functions, which a reorganization does not change) and
//! compares every number: each must agree to 1e-12 relative to the largest
//! magnitude of its quantity (the same key across an array), integers and
//! strings exactly. Run times and the paths of the files written are not
//! compared.
//!
//! A change that is meant to move a figure records the files again with
//! `PLANETWEAR_RECORD_BEHAVIOUR=1 cargo test --release --test behaviour_unchanged`
//! and says so in its commit message.

use std::collections::BTreeMap;
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::process::Command;

use fmi_sys::fmi2::*;
use planetwear::fmi::export::*;
use serde_json::Value;

const REL: f64 = 1e-12;
/// Keys that hold run times, rates or the paths of files written, not figures.
const TIMING_KEYS: &[&str] = &["steps_per_second", "wall_time_s", "seconds", "files"];

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_planetwear")
}

fn run(args: &[&str]) -> String {
    let out = Command::new(bin()).args(args).output().expect("run planetwear");
    assert!(out.status.success(), "planetwear {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("UTF-8 output")
}

fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/behaviour")
}

/// Every leaf of a JSON document by its path, with array indices replaced by
/// `[]` in the quantity key used for the scale.
fn leaves(v: &Value, path: String, out: &mut Vec<(String, String, Value)>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                if TIMING_KEYS.contains(&k.as_str()) {
                    continue;
                }
                leaves(x, format!("{path}.{k}"), out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                leaves(x, format!("{path}[{i}]"), out);
            }
        }
        leaf => {
            let quantity = strip_indices(&path);
            out.push((path, quantity, leaf.clone()));
        }
    }
}

fn strip_indices(path: &str) -> String {
    let mut q = String::new();
    let mut in_index = false;
    for c in path.chars() {
        match c {
            '[' => {
                in_index = true;
                q.push_str("[]");
            }
            ']' => in_index = false,
            _ if in_index => {}
            _ => q.push(c),
        }
    }
    q
}

/// Compares two documents; returns the differences found (at most 20 shown).
fn compare(name: &str, reference: &Value, now: &Value) -> Vec<String> {
    let mut a = Vec::new();
    let mut b = Vec::new();
    leaves(reference, String::new(), &mut a);
    leaves(now, String::new(), &mut b);
    let mut problems = Vec::new();
    if a.len() != b.len() {
        problems.push(format!("{name}: {} figures recorded, {} now", a.len(), b.len()));
        return problems;
    }
    let mut scale: BTreeMap<&str, f64> = BTreeMap::new();
    for (_, q, v) in &a {
        if let Some(x) = v.as_f64() {
            let s = scale.entry(q.as_str()).or_insert(0.0);
            *s = s.max(x.abs());
        }
    }
    for ((pa, q, va), (pb, _, vb)) in a.iter().zip(&b) {
        if pa != pb {
            problems.push(format!("{name}: figure {pa} recorded, {pb} now"));
            continue;
        }
        let same = match (va, vb) {
            (Value::Number(x), Value::Number(y)) if x.is_f64() || y.is_f64() => {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                (x - y).abs() <= REL * scale[q.as_str()].max(f64::MIN_POSITIVE)
            }
            _ => va == vb,
        };
        if !same {
            problems.push(format!("{name}: {pa} recorded {va}, now {vb}"));
        }
    }
    problems
}

/// Compares with the recorded file, or records it when asked to.
fn check(name: &str, now: Value) {
    let path = reference_dir().join(format!("{name}.json"));
    if std::env::var_os("PLANETWEAR_RECORD_BEHAVIOUR").is_some() {
        std::fs::create_dir_all(reference_dir()).unwrap();
        std::fs::write(&path, serde_json::to_string_pretty(&now).unwrap() + "\n").unwrap();
        return;
    }
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reference: Value = serde_json::from_str(&text).unwrap();
    let problems = compare(name, &reference, &now);
    assert!(
        problems.is_empty(),
        "{} figures moved:\n{}",
        problems.len(),
        problems.iter().take(20).cloned().collect::<Vec<_>>().join("\n")
    );
}

fn csv_to_json(text: &str) -> Value {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("CSV header").split(',').collect();
    let rows: Vec<Value> = lines
        .map(|l| {
            let mut row = serde_json::Map::new();
            for (k, cell) in header.iter().zip(l.split(',')) {
                let v = cell
                    .parse::<f64>()
                    .ok()
                    .and_then(|x| serde_json::Number::from_f64(x).map(Value::Number))
                    .unwrap_or_else(|| Value::String(cell.to_string()));
                row.insert(k.to_string(), v);
            }
            Value::Object(row)
        })
        .collect();
    Value::Array(rows)
}

#[test]
fn loaded_tooth_contact_analysis_is_unchanged() {
    let out = run(&["ltca", "--scene", "example-2004", "--json"]);
    check("ltca", serde_json::from_str(&out).unwrap());
}

#[test]
fn natural_frequencies_and_mode_shapes_are_unchanged() {
    let out = run(&["modes", "--scene", "example-2004", "--json"]);
    check("modes", serde_json::from_str(&out).unwrap());
}

#[test]
fn sweep_at_three_speeds_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let args = ["sweep", "--scene", "example-2004", "--from", "2000", "--to", "9000", "--step", "3500"];
    run(&[&args[..], &["--direction", "up", "--out", d]].concat());
    let csv = std::fs::read_to_string(dir.path().join("sweep_up.csv")).unwrap();
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("sweep.json")).unwrap()).unwrap();
    check("sweep", serde_json::json!({ "csv": csv_to_json(&csv), "summary": summary }));
}

#[test]
fn wear_run_to_kappa_2_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    run(&["wear", "run", "--scene", "example-2004", "--to-kappa", "2", "--out", d]);
    let read = |f: &str| -> Value {
        serde_json::from_str(&std::fs::read_to_string(dir.path().join(f)).unwrap()).unwrap()
    };
    check("wear", serde_json::json!({ "summary": read("summary.json"), "kappa_2": read("kappa-2.json") }));
}

/// Value references of the real outputs, read from the generated
/// modelDescription.xml (the tool prints it).
fn real_outputs() -> Vec<(String, u32)> {
    let xml = run(&["fmu", "xml"]);
    let mut out = Vec::new();
    for chunk in xml.split("<ScalarVariable").skip(1) {
        let head = &chunk[..chunk.find('>').unwrap()];
        let attr = |a: &str| -> Option<String> {
            let i = head.find(&format!(" {a}=\""))? + a.len() + 3;
            Some(head[i..i + head[i..].find('"')?].to_string())
        };
        let body = &chunk[..chunk.find("</ScalarVariable>").unwrap_or(chunk.len())];
        if attr("causality").as_deref() == Some("output") && body.contains("<Real") {
            out.push((attr("name").unwrap(), attr("valueReference").unwrap().parse().unwrap()));
        }
    }
    assert!(out.len() > 10, "real outputs found: {}", out.len());
    out
}

fn guid() -> String {
    let xml = run(&["fmu", "xml"]);
    let i = xml.find("guid=\"").unwrap() + 6;
    xml[i..i + xml[i..].find('"').unwrap()].to_string()
}

#[test]
fn fmu_outputs_after_200_steps_are_unchanged() {
    // The outputs recorded (all of them when recording): an output added
    // since is not in the recording, and the recorded ones must not move.
    let mut outputs = real_outputs();
    if std::env::var_os("PLANETWEAR_RECORD_BEHAVIOUR").is_none() {
        let text = std::fs::read_to_string(reference_dir().join("fmu.json")).unwrap();
        let recorded: Value = serde_json::from_str(&text).unwrap();
        let names = recorded["step_50"].as_object().unwrap();
        outputs.retain(|(n, _)| names.contains_key(n));
        assert_eq!(outputs.len(), names.len(), "a recorded output is no longer an output");
    }
    let guid = CString::new(guid()).unwrap();
    let h = 1e-4;
    // SAFETY: the strings are NUL-terminated and outlive the call; the
    // callbacks are null (allowed for this FMU, which logs nowhere then).
    let c = unsafe {
        fmi2Instantiate(
            c"behaviour".as_ptr(),
            fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            c"file:///tmp/resources/".as_ptr(),
            std::ptr::null(),
            0,
            0,
        )
    };
    assert!(!c.is_null());
    // SAFETY: `c` is a live instance for every call below; the value-reference
    // and value arrays have the length passed.
    unsafe {
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), fmi2Status_fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2OK);
    }
    let refs: Vec<u32> = outputs.iter().map(|(_, r)| *r).collect();
    let mut snapshots = serde_json::Map::new();
    for k in 0..200 {
        // SAFETY: as above.
        unsafe {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
        }
        if (k + 1) % 50 == 0 {
            let mut values = vec![0.0; refs.len()];
            // SAFETY: as above.
            unsafe {
                assert_eq!(fmi2GetReal(c, refs.as_ptr(), refs.len(), values.as_mut_ptr()), fmi2Status_fmi2OK);
            }
            let named: serde_json::Map<String, Value> =
                outputs.iter().zip(&values).map(|((n, _), v)| (n.clone(), serde_json::json!(v))).collect();
            snapshots.insert(format!("step_{}", k + 1), Value::Object(named));
        }
    }
    // SAFETY: `c` is live and not used afterwards.
    unsafe { fmi2FreeInstance(c) };
    check("fmu", Value::Object(snapshots));
}
