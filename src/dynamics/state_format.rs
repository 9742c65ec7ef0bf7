//! The serialized simulation state: a versioned, self-checking byte format
//! with no pointers in it (docs/FMU.md, Interface).
//!
//! Layout, all integers and floats little-endian:
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `PWSTATE\0` |
//! | 4 | format version (u32, currently 2; version 1, without the load duty, is read too) |
//! | 4 | length L of the interface fingerprint (u32) |
//! | L | fingerprint: the FMU GUID and the gear set it belongs to |
//! | 8 | time (f64) |
//! | 4·8 | lengths of q, v, the integrator state, the two harmonic-window sample arrays, the window's last point, the speed drive's state and the load duty's counts (u32) |
//! | 8·n | those eight arrays (f64) |
//! | 8·4 | torques on sun, ring, carrier, speed reference (f64) |
//! | 8 | FNV-1a 64 checksum of everything before it |
//!
//! Floats are stored as their bits, so a restore is bit-identical. A blob
//! with another magic, version or fingerprint, a wrong length or a checksum
//! mismatch is refused with the reason.

use crate::dynamics::simulation::Snapshot;

const MAGIC: &[u8; 8] = b"PWSTATE\0";
/// Current format version.
pub const VERSION: u32 = 2;
/// The version before the load duty's counts were kept, still read (with no counts).
pub const VERSION_WITHOUT_DUTY: u32 = 1;

/// Why a serialized state was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum StateFormatError {
    /// Not a planetwear state at all.
    #[error("not a planetwear state (the first bytes are not the format's magic)")]
    NotAState,
    /// A version this build cannot read.
    #[error("state format version {found} cannot be read by this build (reads version {VERSION})")]
    Version {
        /// Version in the blob.
        found: u32,
    },
    /// Made by another FMU interface or for another gear set.
    #[error("the state belongs to '{found}', not to '{expected}'")]
    Foreign {
        /// Fingerprint in the blob.
        found: String,
        /// Fingerprint of this instance.
        expected: String,
    },
    /// Cut short or with trailing bytes.
    #[error("the state is {found} bytes long where its header implies {expected}")]
    Length {
        /// Bytes found.
        found: usize,
        /// Bytes implied.
        expected: usize,
    },
    /// The checksum does not match: the bytes were altered.
    #[error("the state's checksum does not match: the bytes were altered or corrupted")]
    Checksum,
}

/// Serializes a snapshot for an interface/gear-set `fingerprint`.
pub fn encode(snapshot: &Snapshot, fingerprint: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 + fingerprint.len() + 8 * (snapshot.q.len() * 3 + 5));
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(fingerprint.len() as u32).to_le_bytes());
    out.extend_from_slice(fingerprint.as_bytes());
    out.extend_from_slice(&snapshot.time.to_le_bytes());
    let arrays = [
        &snapshot.q,
        &snapshot.v,
        &snapshot.integrator,
        &snapshot.window_sun,
        &snapshot.window_ring,
        &snapshot.window_last,
        &snapshot.drive,
        &snapshot.duty,
    ];
    for v in arrays {
        out.extend_from_slice(&(v.len() as u32).to_le_bytes());
    }
    for v in arrays {
        for x in v.iter() {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    for x in snapshot.torques.iter().chain(std::iter::once(&snapshot.speed_reference)) {
        out.extend_from_slice(&x.to_le_bytes());
    }
    let sum = crate::files::hash::fnv1a64(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

struct Reader<'a> {
    data: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        let end = self.at.checked_add(n)?;
        let s = self.data.get(self.at..end)?;
        self.at = end;
        Some(s)
    }
    fn u32(&mut self) -> Option<u32> {
        self.take(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn f64(&mut self) -> Option<f64> {
        self.take(8).map(|b| {
            let mut a = [0u8; 8];
            a.copy_from_slice(b);
            f64::from_le_bytes(a)
        })
    }
}

/// Reads a serialized state made for `fingerprint`.
pub fn decode(data: &[u8], fingerprint: &str) -> Result<Snapshot, StateFormatError> {
    if data.len() < 8 || &data[..8] != MAGIC {
        return Err(StateFormatError::NotAState);
    }
    let short = |expected: usize| StateFormatError::Length { found: data.len(), expected };
    let mut r = Reader { data, at: 8 };
    let version = r.u32().ok_or(short(16))?;
    let arrays = match version {
        VERSION => 8,
        VERSION_WITHOUT_DUTY => 7,
        _ => return Err(StateFormatError::Version { found: version }),
    };
    let flen = r.u32().ok_or(short(16))? as usize;
    let found = r.take(flen).ok_or(short(16 + flen))?;
    let found = String::from_utf8_lossy(found).into_owned();
    let time = r.f64();
    let lens: Vec<Option<u32>> = (0..arrays).map(|_| r.u32()).collect();
    let header = 16 + flen + 8 + 4 * arrays;
    let (Some(time), Some(lens)) = (time, lens.into_iter().collect::<Option<Vec<u32>>>()) else {
        return Err(short(header + 8));
    };
    let count = lens.iter().try_fold(0usize, |acc, n| acc.checked_add(*n as usize));
    let expected = count
        .and_then(|c| c.checked_add(4))
        .and_then(|c| c.checked_mul(8))
        .and_then(|b| b.checked_add(header + 8));
    let Some(expected) = expected else { return Err(short(usize::MAX)) };
    if data.len() != expected {
        return Err(short(expected));
    }
    let body = &data[..expected - 8];
    let mut sum = [0u8; 8];
    sum.copy_from_slice(&data[expected - 8..]);
    if crate::files::hash::fnv1a64(body) != u64::from_le_bytes(sum) {
        return Err(StateFormatError::Checksum);
    }
    if found != fingerprint {
        return Err(StateFormatError::Foreign { found, expected: fingerprint.into() });
    }
    let mut read = |n: u32| -> Vec<f64> { (0..n).filter_map(|_| r.f64()).collect() };
    let q = read(lens[0]);
    let v = read(lens[1]);
    let integrator = read(lens[2]);
    let window_sun = read(lens[3]);
    let window_ring = read(lens[4]);
    let window_last = read(lens[5]);
    let drive = read(lens[6]);
    let duty = lens.get(7).map_or_else(Vec::new, |n| read(*n));
    let rest = read(4);
    Ok(Snapshot {
        time,
        q,
        v,
        integrator,
        torques: [rest[0], rest[1], rest[2]],
        speed_reference: rest[3],
        window_sun,
        window_ring,
        window_last,
        drive,
        duty,
    })
}
