//! Buffer views compressed by `EXT_meshopt_compression` (or its ratified twin
//! `KHR_meshopt_compression`): the extension object read and checked against the spec's rules,
//! then its bytes decoded by meshoptimizer's own decoder (the `meshopt` crate: the attribute,
//! triangle and index codecs, the octahedral, quaternion, exponential and colour filters).
//!
//! The decoder is safe for untrusted bytes once its preconditions hold (a stride it supports, a
//! triangle count divisible by 3); every one of them is checked here first, and the size a view
//! declares is bounded before anything is allocated, so that hostile JSON or bytes give an error,
//! never an abort. This file depends on nothing else of the crate: the fuzz target
//! (`host/fuzz`) compiles it as it is.

/// The most bytes one decoded view may hold (1 GiB: 89 million vertices of 12 bytes).
pub const MAX_DECODED: usize = 1 << 30;

/// The most bytes a view may decode to per compressed byte: above the codecs' own limit (a
/// block of 256 elements of 4 bytes whose channels are all zero costs one control byte in the
/// attribute codec's version 1), so that only sizes no encoder can have written are refused.
pub const MAX_RATIO: usize = 2048;

/// What a compressed view holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Vertex attributes (mode 0).
    Attributes,
    /// A triangle list's indices (mode 1).
    Triangles,
    /// Other indices (mode 2).
    Indices,
}

/// The transform applied after decoding attributes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// None.
    None,
    /// Octahedral unit vectors (4 or 8 bytes).
    Octahedral,
    /// Quaternions (8 bytes).
    Quaternion,
    /// Floats as exponent and mantissa (4 bytes each).
    Exponential,
    /// Colours in YCoCg (`KHR_meshopt_compression` only; 4 or 8 bytes).
    Color,
}

/// A buffer view's compression object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Compressed {
    /// The buffer holding the compressed bytes.
    pub buffer: usize,
    /// Where they start in it.
    pub offset: usize,
    /// How many there are.
    pub length: usize,
    /// The decoded elements' stride.
    pub stride: usize,
    /// The decoded elements' count.
    pub count: usize,
    /// The codec.
    pub mode: Mode,
    /// The filter.
    pub filter: Filter,
}

/// Why a compressed view cannot be decoded.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MeshoptError {
    /// The extension object breaks its schema (a missing or mistyped field, an unknown mode).
    #[error("{extension}: {what}")]
    Schema {
        /// The extension's name.
        extension: String,
        /// What is wrong.
        what: String,
    },
    /// A layout the spec forbids (a stride the mode or filter does not allow, a count that
    /// disagrees with the view's length).
    #[error("{0}")]
    Layout(String),
    /// The compressed range lies past the end of its buffer.
    #[error("compressed bytes {start}..{end} lie past the end of buffer {buffer} ({len} bytes)")]
    Truncated {
        /// The buffer.
        buffer: usize,
        /// The range's start.
        start: usize,
        /// Its end.
        end: usize,
        /// The buffer's length.
        len: usize,
    },
    /// The view declares more decoded bytes than the bounds allow.
    #[error(
        "declares {declared} decoded bytes from {compressed} compressed ones, more than a \
         meshopt stream can hold ({MAX_RATIO} per byte, {MAX_DECODED} in all)"
    )]
    TooLarge {
        /// The decoded size declared.
        declared: usize,
        /// The compressed size.
        compressed: usize,
    },
    /// The decoder refused the bytes: a truncated stream, a count that disagrees with the data,
    /// a header of an unknown version.
    #[error(
        "the {mode:?} stream of {compressed} bytes does not decode to {count} elements of \
         {stride} bytes (meshoptimizer: {code}); the data is truncated, corrupt or of another count"
    )]
    Stream {
        /// The codec.
        mode: Mode,
        /// The compressed size.
        compressed: usize,
        /// The elements declared.
        count: usize,
        /// Their stride.
        stride: usize,
        /// The decoder's error.
        code: String,
    },
}

