//! Polygon meshes: reading and writing OBJ (optionally gzip-compressed) and PLY, plus the few
//! geometric helpers every other module needs (fan triangulation, normals, bounds, sub-meshes).
//!
//! Vertex order is sacred here: blendshape data (ICT-FaceKit, FLAME, ...) is a list of meshes that
//! correspond vertex by vertex, so a reader must return positions in file order. That is why OBJ
//! is parsed by a small reader of our own rather than `tobj`: with `single_index: false` `tobj`
//! splits the file into models at every `o`/`g` and material change and renumbers each model's
//! positions in order of first use, dropping unreferenced ones, so file order is lost.

use std::collections::HashMap;
use std::io::{Read, Write};
use std::path::Path;

use ply_rs_bw::ply::{
    Addable, DefaultElement, ElementDef, Encoding, Ply, Property, PropertyDef, PropertyType,
    ScalarType,
};

mod error;
pub use error::{EncodeError, InvalidMesh, MeshError, ParseReason};

/// A syntax error and the 1-based OBJ line it is on.
type Syntax = (Option<usize>, ParseReason);

/// A polygon mesh as read from a file: polygons are kept as they are (quads stay quads).
///
/// Texture coordinates come in one of two layouts:
/// - per corner: `polygon_uvs` is parallel to `polygons` (same number of polygons, same number of
///   corners in each) and indexes `uvs` (the OBJ `f v/vt` layout);
/// - per vertex: `polygon_uvs` is empty and `uvs` has one entry per position.
///
/// A mesh without texture coordinates has both empty.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, in file order.
    pub positions: Vec<[f32; 3]>,
    /// Polygons as vertex indices (0-based), each with at least 3 corners.
    pub polygons: Vec<Vec<u32>>,
    /// Texture coordinates.
    pub uvs: Vec<[f32; 2]>,
    /// Per-corner indices into `uvs`, parallel to `polygons`, or empty.
    pub polygon_uvs: Vec<Vec<u32>>,
}

/// The file formats [`Mesh::read`] and [`Mesh::write`] know, chosen by file name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Obj,
    Ply,
}

/// The bytes of the mesh file at `path`, decompressed when it is gzip-compressed (by its `.gz`
/// name or, without one, by its magic).
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, MeshError> {
    let (_, gz) = format_of(path)?;
    let raw = std::fs::read(path).map_err(|source| MeshError::Read {
        path: path.to_owned(),
        source,
    })?;
    if !(gz || raw.starts_with(&[0x1f, 0x8b])) {
        return Ok(raw);
    }
    let mut out = Vec::with_capacity(raw.len() * 4);
    flate2::read::MultiGzDecoder::new(raw.as_slice())
        .read_to_end(&mut out)
        .map_err(|source| MeshError::Gzip {
            path: path.to_owned(),
            source,
        })?;
    Ok(out)
}

/// Picks the format from the file name (`.obj`, `.ply`, either with `.gz`), and whether the
/// file is gzip-compressed.
fn format_of(path: &Path) -> Result<(Format, bool), MeshError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let (stem, gz) = match name.strip_suffix(".gz") {
        Some(stem) => (stem, true),
        None => (name.as_str(), false),
    };
    if stem.ends_with(".obj") {
        Ok((Format::Obj, gz))
    } else if stem.ends_with(".ply") {
        Ok((Format::Ply, gz))
    } else {
        Err(MeshError::UnknownFormat {
            path: path.to_owned(),
        })
    }
}

impl Mesh {
    /// A mesh without texture coordinates.
    pub fn new(positions: Vec<[f32; 3]>, polygons: Vec<Vec<u32>>) -> Self {
        Self {
            positions,
            polygons,
            ..Self::default()
        }
    }

