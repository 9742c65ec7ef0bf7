//! The glibc a shared library needs: the highest `GLIBC_x.y[.z]` among the
//! version requirements of its dynamic symbols (the ELF `.gnu.version_r`
//! section, read with the `object` crate). `fmu pack` names it when it packs
//! a library that was not built for the portable glibc level.

use std::path::Path;

use object::read::elf::ElfFile64;
use object::Endianness;

/// A glibc symbol version, e.g. 2.17 or 2.2.5 (compared part by part).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct GlibcVersion(pub Vec<u32>);

impl std::fmt::Display for GlibcVersion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let parts: Vec<String> = self.0.iter().map(u32::to_string).collect();
        write!(f, "GLIBC_{}", parts.join("."))
    }
}

impl GlibcVersion {
    /// The version named `name` (`GLIBC_2.17`); `None` for any other name (`GLIBC_PRIVATE`,
    /// `GCC_3.0`).
    pub fn parse(name: &str) -> Option<Self> {
        let parts: Option<Vec<u32>> =
            name.strip_prefix("GLIBC_")?.split('.').map(|p| p.parse().ok()).collect();
        parts.filter(|p| !p.is_empty()).map(Self)
    }
}

/// Why a library's glibc versions could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ElfError {
    /// The file could not be read.
    #[error("reading {path}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The file is not a 64-bit ELF shared library, or its version sections are malformed.
    #[error("{path}: not a readable 64-bit ELF shared library")]
    Elf {
        /// File.
        path: String,
        /// Cause.
        source: object::read::Error,
    },
}

/// The highest glibc version `library` requires (`None` when it requires none).
pub fn newest_glibc(library: &Path) -> Result<Option<GlibcVersion>, ElfError> {
    let path = library.display().to_string();
    let data = std::fs::read(library).map_err(|source| ElfError::Io { path: path.clone(), source })?;
    newest_glibc_in(&data).map_err(|source| ElfError::Elf { path, source })
}

/// [`newest_glibc`] of an ELF image in memory.
pub fn newest_glibc_in(data: &[u8]) -> Result<Option<GlibcVersion>, object::read::Error> {
    let file = ElfFile64::<Endianness>::parse(data)?;
    let endian = file.endian();
    let sections = file.elf_section_table();
    let mut newest = None;
    if let Some((mut needs, link)) = sections.gnu_verneed(endian, data)? {
        let strings = sections.strings(endian, data, link)?;
        while let Some((_, mut auxiliaries)) = needs.next()? {
            while let Some(auxiliary) = auxiliaries.next()? {
                let name = String::from_utf8_lossy(auxiliary.name(endian, strings)?);
                newest = newest.max(GlibcVersion::parse(&name));
            }
        }
    }
    Ok(newest)
}
