//! The wear commands: `wear run`, `wear step`, `wear compare` and `wear effect`.

use crate::*;
use planetwear::wear::flank::UpdateEnd;

pub(crate) fn wear_model(
    set: &GearSet,
    run: &RunSettings,
    ring: bool,
    threshold_um: Option<f64>,
    dynamic_rpm: Option<f64>,
) -> Result<WearModel> {
    let mut settings = WearSettings::for_set(set);
    if let Some(rpm) = dynamic_rpm {
        if !(rpm.is_finite() && rpm > 0.0) {
            bail!("--dynamic-speed {rpm}: must be a finite input speed > 0 rpm");
        }
        settings.source = PressureSource::Dynamic { speed: rpm_to_rad_per_s(rpm) };
    }
    if ring {
        settings.wearing = WearingFlanks::both_meshes();
    }
    if let Some(t) = threshold_um {
        settings.update_depth = t * 1e-6;
    }
    WearModel::with_run(set, run, settings).map_err(|e| match threshold_um {
        Some(t) => anyhow::anyhow!("--threshold {t} µm: {e}"),
        None => e.into(),
    })
}

/// The duty-cycle files `paths` read for `set` and added (one file: itself).
fn summed_duty(set: &GearSet, paths: &[PathBuf]) -> Result<planetwear::wear::duty::DutyCycle> {
    let mut cycles = paths.iter().map(|p| planetwear::wear::duty::read_duty_cycle(p, set));
    let mut sum = cycles.next().context("--duty-cycle: no file")??;
    let mut sources = vec![sum.source.clone()];
    for (cycle, path) in cycles.zip(&paths[1..]) {
        let cycle = cycle?;
        sum.duty.add(&cycle.duty).with_context(|| {
            format!("--duty-cycle {}: cannot be added to {}", path.display(), paths[0].display())
        })?;
        sources.push(cycle.source);
    }
    if paths.len() > 1 {
        sources.dedup();
        sum.source = format!("sum of {} duty cycles ({})", paths.len(), sources.join(", "));
    }
    Ok(sum)
}

/// `wear step --duty-cycle`: the state `before` worn by the duty in `paths` (added), `repeat`
/// passes or the passes `hours` of operation take (one by default), written to `out`.
fn duty_step(
    set: &GearSet,
    run: &RunSettings,
    model: &WearModel,
    before: &planetwear::wear::state::WornState,
    (paths, (repeat, hours), dynamic): (&[PathBuf], (Option<f64>, Option<f64>), bool),
    out: &Path,
) -> Result<()> {
    use planetwear::wear::duty_wear::DutyWear;
    let cycle = summed_duty(set, paths)?;
    let named: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    let named = named.join(", ");
    let mut settings = *model.settings();
    if dynamic {
        // The speed is each bin's; this one only selects the dynamic source.
        settings.source = PressureSource::Dynamic { speed: run.input_speed() };
    }
    let wear =
        DutyWear::new(set, Some(run), &settings, &cycle).with_context(|| format!("--duty-cycle {named}"))?;
    let (revolutions, duration) = wear.duty();
    let passes = match (repeat, hours) {
        (Some(n), _) if n.is_finite() && n > 0.0 => n,
        (Some(n), _) => bail!("--repeat {n}: must be a finite number of passes > 0"),
        (None, Some(h)) if h.is_finite() && h > 0.0 && duration > 0.0 => h * 3600.0 / duration,
        (None, Some(h)) => bail!(
            "--hours {h}: must be a finite number of hours > 0, of a duty that lasts (this one {duration} s)"
        ),
        (None, None) => 1.0,
    };
    if wear.outside_share() > 0.0 {
        eprintln!(
            "warning: --duty-cycle {named}: {:.2} % of a mesh's revolutions lie outside the torque bins and do not wear",
            100.0 * wear.outside_share()
        );
    }
    let after = wear.advance(before, passes)?;
    planetwear::wear::state::write_worn_state(out, &after)?;
    let worn = after.revolutions - before.revolutions;
    let time = after.operating_time - before.operating_time;
    let deepest = after.deepest();
    outln!(
        "κ {} → {}: {:.4} passes of the duty ({} load bins, {:.4e} input revolutions of {:.4e} asked, {:.4} h of \
         operation; {:.4} h in all); deepest wear {:.3} µm on {}; wrote {}",
        before.kappa,
        after.kappa,
        worn / revolutions,
        wear.bins(),
        worn,
        passes * revolutions,
        time / 3600.0,
        after.operating_time / 3600.0,
        deepest.depth * 1e6,
        deepest.flank.name(),
        out.display()
    )?;
    Ok(())
}

