//! A glTF file's data as the skin reads it: each buffer (the `.glb`'s binary chunk, a `data:`
//! URI or a file beside it; a meshopt fallback buffer left unread), each buffer view (decoded
//! once where meshopt compressed it), and each accessor as numbers, dequantised by the rules of
//! the core spec and `KHR_mesh_quantization`, sparse substitutions applied. Every offset, stride
//! and count is checked against the bytes there are before it is used.

use std::cell::OnceCell;
use std::path::{Path, PathBuf};

use gltf::accessor::{DataType, Dimensions};

use super::meshopt::Compressed;
use crate::io::rig::file::RigReadError;

/// The most elements one accessor may have (67 million: far past any face).
const MAX_ELEMENTS: usize = 1 << 26;

/// The meshopt extensions, the ratified one last.
pub(super) const MESHOPT: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// What the skin reads an accessor as: which component types it may have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Role {
    /// `POSITION`.
    Position,
    /// `TEXCOORD_0`.
    TexCoord,
    /// `NORMAL` (of a mesh carried beside the skin).
    Normal,
    /// A morph target's `POSITION` (its `k`).
    TargetPosition(usize),
    /// A primitive's indices.
    Indices,
    /// A skin's inverse bind matrices.
    InverseBind,
}

impl Role {
    fn name(self) -> String {
        match self {
            Self::Position => "POSITION".into(),
            Self::TexCoord => "TEXCOORD_0".into(),
            Self::Normal => "NORMAL".into(),
            Self::TargetPosition(k) => format!("morph target {k} POSITION"),
            Self::Indices => "indices".into(),
            Self::InverseBind => "inverse bind matrices".into(),
        }
    }

    /// The accessor type the role needs.
    fn dimensions(self) -> Dimensions {
        match self {
            Self::Position | Self::Normal | Self::TargetPosition(_) => Dimensions::Vec3,
            Self::TexCoord => Dimensions::Vec2,
            Self::Indices => Dimensions::Scalar,
            Self::InverseBind => Dimensions::Mat4,
        }
    }

    /// Whether the core spec or `KHR_mesh_quantization` lets the role be stored so.
    fn allows(self, data: DataType, normalized: bool) -> bool {
        use DataType::{F32, I8, I16, U8, U16, U32};
        match self {
            Self::Position | Self::TexCoord => !(data == U32 || data == F32 && normalized),
            // Normals: FLOAT, or normalised BYTE or SHORT.
            Self::Normal => data == F32 && !normalized || matches!(data, I8 | I16) && normalized,
            // Morph target deltas are signed: FLOAT, BYTE and SHORT, normalised or not.
            Self::TargetPosition(_) => {
                matches!(data, F32 | I8 | I16) && !(data == F32 && normalized)
            }
            Self::Indices => matches!(data, U8 | U16 | U32) && !normalized,
            Self::InverseBind => data == F32 && !normalized,
        }
    }
}

/// The file's buffers and views, each view decoded once on first use.
pub(super) struct Data<'a> {
    path: &'a Path,
    /// Each buffer's bytes; `None` for a meshopt fallback buffer (or any without data).
    buffers: Vec<Option<Vec<u8>>>,
    views: Vec<OnceCell<Vec<u8>>>,
}

impl<'a> Data<'a> {
    /// Loads every buffer of `document` but the meshopt fallbacks; `blob` is the `.glb`'s
    /// binary chunk.
    pub(super) fn load(
        path: &'a Path,
        document: &'a gltf::Document,
        mut blob: Option<Vec<u8>>,
    ) -> Result<Self, RigReadError> {
        let mut buffers = Vec::new();
        for buffer in document.buffers() {
            let fallback = MESHOPT.iter().any(|e| {
                buffer
                    .extension_value(e)
                    .and_then(|v| v.get("fallback"))
                    .and_then(serde_json::Value::as_bool)
                    == Some(true)
            });
            let data = match buffer.source() {
                _ if fallback => None,
                // A buffer without a URI is the binary chunk only as a `.glb`'s first buffer;
                // elsewhere it is a placeholder for views that meshopt compresses.
                gltf::buffer::Source::Bin if buffer.index() == 0 && blob.is_some() => blob.take(),
                gltf::buffer::Source::Bin => None,
                gltf::buffer::Source::Uri(uri) => Some(read_uri(path, buffer.index(), uri)?),
            };
            if let Some(data) = &data
                && data.len() < buffer.length()
            {
                return Err(RigReadError::BufferLength {
                    path: path.to_owned(),
                    buffer: buffer.index(),
                    declared: buffer.length(),
                    found: data.len(),
                });
            }
            buffers.push(data);
        }
        Ok(Self {
            path,
            views: document.views().map(|_| OnceCell::new()).collect(),
            buffers,
        })
    }

    fn view_error(&self, view: usize, what: String) -> RigReadError {
        RigReadError::BufferView {
            path: self.path.to_owned(),
            view,
            what,
        }
    }

