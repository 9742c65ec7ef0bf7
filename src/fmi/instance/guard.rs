//! The numerical guards of fmi2DoStep (docs/LIMITS.md): before a step, a
//! step that would take more internal steps than one step may, or a
//! torque that would drive a member past the speed limit within the step, is
//! refused at once with the figure (instead of the integrator shrinking its
//! steps for seconds); after a step, a state that is not finite or has a
//! member past the speed limit is refused rather than reported as fmi2OK.

use crate::dynamics::simulation::{Simulation, MAX_INTERNAL_STEPS};
use crate::model::gear::{Member, MeshKind};

/// Fastest a member may turn \[rad/s\]: 1e6 rpm, the scene's limit of the
/// input speed. A state past it is not a gear set running but an overflow.
pub const MAX_MEMBER_SPEED: f64 = 1.0e6 * std::f64::consts::PI / 30.0;

const MEMBERS: [(Member, &str, usize); 3] =
    [(Member::Sun, "sun", 0), (Member::Ring, "ring", 1), (Member::Carrier, "carrier", 2)];

/// Refuses a step of `h` seconds in which a torque alone would change its
/// member's speed by more than [`MAX_MEMBER_SPEED`]: |T| h / J with J the
/// member's own inertia (`torques` on sun, ring, carrier \[N·m\]).
pub fn before_step(sim: &Simulation, torques: [f64; 3], h: f64) -> Result<(), String> {
    // A step size that is not a number of seconds is the simulation's to
    // refuse (fmi2Error: the call is wrong, not the step too hard).
    if !(h.is_finite() && h > 0.0) {
        return Ok(());
    }
    // A step longer than the work one step may take is discarded at once
    // with the figure and the longest step that would be taken.
    let steps = sim.internal_steps(h);
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(steps <= MAX_INTERNAL_STEPS as f64) {
        return Err(format!(
            "communicationStepSize = {h:e} s needs {steps:.3e} internal steps, more than the {MAX_INTERNAL_STEPS} \
             one communication step may take: take steps of at most {:.3e} s",
            h * MAX_INTERNAL_STEPS as f64 / steps
        ));
    }
    let set = sim.gear_set();
    let b = set.bodies();
    for (member, name, i) in MEMBERS {
        if member == set.held() {
            continue;
        }
        let inertia = match member {
            Member::Sun => b.sun.inertia,
            Member::Ring => b.ring.inertia,
            Member::Carrier => b.carrier.inertia,
        };
        let change = torques[i].abs() * h / inertia;
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(change <= MAX_MEMBER_SPEED) {
            return Err(format!(
                "{name}Torque = {:e} N·m would change the {name}'s speed by {change:.3e} rad/s within the \
                 step of {h:e} s (inertia {inertia:.4e} kg·m²), past the limit of {MAX_MEMBER_SPEED:.4e} rad/s \
                 (1e6 rpm): refused before integrating",
                torques[i]
            ));
        }
    }
    Ok(())
}

/// Refuses the state a step reached when a speed or a mesh force is not
/// finite or a member turns faster than [`MAX_MEMBER_SPEED`].
pub fn after_step(sim: &Simulation) -> Result<(), String> {
    for (member, name, _) in MEMBERS {
        let w = sim.speed(member);
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(w.abs() <= MAX_MEMBER_SPEED) {
            return Err(format!(
                "the {name}'s speed reached {w:e} rad/s at t = {} s, past the limit of {MAX_MEMBER_SPEED:.4e} rad/s \
                 (1e6 rpm): the state overflowed",
                sim.time()
            ));
        }
    }
    for p in 0..sim.gear_set().planet_angles().len() {
        for (mesh, name) in [(MeshKind::SunPlanet, "sun"), (MeshKind::RingPlanet, "ring")] {
            let f = sim.mesh_force(p, mesh);
            if !f.is_finite() {
                return Err(format!(
                    "planet[{}].{name}MeshForce is {f} at t = {} s: the state is not finite",
                    p + 1,
                    sim.time()
                ));
            }
        }
    }
    Ok(())
}