    /// Reads a mesh from `.obj`, `.obj.gz`, `.ply` (ASCII or binary) or `.ply.gz`.
    ///
    /// OBJ: `v`, `vt` and `f` statements are read (`f` corners as `v`, `v/vt`, `v//vn` or
    /// `v/vt/vn`, negative indices relative to the end as the format allows); groups, objects
    /// and materials are ignored and positions stay in file order, so all groups share one
    /// vertex list as they do in the file. If only some polygons carry texture coordinates the
    /// coordinates are dropped, as this type cannot hold a partial layout.
    ///
    /// PLY: element `vertex` with `x`, `y`, `z` (any numeric type) and optional per-vertex
    /// texture coordinates (`u`/`v`, `s`/`t`, `texture_u`/`texture_v` or
    /// `texture_s`/`texture_t`); element `face` with `vertex_indices` (or `vertex_index`) and an
    /// optional per-corner `texcoord` list (MeshLab's layout).
    ///
    /// Every error names the file; the result is validated (see [`Mesh::validate`]).
    pub fn read(path: &Path) -> Result<Mesh, MeshError> {
        let (format, _) = format_of(path)?;
        let bytes = read_bytes(path)?;
        let mesh = match format {
            Format::Obj => parse_obj(&bytes),
            Format::Ply => parse_ply(&bytes),
        }
        .map_err(|(line, reason)| MeshError::Parse {
            path: path.to_owned(),
            line,
            reason,
        })?;
        mesh.validate().map_err(|source| MeshError::Inconsistent {
            path: path.to_owned(),
            source,
        })?;
        Ok(mesh)
    }

    /// Writes the mesh atomically as OBJ (`.obj`) or binary little-endian PLY (`.ply`), chosen
    /// by extension; a trailing `.gz` compresses the output.
    ///
    /// OBJ keeps polygons and writes `vt` with `f v/vt` when the mesh has texture coordinates.
    /// PLY writes per-vertex coordinates as `s`/`t` and per-corner ones as a face `texcoord`
    /// list. Floats are written exactly (shortest round-trip text in OBJ, raw bits in PLY).
    /// OBJ has no per-vertex layout, so per-vertex UVs are written as `f v/v` and read back in
    /// the per-corner layout (same values at every corner).
    pub fn write(&self, path: &Path) -> Result<(), MeshError> {
        let (format, gz) = format_of(path)?;
        self.validate()
            .map_err(|source| MeshError::WriteInconsistent {
                path: path.to_owned(),
                source,
            })?;
        let mut bytes = Vec::new();
        match format {
            Format::Obj => self.write_obj(&mut bytes).map_err(EncodeError::from),
            Format::Ply => self.write_ply(&mut bytes),
        }
        .map_err(|source| MeshError::Encode {
            path: path.to_owned(),
            source,
        })?;
        if gz {
            let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
            enc.write_all(&bytes)
                .and_then(|()| enc.finish())
                .map(|b| bytes = b)
                .map_err(|source| MeshError::Compress {
                    path: path.to_owned(),
                    source,
                })?;
        }
        crate::io::atomic::write(path, &bytes).map_err(MeshError::Write)
    }