    /// The bytes of buffer view `view`, decoded where meshopt compressed it.
    pub(super) fn view(&self, view: &gltf::buffer::View<'_>) -> Result<&[u8], RigReadError> {
        let cell = &self.views[view.index()];
        if let Some(bytes) = cell.get() {
            return Ok(bytes);
        }
        let compressed = MESHOPT
            .iter()
            .find_map(|e| view.extension_value(e).map(|v| (*e, v)));
        let bytes = match compressed {
            Some((extension, value)) => {
                let c = Compressed::parse(extension, value)
                    .map_err(|e| self.view_error(view.index(), e.to_string()))?;
                let source = self
                    .buffers
                    .get(c.buffer)
                    .ok_or_else(|| {
                        self.view_error(
                            view.index(),
                            format!("{extension}: no buffer {}", c.buffer),
                        )
                    })?
                    .as_deref()
                    .ok_or_else(|| {
                        self.view_error(
                            view.index(),
                            format!(
                                "{extension}: buffer {} is a fallback without data",
                                c.buffer
                            ),
                        )
                    })?;
                c.decode(source, view.length(), view.stride())
                    .map_err(|e| self.view_error(view.index(), e.to_string()))?
            }
            None => {
                let buffer = view.buffer().index();
                let data = self.buffers[buffer].as_deref().ok_or_else(|| {
                    self.view_error(
                        view.index(),
                        format!("buffer {buffer} has no data (a fallback for compressed views)"),
                    )
                })?;
                let range = view.offset()..view.offset().saturating_add(view.length());
                data.get(range.clone())
                    .ok_or_else(|| {
                        self.view_error(
                            view.index(),
                            format!(
                                "bytes {}..{} lie past the end of buffer {buffer} ({} bytes)",
                                range.start,
                                range.end,
                                data.len()
                            ),
                        )
                    })?
                    .to_vec()
            }
        };
        Ok(cell.get_or_init(|| bytes))
    }

    /// Accessor `accessor` read as `role`: `count` elements of the role's width, each
    /// component dequantised (normalised integers by the spec's formulas, other integers as
    /// they are), sparse substitutions applied.
    pub(super) fn read(
        &self,
        accessor: &gltf::Accessor<'_>,
        role: Role,
    ) -> Result<Vec<f32>, RigReadError> {
        let fail = |what: String| RigReadError::Accessor {
            path: self.path.to_owned(),
            accessor: accessor.index(),
            role: role.name(),
            what,
        };
        let (data, normalized) = (accessor.data_type(), accessor.normalized());
        if accessor.dimensions() != role.dimensions() {
            return Err(fail(format!(
                "type {:?}, where {:?} is needed",
                accessor.dimensions(),
                role.dimensions()
            )));
        }
        if !role.allows(data, normalized) {
            return Err(fail(format!(
                "{}{data:?} components, which neither glTF nor KHR_mesh_quantization allows here",
                if normalized { "normalised " } else { "" }
            )));
        }
        let count = accessor.count();
        if count > MAX_ELEMENTS {
            return Err(fail(format!("{count} elements, more than {MAX_ELEMENTS}")));
        }
        let width = role.dimensions().multiplicity();
        let size = data.size();
        let element = width * size;
        let mut out = vec![0.0f32; count * width];
        if let Some(view) = accessor.view() {
            let bytes = self.view(&view)?;
            let stride = view.stride().unwrap_or(element);
            if stride < element {
                return Err(fail(format!(
                    "its view's stride {stride} is under its element's {element} bytes"
                )));
            }
            let need = match count {
                0 => Some(0),
                n => accessor.offset().checked_add((n - 1) * stride + element),
            };
            let Some(need) = need.filter(|&need| need <= bytes.len()) else {
                return Err(fail(format!(
                    "{count} elements of {element} bytes, {stride} apart from byte {}, lie past \
                     the end of buffer view {} ({} bytes)",
                    accessor.offset(),
                    view.index(),
                    bytes.len()
                )));
            };
            debug_assert!(need <= bytes.len());
            for (i, chunk) in out.chunks_exact_mut(width).enumerate() {
                let at = accessor.offset() + i * stride;
                for (k, v) in chunk.iter_mut().enumerate() {
                    *v = component(&bytes[at + k * size..], data, normalized);
                }
            }
        }
        if let Some(sparse) = accessor.sparse() {
            let n = sparse.count();
            let indices = sparse.indices();
            let index_type = match indices.index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let at = |view: gltf::buffer::View<'_>, offset: usize, each: usize, what: &str| {
                let bytes = self.view(&view)?;
                match offset.checked_add(n.saturating_mul(each)) {
                    Some(end) if end <= bytes.len() => Ok(&bytes[offset..end]),
                    _ => Err(fail(format!(
                        "{n} sparse {what} from byte {offset} lie past the end of buffer view {}",
                        view.index()
                    ))),
                }
            };
            let index_bytes = at(
                indices.view(),
                indices.offset(),
                index_type.size(),
                "indices",
            )?;
            let values = sparse.values();
            let value_bytes = at(values.view(), values.offset(), element, "values")?;
            for s in 0..n {
                let i =
                    component(&index_bytes[s * index_type.size()..], index_type, false) as usize;
                if i >= count {
                    return Err(fail(format!("sparse index {i} past its {count} elements")));
                }
                for k in 0..width {
                    out[i * width + k] =
                        component(&value_bytes[s * element + k * size..], data, normalized);
                }
            }
        }
        Ok(out)
    }

    /// Accessor `accessor` as vertex indices, read whole (an f32 holds integers exactly only
    /// up to 2^24).
    pub(super) fn indices(&self, accessor: &gltf::Accessor<'_>) -> Result<Vec<u32>, RigReadError> {
        let fail = |what: String| RigReadError::Accessor {
            path: self.path.to_owned(),
            accessor: accessor.index(),
            role: Role::Indices.name(),
            what,
        };
        let data = accessor.data_type();
        if accessor.dimensions() != Dimensions::Scalar
            || !Role::Indices.allows(data, accessor.normalized())
        {
            return Err(fail(format!(
                "{:?} of {data:?}, where indices are scalars of unsigned bytes, shorts or ints",
                accessor.dimensions()
            )));
        }
        if accessor.sparse().is_some() {
            return Err(fail("sparse indices, which Sinew does not read".into()));
        }
        let count = accessor.count();
        if count > MAX_ELEMENTS {
            return Err(fail(format!("{count} elements, more than {MAX_ELEMENTS}")));
        }
        let view = accessor
            .view()
            .ok_or_else(|| fail("no buffer view".into()))?;
        let bytes = self.view(&view)?;
        let size = data.size();
        let start = accessor.offset();
        let Some(need) = start
            .checked_add(count * size)
            .filter(|&need| need <= bytes.len())
        else {
            return Err(fail(format!(
                "{count} indices of {size} bytes from byte {start} lie past the end of buffer \
                 view {} ({} bytes)",
                view.index(),
                bytes.len()
            )));
        };
        Ok(bytes[start..need]
            .chunks_exact(size)
            .map(|c| match size {
                1 => u32::from(c[0]),
                2 => u32::from(u16::from_le_bytes([c[0], c[1]])),
                _ => u32::from_le_bytes([c[0], c[1], c[2], c[3]]),
            })
            .collect())
    }
}

