//! Versions: the library's, the C ABI's, and the range of `.sinew` format versions it reads.

use std::ffi::c_char;

use sinew_core::format::{MIN_VERSION_MAJOR, VERSION_MAJOR, VERSION_MINOR};

use crate::abi::SINEW_ABI_VERSION;

/// The library's version, NUL-terminated (the crate's, e.g. `0.1.0`).
const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "\0");

/// The `.sinew` format versions the library reads, from [`sinew_format_versions`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SinewFormatVersions {
    /// The oldest major version it reads.
    pub min_major: u16,
    /// The newest major version it reads; a file of a newer major version is refused
    /// (`SINEW_STATUS_INVALID_FORMAT`).
    pub max_major: u16,
    /// The minor version it was written for; files of a newer minor version of a major it reads
    /// load too (their additions are skipped, docs/FORMAT.md "Stability promise").
    pub minor: u16,
}

/// The library's version as a static NUL-terminated string (`"0.1.0"`), never freed.
// Safety (of the unmangled symbol): the name is unique to this library, prefixed `sinew_`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_version() -> *const c_char {
    VERSION.as_ptr().cast()
}

/// The library's C ABI version: equal to the `SINEW_ABI_VERSION` of the header it was built
/// with. A program compares it with its own `SINEW_ABI_VERSION` before any other call.
// Safety (of the unmangled symbol): the name is unique to this library, prefixed `sinew_`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_abi_version() -> u32 {
    SINEW_ABI_VERSION
}

/// The `.sinew` format versions the library reads.
// Safety (of the unmangled symbol): the name is unique to this library, prefixed `sinew_`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_format_versions() -> SinewFormatVersions {
    SinewFormatVersions {
        min_major: MIN_VERSION_MAJOR,
        max_major: VERSION_MAJOR,
        minor: VERSION_MINOR,
    }
}