    /// Checks every index and layout rule stated on [`Mesh`]: polygons have at least 3 corners
    /// and index existing vertices; UVs follow one of the two layouts; positions are finite.
    pub fn validate(&self) -> Result<(), InvalidMesh> {
        let nv = self.positions.len();
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(InvalidMesh::NonFiniteVertex {
                vertex: i,
                position: self.positions[i],
            });
        }
        for (pi, poly) in self.polygons.iter().enumerate() {
            if poly.len() < 3 {
                return Err(InvalidMesh::TooFewCorners {
                    polygon: pi,
                    corners: poly.len(),
                });
            }
            if let Some(&v) = poly.iter().find(|&&v| v as usize >= nv) {
                return Err(InvalidMesh::VertexOutOfRange {
                    polygon: pi,
                    vertex: v,
                    vertices: nv,
                });
            }
        }
        if self.polygon_uvs.is_empty() {
            if !self.uvs.is_empty() && self.uvs.len() != nv {
                return Err(InvalidMesh::UvCount {
                    uvs: self.uvs.len(),
                    vertices: nv,
                });
            }
        } else {
            if self.polygon_uvs.len() != self.polygons.len() {
                return Err(InvalidMesh::UvPolygonCount {
                    polygons: self.polygons.len(),
                    uv_polygons: self.polygon_uvs.len(),
                });
            }
            let nt = self.uvs.len();
            for (pi, (poly, puv)) in self.polygons.iter().zip(&self.polygon_uvs).enumerate() {
                if poly.len() != puv.len() {
                    return Err(InvalidMesh::UvCornerCount {
                        polygon: pi,
                        corners: poly.len(),
                        uv_indices: puv.len(),
                    });
                }
                if let Some(&t) = puv.iter().find(|&&t| t as usize >= nt) {
                    return Err(InvalidMesh::UvOutOfRange {
                        polygon: pi,
                        uv: t,
                        uvs: nt,
                    });
                }
            }
        }
        if let Some(i) = self
            .uvs
            .iter()
            .position(|t| t.iter().any(|c| !c.is_finite()))
        {
            return Err(InvalidMesh::NonFiniteUv {
                index: i,
                uv: self.uvs[i],
            });
        }
        Ok(())
    }

    fn write_obj(&self, out: &mut Vec<u8>) -> std::io::Result<()> {
        writeln!(
            out,
            "# written by sinew: {} vertices, {} polygons",
            self.positions.len(),
            self.polygons.len()
        )?;
        for p in &self.positions {
            writeln!(out, "v {} {} {}", p[0], p[1], p[2])?;
        }
        for t in &self.uvs {
            writeln!(out, "vt {} {}", t[0], t[1])?;
        }
        let per_vertex_uv = !self.uvs.is_empty() && self.polygon_uvs.is_empty();
        for (pi, poly) in self.polygons.iter().enumerate() {
            out.push(b'f');
            for (k, &v) in poly.iter().enumerate() {
                if per_vertex_uv {
                    write!(out, " {}/{}", v + 1, v + 1)?;
                } else if let Some(puv) = self.polygon_uvs.get(pi) {
                    write!(out, " {}/{}", v + 1, puv[k] + 1)?;
                } else {
                    write!(out, " {}", v + 1)?;
                }
            }
            out.push(b'\n');
        }
        Ok(())
    }

    fn write_ply(&self, out: &mut Vec<u8>) -> Result<(), EncodeError> {
        let mut ply = Ply::<DefaultElement>::new();
        ply.header.encoding = Encoding::BinaryLittleEndian;
        ply.header.comments.push("written by sinew".to_owned());
        let per_vertex_uv = !self.uvs.is_empty() && self.polygon_uvs.is_empty();
        let per_corner_uv = !self.polygon_uvs.is_empty();

        let mut vdef = ElementDef::new("vertex".to_owned());
        let mut vnames = vec!["x", "y", "z"];
        if per_vertex_uv {
            vnames.extend(["s", "t"]);
        }
        for name in &vnames {
            vdef.properties.add(PropertyDef::new(
                (*name).to_owned(),
                PropertyType::Scalar(ScalarType::Float),
            ));
        }
        ply.header.elements.add(vdef);
        let mut fdef = ElementDef::new("face".to_owned());
        fdef.properties.add(PropertyDef::new(
            "vertex_indices".to_owned(),
            PropertyType::List(ScalarType::UChar, ScalarType::Int),
        ));
        if per_corner_uv {
            fdef.properties.add(PropertyDef::new(
                "texcoord".to_owned(),
                PropertyType::List(ScalarType::UChar, ScalarType::Float),
            ));
        }
        ply.header.elements.add(fdef);

        let mut verts = Vec::with_capacity(self.positions.len());
        for (i, p) in self.positions.iter().enumerate() {
            let mut e = DefaultElement::new();
            e.insert("x".to_owned(), Property::Float(p[0]));
            e.insert("y".to_owned(), Property::Float(p[1]));
            e.insert("z".to_owned(), Property::Float(p[2]));
            if per_vertex_uv {
                e.insert("s".to_owned(), Property::Float(self.uvs[i][0]));
                e.insert("t".to_owned(), Property::Float(self.uvs[i][1]));
            }
            verts.push(e);
        }
        ply.payload.insert("vertex".to_owned(), verts);
        let mut faces = Vec::with_capacity(self.polygons.len());
        for (pi, poly) in self.polygons.iter().enumerate() {
            // The list length is a uchar, so a PLY polygon has at most 255 corners.
            if poly.len() > 255 {
                return Err(EncodeError::TooManyCorners {
                    polygon: pi,
                    corners: poly.len(),
                });
            }
            let idx = poly
                .iter()
                .map(|&v| i32::try_from(v))
                .collect::<Result<Vec<i32>, _>>()
                .map_err(|_| EncodeError::IndexBeyondInt { polygon: pi })?;
            let mut e = DefaultElement::new();
            e.insert("vertex_indices".to_owned(), Property::ListInt(idx));
            if per_corner_uv {
                let tc = self.polygon_uvs[pi]
                    .iter()
                    .flat_map(|&t| self.uvs[t as usize])
                    .collect();
                e.insert("texcoord".to_owned(), Property::ListFloat(tc));
            }
            faces.push(e);
        }
        ply.payload.insert("face".to_owned(), faces);
        ply_rs_bw::writer::Writer::new()
            .write_ply(out, &mut ply)
            .map_err(EncodeError::Ply)?;
        Ok(())
    }

    /// Fan-triangulates every polygon (`[v0, vi, vi+1]`), keeping its orientation.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let n: usize = self
            .polygons
            .iter()
            .map(|p| p.len().saturating_sub(2))
            .sum();
        let mut tris = Vec::with_capacity(n);
        for poly in &self.polygons {
            for k in 1..poly.len().saturating_sub(1) {
                tris.push([poly[0], poly[k], poly[k + 1]]);
            }
        }
        tris
    }

    /// A baked actor's template as a triangle mesh (its `tpl.pos` and `tpl.tri`).
    pub fn of_actor(actor: &sinew_core::aim::AimActor<'_>) -> Mesh {
        let t: Vec<u32> = actor.triangles().indices().iter().collect();
        let positions = points(actor.template().iter());
        let polygons = t.chunks_exact(3).map(<[u32]>::to_vec).collect();
        Mesh::new(positions, polygons)
    }

    /// The same topology and texture coordinates with new positions.
    ///
    /// # Panics
    /// If `positions` does not have one entry per vertex: that is a programming error, never
    /// a property of input data.
    pub fn with_positions(&self, positions: Vec<[f32; 3]>) -> Mesh {
        assert_eq!(
            positions.len(),
            self.positions.len(),
            "with_positions: vertex count must not change"
        );
        Mesh {
            positions,
            polygons: self.polygons.clone(),
            uvs: self.uvs.clone(),
            polygon_uvs: self.polygon_uvs.clone(),
        }
    }

    /// Checks that `other` (read from `other_path`) has this mesh's vertex count and the same
    /// polygons, so that the two correspond vertex by vertex. Texture coordinates are not
    /// compared.
    pub fn check_same_topology(&self, other: &Mesh, other_path: &Path) -> Result<(), MeshError> {
        if self.positions.len() != other.positions.len()
            || self.polygons.len() != other.polygons.len()
        {
            return Err(MeshError::TopologyCounts {
                path: other_path.to_owned(),
                expected_vertices: self.positions.len(),
                expected_polygons: self.polygons.len(),
                vertices: other.positions.len(),
                polygons: other.polygons.len(),
            });
        }
        if let Some(pi) = (0..self.polygons.len()).find(|&i| self.polygons[i] != other.polygons[i])
        {
            return Err(MeshError::TopologyPolygon {
                path: other_path.to_owned(),
                vertices: self.positions.len(),
                polygons: self.polygons.len(),
                polygon: pi,
                found: other.polygons[pi].clone(),
                expected: self.polygons[pi].clone(),
            });
        }
        Ok(())
    }

    /// The part of the mesh made of the polygons whose vertices all pass `keep`.
    ///
    /// The new mesh holds the vertices that pass `keep` and belong to a kept polygon (for a mesh
    /// without polygons, a point cloud, every vertex that passes `keep`), in their original
    /// order; the second value gives the old index of each new vertex. Texture coordinates are
    /// carried over and compacted the same way.
    pub fn submesh(&self, keep: impl Fn(u32) -> bool) -> (Mesh, Vec<u32>) {
        let nv = self.positions.len();
        let mut used = vec![false; nv];
        let mut kept = Vec::new();
        if self.polygons.is_empty() {
            for (v, u) in used.iter_mut().enumerate() {
                *u = keep(v as u32);
            }
        } else {
            for (pi, poly) in self.polygons.iter().enumerate() {
                if poly.iter().all(|&v| keep(v)) {
                    kept.push(pi);
                    for &v in poly {
                        used[v as usize] = true;
                    }
                }
            }
        }
        let mut new_index = vec![u32::MAX; nv];
        let mut old_index = Vec::new();
        for v in 0..nv {
            if used[v] {
                new_index[v] = old_index.len() as u32;
                old_index.push(v as u32);
            }
        }
        let positions = old_index
            .iter()
            .map(|&v| self.positions[v as usize])
            .collect();
        let polygons = kept
            .iter()
            .map(|&pi| {
                self.polygons[pi]
                    .iter()
                    .map(|&v| new_index[v as usize])
                    .collect()
            })
            .collect();
        let (uvs, polygon_uvs) = if !self.polygon_uvs.is_empty() {
            let mut uv_used = vec![false; self.uvs.len()];
            for &pi in &kept {
                for &t in &self.polygon_uvs[pi] {
                    uv_used[t as usize] = true;
                }
            }
            let mut uv_new = vec![u32::MAX; self.uvs.len()];
            let mut uvs = Vec::new();
            for (t, &u) in uv_used.iter().enumerate() {
                if u {
                    uv_new[t] = uvs.len() as u32;
                    uvs.push(self.uvs[t]);
                }
            }
            let puv = kept
                .iter()
                .map(|&pi| {
                    self.polygon_uvs[pi]
                        .iter()
                        .map(|&t| uv_new[t as usize])
                        .collect()
                })
                .collect();
            (uvs, puv)
        } else if !self.uvs.is_empty() {
            let uvs = old_index.iter().map(|&v| self.uvs[v as usize]).collect();
            (uvs, Vec::new())
        } else {
            (Vec::new(), Vec::new())
        };
        let mesh = Mesh {
            positions,
            polygons,
            uvs,
            polygon_uvs,
        };
        (mesh, old_index)
    }

    /// Area-weighted vertex normals, unit length (zero for a vertex in no polygon or only in
    /// degenerate ones). For a consistently oriented mesh with counter-clockwise polygons seen
    /// from outside, they point outwards.
    pub fn vertex_normals(&self) -> Vec<[f32; 3]> {
        let mut acc = vec![[0.0f64; 3]; self.positions.len()];
        for poly in &self.polygons {
            // Newell's method: the sum of edge cross products is twice the area times the unit
            // normal for a planar polygon and a robust average for a non-planar quad. Taking
            // positions relative to the first corner avoids cancellation far from the origin.
            let p0 = self.positions[poly[0] as usize].map(f64::from);
            let rel = |v: u32| {
                let p = self.positions[v as usize];
                [
                    f64::from(p[0]) - p0[0],
                    f64::from(p[1]) - p0[1],
                    f64::from(p[2]) - p0[2],
                ]
            };
            let mut n = [0.0f64; 3];
            for k in 0..poly.len() {
                let a = rel(poly[k]);
                let b = rel(poly[(k + 1) % poly.len()]);
                n[0] += a[1] * b[2] - a[2] * b[1];
                n[1] += a[2] * b[0] - a[0] * b[2];
                n[2] += a[0] * b[1] - a[1] * b[0];
            }
            for &v in poly {
                let s = &mut acc[v as usize];
                s[0] += n[0];
                s[1] += n[1];
                s[2] += n[2];
            }
        }
        acc.iter()
            .map(|n| {
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if len > 0.0 {
                    [
                        (n[0] / len) as f32,
                        (n[1] / len) as f32,
                        (n[2] / len) as f32,
                    ]
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    }

    /// The axis-aligned bounding box `(min, max)`; both zero for a mesh without vertices.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let Some(first) = self.positions.first() else {
            return ([0.0; 3], [0.0; 3]);
        };
        let (mut lo, mut hi) = (*first, *first);
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }
}

