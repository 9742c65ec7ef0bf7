//! The dynamic and static analyses of one scene: `simulate`, `run`, `sweep`,
//! `modes` and `ltca`, with the printing of their results.

use crate::*;
use planetwear::analysis::modes::{rayleigh_rule, Mode};
use planetwear::analysis::plausibility;
use planetwear::analysis::study::peaks::Peak;
use planetwear::dynamics::response::Sweep;
use planetwear::model::gear::Damping;

pub(crate) fn simulate_command(
    SimulateArgs {
        set: SetArgs { scene, wear_state, accept: AcceptArgs { accept_state_difference } },
        stop,
        step,
        duty_cycle,
        duty_torque_edges,
        duty_speed_edges,
    }: SimulateArgs,
) -> Result<()> {
    let (set, run) = validated_with_run(&load_scene(&scene)?)?;
    let bins = match &duty_cycle {
        Some(_) => Some(duty_bins(&set, &run, duty_torque_edges, duty_speed_edges)?),
        None => None,
    };
    if !(step.is_finite() && step > 0.0 && stop.is_finite() && stop > 0.0) {
        bail!("--stop and --step must be finite and positive (got {stop} and {step})");
    }
    if stop / step > MAX_COMMUNICATION_POINTS {
        bail!(
            "--stop {stop} / --step {step}: {:.3e} communication points, more than the {MAX_COMMUNICATION_POINTS:e} \
             one run may print (docs/LIMITS.md); use a larger --step",
            stop / step
        );
    }
    let model = PlanetaryDynamics::new(
        &set,
        contact_model(&set, wear_state.as_deref(), accept_state_difference.as_deref())?,
    )?;
    let mut sim =
        planetwear::dynamics::simulation::Simulation::new(&set, &run, model, 0.0, run.input_speed())?;
    if let Some(bins) = bins {
        sim.record_duty(bins);
    }
    if run.response() == planetwear::scene::Response::Steady {
        sim.use_steady(None).context("dynamics.response = \"steady\"")?;
    }
    let n = (stop / step).round() as u64;
    use planetwear::model::gear::MeshKind;
    for k in 0..n {
        // Communication points on the integer grid t_k = k·step, each
        // step t_{k+1} − t_k (as fmpy and most importers call doStep):
        // the adaptive integrator's steps depend on the last bit of
        // the step ends.
        let (t0, t1) = (k as f64 * step, (k + 1) as f64 * step);
        sim.do_step(t0, t1 - t0)?;
        // The extremes over the step and the torques, named as the FMU's
        // outputs (docs/FMU.md).
        let e = sim.step_extremes();
        let mut row = serde_json::json!({
            "time": sim.time(),
            "sun.speed": sim.speed(planetwear::model::gear::Member::Sun),
            "reactionTorque": sim.reaction_torque(),
            "balancingTorque": sim.balancing_torque(),
            "sunMeshForceMax": e.any_max(MeshKind::SunPlanet),
            "ringMeshForceMax": e.any_max(MeshKind::RingPlanet),
            "sunToothForceMax": e.any_peak_pair(MeshKind::SunPlanet),
            "ringToothForceMax": e.any_peak_pair(MeshKind::RingPlanet),
            "sunMeshSeparated": u8::from(e.any_separated(MeshKind::SunPlanet)),
            "ringMeshSeparated": u8::from(e.any_separated(MeshKind::RingPlanet)),
        });
        for p in 0..set.planet_angles().len() {
            for (kind, name) in [(MeshKind::SunPlanet, "sun"), (MeshKind::RingPlanet, "ring")] {
                let Some(x) = e.mesh(p, kind) else { continue };
                let planet = format!("planet[{}].{name}", p + 1);
                row[format!("{planet}MeshForce")] = sim.mesh_force(p, kind).into();
                row[format!("{planet}MeshForceMin")] = x.min.into();
                row[format!("{planet}MeshForceMax")] = x.max.into();
                row[format!("{planet}ToothForceMax")] = x.peak_pair.into();
                row[format!("{planet}Separated")] = u8::from(x.separated).into();
            }
        }
        outln!("{row}")?;
    }
    if let Some(engine) = sim.steady() {
        let s = engine.stats();
        eprintln!(
            "steady response: {} steps, {} steady states solved ({} after a march past a fold, {} from the static \
             state, {} not found: their row's nearest taken), {} steps interpolated with an estimated error above \
             dynamics.steady_agreement (largest {:.3}), {} without an estimate (low load {}, not settled {})",
            s.requests.saturating_sub(1),
            s.solved,
            s.marched,
            s.cold,
            s.failed,
            s.unresolved,
            s.worst_estimate,
            s.low_load + s.unsettled,
            s.low_load,
            s.unsettled
        );
    }
    if let (Some(path), Some(duty)) = (duty_cycle, sim.duty()) {
        let cycle = planetwear::wear::duty::DutyCycle::new(&set, "simulate", duty.clone());
        planetwear::wear::duty::write_duty_cycle(&path, &cycle)?;
    }
    Ok(())
}

