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
/// The oldest major format version this build reads (files of `MIN_VERSION_MAJOR` to
/// [`VERSION_MAJOR`] load).
pub const MIN_VERSION_MAJOR: u16 = 1;
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

/// The largest magnitude of a length, per component, in the model's unit: every position,
/// displacement, thickness, pivot and translation a file holds or a caller gives (1e5 is a
/// kilometre in centimetres; a face is tens of units). With [`MAX_FACTOR`] it keeps the
/// worst-case pose of a valid actor below 1e11 in `f32`, far from overflow (docs/FORMAT.md,
/// "Value bounds").
pub const MAX_COORDINATE: f32 = 1e5;
/// The largest magnitude of a dimensionless factor: a corrective coefficient, a jaw skinning
/// weight, a component of a unit normal, a decoder input, a motion's intensity, length or reach.
pub const MAX_FACTOR: f32 = 1e3;
/// The largest magnitude of one of a 6D rotation's six values. Only the columns' directions
/// matter, but their squares must stay far from `f32` overflow.
pub const MAX_ROTATION_ENTRY: f32 = 1e6;
/// The shortest length of a 6D rotation's column: a shorter one has no reliable direction.
pub const MIN_ROTATION_COLUMN: f32 = 1e-6;
/// How far a motion generator's reference motion `p` may be from unit norm: `⟨p, p⟩` within
/// `1 ± UNIT_TOLERANCE`. The exponential map then keeps every generated motion near the unit
/// sphere, whatever the generator's output.
pub const UNIT_TOLERANCE: f32 = 1e-3;
/// The largest magnitude of a Gaussian value a motion generator draws from its seed (the
/// Box–Muller draw of `motion::gaussian_noise`): `√(−2 ln 2⁻²⁴) ≈ 5.77`, rounded up (its `u1` is
/// at least 2⁻²⁴, and the cosine at most 1). The one-hot label's values are 0 and 1.
pub const NOISE_BOUND: f32 = 5.8;
/// The largest magnitude a network (an MLP, or the S2D decoder's layers) may reach anywhere, for
/// any input within its bounds, as validation bounds it from the file's weights: far below
/// `f32`'s 3.4e38, so that every sum downstream stays finite.
pub const MAX_NETWORK_VALUE: f32 = 1e20;
/// The longest a motion generator's tangent vector may be, in Euclidean length: its squared
/// length, 1e36, stays below `f32`'s 3.4e38 with the margin the roundings of its sums need. A
/// generator of `n` outputs is held to ±`MAX_TANGENT_NORM / n` per output
/// ([`crate::NetworkLimit::Tangent`]), so its vector is at most `MAX_TANGENT_NORM / √n` long.
pub const MAX_TANGENT_NORM: f32 = 1e18;

/// A fixed-size field of the header or of a section-table entry: where it starts and how many
/// bytes it takes. All numbers in it are little-endian.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    /// Byte offset from the start of the header, or of the entry.
    pub offset: usize,
    /// Size in bytes.
    pub len: usize,
}

impl Field {
    /// The offset just past the field.
    pub const fn end(self) -> usize {
        self.offset + self.len
    }

    /// The field's bytes within the header or entry.
    pub const fn range(self) -> core::ops::Range<usize> {
        self.offset..self.end()
    }

    /// The field's bytes when the header or entry starts at `base` (e.g. an entry in a table).
    pub const fn at(self, base: usize) -> core::ops::Range<usize> {
        base + self.offset..base + self.end()
    }
}

/// Header: the eight bytes of [`MAGIC`].
pub const HEADER_MAGIC: Field = Field { offset: 0, len: 8 };
/// Header: the major version, `u16` ([`VERSION_MAJOR`]).
pub const HEADER_MAJOR: Field = Field { offset: 8, len: 2 };
/// Header: the minor version, `u16` ([`VERSION_MINOR`]).
pub const HEADER_MINOR: Field = Field { offset: 10, len: 2 };
/// Header: the flags, `u32` (`FLAG_*`).
pub const HEADER_FLAGS: Field = Field { offset: 12, len: 4 };
/// Header: the artefact kind, `u16` (`ArtifactKind::code`).
pub const HEADER_KIND: Field = Field { offset: 16, len: 2 };
/// Header: reserved, `u16`, must be zero.
pub const HEADER_RESERVED: Field = Field { offset: 18, len: 2 };
/// Header: the number of section-table entries, `u32` (at most [`MAX_SECTIONS`]).
pub const HEADER_SECTION_COUNT: Field = Field { offset: 20, len: 4 };
/// Header: the length of the whole file in bytes, `u32`.
pub const HEADER_FILE_LEN: Field = Field { offset: 24, len: 4 };
/// Header: the CRC-32 over header bytes `0..HEADER_CRC_OFFSET` and the section table, `u32`.
pub const HEADER_CRC: Field = Field {
    offset: HEADER_CRC_OFFSET,
    len: 4,
};

