//! `sinew inspect`: what a `.sinew` file holds, for people (text) and tools (JSON).

use std::path::Path;

use serde::Serialize;
use sinew_core::SinewFile;
use sinew_core::format::{FLAG_PLAYBACK_ONLY, SectionKind};

use crate::io::container::{ContainerError, invalid, read_bytes};

/// The JSON form of `sinew inspect --json`.
#[derive(Debug, Serialize)]
pub struct Report {
    /// The file inspected.
    pub file: String,
    /// Artefact kind name.
    pub kind: String,
    /// `major.minor`.
    pub version: String,
    /// Header flags, raw.
    pub flags: u32,
    /// Whether the playback-only flag is set.
    pub playback_only: bool,
    /// File size in bytes.
    pub bytes: usize,
    /// Header and section-table CRC-32, hex.
    pub header_crc32: String,
    /// "ok": every checksum, bound, shape and value was verified.
    pub checksums: &'static str,
    /// Metadata entries in file order.
    pub metadata: Vec<(String, String)>,
    /// The sections.
    pub sections: Vec<SectionReport>,
}

/// One section in [`Report`].
#[derive(Debug, Serialize)]
pub struct SectionReport {
    /// Section name.
    pub name: String,
    /// "metadata", "tensor" or "unknown(N)".
    pub kind: String,
    /// Element type.
    pub dtype: String,
    /// Dimensions.
    pub shape: Vec<u32>,
    /// Byte offset.
    pub offset: u32,
    /// Byte length.
    pub bytes: usize,
    /// CRC-32 of the data, hex.
    pub crc32: String,
}

/// Reads and validates `path`; the error names the file and the problem.
pub fn inspect(path: &Path) -> Result<Report, ContainerError> {
    let bytes = read_bytes(path)?;
    let f = SinewFile::from_bytes(&bytes).map_err(|source| invalid(path, source))?;
    let sections = f
        .sections()
        .map(|s| SectionReport {
            name: s.name().to_owned(),
            kind: match s.kind {
                SectionKind::Metadata => "metadata".into(),
                SectionKind::Tensor => "tensor".into(),
                SectionKind::Other(c) => format!("unknown({c})"),
            },
            dtype: s.dtype.map_or("?", |d| d.name()).to_owned(),
            shape: s.dims().to_vec(),
            offset: s.offset,
            bytes: s.data().len(),
            crc32: format!("{:08x}", s.crc),
        })
        .collect();
    Ok(Report {
        file: path.display().to_string(),
        kind: match f.kind {
            sinew_core::ArtifactKind::Other(c) => format!("unknown({c})"),
            k => k.name().to_owned(),
        },
        version: format!("{}.{}", f.major, f.minor),
        flags: f.flags,
        playback_only: f.flags & FLAG_PLAYBACK_ONLY != 0,
        bytes: bytes.len(),
        header_crc32: format!("{:08x}", f.header_crc),
        checksums: "ok",
        metadata: f
            .metadata()
            .iter()
            .map(|(k, v)| (k.to_owned(), v.to_owned()))
            .collect(),
        sections,
    })
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{}: sinew {} v{}, {} bytes, flags {:#x}{}",
            self.file,
            self.kind,
            self.version,
            self.bytes,
            self.flags,
            if self.playback_only {
                " (playback-only)"
            } else {
                ""
            }
        )?;
        writeln!(
            f,
            "checksums: {} (header+table crc32 {})",
            self.checksums, self.header_crc32
        )?;
        for (k, v) in &self.metadata {
            writeln!(f, "  meta {k} = {v}")?;
        }
        writeln!(
            f,
            "  {:<32} {:<10} {:<7} {:<20} {:>10} {:>10}  crc32",
            "section", "kind", "dtype", "shape", "offset", "bytes"
        )?;
        for s in &self.sections {
            let shape = format!("{:?}", s.shape);
            writeln!(
                f,
                "  {:<32} {:<10} {:<7} {:<20} {:>10} {:>10}  {}",
                s.name, s.kind, s.dtype, shape, s.offset, s.bytes, s.crc32
            )?;
        }
        Ok(())
    }
}