/// Resolves one OBJ index (1-based, or negative counting back from the last element defined so
/// far) to a 0-based index. Range is checked later by [`Mesh::validate`], since the format
/// technically allows no forward references but tolerating them costs nothing.
fn obj_index(token: &str, defined: usize, what: &'static str) -> Result<u32, ParseReason> {
    let i: i64 = token.parse().map_err(|_| ParseReason::BadIndex {
        what,
        token: token.to_owned(),
    })?;
    let resolved = if i > 0 {
        i - 1
    } else if i < 0 {
        defined as i64 + i
    } else {
        return Err(ParseReason::ZeroIndex { what });
    };
    u32::try_from(resolved).map_err(|_| ParseReason::IndexOutOfRange {
        what,
        token: token.to_owned(),
    })
}

/// Parses `count` floats from `it`; `min` of them are required, the rest default to zero.
fn obj_floats<const N: usize>(
    it: &mut std::str::SplitAsciiWhitespace<'_>,
    min: usize,
) -> Result<[f32; N], ParseReason> {
    let mut out = [0.0f32; N];
    for (k, slot) in out.iter_mut().enumerate() {
        match it.next() {
            Some(t) => {
                *slot = t.parse().map_err(|_| ParseReason::BadNumber {
                    token: t.to_owned(),
                })?;
            }
            None if k >= min => break,
            None => {
                return Err(ParseReason::MissingNumbers {
                    expected: min,
                    found: k,
                });
            }
        }
    }
    Ok(out)
}

