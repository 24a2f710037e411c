//! The `.sinew` writer, and a file's bytes read and checked by the core (any artefact, or an AIM
//! actor: the one reader of an actor file). The reader and every constant live in
//! `sinew_core::format`; this module only lays bytes out as `docs/FORMAT.md` specifies, so the
//! two cannot drift apart.

use std::path::{Path, PathBuf};

use sinew_core::FormatError;
use sinew_core::aim::AimActor;
use sinew_core::format::{
    ArtifactKind, CRC32, Dtype, ENTRY_CRC, ENTRY_DTYPE, ENTRY_KIND, ENTRY_LENGTH, ENTRY_NAME,
    ENTRY_OFFSET, ENTRY_RANK, HEADER_CRC, HEADER_FILE_LEN, HEADER_FLAGS, HEADER_KIND, HEADER_LEN,
    HEADER_MAGIC, HEADER_MAJOR, HEADER_MINOR, HEADER_SECTION_COUNT, MAGIC, MAX_RANK, MAX_SECTIONS,
    NAME_LEN, SECTION_ALIGN, SECTION_ENTRY_LEN, SectionKind, VERSION_MAJOR, VERSION_MINOR,
    data_start, entry_dim,
};

/// A `.sinew` file that could not be read or written, with its path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ContainerError {
    /// The file could not be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The bytes are not a valid artefact (the core's verdict).
    #[error("{}: invalid .sinew file", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: FormatError,
    },
    /// A valid artefact that is not an AIM actor where one is expected (or an actor the core
    /// refuses).
    #[error("{}: not an AIM actor", path.display())]
    NotAnActor {
        /// The file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// The artefact could not be laid out (see [`WriterError`]).
    #[error(transparent)]
    Build(#[from] WriterError),
    /// The bytes could not be written to disk (the message names the file).
    #[error(transparent)]
    Write(crate::io::atomic::AtomicWriteError),
}

/// A section, metadata entry or size that the format cannot hold, found before anything is
/// written.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WriterError {
    /// A section name that is empty, too long or not printable ASCII.
    #[error("section name {name:?} must be 1..={NAME_LEN} printable ASCII characters")]
    BadName {
        /// The name.
        name: String,
    },
    /// A section name given twice (or `meta`, which the metadata section takes).
    #[error("section name {name:?} is used twice")]
    DuplicateName {
        /// The name.
        name: String,
    },
    /// More dimensions than the format holds.
    #[error("section {name}: rank {rank} exceeds {MAX_RANK}")]
    Rank {
        /// The section.
        name: String,
        /// Its rank.
        rank: usize,
    },
    /// A dimension beyond `u32`.
    #[error("section {name}: dimension {dim} too large")]
    DimensionTooLarge {
        /// The section.
        name: String,
        /// The dimension.
        dim: usize,
    },
    /// Data whose length is not the shape's.
    #[error("section {name}: shape {dims:?} does not match {bytes} bytes of {dtype}")]
    ShapeMismatch {
        /// The section.
        name: String,
        /// Its shape.
        dims: Vec<u32>,
        /// Its data's length.
        bytes: usize,
        /// Its element type's name.
        dtype: &'static str,
    },
    /// A NaN or infinite `f32`.
    #[error("section {name}: value {index} is {value} (weights must be finite)")]
    NonFinite {
        /// The section.
        name: String,
        /// The value's index.
        index: usize,
        /// The value.
        value: f32,
    },
    /// A section of a validated file without an element type.
    #[error("section {name}: no data type")]
    NoDtype {
        /// The section.
        name: String,
    },
    /// A metadata key with `=` or a line break, an empty key, or a value with a line break.
    #[error("metadata entry {key:?} = {value:?} holds a forbidden character")]
    Metadata {
        /// The key.
        key: String,
        /// The value.
        value: String,
    },
    /// More sections than the format's limit.
    #[error("{sections} sections exceed the format's limit of {MAX_SECTIONS}")]
    TooManySections {
        /// The sections, metadata included.
        sections: usize,
    },
    /// An artefact (or its metadata) beyond 4 GiB.
    #[error("artefact of {bytes} bytes exceeds 4 GiB")]
    TooLarge {
        /// Its length.
        bytes: usize,
    },
}

