//! The source tree reads as the pipeline: a stage imports only from the
//! stages before it, and no modules import each other in a circle.
//!
//! The check reads every `.rs` file under `src/` (comments removed) and
//! collects its references to the crate's modules: `crate::stage::file`,
//! `super::file` (a sibling in the same stage), and the grouped forms
//! `crate::stage::{a::…, b}` and `super::{a, b}`. The binary (`src/main.rs`)
//! is the command-line front end and reaches the library as `planetwear::`.
//! A reference from a stage to a later one, or a circle among files, fails
//! with the files and lines involved. The same rules for the Python package
//! are checked by `tests/python/test_package_layers.py`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The stages in pipeline order; a stage may import only from those before
/// it. `cli` is `src/main.rs`.
const STAGES: &[&str] = &[
    "files", "scene", "model", "geometry", "contact", "dynamics", "wear", "analysis", "fmi", "package",
    "report", "cli",
];

/// One file of the crate: its stage, its module path below the stage (e.g.
/// `solver::rk45`, or `` for the stage's mod.rs) and its source without
/// comments.
struct Unit {
    path: PathBuf,
    stage: String,
    module: Vec<String>,
    lines: Vec<String>,
}

fn strip_comments(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_block = false;
    for line in text.lines() {
        let mut kept = String::new();
        let mut rest = line;
        loop {
            if in_block {
                match rest.find("*/") {
                    Some(i) => {
                        in_block = false;
                        rest = &rest[i + 2..];
                    }
                    None => break,
                }
            } else {
                let line_comment = rest.find("//");
                let block = rest.find("/*");
                match (line_comment, block) {
                    (Some(l), Some(b)) if b < l => {
                        kept.push_str(&rest[..b]);
                        in_block = true;
                        rest = &rest[b + 2..];
                    }
                    (Some(l), _) => {
                        kept.push_str(&rest[..l]);
                        break;
                    }
                    (None, Some(b)) => {
                        kept.push_str(&rest[..b]);
                        in_block = true;
                        rest = &rest[b + 2..];
                    }
                    (None, None) => {
                        kept.push_str(rest);
                        break;
                    }
                }
            }
        }
        out.push(kept);
    }
    out
}

fn units(root: &Path) -> Vec<Unit> {
    let mut found = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                found.push(p);
            }
        }
    }
    found.sort();
    found
        .into_iter()
        .filter_map(|path| {
            let rel = path.strip_prefix(root).unwrap();
            let parts: Vec<String> = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
            let (stage, module) = match parts.as_slice() {
                [f] if f == "main.rs" => ("cli".to_string(), Vec::new()),
                [f] if f == "lib.rs" => return None,
                [stage, rest @ ..] => {
                    let mut m: Vec<String> =
                        rest.iter().map(|s| s.trim_end_matches(".rs").to_string()).collect();
                    if m.last().is_some_and(|l| l == "mod") {
                        m.pop();
                    }
                    (stage.clone(), m)
                }
                [] => return None,
            };
            let text = std::fs::read_to_string(&path).unwrap();
            Some(Unit { path: rel.to_path_buf(), stage, module, lines: strip_comments(&text) })
        })
        .collect()
}

/// The module paths (below the crate root) that a unit references, with the
/// line number of each reference.
fn references(u: &Unit) -> Vec<(usize, Vec<String>)> {
    let mut out = Vec::new();
    let root = if u.stage == "cli" { "planetwear::" } else { "crate::" };
    // The unit's own module path from the crate root.
    let mut own = vec![u.stage.clone()];
    own.extend(u.module.iter().cloned());
    for (n, line) in u.lines.iter().enumerate() {
        for (prefix, base) in
            [(root, Vec::<String>::new()), ("super::", own[..own.len().saturating_sub(1)].to_vec())]
        {
            let mut rest = line.as_str();
            while let Some(i) = rest.find(prefix) {
                let before = rest[..i].chars().last();
                rest = &rest[i + prefix.len()..];
                if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
                    continue;
                }
                for path in expand(rest) {
                    let mut full = base.clone();
                    full.extend(path);
                    if !full.is_empty() {
                        out.push((n + 1, full));
                    }
                }
            }
        }
    }
    out
}

/// The paths named right after a prefix: `a::b::C` gives [a, b, C];
/// `a::{b::X, c}` gives [a, b, X] and [a, c] (groups nest).
fn expand(rest: &str) -> Vec<Vec<String>> {
    let mut head = Vec::new();
    let mut cur = String::new();
    let mut chars = rest.char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        if c.is_alphanumeric() || c == '_' {
            cur.push(c);
        } else if c == ':' && chars.peek().map(|p| p.1) == Some(':') {
            chars.next();
            if !cur.is_empty() {
                head.push(std::mem::take(&mut cur));
            }
        } else if c == '{' && cur.is_empty() {
            // The group's items, split at commas outside nested braces.
            let group = &rest[i + 1..];
            let (mut depth, mut start, mut out) = (0usize, 0usize, Vec::new());
            for (j, g) in group.char_indices() {
                match g {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        out.push(&group[start..j]);
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.push(&group[start..j]);
                        start = j + 1;
                    }
                    _ => {}
                }
            }
            return out
                .into_iter()
                .flat_map(|item| expand(item.trim()))
                .filter(|p| !p.is_empty())
                .map(|p| head.iter().cloned().chain(p).collect())
                .collect();
        } else {
            break;
        }
    }
    if !cur.is_empty() {
        head.push(cur);
    }
    vec![head]
}

