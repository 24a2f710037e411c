//! The errors of loading a baked model ([`FormatError`]) and of evaluating one: a caller's buffer
//! of the wrong length ([`BufferError`]) or a caller's number the core refuses ([`InputError`]),
//! together [`EvalError`]. Evaluation of a validated model never fails on the model's own data.

use core::fmt;

use crate::layout::{
    MAX_COORDINATE, MAX_FACTOR, MAX_ROTATION_ENTRY, MIN_ROTATION_COLUMN, NAME_LEN,
};

/// A section's name (or a metadata key) carried by an error: up to [`NAME_LEN`] ASCII bytes,
/// `Copy` and without a lifetime, so that [`FormatError`] stays a small value that outlives the
/// bytes it describes.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct SectionName {
    bytes: [u8; NAME_LEN],
    len: u8,
}

impl SectionName {
    /// The name `name`, cut to [`NAME_LEN`] bytes (a valid section name is never longer).
    pub fn new(name: &str) -> Self {
        let mut bytes = [0u8; NAME_LEN];
        let len = name.len().min(NAME_LEN);
        if let (Some(d), Some(s)) = (bytes.get_mut(..len), name.as_bytes().get(..len)) {
            d.copy_from_slice(s);
        }
        Self {
            bytes,
            len: len as u8,
        }
    }

    /// The name as text.
    pub fn as_str(&self) -> &str {
        let bytes = self.bytes.get(..usize::from(self.len)).unwrap_or(&[]);
        core::str::from_utf8(bytes).unwrap_or("?")
    }
}

impl fmt::Display for SectionName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Debug for SectionName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

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
    /// The file's major format version is outside the range this build reads
    /// ([`crate::layout::MIN_VERSION_MAJOR`] to [`crate::layout::VERSION_MAJOR`]).
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
    MissingSection {
        /// The section's name.
        section: SectionName,
    },
    /// A section has a different data type than its role requires.
    WrongDtype {
        /// The section's name.
        section: SectionName,
    },
    /// Tensor shapes do not fit together (e.g. a layer's inputs and the previous layer's outputs).
    /// A kernel's constructor names its argument (`weight`, `indices`); a loader names the
    /// section, or a network's prefix ([`FormatError::in_section`]).
    IncompatibleShapes {
        /// The section (or the kernel's argument, or a network's prefix) whose shape does not fit.
        section: SectionName,
    },
    /// A weight given to a kernel's constructor is NaN or infinite. Files never get here: the
    /// container reports [`FormatError::NonFiniteValue`] first.
    NonFinite,
    /// A value of an `f32` section is NaN or infinite.
    NonFiniteValue {
        /// The section's name.
        section: SectionName,
        /// The value's index in the section (row-major).
        index: u32,
    },
    /// A value of a section breaks the bound its role has (docs/FORMAT.md, "Value bounds"), so
    /// that evaluation could leave the finite numbers.
    ValueOutOfRange {
        /// The section's name.
        section: SectionName,
        /// The value's index in the section (row-major).
        index: u32,
        /// The rule it breaks.
        bound: Bound,
    },
    /// A network's weights let it reach beyond its [`NetworkLimit`] for inputs within their
    /// bounds (docs/FORMAT.md, "Value bounds"): ±[`MAX_NETWORK_VALUE`](crate::layout::MAX_NETWORK_VALUE) for any layer, where
    /// evaluating it could overflow `f32`, or a tighter limit its outputs are held to.
    Unbounded {
        /// The weight section of the layer where the bound is passed.
        section: SectionName,
        /// The layer's output (the weight row) whose bound is passed.
        row: u32,
        /// The limit it passes.
        limit: NetworkLimit,
    },
    /// An index points outside the array it indexes (or, in a sparse matrix's row pointers,
    /// does not rise from 0 to the entry count). A kernel's constructor, which sees no file,
    /// names its argument (`indices`, `row_ptr`, `col_idx`); a loader names the section
    /// ([`FormatError::in_section`]).
    IndexOutOfRange {
        /// The section (or the kernel's argument) holding the index.
        section: SectionName,
        /// The index's position in it.
        index: u32,
    },
    /// A count exceeds a limit of this build (layers, widths, vertices, a section name's length).
    LimitExceeded {
        /// The section (or the kernel's argument, or a network's prefix) the count is of.
        section: SectionName,
        /// The count, saturated at `u32::MAX` (then no more than `limit` when the count is a
        /// size past this build's `usize`; see [`FormatError::size_overflow`]).
        value: u32,
        /// The largest count this build takes, saturated at `u32::MAX`.
        limit: u32,
    },
    /// A code (an activation, an input normalisation) has a value this version does not know.
    UnknownCode {
        /// The section (or the kernel's argument) holding the code.
        section: SectionName,
        /// The code's position in it.
        index: u32,
        /// The code.
        code: u32,
    },
    /// The metadata is not UTF-8 `key=value` lines, or an entry the artefact's kind requires is
    /// absent or has a value it does not take.
    BadMetadata {
        /// The entry's key (`mode`, `content`); empty when the text itself is at fault.
        key: SectionName,
        /// The line at fault, counted from 1; 0 when the entry is absent.
        line: u32,
    },
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
            Self::UnsupportedMajor { found } if found > crate::layout::VERSION_MAJOR => write!(
                f,
                "format major version {found} is newer than this build reads ({} to {})",
                crate::layout::MIN_VERSION_MAJOR,
                crate::layout::VERSION_MAJOR
            ),
            Self::UnsupportedMajor { found } => write!(
                f,
                "format major version {found} is older than this build reads ({} to {})",
                crate::layout::MIN_VERSION_MAJOR,
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
            Self::MissingSection { section } => write!(f, "required section {section} is missing"),
            Self::WrongDtype { section } => {
                write!(f, "section {section} has the wrong data type for its role")
            }
            Self::IncompatibleShapes { section } => {
                write!(
                    f,
                    "section {section} has a shape that does not fit with the others"
                )
            }
            Self::NonFinite => write!(f, "a weight is NaN or infinite"),
            Self::NonFiniteValue { section, index } => {
                write!(f, "section {section}: value {index} is NaN or infinite")
            }
            Self::ValueOutOfRange {
                section,
                index,
                bound,
            } => write!(f, "section {section}: value {index} is {bound}"),
            Self::Unbounded {
                section,
                row,
                limit,
            } => write!(
                f,
                "section {section}: row {row} lets the network's {limit} for inputs within their \
                 bounds"
            ),
            Self::IndexOutOfRange { section, index } => {
                write!(
                    f,
                    "section {section}: value {index} is an index out of range"
                )
            }
            Self::LimitExceeded {
                section,
                value,
                limit,
            } if value > limit => write!(
                f,
                "section {section}: a count of {value} exceeds this build's limit of {limit}"
            ),
            Self::LimitExceeded { section, limit, .. } => write!(
                f,
                "section {section}: a count exceeds this build's limit of {limit}"
            ),
            Self::UnknownCode {
                section,
                index,
                code,
            } => write!(
                f,
                "section {section}: value {index} is {code}, a code this build does not know"
            ),
            Self::BadMetadata { key, line } if key.as_str().is_empty() => {
                write!(f, "metadata line {line} is not UTF-8 key=value text")
            }
            Self::BadMetadata { key, line: 0 } => write!(f, "metadata has no {key} entry"),
            Self::BadMetadata { key, line } => write!(
                f,
                "metadata line {line}: {key} has a value this artefact does not take"
            ),
            Self::WrongKind => write!(f, "the artefact is of another kind than expected"),
        }
    }
}

