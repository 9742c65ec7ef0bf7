//! Where the FMU's doStep spends its time with the adaptive integrator at
//! 3000 rpm: the loop of `Simulation::do_step` (RK 5(4) steps up to the
//! communication point, dense output at the 120 internal grid points per mesh
//! cycle, a force evaluation there for the step extremes and the harmonic
//! window) rebuilt on the public API, with the model wrapped to count and
//! time its force and event-function evaluations. One communication step of
//! one mesh cycle, 0.05 s simulated, for the former absolute tolerances
//! (1e-6 m and 1e-3 m/s per unit of relative tolerance) and the
//! simulation's (the static mesh deflection, and that times the mesh angular
//! frequency, per unit of relative tolerance).
//! Run: `cargo bench --bench fmu_step_profile` (docs/PERFORMANCE.md records the figures).

use std::time::Instant;

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::response::static_state;
use planetwear::dynamics::solver::{Rk45, Rk45Settings, SecondOrderSystem};
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

fn profile(fidelity: Fidelity, scaled: bool) {
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
    let rtol = run.relative_tolerance();
    let (atol_q, atol_v) = if scaled {
        (rtol * deflection, rtol * deflection * 2.0 * std::f64::consts::PI * fm)
    } else {
        (rtol * 1e-6, rtol * 1e-3)
    };
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
    let tolerances = if scaled { "deflection-scaled" } else { "former fixed" };
    println!(
        "{fidelity:?}, rtol {rtol:e}, {tolerances} absolute tolerances ({atol_q:.1e} m, {atol_v:.1e} m/s): \
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
        for scaled in [false, true] {
            profile(fidelity, scaled);
        }
    }
}
