//! The deformable-tooth contact of the example with its finite-element
//! bodies: the contact of all pairs of each mesh solved together over the
//! example's finite-element sun, planet and ring (docs/DEFORMABLE.md).
//!
//! What is asserted is what the model must satisfy whatever its figures:
//! the coupling through the bodies makes the mesh softer than the same
//! bodies read tooth by tooth, the loaded transmission error is a positive
//! approach, and the shares are fractions. The comparison with ISO 6336-1's
//! c_γα is printed (`-- --nocapture`) and stated in docs/DEFORMABLE.md with
//! its verdict against the ±30 % band the pair model is held to; it is not
//! asserted because the ring–planet mesh falls outside it (+34 %), an open
//! finding of the model, not a tolerance to widen.

use planetwear::contact::deformable::body::{BodyCompliance, BodySettings};
use planetwear::contact::deformable::law::{DeformableMesh, LocalContact};
use planetwear::contact::deformable::BodyInfluence;
use planetwear::contact::ltca::MeshModel;
use planetwear::contact::separation::MeshFlanks;
use planetwear::model::gear::{GearSet, MeshKind};
use planetwear::scene::Scene;

/// ISO 6336-1 c_γα of the example's meshes \[N/(mm·µm)\] (docs/FORMULAS.md).
const ISO_C_GAMMA: [(MeshKind, f64); 2] = [(MeshKind::SunPlanet, 14.50), (MeshKind::RingPlanet, 18.04)];

/// Samples of one mesh cycle.
const SAMPLES: usize = 200;

/// A body whose teeth do not feel each other: the finite-element body's
/// coefficients between different teeth set to zero.
struct ToothByTooth<'a>(&'a BodyCompliance);

impl BodyInfluence for ToothByTooth<'_> {
    fn coefficient(&self, i: i32, roll_i: f64, j: i32, roll_j: f64) -> f64 {
        if i == j {
            self.0.coefficient(i, roll_i, j, roll_j)
        } else {
            0.0
        }
    }
    fn reference_depth(&self, roll: f64) -> f64 {
        self.0.reference_depth(roll)
    }
    fn reach(&self) -> i32 {
        self.0.reach()
    }
}

fn example() -> GearSet {
    Scene::example_2004().validate().unwrap()
}

#[test]
fn the_example_meshes_on_finite_element_bodies() {
    let set = example();
    let [sun, planet, ring] = BodyCompliance::of_gear_set(&set, &BodySettings::default()).unwrap();
    let load = set.mesh_load_per_planet();
    let width_mm = set.sun().face_width * 1e3;
    for (mesh, iso) in ISO_C_GAMMA {
        let (b1, b2) = match mesh {
            MeshKind::SunPlanet => (&sun, &planet),
            MeshKind::RingPlanet => (&planet, &ring),
        };
        let flanks = MeshFlanks::default();
        let law = DeformableMesh::new(&set, mesh, b1, b2, &flanks, LocalContact::Johnson).unwrap();
        let r = law.ltca(load, SAMPLES).unwrap();
        let mean = r.mean_stiffness() / width_mm * 1e-6;
        let share = law.double_contact_share(load).unwrap();
        let te: Vec<f64> = r.transmission_error.iter().map(|d| d * 1e6).collect();
        let te_max = te.iter().cloned().fold(f64::MIN, f64::max);
        let te_min = te.iter().cloned().fold(f64::MAX, f64::min);

        let (u1, u2) = (ToothByTooth(b1), ToothByTooth(b2));
        let uncoupled = DeformableMesh::new(&set, mesh, &u1, &u2, &flanks, LocalContact::Johnson).unwrap();
        let mean_uncoupled = uncoupled.ltca(load, SAMPLES).unwrap().mean_stiffness() / width_mm * 1e-6;

        let pair_share = MeshModel::new(&set, mesh, &flanks).double_contact_share(load);
        eprintln!(
            "{mesh:?}: mean tangent mesh stiffness {mean:.2} N/(mm·µm) (teeth uncoupled {mean_uncoupled:.2}; \
             ISO c_γα {iso:.2}, ratio {:.3}); two pairs loaded {share:.4} of the cycle (pair model \
             {pair_share:.4}); loaded transmission error {te_min:.2}-{te_max:.2} µm, peak to peak {:.3} µm",
            mean / iso,
            te_max - te_min
        );
        assert!(te_min > 0.0 && te_max < 100.0, "{mesh:?}: transmission error {te_min}-{te_max} µm");
        // A load on one tooth moves its neighbours the same way: coupling can
        // only soften the mesh.
        assert!(mean < mean_uncoupled, "{mesh:?}: coupled {mean} not below uncoupled {mean_uncoupled}");
        assert!(share.is_finite() && (0.0..=1.0).contains(&share), "{share}");
    }
}