impl Compressed {
    /// Reads the compression object `value` of extension `extension`.
    pub fn parse(extension: &str, value: &serde_json::Value) -> Result<Self, MeshoptError> {
        let schema = |what: String| MeshoptError::Schema {
            extension: extension.to_owned(),
            what,
        };
        let number = |key: &str, default: Option<usize>| -> Result<usize, MeshoptError> {
            match value.get(key) {
                None => default.ok_or_else(|| schema(format!("no `{key}`"))),
                Some(v) => v
                    .as_u64()
                    .and_then(|n| usize::try_from(n).ok())
                    .ok_or_else(|| schema(format!("`{key}` is {v}, not a count"))),
            }
        };
        let text = |key: &str| value.get(key).map(|v| v.as_str().ok_or(v));
        let mode = match text("mode") {
            Some(Ok("ATTRIBUTES")) => Mode::Attributes,
            Some(Ok("TRIANGLES")) => Mode::Triangles,
            Some(Ok("INDICES")) => Mode::Indices,
            Some(Ok(other)) => return Err(schema(format!("unknown mode {other:?}"))),
            Some(Err(v)) => return Err(schema(format!("`mode` is {v}, not a string"))),
            None => return Err(schema("no `mode`".into())),
        };
        let filter = match text("filter") {
            None | Some(Ok("NONE")) => Filter::None,
            Some(Ok("OCTAHEDRAL")) => Filter::Octahedral,
            Some(Ok("QUATERNION")) => Filter::Quaternion,
            Some(Ok("EXPONENTIAL")) => Filter::Exponential,
            Some(Ok("COLOR")) if extension == "KHR_meshopt_compression" => Filter::Color,
            Some(Ok(other)) => return Err(schema(format!("unknown filter {other:?}"))),
            Some(Err(v)) => return Err(schema(format!("`filter` is {v}, not a string"))),
        };
        Ok(Self {
            buffer: number("buffer", None)?,
            offset: number("byteOffset", Some(0))?,
            length: number("byteLength", None)?,
            stride: number("byteStride", None)?,
            count: number("count", None)?,
            mode,
            filter,
        })
    }

    /// Checks the layout against the spec's rules and against the parent view's length and
    /// stride; returns the decoded size.
    pub fn check(
        &self,
        view_length: usize,
        view_stride: Option<usize>,
    ) -> Result<usize, MeshoptError> {
        let layout = |what: String| Err(MeshoptError::Layout(what));
        let (stride, count) = (self.stride, self.count);
        if let Some(s) = view_stride
            && s != stride
        {
            return layout(format!("byteStride {stride}, but its buffer view's is {s}"));
        }
        let Some(size) = stride.checked_mul(count) else {
            return layout(format!("{count} elements of {stride} bytes overflow"));
        };
        if size != view_length {
            return layout(format!(
                "{count} elements of {stride} bytes are {size} bytes, but the buffer view holds \
                 {view_length}"
            ));
        }
        match self.mode {
            Mode::Attributes if stride == 0 || stride % 4 != 0 || stride > 256 => {
                return layout(format!(
                    "ATTRIBUTES with byteStride {stride}, which is not a multiple of 4 up to 256"
                ));
            }
            Mode::Triangles | Mode::Indices if stride != 2 && stride != 4 => {
                return layout(format!(
                    "{:?} with byteStride {stride}, not 2 or 4",
                    self.mode
                ));
            }
            Mode::Triangles if count % 3 != 0 => {
                return layout(format!(
                    "TRIANGLES with {count} indices, not a multiple of 3"
                ));
            }
            Mode::Triangles | Mode::Indices if self.filter != Filter::None => {
                return layout(format!("{:?} with the filter {:?}", self.mode, self.filter));
            }
            _ => {}
        }
        match self.filter {
            Filter::Octahedral | Filter::Color if stride != 4 && stride != 8 => {
                return layout(format!(
                    "{:?} filter with byteStride {stride}, not 4 or 8",
                    self.filter
                ));
            }
            Filter::Quaternion if stride != 8 => {
                return layout(format!("QUATERNION filter with byteStride {stride}, not 8"));
            }
            _ => {}
        }
        let ceiling = self.length.saturating_mul(MAX_RATIO).min(MAX_DECODED);
        if size > ceiling {
            return Err(MeshoptError::TooLarge {
                declared: size,
                compressed: self.length,
            });
        }
        Ok(size)
    }