/// Bins of `--duty-torque-edges` [N·m] and `--duty-speed-edges` [rpm]; either left out: that
/// axis of `DutyBins::around` the scene's input torque and speed.
fn duty_bins(
    set: &planetwear::model::gear::GearSet,
    run: &planetwear::model::run::RunSettings,
    torque: Vec<f64>,
    speed_rpm: Vec<f64>,
) -> Result<planetwear::dynamics::duty::DutyBins> {
    use planetwear::dynamics::duty::{check_edges, DutyBins, DutyError};
    // The speed edges checked as given, so that a refusal quotes them in rpm.
    if !speed_rpm.is_empty() {
        check_edges("speed_edges", &speed_rpm).map_err(|e| match e {
            DutyError::Edges { value, allowed, .. } => {
                anyhow::anyhow!("--duty-speed-edges {value} rpm: {allowed}")
            }
            other => other.into(),
        })?;
    }
    let around = DutyBins::around(set.input_torque(), run.input_speed());
    let given = (torque.clone(), speed_rpm.clone());
    let torque = if torque.is_empty() { around.torque_edges().to_vec() } else { torque };
    let speed = if speed_rpm.is_empty() {
        around.speed_edges().to_vec()
    } else {
        speed_rpm.iter().map(|&r| planetwear::scene::units::rpm_to_rad_per_s(r)).collect()
    };
    let bins = DutyBins::new(torque, speed).map_err(|e| match e {
        DutyError::Edges { name, value, allowed } => {
            let (flag, list) = if name == "torque_edges" {
                ("--duty-torque-edges", &given.0)
            } else {
                ("--duty-speed-edges", &given.1)
            };
            let value = if list.is_empty() { format!("(the default, {value})") } else { format!("{list:?}") };
            anyhow::anyhow!("{flag} {value}: {allowed}")
        }
        other => other.into(),
    })?;
    Ok(bins)
}

/// Most communication points `simulate` runs and prints.
const MAX_COMMUNICATION_POINTS: f64 = 1e7;

pub(crate) fn run_command(
    RunArgs {
        set: SetArgs { scene, wear_state, accept: AcceptArgs { accept_state_difference } },
        speed,
        json,
        plots,
        method,
        balance,
    }: RunArgs,
) -> Result<()> {
    if !["march", "shooting", "harmonic-balance"].contains(&method.as_str()) {
        bail!("--method {method}: allowed are march, shooting, harmonic-balance");
    }
    let condensed = match balance.as_str() {
        "condensed" => true,
        "full" => false,
        other => bail!("--balance {other}: allowed are condensed, full"),
    };
    if balance != "condensed" && method != "harmonic-balance" {
        bail!("--balance applies to --method harmonic-balance only");
    }
    let (set, run) = validated_with_run(&load_scene(&scene)?)?;
    let mut model = PlanetaryDynamics::new(
        &set,
        contact_model(&set, wear_state.as_deref(), accept_state_difference.as_deref())?,
    )?;
    let omega = speed.map(rpm_to_rad_per_s).unwrap_or(run.input_speed());
    // An implausible speed is said before the run, which may take long.
    if let Some(w) = plausibility::overspeed_at_input(&set, omega) {
        eprintln!("warning: {w}");
    }
    let (ss, solver) = match method.as_str() {
        "march" => (steady_state(&mut model, &set, &run, omega, None)?, None),
        periodic => {
            let method =
                if periodic == "harmonic-balance" && condensed { "condensed-balance" } else { periodic };
            let (ss, line, record) = periodic_point(&model, run.samples_per_mesh_cycle(), omega, method)?;
            (ss, Some((line, record)))
        }
    };
    for f in plausibility::steady_state(&set, &ss).into_iter().filter(|f| f.condition != "overspeed") {
        eprintln!("warning: {}", f.message);
    }
    if let Some(dir) = &plots {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        write_steady_state(&ss, &set, dir)?;
    }
    if json {
        let mut doc = steady_state_json(&ss)?;
        if let Some((_, record)) = solver {
            doc["solver"] = record;
        }
        outln!("{}", serde_json::to_string_pretty(&doc)?)?;
    } else {
        print_steady_state(&ss, set.sun().face_width * 1e3)?;
        if let Some((line, _)) = solver {
            outln!("  {line}")?;
        }
        if model.carrier_frame_speed() != 0.0 {
            outln!(
                "  carrier turning at {:.2} rad/s: steady centrifugal load {:.2} N on each planet bearing \
                 (radially outward, in the dynamics)",
                model.carrier_frame_speed(),
                model.planet_centrifugal_force()
            )?;
        }
    }
    Ok(())
}