/// Removes a directory's completion marker left by an earlier run.
pub(crate) fn remove_marker(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(e).with_context(|| format!("removing the earlier run's {}", path.display()))
        }
        _ => Ok(()),
    }
}

pub(crate) fn wear_run(
    scene: &str,
    to_kappa: u32,
    out: &Path,
    ring: bool,
    dynamic: Option<f64>,
    json: bool,
) -> Result<()> {
    let (set, run) = validated_with_run(&load_scene(scene)?)?;
    let model = wear_model(&set, &run, ring, None, dynamic)?;
    std::fs::create_dir_all(out.join("plots")).with_context(|| format!("creating {}", out.display()))?;
    // The completion marker of an earlier run goes first: until this run
    // writes it again, the directory holds no finished run.
    remove_marker(&out.join("summary.json"))?;
    let mut state = model.unworn();
    let mut states = vec![state.clone()];
    let mut seconds = vec![0.0];
    planetwear::wear::state::write_worn_state(&out.join("kappa-0.json"), &state)?;
    let bar = progress_bar(u64::from(to_kappa));
    let mut stopped = None;
    for _ in 0..to_kappa {
        let started = std::time::Instant::now();
        match model.step(&state, Limit::Update) {
            Ok(next) => state = next,
            Err(e @ WearError::TotalWearReached { .. }) => {
                stopped = Some(e.to_string());
                break;
            }
            Err(e) => return Err(e.into()),
        }
        seconds.push(started.elapsed().as_secs_f64());
        planetwear::wear::state::write_worn_state(&out.join(format!("kappa-{}.json", state.kappa)), &state)?;
        states.push(state.clone());
        bar.inc(1);
    }
    bar.finish_and_clear();
    let doc = planetwear::report::wear::summary(&set, &states, &seconds);
    let files = planetwear::report::wear::write_plots(&set, &states, &out.join("plots"))?;
    // Written last: its presence says the run finished (docs/LIMITS.md).
    write_atomic(&out.join("summary.json"), serde_json::to_string_pretty(&doc)?.as_bytes())?;
    if json {
        outln!("{}", serde_json::to_string_pretty(&doc)?)?;
        return Ok(());
    }
    outln!(
        "wear of {}: {} updates, states and summary.json in {}, {} plot files",
        set.name(),
        states.len() - 1,
        out.display(),
        files.len()
    )?;
    outln!("   κ  cycles sun  cycles planet   input rev   sun max µm @ roll   planet max µm @ roll   time")?;
    for s in doc["states"].as_array().into_iter().flatten().skip(1) {
        let f = |m: &str, k: &str| s["flanks"][m][k].as_f64().unwrap_or(f64::NAN);
        outln!(
            "  {:>2}  {:>10.4e}  {:>13.4e}  {:>10.4e}   {:>6.3} @ {:>6.2}°     {:>6.3} @ {:>6.2}°      {:.2} s",
            s["kappa"],
            s["cycles_sun"].as_f64().unwrap_or(f64::NAN),
            s["cycles_planet"].as_f64().unwrap_or(f64::NAN),
            s["input_revolutions"].as_f64().unwrap_or(f64::NAN),
            f("sun", "max_um"),
            f("sun", "max_roll_deg"),
            f("planet", "max_um"),
            f("planet", "max_roll_deg"),
            s["seconds"].as_f64().unwrap_or(0.0),
        )?;
    }
    if let Some(why) = stopped {
        outln!("stopped before κ = {to_kappa}: {why}")?;
    }
    Ok(())
}