    /// The decoded view: `buffer` is the bytes of buffer `self.buffer`; `view_length` and
    /// `view_stride` the parent view's.
    pub fn decode(
        &self,
        buffer: &[u8],
        view_length: usize,
        view_stride: Option<usize>,
    ) -> Result<Vec<u8>, MeshoptError> {
        let size = self.check(view_length, view_stride)?;
        let end = self.offset.checked_add(self.length);
        let Some(data) = end.and_then(|end| buffer.get(self.offset..end)) else {
            return Err(MeshoptError::Truncated {
                buffer: self.buffer,
                start: self.offset,
                end: end.unwrap_or(usize::MAX),
                len: buffer.len(),
            });
        };
        let stream = |e: meshopt::Error| MeshoptError::Stream {
            mode: self.mode,
            compressed: data.len(),
            count: self.count,
            stride: self.stride,
            code: e.to_string(),
        };
        let mut out = match (self.mode, self.stride) {
            (Mode::Attributes, _) => attributes(data, self.count, self.stride).map_err(stream)?,
            (Mode::Triangles, 2) => {
                le16(&meshopt::decode_index_buffer::<u16>(data, self.count).map_err(stream)?)
            }
            (Mode::Triangles, _) => {
                le32(&meshopt::decode_index_buffer::<u32>(data, self.count).map_err(stream)?)
            }
            (Mode::Indices, 2) => {
                le16(&meshopt::decode_index_sequence::<u16>(data, self.count).map_err(stream)?)
            }
            (Mode::Indices, _) => {
                le32(&meshopt::decode_index_sequence::<u32>(data, self.count).map_err(stream)?)
            }
        };
        filter(self.filter, self.stride, &mut out);
        debug_assert_eq!(out.len(), size);
        Ok(out)
    }
}

