//! Wear per cycle of the unworn example from the quasi-static and from the
//! dynamic tooth loads, at an off-resonance (3000 rpm) and a resonant speed
//! (5000 rpm: 2×f_m on the 5693 Hz rotational mode), or at the speeds given;
//! each against the same dynamic model at 100 rpm (its low-speed limit) too.
//!
//! cargo run --release --example dynamic_wear [-- [--profiles] rpm ...]

use planetwear::model::gear::MeshKind;
use planetwear::scene::units::rpm_to_rad_per_s;
use planetwear::scene::Scene;
use planetwear::wear::archard::WearSettings;
use planetwear::wear::compare::compare_sources;
use planetwear::wear::flank::Flank;
use planetwear::wear::stepper::dynamic_cycle;
use planetwear::wear::stepper::WearModel;

/// Speed of the low-speed reference run [rpm].
const LOW_SPEED_RPM: f64 = 100.0;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let profiles = args.iter().any(|a| a == "--profiles");
    let mut speeds: Vec<f64> =
        args.iter().filter(|a| *a != "--profiles").map(|a| a.parse()).collect::<Result<_, _>>()?;
    if speeds.is_empty() {
        speeds = vec![3000.0, 5000.0];
    }
    let (set, run) = Scene::example_2004_stiff_pins().validate_with_run()?;
    let wear = WearModel::with_run(&set, &run, WearSettings::for_set(&set))?;
    let state = wear.unworn();
    let face_mm = set.sun().face_width.min(set.planet().face_width) * 1e3;
    println!(
        "example-2004-stiff-pins ({:?}), unworn (κ = 0), R = {}, k = {:e} m²/N; wear per tooth cycle [pm], mean over the planets",
        set.fidelity(),
        wear.settings().positions,
        wear.settings().archard_coefficient
    );
    let (low, _) = dynamic_cycle(&wear, &state, rpm_to_rad_per_s(LOW_SPEED_RPM))?;
    let low_max = |flank: Flank| low.flank(flank, 0).map_or(f64::NAN, |f| f.max_wear().0);
    for rpm in speeds {
        let started = std::time::Instant::now();
        let c = compare_sources(&wear, &state, rpm_to_rad_per_s(rpm))?;
        let l = &c.loads;
        println!(
            "\n{rpm} rpm: f_m = {:.1} Hz, {} mesh cycles × {} samples averaged, {} steps, {:.1} s",
            l.mesh_frequency,
            l.cycles,
            l.samples_per_cycle,
            l.stats.steps,
            started.elapsed().as_secs_f64()
        );
        for m in &c.meshes {
            println!(
                "  {}: F(mean) {:.1} N/mm, F(rms) {:.1} N/mm; largest pair load quasi-static {:.1} N/mm, \
                 dynamic {:.1} N/mm ({:.3}×)",
                mesh_name(m.mesh),
                m.mean_mesh_force / face_mm,
                m.rms_mesh_force / face_mm,
                m.quasi_static_max_pair_load / face_mm,
                m.dynamic_max_pair_load / face_mm,
                m.dynamic_max_pair_load / m.quasi_static_max_pair_load,
            );
        }
        for f in &c.flanks {
            println!(
                "  {}: largest wear/cycle quasi-static {:.4} pm at {:.2}°, dynamic {:.4} pm at {:.2}°; \
                 dynamic/quasi-static {:.3}, dynamic/dynamic at {LOW_SPEED_RPM} rpm {:.3}; \
                 largest pointwise difference {:.1} % of the quasi-static maximum",
                f.flank.name(),
                f.quasi_static_max * 1e12,
                f.quasi_static_max_roll.to_degrees(),
                f.dynamic_max * 1e12,
                f.dynamic_max_roll.to_degrees(),
                f.ratio,
                f.dynamic_max / low_max(f.flank),
                100.0 * f.largest_difference
            );
        }
        if profiles {
            for f in &c.flanks {
                let slow = low.flank(f.flank, f.slice).map(|w| &w.wear_per_cycle);
                println!(
                    "  {} profile: roll [°], quasi-static, dynamic, dynamic at {LOW_SPEED_RPM} rpm [pm]",
                    f.flank.name()
                );
                for (i, ((r, q), d)) in f.roll.iter().zip(&f.quasi_static).zip(&f.dynamic).enumerate() {
                    let s = slow.and_then(|w| w.get(i)).copied().unwrap_or(f64::NAN);
                    println!("    {:6.2} {:8.4} {:8.4} {:8.4}", r.to_degrees(), q * 1e12, d * 1e12, s * 1e12);
                }
            }
        }
    }
    Ok(())
}

fn mesh_name(m: MeshKind) -> &'static str {
    match m {
        MeshKind::SunPlanet => "sun–planet",
        MeshKind::RingPlanet => "ring–planet",
    }
}