/// One section waiting to be written.
#[derive(Clone, Debug)]
struct PendingSection {
    kind: SectionKind,
    name: String,
    dtype: Dtype,
    dims: Vec<u32>,
    data: Vec<u8>,
}

/// Builds a `.sinew` artefact in memory.
#[derive(Clone, Debug)]
pub struct SinewWriter {
    kind: ArtifactKind,
    flags: u32,
    metadata: Vec<(String, String)>,
    sections: Vec<PendingSection>,
}

impl SinewWriter {
    /// An empty artefact of `kind`.
    pub fn new(kind: ArtifactKind) -> Self {
        Self {
            kind,
            flags: 0,
            metadata: Vec::new(),
            sections: Vec::new(),
        }
    }

    /// A writer holding everything of a validated artefact (kind, flags, metadata, sections in
    /// order), to add sections to it and write it again.
    pub fn from_file(file: &sinew_core::SinewFile<'_>) -> Result<Self, WriterError> {
        let mut w = Self::new(file.kind);
        w.flags(file.flags);
        for (k, v) in file.metadata().iter() {
            w.meta(k, v);
        }
        for s in file.sections() {
            if s.kind == SectionKind::Metadata {
                continue;
            }
            let dims: Vec<usize> = s.dims().iter().map(|&d| d as usize).collect();
            let dtype = s.dtype.ok_or_else(|| WriterError::NoDtype {
                name: s.name().to_owned(),
            })?;
            w.push(s.name(), dtype, &dims, s.data().to_vec())?;
            if let Some(last) = w.sections.last_mut() {
                last.kind = s.kind;
            }
        }
        Ok(w)
    }

    /// Removes the sections whose names start with `prefix`; returns how many.
    pub fn remove_prefixed(&mut self, prefix: &str) -> usize {
        let before = self.sections.len();
        self.sections.retain(|s| !s.name.starts_with(prefix));
        before - self.sections.len()
    }

    /// Sets header flags (`sinew_core::format::FLAG_*`).
    pub fn flags(&mut self, flags: u32) -> &mut Self {
        self.flags = flags;
        self
    }

    /// Sets a metadata entry (replacing the key's value where it is set already, in its place).
    /// Keys hold no `=` or newline; values no newline.
    pub fn meta(&mut self, key: &str, value: impl ToString) -> &mut Self {
        let value = value.to_string();
        match self.metadata.iter_mut().find(|(k, _)| k == key) {
            Some(entry) => entry.1 = value,
            None => self.metadata.push((key.to_owned(), value)),
        }
        self
    }

    fn push(
        &mut self,
        name: &str,
        dtype: Dtype,
        dims: &[usize],
        data: Vec<u8>,
    ) -> Result<&mut Self, WriterError> {
        let name_owned = || name.to_owned();
        if name.is_empty() || name.len() > NAME_LEN || !name.bytes().all(|c| c.is_ascii_graphic()) {
            return Err(WriterError::BadName { name: name_owned() });
        }
        if name == "meta" || self.sections.iter().any(|s| s.name == name) {
            return Err(WriterError::DuplicateName { name: name_owned() });
        }
        if dims.len() > MAX_RANK {
            return Err(WriterError::Rank {
                name: name_owned(),
                rank: dims.len(),
            });
        }
        let dims: Vec<u32> = dims
            .iter()
            .map(|&d| {
                u32::try_from(d).map_err(|_| WriterError::DimensionTooLarge {
                    name: name_owned(),
                    dim: d,
                })
            })
            .collect::<Result<_, _>>()?;
        let elements: usize = dims.iter().map(|&d| d as usize).product();
        if elements * dtype.size() != data.len() {
            return Err(WriterError::ShapeMismatch {
                name: name_owned(),
                dims,
                bytes: data.len(),
                dtype: dtype.name(),
            });
        }
        self.sections.push(PendingSection {
            kind: SectionKind::Tensor,
            name: name.to_owned(),
            dtype,
            dims,
            data,
        });
        Ok(self)
    }

