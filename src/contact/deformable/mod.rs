//! Deformable-tooth contact: the compliance of each gear body from a 2-D
//! finite-element model, a local contact term, and the contact of every
//! tooth pair that can touch solved together as a complementarity problem.
//!
//! The pair model ([`crate::contact::ltca`]) gives each tooth pair one
//! stiffness and lets the pairs of a mesh act independently. Here the teeth
//! of a gear share one elastic body: a load on one tooth moves its
//! neighbours, and a pair's share of the mesh load follows from the
//! compliance of both bodies at every contact point, the local flattening of
//! each contact and the unloaded gaps (involute, chamfer, edge relief, wear).
//!
//! The split between the far field and the local term follows the
//! load-distribution programs of this field: the finite-element model gives
//! the displacement of a point at a reference depth d below each flank point
//! (where a coarse mesh resolves the field), and the approach of the surface
//! to that point is the 2-D Hertzian line-contact solution to depth d
//! (Johnson, *Contact Mechanics*, 1985, §5.6): the two add without counting
//! anything twice.
//!
//! The two halves meet in [`BodyInfluence`]: the body model implements it,
//! the contact solution reads it.
//!
//! - [`fe`]: the 9-node plane-strain element and the factorised stiffness.
//! - [`mesher`]: the mapped mesh of a sector of a gear body.
//! - [`body`]: the bodies' influence coefficients ([`body::BodyCompliance`]).
//! - [`law`], [`lcp`]: the contact of one mesh solved over all its pairs.
//! - [`table`]: the mesh law tabulated for the dynamics; [`set`]: both meshes of a set.

pub mod body;
pub mod fe;
pub mod mesher;

/// The influence coefficients of one gear body at the contact points of its
/// flanks: how far a point at the reference depth below one flank point
/// moves under a unit normal load at another.
///
/// Conventions:
/// - a flank point is named by its tooth and its roll angle on the involute
///   \[rad\]; the two flanks of a tooth are mirror images, so one flank's
///   coefficients serve both (a worn flank keeps its body: wear of a few µm
///   changes the gaps, carried by the separation tables, not the compliance);
/// - tooth indices count from the loaded tooth (0) towards the side the flank
///   faces: tooth +1 is the neighbour the flank looks at across the space;
/// - the load is a unit normal force \[N\] over the whole face width,
///   pressing on the flank; the displacement \[m\] is along the same normal,
///   positive when the point recedes into the tooth (so the diagonal is
///   positive and the matrix of coefficients symmetric positive definite);
/// - roll angles outside the body's grid read its nearest end (a tip-corner
///   contact loads the flank at the involute's end).
pub trait BodyInfluence: Send + Sync {
    /// Displacement \[m\] at the reference depth below the flank point of
    /// tooth `i` at roll angle `roll_i` \[rad\], under a unit normal force
    /// \[N\] at the flank point of tooth `j` at roll angle `roll_j` \[rad\].
    fn coefficient(&self, i: i32, roll_i: f64, j: i32, roll_j: f64) -> f64;

    /// Depth \[m\] below the flank point at roll angle `roll` \[rad\], along
    /// its normal, at which [`Self::coefficient`] reads displacements.
    fn reference_depth(&self, roll: f64) -> f64;

    /// How many teeth each side of a loaded tooth the coefficients cover;
    /// teeth farther apart do not influence each other.
    fn reach(&self) -> i32;
}

pub mod law;
pub mod lcp;
pub mod quasi;
pub mod set;
pub mod standin;
pub mod table;
