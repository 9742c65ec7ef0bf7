//! Where the FMU's doStep spends its time with the adaptive integrator at
//! 3000 rpm: the loop of `Simulation::do_step` (RK 5(4) steps up to the
//! communication point, dense output at the internal grid points (`steps_per_mesh_cycle`)
//! of each mesh cycle, a force evaluation there for the step extremes and the harmonic
//! window) rebuilt on the public API, with the model wrapped to count and
//! time its force and event-function evaluations. One communication step of
//! one mesh cycle, 0.05 s simulated, in three configurations: the former
//! absolute tolerances (1e-6 m and 1e-3 m/s per unit of relative tolerance)
//! at the scene's relative tolerance (3e-6); the simulation's absolute
//! tolerances (the static mesh deflection, and that times the mesh angular
//! frequency, per unit of relative tolerance) at 3e-6; and the FMU's
//! default, the simulation's own tolerance (`simulation_relative_tolerance`,
//! 1e-5) with the error weight measured from the rigid-body motion anchored
//! at the start of every communication step. On `example-2004`, the FMU's
//! default scene.
//! Run: `cargo bench --bench fmu_step_profile` (docs/PERFORMANCE.md records the figures).

use std::time::Instant;

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::static_state;
use planetwear::dynamics::solver::{RelativeOrigin, Rk45, Rk45Settings, SecondOrderSystem};
use planetwear::scene::{Fidelity, Scene};

/// The model, its evaluations counted and timed.
struct Counted<'a> {
    model: &'a mut PlanetaryDynamics,
    forces: u64,
    events: u64,
    force_time: f64,
    event_time: f64,
}

impl SecondOrderSystem for Counted<'_> {
    fn dim(&self) -> usize {
        self.model.dim()
    }

    fn mass(&self) -> &[f64] {
        self.model.mass()
    }

    fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        let start = Instant::now();
        self.model.force(t, q, v, f);
        self.force_time += start.elapsed().as_secs_f64();
        self.forces += 1;
    }

    fn events(&mut self, t: f64, q: &[f64], v: &[f64], out: &mut Vec<f64>) {
        let start = Instant::now();
        self.model.events(t, q, v, out);
        self.event_time += start.elapsed().as_secs_f64();
        self.events += 1;
    }
}

/// The integrator's tolerances.
#[derive(Clone, Copy, PartialEq)]
enum Tolerances {
    /// The scene's relative tolerance, absolute tolerances 1e-6 m and 1e-3 m/s per unit of it.
    FormerFixed,
    /// The scene's relative tolerance, absolute tolerances from the static deflection.
    DeflectionScaled,
    /// The FMU's default: the simulation's relative tolerance, deflection-scaled absolute
    /// tolerances, the relative part measured from the rigid-body motion.
    Simulation,
}

