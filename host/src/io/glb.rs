//! The binary glTF container (glTF 2.0 spec, "GLB File Format Specification"): a 12-byte header
//! (`glTF`, version 2, total length), a JSON chunk padded with spaces and a BIN chunk padded with
//! zeros, every chunk 4-byte aligned and all integers little-endian.

use gltf_json as json;
use json::validation::{Checked::Valid, USize64};

/// The document under construction and its binary buffer.
#[derive(Debug)]
pub struct Builder {
    /// The document.
    pub root: json::Root,
    /// The binary chunk.
    pub bin: Vec<u8>,
}

impl Builder {
    /// An empty document whose asset names Sinew as its generator.
    pub fn new() -> Self {
        Self {
            root: json::Root {
                asset: json::Asset {
                    version: "2.0".into(),
                    generator: Some(format!("sinew {}", env!("CARGO_PKG_VERSION"))),
                    copyright: None,
                    extensions: None,
                    extras: None,
                    min_version: None,
                },
                ..Default::default()
            },
            bin: Vec::new(),
        }
    }

    /// A buffer view over `bytes`, appended to the binary chunk at a 4-byte boundary.
    pub fn view(
        &mut self,
        bytes: &[u8],
        target: Option<json::buffer::Target>,
    ) -> json::Index<json::buffer::View> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: target.map(Valid),
            extensions: None,
            extras: None,
        })
    }

    /// An accessor over `values` of `kind` (VEC3, SCALAR, …), with min and max when `bounds`.
    pub fn floats(
        &mut self,
        values: &[f32],
        kind: json::accessor::Type,
        bounds: bool,
        target: Option<json::buffer::Target>,
    ) -> json::Index<json::Accessor> {
        let width = kind.multiplicity();
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, target);
        let (min, max) = if bounds {
            let mut lo = vec![f32::INFINITY; width];
            let mut hi = vec![f32::NEG_INFINITY; width];
            for row in values.chunks_exact(width) {
                for (i, v) in row.iter().enumerate() {
                    lo[i] = lo[i].min(*v);
                    hi[i] = hi[i].max(*v);
                }
            }
            (Some(serde_json::json!(lo)), Some(serde_json::json!(hi)))
        } else {
            (None, None)
        };
        self.accessor(
            view,
            values.len() / width,
            json::accessor::ComponentType::F32,
            kind,
            min,
            max,
        )
    }

    /// An accessor of `count` elements over `view`.
    #[allow(clippy::too_many_arguments)]
    pub fn accessor(
        &mut self,
        view: json::Index<json::buffer::View>,
        count: usize,
        component: json::accessor::ComponentType,
        kind: json::accessor::Type,
        min: Option<serde_json::Value>,
        max: Option<serde_json::Value>,
    ) -> json::Index<json::Accessor> {
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: None,
            type_: Valid(kind),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    /// An accessor over triangle (or any) vertex indices, as unsigned 32-bit integers.
    pub fn indices(&mut self, indices: &[u32]) -> json::Index<json::Accessor> {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(json::buffer::Target::ElementArrayBuffer));
        self.accessor(
            view,
            indices.len(),
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
            None,
        )
    }

    /// The `.glb` bytes: the one buffer declared, the JSON serialised, both chunks laid out.
    pub fn finish(mut self) -> Result<Vec<u8>, BuildError> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.root.push(json::Buffer {
            byte_length: USize64::from(self.bin.len()),
            name: None,
            uri: None,
            extensions: None,
            extras: None,
        });
        let text = json::serialize::to_vec(&self.root)?;
        Ok(write(&text, &self.bin)?)
    }

    /// [`Builder::finish`], with the serialised JSON edited by `edit` first (for what the typed
    /// document cannot hold as another file wrote it: a rig's materials and their extensions),
    /// then, with `compress`, the geometry compressed with `EXT_meshopt_compression`
    /// (`super::glb_compress`).
    pub fn finish_as(
        self,
        edit: impl FnOnce(&mut serde_json::Value),
        compress: bool,
    ) -> Result<Vec<u8>, BuildError> {
        let mut doc = serde_json::to_value(&self.root)?;
        edit(&mut doc);
        let mut bin = self.bin;
        if compress {
            bin = super::glb_compress::compress(&mut doc, &bin)?;
        }
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        if doc["buffers"].as_array().is_none_or(Vec::is_empty) {
            doc["buffers"] = serde_json::json!([{}]);
        }
        doc["buffers"][0] = serde_json::json!({"byteLength": bin.len()});
        let text = serde_json::to_vec(&doc)?;
        Ok(write(&text, &bin)?)
    }
}

