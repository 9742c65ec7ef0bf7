//! One mesh's contact law as the dynamics and its readers see it, whichever
//! model the scene chose: the pair model ([`MeshModel`], each tooth pair its
//! own spring) or the deformable model ([`TabulatedMesh`], all pairs solved
//! together over finite-element bodies).
//!
//! The hot path (force and tangents at every evaluation) calls each model
//! directly; this view serves the readings made at recorded instants: the
//! pairs in contact and their forces, one pair's force, the static
//! transmission error.

use crate::contact::deformable::law::DeformableError;
use crate::contact::deformable::set::DeformableSet;
use crate::contact::deformable::table::TabulatedMesh;
use crate::contact::ltca::{MeshModel, PairContact, SetModel};
use crate::model::gear::MeshKind;
use crate::model::mesh::PathOfContact;

/// A mesh's contact law, borrowed.
#[derive(Clone, Copy, Debug)]
pub enum MeshContact<'a> {
    /// The pair model.
    Pair(&'a MeshModel),
    /// The deformable model.
    Deformable(&'a TabulatedMesh),
}

impl<'a> MeshContact<'a> {
    /// Mesh `kind`'s law: the deformable law's when there is one, else the
    /// pair model of `contact`.
    pub fn of(contact: &'a SetModel, deformable: Option<&'a DeformableSet>, kind: MeshKind) -> Self {
        match deformable {
            Some(d) => Self::Deformable(d.mesh(kind)),
            None => Self::Pair(match kind {
                MeshKind::SunPlanet => &contact.sun_planet,
                MeshKind::RingPlanet => &contact.ring_planet,
            }),
        }
    }

    /// The path of contact.
    pub fn path(&self) -> &PathOfContact {
        match self {
            Self::Pair(m) => m.path(),
            Self::Deformable(t) => t.mesh.path(),
        }
    }

    /// Drive position of the first sample of the separation tables \[m\]:
    /// pair positions are counted from it.
    pub fn table_start(&self) -> f64 {
        match self {
            Self::Pair(m) => m.separation.drive.start,
            Self::Deformable(t) => t.mesh.separation.drive.start,
        }
    }

    /// Mesh force \[N\] at (s, δ) with its tooth pairs in `pairs`, as
    /// [`MeshModel::force`]. On the deformable model a pair's stiffness is its
    /// secant, force over penetration (0 when open), and its largest line
    /// load the force over the face width (one transverse slice).
    pub fn pairs(&self, s: f64, delta: f64, pairs: &mut Vec<PairContact>) -> Result<f64, DeformableError> {
        match self {
            Self::Pair(m) => Ok(m.force(s, delta, Some(pairs)).0),
            Self::Deformable(t) => {
                let state = t.mesh.solve(s, delta)?;
                let width = t.mesh.face_width();
                pairs.clear();
                for p in &state.pairs {
                    let penetration = p.flank.sign() * delta - p.gap;
                    let loaded = p.force != 0.0 && penetration > 0.0;
                    match pairs.iter_mut().find(|c| c.index == p.index) {
                        // The other flank of a pair already listed: at most one of the two carries load.
                        Some(c) if loaded => {
                            c.force = p.force;
                            c.stiffness = p.force.abs() / penetration;
                            c.max_line_load = p.force.abs() / width;
                        }
                        Some(_) => {}
                        None => pairs.push(PairContact {
                            index: p.index,
                            position: p.position,
                            force: p.force,
                            stiffness: if loaded { p.force.abs() / penetration } else { 0.0 },
                            max_line_load: p.force.abs() / width,
                        }),
                    }
                }
                Ok(state.law.force)
            }
        }
    }

    /// Force \[N\] of the tooth pair whose drive position is `pos`, at
    /// approach δ (zero outside the tables); on the deformable model the
    /// pair's share of the mesh solved with the reference pair there.
    pub fn pair_force(&self, pos: f64, delta: f64) -> Result<f64, DeformableError> {
        match self {
            Self::Pair(m) => Ok(m.pair_force(pos, delta)),
            Self::Deformable(t) => Ok(t.mesh.solve(pos, delta)?.pair_force(0)),
        }
    }

    /// The forces \[N\] of `pair` per face slice at approach δ into `out`: the
    /// pair model's slices, or the one transverse slice of the deformable
    /// model (the force of `pair` as [`Self::pairs`] gave it).
    pub fn slice_forces(&self, pair: &PairContact, delta: f64, out: &mut Vec<f64>) {
        match self {
            Self::Pair(m) => m.pair_slice_forces(pair.position, delta, out),
            Self::Deformable(_) => {
                out.clear();
                out.push(pair.force);
            }
        }
    }

    /// The approach \[m\] at which the mesh carries `load` \[N\] at position s:
    /// the loaded static transmission error.
    pub fn approach_for(&self, s: f64, load: f64) -> Result<f64, DeformableError> {
        match self {
            Self::Pair(m) => Ok(m.approach_for(s, load)),
            Self::Deformable(t) => t.mesh.approach_for(s, load),
        }
    }
}
