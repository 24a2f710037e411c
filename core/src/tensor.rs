//! Read-only views of little-endian numbers inside a byte slice of any alignment.
//!
//! A baked model is usually a `&'static [u8]` from `include_bytes!` (alignment 1) or a buffer the
//! caller read from disk. The core never reinterprets those bytes as `&[f32]` (that would need
//! `unsafe` and an aligned buffer); every value is decoded with `from_le_bytes`, which compiles to a
//! plain load on little-endian targets.

/// A view of little-endian `f32` values.
///
/// The byte length is always a multiple of four (the constructor checks it), so every accessor is
/// total. Accessors that take an index return `0.0` for an index past the end; on a validated model
/// that cannot happen, and returning a value keeps evaluation free of panics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct F32s<'a> {
    bytes: &'a [u8],
}

/// A view of little-endian `u32` values (indices, counts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct U32s<'a> {
    bytes: &'a [u8],
}

/// A view of little-endian `i32` values holding Q16.16 fixed-point numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct I32s<'a> {
    bytes: &'a [u8],
}

macro_rules! le_view {
    ($name:ident, $t:ty, $zero:expr) => {
        impl<'a> $name<'a> {
            /// Wraps `bytes`; `None` unless its length is a multiple of four.
            pub const fn new(bytes: &'a [u8]) -> Option<Self> {
                if bytes.len() % 4 == 0 {
                    Some(Self { bytes })
                } else {
                    None
                }
            }

            /// An empty view.
            pub const fn empty() -> Self {
                Self { bytes: &[] }
            }

            /// Number of values.
            pub const fn len(&self) -> usize {
                self.bytes.len() / 4
            }

            /// Whether the view holds no values.
            pub const fn is_empty(&self) -> bool {
                self.bytes.is_empty()
            }

            /// The underlying bytes.
            pub const fn as_bytes(&self) -> &'a [u8] {
                self.bytes
            }

            /// Value `i`, or zero past the end (see the type's documentation).
            #[inline]
            pub fn at(&self, i: usize) -> $t {
                let start = i.saturating_mul(4);
                match self.bytes.get(start..start.saturating_add(4)) {
                    Some(&[a, b, c, d]) => <$t>::from_le_bytes([a, b, c, d]),
                    _ => $zero,
                }
            }

            /// Value `i`, or `None` past the end.
            #[inline]
            pub fn get(&self, i: usize) -> Option<$t> {
                let start = i.checked_mul(4)?;
                match self.bytes.get(start..start.checked_add(4)?) {
                    Some(&[a, b, c, d]) => Some(<$t>::from_le_bytes([a, b, c, d])),
                    _ => None,
                }
            }

            /// The values `start..start + len`, clamped to the view.
            pub fn slice(&self, start: usize, len: usize) -> Self {
                let from = start.saturating_mul(4).min(self.bytes.len());
                let to = start
                    .saturating_add(len)
                    .saturating_mul(4)
                    .min(self.bytes.len());
                Self {
                    bytes: self.bytes.get(from..to).unwrap_or(&[]),
                }
            }

            /// Iterates over the values in order.
            pub fn iter(&self) -> impl ExactSizeIterator<Item = $t> + 'a {
                self.bytes.chunks_exact(4).map(|c| match c {
                    &[a, b, c, d] => <$t>::from_le_bytes([a, b, c, d]),
                    _ => $zero,
                })
            }
        }
    };
}

le_view!(F32s, f32, 0.0);
le_view!(U32s, u32, 0);
le_view!(I32s, i32, 0);

impl F32s<'_> {
    /// Dot product with `x`, summed in index order from zero with separate multiply and add (no
    /// fused multiply-add), so that every target rounds identically. Stops at the shorter length.
    #[inline]
    pub fn dot(&self, x: &[f32]) -> f32 {
        let mut acc = 0.0f32;
        for (w, v) in self.iter().zip(x) {
            acc += w * *v;
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_little_endian_at_any_alignment() {
        // One padding byte in front makes the values start at an odd address.
        let bytes = [0xAA, 0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00, 0xC0];
        let v = F32s::new(&bytes[1..]).unwrap();
        assert_eq!(v.len(), 2);
        assert_eq!(v.at(0), 1.0);
        assert_eq!(v.at(1), -2.0);
        assert_eq!(v.at(2), 0.0);
        assert_eq!(v.get(2), None);
        assert_eq!(
            v.iter().collect::<heapless::Vec<f32, 4>>().as_slice(),
            &[1.0, -2.0]
        );
    }

    #[test]
    fn rejects_ragged_length_and_clamps_slices() {
        assert!(U32s::new(&[1, 2, 3]).is_none());
        let bytes = [1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0];
        let v = U32s::new(&bytes).unwrap();
        assert_eq!(
            v.slice(1, 5)
                .iter()
                .collect::<heapless::Vec<u32, 4>>()
                .as_slice(),
            &[2, 3]
        );
        assert!(v.slice(7, 1).is_empty());
        assert_eq!(I32s::new(&[0, 0, 1, 0]).unwrap().at(0), 65536);
    }

    #[test]
    fn dot_sums_in_order() {
        let mut bytes = [0u8; 12];
        for (c, w) in bytes.chunks_exact_mut(4).zip([1.0f32, 2.0, 3.0]) {
            c.copy_from_slice(&w.to_le_bytes());
        }
        assert_eq!(F32s::new(&bytes).unwrap().dot(&[4.0, 5.0, 6.0]), 32.0);
    }
}
