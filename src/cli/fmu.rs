//! The FMU's generated files: `fmu pack`, `fmu references`, `fmu xml` and
//! `fmu variables`.

use crate::*;

/// The portable shared library `scripts/fmu.sh` builds, in the target directory.
const PORTABLE_LIBRARY: &str = "x86_64-unknown-linux-gnu/fmu/libplanetwear.so";

/// The glibc level the portable library is linked against (`scripts/fmu.sh`).
const PORTABLE_GLIBC: &str = "GLIBC_2.17";

pub(crate) fn fmu_pack_command(FmuPackArgs { out, library, scene }: FmuPackArgs) -> Result<()> {
    let library = match library {
        Some(l) => l,
        None => default_library()?,
    };
    // A missing library is the pack's own error (it names the build).
    let glibc = if library.is_file() { planetwear::package::elf::newest_glibc(&library)? } else { None };
    let limit =
        planetwear::package::elf::GlibcVersion::parse(PORTABLE_GLIBC).context("the portable glibc level")?;
    let needs = glibc.as_ref().map_or_else(|| "no glibc version".to_string(), |v| v.to_string());
    if glibc.as_ref().is_some_and(|v| *v > limit) {
        eprintln!(
            "warning: {} needs {needs}: the FMU loads only where glibc is that new. The portable \
             library ({PORTABLE_GLIBC}) is built by `bash scripts/fmu.sh` into target/{PORTABLE_LIBRARY}, \
             which `fmu pack` takes when it is there.",
            library.display()
        );
    }
    let scene = scene.map(|s| load_scene(&s).with_context(|| format!("--scene {s}"))).transpose()?;
    planetwear::package::pack::pack_scene(
        &library,
        &out,
        scene.as_ref(),
        &planetwear::package::regression::CASES,
    )?;
    let what = format!("library {}, needs {needs}", library.display());
    match &scene {
        Some(s) => outln!("wrote {} ({what}, default scene '{}')", out.display(), s.name)?,
        None => outln!("wrote {} ({what})", out.display())?,
    }
    Ok(())
}

/// The library `fmu pack` takes without `--library`: the portable one where `scripts/fmu.sh`
/// built it in this executable's target directory, otherwise the native libplanetwear.so beside
/// the executable. A portable library older than the native one is taken with a warning (it
/// may not be the executable's code).
fn default_library() -> Result<PathBuf> {
    let exe = std::env::current_exe()?;
    let dir = exe.parent().context("locating the executable's directory")?;
    let native = dir.join("libplanetwear.so");
    let portable = dir.parent().map(|target| target.join(PORTABLE_LIBRARY));
    let Some(portable) = portable.filter(|p| p.is_file()) else {
        return Ok(native);
    };
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    if let (Some(p), Some(n)) = (modified(&portable), modified(&native)) {
        if p < n {
            eprintln!(
                "warning: the portable library {} is older than the native {}: rebuild it with \
                 `bash scripts/fmu.sh` if the code changed since",
                portable.display(),
                native.display()
            );
        }
    }
    Ok(portable)
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
