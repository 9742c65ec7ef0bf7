//! Stage 2, model: what the gear set is. A validated, immutable description
//! in SI units (radians, metres, newtons, kilograms) built from a validated
//! [`crate::scene`]: the tooth forms, the bodies, the supports, the
//! material, the lumped description of the degrees of freedom, and the
//! elementary involute geometry that proves a description feasible (the
//! path of contact and its contact ratio, the form circle where the root
//! fillet begins).
//!
//! May import: [`crate::files`], [`crate::scene`].
//!
//! - [`build`]: the scene's rules, and the gear set built from a valid scene.
//! - [`carrier_frame`]: the gyroscopic and centripetal terms of coordinates
//!   that turn with the carrier, as matrices and as forces.
//! - [`cost`]: what a scene's runs will cost (memory, internal steps) and
//!   the budgets `build` holds them to.
//! - [`gear`]: tooth forms, bodies, supports, material, the gear set (with
//!   the terms of its equations of motion: fidelity, damping, drive).
//! - [`gear_data`]: gears given by gear data (ISO 21771) turned into radii,
//!   the operating pressure angle of shifted pairs, undercut and trochoid
//!   interference limits.
//! - [`involute`]: the involute function and its inverse relations.
//! - [`kinematics`]: teeth, members, balanced torques per unit input torque
//!   and mesh cycles per input revolution, for the front ends.
//! - [`lumped`]: degrees of freedom, fidelity, the lumped (mean-stiffness) set.
//! - [`mesh`]: the path of contact of one mesh along its line of action.
//! - [`planet_bearing`]: a planet's support stiffness from its needle
//!   bearing (Palmgren, Stribeck) and its pin between the carrier plates.
//! - [`run`]: the run settings (integrator, tolerances, windows, samples,
//!   the input speed of a single run), a value apart from the gear set.

pub mod build;
pub mod carrier_frame;
pub mod cost;
pub mod gear;
pub mod gear_data;
pub mod involute;
pub mod kinematics;
pub mod lumped;
pub mod mesh;
pub mod planet_bearing;
pub mod run;