fn parse_obj(bytes: &[u8]) -> Result<Mesh, Syntax> {
    // Comments may hold any bytes; numbers and keywords are ASCII, so a lossy view is exact
    // where it matters and only copies when the file has invalid UTF-8.
    let text = String::from_utf8_lossy(bytes);
    let mut mesh = Mesh::default();
    let (mut with_uv, mut without_uv) = (0usize, 0usize);
    for (n, line) in text.lines().enumerate() {
        let line = match line.find('#') {
            Some(c) => &line[..c],
            None => line,
        };
        let mut it = line.split_ascii_whitespace();
        let parsed: Result<(), ParseReason> = match it.next() {
            Some("v") => obj_floats::<3>(&mut it, 3).map(|p| mesh.positions.push(p)),
            Some("vt") => obj_floats::<2>(&mut it, 1).map(|t| mesh.uvs.push(t)),
            Some("f") => (|| {
                let mut poly = Vec::with_capacity(4);
                let mut puv = Vec::with_capacity(4);
                for corner in it {
                    let mut parts = corner.split('/');
                    let v = parts.next().unwrap_or_default();
                    poly.push(obj_index(v, mesh.positions.len(), "vertex")?);
                    match parts.next() {
                        Some(t) if !t.is_empty() => {
                            puv.push(obj_index(t, mesh.uvs.len(), "texture")?)
                        }
                        _ => {}
                    }
                }
                if poly.len() < 3 {
                    return Err(ParseReason::FaceTooSmall {
                        corners: poly.len(),
                    });
                }
                if puv.is_empty() {
                    without_uv += 1;
                } else if puv.len() == poly.len() {
                    with_uv += 1;
                } else {
                    return Err(ParseReason::PartialFaceTexture);
                }
                mesh.polygons.push(poly);
                mesh.polygon_uvs.push(puv);
                Ok(())
            })(),
            _ => Ok(()),
        };
        parsed.map_err(|reason| (Some(n + 1), reason))?;
    }
    if with_uv == 0 || without_uv > 0 {
        // No polygon, or not every polygon, has texture indices: the per-corner layout cannot
        // hold that, so texture coordinates are dropped (documented on `Mesh::read`).
        mesh.polygon_uvs.clear();
        mesh.uvs.clear();
    }
    Ok(mesh)
}

