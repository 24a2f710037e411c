//! A 64-bit hash of frames of `f32` values, identical on every target: the fingerprint that
//! golden tests and the firmware simulator compare.
//!
//! The hash is XXH64 (seed 0) of the values' bit patterns, each written as 4 little-endian bytes,
//! with one exception: every NaN is written as the canonical quiet NaN `0x7FC0_0000`, because the
//! payload and sign of a NaN produced by arithmetic differ between targets (wasm in particular).
//! `-0.0` and `0.0` keep their distinct bit patterns.

use core::fmt;
use xxhash_rust::xxh64::Xxh64;

/// The bit pattern every NaN is hashed as.
pub const CANONICAL_NAN_BITS: u32 = 0x7FC0_0000;

/// Bytes collected before they are handed to XXH64 (a multiple of 4 and of XXH64's 32-byte
/// stripe).
const BUF_LEN: usize = 64;

/// The bit pattern hashed for `v`: `v.to_bits()`, or [`CANONICAL_NAN_BITS`] for any NaN.
#[inline]
pub fn canonical_bits(v: f32) -> u32 {
    if v.is_nan() {
        CANONICAL_NAN_BITS
    } else {
        v.to_bits()
    }
}

/// Streaming frame hasher. Writing values in several calls gives the same hash as writing them all
/// at once.
#[derive(Clone)]
pub struct FrameHasher {
    state: Xxh64,
    buf: [u8; BUF_LEN],
    /// Bytes used in `buf`; always a multiple of 4 and below `BUF_LEN` between calls.
    used: usize,
}

impl FrameHasher {
    /// A hasher with XXH64 seed 0 and nothing written.
    pub const fn new() -> Self {
        Self {
            state: Xxh64::new(0),
            buf: [0; BUF_LEN],
            used: 0,
        }
    }

    /// Writes `values` in order, each as its canonical bits ([`canonical_bits`]) in little-endian.
    pub fn write_f32s(&mut self, values: &[f32]) {
        for v in values {
            self.push(canonical_bits(*v).to_le_bytes());
        }
    }

    /// Writes one `u32` in little-endian (e.g. a frame index or a count).
    pub fn write_u32(&mut self, value: u32) {
        self.push(value.to_le_bytes());
    }

    /// The hash of everything written so far. The hasher is left unchanged and can keep going.
    pub fn finish(&self) -> u64 {
        let mut state = self.state.clone();
        state.update(self.buf.get(..self.used).unwrap_or(&[]));
        state.digest()
    }

    #[inline]
    fn push(&mut self, bytes: [u8; 4]) {
        if let Some(dst) = self.buf.get_mut(self.used..self.used + 4) {
            dst.copy_from_slice(&bytes);
            self.used += 4;
        }
        if self.used >= BUF_LEN {
            self.state.update(&self.buf);
            self.used = 0;
        }
    }
}

impl Default for FrameHasher {
    fn default() -> Self {
        Self::new()
    }
}

impl fmt::Debug for FrameHasher {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FrameHasher")
            .field("hash_so_far", &self.finish())
            .finish()
    }
}

/// The frame hash of `values`: [`FrameHasher::write_f32s`] then [`FrameHasher::finish`]. An S2D
/// frame's hash (replays, generated sequences): its decoded vertices.
pub fn frame_hash(values: &[f32]) -> u64 {
    let mut h = FrameHasher::new();
    h.write_f32s(values);
    h.finish()
}

/// The frame hash of a posed actor in the f32 and fast modes (replays, fitted performances,
/// driven frames): its `positions`, then its `normals`.
pub fn posed_frame_hash(positions: &[f32], normals: &[f32]) -> u64 {
    let mut h = FrameHasher::new();
    h.write_f32s(positions);
    h.write_f32s(normals);
    h.finish()
}

