//! The binary glTF container (glTF 2.0 spec, "GLB File Format Specification"): a 12-byte header
//! (`glTF`, version 2, total length), a JSON chunk padded with spaces and a BIN chunk padded with
//! zeros, every chunk 4-byte aligned and all integers little-endian.

use anyhow::{Result, bail, ensure};

/// `glTF` as a little-endian u32.
pub const MAGIC: u32 = 0x4654_6C67;
/// The container version this module writes and reads.
pub const VERSION: u32 = 2;
/// Chunk type of the JSON chunk (`JSON`).
pub const CHUNK_JSON: u32 = 0x4E4F_534A;
/// Chunk type of the binary chunk (`BIN\0`).
pub const CHUNK_BIN: u32 = 0x004E_4942;

fn padded(bytes: &[u8], fill: u8) -> Vec<u8> {
    let mut v = bytes.to_vec();
    while !v.len().is_multiple_of(4) {
        v.push(fill);
    }
    v
}

/// A `.glb` from the JSON document and the binary buffer.
pub fn write(json: &[u8], bin: &[u8]) -> Result<Vec<u8>> {
    let json = padded(json, b' ');
    let bin = padded(bin, 0);
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let Ok(total32) = u32::try_from(total) else {
        bail!("a .glb holds at most 4 GiB, this one would be {total} bytes");
    };
    let mut out = Vec::with_capacity(total);
    for word in [MAGIC, VERSION, total32, json.len() as u32, CHUNK_JSON] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
        out.extend_from_slice(&bin);
    }
    Ok(out)
}

/// The JSON and BIN chunks of a `.glb` (BIN empty when absent), after checking the header and
/// chunk layout.
pub fn read(bytes: &[u8]) -> Result<(&[u8], &[u8])> {
    let word = |at: usize| -> Result<u32> {
        match bytes.get(at..at + 4) {
            Some(b) => Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            None => bail!("truncated at byte {at}"),
        }
    };
    ensure!(word(0)? == MAGIC, "not a binary glTF (magic)");
    ensure!(
        word(4)? == VERSION,
        "glTF container version {}, not 2",
        word(4)?
    );
    ensure!(
        word(8)? as usize == bytes.len(),
        "header says {} bytes, the file has {}",
        word(8)?,
        bytes.len()
    );
    let chunk = |at: usize, kind: u32| -> Result<(&[u8], usize)> {
        let len = word(at)? as usize;
        ensure!(
            word(at + 4)? == kind,
            "chunk at byte {at} has the wrong type"
        );
        ensure!(
            len.is_multiple_of(4),
            "chunk at byte {at} is not 4-byte aligned"
        );
        let body = bytes
            .get(at + 8..at + 8 + len)
            .ok_or_else(|| anyhow::anyhow!("chunk at byte {at} runs past the end"))?;
        Ok((body, at + 8 + len))
    };
    let (json, next) = chunk(12, CHUNK_JSON)?;
    if next == bytes.len() {
        return Ok((json, &[]));
    }
    let (bin, end) = chunk(next, CHUNK_BIN)?;
    ensure!(end == bytes.len(), "bytes after the BIN chunk");
    Ok((json, bin))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_alignment() {
        let glb = write(b"{\"a\":1}", &[1, 2, 3, 4, 5]).unwrap();
        assert_eq!(glb.len() % 4, 0);
        assert_eq!(&glb[..4], b"glTF");
        let (json, bin) = read(&glb).unwrap();
        assert_eq!(json, b"{\"a\":1} ");
        assert_eq!(bin, [1, 2, 3, 4, 5, 0, 0, 0]);
        let mut bad = glb.clone();
        bad[8] ^= 1;
        assert!(read(&bad).unwrap_err().to_string().contains("header says"));
        assert!(read(&glb[..10]).is_err());
    }
}