fn parse_ply(bytes: &[u8]) -> Result<Mesh, Syntax> {
    parse_ply_body(bytes).map_err(|reason| (None, reason))
}

fn parse_ply_body(bytes: &[u8]) -> Result<Mesh, ParseReason> {
    let parser = ply_rs_bw::parser::Parser::<DefaultElement>::new();
    let mut src = bytes;
    let ply = parser.read_ply(&mut src).map_err(ParseReason::Ply)?;
    let mut mesh = Mesh::default();
    let empty = Vec::new();
    let verts = ply.payload.get("vertex").unwrap_or(&empty);
    const UV_NAMES: [(&str, &str); 4] = [
        ("u", "v"),
        ("s", "t"),
        ("texture_u", "texture_v"),
        ("texture_s", "texture_t"),
    ];
    let uv_names = ply.header.elements.get("vertex").and_then(|def| {
        UV_NAMES
            .into_iter()
            .find(|(a, b)| def.properties.contains_key(*a) && def.properties.contains_key(*b))
    });
    let scalar = |e: &DefaultElement, i: usize, name: &'static str| -> Result<f32, ParseReason> {
        e.get(name)
            .and_then(Property::to_f32_lossy)
            .ok_or(ParseReason::VertexProperty { vertex: i, name })
    };
    for (i, e) in verts.iter().enumerate() {
        mesh.positions
            .push([scalar(e, i, "x")?, scalar(e, i, "y")?, scalar(e, i, "z")?]);
        if let Some((a, b)) = uv_names {
            mesh.uvs.push([scalar(e, i, a)?, scalar(e, i, b)?]);
        }
    }
    let faces = ply.payload.get("face").unwrap_or(&empty);
    // Per-corner coordinates are deduplicated by bit pattern, so shared seams come back shared.
    let mut corner_uvs: Vec<[f32; 2]> = Vec::new();
    let mut uv_ids: HashMap<[u32; 2], u32> = HashMap::new();
    let mut polygon_uvs = Vec::new();
    for (fi, e) in faces.iter().enumerate() {
        let idx = e
            .get("vertex_indices")
            .or_else(|| e.get("vertex_index"))
            .ok_or(ParseReason::NoVertexIndices { face: fi })?;
        let poly = idx
            .to_u32_list()
            .ok_or(ParseReason::BadVertexIndices { face: fi })?;
        let tc: Option<Vec<f32>> = match e.get("texcoord") {
            Some(Property::ListFloat(v)) => Some(v.clone()),
            Some(Property::ListDouble(v)) => Some(v.iter().map(|&x| x as f32).collect()),
            Some(_) => return Err(ParseReason::TexcoordNotFloat { face: fi }),
            None => None,
        };
        if let Some(tc) = tc {
            if tc.len() != 2 * poly.len() {
                return Err(ParseReason::TexcoordCount {
                    face: fi,
                    values: tc.len(),
                    corners: poly.len(),
                });
            }
            let ids = tc
                .chunks_exact(2)
                .map(|c| {
                    let key = [c[0].to_bits(), c[1].to_bits()];
                    *uv_ids.entry(key).or_insert_with(|| {
                        corner_uvs.push([c[0], c[1]]);
                        (corner_uvs.len() - 1) as u32
                    })
                })
                .collect();
            polygon_uvs.push(ids);
        }
        mesh.polygons.push(poly);
    }
    if !polygon_uvs.is_empty() {
        if polygon_uvs.len() != mesh.polygons.len() {
            return Err(ParseReason::PartialTexcoord);
        }
        // Per-corner coordinates win over per-vertex ones: they can express seams.
        mesh.uvs = corner_uvs;
        mesh.polygon_uvs = polygon_uvs;
    }
    Ok(mesh)
}

/// Groups flat `x, y, z, x, y, z, …` values into points (a trailing partial point is dropped).
pub fn points(values: impl IntoIterator<Item = f32>) -> Vec<[f32; 3]> {
    let flat: Vec<f32> = values.into_iter().collect();
    flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

#[cfg(test)]
pub(crate) mod tests;
