//! The GUID of a variable interface: a 128-bit FNV-1a hash (two 64-bit
//! passes with different offsets) of the model name and identifier and, per
//! variable, its name, value reference, type, causality, variability and
//! unit. Descriptions and start values are not part of the interface.
//! Shared by build.rs (which writes the GUID) and the library (whose tests
//! recompute it); build.rs includes this file and [`crate::files::hash`]
//! under the same module paths.

use crate::files::hash::{fnv1a64_from, FNV_OFFSET};

/// One variable's part of the interface: name, value reference, type,
/// causality, variability, unit.
pub type InterfaceRow<'a> = (&'a str, u32, &'a str, &'a str, &'a str, &'a str);

/// The GUID, formatted `{8-4-4-4-12}` in lower-case hexadecimal.
pub fn interface_guid<'a>(
    model_name: &str,
    model_identifier: &str,
    rows: impl Iterator<Item = InterfaceRow<'a>>,
) -> String {
    let mut text = format!("{model_name}|{model_identifier}");
    for (name, vr, ty, causality, variability, unit) in rows {
        text.push_str(&format!("\n{name}|{vr}|{ty}|{causality}|{variability}|{unit}"));
    }
    let a = fnv1a64_from(FNV_OFFSET, text.as_bytes());
    let b = fnv1a64_from(0x6c62_272e_07bb_0142, text.as_bytes());
    let hex = format!("{a:016x}{b:016x}");
    format!("{{{}-{}-{}-{}-{}}}", &hex[0..8], &hex[8..12], &hex[12..16], &hex[16..20], &hex[20..32])
}
