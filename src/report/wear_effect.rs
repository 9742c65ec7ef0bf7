//! Tables of the wear-effect experiments ([`crate::analysis::study::wear_effect`]):
//! Markdown for the documentation and the terminal, in the field's units.

use crate::analysis::study::wear_effect::VariantResult;
use crate::scene::units::rad_per_s_to_rpm;

/// The experiments as two Markdown tables: the wear shape and quasi-static
/// figures, then the dynamic loads of planet 1's meshes per speed.
pub fn markdown(results: &[VariantResult]) -> String {
    let mut out = String::new();
    let um = |x: f64| x * 1e6;
    out.push_str(
        "| variant | κ | sun deepest µm @ roll | sun at tip / pitch / SAP µm | planet deepest µm @ roll | planet addendum share | double contact sun–planet κ 0 → κ | ring–planet | loaded TE p-p sun–planet µm | ring–planet µm | whole set µm | time s |\n",
    );
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in results {
        let s = &r.statics;
        out.push_str(&format!(
            "| {} | {} | {:.2} @ {:.2}° | {:.2} / {:.2} / {:.2} | {:.2} @ {:.2}° | {:.2} | {:.3} → {:.3} | {:.3} → {:.3} | {:.2} → {:.2} | {:.2} → {:.2} | {:.2} → {:.2} | {:.1} |\n",
            r.key,
            r.kappa,
            um(r.sun.deepest.0),
            r.sun.deepest.1.to_degrees(),
            um(r.sun.tip_end),
            um(r.sun.pitch.0),
            um(r.sun.root_end),
            um(r.planet.deepest.0),
            r.planet.deepest.1.to_degrees(),
            r.planet.addendum_share,
            s[0].double_contact[0],
            s[1].double_contact[0],
            s[0].double_contact[1],
            s[1].double_contact[1],
            um(s[0].transmission_error[0]),
            um(s[1].transmission_error[0]),
            um(s[0].transmission_error[1]),
            um(s[1].transmission_error[1]),
            um(s[0].set_transmission_error),
            um(s[1].set_transmission_error),
            r.seconds,
        ));
    }
    out.push('\n');
    let speeds: Vec<f64> = results
        .first()
        .map(|r| r.loads[0].iter().map(|l| rad_per_s_to_rpm(l.speed)).collect())
        .unwrap_or_default();
    out.push_str("| variant | mesh |");
    for rpm in &speeds {
        out.push_str(&format!(" {rpm:.0} rpm F^(1) | F^(rms) |"));
    }
    out.push_str(" mean ΔF^(rms) |\n|---|---|");
    for _ in &speeds {
        out.push_str("---|---|");
    }
    out.push_str("---|\n");
    for r in results {
        let w = r.face_width * 1e3;
        for (m, name) in [(0, "sun–planet"), (1, "ring–planet")] {
            out.push_str(&format!("| {} | {name} |", r.key));
            let mut change = 0.0;
            for (a, b) in r.loads[0].iter().zip(&r.loads[1]) {
                out.push_str(&format!(
                    " {:.1} → {:.1} | {:.1} → {:.1} |",
                    a.first_harmonic[m] / w,
                    b.first_harmonic[m] / w,
                    a.rms[m] / w,
                    b.rms[m] / w
                ));
                change += b.rms[m] / a.rms[m] - 1.0;
            }
            out.push_str(&format!(" {:+.1} % |\n", 100.0 * change / r.loads[0].len().max(1) as f64));
        }
    }
    out.push_str("\nForces in N/mm of face width; κ 0 → κ; planet 1's meshes; TE: loaded static transmission error along the line of action.\n");
    out
}
