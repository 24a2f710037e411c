//! The `.sinew` container: one byte format for every baked artefact (actor models, decoders,
//! generators, performances, replays). `docs/FORMAT.md` is the normative description; every limit
//! it names is a constant of [`crate::layout`], re-exported here.
//!
//! [`SinewFile::from_bytes`] validates the whole container once: header, section table, bounds,
//! layout, checksums, shapes and finiteness of every `f32` tensor. Typed loaders (an MLP, an actor)
//! then only check roles and index ranges, and evaluation cannot fail on model data.

use crate::error::{Bound, FormatError, SectionName};
pub use crate::layout::*;
use crate::tensor::{F32s, I32s, U32s};

/// The CRC-32 used throughout (the ISO-HDLC polynomial of zlib, PNG and gzip).
pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// What an artefact is. Codes not known to this version load as [`ArtifactKind::Other`], so that
/// generic tools (`sinew inspect`) still read them; typed loaders reject them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArtifactKind {
    /// One or more stand-alone networks (used for kernel checks and tests).
    Network,
    /// An AIM actor: anatomy networks and/or the per-vertex playback cache.
    AimActor,
    /// An S2D-Dec sparse-to-dense decoder with its mesh hierarchy.
    S2dDecoder,
    /// A Motion3DGAN landmark-motion generator.
    MotionGenerator,
    /// A fitted performance (per-frame model inputs).
    Performance,
    /// A replay script: a model's content hash, inputs and expected frame hashes.
    Replay,
    /// A landmark driver: a network from one frame's 68 landmarks to an actor's pose.
    Driver,
    /// A kind this version does not know.
    Other(u16),
}

impl ArtifactKind {
    /// The on-disk code.
    pub const fn code(self) -> u16 {
        match self {
            Self::Network => 1,
            Self::AimActor => 2,
            Self::S2dDecoder => 3,
            Self::MotionGenerator => 4,
            Self::Performance => 5,
            Self::Replay => 6,
            Self::Driver => 7,
            Self::Other(c) => c,
        }
    }

    /// The kind for an on-disk code.
    pub const fn from_code(code: u16) -> Self {
        match code {
            1 => Self::Network,
            2 => Self::AimActor,
            3 => Self::S2dDecoder,
            4 => Self::MotionGenerator,
            5 => Self::Performance,
            6 => Self::Replay,
            7 => Self::Driver,
            c => Self::Other(c),
        }
    }

    /// A short lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Network => "network",
            Self::AimActor => "aim-actor",
            Self::S2dDecoder => "s2d-decoder",
            Self::MotionGenerator => "motion-generator",
            Self::Performance => "performance",
            Self::Replay => "replay",
            Self::Driver => "driver",
            Self::Other(_) => "unknown",
        }
    }
}

impl core::fmt::Display for ArtifactKind {
    /// The kind in words with its article, for messages: "an AIM actor", "a replay", "an
    /// artefact of unknown kind 7".
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Network => f.write_str("a network"),
            Self::AimActor => f.write_str("an AIM actor"),
            Self::S2dDecoder => f.write_str("an S2D decoder"),
            Self::MotionGenerator => f.write_str("a motion generator"),
            Self::Performance => f.write_str("a fitted performance"),
            Self::Replay => f.write_str("a replay"),
            Self::Driver => f.write_str("a landmark driver"),
            Self::Other(code) => write!(f, "an artefact of unknown kind {code}"),
        }
    }
}

/// What a section holds. Unknown codes are bounds- and checksum-checked, then skipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SectionKind {
    /// UTF-8 `key=value` lines (units, axes, provenance).
    Metadata,
    /// A typed tensor.
    Tensor,
    /// A kind this version does not know; its data is never interpreted.
    Other(u16),
}

impl SectionKind {
    /// The on-disk code.
    pub const fn code(self) -> u16 {
        match self {
            Self::Metadata => 1,
            Self::Tensor => 2,
            Self::Other(c) => c,
        }
    }

    /// The kind for an on-disk code.
    pub const fn from_code(code: u16) -> Self {
        match code {
            1 => Self::Metadata,
            2 => Self::Tensor,
            c => Self::Other(c),
        }
    }
}

/// The element type of a section.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dtype {
    /// Raw bytes (metadata text).
    U8,
    /// IEEE-754 binary32, little-endian.
    F32,
    /// Unsigned 32-bit integer, little-endian (indices, counts).
    U32,
    /// Signed Q16.16 fixed point in a little-endian `i32`.
    Q16,
}