fn le16(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn le32(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// One element of `N` bytes: the decoder's element type for a stride of `N`.
#[derive(Clone, Copy)]
struct Element<const N: usize>([u8; N]);

impl<const N: usize> Default for Element<N> {
    fn default() -> Self {
        Self([0; N])
    }
}

fn decode_as<const N: usize>(data: &[u8], count: usize) -> meshopt::Result<Vec<u8>> {
    let elements = meshopt::decode_vertex_buffer::<Element<N>>(data, count)?;
    Ok(elements.iter().flat_map(|e| e.0).collect())
}

/// The attribute codec over elements of `stride` bytes (a multiple of 4 up to 256, checked).
fn attributes(data: &[u8], count: usize, stride: usize) -> meshopt::Result<Vec<u8>> {
    // The decoder's element size is its type's; each allowed stride has its own.
    macro_rules! by_stride {
        ($($n:literal)*) => {
            match stride {
                $($n => decode_as::<$n>(data, count),)*
                _ => Err(meshopt::Error::Parse(format!("byteStride {stride}"))),
            }
        };
    }
    by_stride!(4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64 68 72 76 80 84 88 92 96 100 104 108
        112 116 120 124 128 132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192 196
        200 204 208 212 216 220 224 228 232 236 240 244 248 252 256)
}

/// Applies `filter` in place to decoded elements of `stride` bytes (checked against it).
fn filter(filter: Filter, stride: usize, bytes: &mut [u8]) {
    match (filter, stride) {
        (Filter::None, _) => {}
        (Filter::Octahedral | Filter::Color, 4) => {
            let mut v: Vec<[i8; 4]> = bytes
                .chunks_exact(4)
                .map(|c| std::array::from_fn(|k| i8::from_le_bytes([c[k]])))
                .collect();
            if filter == Filter::Octahedral {
                meshopt::decode_filter_oct(&mut v);
            } else {
                meshopt::decode_filter_color(&mut v);
            }
            for (c, e) in bytes.chunks_exact_mut(4).zip(&v) {
                for k in 0..4 {
                    c[k] = e[k].to_le_bytes()[0];
                }
            }
        }
        (Filter::Octahedral | Filter::Color | Filter::Quaternion, _) => {
            let mut v: Vec<[i16; 4]> = bytes
                .chunks_exact(8)
                .map(|c| std::array::from_fn(|k| i16::from_le_bytes([c[2 * k], c[2 * k + 1]])))
                .collect();
            match filter {
                Filter::Octahedral => meshopt::decode_filter_oct(&mut v),
                Filter::Color => meshopt::decode_filter_color(&mut v),
                _ => meshopt::decode_filter_quat(&mut v),
            }
            for (c, e) in bytes.chunks_exact_mut(8).zip(&v) {
                for k in 0..4 {
                    c[2 * k..2 * k + 2].copy_from_slice(&e[k].to_le_bytes());
                }
            }
        }
        (Filter::Exponential, _) => {
            // Each 32-bit value decodes on its own, whatever the element's stride.
            let mut v: Vec<[u32; 1]> = bytes
                .chunks_exact(4)
                .map(|c| [u32::from_le_bytes([c[0], c[1], c[2], c[3]])])
                .collect();
            meshopt::decode_filter_exp(&mut v);
            for (c, e) in bytes.chunks_exact_mut(4).zip(&v) {
                c.copy_from_slice(&e[0].to_le_bytes());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn object(mode: &str, filter: &str, stride: usize, count: usize, length: usize) -> Compressed {
        Compressed::parse(
            "EXT_meshopt_compression",
            &serde_json::json!({"buffer": 0, "byteLength": length, "byteStride": stride,
                "count": count, "mode": mode, "filter": filter}),
        )
        .unwrap()
    }

    #[test]
    fn encoded_views_decode_to_what_was_encoded() {
        let points: Vec<[u16; 4]> = (0..300u16).map(|i| [i, i * 3, 7, 40_000 - i]).collect();
        let encoded = meshopt::encode_vertex_buffer(&points).unwrap();
        let c = object("ATTRIBUTES", "NONE", 8, 300, encoded.len());
        let out = c.decode(&encoded, 2400, Some(8)).unwrap();
        let want: Vec<u8> = points
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(out, want);

        let triangles: Vec<u32> = (0..60).flat_map(|t| [t, t + 1, t + 2]).collect();
        let encoded = meshopt::encode_index_buffer(&triangles, 62).unwrap();
        let c = object("TRIANGLES", "NONE", 4, 180, encoded.len());
        // The codec may start a triangle at another corner, keeping its winding.
        let turned = |t: &[u32]| -> Vec<[u32; 3]> {
            t.chunks_exact(3)
                .map(|t| {
                    let m = (0..3).min_by_key(|&k| t[k]).unwrap();
                    [t[m], t[(m + 1) % 3], t[(m + 2) % 3]]
                })
                .collect()
        };
        let out = c.decode(&encoded, 720, None).unwrap();
        let out: Vec<u32> = out
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        assert_eq!(turned(&out), turned(&triangles));
        let c = object("TRIANGLES", "NONE", 2, 180, encoded.len());
        let out = c.decode(&encoded, 360, None).unwrap();
        let out: Vec<u32> = out
            .chunks_exact(2)
            .map(|b| u32::from(u16::from_le_bytes([b[0], b[1]])))
            .collect();
        assert_eq!(turned(&out), turned(&triangles));

        // Unit vectors through the octahedral filter, within its 8-bit step.
        let normals: Vec<[f32; 4]> = (0..64)
            .map(|i| {
                let a = f32::from(i as u8) * 0.1;
                [a.cos() * 0.6, a.sin() * 0.6, 0.8, 0.0]
            })
            .collect();
        let packed: Vec<[i8; 4]> = meshopt::encode_filter_oct(&normals, 8);
        let encoded = meshopt::encode_vertex_buffer(&packed).unwrap();
        let c = object("ATTRIBUTES", "OCTAHEDRAL", 4, 64, encoded.len());
        let out = c.decode(&encoded, 256, Some(4)).unwrap();
        for (n, e) in normals.iter().zip(out.chunks_exact(4)) {
            for k in 0..3 {
                let v = f32::from(i8::from_le_bytes([e[k]])) / 127.0;
                assert!((v - n[k]).abs() < 0.02, "{v} {}", n[k]);
            }
        }
    }

    #[test]
    fn bad_layouts_and_streams_are_errors() {
        let points: Vec<[u8; 4]> = (0..100u8).map(|i| [i, i, i, i]).collect();
        let encoded = meshopt::encode_vertex_buffer(&points).unwrap();
        let c = object("ATTRIBUTES", "NONE", 4, 100, encoded.len());
        // Truncated: every shorter stream is refused, never a panic.
        for cut in 0..encoded.len() {
            let short = Compressed { length: cut, ..c };
            assert!(short.decode(&encoded, 400, None).is_err(), "{cut}");
        }
        // A count that disagrees with the data (by a group of 16: within a group the codec
        // cannot tell, its groups being padded) or with the view.
        assert!(matches!(
            Compressed { count: 84, ..c }.decode(&encoded, 336, None),
            Err(MeshoptError::Stream { .. })
        ));
        assert!(matches!(
            c.decode(&encoded, 404, None),
            Err(MeshoptError::Layout(_))
        ));
        assert!(matches!(
            c.decode(&encoded, 400, Some(8)),
            Err(MeshoptError::Layout(_))
        ));
        // Strides the codecs and filters do not allow.
        for (mode, filter, stride) in [
            ("ATTRIBUTES", "NONE", 6),
            ("ATTRIBUTES", "NONE", 260),
            ("ATTRIBUTES", "QUATERNION", 4),
            ("ATTRIBUTES", "OCTAHEDRAL", 12),
            ("TRIANGLES", "NONE", 1),
            ("INDICES", "OCTAHEDRAL", 4),
        ] {
            let c = object(mode, filter, stride, 3, encoded.len());
            assert!(
                matches!(c.check(3 * stride, None), Err(MeshoptError::Layout(_))),
                "{mode} {filter} {stride}"
            );
        }
        let c = object("TRIANGLES", "NONE", 4, 4, encoded.len());
        assert!(matches!(c.check(16, None), Err(MeshoptError::Layout(_))));
        // Sizes no stream can hold, and ranges past the buffer.
        let c = object("ATTRIBUTES", "NONE", 4, 1 << 20, 40);
        assert!(matches!(
            c.check(4 << 20, None),
            Err(MeshoptError::TooLarge { .. })
        ));
        let c = Compressed {
            offset: 10,
            ..object("ATTRIBUTES", "NONE", 4, 100, encoded.len())
        };
        assert!(matches!(
            c.decode(&encoded, 400, None),
            Err(MeshoptError::Truncated { .. })
        ));
        // Schema.
        for bad in [
            serde_json::json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 1}),
            serde_json::json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 1, "mode": "FAST"}),
            serde_json::json!({"buffer": -1, "byteLength": 4, "byteStride": 4, "count": 1, "mode": "INDICES"}),
            serde_json::json!({"buffer": 0, "byteLength": 4, "byteStride": 4, "count": 1, "mode": "ATTRIBUTES", "filter": "COLOR"}),
        ] {
            assert!(matches!(
                Compressed::parse("EXT_meshopt_compression", &bad),
                Err(MeshoptError::Schema { .. })
            ));
        }
    }
}
