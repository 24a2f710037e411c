//! What the C API's tests share: the golden files, error records, and a model handle that frees
//! itself.
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.
#![allow(dead_code)] // each test binary uses its own part of it

use std::ffi::CStr;
use std::path::PathBuf;
use std::ptr::null_mut;

use sinew::*;

/// A golden file of `tests/data/`.
pub fn data(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A copy of the valid `.sinew` file `bytes` with the text `from` replaced by `to` (as long), its
/// checksums recomputed ([`reseal`]).
pub fn with_text(bytes: &[u8], from: &[u8], to: &[u8]) -> Vec<u8> {
    assert_eq!(from.len(), to.len());
    let at = bytes.windows(from.len()).position(|w| w == from).unwrap();
    let mut out = bytes.to_vec();
    out[at..at + to.len()].copy_from_slice(to);
    reseal(&mut out);
    out
}

/// Recomputes every section's CRC-32 and then the header's, so that edited data passes the
/// checksums: a file whose content, not its integrity, is refused.
pub fn reseal(out: &mut [u8]) {
    use sinew_core::format::{
        CRC32, ENTRY_CRC, ENTRY_LENGTH, ENTRY_OFFSET, HEADER_CRC, HEADER_CRC_OFFSET, HEADER_LEN,
        HEADER_SECTION_COUNT, SECTION_ENTRY_LEN,
    };
    let word = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let count = word(out, HEADER_SECTION_COUNT.offset) as usize;
    for i in 0..count {
        let e = HEADER_LEN + i * SECTION_ENTRY_LEN;
        let offset = word(out, e + ENTRY_OFFSET.offset) as usize;
        let length = word(out, e + ENTRY_LENGTH.offset) as usize;
        let crc = CRC32.checksum(&out[offset..offset + length]);
        out[e + ENTRY_CRC.offset..e + ENTRY_CRC.end()].copy_from_slice(&crc.to_le_bytes());
    }
    let mut digest = CRC32.digest();
    digest.update(&out[..HEADER_CRC_OFFSET]);
    digest.update(&out[HEADER_LEN..HEADER_LEN + count * SECTION_ENTRY_LEN]);
    let crc = digest.finalize();
    out[HEADER_CRC.range()].copy_from_slice(&crc.to_le_bytes());
}

/// An error record before any call.
pub fn new_error() -> SinewError {
    SinewError {
        status: SinewStatus::Internal,
        message: [0; SINEW_MESSAGE_LEN],
    }
}

/// The error record's message.
pub fn message(err: &SinewError) -> String {
    // Safety: the library always NUL-terminates the message within the array.
    unsafe { CStr::from_ptr(err.message.as_ptr()) }
        .to_str()
        .unwrap()
        .to_owned()
}

/// An open model over bytes the struct keeps alive (the handle borrows them).
pub struct Model {
    /// The handle.
    pub handle: *mut SinewModel,
    _bytes: Vec<u8>,
}

impl Model {
    /// Opens a golden model, requiring success and an empty error record.
    pub fn open(name: &str) -> Self {
        let bytes = data(name);
        let mut handle = null_mut();
        let mut err = new_error();
        // Safety: `bytes` outlives the handle (both in `Model`, freed in `drop` first).
        let status =
            unsafe { sinew_model_open(bytes.as_ptr(), bytes.len(), &mut handle, &mut err) };
        assert_eq!(status, SinewStatus::Ok, "{name}: {}", message(&err));
        assert_eq!(err.status, SinewStatus::Ok);
        assert_eq!(message(&err), "");
        Self {
            handle,
            _bytes: bytes,
        }
    }

    /// The model's info, requiring success.
    pub fn info(&self) -> SinewModelInfo {
        let mut info = std::mem::MaybeUninit::uninit();
        // Safety: a live handle and a writable info.
        let status = unsafe { sinew_model_info(self.handle, info.as_mut_ptr(), null_mut()) };
        assert_eq!(status, SinewStatus::Ok);
        // Safety: written on success.
        unsafe { info.assume_init() }
    }
}

impl Drop for Model {
    fn drop(&mut self) {
        // Safety: opened by `Model::open`, freed once.
        unsafe { sinew_model_free(self.handle) };
    }
}

/// A section of a container [`container`] writes: its name, data type code (2 `f32`, 3 `u32`),
/// dimensions and little-endian data.
pub struct Section {
    pub name: &'static str,
    pub dtype: u8,
    pub dims: Vec<u32>,
    pub data: Vec<u8>,
}

impl Section {
    /// An `f32` tensor.
    pub fn f32s(name: &'static str, dims: &[u32], values: &[f32]) -> Self {
        Self {
            name,
            dtype: 2,
            dims: dims.to_vec(),
            data: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        }
    }

    /// A `u32` tensor.
    pub fn u32s(name: &'static str, dims: &[u32], values: &[u32]) -> Self {
        Self {
            name,
            dtype: 3,
            dims: dims.to_vec(),
            data: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        }
    }
}

/// A `.sinew` container of artefact kind `kind` holding `sections` (tensors), laid out and
/// checksummed as docs/FORMAT.md prescribes: what the host's writer does, for artefacts the
/// goldens do not include (the C API's tests cannot depend on the host).
pub fn container(kind: u16, sections: &[Section]) -> Vec<u8> {
    use sinew_core::format::CRC32;
    let align = |n: usize| n.div_ceil(16) * 16;
    let table_end = 32 + 64 * sections.len();
    let mut offsets = Vec::new();
    let mut at = align(table_end);
    for s in sections {
        offsets.push(at);
        at = align(at + s.data.len());
    }
    let end = offsets
        .last()
        .zip(sections.last())
        .map_or(align(table_end), |(o, s)| o + s.data.len());
    let mut out = vec![0u8; end];
    out[..8].copy_from_slice(&sinew_core::format::MAGIC);
    out[8..10].copy_from_slice(&1u16.to_le_bytes());
    out[16..18].copy_from_slice(&kind.to_le_bytes());
    out[20..24].copy_from_slice(&(sections.len() as u32).to_le_bytes());
    out[24..28].copy_from_slice(&(end as u32).to_le_bytes());
    for (i, (s, offset)) in sections.iter().zip(&offsets).enumerate() {
        let e = 32 + 64 * i;
        out[e..e + 2].copy_from_slice(&2u16.to_le_bytes());
        out[e + 2] = s.dtype;
        out[e + 3] = s.dims.len() as u8;
        out[e + 4..e + 4 + s.name.len()].copy_from_slice(s.name.as_bytes());
        for (d, dim) in s.dims.iter().enumerate() {
            out[e + 36 + 4 * d..e + 40 + 4 * d].copy_from_slice(&dim.to_le_bytes());
        }
        out[e + 52..e + 56].copy_from_slice(&(*offset as u32).to_le_bytes());
        out[e + 56..e + 60].copy_from_slice(&(s.data.len() as u32).to_le_bytes());
        out[e + 60..e + 64].copy_from_slice(&CRC32.checksum(&s.data).to_le_bytes());
        out[*offset..offset + s.data.len()].copy_from_slice(&s.data);
    }
    let mut digest = CRC32.digest();
    digest.update(&out[..28]);
    digest.update(&out[32..table_end]);
    let crc = digest.finalize();
    out[28..32].copy_from_slice(&crc.to_le_bytes());
    out
}