impl core::error::Error for FormatError {}

impl FormatError {
    /// An [`FormatError::IndexOutOfRange`] at position `index` of the section or argument
    /// `section`.
    pub fn index_out_of_range(section: &str, index: usize) -> Self {
        Self::IndexOutOfRange {
            section: SectionName::new(section),
            index: u32::try_from(index).unwrap_or(u32::MAX),
        }
    }

    /// An [`FormatError::IncompatibleShapes`] naming the section or argument `section`.
    #[cold]
    #[inline(never)]
    pub fn incompatible_shapes(section: &str) -> Self {
        Self::IncompatibleShapes {
            section: SectionName::new(section),
        }
    }

    /// A [`FormatError::LimitExceeded`]: the section or argument `section` counts `value`, more
    /// than `limit`.
    #[cold]
    #[inline(never)]
    pub fn limit_exceeded(section: &str, value: usize, limit: usize) -> Self {
        Self::LimitExceeded {
            section: SectionName::new(section),
            value: u32::try_from(value).unwrap_or(u32::MAX),
            limit: u32::try_from(limit).unwrap_or(u32::MAX),
        }
    }

    /// A [`FormatError::LimitExceeded`] for a size that does not fit this build's `usize`:
    /// `a × b + c`, computed in `u64`, saturated at `u32::MAX` (the limit, `usize::MAX`, too: on
    /// a 32-bit target both read `u32::MAX` and the message gives the limit alone).
    #[cold]
    #[inline(never)]
    pub fn size_overflow(section: &str, a: usize, b: usize, c: usize) -> Self {
        let wide = |n: usize| u64::try_from(n).unwrap_or(u64::MAX);
        let narrow = |n: u64| u32::try_from(n).unwrap_or(u32::MAX);
        Self::LimitExceeded {
            section: SectionName::new(section),
            value: narrow(wide(a).saturating_mul(wide(b)).saturating_add(wide(c))),
            limit: narrow(wide(usize::MAX)),
        }
    }

