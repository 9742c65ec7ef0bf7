//! What a gear set's users need of its kinematics and statics without the
//! dynamics: teeth, members, the balanced torques per unit input torque and
//! the mesh cycles per input revolution. The front ends that drive the FMU
//! from outside (the Python package) read it here (`planetwear scene show
//! --json`, and beside each scene the packed FMU ships) instead of deriving
//! it again.

use serde::Serialize;

use crate::model::cost::mesh_cycles_per_revolution;
use crate::model::gear::{GearSet, Member};

/// The kinematics and statics of a gear set, SI.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Kinematics {
    /// Teeth of sun, planet and ring.
    pub teeth: [u32; 3],
    /// Number of planets.
    pub planets: usize,
    /// The held member.
    pub held: Member,
    /// The input member.
    pub input: Member,
    /// The output member.
    pub output: Member,
    /// The scene's input torque \[N·m\].
    pub input_torque: f64,
    /// The external torques on sun, ring and carrier that balance a unit
    /// input torque on the input member \[N·m per N·m\]; zero on the held member.
    pub balanced_torques_per_input_torque: [f64; 3],
    /// Mesh cycles per revolution of the input member.
    pub mesh_cycles_per_input_revolution: f64,
    /// Face width of the sun \[m\].
    pub face_width: f64,
    /// Base radii of sun, planet and ring \[m\].
    pub base_radii: [f64; 3],
    /// Speeds of sun, ring and carrier for a unit input speed, the held member at rest.
    pub rigid_speeds: [f64; 3],
}

impl Kinematics {
    /// The kinematics of `set`.
    pub fn of(set: &GearSet) -> Kinematics {
        let unit = set.with_input_torque(1.0).map_or([0.0; 3], |s| s.balanced_torques());
        let (sun, planet, ring) = (set.sun(), set.planet(), set.ring());
        Kinematics {
            teeth: [sun.teeth, planet.teeth, ring.teeth],
            planets: set.planet_angles().len(),
            held: set.held(),
            input: set.input(),
            output: set.output(),
            input_torque: set.input_torque(),
            balanced_torques_per_input_torque: unit,
            mesh_cycles_per_input_revolution: mesh_cycles_per_revolution(
                f64::from(sun.teeth),
                f64::from(ring.teeth),
                set.held(),
                set.input(),
            ),
            face_width: sun.face_width,
            base_radii: [sun.base_radius(), planet.base_radius(), ring.base_radius()],
            rigid_speeds: {
                let (s, r, c) = rigid_speeds(set);
                [s, r, c]
            },
        }
    }
}

/// Speeds of sun, ring and carrier [rad/s] for a unit input speed, the held
/// member at rest (Willis: ω_s − ω_c = R (ω_r − ω_c), R = −Z_r/Z_s).
pub fn rigid_speeds(set: &GearSet) -> (f64, f64, f64) {
    let r = -f64::from(set.ring().teeth) / f64::from(set.sun().teeth);
    match (set.held(), set.input()) {
        (Member::Carrier, Member::Sun) => (1.0, 1.0 / r, 0.0),
        (Member::Carrier, Member::Ring) => (r, 1.0, 0.0),
        (Member::Ring, Member::Sun) => (1.0, 0.0, 1.0 / (1.0 - r)),
        (Member::Ring, Member::Carrier) => (1.0 - r, 0.0, 1.0),
        (Member::Sun, Member::Ring) => (0.0, 1.0, r / (r - 1.0)),
        (Member::Sun, Member::Carrier) => (0.0, (r - 1.0) / r, 1.0),
        // Validation refuses held == input.
        _ => (0.0, 0.0, 0.0),
    }
}
