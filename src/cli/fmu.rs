//! The FMU's generated files: `fmu pack`, `fmu references`, `fmu xml` and
//! `fmu variables`.

use crate::*;

pub(crate) fn fmu_pack_command(FmuPackArgs { out, library, scene }: FmuPackArgs) -> Result<()> {
    let library = match library {
        Some(l) => l,
        None => std::env::current_exe()?
            .parent()
            .map(|d| d.join("libplanetwear.so"))
            .context("locating the executable's directory")?,
    };
    let scene = scene.map(|s| load_scene(&s).with_context(|| format!("--scene {s}"))).transpose()?;
    planetwear::package::pack::pack_scene(
        &library,
        &out,
        scene.as_ref(),
        &planetwear::package::regression::CASES,
    )?;
    match &scene {
        Some(s) => {
            outln!("wrote {} (library {}, default scene '{}')", out.display(), library.display(), s.name)?
        }
        None => outln!("wrote {} (library {})", out.display(), library.display())?,
    }
    Ok(())
}

pub(crate) fn fmu_references_command(
    FmuReferencesArgs { out, relative_tolerance }: FmuReferencesArgs,
) -> Result<()> {
    use planetwear::package::regression::{example_references, CASES};
    let started = std::time::Instant::now();
    let mut texts = Vec::new();
    for state in planetwear::package::pack::example_wear_states()? {
        texts.push(state.to_json()?);
    }
    let refs = example_references(&texts, &CASES, relative_tolerance)?;
    write_atomic(&out, refs.to_json()?.as_bytes())?;
    for c in &refs.cases {
        outln!(
            "{:<18} sun F1 {:9.3} N  ring F1 {:9.3} N  drift {:.2e}  tolerance {:.1e} of F1  ({} steps)",
            c.name,
            c.values["window.sunMeshF1"],
            c.values["window.ringMeshF1"],
            c.budget.drift,
            c.budget.fraction_of_f1,
            c.work.steps
        )?;
    }
    outln!("wrote {} ({} cases, {:.1} s)", out.display(), refs.cases.len(), started.elapsed().as_secs_f64())?;
    Ok(())
}

pub(crate) fn fmu_xml_command(FmuXmlArgs { out }: FmuXmlArgs) -> Result<()> {
    let xml = planetwear::fmi::variables::MODEL_DESCRIPTION_XML;
    match out {
        Some(path) => write_atomic(&path, xml.as_bytes())?,
        None => out!("{xml}")?,
    }
    Ok(())
}

pub(crate) fn fmu_variables_command(FmuXmlArgs { out }: FmuXmlArgs) -> Result<()> {
    let page = planetwear::fmi::reference::variables_markdown();
    match out {
        Some(path) => write_atomic(&path, page.as_bytes())?,
        None => out!("{page}")?,
    }
    Ok(())
}
