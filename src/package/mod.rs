//! Front end, package: the `.fmu` archive and what it ships besides the
//! shared library — the modelDescription.xml, the built-in scenes, the
//! example's worn-profile states and the regression references computed at
//! pack time (`planetwear fmu pack`, `planetwear fmu references`).
//!
//! May import: every stage up to [`crate::analysis`], and [`crate::fmi`]
//! (the variable table).
//!
//! - [`elf`]: the glibc version a shared library needs.
//! - [`pack`]: the archive.
//! - [`regression`]: the regression cases, their protocol and references.

pub mod elf;
pub mod pack;
pub mod regression;
