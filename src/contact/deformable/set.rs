//! The deformable contact law of both meshes of a gear set, as the dynamics
//! reads it: the three finite-element bodies ([`BodyCompliance::of_gear_set`]
//! at [`BodySettings::default`]), Johnson's local term, and each mesh's force
//! table ([`TabulatedMesh`] at [`TableSpec::default`]) for its flank
//! deviations.
//!
//! Built once per geometry and worn state and kept for the process: the
//! bodies by the gears' forms and material (wear does not change a body,
//! only its gaps), the tables by the whole validated set and the flanks.

use std::sync::{Arc, Mutex};

use crate::contact::deformable::body::{BodyCompliance, BodySettings};
use crate::contact::deformable::law::{DeformableError, DeformableMesh, LocalContact};
use crate::contact::deformable::table::{TableSpec, TabulatedMesh};
use crate::contact::ltca::SetModel;
use crate::contact::separation::MeshFlanks;
use crate::model::gear::{ContactModel, GearSet, MeshKind};

/// The smallest line load the tables are built for \[N/m\]: a set without
/// input torque (a speed-driven run) still gets a table over the loads of
/// ordinary operation; beyond a table's range the exact solution is read.
const MINIMUM_TABLE_LINE_LOAD: f64 = 50.0e3;

/// How many built sets of bodies and of tables the process keeps.
const KEPT: usize = 8;

/// The deformable contact law of the two meshes of a set.
#[derive(Clone, Debug)]
pub struct DeformableSet {
    /// Sun–planet mesh.
    pub sun_planet: TabulatedMesh,
    /// Ring–planet mesh.
    pub ring_planet: TabulatedMesh,
}

type Bodies = Arc<[BodyCompliance; 3]>;

static BODIES: Mutex<Vec<(String, Bodies)>> = Mutex::new(Vec::new());
static TABLES: Mutex<Vec<(String, Arc<DeformableSet>)>> = Mutex::new(Vec::new());

/// The entry of `cache` under `key`, or `make()`'s value, kept (the oldest
/// of more than [`KEPT`] entries dropped). Built outside the lock.
fn cached<T: Clone>(
    cache: &Mutex<Vec<(String, T)>>,
    key: Option<String>,
    make: impl FnOnce() -> Result<T, DeformableError>,
) -> Result<T, DeformableError> {
    if let Some(k) = &key {
        let held = cache.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, v)) = held.iter().find(|(kk, _)| kk == k) {
            return Ok(v.clone());
        }
    }
    let value = make()?;
    if let Some(k) = key {
        let mut held = cache.lock().unwrap_or_else(|e| e.into_inner());
        if !held.iter().any(|(kk, _)| *kk == k) {
            held.push((k, value.clone()));
            if held.len() > KEPT {
                held.remove(0);
            }
        }
    }
    Ok(value)
}

impl DeformableSet {
    /// The law of both meshes of `set` with one flank deviation per mesh
    /// (the deformable model is transverse: one face slice).
    pub fn of_gear_set(
        set: &GearSet,
        sun_planet: &MeshFlanks,
        ring_planet: &MeshFlanks,
    ) -> Result<Arc<Self>, DeformableError> {
        let body_key = serde_json::to_string(&(set.sun(), set.planet(), set.ring(), set.material())).ok();
        let key = serde_json::to_string(&(set, sun_planet, ring_planet)).ok();
        cached(&TABLES, key, || {
            let bodies: Bodies = cached(&BODIES, body_key, || {
                BodyCompliance::of_gear_set(set, &BodySettings::default())
                    .map(Arc::new)
                    .map_err(|e| DeformableError::Body(e.to_string()))
            })?;
            let [sun, planet, ring] = &*bodies;
            let width = set.sun().face_width.min(set.planet().face_width).min(set.ring().face_width);
            let load = set.mesh_load_per_planet().max(MINIMUM_TABLE_LINE_LOAD * width);
            let table = |mesh: MeshKind, flanks: &MeshFlanks| {
                let (b1, b2) = match mesh {
                    MeshKind::SunPlanet => (sun, planet),
                    MeshKind::RingPlanet => (planet, ring),
                };
                let law = DeformableMesh::new(set, mesh, b1, b2, flanks, LocalContact::Johnson)?;
                TabulatedMesh::new(law, load, TableSpec::default())
            };
            let (sp, rp) = rayon::join(
                || table(MeshKind::SunPlanet, sun_planet),
                || table(MeshKind::RingPlanet, ring_planet),
            );
            Ok(Arc::new(Self { sun_planet: sp?, ring_planet: rp? }))
        })
    }

    /// The law of both meshes for the flank deviations of `contact` (a set's
    /// contact models, worn or not) when the set asks for it
    /// ([`GearSet::contact_model`]), `None` on the pair model: one transverse
    /// slice, so the flanks must be the same across the face.
    pub fn of_set_model(set: &GearSet, contact: &SetModel) -> Result<Option<Arc<Self>>, DeformableError> {
        if set.contact_model() != ContactModel::Deformable {
            return Ok(None);
        }
        let one = |kind: MeshKind| {
            let slices = contact.flanks(kind);
            if slices.iter().all(|f| *f == slices[0]) {
                Ok(slices[0].clone())
            } else {
                Err(DeformableError::Setting {
                    name: "face slices with different flank deviations",
                    value: slices.len() as f64,
                    allowed:
                        "flanks the same across the face: the deformable law is transverse (one slice); \
                              use dynamics.contact = \"pair\" for this worn state",
                })
            }
        };
        Self::of_gear_set(set, &one(MeshKind::SunPlanet)?, &one(MeshKind::RingPlanet)?).map(Some)
    }

    /// The law of mesh `kind`.
    pub fn mesh(&self, kind: MeshKind) -> &TabulatedMesh {
        match kind {
            MeshKind::SunPlanet => &self.sun_planet,
            MeshKind::RingPlanet => &self.ring_planet,
        }
    }
}
