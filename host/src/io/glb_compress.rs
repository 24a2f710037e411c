//! A glTF document's geometry compressed with `EXT_meshopt_compression`, for web delivery:
//! every buffer view that accessors read is encoded by meshoptimizer's own encoder (the `meshopt`
//! crate) losslessly: vertex data (attributes, morph targets, skin, animation keys) with the
//! vertex codec at version 0, the one the extension defines, and indices with the index sequence
//! codec, which keeps every triangle's corners in order. No filter quantises anything, so the
//! decoded bytes are the uncompressed file's and an engine poses it exactly as that one.
//!
//! The views move to a second buffer that holds no data (the extension's `fallback`), and the
//! extension is required: a file without an uncompressed copy is the smaller, and the engines
//! that deliver to the web (three.js, Babylon.js, PlayCanvas) decode it; an application without
//! a meshopt decoder takes the uncompressed export instead. Views no accessor reads (images)
//! stay in the binary chunk as they are.

use std::collections::BTreeMap;

use serde_json::{Value, json};

/// The extension written.
pub const EXTENSION: &str = "EXT_meshopt_compression";

/// Why a view could not be compressed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CompressError {
    /// The encoder refused a view's data.
    #[error("buffer view {view}: the meshopt encoder refused it: {reason}")]
    Encode {
        /// The view.
        view: usize,
        /// What the encoder said.
        reason: String,
    },
    /// The document's views or accessors are not as the builder writes them.
    #[error("the document is malformed: {0}")]
    Document(String),
}

/// How a view is encoded: its mode and element size in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Codec {
    /// Vertex data of elements of this many bytes (a multiple of 4, at most 256).
    Attributes(usize),
    /// 32-bit indices.
    Indices,
}

/// The bytes of one element of an accessor, from its JSON.
fn element_size(accessor: &Value) -> Option<usize> {
    let component = match accessor.get("componentType")?.as_u64()? {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        5125 | 5126 => 4,
        _ => return None,
    };
    let count = match accessor.get("type")?.as_str()? {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" | "MAT2" => 4,
        "MAT3" => 9,
        "MAT4" => 16,
        _ => return None,
    };
    Some(component * count)
}

/// Each view that accessors read whole (no accessor offset, no view stride, one element size),
/// with its codec; indices of 32 bits take the index codec.
fn codecs(doc: &Value, indices: &[usize]) -> BTreeMap<usize, Option<Codec>> {
    let mut out: BTreeMap<usize, Option<Codec>> = BTreeMap::new();
    let views = doc["bufferViews"].as_array().cloned().unwrap_or_default();
    for (i, a) in doc["accessors"]
        .as_array()
        .cloned()
        .unwrap_or_default()
        .iter()
        .enumerate()
    {
        let Some(view) = a
            .get("bufferView")
            .and_then(Value::as_u64)
            .map(|v| v as usize)
        else {
            continue;
        };
        let whole = a.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) == 0
            && a.get("sparse").is_none()
            && views
                .get(view)
                .is_some_and(|v| v.get("byteStride").is_none());
        let codec = match element_size(a) {
            _ if !whole => None,
            Some(4) if indices.contains(&i) && a["componentType"] == 5125 => Some(Codec::Indices),
            _ if indices.contains(&i) => None,
            Some(size) if size.is_multiple_of(4) && size <= 256 => Some(Codec::Attributes(size)),
            _ => None,
        };
        let entry = out.entry(view).or_insert(codec);
        if *entry != codec {
            *entry = None;
        }
    }
    out
}

/// The vertex codec at version 0 over elements of `N` bytes.
fn encode_vertices<const N: usize>(bytes: &[u8]) -> Result<Vec<u8>, String> {
    let elements: Vec<[u8; N]> = bytes
        .chunks_exact(N)
        .map(|c| {
            let mut e = [0u8; N];
            e.copy_from_slice(c);
            e
        })
        .collect();
    meshopt::encode_vertex_buffer_level(&elements, 2, Some(0)).map_err(|e| e.to_string())
}

