//! The 2004 scene: the automatic-transmission planetary set of docs/MODEL.md §1.

use super::units::{deg_to_rad, mm_to_m};
use super::Member;
use super::{
    AnalysisSpec, ChamferSpec, ExternalGearSpec, GearData, MaterialSpec, OperationSpec, PlanetLayoutSpec,
    RingGearSpec, Scene,
};

/// The profile shift of planet and ring (and, negated, of the sun) that
/// gives the study's radii from one dedendum factor: 7/24 = 0.291 67.
const EXAMPLE_PROFILE_SHIFT: f64 = 7.0 / 24.0;

impl Scene {
    /// The study's example system, calibrated to the study's own figures and
    /// carrying what the study says of its own model: the geometry of
    /// [`Scene::example_2004_annulus`], sun and planet inertias and the
    /// chamfer height fitted to the study's torsional natural frequencies and
    /// its loaded sun–planet double contact of about 1/5, chamfer edges that
    /// carry no load, the ring with its output drum, planets on needle
    /// bearings and pins of the radial stiffness their geometry and load give
    /// (the study's radially flexible planet bearings), and Rayleigh damping
    /// C = μM + ηK with ζ = 0.02 at the first two rotational modes (each
    /// choice and its reason: docs/PARAMETERS.md).
    pub fn example_2004() -> Self {
        let mut s = Self::example_2004_stiff_pins();
        s.name = "example-2004".into();
        // The needle bearing and pin of `NeedleBearing::example_2004` at the
        // example's load (model::planet_bearing; tests/planet_bearing.rs).
        s.supports.planet_bearing_n_per_m = 2.4611e8;
        // Rayleigh damping by the two-frequency rule at ζ = 0.02 (the mesh
        // damping ratio, which the rule reads) on the first two rotational
        // modes, 4119.6 and 8536.7 Hz: `planetwear modes` prints the rule,
        // tests/rayleigh.rs checks these values against it.
        s.dynamics.damping = super::DampingModel::Rayleigh;
        s.dynamics.rayleigh_mass_per_s = 698.36;
        s.dynamics.rayleigh_stiffness_s = 5.0301e-7;
        // On these bearings the sun–planet force has a narrow peak where a
        // pair leaves contact; its harmonics 1 to 6 sampled 60 times per mesh
        // cycle read F^(rms) up to 4 % low, 240 times within 0.1 % of 1024
        // (docs/ACCURACY.md, "Samples per mesh cycle").
        s.dynamics.samples_per_mesh_cycle = 240;
        s
    }

    /// The calibrated example where it departs from the study's statements
    /// about its model: rigid planet pins (3e10 N/m, so that its
    /// transverse–torsional rotational modes stay the torsional ones the
    /// calibration meets) and a damping ratio of 0.02 per mesh and bearing,
    /// the rest as [`Scene::example_2004`] (docs/PARAMETERS.md).
    pub fn example_2004_stiff_pins() -> Self {
        let mut s = Self::example_2004_annulus();
        s.name = "example-2004-stiff-pins".into();
        // `planetwear calibrate --plan example-2004` (the plan:
        // src/scene/example-2004.calibration.toml; values to five digits).
        let chamfer =
            ChamferSpec { edge_carries_load: false, ..ChamferSpec::new(mm_to_m(0.22724), deg_to_rad(45.0)) };
        s.sun.tip_chamfer = Some(chamfer);
        s.planet.tip_chamfer = Some(chamfer);
        s.inertia.sun_inertia_kg_m2 = Some(1.2818e-4);
        s.inertia.planet_inertia_kg_m2 = Some(9.7687e-6);
        s.inertia.ring_inertia_kg_m2 = Some(1.8193e-2);
        s.supports.planet_bearing_n_per_m = 3.0e10;
        s.dynamics.mesh_damping_ratio = 0.02;
        s
    }

