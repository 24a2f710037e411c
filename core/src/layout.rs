//! The byte layout of the `.sinew` container: the magic, the versions, the sizes of the header and
//! of a section-table entry, and every limit `docs/FORMAT.md` names.
//!
//! This module depends on nothing else in the crate, so that both the reader ([`crate::format`],
//! which re-exports everything here) and the errors ([`crate::error`], whose messages quote the
//! limits) can use it without depending on each other.

/// The eight magic bytes: a non-ASCII first byte, the name, and CR LF / EOF / LF to catch text-mode
/// transfers, in the manner of PNG.
pub const MAGIC: [u8; 8] = [0x89, b'S', b'N', b'W', b'\r', b'\n', 0x1A, b'\n'];
/// Major format version: a reader rejects files with a larger major version.
pub const VERSION_MAJOR: u16 = 1;
/// Minor format version: additions that older readers can skip (new section kinds, new flags).
pub const VERSION_MINOR: u16 = 0;
/// Length of the fixed header in bytes.
pub const HEADER_LEN: usize = 32;
/// Length of one section-table entry in bytes.
pub const SECTION_ENTRY_LEN: usize = 64;
/// Bytes reserved for a section name (ASCII, NUL-padded, at least one byte long).
pub const NAME_LEN: usize = 32;
/// Largest tensor rank.
pub const MAX_RANK: usize = 4;
/// Largest number of sections in one file.
pub const MAX_SECTIONS: usize = 4096;
/// Every section's data starts at a multiple of this many bytes from the start of the file.
pub const SECTION_ALIGN: usize = 16;
/// Byte offset of the header CRC field; the CRC covers bytes `0..HEADER_CRC_OFFSET` and the table.
pub const HEADER_CRC_OFFSET: usize = 28;

/// Header flag: the artefact omits what only training or re-baking needs (e.g. an actor's networks).
pub const FLAG_PLAYBACK_ONLY: u32 = 1;