    /// Adds an `f32` tensor; every value must be finite.
    pub fn f32s(
        &mut self,
        name: &str,
        dims: &[usize],
        values: &[f32],
    ) -> Result<&mut Self, WriterError> {
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(WriterError::NonFinite {
                name: name.to_owned(),
                index: i,
                value: values[i],
            });
        }
        self.push(
            name,
            Dtype::F32,
            dims,
            values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        )
    }

    /// Adds a `u32` tensor.
    pub fn u32s(
        &mut self,
        name: &str,
        dims: &[usize],
        values: &[u32],
    ) -> Result<&mut Self, WriterError> {
        self.push(
            name,
            Dtype::U32,
            dims,
            values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        )
    }

    /// Adds a Q16.16 tensor.
    pub fn q16s(
        &mut self,
        name: &str,
        dims: &[usize],
        values: &[i32],
    ) -> Result<&mut Self, WriterError> {
        self.push(
            name,
            Dtype::Q16,
            dims,
            values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        )
    }

    /// Adds a section of a kind this version may not know (for forward-compatibility tests).
    pub fn raw(
        &mut self,
        kind: SectionKind,
        name: &str,
        data: Vec<u8>,
    ) -> Result<&mut Self, WriterError> {
        let len = data.len();
        self.push(name, Dtype::U8, &[len], data)?;
        if let Some(last) = self.sections.last_mut() {
            last.kind = kind;
        }
        Ok(self)
    }

    /// Serialises the artefact.
    pub fn to_bytes(&self) -> Result<Vec<u8>, WriterError> {
        let mut sections = Vec::with_capacity(self.sections.len() + 1);
        if !self.metadata.is_empty() {
            let mut text = String::new();
            for (k, v) in &self.metadata {
                if k.is_empty() || k.contains(['=', '\n', '\r']) || v.contains(['\n', '\r']) {
                    return Err(WriterError::Metadata {
                        key: k.clone(),
                        value: v.clone(),
                    });
                }
                text.push_str(k);
                text.push('=');
                text.push_str(v);
                text.push('\n');
            }
            let data = text.into_bytes();
            let dims = vec![
                u32::try_from(data.len())
                    .map_err(|_| WriterError::TooLarge { bytes: data.len() })?,
            ];
            sections.push(PendingSection {
                kind: SectionKind::Metadata,
                name: "meta".into(),
                dtype: Dtype::U8,
                dims,
                data,
            });
        }
        sections.extend(self.sections.iter().cloned());
        if sections.len() > MAX_SECTIONS {
            return Err(WriterError::TooManySections {
                sections: sections.len(),
            });
        }

        let mut offsets = Vec::with_capacity(sections.len());
        let mut cursor = data_start(sections.len());
        for s in &sections {
            offsets.push(cursor);
            cursor = (cursor + s.data.len()).div_ceil(SECTION_ALIGN) * SECTION_ALIGN;
        }
        let file_len = offsets
            .last()
            .zip(sections.last())
            .map_or(HEADER_LEN, |(o, s)| o + s.data.len());
        let file_len_u32 =
            u32::try_from(file_len).map_err(|_| WriterError::TooLarge { bytes: file_len })?;

        let mut out = vec![0u8; file_len];
        out[HEADER_MAGIC.range()].copy_from_slice(&MAGIC);
        out[HEADER_MAJOR.range()].copy_from_slice(&VERSION_MAJOR.to_le_bytes());
        out[HEADER_MINOR.range()].copy_from_slice(&VERSION_MINOR.to_le_bytes());
        out[HEADER_FLAGS.range()].copy_from_slice(&self.flags.to_le_bytes());
        out[HEADER_KIND.range()].copy_from_slice(&self.kind.code().to_le_bytes());
        out[HEADER_SECTION_COUNT.range()].copy_from_slice(&(sections.len() as u32).to_le_bytes());
        out[HEADER_FILE_LEN.range()].copy_from_slice(&file_len_u32.to_le_bytes());
        for (i, (s, &offset)) in sections.iter().zip(&offsets).enumerate() {
            let e = &mut out[HEADER_LEN + i * SECTION_ENTRY_LEN..][..SECTION_ENTRY_LEN];
            e[ENTRY_KIND.range()].copy_from_slice(&s.kind.code().to_le_bytes());
            e[ENTRY_DTYPE.range()].copy_from_slice(&[s.dtype.code()]);
            e[ENTRY_RANK.range()].copy_from_slice(&[s.dims.len() as u8]);
            e[ENTRY_NAME.range()][..s.name.len()].copy_from_slice(s.name.as_bytes());
            for (d, &dim) in s.dims.iter().enumerate() {
                e[entry_dim(d).range()].copy_from_slice(&dim.to_le_bytes());
            }
            e[ENTRY_OFFSET.range()].copy_from_slice(&(offset as u32).to_le_bytes());
            e[ENTRY_LENGTH.range()].copy_from_slice(&(s.data.len() as u32).to_le_bytes());
            e[ENTRY_CRC.range()].copy_from_slice(&CRC32.checksum(&s.data).to_le_bytes());
            out[offset..offset + s.data.len()].copy_from_slice(&s.data);
        }
        let table_end = HEADER_LEN + sections.len() * SECTION_ENTRY_LEN;
        let mut digest = CRC32.digest();
        digest.update(&out[..HEADER_CRC.offset]);
        digest.update(&out[HEADER_LEN..table_end]);
        let crc = digest.finalize();
        out[HEADER_CRC.range()].copy_from_slice(&crc.to_le_bytes());
        Ok(out)
    }

    /// Serialises and writes the artefact atomically.
    pub fn write(&self, path: &Path) -> Result<(), ContainerError> {
        crate::io::atomic::write(path, &self.to_bytes()?).map_err(ContainerError::Write)
    }
}