/// The periodic steady state at `omega` [rad/s] by shooting or harmonic
/// balance (`method`), measured at `samples` per mesh cycle over one period,
/// a line that says how it was found, and the same as the JSON's `solver`.
fn periodic_point(
    model: &PlanetaryDynamics,
    samples: usize,
    omega: f64,
    method: &str,
) -> Result<(SteadyState, String, serde_json::Value)> {
    use planetwear::dynamics::periodic::{
        all_inside_unit_circle, highest_frequency, HarmonicBalance, HarmonicSettings, PeriodicProblem,
        ShootingSettings, MAX_RULE_HARMONICS,
    };
    let rpm = rad_per_s_to_rpm(omega);
    let settings = ShootingSettings { samples_per_mesh_cycle: samples, ..ShootingSettings::default() };
    let mut problem = PeriodicProblem::new(model.clone(), settings, omega)?;
    if method == "shooting" {
        let orbit = problem.solve(omega, None).with_context(|| format!("shooting at {rpm} rpm"))?;
        let mu = orbit.largest_multiplier();
        let line = format!(
            "shooting: {} Newton iterations, {} flows over the period; largest Floquet multiplier |μ| = {mu:.4} ({})",
            orbit.newton_iterations,
            orbit.flows,
            if orbit.is_stable() { "stable" } else { "unstable: time marching leaves this orbit" }
        );
        let record = serde_json::json!({
            "method": "shooting",
            "newton_iterations": orbit.newton_iterations,
            "flows": orbit.flows,
            "floquet_multipliers": orbit.multipliers.iter().map(|m| [m.re, m.im]).collect::<Vec<_>>(),
            "stable": orbit.is_stable(),
        });
        // The header's Newton iterations are the solver's (the flows' RK 5(4) takes none).
        let mut ss = problem.steady_state(&orbit)?;
        ss.stats.newton_iterations = orbit.newton_iterations as u64;
        return Ok((ss, line, record));
    }
    // The rule's H, and whether MAX_RULE_HARMONICS held it (the line and the record say so).
    let (highest, period) = (highest_frequency(problem.model(), omega), problem.period(omega));
    let settings = HarmonicSettings::for_frequency(highest, period);
    let rule = HarmonicSettings::rule_harmonics(highest, period);
    let held = if rule > settings.harmonics {
        format!(" (the rule's {rule} held at {MAX_RULE_HARMONICS}: docs/PERIODIC.md §2)")
    } else {
        String::new()
    };
    let hb = HarmonicBalance::new(problem, settings).with_context(|| {
        format!("harmonic balance at {rpm} rpm (H from the model's highest natural frequency)")
    })?;
    if method == "condensed-balance" {
        return condensed_point(hb, omega, &held);
    }
    let mut hb = hb;
    let orbit = hb.solve(omega, None).with_context(|| {
        format!(
            "harmonic balance at {rpm} rpm (H = {}); --method shooting or march may find the response",
            settings.harmonics
        )
    })?;
    let multipliers = hb.floquet_multipliers(&orbit, settings.samples)?;
    let mu = multipliers.first().map_or(0.0, |m| m.modulus());
    let stable = all_inside_unit_circle(&multipliers);
    // Where neither the static state nor the march's period led Newton to the orbit, the
    // solve started from a neighbouring speed's orbit: the line says which.
    let neighbour = orbit.neighbour.map(rad_per_s_to_rpm);
    let line = format!(
        "harmonic balance: H = {} harmonics{held}, N = {} samples, {} Newton iterations, {} Jacobians{}{}; \
         largest Floquet multiplier |μ| = {mu:.4} from the orbit's tangents ({})",
        settings.harmonics,
        settings.samples,
        orbit.iterations,
        orbit.factorizations,
        // Beyond the dense LU's size the steps are GMRES's: how many products they took.
        if orbit.products > 0 { format!(" ({} GMRES products)", orbit.products) } else { String::new() },
        neighbour.map_or(String::new(), |r| format!(" (started from the orbit at {r:.1} rpm)")),
        if stable { "stable" } else { "unstable: time marching leaves this orbit" }
    );
    let record = serde_json::json!({
        "method": "harmonic-balance",
        "harmonics": settings.harmonics,
        "rule_harmonics": rule,
        "samples": settings.samples,
        "newton_iterations": orbit.iterations,
        "jacobians": orbit.factorizations,
        "gmres_products": orbit.products,
        "started_from_rpm": neighbour,
        "floquet_multipliers": multipliers.iter().map(|m| [m.re, m.im]).collect::<Vec<_>>(),
        "stable": stable,
    });
    Ok((hb.steady_state(&orbit)?, line, record))
}

