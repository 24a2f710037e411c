//! The errors of loading a baked model. Evaluation of a validated model cannot fail.

use core::fmt;

/// Why a byte slice is not a valid `.sinew` artefact.
///
/// Each variant names one exact failure, so a tool can print it next to the file name and the
/// user knows what to fix. The enum is small and `Copy` so that it is cheap on a microcontroller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum FormatError {
    /// The input is shorter than the fixed header.
    TooShort,
    /// The first eight bytes are not the `.sinew` magic.
    BadMagic,
    /// The file was written by a newer, incompatible major version of the format.
    UnsupportedMajor {
        /// The major version found in the file.
        found: u16,
    },
    /// A reserved header field or padding byte is not zero.
    NonZeroReserved,
    /// The header's file length differs from the number of bytes given.
    LengthMismatch {
        /// Length recorded in the header.
        header: u32,
        /// Length of the byte slice.
        actual: usize,
    },
    /// More sections than [`crate::layout::MAX_SECTIONS`].
    TooManySections,
    /// The CRC-32 over the header and section table does not match.
    HeaderChecksum,
    /// The section table or a section's data extends past the end of the file.
    TruncatedSection {
        /// Index of the section in the table.
        section: u16,
    },
    /// A section starts before the previous one ends, or is not aligned.
    BadLayout {
        /// Index of the section in the table.
        section: u16,
    },
    /// A section's CRC-32 does not match its data.
    SectionChecksum {
        /// Index of the section in the table.
        section: u16,
    },
    /// A section name is empty, not ASCII, or not NUL-padded.
    BadName {
        /// Index of the section in the table.
        section: u16,
    },
    /// Two sections share a name.
    DuplicateName {
        /// Index of the second section with that name.
        section: u16,
    },
    /// A data type code that this version does not know.
    UnknownDtype {
        /// Index of the section in the table.
        section: u16,
    },
    /// A rank above [`crate::layout::MAX_RANK`], or dimensions past the rank that are not zero.
    BadShape {
        /// Index of the section in the table.
        section: u16,
    },
    /// The product of the shape times the element size differs from the section length.
    ShapeMismatch {
        /// Index of the section in the table.
        section: u16,
    },
    /// A section the artefact kind requires is absent.
    MissingSection,
    /// A section has a different data type than its role requires.
    WrongDtype,
    /// Tensor shapes do not fit together (e.g. a layer's inputs and the previous layer's outputs).
    IncompatibleShapes,
    /// A weight is NaN or infinite.
    NonFinite,
    /// An index points outside the array it indexes.
    IndexOutOfRange,
    /// A count exceeds a limit of this build (layers, widths, vertices).
    LimitExceeded,
    /// A code (activation, artefact kind) has a value this version does not know.
    UnknownCode,
    /// The metadata section is not UTF-8 `key=value` lines.
    BadMetadata,
    /// The artefact is of another kind than the loader expects.
    WrongKind,
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::TooShort => write!(
                f,
                "file is shorter than the {}-byte header",
                crate::layout::HEADER_LEN
            ),
            Self::BadMagic => write!(f, "not a .sinew file (bad magic bytes)"),
            Self::UnsupportedMajor { found } => write!(
                f,
                "format major version {found} is newer than this build supports ({})",
                crate::layout::VERSION_MAJOR
            ),
            Self::NonZeroReserved => write!(f, "a reserved field or padding byte is not zero"),
            Self::LengthMismatch { header, actual } => {
                write!(
                    f,
                    "header says the file is {header} bytes, but it is {actual} bytes (truncated or padded)"
                )
            }
            Self::TooManySections => {
                write!(f, "more than {} sections", crate::layout::MAX_SECTIONS)
            }
            Self::HeaderChecksum => write!(f, "header/section-table CRC-32 mismatch (corrupted)"),
            Self::TruncatedSection { section } => {
                write!(f, "section {section} extends past the end of the file")
            }
            Self::BadLayout { section } => {
                write!(f, "section {section} overlaps another or is misaligned")
            }
            Self::SectionChecksum { section } => {
                write!(f, "section {section} data CRC-32 mismatch (corrupted)")
            }
            Self::BadName { section } => write!(f, "section {section} has an invalid name"),
            Self::DuplicateName { section } => {
                write!(f, "section {section} repeats an earlier section's name")
            }
            Self::UnknownDtype { section } => {
                write!(f, "section {section} has an unknown data type")
            }
            Self::BadShape { section } => write!(f, "section {section} has an invalid shape"),
            Self::ShapeMismatch { section } => {
                write!(
                    f,
                    "section {section} length does not match its shape and data type"
                )
            }
            Self::MissingSection => write!(f, "a required section is missing"),
            Self::WrongDtype => write!(f, "a section has the wrong data type for its role"),
            Self::IncompatibleShapes => write!(f, "tensor shapes do not fit together"),
            Self::NonFinite => write!(f, "a weight is NaN or infinite"),
            Self::IndexOutOfRange => write!(f, "an index is out of range"),
            Self::LimitExceeded => write!(f, "a count exceeds this build's limits"),
            Self::UnknownCode => write!(f, "an enumeration code is unknown"),
            Self::BadMetadata => write!(f, "metadata is not UTF-8 key=value lines"),
            Self::WrongKind => write!(f, "the artefact is of another kind than expected"),
        }
    }
}

impl core::error::Error for FormatError {}

/// A caller-provided buffer has the wrong length for the model it is used with.
///
/// This is the only way evaluation can refuse to run, and it depends on the caller's buffers,
/// never on model data: the sizes are reported by the model (`scratch_len()` and friends).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum BufferError {
    /// The input slice has the wrong length.
    Input,
    /// The output slice has the wrong length.
    Output,
    /// The scratch slice is shorter than the model's reported scratch length.
    Scratch,
}

impl fmt::Display for BufferError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Input => write!(f, "input buffer has the wrong length"),
            Self::Output => write!(f, "output buffer has the wrong length"),
            Self::Scratch => write!(f, "scratch buffer is too small"),
        }
    }
}

impl core::error::Error for BufferError {}