/// Reads and validates a `.sinew` file, naming the file in any error.
pub fn read(path: &Path) -> Result<Vec<u8>, ContainerError> {
    let bytes = read_bytes(path)?;
    sinew_core::SinewFile::from_bytes(&bytes).map_err(|source| invalid(path, source))?;
    Ok(bytes)
}

/// Reads an AIM actor file: its bytes, checked by the core as an actor ([`actor`] parses them
/// again where the actor is needed), naming the file in any error.
pub fn read_actor(path: &Path) -> Result<Vec<u8>, ContainerError> {
    let bytes = read(path)?;
    actor(path, &bytes)?;
    Ok(bytes)
}

/// The AIM actor in `bytes`, read from `path`: [`ContainerError::NotAnActor`] naming the file
/// when they are not one.
pub fn actor<'a>(path: &Path, bytes: &'a [u8]) -> Result<AimActor<'a>, ContainerError> {
    AimActor::from_bytes(bytes).map_err(|source| ContainerError::NotAnActor {
        path: path.to_owned(),
        source,
    })
}

/// Reads a file's bytes without validating them.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, ContainerError> {
    std::fs::read(path).map_err(|source| ContainerError::Read {
        path: path.to_owned(),
        source,
    })
}

/// The error for `path`, whose bytes the core rejected.
pub(crate) fn invalid(path: &Path, source: FormatError) -> ContainerError {
    ContainerError::Invalid {
        path: path.to_owned(),
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sinew_core::SinewFile;

    #[test]
    fn round_trips_bit_exactly() {
        let weights = [1.5f32, -0.0, f32::MIN_POSITIVE / 2.0, 3.25e-7, -1.0e30, 7.0];
        let mut w = SinewWriter::new(ArtifactKind::Network);
        w.meta("units", "cm").meta("seed", 7);
        w.f32s("w", &[2, 3], &weights).unwrap();
        w.u32s("idx", &[3], &[0, 5, u32::MAX]).unwrap();
        w.q16s("q", &[1], &[-65536]).unwrap();
        let bytes = w.to_bytes().unwrap();
        let f = SinewFile::from_bytes(&bytes).unwrap();
        assert_eq!(f.kind, ArtifactKind::Network);
        assert_eq!(f.metadata().get("units"), Some("cm"));
        assert_eq!(f.metadata().get("seed"), Some("7"));
        let back: Vec<u32> = f
            .f32_tensor("w", &[2, 3])
            .unwrap()
            .iter()
            .map(f32::to_bits)
            .collect();
        assert_eq!(
            back,
            weights.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(f.u32_tensor("idx", &[3]).unwrap().at(2), u32::MAX);
        assert_eq!(f.section("q").unwrap().q16s().unwrap().at(0), -65536);
        // Every section starts aligned, whatever the lengths before it.
        assert!(
            f.sections()
                .all(|s| (s.offset as usize).is_multiple_of(SECTION_ALIGN))
        );
        // Loading from an odd address works as well: the core never assumes alignment.
        let mut shifted = vec![0u8];
        shifted.extend_from_slice(&bytes);
        assert!(SinewFile::from_bytes(&shifted[1..]).is_ok());
    }

    #[test]
    fn rejects_bad_sections_before_writing() {
        let mut w = SinewWriter::new(ArtifactKind::Network);
        assert!(matches!(
            w.f32s("x", &[2], &[1.0, f32::NAN]),
            Err(WriterError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            w.f32s("x", &[3], &[1.0]),
            Err(WriterError::ShapeMismatch { bytes: 4, .. })
        ));
        assert!(matches!(
            w.f32s("a name that is much too long for the table", &[1], &[1.0]),
            Err(WriterError::BadName { .. })
        ));
        w.f32s("x", &[1], &[1.0]).unwrap();
        assert!(matches!(
            w.u32s("x", &[1], &[1]),
            Err(WriterError::DuplicateName { name }) if name == "x"
        ));
        w.meta("bad=key", 1);
        assert!(matches!(w.to_bytes(), Err(WriterError::Metadata { .. })));
    }

    #[test]
    fn read_names_the_file_and_the_core_verdict() {
        let dir = tempfile::tempdir().unwrap();
        let junk = dir.path().join("junk.sinew");
        std::fs::write(
            &junk,
            b"not an artefact at all, but long enough to have a header",
        )
        .unwrap();
        let err = read(&junk).unwrap_err();
        assert!(
            matches!(&err, ContainerError::Invalid { path, .. } if path == &junk),
            "{err:?}"
        );
        assert!(err.to_string().contains("junk.sinew"), "{err}");
        let missing = dir.path().join("missing.sinew");
        assert!(matches!(
            crate::io::inspect::inspect(&missing),
            Err(ContainerError::Read { path, .. }) if path == missing
        ));
    }

    #[test]
    fn unknown_section_kinds_are_skipped() {
        let mut w = SinewWriter::new(ArtifactKind::Network);
        w.raw(SectionKind::Other(999), "future", vec![1, 2, 3])
            .unwrap();
        w.f32s("w", &[1], &[2.0]).unwrap();
        let bytes = w.to_bytes().unwrap();
        let f = SinewFile::from_bytes(&bytes).unwrap();
        assert_eq!(f.section("future").unwrap().kind, SectionKind::Other(999));
        assert_eq!(f.f32_tensor("w", &[1]).unwrap().at(0), 2.0);
    }
}
