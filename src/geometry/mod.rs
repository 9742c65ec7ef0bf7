//! Stage 3, geometry: the complete outline of a flank — involute, root
//! fillet, tip chamfer and its edge rounding — and the profile deviations
//! (wear) carried on it, as functions of the roll angle.
//!
//! May import: [`crate::files`], [`crate::scene`], [`crate::model`].
//!
//! - [`profile`]: flank outlines, profile regions and deviations.

pub mod profile;