    /// The example on deformable-tooth contact (the study's deformable gear
    /// bodies), calibrated on that law to the same targets with the same
    /// free parameters and choices as [`Scene::example_2004`]: what differs
    /// from it is the contact law, the three values the calibration fits on
    /// it and the Rayleigh coefficients of its own modes (docs/DEFORMABLE.md).
    pub fn example_2004_deformable() -> Self {
        let mut s = Self::example_2004();
        s.name = "example-2004-deformable".into();
        s.dynamics.contact = super::ContactModel::Deformable;
        // `planetwear calibrate --plan example-2004-deformable` (the plan:
        // src/scene/example-2004-deformable.calibration.toml; five digits).
        let chamfer =
            ChamferSpec { edge_carries_load: false, ..ChamferSpec::new(mm_to_m(0.21446), deg_to_rad(45.0)) };
        s.sun.tip_chamfer = Some(chamfer);
        s.planet.tip_chamfer = Some(chamfer);
        s.inertia.sun_inertia_kg_m2 = Some(1.4693e-4);
        s.inertia.planet_inertia_kg_m2 = Some(1.1058e-5);
        // The two-frequency rule at ζ = 0.02 on this law's own first two
        // rotational modes, 3944.9 and 8488.4 Hz (`planetwear modes`).
        s.dynamics.rayleigh_mass_per_s = 676.88;
        s.dynamics.rayleigh_stiffness_s = 5.1203e-7;
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
                module: mm_to_m(1.5),
                pressure_angle: deg_to_rad(21.3),
                tooth_thickness: mm_to_m(1.895),
                tip_radius: mm_to_m(26.37),
                root_radius: mm_to_m(23.00),
                bore_radius: mm_to_m(12.88),
                hob_tip_radius: mm_to_m(0.2),
                face_width: mm_to_m(30.0),
                tip_chamfer: None,
                gear_data: None,
            },
            planet: ExternalGearSpec {
                teeth: 18,
                module: mm_to_m(1.5),
                pressure_angle: deg_to_rad(21.3),
                tooth_thickness: mm_to_m(2.585),
                tip_radius: mm_to_m(15.25),
                root_radius: mm_to_m(11.875),
                bore_radius: mm_to_m(5.94),
                hob_tip_radius: mm_to_m(0.2),
                face_width: mm_to_m(30.0),
                tip_chamfer: None,
                gear_data: None,
            },
            ring: RingGearSpec {
                teeth: 70,
                module: mm_to_m(1.5),
                pressure_angle: deg_to_rad(21.3),
                tooth_thickness: mm_to_m(1.884),
                minor_radius: mm_to_m(51.725),
                root_radius: mm_to_m(55.00),
                rim_radius: mm_to_m(58.95),
                fillet_radius: mm_to_m(0.5),
                face_width: mm_to_m(30.0),
                tip_chamfer: None,
                gear_data: None,
            },
            planets: PlanetLayoutSpec { count: 4, angles: None },
            centre_distance: mm_to_m(39.0),
            material: MaterialSpec::default(),
            operation: OperationSpec { held: Member::Carrier, input: Member::Sun, input_torque_nm: 750.0 },
            analysis: AnalysisSpec::default(),
            supports: Default::default(),
            inertia: Default::default(),
            mesh_stiffness: Default::default(),
            dynamics: Default::default(),
        }
    }

    /// [`Scene::example_2004`] with its gears given by gear data (ISO 21771)
    /// instead of radii: the same radii to well below a nanometre, so the
    /// same gear set (docs/GEAR_DATA.md). Profile shifts −7/24 (sun) and
    /// +7/24 (planet, ring) on a rack of dedendum factor 1.375 give the
    /// study's root radii and, with an addendum factor 0.875, the planet's
    /// tip; the sun's and the ring's tips are given by diameter as made
    /// (52.74 mm and 103.45 mm); the tooth-thickness allowances carry the
    /// study's backlash; the shifts sum to zero in both meshes, so the
    /// operating centre distance is the standard 39 mm.
    pub fn example_2004_gear_data() -> Self {
        let mut s = Self::example_2004();
        s.name = "example-2004-gear-data".into();
        let x = EXAMPLE_PROFILE_SHIFT;
        let data =
            |profile_shift: f64, tooth_thickness_allowance_mm: f64, tool_tip_radius_factor: f64| GearData {
                profile_shift,
                addendum_factor: 0.875,
                dedendum_factor: 1.375,
                tool_tip_radius_factor,
                tooth_thickness_allowance: mm_to_m(tooth_thickness_allowance_mm),
                tip_diameter: None,
                root_diameter: None,
            };
        let hob = 0.2 / 1.5;
        s.sun.gear_data =
            Some(GearData { tip_diameter: Some(mm_to_m(52.74)), ..data(-x, -0.1200462457, hob) });
        s.planet.gear_data = Some(data(x, -0.1123427346, hob));
        s.ring.gear_data =
            Some(GearData { tip_diameter: Some(mm_to_m(103.45)), ..data(x, -0.1310462457, 0.5 / 1.5) });
        for (t, r, f, h) in [
            (
                &mut s.sun.tooth_thickness,
                &mut s.sun.tip_radius,
                &mut s.sun.root_radius,
                &mut s.sun.hob_tip_radius,
            ),
            (
                &mut s.planet.tooth_thickness,
                &mut s.planet.tip_radius,
                &mut s.planet.root_radius,
                &mut s.planet.hob_tip_radius,
            ),
            (
                &mut s.ring.tooth_thickness,
                &mut s.ring.minor_radius,
                &mut s.ring.root_radius,
                &mut s.ring.fillet_radius,
            ),
        ] {
            (*t, *r, *f, *h) = (0.0, 0.0, 0.0, 0.0);
        }
        s
    }
}