impl Dtype {
    /// The on-disk code.
    pub const fn code(self) -> u8 {
        match self {
            Self::U8 => 1,
            Self::F32 => 2,
            Self::U32 => 3,
            Self::Q16 => 4,
        }
    }

    /// The type for an on-disk code.
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            1 => Some(Self::U8),
            2 => Some(Self::F32),
            3 => Some(Self::U32),
            4 => Some(Self::Q16),
            _ => None,
        }
    }

    /// Bytes per element.
    pub const fn size(self) -> usize {
        match self {
            Self::U8 => 1,
            Self::F32 | Self::U32 | Self::Q16 => 4,
        }
    }

    /// A short lower-case name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::U8 => "u8",
            Self::F32 => "f32",
            Self::U32 => "u32",
            Self::Q16 => "q16.16",
        }
    }
}

/// One validated section of a [`SinewFile`].
#[derive(Clone, Copy, Debug)]
pub struct Section<'a> {
    /// Position in the section table.
    pub index: u16,
    /// What the section holds.
    pub kind: SectionKind,
    /// Element type; `None` only for sections of an unknown kind.
    pub dtype: Option<Dtype>,
    /// Number of meaningful entries of `shape`.
    pub rank: u8,
    /// Dimensions; entries past `rank` are zero.
    pub shape: [u32; MAX_RANK],
    /// Byte offset of the data from the start of the file.
    pub offset: u32,
    /// CRC-32 of the data.
    pub crc: u32,
    name: &'a [u8],
    data: &'a [u8],
}

impl<'a> Section<'a> {
    /// The name (ASCII, validated at load).
    pub fn name(&self) -> &'a str {
        core::str::from_utf8(self.name).unwrap_or("")
    }

    /// The raw data bytes.
    pub const fn data(&self) -> &'a [u8] {
        self.data
    }

    /// The meaningful dimensions.
    pub fn dims(&self) -> &[u32] {
        self.shape.get(..usize::from(self.rank)).unwrap_or(&[])
    }

    /// Number of elements (product of the dimensions; 1 for rank 0).
    pub fn elements(&self) -> usize {
        self.dims()
            .iter()
            .fold(1usize, |n, &d| n.saturating_mul(d as usize))
    }

    /// The data as `f32` values, if this is an `f32` tensor.
    pub fn f32s(&self) -> Option<F32s<'a>> {
        (self.kind == SectionKind::Tensor && self.dtype == Some(Dtype::F32))
            .then(|| F32s::new(self.data))
            .flatten()
    }

    /// The data as `u32` values, if this is a `u32` tensor.
    pub fn u32s(&self) -> Option<U32s<'a>> {
        (self.kind == SectionKind::Tensor && self.dtype == Some(Dtype::U32))
            .then(|| U32s::new(self.data))
            .flatten()
    }

    /// The data as Q16.16 values, if this is a Q16.16 tensor.
    pub fn q16s(&self) -> Option<I32s<'a>> {
        (self.kind == SectionKind::Tensor && self.dtype == Some(Dtype::Q16))
            .then(|| I32s::new(self.data))
            .flatten()
    }
}

/// The metadata of an artefact: `key=value` lines of UTF-8 text.
#[derive(Clone, Copy, Debug)]
pub struct Metadata<'a> {
    text: &'a str,
}

impl<'a> Metadata<'a> {
    /// The value of `key`, if present (the first occurrence).
    pub fn get(&self, key: &str) -> Option<&'a str> {
        self.iter().find(|(k, _)| *k == key).map(|(_, v)| v)
    }

    /// All `(key, value)` pairs in file order.
    pub fn iter(&self) -> impl Iterator<Item = (&'a str, &'a str)> + 'a {
        self.text
            .lines()
            .filter(|l| !l.is_empty())
            .filter_map(|l| l.split_once('='))
    }

    /// [`FormatError::BadMetadata`] for the entry `key`, which the artefact's kind requires:
    /// naming its line (counted from 1), or line 0 when the metadata has no such entry.
    pub fn bad_entry(&self, key: &str) -> FormatError {
        let line = self
            .text
            .lines()
            .position(|l| l.split_once('=').is_some_and(|(k, _)| k == key));
        FormatError::BadMetadata {
            key: SectionName::new(key),
            line: line.map_or(0, |i| {
                u32::try_from(i).map_or(u32::MAX, |i| i.saturating_add(1))
            }),
        }
    }

    /// The whole text.
    pub const fn text(&self) -> &'a str {
        self.text
    }
}