/// [`periodic_point`] by the harmonic balance condensed onto the contact coordinates, one
/// planet's meshes where the set and the orbit allow; where its Newton does not converge from
/// the static state, from the full balance's orbit (which starts from the march where it must).
fn condensed_point(
    hb: planetwear::dynamics::periodic::HarmonicBalance,
    omega: f64,
    held: &str,
) -> Result<(SteadyState, String, serde_json::Value)> {
    use planetwear::analysis::condensed_branch::{spectral_harmonics, Checks};
    use planetwear::dynamics::periodic::{
        all_inside_unit_circle, CondensedBalance, Symmetry, CONDENSED_MAX_HARMONICS,
    };
    use planetwear::dynamics::response::Work;
    let rpm = rad_per_s_to_rpm(omega);
    let wanted = *hb.settings();
    let mut cb = CondensedBalance::new(hb, Symmetry::Cyclic);
    let settings = *cb.balance().settings();
    let held = if settings.harmonics < wanted.harmonics {
        format!(
            "{held} (the rule's {} held at {CONDENSED_MAX_HARMONICS} in the condensed balance)",
            wanted.harmonics
        )
    } else {
        held.to_string()
    };
    let (orbit, report, from_full) = match cb.solve(omega, None) {
        Ok((orbit, report)) => (orbit, report, false),
        Err(first) => {
            let full = cb.balance().solve(omega, None).with_context(|| {
                format!(
                    "harmonic balance at {rpm} rpm (H = {}): the condensed balance gave {first}",
                    settings.harmonics
                )
            })?;
            let guess = cb.coordinates_of(&full)?;
            let (orbit, report) = cb.solve(omega, Some(&guess)).with_context(|| {
                format!("condensed harmonic balance at {rpm} rpm from the full balance's orbit")
            })?;
            (orbit, report, true)
        }
    };
    // The harmonics the orbit's own spectrum asks, where the rule's fall short.
    let (rule, jacobians) = (settings.harmonics, orbit.factorizations);
    let mut checks = Checks::default();
    let x = cb.coordinates_of(&orbit)?;
    let orbit = match spectral_harmonics(&mut cb, omega, &x, &mut checks, &mut Work::default())? {
        Some(x) => cb.orbit_at(omega, &x, report.iterations, &mut 0)?,
        None => orbit,
    };
    let settings = *cb.balance().settings();
    let unknowns = report.coordinates * (2 * settings.harmonics + 1);
    // A check that kept the rule's harmonics either found them within the estimate
    // (`passed`) or could not solve at twice them, and the point keeps what it has.
    let spectrum = match (settings.harmonics > rule, checks.count, checks.passed) {
        (true, _, _) => format!(" (its spectrum asked for them: the rule's {rule} checked at twice)"),
        (false, 0, _) => String::new(),
        (false, _, Some(_)) => format!(" (its spectrum checked at {} harmonics: these suffice)", 2 * rule),
        (false, _, None) => format!(
            " (its spectrum asked for more; the solve at {} harmonics failed, so it keeps these)",
            2 * rule
        ),
    };
    let multipliers = cb.balance().floquet_multipliers(&orbit, settings.samples)?;
    let mu = multipliers.first().map_or(0.0, |m| m.modulus());
    let stable = all_inside_unit_circle(&multipliers);
    let meshes = match (&report.symmetry, &report.cyclic_refused) {
        (Symmetry::Cyclic, _) => "planet 1's meshes, the others by the planets' symmetry".to_string(),
        (_, Some(why)) => format!("every mesh ({why})"),
        _ => "every mesh".to_string(),
    };
    let line = format!(
        "harmonic balance condensed onto {} contact coordinates ({meshes}): H = {} harmonics{held}{spectrum}, N = {} \
         samples, {} unknowns, {} Newton iterations, {} Jacobians{}; largest Floquet multiplier |μ| = {mu:.4} of the \
         whole model ({})",
        report.coordinates,
        settings.harmonics,
        settings.samples,
        unknowns,
        report.iterations,
        jacobians,
        if from_full { " (from the full balance's orbit)" } else { "" },
        if stable { "stable" } else { "unstable: time marching leaves this orbit" }
    );
    let record = serde_json::json!({
        "method": "harmonic-balance",
        "balance": "condensed",
        "harmonics": settings.harmonics,
        "rule_harmonics": rule,
        "spectrum_checks": checks.count,
        "samples": settings.samples,
        "contact_coordinates": report.coordinates,
        "unknowns": unknowns,
        "symmetry": report.symmetry,
        "symmetry_residual": report.symmetry_residual,
        "cyclic_refused": report.cyclic_refused,
        "newton_iterations": report.iterations,
        "jacobians": jacobians,
        "from_full_balance": from_full,
        "floquet_multipliers": multipliers.iter().map(|m| [m.re, m.im]).collect::<Vec<_>>(),
        "stable": stable,
    });
    Ok((cb.balance().steady_state(&orbit)?, line, record))
}

