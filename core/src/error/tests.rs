//! Every error's message: words a user can act on, naming what is at fault.

use std::string::{String, ToString};
use std::vec::Vec;

use super::*;

/// Every variant's message: none prints a Rust value (`Debug` output, a type's name), each
/// reads as a lower-case phrase, and each that carries a section or an index names it.
#[test]
fn every_format_error_message_reads_as_words_and_names_what_it_carries() {
    let s = SectionName::new("cache.e");
    let cases: Vec<(FormatError, &[&str])> = Vec::from([
        (FormatError::TooShort, &["32-byte header"][..]),
        (FormatError::BadMagic, &[".sinew"]),
        (
            FormatError::UnsupportedMajor { found: 7 },
            &["7 is newer", "1 to 1"],
        ),
        (
            FormatError::UnsupportedMajor { found: 0 },
            &["0 is older", "1 to 1"],
        ),
        (FormatError::NonZeroReserved, &["reserved"]),
        (
            FormatError::LengthMismatch {
                header: 100,
                actual: 90,
            },
            &["100 bytes", "90 bytes"],
        ),
        (FormatError::TooManySections, &["4096"]),
        (FormatError::HeaderChecksum, &["CRC-32"]),
        (FormatError::TruncatedSection { section: 3 }, &["section 3"]),
        (FormatError::BadLayout { section: 4 }, &["section 4"]),
        (FormatError::SectionChecksum { section: 5 }, &["section 5"]),
        (FormatError::BadName { section: 6 }, &["section 6"]),
        (FormatError::DuplicateName { section: 7 }, &["section 7"]),
        (FormatError::UnknownDtype { section: 8 }, &["section 8"]),
        (FormatError::BadShape { section: 9 }, &["section 9"]),
        (FormatError::ShapeMismatch { section: 10 }, &["section 10"]),
        (FormatError::MissingSection { section: s }, &["cache.e"]),
        (FormatError::WrongDtype { section: s }, &["cache.e"]),
        (
            FormatError::incompatible_shapes("s2d.fc.w"),
            &["section s2d.fc.w", "shape"],
        ),
        (FormatError::NonFinite, &["NaN"]),
        (
            FormatError::NonFiniteValue {
                section: s,
                index: 11,
            },
            &["cache.e", "value 11"],
        ),
        (
            FormatError::ValueOutOfRange {
                section: s,
                index: 12,
                bound: Bound::Coordinate,
            },
            &["cache.e", "value 12", "±1e5"],
        ),
        (
            FormatError::Unbounded {
                section: s,
                row: 13,
                limit: NetworkLimit::Values,
            },
            &["cache.e", "row 13", "values exceed ±1e20"],
        ),
        (
            FormatError::Unbounded {
                section: s,
                row: 2,
                limit: NetworkLimit::Tangent { outputs: 6120 },
            },
            &["cache.e", "row 2", "outputs exceed ±1e18 / 6120"],
        ),
        (
            FormatError::index_out_of_range("tpl.tri", 14),
            &["tpl.tri", "value 14"],
        ),
        (
            FormatError::limit_exceeded("s2d.levels", 9, 8),
            &["section s2d.levels", "count of 9", "limit of 8"],
        ),
        (
            FormatError::size_overflow("s2d.fc.w", usize::MAX, 2, 1),
            &["section s2d.fc.w", "exceeds", "limit of"],
        ),
        (
            FormatError::unknown_code("net.b.act", 2, 9),
            &["section net.b.act", "value 2 is 9", "code"],
        ),
        (
            FormatError::BadMetadata {
                key: SectionName::new(""),
                line: 3,
            },
            &["metadata line 3", "key=value"],
        ),
        (
            FormatError::BadMetadata {
                key: SectionName::new("mode"),
                line: 0,
            },
            &["metadata", "no mode entry"],
        ),
        (
            FormatError::BadMetadata {
                key: SectionName::new("content"),
                line: 2,
            },
            &["metadata line 2", "content has a value"],
        ),
        (FormatError::WrongKind, &["kind"]),
    ]);
    // Every variant has a case above (a new variant fails to compile in `variant` until it is
    // listed there, and then fails here until it has a case).
    let mut covered = [false; VARIANTS];
    for (e, _) in &cases {
        covered[variant(e)] = true;
    }
    assert!(
        covered.iter().all(|&c| c),
        "variants without a case: {covered:?}"
    );
    for (e, names) in cases {
        let m = e.to_string();
        for leak in [
            "{",
            "}",
            "Some(",
            "None",
            "Other(",
            "SectionName",
            "\"",
            "::",
        ] {
            assert!(!m.contains(leak), "{m:?} shows a Rust value ({leak})");
        }
        let first = m.chars().next().unwrap();
        assert!(!first.is_uppercase() || m.starts_with("CRC"), "{m:?}");
        // An article before a vowel sound: "a AIM", "a S2D", "a index" are broken English.
        for bad in [" a A", " a S2D", " a index", " a unknown", " a e"] {
            assert!(!m.contains(bad), "{m:?} has {bad:?}");
        }
        for name in names {
            assert!(m.contains(name), "{m:?} does not name {name:?}");
        }
    }
    let every_bound = [
        Bound::Coordinate,
        Bound::PositiveCoordinate,
        Bound::Factor,
        Bound::PositiveFactor,
        Bound::NonNegativeFactor,
        Bound::UnitMotion,
        Bound::Rotation,
        Bound::LogNormalFactor,
    ];
    let words: Vec<String> = every_bound.iter().map(ToString::to_string).collect();
    assert!(
        words.iter().all(|w| !w.contains('{') && !w.is_empty()),
        "{words:?}"
    );
}