impl Default for Builder {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a [`Builder`] could not finish its file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BuildError {
    /// The glTF document could not be serialised.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The container could not be laid out.
    #[error(transparent)]
    Glb(#[from] GlbError),
    /// The geometry could not be compressed.
    #[error(transparent)]
    Compress(#[from] super::glb_compress::CompressError),
}

/// Why bytes could not be laid out as, or read as, a binary glTF.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum GlbError {
    /// The container's 32-bit length cannot hold the file.
    #[error("a .glb holds at most 4 GiB, this one would be {bytes} bytes")]
    TooLarge {
        /// The bytes the file would have.
        bytes: usize,
    },
    /// The file ends inside a header or chunk header.
    #[error("truncated at byte {at}")]
    Truncated {
        /// Where a word was expected.
        at: usize,
    },
    /// The file does not start with `glTF`.
    #[error("not a binary glTF (magic)")]
    Magic,
    /// A container version other than 2.
    #[error("glTF container version {version}, not 2")]
    Version {
        /// The file's version.
        version: u32,
    },
    /// The header's length is not the file's.
    #[error("header says {header} bytes, the file has {file}")]
    Length {
        /// The header's length.
        header: u32,
        /// The file's length.
        file: usize,
    },
    /// A chunk of the wrong type where JSON or BIN was expected.
    #[error("chunk at byte {at} has the wrong type")]
    ChunkType {
        /// Where the chunk starts.
        at: usize,
    },
    /// A chunk whose length is not a multiple of 4.
    #[error("chunk at byte {at} is not 4-byte aligned")]
    ChunkAlignment {
        /// Where the chunk starts.
        at: usize,
    },
    /// A chunk longer than the rest of the file.
    #[error("chunk at byte {at} runs past the end")]
    ChunkPastEnd {
        /// Where the chunk starts.
        at: usize,
    },
    /// Bytes after the BIN chunk.
    #[error("bytes after the BIN chunk")]
    TrailingBytes,
}

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
pub fn write(json: &[u8], bin: &[u8]) -> Result<Vec<u8>, GlbError> {
    let json = padded(json, b' ');
    let bin = padded(bin, 0);
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let Ok(total32) = u32::try_from(total) else {
        return Err(GlbError::TooLarge { bytes: total });
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
pub fn read(bytes: &[u8]) -> Result<(&[u8], &[u8]), GlbError> {
    let word = |at: usize| -> Result<u32, GlbError> {
        match bytes.get(at..at + 4) {
            Some(b) => Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            None => Err(GlbError::Truncated { at }),
        }
    };
    if word(0)? != MAGIC {
        return Err(GlbError::Magic);
    }
    let version = word(4)?;
    if version != VERSION {
        return Err(GlbError::Version { version });
    }
    let header = word(8)?;
    if header as usize != bytes.len() {
        return Err(GlbError::Length {
            header,
            file: bytes.len(),
        });
    }
    let chunk = |at: usize, kind: u32| -> Result<(&[u8], usize), GlbError> {
        let len = word(at)? as usize;
        if word(at + 4)? != kind {
            return Err(GlbError::ChunkType { at });
        }
        if !len.is_multiple_of(4) {
            return Err(GlbError::ChunkAlignment { at });
        }
        let body = bytes
            .get(at + 8..at + 8 + len)
            .ok_or(GlbError::ChunkPastEnd { at })?;
        Ok((body, at + 8 + len))
    };
    let (json, next) = chunk(12, CHUNK_JSON)?;
    if next == bytes.len() {
        return Ok((json, &[]));
    }
    let (bin, end) = chunk(next, CHUNK_BIN)?;
    if end != bytes.len() {
        return Err(GlbError::TrailingBytes);
    }
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
        assert!(matches!(read(&bad), Err(GlbError::Length { .. })));
        assert_eq!(read(&glb[..10]), Err(GlbError::Truncated { at: 8 }));
        let mut more = glb.clone();
        more.extend_from_slice(&[0; 4]);
        let len = more.len() as u32;
        more[8..12].copy_from_slice(&len.to_le_bytes());
        assert_eq!(read(&more), Err(GlbError::TrailingBytes));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cut.glb");
        std::fs::write(&path, &glb[..glb.len() - 4]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert!(matches!(read(&bytes), Err(GlbError::Length { .. })));
    }
}
