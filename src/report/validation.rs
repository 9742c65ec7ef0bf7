//! The validation report (docs/VALIDATION.md): the rows of
//! [`crate::analysis::study::validation`] as Markdown tables, the figures that lay
//! the study's features over ours, and the JSON of the run, so that a later
//! run can say which rows moved.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::plot::{write_chart, Chart, PlotError, Series};
use super::write_atomic;
use crate::analysis::study::validation::{headline, ForcedResponse, Validation, Verdict, STUDY_PEAKS};
use crate::dynamics::response::Direction;
use crate::scene::units::rad_per_s_to_rpm;

/// A row whose number differs from the previous run's beyond this relative change has moved.
const MOVED: f64 = 1e-6;

/// What moved since the previous run: (row id, previous value, new value).
pub fn moved_rows(previous: &Validation, current: &Validation) -> Vec<(String, f64, f64)> {
    current
        .rows
        .iter()
        .filter_map(|r| {
            let old = previous.row(&r.id)?;
            match (old.value, r.value) {
                (Some(a), Some(b)) if (a - b).abs() > MOVED * a.abs().max(b.abs()).max(1e-300) => {
                    Some((r.id.clone(), a, b))
                }
                _ => None,
            }
        })
        .collect()
}

/// Rows whose verdict differs from the previous run's: (row id, previous, new).
pub fn changed_verdicts(previous: &Validation, current: &Validation) -> Vec<(String, Verdict, Verdict)> {
    current
        .rows
        .iter()
        .filter_map(|r| {
            let old = previous.row(&r.id)?;
            (old.verdict != r.verdict).then(|| (r.id.clone(), old.verdict, r.verdict))
        })
        .collect()
}

fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// The verdict as the tables write it.
fn verdict_cell(v: Verdict) -> &'static str {
    match v {
        Verdict::Pass => "pass",
        Verdict::Fail => "**fail**",
        Verdict::Undecided => "**undecided**",
    }
}

/// The section that sets a second scene's validation (`other`, the same
/// claims on another contact law or parameter choice) beside the report's:
/// each scene's headline, then every row whose reading differs, with both
/// readings, verdicts and times; the rows read alike are counted.
pub fn comparison_markdown(v: &Validation, other: &Validation) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "
## `{}` beside `{}`
",
        other.scene, v.scene
    );
    let _ = writeln!(
        out,
        "The same claims on the built-in scene `{}` ({:.0} s; {}, and its wear without the resolution check). \
         `{}`: **{}** `{}`: **{}**\n",
        other.scene,
        other.seconds,
        match other.plan.forced {
            ForcedResponse::Continuation => "its forced-response rows from the continuation's branches",
            ForcedResponse::Marching => "its forced-response rows read once, without the second reading at a third of the tolerance",
        },
        v.scene,
        headline(&v.rows),
        other.scene,
        headline(&other.rows)
    );
    let _ = writeln!(
        out,
        "| claim | evidence | study | `{}` | verdict | `{}` | verdict | time s |",
        v.scene, other.scene
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    let mut same = 0;
    for r in &v.rows {
        let Some(o) = other.row(&r.id) else { continue };
        if o.ours == r.ours && o.verdict == r.verdict {
            same += 1;
            continue;
        }
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {:.2} / {:.2} |",
            cell(&r.claim),
            r.evidence.word(),
            cell(&r.study),
            cell(&r.ours),
            verdict_cell(r.verdict),
            cell(&o.ours),
            verdict_cell(o.verdict),
            r.seconds,
            o.seconds
        );
    }
    let rows = if same == 1 { "row reads" } else { "rows read" };
    let _ = writeln!(out, "\n{same} further {rows} the same on both scenes.");
    out
}

/// How the forced-response rows were read, in a paragraph (empty when there is nothing to say).
fn reading_words(v: &Validation) -> String {
    let mut out = String::new();
    if let Some(from) = v.check_from {
        let _ = writeln!(
            out,
            "The forced-response rows are read twice: on the sweeps, and on the same sweeps run again at a third of \
             the tolerance from {from:.0} rpm up, below the lowest speed where the up and down sweeps differ (several \
             attractors coexist there). A row whose verdict differs between the two readings is **undecided**: \
             which attractor a sweep rides turns on errors of the integrator's size, so the model does not decide \
             the claim at the accuracy computed.\n"
        );
    }
    if v.plan.forced == ForcedResponse::Continuation {
        let _ = writeln!(
            out,
            "The forced-response rows are read on the continuation's branches: the periodic states of the harmonic \
             balance condensed onto the contact coordinates, followed up and down in speed through their folds, \
             with their stability from the whole model's Floquet multipliers (docs/PERIODIC.md §4). Each \
             direction's curve is the first stable stretch of its run that spans each speed, so a claim about the \
             upper or the lower branch is read on that branch and no row depends on which attractor an \
             integrator's error picks. Where no stable periodic state spans a speed, a sweep leaves the branch: \
             those speeds are read on a marching sweep over the stretch, started as a sweep enters it from the \
             stable state read at the grid speed before it. The \
             spot-check row marches from stable branch points. `planetwear validate --full` reads the same rows \
             on marching sweeps instead.\n"
        );
    }
    out
}