pub(crate) fn wear_run_command(
    WearRunArgs { scene, to_kappa, out, ring, dynamic_speed, json }: WearRunArgs,
) -> Result<()> {
    wear_run(&scene, to_kappa, &out, ring, dynamic_speed, json)?;
    Ok(())
}

pub(crate) fn wear_compare_command(
    WearCompareArgs { scene, state, accept: AcceptArgs { accept_state_difference }, speeds, json }: WearCompareArgs,
) -> Result<()> {
    let (set, run) = validated_with_run(&load_scene(&scene)?)?;
    let model = wear_model(&set, &run, false, None, None)?;
    let state = match &state {
        Some(path) => read_state("--state", path, &set, accept_state_difference.as_deref())?,
        None => model.unworn(),
    };
    let face_mm = set.sun().face_width * 1e3;
    let mut docs = Vec::new();
    for rpm in speeds {
        if !(rpm.is_finite() && rpm > 0.0) {
            bail!("--speeds {rpm}: speeds must be finite and > 0 rpm");
        }
        let c = compare_sources(&model, &state, rpm_to_rad_per_s(rpm))?;
        if json {
            docs.push(serde_json::json!({
                "speed_rpm": rpm,
                "flanks": c.flanks.iter().map(|f| serde_json::json!({
                    "flank": f.flank.name(), "roll": f.roll, "quasi_static": f.quasi_static,
                    "dynamic": f.dynamic, "ratio": f.ratio,
                    "quasi_static_max_roll": f.quasi_static_max_roll, "dynamic_max_roll": f.dynamic_max_roll,
                })).collect::<Vec<_>>(),
                "meshes": c.meshes.iter().map(|m| serde_json::json!({
                    "mesh": m.mesh.name(), "mean_force": m.mean_mesh_force, "rms_force": m.rms_mesh_force,
                    "quasi_static_max_pair_load": m.quasi_static_max_pair_load,
                    "dynamic_max_pair_load": m.dynamic_max_pair_load,
                })).collect::<Vec<_>>(),
            }));
            continue;
        }
        outln!("{rpm:.0} rpm (κ = {}):", state.kappa)?;
        for m in &c.meshes {
            outln!(
                "  {}: F(rms) {:.1} N/mm; largest pair load quasi-static {:.1}, dynamic {:.1} N/mm ({:.3}×)",
                m.mesh.name(),
                m.rms_mesh_force / face_mm,
                m.quasi_static_max_pair_load / face_mm,
                m.dynamic_max_pair_load / face_mm,
                m.dynamic_max_pair_load / m.quasi_static_max_pair_load
            )?;
        }
        for f in &c.flanks {
            outln!(
                "  {}: largest wear per cycle quasi-static {:.4} pm at {:.2}°, dynamic {:.4} pm at {:.2}° ({:.3}×)",
                f.flank.name(),
                f.quasi_static_max * 1e12,
                f.quasi_static_max_roll.to_degrees(),
                f.dynamic_max * 1e12,
                f.dynamic_max_roll.to_degrees(),
                f.ratio
            )?;
        }
    }
    if json {
        outln!("{}", serde_json::to_string_pretty(&docs)?)?;
    }
    Ok(())
}