/// A validated `.sinew` container over a borrowed byte slice of any alignment.
#[derive(Clone, Copy, Debug)]
pub struct SinewFile<'a> {
    bytes: &'a [u8],
    /// Major version found in the file.
    pub major: u16,
    /// Minor version found in the file.
    pub minor: u16,
    /// Header flags (`FLAG_*`); unknown bits are kept and ignored.
    pub flags: u32,
    /// What the artefact is.
    pub kind: ArtifactKind,
    /// CRC-32 of the header and section table (also the artefact's cheap identity).
    pub header_crc: u32,
    section_count: u16,
}

/// The `u16` in field `f` of `b` (`None` if `b` is too short or the field is not two bytes).
fn u16_in(b: &[u8], f: Field) -> Option<u16> {
    match b.get(f.range()) {
        Some(&[x, y]) => Some(u16::from_le_bytes([x, y])),
        _ => None,
    }
}

/// The `u32` in field `f` of `b` (`None` if `b` is too short or the field is not four bytes).
fn u32_in(b: &[u8], f: Field) -> Option<u32> {
    match b.get(f.range()) {
        Some(&[x, y, z, w]) => Some(u32::from_le_bytes([x, y, z, w])),
        _ => None,
    }
}

/// The `u8` in field `f` of `b` (`None` if `b` is too short or the field is not one byte).
fn u8_in(b: &[u8], f: Field) -> Option<u8> {
    match b.get(f.range()) {
        Some(&[x]) => Some(x),
        _ => None,
    }
}

/// Start of the data area for `count` sections.
pub const fn data_start(count: usize) -> usize {
    let table_end = HEADER_LEN + count * SECTION_ENTRY_LEN;
    table_end.div_ceil(SECTION_ALIGN) * SECTION_ALIGN
}

/// A section-table entry as stored, before its data is looked at.
struct Entry<'a> {
    kind: u16,
    dtype: u8,
    rank: u8,
    name: &'a [u8],
    shape: [u32; MAX_RANK],
    offset: u32,
    length: u32,
    crc: u32,
}

fn read_entry(table: &[u8], i: usize) -> Option<Entry<'_>> {
    let e = table
        .get(i.checked_mul(SECTION_ENTRY_LEN)?..)?
        .get(..SECTION_ENTRY_LEN)?;
    let name_field = e.get(ENTRY_NAME.range())?;
    let name_len = name_field.iter().position(|&c| c == 0).unwrap_or(NAME_LEN);
    let mut shape = [0u32; MAX_RANK];
    for (d, s) in shape.iter_mut().enumerate() {
        *s = u32_in(e, entry_dim(d))?;
    }
    Some(Entry {
        kind: u16_in(e, ENTRY_KIND)?,
        dtype: u8_in(e, ENTRY_DTYPE)?,
        rank: u8_in(e, ENTRY_RANK)?,
        name: name_field.get(..name_len)?,
        shape,
        offset: u32_in(e, ENTRY_OFFSET)?,
        length: u32_in(e, ENTRY_LENGTH)?,
        crc: u32_in(e, ENTRY_CRC)?,
    })
}

fn valid_name(field_len: usize, name: &[u8], padding: &[u8]) -> bool {
    !name.is_empty()
        && name.len() <= field_len
        && name.iter().all(|&c| c.is_ascii_graphic())
        && padding.iter().all(|&c| c == 0)
}