/// Section-table entry: the section kind, `u16` (`SectionKind::code`).
pub const ENTRY_KIND: Field = Field { offset: 0, len: 2 };
/// Section-table entry: the element type, `u8` (`Dtype::code`).
pub const ENTRY_DTYPE: Field = Field { offset: 2, len: 1 };
/// Section-table entry: the rank, `u8` (at most [`MAX_RANK`]).
pub const ENTRY_RANK: Field = Field { offset: 3, len: 1 };
/// Section-table entry: the name, [`NAME_LEN`] bytes of ASCII, NUL-padded.
pub const ENTRY_NAME: Field = Field {
    offset: 4,
    len: NAME_LEN,
};
/// Section-table entry: the shape, [`MAX_RANK`] `u32` dimensions ([`SHAPE_DIM_LEN`] bytes each),
/// zero past the rank.
pub const ENTRY_SHAPE: Field = Field {
    offset: 36,
    len: MAX_RANK * SHAPE_DIM_LEN,
};
/// Bytes of one dimension in [`ENTRY_SHAPE`] (a `u32`).
pub const SHAPE_DIM_LEN: usize = 4;
/// Section-table entry: the data's offset from the start of the file, `u32`.
pub const ENTRY_OFFSET: Field = Field { offset: 52, len: 4 };
/// Section-table entry: the data's length in bytes, `u32`.
pub const ENTRY_LENGTH: Field = Field { offset: 56, len: 4 };
/// Section-table entry: the CRC-32 of the data, `u32`.
pub const ENTRY_CRC: Field = Field { offset: 60, len: 4 };

