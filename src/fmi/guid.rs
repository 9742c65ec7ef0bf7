//! The GUID of a variable interface: a 128-bit FNV-1a hash (two 64-bit
//! passes with different offsets) of the model name and identifier and, per
//! variable, its name, value reference, type, causality, variability and
//! unit. Descriptions and start values are not part of the interface.
//! Shared by build.rs (which writes the GUID) and the library (whose tests
//! recompute it).

/// One variable's part of the interface: name, value reference, type,
/// causality, variability, unit.
pub type InterfaceRow<'a> = (&'a str, u32, &'a str, &'a str, &'a str, &'a str);

fn fnv1a(seed: u64, data: &[u8]) -> u64 {
    let mut h = seed;
    for b in data {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

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
    let a = fnv1a(0xcbf2_9ce4_8422_2325, text.as_bytes());
    let b = fnv1a(0x6c62_272e_07bb_0142, text.as_bytes());
    let hex = format!("{a:016x}{b:016x}");
    format!("{{{}-{}-{}-{}-{}}}", &hex[0..8], &hex[8..12], &hex[12..16], &hex[16..20], &hex[20..32])
}