pub(crate) fn sweep_command(args: SweepArgs) -> Result<()> {
    match args.method.as_str() {
        "march" if args.max_back.is_some() => bail!("--max-back applies to --method continuation only"),
        "march" if args.against_march => bail!("--against-march applies to --method continuation only"),
        "march" if args.solver.is_some() => bail!("--solver applies to --method continuation only"),
        "march" if args.join => bail!("--join applies to --method continuation only"),
        "march" if args.broken_symmetry => bail!("--broken-symmetry applies to --method continuation only"),
        "march" => {}
        "continuation" => return sweep_continuation(args),
        other => bail!("--method {other}: allowed are march, continuation"),
    }
    let SweepArgs {
        set: SetArgs { scene, wear_state, accept: AcceptArgs { accept_state_difference } },
        from,
        to,
        step,
        direction,
        out,
        histories,
        json,
        ..
    } = args;
    let scene = load_scene(&scene)?;
    let (set, run_settings) = validated_with_run(&scene)?;
    let speeds = speed_grid(from, to, step)?;
    let dirs: Vec<Direction> = match direction.as_str() {
        "up" => vec![Direction::Up],
        "down" => vec![Direction::Down],
        "both" => vec![Direction::Up, Direction::Down],
        other => bail!("--direction {other}: allowed are up, down, both"),
    };
    planetwear::model::cost::sweep(&scene, speeds.len(), dirs.len(), "--from/--to/--step/--direction")
        .map_err(|p| anyhow::anyhow!("{p}"))?;
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    remove_marker(&out.join("sweep.json"))?;
    let model = PlanetaryDynamics::new(
        &set,
        contact_model(&set, wear_state.as_deref(), accept_state_difference.as_deref())?,
    )?;
    let modes = natural_modes(&model.lumped);
    let started = std::time::Instant::now();
    // The core takes rad/s; the report shows each point's speed in rpm as
    // given (rad_per_s_to_rpm returns a speed written in rpm exactly).
    let histories: Vec<f64> = histories.into_iter().map(rpm_to_rad_per_s).collect();
    let results = march_sweeps(&model, (&set, &run_settings), &speeds, &dirs, &histories)?;
    warn_implausible(&results, &set);
    let wall = started.elapsed().as_secs_f64();
    let width_mm = set.sun().face_width * 1e3;
    let files = write_sweeps(&results, &set, &modes, &out)?;
    let peaks: Vec<Peak> = results
        .iter()
        .flat_map(|sw| {
            let mut v = find_peaks(sw, 0, width_mm, &modes, &set);
            v.extend(find_peaks(sw, 1, width_mm, &modes, &set));
            v
        })
        .collect();
    let steps: u64 = results.iter().flat_map(|s| &s.points).map(|p| p.stats.steps).sum();
    let summary = serde_json::json!({
        "scene": set.name(),
        "speeds": speeds.len(),
        "directions": dirs,
        "wall_time_s": wall,
        "internal_steps": steps,
        "steps_per_second": steps as f64 / wall,
        "peaks": peaks,
        "files": files,
    });
    if write_sweep_summary(&out, &summary, json)? {
        return Ok(());
    }
    outln!(
        "swept {} speeds × {} directions in {wall:.2} s ({steps} steps, {:.0} steps/s); {} files in {}",
        speeds.len(),
        dirs.len(),
        steps as f64 / wall,
        files.len(),
        out.display()
    )?;
    for p in &peaks {
        outln!(
            "  peak {:?} {} at {:.0} rpm: F(rms) {:.1} N/mm; {}×f_m = {:.0} Hz ≈ {:?} mode at {:.0} Hz ({:.1} %)",
            p.direction,
            p.mesh.name(),
            rad_per_s_to_rpm(p.speed),
            p.rms_n_per_mm,
            p.harmonic,
            f64::from(p.harmonic) * p.mesh_frequency,
            p.family,
            p.natural_frequency,
            100.0 * p.mismatch
        )?;
    }
    Ok(())
}

/// Writes a sweep's `summary` to sweep.json in `out`, and prints it when `json`: whether
/// it was printed (the text report then is not).
pub(crate) fn write_sweep_summary(out: &Path, summary: &serde_json::Value, json: bool) -> Result<bool> {
    write_atomic(&out.join("sweep.json"), serde_json::to_string_pretty(summary)?.as_bytes())?;
    if json {
        outln!("{}", serde_json::to_string_pretty(summary)?)?;
    }
    Ok(json)
}

/// The marching sweeps over `speeds` [rpm] in each direction of `dirs` (both side by
/// side), each from the static state with its own copy of `model`, under the gear set and
/// run settings `scene`; time histories kept at `histories` [rad/s]. A progress bar over
/// all points.
fn march_sweeps(
    model: &PlanetaryDynamics,
    (set, run_settings): (&GearSet, &RunSettings),
    speeds: &[f64],
    dirs: &[Direction],
    histories: &[f64],
) -> Result<Vec<Sweep>> {
    let bar = progress_bar((speeds.len() * dirs.len()) as u64);
    let run = |d: Direction| {
        let mut m = model.clone();
        let mut grid: Vec<f64> = speeds.iter().copied().map(rpm_to_rad_per_s).collect();
        if d == Direction::Down {
            grid.reverse();
        }
        sweep(set, run_settings, &mut m, d, &grid, histories, |_| bar.inc(1))
    };
    let results: Vec<_> = if dirs.len() == 2 {
        let (a, b) = rayon::join(|| run(Direction::Up), || run(Direction::Down));
        vec![a?, b?]
    } else {
        vec![run(dirs[0])?]
    };
    bar.finish_and_clear();
    Ok(results)
}