    /// An [`FormatError::UnknownCode`]: value `index` of the section or argument `section` is
    /// `code`.
    #[cold]
    #[inline(never)]
    pub fn unknown_code(section: &str, index: usize, code: u32) -> Self {
        Self::UnknownCode {
            section: SectionName::new(section),
            index: u32::try_from(index).unwrap_or(u32::MAX),
            code,
        }
    }

    /// The error with the file's section name `section` in place of a kernel's argument name
    /// (of an [`FormatError::IndexOutOfRange`], [`FormatError::IncompatibleShapes`],
    /// [`FormatError::LimitExceeded`] or [`FormatError::UnknownCode`] from a constructor such as
    /// `Triangles::new`); other errors, which name no argument, are returned as they are.
    #[must_use]
    pub fn in_section(self, section: &str) -> Self {
        let name = SectionName::new(section);
        match self {
            Self::IndexOutOfRange { index, .. } => Self::IndexOutOfRange {
                section: name,
                index,
            },
            Self::IncompatibleShapes { .. } => Self::IncompatibleShapes { section: name },
            Self::LimitExceeded { value, limit, .. } => Self::LimitExceeded {
                section: name,
                value,
                limit,
            },
            Self::UnknownCode { index, code, .. } => Self::UnknownCode {
                section: name,
                index,
                code,
            },
            e => e,
        }
    }
}

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

/// The caller's argument an [`InputError`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Argument {
    /// The head transform's 9 values: 6D rotation (0..6), then translation (6..9).
    Head,
    /// The jaw transform's 9 values, as [`Argument::Head`].
    Jaw,
    /// A built pose's head transform: its rotation matrix by columns (0..9), then its
    /// translation (9..12).
    PoseHead,
    /// A built pose's jaw transform: rotation by columns (0..9), translation (9..12), pivot
    /// (12..15).
    PoseJaw,
    /// The corrective coefficients, `[M]`.
    Weights,
    /// Another neutral skin to pose from, `[V, 3]`.
    Rest,
    /// Posed positions to compute normals of, `[V, 3]`.
    Positions,
    /// A per-vertex editing mask, `[V]`, each value in `[0, 1]`.
    Mask,
    /// A thickness scale.
    Scale,
    /// A template point to evaluate the networks at, `[3]`.
    Point,
    /// An S2D decoder's input, `[3 K]`.
    Input,
    /// A neutral: a face to decode onto (`[V, 3]`) or a landmark set (`[K, 3]`).
    Neutral,
    /// An expressive landmark set, `[K, 3]`.
    Expressive,
    /// A motion's intensity.
    Intensity,
    /// A generated landmark curve, `[(FRAMES + 1) × 3K]` (a sequence's frames decode from it).
    Curve,
    /// A tracker's landmarks driving an actor, `[68, 2]` or `[68, 3]`.
    Landmarks,
    /// A temporal filter's settings: minimum cutoff (Hz), speed coefficient, derivative cutoff
    /// (Hz) and frame rate (Hz), each within `[0, MAX_FACTOR]`, the cutoffs and the rate above 0.
    Filter,
    /// A frame's time stamp in seconds (a time-stamped filter step), within ±`MAX_COORDINATE` and
    /// at least `1 / MAX_FACTOR` after the last one the filter saw.
    Time,
    /// Live driving's settings ([`crate::live::Settings`]): the calibration's frame count, the
    /// largest residual, head speed and turn rate, and the time before a lost head is found
    /// again, each within `[0, MAX_FACTOR]`.
    Live,
}