pub(crate) fn wear_effect_command(
    WearEffectArgs { scene, kappa, speeds, only, out }: WearEffectArgs,
) -> Result<()> {
    use planetwear::analysis::study::wear_effect::{run_all, variants};
    let base = load_scene(&scene)?;
    validated(&base)?;
    for rpm in &speeds {
        if !(rpm.is_finite() && *rpm > 0.0) {
            bail!("--speeds {rpm}: every speed must be a finite positive input speed in rpm");
        }
    }
    let mut list = variants(&base);
    if !only.is_empty() {
        let keys: Vec<String> = list.iter().map(|v| v.key.clone()).collect();
        if let Some(bad) = only.iter().find(|k| !keys.contains(k)) {
            bail!("--only {bad}: not a variant; the variants are {}", keys.join(", "));
        }
        list.retain(|v| only.contains(&v.key));
    }
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let started = std::time::Instant::now();
    let speeds: Vec<f64> = speeds.into_iter().map(rpm_to_rad_per_s).collect();
    let results: Vec<_> = run_all(&list, kappa, &speeds)
        .into_iter()
        .collect::<Result<_, _>>()
        .map_err(|e| anyhow::anyhow!("wear effect: {e}"))?;
    let table = planetwear::report::wear_effect::markdown(&results);
    write_atomic(&out.join("effect.md"), table.as_bytes())?;
    write_atomic(&out.join("effect.json"), serde_json::to_string_pretty(&results)?.as_bytes())?;
    for v in &list {
        outln!("{}: {}", v.key, v.description)?;
    }
    outln!("\n{table}")?;
    outln!(
        "{} variants in {:.1} s; effect.md and effect.json in {}",
        results.len(),
        started.elapsed().as_secs_f64(),
        out.display()
    )?;
    Ok(())
}

pub(crate) fn wear_step_command(
    WearStepArgs {
        scene,
        state,
        accept: AcceptArgs { accept_state_difference },
        out,
        threshold,
        revolutions,
        ring,
        dynamic_speed,
        duty_cycle,
        repeat,
        hours,
        dynamic,
    }: WearStepArgs,
) -> Result<()> {
    let (set, run) = validated_with_run(&load_scene(&scene)?)?;
    let model = wear_model(&set, &run, ring, threshold, dynamic_speed)?;
    let before = match &state {
        Some(path) => read_state("--state", path, &set, accept_state_difference.as_deref())?,
        None => model.unworn(),
    };
    if !duty_cycle.is_empty() {
        let passes = (repeat, hours);
        return duty_step(&set, &run, &model, &before, (&duty_cycle, passes, dynamic), &out);
    }
    let limit = match revolutions {
        Some(n) if n.is_finite() && n > 0.0 => Limit::Revolutions(n),
        Some(n) => bail!("--revolutions {n}: must be a finite number of input revolutions > 0"),
        None => Limit::Update,
    };
    let after = model.step(&before, limit)?;
    if let (Some(n), Some(update)) = (revolutions, after.history.last()) {
        if update.ended_by != UpdateEnd::Revolutions {
            let why = match update.ended_by {
                UpdateEnd::TotalDepth => "the deepest wear reaches the total wear limit".to_string(),
                _ => format!(
                    "the largest new wear reaches the update depth {} µm (--threshold)",
                    model.settings().update_depth * 1e6
                ),
            };
            bail!(
                "--revolutions {n:e}: cannot be met in one update: it ends after {:.4e} input revolutions, \
                 when {why}; nothing written. Ask for at most that many, or step again from each new state",
                update.revolutions
            );
        }
    }
    planetwear::wear::state::write_worn_state(&out, &after)?;
    let deepest = |s: &planetwear::wear::state::WornState, f| s.deepest_on(f);
    let (sun, planet) = (Flank::SunDrive, Flank::PlanetSunSide);
    outln!(
        "κ {} → {}: {:.4e} input revolutions ({:.4e} in all); deepest wear sun {:.3} µm at {:.2}°, planet {:.3} µm at {:.2}°; wrote {}",
        before.kappa,
        after.kappa,
        after.revolutions - before.revolutions,
        after.revolutions,
        deepest(&after, sun).depth * 1e6,
        deepest(&after, sun).roll.to_degrees(),
        deepest(&after, planet).depth * 1e6,
        deepest(&after, planet).roll.to_degrees(),
        out.display()
    )?;
    Ok(())
}