/// Warns of each implausible condition once per direction, at the first speed that sets
/// it off.
fn warn_implausible(results: &[Sweep], set: &GearSet) {
    for sw in results {
        let mut said = std::collections::BTreeSet::new();
        for p in &sw.points {
            for f in plausibility::steady_state(set, p) {
                if said.insert(f.condition.clone()) {
                    eprintln!(
                        "warning: sweep {:?}, from {:.1} rpm: {}",
                        sw.direction,
                        rad_per_s_to_rpm(p.input_speed),
                        f.message
                    );
                }
            }
        }
    }
}

/// Each sweep's CSV and kept time histories, and the forced-response charts, written into
/// `out`: the files written.
fn write_sweeps(results: &[Sweep], set: &GearSet, modes: &[Mode], out: &Path) -> Result<Vec<PathBuf>> {
    let width_mm = set.sun().face_width * 1e3;
    let mut files = Vec::new();
    for sw in results {
        let name = if sw.direction == Direction::Up { "sweep_up.csv" } else { "sweep_down.csv" };
        let path = out.join(name);
        write_csv(&path, &sweep_csv(sw, width_mm))?;
        files.push(path);
        for p in sw.points.iter().filter(|p| !p.time.is_empty()) {
            files.extend(write_steady_state(p, set, out)?);
        }
    }
    files.extend(write_forced_response(results, set, modes, out)?);
    Ok(files)
}

pub(crate) fn modes_command(
    ModesArgs { set: SetArgs { scene, wear_state, accept: AcceptArgs { accept_state_difference } }, json }: ModesArgs,
) -> Result<()> {
    let (name, lumped, frame, damping) = match load_any(&scene)? {
        AnyScene::Gear(s) => {
            let (set, run) = validated_with_run(&s)?;
            let mut model = PlanetaryDynamics::new(
                &set,
                contact_model(&set, wear_state.as_deref(), accept_state_difference.as_deref())?,
            )?;
            // The carrier frame at the scene's input speed (a turning carrier only).
            model.set_drive_speed(run.input_speed());
            let frame = (model.carrier_frame_speed(), set.centre_distance());
            (
                set.name().to_string(),
                model.lumped,
                Some(frame).filter(|(w, _)| *w != 0.0),
                Some((set.damping(), set.mesh_damping_ratio())),
            )
        }
        AnyScene::Lumped(_) if wear_state.is_some() => {
            bail!("--wear-state: a lumped-parameter scene has no tooth flanks to wear")
        }
        AnyScene::Lumped(s) => (s.name.clone(), s.validate()?, None, None),
    };
    report_modes(&name, &lumped, frame, damping, json)?;
    Ok(())
}

pub(crate) fn ltca_command(
    LtcaArgs {
        set: SetArgs { scene, wear_state, accept: AcceptArgs { accept_state_difference } },
        torque,
        samples,
        json,
        out,
        plots,
    }: LtcaArgs,
) -> Result<()> {
    let mut scene = load_scene(&scene)?;
    if let Some(t) = torque {
        scene.operation.input_torque_nm = t;
    }
    if let Some(n) = samples {
        scene.analysis.positions_per_mesh_cycle = n as u32;
    }
    let set = validated(&scene)?;
    // The same check `scene check` reports, naming where the torque was written.
    let key = if torque.is_some() { "--torque" } else { "operation.input_torque_nm" };
    planetwear::model::cost::ltca_torque(set.input_torque(), key).map_err(|p| anyhow::anyhow!("{p}"))?;
    let state = match &wear_state {
        Some(path) => Some(read_state("--wear-state", path, &set, accept_state_difference.as_deref())?),
        None => None,
    };
    let model = state.as_ref().map_or_else(|| SetModel::new(&set), |s| s.set_model(&set));
    let kappa = state.as_ref().map(|s| s.kappa);
    let study = LtcaStudy::run_on(&set, &model, set.analysis().positions_per_mesh_cycle, kappa);
    let doc = study.to_json();
    let text = serde_json::to_string_pretty(&doc)?;
    if let Some(path) = &out {
        write_atomic(path, text.as_bytes()).map_err(anyhow::Error::from)?;
    }
    if let Some(dir) = &plots {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let files = study.write_plots(dir).map_err(anyhow::Error::from)?;
        if !json {
            outln!("wrote {} plot files to {}", files.len(), dir.display())?;
        }
    }
    if json {
        outln!("{text}")?;
    } else {
        print_summary(&doc)?;
    }
    Ok(())
}