impl<'a> SinewFile<'a> {
    /// Validates `bytes` as a `.sinew` container.
    ///
    /// Checks, in order: length, magic, major version, reserved fields, declared length, section
    /// count, header CRC, then for every section its name, type, shape, bounds, alignment and
    /// order, data CRC, the zero padding between sections and, for `f32` tensors, that every value
    /// is finite; the metadata section must be UTF-8 `key=value` lines.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let header = bytes.get(..HEADER_LEN).ok_or(FormatError::TooShort)?;
        if header.get(HEADER_MAGIC.range()) != Some(&MAGIC[..]) {
            return Err(FormatError::BadMagic);
        }
        let field16 = |f| u16_in(header, f).ok_or(FormatError::TooShort);
        let field32 = |f| u32_in(header, f).ok_or(FormatError::TooShort);
        let major = field16(HEADER_MAJOR)?;
        let minor = field16(HEADER_MINOR)?;
        let flags = field32(HEADER_FLAGS)?;
        let kind = ArtifactKind::from_code(field16(HEADER_KIND)?);
        if !(MIN_VERSION_MAJOR..=VERSION_MAJOR).contains(&major) {
            return Err(FormatError::UnsupportedMajor { found: major });
        }
        if field16(HEADER_RESERVED)? != 0 {
            return Err(FormatError::NonZeroReserved);
        }
        let count = field32(HEADER_SECTION_COUNT)? as usize;
        let file_len = field32(HEADER_FILE_LEN)?;
        let header_crc = field32(HEADER_CRC)?;
        if file_len as usize != bytes.len() {
            return Err(FormatError::LengthMismatch {
                header: file_len,
                actual: bytes.len(),
            });
        }
        if count > MAX_SECTIONS {
            return Err(FormatError::TooManySections);
        }
        let table_end = HEADER_LEN + count * SECTION_ENTRY_LEN;
        let table = bytes
            .get(HEADER_LEN..table_end)
            .ok_or(FormatError::TruncatedSection { section: 0 })?;
        let mut digest = CRC32.digest();
        digest.update(header.get(..HEADER_CRC_OFFSET).unwrap_or(&[]));
        digest.update(table);
        if digest.finalize() != header_crc {
            return Err(FormatError::HeaderChecksum);
        }