/// The report as Markdown; `figures` is the figures' folder relative to the report,
/// `command` the command that made it; `compare`, a second scene's validation
/// set beside it ([`comparison_markdown`]).
pub fn markdown(
    v: &Validation,
    previous: Option<&Validation>,
    compare: Option<&Validation>,
    figures: &str,
    command: &str,
) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# Validation: the study's claims beside ours\n");
    let _ = writeln!(
        out,
        "Generated by `{command}` ({:.0} s on the machine it ran on) for the built-in scene `{}`. \
         Every claim of the 2004 study of the example set (its parameters: docs/PARAMETERS.md) and the published benchmarks the \
         model relies on, with our figure, the tolerance, the verdict, how ours was computed, an estimate \
         of its error and the time it took. **{}**\n",
        v.seconds,
        v.scene,
        headline(&v.rows)
    );
    let _ = writeln!(
        out,
        "Every row is labelled by what its pass would show. **Independent**: the study's or a published number \
         that the model was neither built nor fitted to reproduce; only these rows are evidence that the model \
         reproduces the study. **Fitted**: a calibration target (the three torsional natural frequencies and the \
         sun–planet double-contact share, docs/PARAMETERS.md); its pass says the fit converged. **Identity**: it \
         follows from how the model is built or from the input data (the rigid-body mode, the phasing rule, the \
         total wear of κ updates of 2.5 µm, closed forms of our own model, the geometry of the study's tooth data, \
         and the transverse–torsional frequencies, which follow from the torsional ones through the near-rigid \
         planet bearings chosen); its pass checks the code.\n"
    );
    out.push_str(&reading_words(v));
    let _ = writeln!(
        out,
        "Time-marching rows (off resonance, phasing, spot checks, or the sweeps with `--full`): {}.\n",
        v.integrator
    );
    match previous {
        Some(p) => {
            let moved = moved_rows(p, v);
            let verdicts = changed_verdicts(p, v);
            if !verdicts.is_empty() {
                let _ = writeln!(out, "Verdicts that changed since the previous run of this report:\n");
                for (id, a, b) in verdicts {
                    let _ = writeln!(out, "- `{id}`: {} → {}", a.word(), b.word());
                }
                out.push('\n');
            }
            if moved.is_empty() {
                let _ = writeln!(out, "No row moved since the previous run of this report.\n");
            } else {
                let _ = writeln!(out, "Rows that moved since the previous run of this report:\n");
                for (id, a, b) in moved {
                    let _ = writeln!(out, "- `{id}`: {a:.6e} → {b:.6e}");
                }
                out.push('\n');
            }
        }
        None => {
            let _ = writeln!(out, "No previous run of this report to compare with.\n");
        }
    }
    let mut section = String::new();
    for r in &v.rows {
        if r.section != section {
            section = r.section.clone();
            let _ = writeln!(out, "\n## {section}\n");
            let _ = writeln!(out, "| claim | evidence | study | ours | tolerance | verdict | time s |");
            let _ = writeln!(out, "|---|---|---|---|---|---|---|");
        }
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {:.2} |",
            cell(&r.claim),
            r.evidence.word(),
            cell(&r.study),
            cell(&r.ours),
            cell(&r.tolerance),
            verdict_cell(r.verdict),
            r.seconds
        );
    }
    if let Some(other) = compare {
        out.push_str(&comparison_markdown(v, other));
    }
    let _ = writeln!(out, "\n## How each row was computed\n");
    let _ = writeln!(out, "| row | method | error estimate |");
    let _ = writeln!(out, "|---|---|---|");
    for r in &v.rows {
        let _ = writeln!(out, "| `{}` | {} | {} |", r.id, cell(&r.method), cell(&r.error));
    }
    let _ = writeln!(out, "\n## Figures\n");
    let _ = writeln!(
        out,
        "![forced response]({figures}/forced_response.png)\n\nF^(rms) of the sun–planet mesh (the most loaded planet's), up and down sweeps at κ = 0 and the worn κ; the vertical lines mark the study's peak speeds.\n"
    );
    let _ = writeln!(
        out,
        "![ring–planet forced response]({figures}/forced_response_ring.png)\n\nThe same for the ring–planet mesh.\n"
    );
    let _ = writeln!(
        out,
        "![wear depth]({figures}/wear_depth.png)\n\nWorn depth of the sun's and the planet's flank against roll angle; the vertical lines mark their pitch points.\n"
    );
    let _ = writeln!(out, "## Natural frequencies of both fidelities\n");
    let _ = writeln!(out, "| fidelity | class | frequency Hz | multiplicity |");
    let _ = writeln!(out, "|---|---|---|---|");
    for (f, fr, c, m) in &v.modes {
        let _ = writeln!(out, "| {f:?} | {c:?} | {fr:.1} | {m} |");
    }
    out
}