pub(crate) fn print_steady_state(ss: &SteadyState, width_mm: f64) -> Result<()> {
    outln!(
        "steady state at {:.1} rpm (mesh frequency {:.1} Hz, {} mesh cycle{}; {} steps, {} Newton iterations)",
        rad_per_s_to_rpm(ss.input_speed),
        ss.mesh_frequency,
        ss.cycles,
        if ss.cycles == 1 { "" } else { "s" },
        ss.stats.steps,
        ss.stats.newton_iterations
    )?;
    outln!(
        "  {:<16} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7}",
        "mesh",
        "mean",
        "F1",
        "F2",
        "F3",
        "F4",
        "F5",
        "F6",
        "rms",
        "sep"
    )?;
    for m in &ss.meshes {
        let h = &m.harmonics;
        out!(
            "  planet {} {:<7} {:>9.2}",
            m.planet + 1,
            format!("{:?}", m.mesh).replace("Planet", ""),
            h.mean / width_mm
        )?;
        for a in &h.amplitude {
            out!(" {:>9.2}", a / width_mm)?;
        }
        outln!(" {:>9.2} {:>7.3}", h.rms / width_mm, m.separation)?;
    }
    outln!("  (forces in N/mm of face width)")?;
    Ok(())
}

/// Prints the natural modes of `set`; with `frame` = (Ω_c [rad/s], r_c \[m\])
/// of a turning carrier also the whirl frequencies at that carrier speed and
/// the planets' centrifugal bearing load; with `damping` = (the scene's
/// damping model, its mesh damping ratio [-]) the Rayleigh coefficients of
/// the two-frequency rule at that ratio on the first two rotational modes,
/// and under Rayleigh damping each mode's ratio μ/(2ω) + ηω/2.
pub(crate) fn report_modes(
    name: &str,
    set: &LumpedSet,
    frame: Option<(f64, f64)>,
    damping: Option<(Damping, f64)>,
    json: bool,
) -> Result<()> {
    let modes = natural_modes(set);
    let rule = damping.and_then(|(_, zeta)| rayleigh_rule(&modes, zeta));
    let ratio = |f: f64| damping.and_then(|(d, _)| d.rayleigh_ratio(2.0 * std::f64::consts::PI * f));
    let red = set.reduction();
    let whirl = frame.map(|(w, rc)| (w, set.planet_mass * w * w * rc, rotating_modes(set, w, rc)));
    if json {
        let mut doc = serde_json::json!({
            "scene": name,
            "fidelity": set.fidelity,
            "held": set.held,
            "mean_mesh_stiffness": {"sun_planet": set.sun_mesh, "ring_planet": set.ring_mesh},
            "coordinates": red.coordinates.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>(),
            "modes": modes,
            "rayleigh_two_frequency_rule": rule,
        });
        // Each mode's ratio μ/(2ω) + ηω/2, under Rayleigh damping only.
        if modes.iter().any(|m| ratio(m.frequency.max(1.0)).is_some()) {
            doc["rayleigh_mode_damping_ratios"] = serde_json::json!(modes
                .iter()
                .map(|m| ratio(m.frequency).filter(|z| z.is_finite()))
                .collect::<Vec<_>>());
        }
        if let Some((w, load, whirl)) = &whirl {
            doc["carrier_frame"] = serde_json::json!({
                "carrier_speed_rad_per_s": w,
                "planet_centrifugal_load_n": load,
                "whirl_modes": whirl,
            });
        }
        outln!("{}", serde_json::to_string_pretty(&doc)?)?;
        return Ok(());
    }
    outln!(
        "natural modes of {name} ({:?}, held {:?}); mean mesh stiffness sun–planet {:.4e} N/m, ring–planet {:.4e} N/m",
        set.fidelity, set.held, set.sun_mesh, set.ring_mesh
    )?;
    let rayleigh = modes.first().and_then(|m| ratio(m.frequency.max(1.0))).is_some();
    if rayleigh {
        outln!("  {:>12}  {:<14} {:>12} {:>12}", "frequency Hz", "class", "multiplicity", "ζ Rayleigh")?;
    } else {
        outln!("  {:>12}  {:<14} {:>12}", "frequency Hz", "class", "multiplicity")?;
    }
    let mut i = 0;
    while i < modes.len() {
        let m = &modes[i];
        let class = match m.class {
            ModeClass::RigidBody => "rigid body",
            ModeClass::Rotational => "rotational",
            ModeClass::Translational => "translational",
            ModeClass::Planet => "planet",
            ModeClass::Mixed => "mixed",
        };
        match ratio(m.frequency).filter(|z| z.is_finite() && m.class != ModeClass::RigidBody) {
            Some(z) => outln!("  {:>12.1}  {:<14} {:>12} {:>12.4}", m.frequency, class, m.multiplicity, z)?,
            None => outln!("  {:>12.1}  {:<14} {:>12}", m.frequency, class, m.multiplicity)?,
        }
        i += m.multiplicity.max(1);
    }
    if let Some(r) = rule {
        outln!(
            "Rayleigh damping by the two-frequency rule, ζ = {} (dynamics.mesh_damping_ratio) at the rotational \
             modes {:.1} and {:.1} Hz: rayleigh_mass_per_s = {:.6e}, rayleigh_stiffness_s = {:.6e}",
            r.zeta, r.frequencies[0], r.frequencies[1], r.mass_per_s, r.stiffness_s
        )?;
    }
    if let Some((w, load, whirl)) = &whirl {
        outln!(
            "carrier turning at {w:.2} rad/s ({:.1} rpm): planet centrifugal bearing load {load:.2} N; \
             frequencies with the gyroscopic and centripetal terms:",
            rad_per_s_to_rpm(*w)
        )?;
        outln!("  {:>12}  {:>14}", "frequency Hz", "growth 1/s")?;
        for m in whirl {
            outln!("  {:>12.1}  {:>14.3e}", m.frequency, m.growth_rate)?;
        }
    }
    Ok(())
}