#[test]
fn stages_import_only_earlier_stages_and_files_form_no_circle() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let units = units(&root);
    let order: BTreeMap<&str, usize> = STAGES.iter().enumerate().map(|(i, s)| (*s, i)).collect();
    let mut problems = Vec::new();
    for u in &units {
        if !order.contains_key(u.stage.as_str()) {
            problems.push(format!(
                "src/{}: folder '{}' is not a stage; add it to STAGES in tests/layers.rs in pipeline order",
                u.path.display(),
                u.stage
            ));
        }
    }
    // Module path -> unit index, to resolve a reference to the file it names.
    let by_module: BTreeMap<Vec<String>, usize> = units
        .iter()
        .enumerate()
        .map(|(i, u)| {
            let mut m = vec![u.stage.clone()];
            m.extend(u.module.iter().cloned());
            (m, i)
        })
        .collect();
    let mut edges: BTreeMap<usize, BTreeMap<usize, usize>> = BTreeMap::new();
    for (i, u) in units.iter().enumerate() {
        let Some(&from) = order.get(u.stage.as_str()) else { continue };
        for (line, path) in references(u) {
            let Some(&to) = order.get(path[0].as_str()) else { continue };
            if to > from {
                problems.push(format!(
                    "src/{}:{line}: stage '{}' imports '{}' from the later stage '{}'",
                    u.path.display(),
                    u.stage,
                    path.join("::"),
                    path[0]
                ));
            }
            // The longest prefix of the path that is a file of the crate.
            let target = (1..=path.len()).rev().find_map(|k| by_module.get(&path[..k]).copied());
            if let Some(j) = target {
                if j != i {
                    edges.entry(i).or_default().entry(j).or_insert(line);
                }
            }
        }
    }
    // Circles among files: depth-first search for a back edge.
    fn visit(
        v: usize,
        edges: &BTreeMap<usize, BTreeMap<usize, usize>>,
        colour: &mut Vec<u8>,
        path: &mut Vec<usize>,
        circles: &mut Vec<Vec<usize>>,
    ) {
        colour[v] = 1;
        path.push(v);
        for &w in edges.get(&v).map(|e| e.keys().collect::<Vec<_>>()).unwrap_or_default() {
            if colour[w] == 1 {
                let start = path.iter().position(|&x| x == w).unwrap();
                let mut c = path[start..].to_vec();
                c.push(w);
                circles.push(c);
            } else if colour[w] == 0 {
                visit(w, edges, colour, path, circles);
            }
        }
        path.pop();
        colour[v] = 2;
    }
    let mut colour = vec![0u8; units.len()];
    let mut circles = Vec::new();
    for v in 0..units.len() {
        if colour[v] == 0 {
            visit(v, &edges, &mut colour, &mut Vec::new(), &mut circles);
        }
    }
    for c in circles {
        let hops: Vec<String> = c
            .windows(2)
            .map(|w| format!("src/{}:{}", units[w[0]].path.display(), edges[&w[0]][&w[1]]))
            .collect();
        problems.push(format!("circle: {} -> src/{}", hops.join(" -> "), units[c[0]].path.display()));
    }
    let files = units.len();
    let stages: BTreeSet<&str> = units.iter().map(|u| u.stage.as_str()).collect();
    assert!(problems.is_empty(), "{} problems in the layering:\n{}", problems.len(), problems.join("\n"));
    println!("{files} files in {} stages {:?}: no back-arrow, no circle", stages.len(), STAGES);
}

#[test]
fn the_checker_sees_a_grouped_import_and_a_super_import() {
    assert_eq!(expand("{gear::GearSet, mesh}"), vec![vec!["gear", "GearSet"], vec!["mesh"]]);
    assert_eq!(expand("ltca::SetModel;"), vec![vec!["ltca", "SetModel"]]);
    assert_eq!(
        expand("contact::{ltca::{A, B}, hertz};"),
        vec![vec!["contact", "ltca", "A"], vec!["contact", "ltca", "B"], vec!["contact", "hertz"]]
    );
    let u = Unit {
        path: "model/gear.rs".into(),
        stage: "model".into(),
        module: vec!["gear".into()],
        lines: strip_comments("use super::mesh; // crate::wear\nuse crate::contact::{ltca, hertz::X};"),
    };
    let refs: Vec<String> = references(&u).into_iter().map(|(_, p)| p.join("::")).collect();
    assert_eq!(refs, vec!["model::mesh", "contact::ltca", "contact::hertz::X"]);
}
