//! Fuzzes the loader: any byte string must give `Ok` or `Err`, never a panic, and whatever loads
//! must evaluate without panicking. Run: `cd core/fuzz && cargo fuzz run from_bytes -s none`.
//!
//! Random bytes almost never carry valid CRCs, so each input is tried twice: as it is (the CRC
//! and header checks), and with its file length and checksums recomputed, which lets the fuzzer
//! reach the section, shape, metadata and typed-loader checks and the evaluation behind them.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sinew_core::SinewFile;
use sinew_core::format::{CRC32, HEADER_CRC_OFFSET, HEADER_LEN, SECTION_ENTRY_LEN};
use sinew_core::network::load_mlp;

fuzz_target!(|data: &[u8]| {
    exercise(data);
    if let Some(fixed) = fix_checksums(data) {
        exercise(&fixed);
    }
});

fn exercise(data: &[u8]) {
    let Ok(file) = SinewFile::from_bytes(data) else {
        return;
    };
    for section in file.sections() {
        let _ = (
            section.name(),
            section.dims(),
            section.elements(),
            section.f32s(),
            section.u32s(),
            section.q16s(),
        );
    }
    let _ = file.metadata().iter().count();
    if let Ok(mlp) = load_mlp(&file, "mlp") {
        let input = [0.25f32; 64];
        let mut output = [0.0f32; 256];
        let mut scratch = vec![0.0f32; mlp.scratch_len()];
        if mlp.inputs() <= input.len() && mlp.outputs() <= output.len() {
            let result = mlp.eval(
                &input[..mlp.inputs()],
                &mut output[..mlp.outputs()],
                &mut scratch,
            );
            assert!(
                result.is_ok(),
                "a loaded MLP with right-sized buffers must evaluate"
            );
        }
    }
}

/// Rewrites the declared length, every section CRC it can locate, and the header CRC.
fn fix_checksums(data: &[u8]) -> Option<Vec<u8>> {
    let mut out = data.to_vec();
    if out.len() < HEADER_LEN {
        return None;
    }
    let len = u32::try_from(out.len()).ok()?;
    out[24..28].copy_from_slice(&len.to_le_bytes());
    let count = (u32::from_le_bytes(out[20..24].try_into().ok()?) as usize).min(64);
    let table_end = (HEADER_LEN + count * SECTION_ENTRY_LEN).min(out.len());
    for i in 0..count {
        let e = HEADER_LEN + i * SECTION_ENTRY_LEN;
        if e + SECTION_ENTRY_LEN > out.len() {
            break;
        }
        let offset = u32::from_le_bytes(out[e + 52..e + 56].try_into().ok()?) as usize;
        let length = u32::from_le_bytes(out[e + 56..e + 60].try_into().ok()?) as usize;
        if let Some(section) = out.get(offset..offset.saturating_add(length)) {
            let crc = CRC32.checksum(section);
            out[e + 60..e + 64].copy_from_slice(&crc.to_le_bytes());
        }
    }
    let mut digest = CRC32.digest();
    digest.update(&out[..HEADER_CRC_OFFSET]);
    digest.update(&out[HEADER_LEN..table_end]);
    let crc = digest.finalize();
    out[HEADER_CRC_OFFSET..HEADER_LEN].copy_from_slice(&crc.to_le_bytes());
    Some(out)
}