/// Dimension `d` of [`ENTRY_SHAPE`] (`d < MAX_RANK`).
pub const fn entry_dim(d: usize) -> Field {
    Field {
        offset: ENTRY_SHAPE.offset + d * SHAPE_DIM_LEN,
        len: SHAPE_DIM_LEN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::format;
    use std::string::String;
    use std::vec::Vec;

    /// Every header field, by the name of its constant, in byte order.
    const HEADER_FIELDS: [(&str, Field); 9] = [
        ("HEADER_MAGIC", HEADER_MAGIC),
        ("HEADER_MAJOR", HEADER_MAJOR),
        ("HEADER_MINOR", HEADER_MINOR),
        ("HEADER_FLAGS", HEADER_FLAGS),
        ("HEADER_KIND", HEADER_KIND),
        ("HEADER_RESERVED", HEADER_RESERVED),
        ("HEADER_SECTION_COUNT", HEADER_SECTION_COUNT),
        ("HEADER_FILE_LEN", HEADER_FILE_LEN),
        ("HEADER_CRC", HEADER_CRC),
    ];

    /// Every section-table entry field, by the name of its constant, in byte order.
    const ENTRY_FIELDS: [(&str, Field); 8] = [
        ("ENTRY_KIND", ENTRY_KIND),
        ("ENTRY_DTYPE", ENTRY_DTYPE),
        ("ENTRY_RANK", ENTRY_RANK),
        ("ENTRY_NAME", ENTRY_NAME),
        ("ENTRY_SHAPE", ENTRY_SHAPE),
        ("ENTRY_OFFSET", ENTRY_OFFSET),
        ("ENTRY_LENGTH", ENTRY_LENGTH),
        ("ENTRY_CRC", ENTRY_CRC),
    ];

    const FORMAT_MD: &str = include_str!("../../docs/FORMAT.md");

    /// The fields follow each other without gaps or overlaps and fill `len` bytes exactly, so
    /// the lists above name every field.
    fn tiles(fields: &[(&str, Field)], len: usize) -> Result<(), String> {
        let mut end = 0;
        for (name, f) in fields {
            if f.offset != end {
                return Err(format!("{name} starts at {}, not at {end}", f.offset));
            }
            end = f.end();
        }
        if end == len {
            Ok(())
        } else {
            Err(format!("the fields end at {end}, not at {len}"))
        }
    }

    #[test]
    fn fields_tile_the_header_and_the_entry() {
        tiles(&HEADER_FIELDS, HEADER_LEN).unwrap();
        tiles(&ENTRY_FIELDS, SECTION_ENTRY_LEN).unwrap();
        assert_eq!(HEADER_MAGIC.len, MAGIC.len());
        assert_eq!(HEADER_CRC.end(), HEADER_LEN);
        assert_eq!(entry_dim(MAX_RANK - 1).end(), ENTRY_SHAPE.end());
        assert_eq!(ENTRY_NAME.at(SECTION_ENTRY_LEN), 68..100);
        let mut wrong = HEADER_FIELDS;
        wrong[2].1.len = 4;
        assert!(
            tiles(&wrong, HEADER_LEN)
                .unwrap_err()
                .contains("HEADER_FLAGS")
        );
    }

    /// Checks the markdown table that follows the heading starting with `heading` in `doc`
    /// (columns `offset`, `size`, `field` and `constant`) against `fields`: every row's constant
    /// must be one of them with the row's offset and size, and every field must have one row.
    /// Returns one line per failure, naming the row.
    fn check_table(doc: &str, heading: &str, fields: &[(&str, Field)]) -> Vec<String> {
        let mut errors = Vec::new();
        let mut lines = doc.lines().skip_while(|l| !l.starts_with(heading));
        if lines.next().is_none() {
            return Vec::from([format!("no heading {heading:?}")]);
        }
        let mut table = lines
            .skip_while(|l| !l.starts_with('|'))
            .take_while(|l| l.starts_with('|'))
            .map(|l| {
                l.trim_matches('|')
                    .split('|')
                    .map(|c| c.trim().trim_matches('`'))
                    .collect::<Vec<_>>()
            });
        let Some(columns) = table.next() else {
            return Vec::from([format!("{heading}: no table")]);
        };
        let column = |name: &str| columns.iter().position(|c| *c == name);
        let (Some(offset), Some(size), Some(field), Some(constant)) = (
            column("offset"),
            column("size"),
            column("field"),
            column("constant"),
        ) else {
            return Vec::from([format!("{heading}: the table lacks a column: {columns:?}")]);
        };
        let mut seen = Vec::new();
        for row in table.skip(1) {
            let cell = |i: usize| row.get(i).copied().unwrap_or("");
            let what = format!("{heading}, row `{}`", cell(field));
            let Some((name, f)) = fields.iter().find(|(n, _)| *n == cell(constant)) else {
                errors.push(format!("{what}: `{}` is no field constant", cell(constant)));
                continue;
            };
            seen.push(*name);
            if cell(offset).parse() != Ok(f.offset) {
                errors.push(format!(
                    "{what}: offset {} in the document, {} in {name}",
                    cell(offset),
                    f.offset
                ));
            }
            if cell(size).parse() != Ok(f.len) {
                errors.push(format!(
                    "{what}: size {} in the document, {} in {name}",
                    cell(size),
                    f.len
                ));
            }
        }
        for (name, _) in fields {
            match seen.iter().filter(|s| *s == name).count() {
                1 => {}
                n => errors.push(format!("{heading}: {name} has {n} rows, not one")),
            }
        }
        errors
    }

    #[test]
    fn format_md_field_tables_match_the_constants() {
        let mut errors = check_table(FORMAT_MD, "### Header", &HEADER_FIELDS);
        errors.extend(check_table(
            FORMAT_MD,
            "### Section-table entry",
            &ENTRY_FIELDS,
        ));
        assert!(errors.is_empty(), "docs/FORMAT.md:\n{}", errors.join("\n"));
    }

    /// The value limits, by the name of their constant, as `docs/FORMAT.md` ("Value bounds")
    /// must state them.
    const VALUE_LIMITS: [(&str, f32); 7] = [
        ("MAX_COORDINATE", MAX_COORDINATE),
        ("MAX_FACTOR", MAX_FACTOR),
        ("MAX_ROTATION_ENTRY", MAX_ROTATION_ENTRY),
        ("MIN_ROTATION_COLUMN", MIN_ROTATION_COLUMN),
        ("MAX_NETWORK_VALUE", MAX_NETWORK_VALUE),
        ("MAX_TANGENT_NORM", MAX_TANGENT_NORM),
        ("UNIT_TOLERANCE", UNIT_TOLERANCE),
    ];

    #[test]
    fn format_md_value_limits_match_the_constants() {
        let mut lines = FORMAT_MD
            .lines()
            .skip_while(|l| !l.starts_with("### Value bounds"))
            .skip_while(|l| !l.starts_with('|'))
            .take_while(|l| l.starts_with('|'));
        let mut seen = Vec::new();
        for line in lines.by_ref().skip(2) {
            let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
            let (Some(name), Some(value)) = (cells.first(), cells.get(1)) else {
                continue;
            };
            let name = name.trim_matches('`');
            if let Some((_, limit)) = VALUE_LIMITS.iter().find(|(n, _)| *n == name) {
                assert_eq!(value.parse::<f32>(), Ok(*limit), "docs/FORMAT.md, {name}");
                seen.push(name);
            }
        }
        for (name, _) in VALUE_LIMITS {
            assert!(
                seen.contains(&name),
                "docs/FORMAT.md's value bounds lack {name}"
            );
        }
    }

    #[test]
    fn a_wrong_row_in_format_md_is_named() {
        let doc = FORMAT_MD.replace("| 10 | 2 | minor |", "| 11 | 2 | minor |");
        let errors = check_table(&doc, "### Header", &HEADER_FIELDS);
        assert_eq!(
            errors,
            ["### Header, row `minor`: offset 11 in the document, 10 in HEADER_MINOR"]
        );
        let doc = FORMAT_MD.replace("| 52 | 4 | offset | u32 | `ENTRY_OFFSET` |\n", "");
        let errors = check_table(&doc, "### Section-table entry", &ENTRY_FIELDS);
        assert_eq!(
            errors,
            ["### Section-table entry: ENTRY_OFFSET has 0 rows, not one"]
        );
    }
}
