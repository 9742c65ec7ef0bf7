//! The glibc version a shared library needs (`package::elf`), which `fmu pack` names when it
//! packs a library built for a newer glibc than the portable level.

use planetwear::package::elf::{newest_glibc, newest_glibc_in, GlibcVersion};

fn version(name: &str) -> GlibcVersion {
    GlibcVersion::parse(name).unwrap_or_else(|| panic!("{name} is a glibc version"))
}

#[test]
fn glibc_versions_compare_part_by_part_and_other_names_are_none() {
    assert!(version("GLIBC_2.2.5") < version("GLIBC_2.17"));
    assert!(version("GLIBC_2.17") < version("GLIBC_2.35"));
    assert!(version("GLIBC_2.3") < version("GLIBC_2.3.4"));
    assert_eq!(version("GLIBC_2.17").to_string(), "GLIBC_2.17");
    for other in ["GLIBC_PRIVATE", "GCC_3.0", "GLIBC_", "GLIBCXX_3.4", "GLIBC_2.x"] {
        assert_eq!(GlibcVersion::parse(other), None, "{other}");
    }
}

/// The highest of the versions `objdump -T` prints for this test's own executable (binutils
/// comes with the C toolchain that links Rust on Linux).
#[test]
fn the_newest_glibc_of_an_executable_is_the_highest_objdump_lists() {
    let exe = std::env::current_exe().unwrap();
    let listing = std::process::Command::new("objdump").arg("-T").arg(&exe).output().expect("objdump runs");
    assert!(listing.status.success(), "objdump -T {}", exe.display());
    let text = String::from_utf8_lossy(&listing.stdout);
    let highest =
        text.split(|c: char| c.is_whitespace() || c == '(' || c == ')').filter_map(GlibcVersion::parse).max();
    assert!(highest.is_some(), "objdump lists no GLIBC version for {}", exe.display());
    assert_eq!(newest_glibc(&exe).unwrap(), highest);
}

#[test]
fn a_file_that_is_not_elf_is_refused_with_its_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("not-a-library.so");
    std::fs::write(&path, b"#!/bin/sh\necho not a library\n").unwrap();
    let message = newest_glibc(&path).unwrap_err().to_string();
    assert!(message.contains("not-a-library.so") && message.contains("ELF"), "{message}");
    let missing = newest_glibc(&dir.path().join("missing.so")).unwrap_err().to_string();
    assert!(missing.contains("missing.so"), "{missing}");
    assert!(newest_glibc_in(&[0x7f, b'E', b'L', b'F', 2, 1, 1]).is_err(), "a truncated header");
}