fn encode(codec: Codec, bytes: &[u8]) -> Result<Vec<u8>, String> {
    match codec {
        Codec::Indices => {
            let indices: Vec<u32> = bytes
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            let vertices = indices.iter().max().map_or(0, |&m| m as usize + 1);
            meshopt::encode_index_sequence(&indices, vertices).map_err(|e| e.to_string())
        }
        Codec::Attributes(4) => encode_vertices::<4>(bytes),
        Codec::Attributes(8) => encode_vertices::<8>(bytes),
        Codec::Attributes(12) => encode_vertices::<12>(bytes),
        Codec::Attributes(16) => encode_vertices::<16>(bytes),
        Codec::Attributes(36) => encode_vertices::<36>(bytes),
        Codec::Attributes(64) => encode_vertices::<64>(bytes),
        Codec::Attributes(n) => Err(format!("no encoder for {n}-byte elements")),
    }
}

/// Compresses the views of `doc` (whose one buffer is `bin`) that accessors read; returns the
/// new binary chunk. `doc` gains the fallback buffer, the views' extension objects and the
/// extension, used and required. `buffers` must not be written yet: the caller adds buffer 0
/// (the binary chunk) after.
pub fn compress(doc: &mut Value, bin: &[u8]) -> Result<Vec<u8>, CompressError> {
    let malformed = |what: &str| CompressError::Document(what.to_owned());
    let indices: Vec<usize> = doc["meshes"]
        .as_array()
        .into_iter()
        .flatten()
        .flat_map(|m| m["primitives"].as_array().cloned().unwrap_or_default())
        .filter_map(|p| p.get("indices").and_then(Value::as_u64).map(|i| i as usize))
        .collect();
    let codecs = codecs(doc, &indices);
    let views = doc["bufferViews"]
        .as_array_mut()
        .ok_or_else(|| malformed("no buffer views"))?;
    let (mut out, mut fallback) = (Vec::new(), 0usize);
    let mut compressed = 0;
    for (i, view) in views.iter_mut().enumerate() {
        let offset = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
        let length = view
            .get("byteLength")
            .and_then(Value::as_u64)
            .ok_or_else(|| malformed("a view without byteLength"))? as usize;
        let bytes = bin
            .get(offset..offset + length)
            .ok_or_else(|| malformed("a view past the binary chunk"))?;
        while !out.len().is_multiple_of(4) {
            out.push(0);
        }
        let Some(Some(codec)) = codecs.get(&i).copied() else {
            view["byteOffset"] = json!(out.len());
            out.extend_from_slice(bytes);
            continue;
        };
        let encoded =
            encode(codec, bytes).map_err(|reason| CompressError::Encode { view: i, reason })?;
        let (stride, mode) = match codec {
            Codec::Indices => (4, "INDICES"),
            Codec::Attributes(n) => (n, "ATTRIBUTES"),
        };
        view["extensions"] = json!({EXTENSION: {
            "buffer": 0,
            "byteOffset": out.len(),
            "byteLength": encoded.len(),
            "byteStride": stride,
            "count": length / stride,
            "mode": mode,
        }});
        view["buffer"] = json!(1);
        view["byteOffset"] = json!(fallback);
        out.extend_from_slice(&encoded);
        fallback += length.div_ceil(4) * 4;
        compressed += 1;
    }
    if compressed == 0 {
        return Ok(bin.to_vec());
    }
    // Buffer 0 (the binary chunk) is the caller's to add; the fallback follows it.
    doc["buffers"] = json!([
        {"byteLength": 0},
        {"byteLength": fallback, "extensions": {EXTENSION: {"fallback": true}}}
    ]);
    for key in ["extensionsUsed", "extensionsRequired"] {
        let list = doc
            .as_object_mut()
            .ok_or_else(|| malformed("not an object"))?
            .entry(key)
            .or_insert_with(|| json!([]));
        if let Value::Array(list) = list
            && !list.iter().any(|e| e == EXTENSION)
        {
            list.push(EXTENSION.into());
        }
    }
    Ok(out)
}
