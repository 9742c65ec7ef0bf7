//! The energy balance of a dynamic model along a fixed-step run: kinetic +
//! support + contact energy changes by the work of the external forces and
//! of the time-varying contact law, less what the damping takes. Used by
//! tests/rayleigh.rs and tests/deformable_dynamics.rs.

use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::solver::{GeneralizedAlpha, GeneralizedAlphaSettings, SecondOrderSystem};

/// The balance over a run.
pub struct Balance {
    /// Largest |E(t) − E(0) − work(t)| over the run \[J\].
    pub worst: f64,
    /// Energy the damping took \[J\].
    pub dissipated: f64,
    /// Largest contact energy over the run \[J\].
    pub contact: f64,
}

impl Balance {
    /// Prints the balance and asserts that it closes to 1e-3 of the contact
    /// energy and that the damping took more than ten times its error
    /// (leaving the damping out would break the balance).
    pub fn assert_closes(&self) {
        let Balance { worst, dissipated, contact } = self;
        eprintln!(
            "energy balance error {worst:e} J, dissipated {dissipated:e} J, contact energy {contact:e} J"
        );
        assert!(*worst < 1e-3 * contact, "balance error {worst} vs contact energy {contact}");
        assert!(
            *dissipated > 10.0 * worst,
            "the damping took {dissipated} J only, against the balance error {worst} J"
        );
    }
}

/// Runs `model` from its static state at `rpm` with generalized-α (ρ∞ = 1,
/// tolerances 1e-14) at `steps_per_cycle` steps per mesh cycle for `cycles`
/// mesh cycles, integrating the work rates by the trapezoidal rule; the
/// damping's power is the force's change with the velocities, −(f(q, v) −
/// f(q, 0))·v.
pub fn energy_balance(model: &mut PlanetaryDynamics, rpm: f64, steps_per_cycle: u64, cycles: u64) -> Balance {
    let n = model.dim();
    let omega = rpm * std::f64::consts::PI / 30.0;
    let start = planetwear::dynamics::response::static_state(model, omega);
    let fm = model.mesh_frequency_per_input_speed * omega;
    let mut settings = GeneralizedAlphaSettings::chung_hulbert(1.0).unwrap();
    settings.rtol = 1e-14;
    settings.atol = 1e-15;
    let mut ga = GeneralizedAlpha::new(settings).unwrap();
    ga.init(model, 0.0, &start.q, &start.v).unwrap();
    let h = 1.0 / fm / steps_per_cycle as f64;
    let zeros = vec![0.0; n];
    let (mut fv, mut f0) = (vec![0.0; n], vec![0.0; n]);
    let mut rates = |m: &mut PlanetaryDynamics, t: f64, q: &[f64], v: &[f64]| {
        m.force(t, q, &zeros, &mut f0);
        m.force(t, q, v, &mut fv);
        let dissipated: f64 = -fv.iter().zip(&f0).zip(v).map(|((a, b), v)| (a - b) * v).sum::<f64>();
        let (k, s, c, p) = m.energy(t, q, v);
        (k + s + c, p + m.external_power(v) - dissipated, c, dissipated)
    };
    let (q, v) = (ga.q().to_vec(), ga.v().to_vec());
    let (e0, mut p_prev, _, mut d_prev) = rates(model, 0.0, &q, &v);
    let (mut work, mut lost, mut worst, mut contact) = (0.0, 0.0, 0.0_f64, 0.0_f64);
    for k in 1..=steps_per_cycle * cycles {
        let t = k as f64 * h;
        ga.advance(model, t, 1).unwrap();
        let (q, v) = (ga.q().to_vec(), ga.v().to_vec());
        let (e, p, c, d) = rates(model, t, &q, &v);
        work += 0.5 * h * (p + p_prev);
        lost += 0.5 * h * (d + d_prev);
        (p_prev, d_prev) = (p, d);
        contact = contact.max(c);
        worst = worst.max((e - e0 - work).abs());
    }
    Balance { worst, dissipated: lost, contact }
}
