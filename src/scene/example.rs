//! The 2004 scene: the automatic-transmission planetary set of docs/MODEL.md §1.

use super::Member;
use super::{
    AnalysisSpec, ChamferSpec, ExternalGearSpec, MaterialSpec, OperationSpec, PlanetLayoutSpec, RingGearSpec,
    Scene,
};

impl Scene {
    /// The study's example system, calibrated to the study's own figures:
    /// the geometry of [`Scene::example_2004_annulus`], sun and planet
    /// inertias and the chamfer height fitted to the study's torsional
    /// natural frequencies and its loaded sun–planet double contact of about
    /// 1/5, chamfer edges that carry no load, the ring with its output drum,
    /// rigid planet pins and mesh damping 0.03 (each choice and its reason:
    /// docs/PARAMETERS.md).
    pub fn example_2004() -> Self {
        let mut s = Self::example_2004_annulus();
        s.name = "example-2004".into();
        // `planetwear calibrate --plan example-2004` (the plan:
        // src/scene/example-2004.calibration.toml; values to five digits).
        let chamfer = ChamferSpec { edge_carries_load: false, ..ChamferSpec::new(0.22724, 45.0) };
        s.sun.tip_chamfer = Some(chamfer);
        s.planet.tip_chamfer = Some(chamfer);
        s.inertia.sun_inertia_kg_m2 = Some(1.2813e-4);
        s.inertia.planet_inertia_kg_m2 = Some(9.7655e-6);
        s.inertia.ring_inertia_kg_m2 = Some(1.8193e-2);
        s.supports.planet_bearing_n_per_m = 3.0e10;
        s.dynamics.mesh_damping_ratio = 0.03;
        s
    }

    /// The example read with the geometry's defaults (docs/PARAMETERS.md)
    /// where the study gives nothing: sun and planet inertias of bare annuli
    /// from bore to root, the ring's from tooth tip to rim outside, needle-bearing planet
    /// supports (3e8 N/m), chamfers 0.1·m × 45° whose edges carry load, mesh
    /// damping 0.05 ([`Scene::example_2004`] is the calibrated reading).
    pub fn example_2004_annulus() -> Self {
        Self {
            name: "example-2004-annulus".into(),
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
            mesh_stiffness: Default::default(),
            dynamics: Default::default(),
        }
    }
}