impl Argument {
    /// The argument's name, as the core's functions call it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Head => "head",
            Self::Jaw => "jaw",
            Self::PoseHead => "pose.head",
            Self::PoseJaw => "pose.jaw",
            Self::Weights => "weights",
            Self::Rest => "rest",
            Self::Positions => "positions",
            Self::Mask => "mask",
            Self::Scale => "scale",
            Self::Point => "point",
            Self::Input => "input",
            Self::Neutral => "neutral",
            Self::Expressive => "expressive",
            Self::Intensity => "intensity",
            Self::Curve => "curve",
            Self::Landmarks => "landmarks",
            Self::Filter => "filter",
            Self::Time => "time",
            Self::Live => "live",
        }
    }

    /// Whether the argument is a 9-value transform (`[6D rotation, translation]`).
    const fn is_9d(self) -> bool {
        matches!(self, Self::Head | Self::Jaw)
    }

    /// The range value `index` of this argument must lie in (inclusive).
    pub const fn range(self, index: usize) -> (f32, f32) {
        let limit = match self {
            Self::Head | Self::Jaw if index < 6 => MAX_ROTATION_ENTRY,
            Self::PoseHead | Self::PoseJaw if index < 9 => MAX_FACTOR,
            Self::Mask => return (0.0, 1.0),
            Self::Filter | Self::Live => return (0.0, MAX_FACTOR),
            Self::Weights | Self::Scale | Self::Input | Self::Intensity => MAX_FACTOR,
            _ => MAX_COORDINATE,
        };
        (-limit, limit)
    }
}

impl fmt::Display for Argument {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What is wrong with a caller's number ([`InputError`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum InputErrorKind {
    /// NaN or infinite.
    NonFinite,
    /// Finite, but outside the argument's range ([`Argument::range`]).
    OutOfRange,
    /// Finite and in range, but without a meaning to compute with: a 6D rotation's column too
    /// short or parallel to the other, a landmark set whose points all coincide.
    Degenerate,
}

/// A number the caller gave that the core refuses instead of guessing: NaN or infinite, out of
/// its documented range, or degenerate. Which argument and which value.
///
/// Every evaluation entry that takes the caller's numbers checks them before computing anything
/// (nothing is written then), so a valid model with accepted inputs always gives finite outputs.
/// The checks only compare; the outputs of accepted inputs are the same bits as without them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InputError {
    /// The argument.
    pub argument: Argument,
    /// The value's index in it (for a degenerate 6D rotation, the first index of its column; for
    /// a degenerate landmark set, 0).
    pub index: usize,
    /// What is wrong with it.
    pub kind: InputErrorKind,
}

impl InputError {
    /// An error about value `index` of `argument`.
    pub const fn new(argument: Argument, index: usize, kind: InputErrorKind) -> Self {
        Self {
            argument,
            index,
            kind,
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (argument, index) = (self.argument, self.index);
        match self.kind {
            InputErrorKind::NonFinite => write!(f, "{argument}[{index}] is NaN or infinite"),
            InputErrorKind::OutOfRange => match argument.range(index) {
                (lo, hi) if lo == -hi => {
                    write!(f, "{argument}[{index}] is outside ±{}", Magnitude(hi))
                }
                (lo, hi) => write!(
                    f,
                    "{argument}[{index}] is outside [{}, {}]",
                    Magnitude(lo),
                    Magnitude(hi)
                ),
            },
            InputErrorKind::Degenerate if argument.is_9d() && index < 3 => write!(
                f,
                "{argument}[0..3], the 6D rotation's first column, is shorter than {}",
                Magnitude(MIN_ROTATION_COLUMN)
            ),
            InputErrorKind::Degenerate if argument.is_9d() => write!(
                f,
                "{argument}[3..6], the 6D rotation's second column, is shorter than {} or \
                 parallel to the first",
                Magnitude(MIN_ROTATION_COLUMN)
            ),
            InputErrorKind::Degenerate if matches!(argument, Argument::Time) => write!(
                f,
                "{argument}[{index}] is not at least {} s after the last frame's time stamp",
                Magnitude(1.0 / MAX_FACTOR)
            ),
            InputErrorKind::Degenerate => write!(
                f,
                "{argument}: the landmarks all coincide (the set has no size to normalise by)"
            ),
        }
    }
}

impl core::error::Error for InputError {}

/// Why an evaluation refused to run: a caller's buffer has the wrong length, or a caller's
/// number is refused. Never because of the model's data, which validation checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum EvalError {
    /// A buffer has the wrong length.
    Buffer(BufferError),
    /// A number is NaN, infinite, out of range or degenerate.
    Input(InputError),
}

impl fmt::Display for EvalError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Buffer(e) => write!(f, "{e}"),
            Self::Input(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for EvalError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Buffer(e) => Some(e),
            Self::Input(e) => Some(e),
        }
    }
}

impl From<BufferError> for EvalError {
    fn from(e: BufferError) -> Self {
        Self::Buffer(e)
    }
}

impl From<InputError> for EvalError {
    fn from(e: InputError) -> Self {
        Self::Input(e)
    }
}

mod bound;
mod limit;
mod words;
pub use bound::Bound;
pub use limit::NetworkLimit;
use words::Magnitude;

#[cfg(test)]
mod tests;