/// Writes the figures into `dir` and returns the files written.
pub fn write_figures(v: &Validation, dir: &Path, face_width: f64) -> Result<Vec<PathBuf>, PlotError> {
    let per_mm = face_width * 1e3;
    let mut files = Vec::new();
    let marks: Vec<(f64, String)> = STUDY_PEAKS.iter().map(|r| (*r, format!("study {r:.0}"))).collect();
    for (mesh, name, title) in
        [(0, "forced_response", "sun–planet"), (1, "forced_response_ring", "ring–planet")]
    {
        let series = v
            .curves
            .iter()
            .map(|c| {
                let dir = if c.direction == Direction::Up { "up" } else { "down" };
                Series::new(
                    format!("κ = {}, {dir}", c.kappa),
                    c.points.iter().map(|p| rad_per_s_to_rpm(p.speed)).collect(),
                    c.points.iter().map(|p| p.rms[mesh] / per_mm).collect(),
                )
            })
            .collect();
        files.extend(write_chart(
            &Chart {
                title: format!("{}: {title} F(rms) against input speed", v.scene),
                x_label: "input speed (rpm)".into(),
                y_label: "F(rms) (N/mm)".into(),
                series,
                vlines: marks.clone(),
            },
            &dir.join(name),
        )?);
    }
    let series = v
        .profiles
        .iter()
        .map(|p| {
            Series::new(
                p.flank.name(),
                p.roll.iter().map(|r| r.to_degrees()).collect(),
                p.depth.iter().map(|d| d * 1e6).collect(),
            )
        })
        .collect();
    let pitch = v
        .profiles
        .iter()
        .map(|p| (p.pitch_roll.to_degrees(), format!("{} pitch point", p.flank.name())))
        .collect();
    files.extend(write_chart(
        &Chart {
            title: format!("{}: worn depth at κ = {}", v.scene, v.plan.kappa),
            x_label: "roll angle (deg)".into(),
            y_label: "wear depth (µm)".into(),
            series,
            vlines: pitch,
        },
        &dir.join("wear_depth"),
    )?);
    Ok(files)
}