fn profile(fidelity: Fidelity, tolerances: Tolerances) {
    let mut scene = Scene::example_2004();
    scene.dynamics.fidelity = fidelity;
    let (set, run) = scene.validate_with_run().expect("valid");
    let mut model = PlanetaryDynamics::new(&set, SetModel::new(&set)).expect("model");
    let omega = 3000.0 * std::f64::consts::PI / 30.0;
    let fm = model.mesh_frequency_per_input_speed * omega;
    // As `Simulation::new` starts.
    let start = static_state(&model, omega);
    let torques = set.balanced_torques();
    model.set_torques(torques[0], torques[1], torques[2]);
    model.set_drive_speed(omega);
    model.rebase_drive(&start.q);
    let n = model.dim();
    let mut f = vec![0.0; n];
    model.force(0.0, &start.q, &start.v, &mut f);
    let deflection = model.meshes.iter().fold(0.0_f64, |a, m| a.max(m.approach.abs()));
    let rtol = if tolerances == Tolerances::Simulation {
        run.simulation_relative_tolerance()
    } else {
        run.relative_tolerance()
    };
    let (atol_q, atol_v) = if tolerances == Tolerances::FormerFixed {
        (rtol * 1e-6, rtol * 1e-3)
    } else {
        (rtol * deflection, rtol * deflection * 2.0 * std::f64::consts::PI * fm)
    };
    let rigid = model.rigid_velocity_at(omega);
    let settings = Rk45Settings { rtol, atol_q, atol_v, max_step: 0.25 / fm, ..Rk45Settings::default() };
    let mut r = Rk45::new(settings).expect("settings");
    let mut sys = Counted { model: &mut model, forces: 0, events: 0, force_time: 0.0, event_time: 0.0 };
    r.init(&mut sys, 0.0, &start.q, &start.v).expect("start");
    let (forces0, events0, stats0) = (sys.forces, sys.events, *r.stats());
    let (force_time0, event_time0) = (sys.force_time, sys.event_time);
    let cycles = 85_u64;
    let points = run.steps_per_mesh_cycle() as u64;
    let h = 1.0 / fm;
    let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
    let (mut stepping, mut dense, mut observing) = (0.0, 0.0, 0.0);
    let mut checksum = 0.0;
    let wall = Instant::now();
    for c in 0..cycles {
        let t0 = c as f64 * h;
        let end = t0 + h;
        if tolerances == Tolerances::Simulation {
            // As `Simulation::do_step` anchors the error weight's origin.
            let origin = RelativeOrigin { t_anchor: t0, q_anchor: r.q().to_vec(), rate: rigid.clone() };
            r.set_relative_origin(Some(origin)).expect("origin");
        }
        for k in 1..=points {
            let tk = if k == points { end } else { t0 + h * k as f64 / points as f64 };
            let a = Instant::now();
            while r.time() < tk {
                r.step(&mut sys, end).expect("step");
            }
            stepping += a.elapsed().as_secs_f64();
            let a = Instant::now();
            r.dense_at(tk, &mut q, &mut v).expect("dense output");
            dense += a.elapsed().as_secs_f64();
            let a = Instant::now();
            sys.model.force(tk, &q, &v, &mut f);
            checksum += sys.model.meshes[0].force;
            observing += a.elapsed().as_secs_f64();
        }
    }
    let total = wall.elapsed().as_secs_f64();
    let stats = r.stats();
    let per = |x: u64| x as f64 / cycles as f64;
    let us = |x: f64| x / cycles as f64 * 1e6;
    let forces = sys.forces - forces0;
    let events = sys.events - events0;
    let (force_time, event_time) = (sys.force_time - force_time0, sys.event_time - event_time0);
    let tolerances = match tolerances {
        Tolerances::FormerFixed => "former fixed absolute tolerances",
        Tolerances::DeflectionScaled => "deflection-scaled absolute tolerances",
        Tolerances::Simulation => "the FMU's default: deflection-scaled, weight from the rigid motion,",
    };
    println!(
        "{fidelity:?}, rtol {rtol:e}, {tolerances} ({atol_q:.1e} m, {atol_v:.1e} m/s): \
         {:.1} µs per mesh cycle (checksum {checksum:.3e})",
        us(total)
    );
    println!(
        "  per mesh cycle: {:.1} accepted steps, {:.1} rejected, {:.1} events located",
        per(stats.steps - stats0.steps),
        per(stats.rejected_steps - stats0.rejected_steps),
        per(stats.events_located - stats0.events_located)
    );
    println!(
        "  integrator's force evaluations: {:.1} per cycle, {:.1} µs ({:.2} µs each)",
        per(forces),
        us(force_time),
        force_time / forces as f64 * 1e6
    );
    println!(
        "  event-function evaluations (step ends, location): {:.1} per cycle, {:.1} µs ({:.2} µs each)",
        per(events),
        us(event_time),
        event_time / events.max(1) as f64 * 1e6
    );
    println!(
        "  rest of the integrator (stages, error norm, controller): {:.1} µs",
        us(stepping - force_time - event_time)
    );
    println!(
        "  dense output at {points} points: {:.1} µs; observation force evaluations at {points} points: {:.1} µs",
        us(dense),
        us(observing)
    );
}

fn main() {
    for fidelity in [Fidelity::Torsional, Fidelity::TransverseTorsional] {
        for tolerances in [Tolerances::FormerFixed, Tolerances::DeflectionScaled, Tolerances::Simulation] {
            profile(fidelity, tolerances);
        }
    }
}