/// The number of [`FormatError`] variants.
const VARIANTS: usize = 27;

/// The position of `e`'s variant in [`FormatError`] (an exhaustive match, without a wildcard).
fn variant(e: &FormatError) -> usize {
    match e {
        FormatError::TooShort => 0,
        FormatError::BadMagic => 1,
        FormatError::UnsupportedMajor { .. } => 2,
        FormatError::NonZeroReserved => 3,
        FormatError::LengthMismatch { .. } => 4,
        FormatError::TooManySections => 5,
        FormatError::HeaderChecksum => 6,
        FormatError::TruncatedSection { .. } => 7,
        FormatError::BadLayout { .. } => 8,
        FormatError::SectionChecksum { .. } => 9,
        FormatError::BadName { .. } => 10,
        FormatError::DuplicateName { .. } => 11,
        FormatError::UnknownDtype { .. } => 12,
        FormatError::BadShape { .. } => 13,
        FormatError::ShapeMismatch { .. } => 14,
        FormatError::MissingSection { .. } => 15,
        FormatError::WrongDtype { .. } => 16,
        FormatError::IncompatibleShapes { .. } => 17,
        FormatError::NonFinite => 18,
        FormatError::NonFiniteValue { .. } => 19,
        FormatError::ValueOutOfRange { .. } => 20,
        FormatError::Unbounded { .. } => 21,
        FormatError::IndexOutOfRange { .. } => 22,
        FormatError::LimitExceeded { .. } => 23,
        FormatError::UnknownCode { .. } => 24,
        FormatError::BadMetadata { .. } => 25,
        FormatError::WrongKind => 26,
    }
}

/// A kernel's constructor names its argument; a loader puts the file's section in its place,
/// keeping the index, value, limit or code, and leaves errors that name no argument as they are.
#[test]
fn in_section_names_the_file_section_in_place_of_the_argument() {
    let cases = [
        (
            FormatError::index_out_of_range("indices", 5),
            FormatError::index_out_of_range("tpl.tri", 5),
        ),
        (
            FormatError::incompatible_shapes("weight"),
            FormatError::incompatible_shapes("tpl.tri"),
        ),
        (
            FormatError::limit_exceeded("layers", 17, 16),
            FormatError::limit_exceeded("tpl.tri", 17, 16),
        ),
        (
            FormatError::unknown_code("code", 0, 6),
            FormatError::unknown_code("tpl.tri", 0, 6),
        ),
        (FormatError::NonFinite, FormatError::NonFinite),
        (
            FormatError::MissingSection {
                section: SectionName::new("cache.e"),
            },
            FormatError::MissingSection {
                section: SectionName::new("cache.e"),
            },
        ),
    ];
    for (from_kernel, expected) in cases {
        assert_eq!(from_kernel.in_section("tpl.tri"), expected);
    }
    assert!(
        FormatError::limit_exceeded("layers", 17, 16)
            .in_section("net.b")
            .to_string()
            .contains("section net.b: a count of 17 exceeds")
    );
}
