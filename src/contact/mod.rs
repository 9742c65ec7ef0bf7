//! Stage 4, contact: what happens where two flanks meet. The separation of
//! each tooth pair along the path of contact, the tooth-pair stiffness, the
//! Hertzian contact, the published ISO/TR 6336-30 stiffness example, and the
//! quasi-static loaded tooth contact analysis (LTCA) of a mesh and of the
//! whole set.
//!
//! May import: [`crate::files`], [`crate::scene`], [`crate::model`],
//! [`crate::geometry`].
//!
//! - [`separation`]: the gap between the flanks of each tooth pair.
//! - [`stiffness`]: tooth-pair and mesh stiffness.
//! - [`hertz`]: Hertzian line contact.
//! - [`iso6336`]: the ISO/TR 6336-30 single-pair stiffness example.
//! - [`ltca`]: loaded tooth contact analysis.
//! - [`mesh_law`]: one mesh's law, pair or deformable, as its readers see it.
//! - [`cache`]: the separation tables on disk, keyed by what they are made from.
//! - [`deformable`]: deformable-tooth contact (finite-element bodies, a local
//!   contact term, the pairs solved together).

pub mod cache;
pub mod deformable;
pub mod hertz;
pub mod iso6336;
pub mod ltca;
pub mod mesh_law;
pub mod separation;
pub mod stiffness;