/// Writes `DIR/VALIDATION.md`, the figures and `validation.json` into
/// `DIR/validation/`, comparing with the JSON a previous run left there.
/// With `compare`, a second scene's validation is set beside it in the
/// report and its JSON written as `DIR/validation/<scene>.json`.
pub fn write_report(
    v: &Validation,
    compare: Option<&Validation>,
    out: &Path,
    face_width: f64,
    command: &str,
) -> Result<Vec<PathBuf>, PlotError> {
    let figures = out.join("validation");
    std::fs::create_dir_all(&figures).map_err(|source| PlotError::Io { path: figures.clone(), source })?;
    let json_path = figures.join("validation.json");
    let previous: Option<Validation> = crate::files::read_input(&json_path, crate::files::InputKind::Record)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok());
    let mut files = write_figures(v, &figures, face_width)?;
    let md = markdown(v, previous.as_ref(), compare, "validation", command);
    if let Some(other) = compare {
        let path = figures.join(format!("{}.json", other.scene));
        let json = serde_json::to_string_pretty(other).map_err(|e| PlotError::Backend(e.to_string()))?;
        write_atomic(&path, json.as_bytes())?;
        files.push(path);
    }
    let json = serde_json::to_string_pretty(v).map_err(|e| PlotError::Backend(e.to_string()))?;
    // The next run reads it back: written only if it will be read.
    crate::files::check_output_size(&json_path, crate::files::InputKind::Record, json.len())?;
    write_atomic(&json_path, json.as_bytes())?;
    files.push(json_path);
    let report = out.join("VALIDATION.md");
    write_atomic(&report, md.as_bytes())?;
    files.push(report);
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::study::validation::{Evidence, Row, ValidationPlan};

    fn row(id: &str, value: f64, verdict: Verdict) -> Row {
        Row {
            id: id.into(),
            section: "Forced response (κ = 0)".into(),
            evidence: if id == "c" { Evidence::Identity } else { Evidence::Independent },
            claim: format!("claim {id}"),
            study: "≈ 1".into(),
            ours: format!("{value}"),
            value: Some(value),
            tolerance: "±5 %".into(),
            verdict,
            method: "sweeps".into(),
            error: "±25 rpm".into(),
            seconds: 1.0,
        }
    }

    fn validation(rows: Vec<Row>, check_from: Option<f64>) -> Validation {
        Validation {
            scene: "example-2004".into(),
            plan: ValidationPlan::quick(),
            integrator: "RK 5(4)".into(),
            rows,
            curves: Vec::new(),
            check_curves: Vec::new(),
            check_from,
            profiles: Vec::new(),
            modes: Vec::new(),
            seconds: 1.0,
        }
    }

    #[test]
    fn the_report_counts_undecided_rows_and_names_changed_verdicts_and_values() {
        let previous = validation(
            vec![row("a", 1.0, Verdict::Pass), row("b", 2.0, Verdict::Fail), row("c", 3.0, Verdict::Pass)],
            None,
        );
        let current = validation(
            vec![
                row("a", 1.0, Verdict::Undecided),
                row("b", 2.5, Verdict::Fail),
                row("c", 3.0, Verdict::Pass),
            ],
            Some(3550.0),
        );
        let verdicts = changed_verdicts(&previous, &current);
        assert_eq!(verdicts, vec![("a".to_string(), Verdict::Pass, Verdict::Undecided)]);
        assert_eq!(moved_rows(&previous, &current), vec![("b".to_string(), 2.0, 2.5)]);
        let md = markdown(&current, Some(&previous), None, "validation", "planetwear validate");
        // The headline counts the independent rows (a and b) apart from the identity (c).
        assert!(
            md.contains(
                "**Independent evidence: 0 of 2 rows pass (1 undecided); fitted: 0 of 0; identities: 1 of 1.**"
            ),
            "{md}"
        );
        assert!(md.contains("**Identity**: it follows from how the model is built"), "{md}");
        assert!(md.contains("- `a`: pass → undecided"), "{md}");
        assert!(md.contains("- `b`: 2.000000e0 → 2.500000e0"), "{md}");
        assert!(md.contains("from 3550 rpm up"), "{md}");
        assert!(md.contains("| claim a | independent | ≈ 1 | 1 | ±5 % | **undecided** |"), "{md}");
        assert!(md.contains("| claim c | identity | ≈ 1 | 3 | ±5 % | pass |"), "{md}");
        // Nothing changed: nothing listed.
        let md = markdown(&current, Some(&current), None, "validation", "planetwear validate");
        assert!(md.contains("No row moved") && !md.contains("Verdicts that changed"), "{md}");
    }

    #[test]
    fn a_compared_scene_shows_the_rows_it_reads_differently() {
        let ours = validation(vec![row("a", 1.0, Verdict::Pass), row("b", 2.0, Verdict::Fail)], None);
        let mut other = validation(vec![row("a", 1.0, Verdict::Pass), row("b", 2.5, Verdict::Pass)], None);
        other.scene = "example-2004-deformable".into();
        let md = markdown(&ours, None, Some(&other), "validation", "planetwear validate");
        assert!(md.contains("## `example-2004-deformable` beside `example-2004`"), "{md}");
        assert!(
            md.contains("| claim b | independent | ≈ 1 | 2 | **fail** | 2.5 | pass | 1.00 / 1.00 |"),
            "{md}"
        );
        assert!(!md.contains("| claim a | independent | ≈ 1 | 1 | pass | 1 |"), "{md}");
        assert!(md.contains("1 further row reads the same on both scenes."), "{md}");
        assert!(md.contains("`example-2004-deformable`: **Independent evidence: 2 of 2 rows pass"), "{md}");
    }
}
