//! Shared helpers for Sinew's cross-crate tests: golden files and the real-data location.
//!
//! Golden files live under `tests/data/`. Only `UPDATE_EXPECT=1` writes or rewrites them; a
//! missing golden file fails the test, so CI can never pass by writing its own expectations.

use std::path::{Path, PathBuf};

/// The folder of golden files.
pub fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// Compares `actual` with the golden text file `name` under `tests/data/`.
///
/// With `UPDATE_EXPECT=1` the file is (re)written instead. Panics (failing the test) with a
/// readable message on a mismatch or a missing file.
pub fn check(name: &str, actual: &str) {
    let Some(expected) = golden(name, actual.as_bytes()) else {
        return;
    };
    let expected = String::from_utf8_lossy(&expected);
    if expected != actual {
        let first = expected
            .lines()
            .zip(actual.lines())
            .position(|(a, b)| a != b);
        panic!(
            "tests/data/{name}: output differs from the golden file (first differing line: {:?}).\n--- expected\n{expected}\n--- actual\n{actual}\n\
             If the change is deliberate, rerun with UPDATE_EXPECT=1 and explain it in the commit.",
            first.map(|i| i + 1)
        );
    }
}

/// Compares `actual` with the golden binary file `name` under `tests/data/` (see [`check`]).
pub fn check_bytes(name: &str, actual: &[u8]) {
    let Some(expected) = golden(name, actual) else {
        return;
    };
    if expected != actual {
        let first = expected.iter().zip(actual).position(|(a, b)| a != b);
        panic!(
            "tests/data/{name}: {} bytes differ from the golden file's {} (first differing byte: {first:?}). \
             If the change is deliberate, rerun with UPDATE_EXPECT=1 and explain it in the commit.",
            actual.len(),
            expected.len()
        );
    }
}

/// Writes the golden file under `UPDATE_EXPECT=1` (returning `None`), else reads it.
fn golden(name: &str, actual: &[u8]) -> Option<Vec<u8>> {
    let path = golden_dir().join(name);
    if std::env::var_os("UPDATE_EXPECT").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(golden_dir()).expect("create tests/data");
        std::fs::write(&path, actual)
            .unwrap_or_else(|e| panic!("{}: cannot write golden file: {e}", path.display()));
        return None;
    }
    Some(std::fs::read(&path).unwrap_or_else(|e| {
        panic!("{}: golden file missing or unreadable ({e}); run with UPDATE_EXPECT=1 to create it, and commit it", path.display())
    }))
}

/// Where the real face data lives (`$SINEW_DATA`, else `../shared/data`), with a subfolder;
/// `None` to skip a data test (see `sinew_host::io::data::data_dir`, which fails instead under
/// `SINEW_REQUIRE_DATA=1`).
pub fn data_dir(subfolder: &str) -> Option<PathBuf> {
    sinew_host::io::data::data_dir().map(|d| d.join(subfolder))
}

/// A small deterministic generator for test inputs and weights (PCG32 via `rand_pcg`), so goldens
/// never depend on a framework's random numbers.
#[derive(Debug)]
pub struct Rng(rand_pcg::Pcg32);

impl Rng {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Self {
        Self(rand_pcg::Pcg32::new(seed, 0x0a02_bdbf_7bb3_c0a7))
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        use rand_core::RngCore;
        let u = (self.0.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        lo + (hi - lo) * u
    }

    /// `n` values uniform in `[lo, hi)`.
    pub fn vec(&mut self, n: usize, lo: f32, hi: f32) -> Vec<f32> {
        (0..n).map(|_| self.uniform(lo, hi)).collect()
    }
}

/// A copy of the valid `.sinew` file `bytes` with value `index` of its `f32` section `name` set to
/// `value`, and every checksum recomputed ([`reseal`]): a file whose CRCs are valid but whose
/// numbers are not. Panics if the section or the value is not there.
pub fn with_f32(bytes: &[u8], name: &str, index: usize, value: f32) -> Vec<u8> {
    let mut seen = false;
    let out = map_f32(bytes, name, |i, x| {
        seen |= i == index;
        if i == index { value } else { x }
    });
    assert!(seen, "{name} has no value {index}");
    out
}

/// A copy of the valid `.sinew` file `bytes` with every value `x` (at index `i`) of its `f32`
/// section `name` replaced by `f(i, x)`, and every checksum recomputed ([`reseal`]).
pub fn map_f32(bytes: &[u8], name: &str, mut f: impl FnMut(usize, f32) -> f32) -> Vec<u8> {
    let file = sinew_core::SinewFile::from_bytes(bytes).expect("a valid file to edit");
    let section = file
        .section(name)
        .unwrap_or_else(|| panic!("no section {name}"));
    let start = section.offset as usize;
    let mut out = bytes.to_vec();
    for i in 0..section.elements() {
        let at = start + 4 * i;
        let x = f32::from_le_bytes(out[at..at + 4].try_into().unwrap());
        out[at..at + 4].copy_from_slice(&f(i, x).to_le_bytes());
    }
    reseal(&mut out);
    out
}

/// Recomputes every section's CRC-32 and then the header's, so that edited data passes the
/// checksums (the table's offsets and lengths must still lie inside the file).
pub fn reseal(bytes: &mut [u8]) {
    use sinew_core::format::{
        CRC32, ENTRY_CRC, ENTRY_LENGTH, ENTRY_OFFSET, HEADER_CRC, HEADER_CRC_OFFSET, HEADER_LEN,
        HEADER_SECTION_COUNT, SECTION_ENTRY_LEN,
    };
    let word = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let count = word(bytes, HEADER_SECTION_COUNT.offset) as usize;
    for i in 0..count {
        let e = HEADER_LEN + i * SECTION_ENTRY_LEN;
        let offset = word(bytes, e + ENTRY_OFFSET.offset) as usize;
        let length = word(bytes, e + ENTRY_LENGTH.offset) as usize;
        let crc = CRC32.checksum(&bytes[offset..offset + length]);
        bytes[e + ENTRY_CRC.offset..e + ENTRY_CRC.end()].copy_from_slice(&crc.to_le_bytes());
    }
    let mut digest = CRC32.digest();
    digest.update(&bytes[..HEADER_CRC_OFFSET]);
    digest.update(&bytes[HEADER_LEN..HEADER_LEN + count * SECTION_ENTRY_LEN]);
    let crc = digest.finalize();
    bytes[HEADER_CRC.range()].copy_from_slice(&crc.to_le_bytes());
}
