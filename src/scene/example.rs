//! The 2004 scene: the automatic-transmission planetary set of MODEL.md §1.

use super::{
    AnalysisSpec, ExternalGearSpec, MaterialSpec, OperationSpec, PlanetLayoutSpec, RingGearSpec, Scene,
};
use crate::physics::gear::Member;

impl Scene {
    /// The example system of MODEL.md §1, read as written there: 21.3° is the
    /// operating pressure angle and m·Z/2 the operating pitch radius (centre
    /// distance 39.0 mm for both meshes); the tooth thicknesses carry the
    /// backlash; carrier held, sun driven with 25 N·m per mm of face width.
    /// The tip chamfer of sun and planet is not given: the default of
    /// docs/PARAMETERS.md applies.
    pub fn example_2004() -> Self {
        Self {
            name: "example-2004".into(),
            sun: ExternalGearSpec {
                teeth: 34,
                module_mm: 1.5,
                pressure_angle_deg: 21.3,
                tooth_thickness_mm: 1.895,
                tip_radius_mm: 26.37,
                root_radius_mm: 23.00,
                bore_radius_mm: 12.88,
                hob_tip_radius_mm: 0.2,
                face_width_mm: 30.0,
                tip_chamfer: None,
            },
            planet: ExternalGearSpec {
                teeth: 18,
                module_mm: 1.5,
                pressure_angle_deg: 21.3,
                tooth_thickness_mm: 2.585,
                tip_radius_mm: 15.25,
                root_radius_mm: 11.875,
                bore_radius_mm: 5.94,
                hob_tip_radius_mm: 0.2,
                face_width_mm: 30.0,
                tip_chamfer: None,
            },
            ring: RingGearSpec {
                teeth: 70,
                module_mm: 1.5,
                pressure_angle_deg: 21.3,
                tooth_thickness_mm: 1.884,
                minor_radius_mm: 51.725,
                root_radius_mm: 55.00,
                rim_radius_mm: 58.95,
                fillet_radius_mm: 0.5,
                face_width_mm: 30.0,
                tip_chamfer: None,
            },
            planets: PlanetLayoutSpec { count: 4, angles_deg: None },
            centre_distance_mm: 39.0,
            material: MaterialSpec::default(),
            operation: OperationSpec { held: Member::Carrier, input: Member::Sun, input_torque_nm: 750.0 },
            analysis: AnalysisSpec::default(),
            supports: Default::default(),
            inertia: Default::default(),
            dynamics: Default::default(),
        }
    }
}