pub(crate) fn print_summary(doc: &serde_json::Value) -> Result<()> {
    let width_mm = doc["face_width"].as_f64().unwrap_or(1.0) * 1e3;
    outln!(
        "LTCA of {} at {} N·m (κ = {})",
        doc["scene"].as_str().unwrap_or("?"),
        doc["input_torque"],
        doc["kappa"]
    )?;
    for m in doc["meshes"].as_array().into_iter().flatten() {
        let f = |k: &str| m[k].as_f64().unwrap_or(f64::NAN);
        let g = |k: &str, s: &str| m[k][s].as_f64().unwrap_or(f64::NAN);
        outln!("  {}:", m["name"].as_str().unwrap_or("?"))?;
        outln!("    load {:.1} N/mm along the line of action", f("load") / width_mm)?;
        outln!(
            "    contact ratio: nominal {:.4}, on the involutes {:.4}, loaded {:.4} (1 pair {:.1} %, 2 pairs {:.1} %, 3 pairs {:.1} %)",
            f("contact_ratio_nominal"),
            f("contact_ratio_involute"),
            f("contact_ratio_loaded"),
            100.0 * m["pairs_in_contact_fraction"]["1"].as_f64().unwrap_or(0.0),
            100.0 * m["pairs_in_contact_fraction"]["2"].as_f64().unwrap_or(0.0),
            100.0 * m["pairs_in_contact_fraction"]["3"].as_f64().unwrap_or(0.0),
        )?;
        let k = |v: f64| v / width_mm * 1e-6;
        outln!(
            "    mesh stiffness N/(mm·µm): nominal mean {:.3} p-p {:.3}; loaded mean {:.3} p-p {:.3}; ISO c_γα {:.3}",
            k(g("mesh_stiffness_nominal", "mean")),
            k(g("mesh_stiffness_nominal", "peak_to_peak")),
            k(g("mesh_stiffness_loaded", "mean")),
            k(g("mesh_stiffness_loaded", "peak_to_peak")),
            m["iso6336"]["mesh_stiffness_per_width_N_per_mm_um"].as_f64().unwrap_or(f64::NAN),
        )?;
        outln!(
            "    static TE: mean {:.3} µm, peak-to-peak {:.3} µm; peak Hertz pressure {:.0} MPa, half-width up to {:.1} µm",
            g("static_transmission_error", "mean") * 1e6,
            g("static_transmission_error", "peak_to_peak") * 1e6,
            f("peak_hertz_pressure") * 1e-6,
            f("max_hertz_half_width") * 1e6,
        )?;
    }
    let p = &doc["planets"];
    let loads: Vec<String> = p["mean_load"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|v| format!("{:.2}", v.as_f64().unwrap_or(f64::NAN) / width_mm))
        .collect();
    outln!(
        "  planets: mean loads {} N/mm, load sharing factor {:.4}; sun rotation along the line of action peak-to-peak {:.3} µm",
        loads.join(", "),
        p["load_sharing_factor"].as_f64().unwrap_or(f64::NAN),
        p["sun_transmission_error"]["peak_to_peak"].as_f64().unwrap_or(f64::NAN) * 1e6
    )?;
    Ok(())
}

/// A steady state as JSON with its meshes' planets numbered from 1, as the
/// FMU's planet[1]… and every table and plot of the tool (docs/FMU.md).
fn steady_state_json(ss: &SteadyState) -> Result<serde_json::Value> {
    let mut doc = serde_json::to_value(ss)?;
    if let Some(meshes) = doc.get_mut("meshes").and_then(serde_json::Value::as_array_mut) {
        for m in meshes {
            if let Some(p) = m.get("planet").and_then(serde_json::Value::as_u64) {
                m["planet"] = (p + 1).into();
            }
        }
    }
    Ok(doc)
}