        let mut cursor = table_end;
        let mut metadata_seen = false;
        for i in 0..count {
            // `count <= MAX_SECTIONS < u16::MAX`, so the index always fits.
            let section = u16::try_from(i).map_err(|_| FormatError::TooManySections)?;
            let e = read_entry(table, i).ok_or(FormatError::TruncatedSection { section })?;
            let field = table
                .get(ENTRY_NAME.at(i * SECTION_ENTRY_LEN))
                .unwrap_or(&[]);
            if !valid_name(NAME_LEN, e.name, field.get(e.name.len()..).unwrap_or(&[])) {
                return Err(FormatError::BadName { section });
            }
            for j in 0..i {
                if read_entry(table, j).is_some_and(|p| p.name == e.name) {
                    return Err(FormatError::DuplicateName { section });
                }
            }
            let start = e.offset as usize;
            let end = start
                .checked_add(e.length as usize)
                .ok_or(FormatError::TruncatedSection { section })?;
            if !start.is_multiple_of(SECTION_ALIGN) || start < cursor {
                return Err(FormatError::BadLayout { section });
            }
            if end > bytes.len() {
                return Err(FormatError::TruncatedSection { section });
            }
            if bytes
                .get(cursor..start)
                .is_none_or(|pad| pad.iter().any(|&b| b != 0))
            {
                return Err(FormatError::NonZeroReserved);
            }
            let data = bytes
                .get(start..end)
                .ok_or(FormatError::TruncatedSection { section })?;
            if CRC32.checksum(data) != e.crc {
                return Err(FormatError::SectionChecksum { section });
            }
            cursor = end;
            let kind = SectionKind::from_code(e.kind);
            if let SectionKind::Other(_) = kind {
                continue; // Unknown kinds: bounds and checksum checked above, contents skipped.
            }
            let dtype = Dtype::from_code(e.dtype).ok_or(FormatError::UnknownDtype { section })?;
            let rank = usize::from(e.rank);
            if rank > MAX_RANK || e.shape.iter().skip(rank).any(|&d| d != 0) {
                return Err(FormatError::BadShape { section });
            }
            let elements = e
                .shape
                .iter()
                .take(rank)
                .try_fold(1usize, |n, &d| n.checked_mul(d as usize));
            if elements.and_then(|n| n.checked_mul(dtype.size())) != Some(data.len()) {
                return Err(FormatError::ShapeMismatch { section });
            }
            match kind {
                SectionKind::Metadata => {
                    // One `u8 [n]` section called `meta` (a second one repeats its name).
                    if e.name != b"meta" {
                        return Err(FormatError::BadName { section });
                    }
                    if metadata_seen {
                        return Err(FormatError::DuplicateName { section });
                    }
                    if dtype != Dtype::U8 {
                        return Err(wrong_dtype("meta"));
                    }
                    if rank != 1 {
                        return Err(FormatError::BadShape { section });
                    }
                    metadata_seen = true;
                    let text = core::str::from_utf8(data).map_err(|e| {
                        let before = data.get(..e.valid_up_to()).unwrap_or(&[]);
                        bad_line(before.iter().filter(|&&b| b == b'\n').count())
                    })?;
                    if let Some(i) = text.lines().position(|l| !l.is_empty() && !l.contains('=')) {
                        return Err(bad_line(i));
                    }
                }
                SectionKind::Tensor if dtype == Dtype::F32 => {
                    let values = F32s::new(data).ok_or(FormatError::ShapeMismatch { section })?;
                    if let Some(index) = values.iter().position(|v| !v.is_finite()) {
                        return Err(FormatError::NonFiniteValue {
                            section: SectionName::new(core::str::from_utf8(e.name).unwrap_or("")),
                            index: index as u32,
                        });
                    }
                }
                _ => {}
            }
        }
        if cursor != bytes.len() {
            return Err(FormatError::LengthMismatch {
                header: file_len,
                actual: cursor,
            });
        }
        let section_count = u16::try_from(count).map_err(|_| FormatError::TooManySections)?;
        Ok(Self {
            bytes,
            major,
            minor,
            flags,
            kind,
            header_crc,
            section_count,
        })
    }

    /// Validates `bytes` and checks that the artefact is of `kind`.
    pub fn from_bytes_of_kind(bytes: &'a [u8], kind: ArtifactKind) -> Result<Self, FormatError> {
        let file = Self::from_bytes(bytes)?;
        if file.kind == kind {
            Ok(file)
        } else {
            Err(FormatError::WrongKind)
        }
    }

    /// The whole file.
    pub const fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// Number of sections (of every kind).
    pub const fn section_count(&self) -> usize {
        self.section_count as usize
    }

    /// The section at table position `index`.
    pub fn section_at(&self, index: usize) -> Option<Section<'a>> {
        let table = self
            .bytes
            .get(HEADER_LEN..HEADER_LEN + self.section_count() * SECTION_ENTRY_LEN)?;
        let e = read_entry(table, index)?;
        let start = e.offset as usize;
        let data = self
            .bytes
            .get(start..start.checked_add(e.length as usize)?)?;
        Some(Section {
            index: u16::try_from(index).ok()?,
            kind: SectionKind::from_code(e.kind),
            dtype: Dtype::from_code(e.dtype),
            rank: e.rank,
            shape: e.shape,
            offset: e.offset,
            crc: e.crc,
            name: e.name,
            data,
        })
    }

    /// All sections in table order, unknown kinds included.
    pub fn sections(&self) -> impl Iterator<Item = Section<'a>> + '_ {
        (0..self.section_count()).filter_map(|i| self.section_at(i))
    }

    /// The section called `name`, if any.
    pub fn section(&self, name: &str) -> Option<Section<'a>> {
        self.sections().find(|s| s.name == name.as_bytes())
    }

    /// The metadata (empty when the file has none).
    pub fn metadata(&self) -> Metadata<'a> {
        let text = self
            .sections()
            .find(|s| s.kind == SectionKind::Metadata)
            .and_then(|s| core::str::from_utf8(s.data).ok())
            .unwrap_or("");
        Metadata { text }
    }

    /// The `f32` tensor called `name` with exactly the dimensions `dims`.
    pub fn f32_tensor(&self, name: &str, dims: &[u32]) -> Result<F32s<'a>, FormatError> {
        let s = self.section(name).ok_or_else(|| missing(name))?;
        let v = s.f32s().ok_or_else(|| wrong_dtype(name))?;
        if s.dims() == dims {
            Ok(v)
        } else {
            Err(FormatError::incompatible_shapes(name))
        }
    }

    /// The `f32` tensor called `name` with exactly the dimensions `dims`, every value within
    /// `bound` (docs/FORMAT.md, "Value bounds").
    ///
    /// # Errors
    /// As [`Self::f32_tensor`]; [`FormatError::ValueOutOfRange`] naming the first value outside.
    pub fn f32_tensor_within(
        &self,
        name: &str,
        dims: &[u32],
        bound: Bound,
    ) -> Result<F32s<'a>, FormatError> {
        let v = self.f32_tensor(name, dims)?;
        check_within(name, v, bound)?;
        Ok(v)
    }

    /// The `u32` tensor called `name` with exactly the dimensions `dims`.
    pub fn u32_tensor(&self, name: &str, dims: &[u32]) -> Result<U32s<'a>, FormatError> {
        let s = self.section(name).ok_or_else(|| missing(name))?;
        let v = s.u32s().ok_or_else(|| wrong_dtype(name))?;
        if s.dims() == dims {
            Ok(v)
        } else {
            Err(FormatError::incompatible_shapes(name))
        }
    }

    /// The Q16.16 tensor called `name` with exactly the dimensions `dims`.
    pub fn q16_tensor(&self, name: &str, dims: &[u32]) -> Result<I32s<'a>, FormatError> {
        let s = self.section(name).ok_or_else(|| missing(name))?;
        let v = s.q16s().ok_or_else(|| wrong_dtype(name))?;
        if s.dims() == dims {
            Ok(v)
        } else {
            Err(FormatError::incompatible_shapes(name))
        }
    }

    /// The dimensions of the tensor called `name`.
    pub fn dims_of(&self, name: &str) -> Result<([u32; MAX_RANK], u8), FormatError> {
        let s = self.section(name).ok_or_else(|| missing(name))?;
        Ok((s.shape, s.rank))
    }
}