/// The frame hash of a posed actor in the Q16.16 mode: its fixed-point `positions`' raw bits
/// ([`FrameHasher::write_u32`] of each; the normals are not computed in that mode).
pub fn q16_frame_hash(positions: &[crate::q16::Q16]) -> u64 {
    let mut h = FrameHasher::new();
    for v in positions {
        h.write_u32(v.to_bits() as u32);
    }
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    #[test]
    fn empty_is_xxh64_of_nothing() {
        // XXH64("", seed 0) = 0xEF46DB3751D8E999 (the reference implementation's test vector).
        assert_eq!(frame_hash(&[]), 0xEF46_DB37_51D8_E999);
        assert_eq!(FrameHasher::new().finish(), 0xEF46_DB37_51D8_E999);
        assert_eq!(FrameHasher::default().finish(), 0xEF46_DB37_51D8_E999);
    }

    #[test]
    fn equals_one_shot_xxh64_of_le_bits() {
        let values: Vec<f32> = (0..100).map(|i| i as f32 * 0.37 - 5.0).collect();
        let bytes: Vec<u8> = values
            .iter()
            .flat_map(|v| v.to_bits().to_le_bytes())
            .collect();
        assert_eq!(frame_hash(&values), xxhash_rust::xxh64::xxh64(&bytes, 0));
        // 1.0 = 0x3F80_0000 → bytes 00 00 80 3F.
        assert_eq!(
            frame_hash(&[1.0]),
            xxhash_rust::xxh64::xxh64(&[0x00, 0x00, 0x80, 0x3F], 0)
        );
        let mut h = FrameHasher::new();
        h.write_u32(0x3F80_0000);
        assert_eq!(h.finish(), frame_hash(&[1.0]));
    }

    #[test]
    fn a_posed_frame_is_its_positions_then_its_normals() {
        let positions: Vec<f32> = (0..30).map(|i| i as f32 * 0.25 - 3.0).collect();
        let normals: Vec<f32> = (0..30).map(|i| 1.0 - i as f32 / 30.0).collect();
        let both: Vec<f32> = positions.iter().chain(&normals).copied().collect();
        assert_eq!(posed_frame_hash(&positions, &normals), frame_hash(&both));
        assert_ne!(
            posed_frame_hash(&positions, &normals),
            posed_frame_hash(&normals, &positions)
        );
        // Q16.16 positions hash their raw 32 bits, as `write_u32` of each.
        let q16: Vec<crate::q16::Q16> = positions
            .iter()
            .map(|&v| crate::q16::Q16::from_num(v))
            .collect();
        let mut h = FrameHasher::new();
        for v in &q16 {
            h.write_u32(v.to_bits() as u32);
        }
        assert_eq!(q16_frame_hash(&q16), h.finish());
        assert_ne!(q16_frame_hash(&q16), frame_hash(&positions));
    }

    #[test]
    fn nan_variants_hash_equal() {
        let nans = [
            f32::NAN,
            -f32::NAN,
            f32::from_bits(0x7FC0_0001),
            f32::from_bits(0x7F80_0001), // signalling
            f32::from_bits(0xFFFF_FFFF),
        ];
        let h = frame_hash(&[f32::from_bits(CANONICAL_NAN_BITS)]);
        for n in nans {
            assert!(n.is_nan());
            assert_eq!(frame_hash(&[n]), h);
            assert_eq!(
                frame_hash(&[1.0, n, 2.0]),
                frame_hash(&[1.0, f32::from_bits(CANONICAL_NAN_BITS), 2.0])
            );
        }
        // Infinities are not NaN and stay distinct.
        assert_ne!(frame_hash(&[f32::INFINITY]), h);
        assert_ne!(
            frame_hash(&[f32::INFINITY]),
            frame_hash(&[f32::NEG_INFINITY])
        );
    }

    #[test]
    fn signed_zeros_differ() {
        assert_ne!(frame_hash(&[-0.0]), frame_hash(&[0.0]));
    }

    #[test]
    fn chunking_invariance() {
        // 53 values = 212 bytes: crosses the 64-byte buffer and XXH64's 32-byte stripes unevenly.
        let values: Vec<f32> = (0..53)
            .map(|i| libm::sinf(i as f32) * 1000.0 + i as f32)
            .collect();
        let whole = frame_hash(&values);
        for split in [1, 3, 15, 16, 17, 32, 52] {
            let mut h = FrameHasher::new();
            let (a, b) = values.split_at(split);
            h.write_f32s(a);
            // finish() in the middle does not disturb the stream.
            let _ = h.finish();
            h.write_f32s(b);
            assert_eq!(h.finish(), whole, "split at {split}");
        }
        let mut h = FrameHasher::new();
        for v in &values {
            h.write_f32s(core::slice::from_ref(v));
        }
        assert_eq!(h.finish(), whole);
    }
}