/// One component at the start of `bytes` (which holds at least its size), as a number: a
/// normalised integer by `KHR_mesh_quantization`'s int-to-float table, another as it is.
fn component(bytes: &[u8], data: DataType, normalized: bool) -> f32 {
    let b = |k: usize| bytes[k];
    match (data, normalized) {
        (DataType::F32, _) => f32::from_le_bytes([b(0), b(1), b(2), b(3)]),
        (DataType::I8, false) => f32::from(i8::from_le_bytes([b(0)])),
        (DataType::I8, true) => (f32::from(i8::from_le_bytes([b(0)])) / 127.0).max(-1.0),
        (DataType::U8, false) => f32::from(b(0)),
        (DataType::U8, true) => f32::from(b(0)) / 255.0,
        (DataType::I16, false) => f32::from(i16::from_le_bytes([b(0), b(1)])),
        (DataType::I16, true) => (f32::from(i16::from_le_bytes([b(0), b(1)])) / 32767.0).max(-1.0),
        (DataType::U16, false) => f32::from(u16::from_le_bytes([b(0), b(1)])),
        (DataType::U16, true) => f32::from(u16::from_le_bytes([b(0), b(1)])) / 65535.0,
        // Only indices are U32, and they are read whole; as a number it is the nearest f32.
        (DataType::U32, _) => u32::from_le_bytes([b(0), b(1), b(2), b(3)]) as f32,
    }
}

/// The bytes of buffer `index` at `uri`: a `data:` URI's payload or a file beside `path`.
pub(super) fn read_uri(path: &Path, index: usize, uri: &str) -> Result<Vec<u8>, RigReadError> {
    let bad_uri = || RigReadError::BufferUri {
        path: path.to_owned(),
        buffer: index,
        uri: cut(uri),
    };
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest.split_once(";base64,").ok_or_else(bad_uri)?;
        use base64::Engine as _;
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|_| bad_uri());
    }
    let decoded = urlencoding::decode(uri).map_err(|_| bad_uri())?;
    let relative = Path::new(decoded.as_ref());
    if decoded.contains(':') || relative.is_absolute() {
        return Err(bad_uri());
    }
    let file: PathBuf = path.parent().unwrap_or(Path::new(".")).join(relative);
    std::fs::read(&file).map_err(|source| RigReadError::Read { path: file, source })
}

fn cut(s: &str) -> String {
    match s.char_indices().nth(80) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_owned(),
    }
}