/// [`FormatError::BadMetadata`] for the line after the first `i` lines of the metadata text.
fn bad_line(i: usize) -> FormatError {
    FormatError::BadMetadata {
        key: SectionName::new(""),
        line: u32::try_from(i).map_or(u32::MAX, |i| i.saturating_add(1)),
    }
}

/// [`FormatError::MissingSection`] naming the section `name`.
pub fn missing(name: &str) -> FormatError {
    FormatError::MissingSection {
        section: SectionName::new(name),
    }
}

/// [`FormatError::WrongDtype`] naming the section `name`.
pub fn wrong_dtype(name: &str) -> FormatError {
    FormatError::WrongDtype {
        section: SectionName::new(name),
    }
}

/// Checks that every value of section `name`'s `values` keeps `bound`.
///
/// # Errors
/// [`FormatError::ValueOutOfRange`] naming the first value that does not.
pub fn check_within(name: &str, values: F32s<'_>, bound: Bound) -> Result<(), FormatError> {
    match values.iter().position(|v| !bound.contains(v)) {
        Some(index) => Err(out_of_range(name, index, bound)),
        None => Ok(()),
    }
}

/// [`FormatError::ValueOutOfRange`] for value `index` of section `name`.
pub fn out_of_range(name: &str, index: usize, bound: Bound) -> FormatError {
    FormatError::ValueOutOfRange {
        section: SectionName::new(name),
        index: u32::try_from(index).unwrap_or(u32::MAX),
        bound,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pinned_constants() {
        // These values are the format; changing any of them is a new major version.
        assert_eq!(&MAGIC, b"\x89SNW\r\n\x1a\n");
        assert_eq!((VERSION_MAJOR, VERSION_MINOR), (1, 0));
        assert_eq!(HEADER_LEN, 32);
        assert_eq!(SECTION_ENTRY_LEN, 64);
        assert_eq!(4 + NAME_LEN + 4 * MAX_RANK + 12, SECTION_ENTRY_LEN);
        assert_eq!(data_start(0), 32);
        assert_eq!(data_start(1), 96);
        assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn rejects_short_and_foreign_input() {
        assert_eq!(
            SinewFile::from_bytes(&[]).unwrap_err(),
            FormatError::TooShort
        );
        assert_eq!(
            SinewFile::from_bytes(&[0u8; 64]).unwrap_err(),
            FormatError::BadMagic
        );
    }

    /// A hand-assembled file with zero sections, to pin the header layout byte by byte.
    #[test]
    fn empty_file_layout() {
        let mut b = [0u8; 32];
        b[..8].copy_from_slice(&MAGIC);
        b[8..10].copy_from_slice(&1u16.to_le_bytes());
        b[16..18].copy_from_slice(&ArtifactKind::Replay.code().to_le_bytes());
        b[24..28].copy_from_slice(&32u32.to_le_bytes());
        let crc = CRC32.checksum(&b[..28]);
        b[28..].copy_from_slice(&crc.to_le_bytes());
        let f = SinewFile::from_bytes(&b).unwrap();
        assert_eq!(f.kind, ArtifactKind::Replay);
        assert_eq!(f.section_count(), 0);
        assert_eq!(f.metadata().get("units"), None);
        b[8] = 2;
        assert_eq!(
            SinewFile::from_bytes(&b).unwrap_err(),
            FormatError::UnsupportedMajor { found: 2 }
        );
    }
}
